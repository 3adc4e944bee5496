use std::path::PathBuf;

/// Why a rig could not be read. Every variant names the file and, where it applies, the glTF
/// element (`accessors[3]`, `meshes[0].primitives[1]`, ...) at fault.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    /// The file could not be opened or read.
    #[error("{file}: cannot read: {source}")]
    Io {
        /// The file.
        file: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The container or JSON is not valid glTF 2.0 (as judged by the `gltf` crate).
    #[error("{file}: not a valid glTF 2.0 file: {message}")]
    Format {
        /// The file.
        file: PathBuf,
        /// What the parser said.
        message: String,
    },
    /// A buffer could not be resolved (bad data URI, missing file, URI leaving the folder, ...).
    #[error("{file}: buffers[{buffer}]: {message}")]
    Buffer {
        /// The file.
        file: PathBuf,
        /// Buffer index.
        buffer: usize,
        /// What is wrong.
        message: String,
    },
    /// An accessor is out of bounds, of the wrong type, or otherwise unreadable.
    #[error("{file}: accessors[{accessor}] ({role}): {message}")]
    Accessor {
        /// The file.
        file: PathBuf,
        /// Accessor index.
        accessor: usize,
        /// What the accessor is used for (`POSITION of meshes[0].primitives[1]`, ...).
        role: String,
        /// What is wrong.
        message: String,
    },
    /// Any other inconsistency, located by a JSON-pointer-like path.
    #[error("{file}: {element}: {message}")]
    Invalid {
        /// The file.
        file: PathBuf,
        /// The element at fault (`skins[0].joints[4]`, `nodes[7]`, ...).
        element: String,
        /// What is wrong.
        message: String,
    },
}
