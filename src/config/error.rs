//! [`ConfigError`]: why a configuration could not be read or applied, naming the file and the
//! field at fault.

use crate::selfcontact::SelfContactError;
use std::path::PathBuf;

/// Why a configuration could not be read or applied. Every variant names the configuration
/// file and the field at fault.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read (missing, unreadable, too large).
    #[error("{file}: cannot read: {source}")]
    Io {
        /// The configuration file.
        file: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// Not valid TOML, an unknown field, or a value of the wrong type.
    #[error("{file}: {field}: {message} (line {line}, column {column})")]
    Parse {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault, as far as it can be located (`object[1].stiffness`).
        field: String,
        /// Line (1-based).
        line: usize,
        /// Column (1-based).
        column: usize,
        /// What the parser said.
        message: String,
    },
    /// A value out of its range, or two options that exclude each other.
    #[error("{file}: {field}: {message}")]
    Invalid {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A name or index that is no body of the rig.
    #[error("{file}: {field}: no body '{name}' in the rig (bodies: {available})")]
    UnknownBody {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault.
        field: String,
        /// The name or index given.
        name: String,
        /// The bodies of the rig (`0 'ball', 1 'thumb'`).
        available: String,
    },
    /// An object or a pair configured twice.
    #[error("{file}: {field}: {what} is already configured by {first}")]
    Duplicate {
        /// The configuration file.
        file: PathBuf,
        /// The second occurrence.
        field: String,
        /// What is repeated (`body 'ball'`, `pair 'ball' / 'thumb'`).
        what: String,
        /// The first occurrence.
        first: String,
    },
    /// A bulge-map file that is refused (path leaving the folder), unreadable or malformed,
    /// or a value that is not finite.
    #[error("{file}: {field}: bulge map '{map}': {message}")]
    BulgeMap {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault.
        field: String,
        /// The map as written in the configuration.
        map: String,
        /// What is wrong.
        message: String,
    },
    /// A bulge map whose value count differs from the body's file vertex count.
    #[error(
        "{file}: {field}: bulge map '{map}' has {got} values, body '{body}' has {expected} file vertices"
    )]
    BulgeCount {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault.
        field: String,
        /// The map as written in the configuration.
        map: String,
        /// The body.
        body: String,
        /// File vertices of the body.
        expected: usize,
        /// Values found.
        got: usize,
    },
    /// A `[[self_contact.pair]]` naming no joint pair derived from the rig.
    #[error("{file}: {field}: no joint pair '{name}' in the rig (derived pairs: {available})")]
    UnknownPair {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault.
        field: String,
        /// The name given.
        name: String,
        /// The pairs derived from the rig's skin weights (`lips/head-jaw`), or `none`.
        available: String,
    },
    /// The joint pairs could not be derived from the rig (needed to check the pair names of
    /// `[self_contact]` and to resolve its `extent_factor`).
    #[error("{file}: {field}: cannot derive the joint pairs of the rig: {source}")]
    SelfContact {
        /// The configuration file.
        file: PathBuf,
        /// The field that needed the pairs.
        field: String,
        /// The underlying error.
        #[source]
        source: Box<SelfContactError>,
    },
    /// `attribute:NAME` naming no custom attribute of the body.
    #[error(
        "{file}: {field}: body '{body}' has no custom vertex attribute '{attribute}' (available: {available})"
    )]
    UnknownAttribute {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault.
        field: String,
        /// The body.
        body: String,
        /// The attribute asked for.
        attribute: String,
        /// The attributes the body has.
        available: String,
    },
}

impl ConfigError {
    /// The field at fault (empty for [`ConfigError::Io`]).
    pub fn field(&self) -> &str {
        match self {
            ConfigError::Io { .. } => "",
            ConfigError::Parse { field, .. }
            | ConfigError::Invalid { field, .. }
            | ConfigError::UnknownBody { field, .. }
            | ConfigError::Duplicate { field, .. }
            | ConfigError::BulgeMap { field, .. }
            | ConfigError::BulgeCount { field, .. }
            | ConfigError::UnknownPair { field, .. }
            | ConfigError::SelfContact { field, .. }
            | ConfigError::UnknownAttribute { field, .. } => field,
        }
    }
}
