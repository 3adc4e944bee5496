//! Reading a `.gltf` / `.glb` file into a [`Rig`].

use super::accessor::{self, Source};
use super::animation::{Animation, Channel, Interpolation, Property};
use super::skeleton::{unit_quaternion, LocalTransform, Node, Trs};
use super::weights::{normalize_row, SkinWeights};
use super::{Body, PrimitiveRange, Rig, RigError, Skin};
use base64::Engine;
use nalgebra::{Matrix4, Point3, Vector3};
use std::path::{Component, Path, PathBuf};

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
    let buffers = resolve_buffers(file, &gltf, folder)?;
    let src = Source {
        file,
        buffers: &buffers,
    };
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
/// hook of `gltf-json` 1.4 that indexes without a bounds check (the POSITION accessor).
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
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |path, error| {
        errors.push(format!("{}: {error}", path()))
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

// ---------------------------------------------------------------------------------------------
// Buffers

fn resolve_buffers(
    file: &Path,
    gltf: &gltf::Gltf,
    folder: Option<&Path>,
) -> Result<Vec<Vec<u8>>, RigError> {
    let mut out = Vec::new();
    for buffer in gltf.document.buffers() {
        let i = buffer.index();
        let err = |message: String| RigError::Buffer {
            file: file.to_path_buf(),
            buffer: i,
            message,
        };
        let mut data = match buffer.source() {
            gltf::buffer::Source::Bin => gltf
                .blob
                .clone()
                .ok_or_else(|| err("refers to the GLB binary chunk, which is missing".into()))?,
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                decode_data_uri(uri).map_err(err)?
            }
            gltf::buffer::Source::Uri(uri) => {
                let folder = folder.ok_or_else(|| {
                    err(format!(
                        "external URI '{uri}' with no folder to read it from"
                    ))
                })?;
                let path = safe_relative_path(folder, uri).map_err(err)?;
                read_whole(&path, MAX_FILE_BYTES)
                    .map_err(|e| err(format!("cannot read '{}': {e}", path.display())))?
            }
        };
        if data.len() < buffer.length() {
            return Err(err(format!(
                "holds {} bytes but byteLength says {}",
                data.len(),
                buffer.length()
            )));
        }
        // The buffer is its first byteLength bytes (a GLB chunk is padded to 4 bytes): a view
        // reaching past them is an error, not read from the padding or beyond (until
        // 2026-12-05 a byteLength of 0 or too short passed without a word).
        data.truncate(buffer.length());
        out.push(data);
    }
    Ok(out)
}

fn decode_data_uri(uri: &str) -> Result<Vec<u8>, String> {
    let comma = uri.find(',').ok_or("data URI without a comma")?;
    let (header, payload) = (&uri[..comma], &uri[comma + 1..]);
    if !header.ends_with(";base64") {
        return Err("only base64 data URIs are supported".into());
    }
    base64::engine::general_purpose::STANDARD
        .decode(payload.trim())
        .map_err(|e| format!("bad base64 in data URI: {e}"))
}

/// Resolves a relative URI reference inside `folder`, refusing anything that could leave it:
/// schemes (`http:`, `file:`), absolute paths, drive letters, backslashes, `..` components, and
/// symbolic links that point outside.
pub(crate) fn safe_relative_path(folder: &Path, uri: &str) -> Result<PathBuf, String> {
    let decoded = percent_decode(uri)?;
    confined_path(folder, &decoded).map_err(|e| match e {
        Confinement::Refused(why) => {
            format!("URI '{uri}' {why}: a buffer must lie inside the file's folder")
        }
        Confinement::Unreadable(message) => message,
    })
}

/// Why [`confined_path`] refused a path.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Confinement {
    /// The path could leave the folder (the reason, e.g. `is absolute`).
    Refused(&'static str),
    /// The folder or the file cannot be resolved (missing file, ...).
    Unreadable(String),
}

