//! The extensions a file may require (glTF 2.0 §3.12: a loader refuses a file that requires an
//! extension it does not support).
//!
//! Accepted: `KHR_mesh_quantization`, whose integer and normalized-integer attributes (POSITION,
//! NORMAL, morph displacements) the accessor reader decodes like any other, and the extensions
//! that change only how a model is rendered (materials, textures, lights), which posing does
//! not read. Refused, saying why: compressed geometry (`KHR_draco_mesh_compression`,
//! `EXT_meshopt_compression`: the accessors hold no data until decoded), GPU instancing and
//! any other extension.

use super::invalid;
use crate::rig::RigError;
use std::path::Path;

/// Required extensions accepted by name, besides any `KHR_materials_*`.
const ACCEPTED: &[&str] = &[
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "KHR_texture_basisu",
    "EXT_texture_webp",
    "EXT_texture_avif",
    "MSFT_texture_dds",
    "KHR_lights_punctual",
];

/// Whether posing can honour a file that requires `name`.
fn accepted(name: &str) -> bool {
    ACCEPTED.contains(&name) || name.starts_with("KHR_materials_")
}

/// Refuses a file that requires an extension posing cannot honour, naming it and why.
pub(super) fn check_required(file: &Path, root: &gltf::json::Root) -> Result<(), RigError> {
    let Some((i, name)) =
        (root.extensions_required.iter().enumerate()).find(|(_, name)| !accepted(name))
    else {
        return Ok(());
    };
    let why = match name.as_str() {
        "KHR_draco_mesh_compression" | "EXT_meshopt_compression" => {
            "compressed geometry is not decoded here: decompress the file first (glTF-Transform \
             or gltfpack can write it uncompressed)"
        }
        "EXT_mesh_gpu_instancing" => "GPU instances are not posed",
        _ => "an extension this reader does not support",
    };
    Err(invalid(
        file,
        format!("extensionsRequired[{i}]"),
        format!("{name}: {why}"),
    ))
}
