//! Resolving a file's buffers: the GLB chunk, `data:` URIs, or files confined to the rig's
//! own folder.

use super::{read_whole, MAX_FILE_BYTES};
use crate::rig::RigError;
use base64::Engine;
use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};
use std::sync::Arc;

/// A buffer's bytes: the first `len` of `data`, which buffers naming one file share.
pub(super) struct BufferBytes {
    data: Arc<[u8]>,
    len: usize,
}

impl BufferBytes {
    /// The buffer: its first `byteLength` bytes.
    pub(super) fn bytes(&self) -> &[u8] {
        &self.data[..self.len]
    }
}

/// The bytes of every buffer of `gltf`: its GLB chunk (`buffers[0]` only, glTF 2.0 §4.4.3.3), a
/// `data:` URI, or a file inside `folder` (the rig's own folder; `None` for a rig read from
/// bytes, where an external URI is an error), each file read once however many buffers name
/// it. Each is cut to its `byteLength`. Until 2026-12-06 every buffer without a URI copied
/// the whole chunk and every buffer naming a file read it again (found by review: 2 000
/// buffers of one byte in a 1 MB glb took 2 GB).
pub(super) fn resolve_buffers(
    file: &Path,
    gltf: &gltf::Gltf,
    folder: Option<&Path>,
) -> Result<Vec<BufferBytes>, RigError> {
    let mut out = Vec::new();
    let mut files: HashMap<PathBuf, Arc<[u8]>> = HashMap::new();
    let chunk: Option<Arc<[u8]>> = gltf.blob.as_deref().map(Arc::from);
    for buffer in gltf.document.buffers() {
        let i = buffer.index();
        let err = |message: String| RigError::Buffer {
            file: file.to_path_buf(),
            buffer: i,
            message,
        };
        let data: Arc<[u8]> = match buffer.source() {
            gltf::buffer::Source::Bin if i != 0 => {
                let message = "has no URI: only buffers[0] may refer to the GLB binary chunk";
                return Err(err(message.into()));
            }
            gltf::buffer::Source::Bin => chunk
                .clone()
                .ok_or_else(|| err("refers to the GLB binary chunk, which is missing".into()))?,
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                Arc::from(decode_data_uri(uri).map_err(err)?)
            }
            gltf::buffer::Source::Uri(uri) => {
                let folder = folder.ok_or_else(|| {
                    err(format!(
                        "external URI '{uri}' with no folder to read it from"
                    ))
                })?;
                let path = safe_relative_path(folder, uri).map_err(err)?;
                match files.get(&path) {
                    Some(data) => Arc::clone(data),
                    None => {
                        let data: Arc<[u8]> =
                            Arc::from(read_whole(&path, MAX_FILE_BYTES).map_err(|e| {
                                err(format!("cannot read '{}': {e}", path.display()))
                            })?);
                        files.insert(path, Arc::clone(&data));
                        data
                    }
                }
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
        out.push(BufferBytes {
            data,
            len: buffer.length(),
        });
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