/// Resolves the relative path `rel` (already decoded) inside `folder`, refusing anything that
/// could leave it: schemes and drive letters, backslashes and NUL, absolute paths, any
/// component other than a plain name or `.`, and symbolic links resolving outside. The file
/// must exist; the canonical path is returned.
pub(crate) fn confined_path(folder: &Path, rel: &str) -> Result<PathBuf, Confinement> {
    use Confinement::{Refused, Unreadable};
    if rel.contains('\\') || rel.contains('\0') {
        return Err(Refused("contains a backslash or NUL"));
    }
    if let Some(colon) = rel.find(':') {
        if !rel[..colon].contains('/') {
            return Err(Refused("has a scheme or drive letter"));
        }
    }
    let path = Path::new(rel);
    if path.is_absolute() || rel.starts_with('/') {
        return Err(Refused("is absolute"));
    }
    if path
        .components()
        .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(Refused("leaves the folder"));
    }
    let joined = folder.join(path);
    let canon_folder = folder
        .canonicalize()
        .or_else(|_| std::env::current_dir().and_then(|d| d.join(folder).canonicalize()))
        .map_err(|e| Unreadable(format!("cannot resolve the folder: {e}")))?;
    let canon = joined
        .canonicalize()
        .map_err(|e| Unreadable(format!("cannot open '{}': {e}", joined.display())))?;
    if !canon.starts_with(&canon_folder) {
        return Err(Refused("resolves (through a link) outside the folder"));
    }
    Ok(canon)
}

fn percent_decode(s: &str) -> Result<String, String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = s.get(i + 1..i + 3).ok_or("truncated percent escape")?;
            let v =
                u8::from_str_radix(hex, 16).map_err(|_| format!("bad percent escape '%{hex}'"))?;
            out.push(v);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| "URI is not UTF-8 after decoding".to_string())
}

// ---------------------------------------------------------------------------------------------
// Nodes

fn read_local(
    file: &Path,
    node: &gltf::Node,
    not_affine: &mut NotAffine,
) -> Result<LocalTransform, RigError> {
    let element = format!("nodes[{}]", node.index());
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            let m = Matrix4::from_fn(|r, c| matrix[c][r] as f64);
            if m.iter().any(|x| !x.is_finite()) {
                return Err(invalid(file, element, "matrix has a non-finite entry"));
            }
            Ok(LocalTransform::Matrix(not_affine.fix(m, || element)))
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let all = translation.iter().chain(&rotation).chain(&scale);
            if all.clone().any(|x| !x.is_finite()) {
                return Err(invalid(
                    file,
                    element,
                    "translation, rotation or scale is not finite",
                ));
            }
            let rotation = unit_quaternion(rotation.map(|x| x as f64))
                .ok_or_else(|| invalid(file, element, "rotation quaternion is zero"))?;
            Ok(LocalTransform::Trs(Trs {
                translation: Vector3::from(translation.map(|x| x as f64)),
                rotation,
                scale: Vector3::from(scale.map(|x| x as f64)),
            }))
        }
    }
}

/// The matrices whose last row is not `[0, 0, 0, 1]`, as glTF requires of a node's matrix
/// and an inverse bind matrix (an affine transform): their affine part is used (with a
/// projective row the skinning divided each position by its homogeneous coordinate; the
/// fuzzing corpus sets `m[15] = 0`), and one warning names the first.
#[derive(Default)]
struct NotAffine {
    count: usize,
    first: Option<(String, [f64; 4])>,
}

impl NotAffine {
    /// `m` with its last row `[0, 0, 0, 1]`, counted when it was not (`element` names it).
    fn fix(&mut self, mut m: Matrix4<f64>, element: impl FnOnce() -> String) -> Matrix4<f64> {
        let row = [m[(3, 0)], m[(3, 1)], m[(3, 2)], m[(3, 3)]];
        if row != [0.0, 0.0, 0.0, 1.0] {
            self.count += 1;
            self.first.get_or_insert_with(|| (element(), row));
            m.set_row(3, &nalgebra::RowVector4::new(0.0, 0.0, 0.0, 1.0));
        }
        m
    }

    /// The warning, if any matrix was fixed.
    fn warn(self, warnings: &mut Vec<String>) {
        if let Some((element, row)) = self.first {
            warnings.push(format!(
                "{} matrices whose last row is not [0, 0, 0, 1] (not affine; the first: \
                 {element}, {row:?}): their affine part is used",
                self.count
            ));
        }
    }
}

