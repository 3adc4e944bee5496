//! Reading a `.gltf` / `.glb` file into a [`Rig`].

use super::accessor::Source;
use super::{Rig, RigError};
use nalgebra::Matrix4;
use std::path::Path;

mod animations;
mod bodies;
mod buffers;
mod extensions;
mod morphs;
mod nodes;
mod skins;

use animations::read_animations;
pub(super) use bodies::area_weighted_normals;
use bodies::read_bodies;
pub use bodies::MAX_FILE_VERTICES;
use buffers::resolve_buffers;
pub(crate) use buffers::{confined_path, Confinement};
pub use morphs::{MAX_MORPH_DISPLACEMENTS, MAX_MORPH_READS};
use nodes::read_nodes;
use skins::read_skins;

/// Largest file we agree to read (1 GiB): a guard against absurd inputs, not a format limit.
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// Reads a rig from a `.gltf` or `.glb` file. Buffers may be embedded (GLB binary chunk or
/// `data:` URI) or sibling files; a buffer URI must stay inside the file's own folder.
pub fn load(path: &Path) -> Result<Rig, RigError> {
    let io = |source| RigError::Io {
        file: path.to_path_buf(),
        source,
    };
    let bytes = read_whole(path, MAX_FILE_BYTES).map_err(|e| match e {
        Unreadable::Io(source) => io(source),
        Unreadable::Refused(message) => RigError::Format {
            file: path.to_path_buf(),
            message,
        },
    })?;
    let folder = path.parent().map(Path::to_path_buf).unwrap_or_default();
    load_impl(path, &bytes, Some(&folder))
}

/// Why [`read_whole`] read nothing.
#[derive(Debug)]
pub(crate) enum Unreadable {
    /// The file system's error.
    Io(std::io::Error),
    /// Not a regular file, or too large.
    Refused(String),
}

impl std::fmt::Display for Unreadable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Unreadable::Io(e) => e.fmt(f),
            Unreadable::Refused(why) => f.write_str(why),
        }
    }
}

/// The bytes of a file we read whole (a rig, its buffers, a configuration, a bulge map): a
/// regular file of at most `limit` bytes, read no further than that even if it grows. A FIFO
/// would block (opening one waits for a writer, so it is refused from its `stat`) and a
/// device such as `/dev/zero` reports no size and never ends (found by fuzzing and by
/// probing the CLI).
pub(crate) fn read_whole(path: &Path, limit: u64) -> Result<Vec<u8>, Unreadable> {
    use std::io::Read;
    let refuse = |meta: &std::fs::Metadata| {
        if !meta.is_file() {
            Err(Unreadable::Refused("not a regular file".into()))
        } else if meta.len() > limit {
            Err(too_big(meta.len(), limit))
        } else {
            Ok(())
        }
    };
    refuse(&std::fs::metadata(path).map_err(Unreadable::Io)?)?;
    let file = std::fs::File::open(path).map_err(Unreadable::Io)?;
    refuse(&file.metadata().map_err(Unreadable::Io)?)?;
    let mut bytes = Vec::new();
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(Unreadable::Io)?;
    match bytes.len() as u64 > limit {
        true => Err(too_big(bytes.len() as u64, limit)),
        false => Ok(bytes),
    }
}

fn too_big(size: u64, limit: u64) -> Unreadable {
    Unreadable::Refused(format!(
        "file is {size} bytes, above the {limit} byte limit"
    ))
}

/// Reads a rig from bytes already in memory. `label` names it in errors; external buffer
/// files are refused (there is no folder to resolve them in).
pub fn load_from_bytes(label: &Path, bytes: &[u8]) -> Result<Rig, RigError> {
    load_impl(label, bytes, None)
}