/// Reads the hierarchy and checks it is a forest (one parent per node, no cycle).
fn read_nodes(
    file: &Path,
    doc: &gltf::Document,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Node>, Vec<usize>), RigError> {
    let mut nodes = Vec::new();
    let mut not_affine = NotAffine::default();
    for node in doc.nodes() {
        nodes.push(Node {
            name: node.name().map(str::to_string),
            parent: None,
            children: node.children().map(|c| c.index()).collect(),
            rest: read_local(file, &node, &mut not_affine)?,
        });
    }
    not_affine.warn(warnings);
    for n in 0..nodes.len() {
        for k in 0..nodes[n].children.len() {
            let c = nodes[n].children[k];
            if let Some(p) = nodes[c].parent {
                return Err(invalid(
                    file,
                    format!("nodes[{c}]"),
                    format!("has two parents (nodes[{p}] and nodes[{n}])"),
                ));
            }
            nodes[c].parent = Some(n);
        }
    }
    let mut order = Vec::with_capacity(nodes.len());
    let mut stack: Vec<usize> = (0..nodes.len())
        .rev()
        .filter(|&n| nodes[n].parent.is_none())
        .collect();
    while let Some(n) = stack.pop() {
        order.push(n);
        stack.extend(nodes[n].children.iter().rev());
    }
    if order.len() != nodes.len() {
        let stuck = (0..nodes.len()).find(|n| !order.contains(n)).unwrap_or(0);
        return Err(invalid(
            file,
            format!("nodes[{stuck}]"),
            "is part of a cycle in the node hierarchy",
        ));
    }
    Ok((nodes, order))
}

// ---------------------------------------------------------------------------------------------
// Skins

fn read_skins(
    src: &Source,
    doc: &gltf::Document,
    warnings: &mut Vec<String>,
) -> Result<Vec<Skin>, RigError> {
    let mut skins = Vec::new();
    let mut not_affine = NotAffine::default();
    for skin in doc.skins() {
        let joints: Vec<usize> = skin.joints().map(|n| n.index()).collect();
        if joints.is_empty() {
            return Err(invalid(
                src.file,
                format!("skins[{}]", skin.index()),
                "has no joints",
            ));
        }
        if joints.len() > u16::MAX as usize {
            return Err(invalid(
                src.file,
                format!("skins[{}]", skin.index()),
                "has more than 65535 joints",
            ));
        }
        let inverse_bind = match skin.inverse_bind_matrices() {
            None => vec![Matrix4::identity(); joints.len()],
            Some(acc) => {
                let role = format!("inverseBindMatrices of skins[{}]", skin.index());
                let v = accessor::read(src, doc, acc.index(), &role, &[16], false)?;
                if v.count() < joints.len() {
                    return Err(invalid(
                        src.file,
                        format!("skins[{}]", skin.index()),
                        format!(
                            "{} inverse bind matrices for {} joints",
                            v.count(),
                            joints.len()
                        ),
                    ));
                }
                if v.data.iter().any(|x| !x.is_finite()) {
                    return Err(invalid(src.file, role, "non-finite matrix entry"));
                }
                (0..joints.len())
                    .map(|j| {
                        let m = Matrix4::from_column_slice(v.element(j));
                        not_affine.fix(m, || format!("{role}[{j}]"))
                    })
                    .collect()
            }
        };
        skins.push(Skin {
            name: skin.name().map(str::to_string),
            joints,
            inverse_bind,
        });
    }
    not_affine.warn(warnings);
    Ok(skins)
}

// ---------------------------------------------------------------------------------------------
// Skinned meshes

/// Custom attributes of one body or primitive: `(name with its underscore, values)`.
type Extras = Vec<(String, Vec<f64>)>;

/// The bodies: every skinned mesh instance in node order, then every unskinned one in node
/// order (a prop, often parented to a joint), which glTF poses by its node's world
/// transform: a rigid body, given a skin of its own appended to `skins` (its node as the one
/// joint, an identity inverse bind matrix, weight 1 on every vertex). Placed after the
/// skinned bodies, so that a configuration naming bodies by index keeps its meaning.
fn read_bodies(
    src: &Source,
    doc: &gltf::Document,
    skins: &mut Vec<Skin>,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Body>, Vec<Extras>), RigError> {
    let mut bodies = Vec::new();
    let mut extras = Vec::new();
    for rigid in [false, true] {
        for node in doc.nodes() {
            let Some(mesh) = node.mesh() else { continue };
            let (index, own) = match (node.skin(), rigid) {
                (Some(skin), false) => (skin.index(), None),
                (None, true) => (skins.len(), Some(rigid_skin(&node))),
                _ => continue,
            };
            let skin = own.as_ref().unwrap_or_else(|| &skins[index]);
            let read = read_body(src, doc, &node, &mesh, (index, skin), rigid, warnings)?;
            let Some((mut body, extra)) = read else {
                continue;
            };
            if let Some(own) = own {
                skins.push(own);
                warnings.push(format!(
                    "nodes[{}] carries meshes[{}] without a skin: posed rigidly by its node",
                    node.index(),
                    mesh.index()
                ));
            }
            if body.name.is_empty() {
                body.name = format!("body{}", bodies.len());
            }
            bodies.push(body);
            extras.push(extra);
        }
    }
    Ok((bodies, extras))
}

/// The skin of a rigid body: `node` as its one joint, an identity inverse bind matrix (so
/// that its skinning matrix is the node's world transform).
fn rigid_skin(node: &gltf::Node) -> Skin {
    Skin {
        name: Some(format!("nodes[{}] (rigid)", node.index())),
        joints: vec![node.index()],
        inverse_bind: vec![Matrix4::identity()],
    }
}

/// One body: the triangle primitives of `mesh` instanced by `node`, skinned by `skin` (its
/// index and itself; `rigid`: every vertex on its one joint), with its custom attributes.
/// `None` (with a warning) when the mesh has no triangle primitive.
fn read_body(
    src: &Source,
    doc: &gltf::Document,
    node: &gltf::Node,
    mesh: &gltf::Mesh,
    (skin_index, skin): (usize, &Skin),
    rigid: bool,
    warnings: &mut Vec<String>,
) -> Result<Option<(Body, Extras)>, RigError> {
    let name = node.name().or(mesh.name()).unwrap_or_default().to_string();
    let mut body = Body {
        name,
        node: node.index(),
        mesh: mesh.index(),
        skin: skin_index,
        rigid,
        positions: Vec::new(),
        normals: Vec::new(),
        weights: SkinWeights::with_capacity(0),
        triangles: Vec::new(),
        primitives: Vec::new(),
    };
    let mut has_normals = true;
    let mut primitive_extras = Vec::new();
    for prim in mesh.primitives() {
        let at = PrimitiveAt {
            mesh: mesh.index(),
            skin,
            rigid,
        };
        let read = read_primitive(src, doc, &prim, &at, &mut body, warnings)?;
        has_normals &= read.has_normals;
        primitive_extras.extend(read.extras);
    }
    if body.positions.is_empty() {
        warnings.push(format!(
            "meshes[{}] has no triangle primitive: skipped",
            mesh.index()
        ));
        return Ok(None);
    }
    if !has_normals {
        body.normals = area_weighted_normals(&body.positions, &body.triangles);
    }
    let extras = merge_extras(primitive_extras, mesh.index(), warnings);
    Ok(Some((body, extras)))
}

/// Concatenates the custom attributes of a body's triangle primitives (one list per
/// primitive, in order); an attribute missing from one of them is dropped with a warning.
fn merge_extras(per_primitive: Vec<Extras>, mesh: usize, warnings: &mut Vec<String>) -> Extras {
    let mut names: Vec<String> = Vec::new();
    for (name, _) in per_primitive.iter().flatten() {
        if !names.contains(name) {
            names.push(name.clone());
        }
    }
    let mut out = Vec::new();
    for name in names {
        let parts: Vec<&Vec<f64>> = per_primitive
            .iter()
            .filter_map(|p| p.iter().find(|(n, _)| *n == name).map(|(_, v)| v))
            .collect();
        if parts.len() == per_primitive.len() {
            out.push((name, parts.into_iter().flatten().copied().collect()));
        } else {
            warnings.push(format!(
                "meshes[{mesh}]: attribute {name} is missing on some triangle primitives: ignored"
            ));
        }
    }
    out
}