fn load_impl(file: &Path, bytes: &[u8], folder: Option<&Path>) -> Result<Rig, RigError> {
    // glTF JSON must be UTF-8 without a byte order mark; the parser's own message for one
    // ("expected value at line 1 column 1") did not say what was wrong.
    if bytes.starts_with(b"\xEF\xBB\xBF") {
        return Err(RigError::Format {
            file: file.to_path_buf(),
            message: "the file starts with a UTF-8 byte order mark, which glTF JSON must not have"
                .into(),
        });
    }
    let gltf = gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| RigError::Format {
        file: file.to_path_buf(),
        message: e.to_string(),
    })?;
    let version = &gltf.document.as_json().asset.version;
    if version.split('.').next() != Some("2") {
        return Err(invalid(
            file,
            "asset.version",
            format!("glTF {version} is not supported (2.x only)"),
        ));
    }
    validate_json(file, gltf.document.as_json())?;
    check_enums(file, gltf.document.as_json())?;
    let resolved = resolve_buffers(file, &gltf, folder)?;
    let buffers: Vec<&[u8]> = resolved.iter().map(|b| b.bytes()).collect();
    let src = Source::new(file, &buffers);
    let doc = &gltf.document;
    let mut warnings = Vec::new();
    if let Some(w) = glb_length_warning(bytes) {
        warnings.push(w);
    }
    warnings.extend(glb_chunk_warning(bytes));
    let (nodes, node_order) = read_nodes(file, doc, &mut warnings)?;
    let mut skins = read_skins(&src, doc, &mut warnings)?;
    let (bodies, extra_attributes) = read_bodies(&src, doc, &mut skins, &mut warnings)?;
    let animations = read_animations(&src, doc, &mut warnings)?;
    let mut rig = Rig {
        source: file.to_path_buf(),
        nodes,
        node_order,
        skins,
        bodies,
        animations,
        extra_attributes,
        warnings,
    };
    let rest = check_rest_pose(file, &rig)?;
    super::orientation::face_outward(&mut rig, &rest);
    super::orientation::wind_outward(&mut rig, &rest);
    Ok(rig)
}

/// Every node's world transform and every skinning matrix at rest is finite: each value is
/// checked as read, but scales of 1e30 down a chain of twelve nodes, or inverse bind matrices
/// near `f64::MAX`, overflow once composed (found by fuzzing: the rest pose came out NaN).
/// The rest pose, checked.
fn check_rest_pose(file: &Path, rig: &Rig) -> Result<super::Pose, RigError> {
    let pose = rig.pose_at(None, 0.0);
    let finite = |m: &Matrix4<f64>| m.iter().all(|x| x.is_finite());
    if let Some(n) = pose.world.iter().position(|m| !finite(m)) {
        return Err(invalid(
            file,
            format!("nodes[{n}]"),
            "its world transform at rest overflows (the transforms above it compose to infinity)",
        ));
    }
    for (s, skin) in rig.skins.iter().enumerate() {
        if let Some(j) = pose.skin_matrices(skin).iter().position(|m| !finite(m)) {
            return Err(invalid(
                file,
                format!("skins[{s}].joints[{j}]"),
                "its skinning matrix at rest (world × inverse bind) overflows",
            ));
        }
    }
    Ok(pose)
}

/// A GLB whose header declares fewer bytes than the file holds (the spec's length is the
/// whole file's; found by fuzzing): the chunks are read as they are, with a warning (a longer
/// declaration is a format error of the container).
fn glb_length_warning(bytes: &[u8]) -> Option<String> {
    let declared = le_word(bytes, 8).filter(|_| bytes.starts_with(b"glTF"))?;
    (declared < bytes.len()).then(|| {
        format!(
            "GLB header declares {declared} bytes but the file holds {}: read by its chunks",
            bytes.len()
        )
    })
}

/// A GLB chunk that declares more bytes than the file holds after it. The JSON and BIN chunks
/// are checked as they are read; a chunk after them (of a type the spec says to ignore) was
/// ignored without a word even when it claimed 4 GB (found by fuzzing): a truncated or
/// corrupt file. Read as before, with a warning naming the chunk.
fn glb_chunk_warning(bytes: &[u8]) -> Option<String> {
    if !bytes.starts_with(b"glTF") {
        return None;
    }
    let mut at = 12;
    while at + 8 <= bytes.len() {
        let length = le_word(bytes, at)?;
        let end = at.checked_add(8)?.checked_add(length)?;
        if end > bytes.len() {
            let kind = String::from_utf8_lossy(&bytes[at + 4..at + 8]).into_owned();
            return Some(format!(
                "GLB chunk at byte {at} (type {kind:?}) declares {length} bytes, {} beyond the \
                 file's end: ignored",
                end - bytes.len()
            ));
        }
        at = end;
    }
    None
}