/// The custom `_NAME` attributes of a primitive with `n` vertices: SCALAR float or normalized
/// integer accessors of `n` elements; anything else is skipped with a warning.
fn read_extras(
    src: &Source,
    doc: &gltf::Document,
    prim: &gltf::Primitive,
    at: &str,
    n: usize,
    warnings: &mut Vec<String>,
) -> Result<Extras, RigError> {
    use gltf::accessor::{DataType, Dimensions};
    let mut out = Vec::new();
    for (semantic, acc) in prim.attributes() {
        let gltf::Semantic::Extras(name) = semantic else {
            continue;
        };
        let name = format!("_{name}");
        let mut skip =
            |why: String| warnings.push(format!("{at}: attribute {name} {why}: ignored"));
        if acc.dimensions() != Dimensions::Scalar {
            skip(format!("is {:?}, not SCALAR", acc.dimensions()));
            continue;
        }
        if acc.data_type() != DataType::F32 && !acc.normalized() {
            skip("holds integers that are not normalized".into());
            continue;
        }
        let role = format!("{name} of {at}");
        let values = accessor::read(src, doc, acc.index(), &role, &[1], false)?;
        if values.count() != n {
            skip(format!("has {} values for {n} vertices", values.count()));
            continue;
        }
        out.push((name, values.data));
    }
    Ok(out)
}

/// What [`read_primitive`] found besides the arrays it appended.
struct PrimitiveRead {
    /// The primitive carried NORMAL (or was ignored).
    has_normals: bool,
    /// Its custom attributes (`None` for an ignored, non-triangle primitive).
    extras: Option<Extras>,
}

/// Where a primitive is read: its mesh, the skin of the body it joins and whether that body
/// is rigid (an unskinned mesh: every vertex on the skin's one joint).
struct PrimitiveAt<'a> {
    mesh: usize,
    skin: &'a Skin,
    rigid: bool,
}

/// Appends one primitive to `body`.
fn read_primitive(
    src: &Source,
    doc: &gltf::Document,
    prim: &gltf::Primitive,
    place: &PrimitiveAt,
    body: &mut Body,
    warnings: &mut Vec<String>,
) -> Result<PrimitiveRead, RigError> {
    use gltf::mesh::Mode;
    let mesh = place.mesh;
    let at = format!("meshes[{mesh}].primitives[{}]", prim.index());
    let mode = prim.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        warnings.push(format!("{at}: mode {mode:?} is not triangles: ignored"));
        return Ok(PrimitiveRead {
            has_normals: true,
            extras: None,
        });
    }
    let pos = read_positions(src, doc, prim, &at, body.positions.len())?;
    let n = pos.count();
    let normals = read_normals(src, doc, prim, &at, n)?;
    let weights = if place.rigid {
        SkinWeights::rigid(n)
    } else {
        read_weights(src, doc, prim, &at, n, place.skin, warnings)?
    };
    let extras = read_extras(src, doc, prim, &at, n, warnings)?;
    let indices = match prim.indices() {
        Some(acc) => {
            accessor::read_indices(
                src,
                doc,
                acc.index(),
                &format!("indices of {at}"),
                &[1],
                n as u64,
            )?
            .1
        }
        None => (0..n as u32).collect(),
    };
    let first_vertex = body.positions.len();
    body.positions
        .extend((0..n).map(|i| Point3::from_slice(pos.element(i))));
    append_normals(body, normals.as_ref(), n);
    for r in 0..n {
        let (j, w) = weights.row_slices(r);
        let row: Vec<(u16, f64)> = j.iter().copied().zip(w.iter().copied()).collect();
        body.weights.push_row(&row);
    }
    let local_tris = triangulate(mode, &indices);
    let first_triangle = body.triangles.len();
    let off = first_vertex as u32;
    body.triangles.extend(
        local_tris
            .iter()
            .map(|t| [t[0] + off, t[1] + off, t[2] + off]),
    );
    body.primitives.push(PrimitiveRange {
        mesh,
        primitive: prim.index(),
        first_vertex,
        vertex_count: n,
        first_triangle,
        triangle_count: local_tris.len(),
    });
    Ok(PrimitiveRead {
        has_normals: normals_present(prim),
        extras: Some(extras),
    })
}

/// POSITION of a primitive: finite, and the body (holding `before` vertices) stays within
/// 32-bit indices.
fn read_positions(
    src: &Source,
    doc: &gltf::Document,
    prim: &gltf::Primitive,
    at: &str,
    before: usize,
) -> Result<accessor::Values, RigError> {
    let acc = prim
        .get(&gltf::Semantic::Positions)
        .ok_or_else(|| invalid(src.file, at, "has no POSITION"))?;
    let pos = accessor::read(
        src,
        doc,
        acc.index(),
        &format!("POSITION of {at}"),
        &[3],
        false,
    )?;
    if pos.data.iter().any(|x| !x.is_finite()) {
        return Err(invalid(src.file, at, "POSITION holds a non-finite value"));
    }
    if (before + pos.count()) as u64 > u32::MAX as u64 {
        return Err(invalid(src.file, at, "more than 2^32 vertices in one mesh"));
    }
    Ok(pos)
}

/// NORMAL of a primitive of `n` vertices, if it has one.
fn read_normals(
    src: &Source,
    doc: &gltf::Document,
    prim: &gltf::Primitive,
    at: &str,
    n: usize,
) -> Result<Option<accessor::Values>, RigError> {
    let Some(acc) = prim.get(&gltf::Semantic::Normals) else {
        return Ok(None);
    };
    let v = accessor::read(
        src,
        doc,
        acc.index(),
        &format!("NORMAL of {at}"),
        &[3],
        false,
    )?;
    if v.count() != n {
        return Err(invalid(
            src.file,
            at,
            format!("NORMAL has {} elements, POSITION {}", v.count(), n),
        ));
    }
    Ok(Some(v))
}

/// Appends `n` unit normals (zero where the file has none, or a zero or non-finite one).
fn append_normals(body: &mut Body, normals: Option<&accessor::Values>, n: usize) {
    match normals {
        Some(v) => body.normals.extend((0..n).map(|i| {
            let nv = Vector3::from_column_slice(v.element(i));
            let len = nv.norm();
            if len.is_finite() && len > 1e-12 {
                nv / len
            } else {
                Vector3::zeros()
            }
        })),
        None => body
            .normals
            .extend(std::iter::repeat_n(Vector3::zeros(), n)),
    }
}

fn normals_present(prim: &gltf::Primitive) -> bool {
    prim.get(&gltf::Semantic::Normals).is_some()
}

/// Reads JOINTS_0/1 and WEIGHTS_0/1 into normalized rows, with the fallbacks documented on
/// [`crate::rig`]: invalid (NaN, negative) weights are dropped, rows are renormalized, a vertex
/// with no usable weight follows the skin's first joint; each fallback is counted in `warnings`.
fn read_weights(
    src: &Source,
    doc: &gltf::Document,
    prim: &gltf::Primitive,
    at: &str,
    n: usize,
    skin: &Skin,
    warnings: &mut Vec<String>,
) -> Result<SkinWeights, RigError> {
    let mut raw: Vec<Vec<(u16, f64)>> = vec![Vec::with_capacity(4); n];
    for set in 0..2u32 {
        let (ja, wa) = (
            prim.get(&gltf::Semantic::Joints(set)),
            prim.get(&gltf::Semantic::Weights(set)),
        );
        match (ja, wa) {
            (Some(j), Some(w)) => {
                let set = WeightSet {
                    set,
                    joints: j.index(),
                    weights: w.index(),
                };
                read_weight_set(src, doc, at, &set, skin, &mut raw)?;
            }
            (None, None) if set > 0 => break,
            (None, None) => {
                return Err(invalid(
                    src.file,
                    at,
                    "skinned primitive without JOINTS_0 / WEIGHTS_0",
                ))
            }
            _ => {
                return Err(invalid(
                    src.file,
                    at,
                    format!("JOINTS_{set} and WEIGHTS_{set} must come together"),
                ))
            }
        }
    }
    Ok(normalized_weights(&raw, at, warnings))
}