/// The little-endian `u32` at byte `at` of a GLB, if the file holds it.
fn le_word(bytes: &[u8], at: usize) -> Option<usize> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes(b.try_into().ok()?) as usize)
}

fn invalid(file: &Path, element: impl Into<String>, message: impl Into<String>) -> RigError {
    RigError::Invalid {
        file: file.to_path_buf(),
        element: element.into(),
        message: message.into(),
    }
}

/// Runs `gltf-json`'s validation (indices in range, required fields), after guarding the one
/// hook of `gltf-json` 1.4 that indexes without a bounds check (the POSITION accessor) and
/// checking the required extensions ([`extensions`]).
fn validate_json(file: &Path, root: &gltf::json::Root) -> Result<(), RigError> {
    use gltf::json::validation::Validate;
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position =
                gltf::json::validation::Checked::Valid(gltf::json::mesh::Semantic::Positions);
            if prim
                .attributes
                .get(&position)
                .is_some_and(|a| a.value() >= root.accessors.len())
            {
                return Err(invalid(
                    file,
                    format!("meshes[{m}].primitives[{p}].attributes.POSITION"),
                    "accessor index out of range",
                ));
            }
        }
    }
    extensions::check_required(file, root)?;
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |path, error| {
        let path = path().to_string();
        // `gltf-json` refuses every required extension it was not built with; those left here
        // are ones posing honours (`extensions::accepted`).
        if !path.starts_with("extensionsRequired") {
            errors.push(format!("{path}: {error}"))
        }
    });
    match errors.first() {
        None => Ok(()),
        Some(first) => Err(RigError::Format {
            file: file.to_path_buf(),
            message: format!(
                "invalid glTF: {first}{}",
                if errors.len() > 1 {
                    format!(" (and {} more)", errors.len() - 1)
                } else {
                    String::new()
                }
            ),
        }),
    }
}

/// Checks what the `gltf` crate's validation leaves out but its accessors `unwrap()`: enum
/// values (component types, modes, paths, interpolations, semantics) and animation targets
/// (not validated at all by `gltf-json` 1.4).
fn check_enums(file: &Path, root: &gltf::json::Root) -> Result<(), RigError> {
    use gltf::json::validation::Checked;
    let bad = |element: String| Err(invalid(file, element, "invalid or unknown enum value"));
    for (i, a) in root.accessors.iter().enumerate() {
        if matches!(a.component_type, Checked::Invalid) || matches!(a.type_, Checked::Invalid) {
            return bad(format!("accessors[{i}]"));
        }
        if let Some(s) = &a.sparse {
            if matches!(s.indices.component_type, Checked::Invalid) {
                return bad(format!("accessors[{i}].sparse.indices"));
            }
        }
    }
    for (i, v) in root.buffer_views.iter().enumerate() {
        if matches!(v.target, Some(Checked::Invalid)) {
            return bad(format!("bufferViews[{i}].target"));
        }
    }
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let invalid_key = prim
                .attributes
                .keys()
                .any(|k| matches!(k, Checked::Invalid));
            if matches!(prim.mode, Checked::Invalid) || invalid_key {
                return bad(format!("meshes[{m}].primitives[{p}]"));
            }
        }
    }
    for (a, anim) in root.animations.iter().enumerate() {
        for (s, sampler) in anim.samplers.iter().enumerate() {
            let n = root.accessors.len();
            if matches!(sampler.interpolation, Checked::Invalid) {
                return bad(format!("animations[{a}].samplers[{s}].interpolation"));
            }
            if sampler.input.value() >= n || sampler.output.value() >= n {
                return Err(invalid(
                    file,
                    format!("animations[{a}].samplers[{s}]"),
                    "accessor index out of range",
                ));
            }
        }
        for (c, ch) in anim.channels.iter().enumerate() {
            let at = format!("animations[{a}].channels[{c}]");
            if matches!(ch.target.path, Checked::Invalid) {
                return bad(format!("{at}.target.path"));
            }
            if ch.target.node.value() >= root.nodes.len()
                || ch.sampler.value() >= anim.samplers.len()
            {
                return Err(invalid(
                    file,
                    at,
                    "target node or sampler index out of range",
                ));
            }
        }
    }
    Ok(())
}