/// One JOINTS_i / WEIGHTS_i pair of accessors.
struct WeightSet {
    set: u32,
    joints: usize,
    weights: usize,
}

/// Appends a set's four (joint, weight) entries to each vertex's `raw` row; a joint index
/// outside the skin with a non-zero weight is an error.
fn read_weight_set(
    src: &Source,
    doc: &gltf::Document,
    at: &str,
    ws: &WeightSet,
    skin: &Skin,
    raw: &mut [Vec<(u16, f64)>],
) -> Result<(), RigError> {
    let (set, n) = (ws.set, raw.len());
    let (_, joints) = accessor::read_indices(
        src,
        doc,
        ws.joints,
        &format!("JOINTS_{set} of {at}"),
        &[4],
        1 << 16,
    )?;
    let weights = accessor::read(
        src,
        doc,
        ws.weights,
        &format!("WEIGHTS_{set} of {at}"),
        &[4],
        true,
    )?;
    if joints.len() != 4 * n || weights.data.len() != 4 * n {
        return Err(invalid(
            src.file,
            at,
            format!("JOINTS_{set} / WEIGHTS_{set} counts differ from POSITION ({n})"),
        ));
    }
    for (v, row) in raw.iter_mut().enumerate() {
        for k in 0..4 {
            let (j, w) = (joints[4 * v + k], weights.data[4 * v + k]);
            if w != 0.0 && j as usize >= skin.joints.len() {
                return Err(invalid(
                    src.file,
                    format!("JOINTS_{set} of {at}"),
                    format!(
                        "vertex {v} uses joint {j} with weight {w}, but the skin has {} joints",
                        skin.joints.len()
                    ),
                ));
            }
            row.push((j as u16, w));
        }
    }
    Ok(())
}

/// The rows normalized ([`normalize_row`]), each fallback counted in `warnings`.
fn normalized_weights(
    raw: &[Vec<(u16, f64)>],
    at: &str,
    warnings: &mut Vec<String>,
) -> SkinWeights {
    let mut out = SkinWeights::with_capacity(raw.len());
    let (mut invalid_rows, mut renormalized, mut empty) = (0, 0, 0);
    let mut row = Vec::with_capacity(8);
    for r in raw {
        let fixes = normalize_row(r, &mut row);
        invalid_rows += fixes.dropped_invalid as usize;
        renormalized += fixes.renormalized as usize;
        if fixes.empty {
            empty += 1;
            row.push((0, 1.0));
        }
        out.push_row(&row);
    }
    if invalid_rows > 0 {
        warnings.push(format!(
            "{at}: {invalid_rows} vertices had NaN, infinite or negative weights (dropped)"
        ));
    }
    if renormalized > 0 {
        warnings.push(format!(
            "{at}: {renormalized} vertices had weights not summing to 1 (renormalized)"
        ));
    }
    if empty > 0 {
        warnings.push(format!(
            "{at}: {empty} vertices had no usable weight (bound to the skin's first joint)"
        ));
    }
    out
}

fn triangulate(mode: gltf::mesh::Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    use gltf::mesh::Mode;
    match mode {
        Mode::TriangleStrip => (2..idx.len())
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i - 2], idx[i - 1], idx[i]]
                } else {
                    [idx[i - 1], idx[i - 2], idx[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..idx.len())
            .map(|i| [idx[0], idx[i - 1], idx[i]])
            .collect(),
        _ => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    }
}

/// Area-weighted vertex normals of a triangle soup (zero for isolated vertices).
pub fn area_weighted_normals(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
) -> Vec<Vector3<f64>> {
    let mut normals = vec![Vector3::zeros(); positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(&(c - a));
        for &i in t {
            normals[i as usize] += n;
        }
    }
    for n in &mut normals {
        let len = n.norm();
        *n = if len > 1e-300 {
            *n / len
        } else {
            Vector3::zeros()
        };
    }
    normals
}

// ---------------------------------------------------------------------------------------------
// Animations

fn read_animations(
    src: &Source,
    doc: &gltf::Document,
    warnings: &mut Vec<String>,
) -> Result<Vec<Animation>, RigError> {
    let mut out = Vec::new();
    for anim in doc.animations() {
        let mut channels = Vec::new();
        for ch in anim.channels() {
            let at = format!("animations[{}].channels[{}]", anim.index(), ch.index());
            let property = match ch.target().property() {
                gltf::animation::Property::Translation => Property::Translation,
                gltf::animation::Property::Rotation => Property::Rotation,
                gltf::animation::Property::Scale => Property::Scale,
                gltf::animation::Property::MorphTargetWeights => {
                    warnings.push(format!(
                        "{at}: morph target weights are not posed (ignored)"
                    ));
                    continue;
                }
            };
            let mut channel = read_channel(src, doc, &ch, &at, property)?;
            if property == Property::Rotation {
                let rest = ch.target().node().transform().decomposed().1;
                let zeros = replace_zero_rotations(&mut channel, rest.map(f64::from));
                if zeros > 0 {
                    warnings.push(format!(
                        "{at}: {zeros} rotation key(s) are zero quaternions (not a rotation): \
                         read as the node's rest rotation"
                    ));
                }
            }
            channels.push(channel);
        }
        out.push(Animation::new(anim.name().map(str::to_string), channels));
    }
    Ok(out)
}

/// Replaces the zero quaternions ([`unit_quaternion`]'s `None`) among a rotation channel's key
/// values (each key's value; a cubic spline's tangents left as they are) by `rest`
/// (`[x, y, z, w]`); their number.
/// Sampling would otherwise read them as the identity between keys and as the rest rotation at
/// a key (until 2026-12-05, without a word).
fn replace_zero_rotations(channel: &mut Channel, rest: [f64; 4]) -> usize {
    let cubic = channel.interpolation == Interpolation::CubicSpline;
    let (stride, value) = if cubic { (12, 4) } else { (4, 0) };
    let mut zeros = 0;
    for key in channel.values.chunks_exact_mut(stride) {
        let q = &mut key[value..value + 4];
        if unit_quaternion([q[0], q[1], q[2], q[3]]).is_none() {
            q.copy_from_slice(&rest);
            zeros += 1;
        }
    }
    zeros
}

fn read_channel(
    src: &Source,
    doc: &gltf::Document,
    ch: &gltf::animation::Channel,
    at: &str,
    property: Property,
) -> Result<Channel, RigError> {
    let sampler = ch.sampler();
    let interpolation = match sampler.interpolation() {
        gltf::animation::Interpolation::Linear => Interpolation::Linear,
        gltf::animation::Interpolation::Step => Interpolation::Step,
        gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
    };
    let input = accessor::read(
        src,
        doc,
        sampler.input().index(),
        &format!("input of {at}"),
        &[1],
        false,
    )?;
    let times = input.data;
    if times.is_empty() {
        return Err(invalid(src.file, at, "sampler input has no key"));
    }
    if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] <= w[0]) {
        return Err(invalid(
            src.file,
            at,
            "key times are not finite and strictly increasing",
        ));
    }
    let comps = property.components();
    let output = accessor::read(
        src,
        doc,
        sampler.output().index(),
        &format!("output of {at}"),
        &[comps],
        false,
    )?;
    let per_key = if interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    };
    if output.count() != times.len() * per_key {
        return Err(invalid(
            src.file,
            at,
            format!(
                "{} output values for {} keys ({:?})",
                output.count(),
                times.len(),
                interpolation
            ),
        ));
    }
    if output.data.iter().any(|x| !x.is_finite()) {
        return Err(invalid(src.file, at, "output holds a non-finite value"));
    }
    Ok(Channel {
        node: ch.target().node().index(),
        property,
        interpolation,
        times,
        values: output.data,
    })
}
