//! Rewriting a GLB held in memory: the tests' broken and rescaled rigs.

#![allow(dead_code)]

use serde_json::Value;

/// The byte offset where the JSON chunk ends (where the BIN chunk's header starts).
fn json_end(glb: &[u8]) -> usize {
    let length = u32::from_le_bytes(glb[12..16].try_into().expect("a GLB header"));
    20 + length as usize
}

/// The GLB's JSON.
pub fn json(glb: &[u8]) -> Value {
    serde_json::from_slice(&glb[20..json_end(glb)]).expect("the JSON chunk parses")
}

/// The byte offset of the BIN chunk's data.
pub fn bin_start(glb: &[u8]) -> usize {
    json_end(glb) + 8
}

/// `glb` with its JSON chunk edited by `edit` (padded with spaces), the rest as it was.
pub fn with_json(glb: &[u8], edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    let mut value = json(glb);
    edit(&mut value);
    assembled(glb, &value, &glb[json_end(glb)..])
}

/// `glb` with `data` appended to its BIN chunk (4-byte aligned; the buffer's `byteLength`
/// updated) and its JSON then edited by `edit`, given the byte offset of `data` in the buffer.
pub fn with_bin_appended(glb: &[u8], data: &[u8], edit: impl FnOnce(&mut Value, usize)) -> Vec<u8> {
    let start = bin_start(glb);
    let header = &glb[start - 8..start];
    let length = u32::from_le_bytes(header[..4].try_into().expect("a BIN chunk")) as usize;
    let mut bin = glb[start..start + length].to_vec();
    let offset = bin.len().next_multiple_of(4);
    bin.resize(offset, 0);
    bin.extend_from_slice(data);
    bin.resize(bin.len().next_multiple_of(4), 0);
    let mut value = json(glb);
    value["buffers"][0]["byteLength"] = Value::from(bin.len());
    edit(&mut value, offset);
    let mut chunk = Vec::with_capacity(8 + bin.len());
    chunk.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    chunk.extend_from_slice(b"BIN\0");
    chunk.extend_from_slice(&bin);
    assembled(glb, &value, &chunk)
}

/// `glb`'s header (its total length rewritten), the JSON chunk of `value` (padded with spaces)
/// and `rest`, the chunks after it.
fn assembled(glb: &[u8], value: &Value, rest: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(value).expect("json");
    text.resize(text.len().next_multiple_of(4), b' ');
    let mut out = Vec::with_capacity(20 + text.len() + rest.len());
    out.extend_from_slice(&glb[..8]);
    out.extend_from_slice(&((20 + text.len() + rest.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(rest);
    out
}

/// `glb` with every mesh primitive's triangles (read from its index accessor, `u8`, `u16`
/// or `u32`, tightly packed) replaced by `edit` of them, as `u32` indices.
pub fn with_triangles(glb: &[u8], edit: impl Fn(&[[u32; 3]]) -> Vec<[u32; 3]>) -> Vec<u8> {
    let ids = primitive_accessors(glb, |p| p["indices"].as_u64());
    with_accessors_rewritten(glb, &ids, |acc, bytes| {
        let size = match acc["componentType"].as_u64() {
            Some(5121) => 1,
            Some(5123) => 2,
            _ => 4,
        };
        let indices: Vec<u32> = (0..acc["count"].as_u64().expect("a count") as usize)
            .map(|i| {
                let b = &bytes[i * size..(i + 1) * size];
                b.iter()
                    .rev()
                    .fold(0u32, |x, &byte| x << 8 | u32::from(byte))
            })
            .collect();
        let triangles: Vec<[u32; 3]> = indices.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        let edited = edit(&triangles);
        let data = edited
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        let accessor = serde_json::json!({
            "componentType": 5125,
            "count": edited.len() * 3,
            "type": "SCALAR",
        });
        (data, accessor)
    })
}

/// `glb` with every mesh primitive's normals (`f32` VEC3, tightly packed) negated.
pub fn with_normals_negated(glb: &[u8]) -> Vec<u8> {
    let ids = primitive_accessors(glb, |p| p["attributes"]["NORMAL"].as_u64());
    with_accessors_rewritten(glb, &ids, |acc, bytes| {
        let count = acc["count"].as_u64().expect("a count") as usize;
        let data = bytes[..12 * count]
            .chunks(4)
            .flat_map(|b| (-f32::from_le_bytes(b.try_into().expect("4 bytes"))).to_le_bytes())
            .collect();
        let accessor = serde_json::json!({
            "componentType": 5126,
            "count": count,
            "type": "VEC3",
        });
        (data, accessor)
    })
}

/// The accessors that `pick` gives of the mesh primitives of `glb`, sorted, once each.
fn primitive_accessors(glb: &[u8], pick: impl Fn(&Value) -> Option<u64>) -> Vec<usize> {
    let value = json(glb);
    let mut ids: Vec<usize> = value["meshes"]
        .as_array()
        .expect("meshes")
        .iter()
        .flat_map(|m| m["primitives"].as_array().expect("primitives").iter())
        .filter_map(|p| pick(p).map(|a| a as usize))
        .collect();
    ids.sort_unstable();
    ids.dedup();
    ids
}

/// `glb` with each accessor of `ids` replaced: `rewrite(accessor, bytes)`, given the
/// accessor's JSON and the BIN chunk from its first byte, returns the new data (appended to
/// the BIN chunk, in a new buffer view) and the new accessor's JSON (its view set here).
fn with_accessors_rewritten(
    glb: &[u8],
    ids: &[usize],
    rewrite: impl Fn(&Value, &[u8]) -> (Vec<u8>, Value),
) -> Vec<u8> {
    let value = json(glb);
    let bin = &glb[bin_start(glb)..];
    let mut data = Vec::new();
    let mut placed = Vec::new();
    for &a in ids {
        let acc = &value["accessors"][a];
        let view = &value["bufferViews"][acc["bufferView"].as_u64().expect("a view") as usize];
        let offset = |v: &Value| v["byteOffset"].as_u64().unwrap_or(0) as usize;
        let (bytes, accessor) = rewrite(acc, &bin[offset(view) + offset(acc)..]);
        placed.push((a, data.len(), bytes.len(), accessor));
        data.extend(bytes);
    }
    with_bin_appended(glb, &data, |json, offset| {
        for (a, at, length, mut accessor) in placed {
            let views = json["bufferViews"].as_array_mut().expect("views");
            views.push(serde_json::json!({
                "buffer": 0,
                "byteOffset": offset + at,
                "byteLength": length,
            }));
            accessor["bufferView"] = Value::from(views.len() - 1);
            json["accessors"][a] = accessor;
        }
    })
}

/// `glb` with a triangle primitive appended to mesh `mesh`: `POSITION` and `NORMAL` (`f32`),
/// `JOINTS_0` (`u16`) and `WEIGHTS_0` (`f32`, four influences per vertex, the heaviest kept)
/// and `u32` indices, in new buffer views at the end of the BIN chunk.
pub fn with_primitive_appended(
    glb: &[u8],
    mesh: usize,
    positions: &[[f64; 3]],
    normals: &[[f64; 3]],
    weights: &[Vec<(u16, f64)>],
    triangles: &[[u32; 3]],
) -> Vec<u8> {
    let f32s = |v: &[[f64; 3]]| -> Vec<u8> {
        v.iter()
            .flatten()
            .flat_map(|&x| (x as f32).to_le_bytes())
            .collect()
    };
    let four = |row: &Vec<(u16, f64)>| -> [(u16, f64); 4] {
        let mut row = row.clone();
        row.sort_by(|a, b| b.1.total_cmp(&a.1));
        row.resize(4, (0, 0.0));
        [row[0], row[1], row[2], row[3]]
    };
    let joints: Vec<u8> = (weights.iter().flat_map(&four))
        .flat_map(|(j, _)| j.to_le_bytes())
        .collect();
    let values: Vec<u8> = (weights.iter().flat_map(four))
        .flat_map(|(_, w)| (w as f32).to_le_bytes())
        .collect();
    let indices: Vec<u8> = triangles
        .iter()
        .flatten()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let (lo, hi) = positions
        .iter()
        .fold(([f64::MAX; 3], [f64::MIN; 3]), |(lo, hi), p| {
            (
                [0, 1, 2].map(|k| lo[k].min(p[k] as f32 as f64)),
                [0, 1, 2].map(|k| hi[k].max(p[k] as f32 as f64)),
            )
        });
    let n = positions.len();
    let parts: [(Vec<u8>, u64, &str, usize); 5] = [
        (f32s(positions), 5126, "VEC3", n),
        (f32s(normals), 5126, "VEC3", n),
        (joints, 5123, "VEC4", n),
        (values, 5126, "VEC4", n),
        (indices, 5125, "SCALAR", triangles.len() * 3),
    ];
    let data: Vec<u8> = parts.iter().flat_map(|p| p.0.clone()).collect();
    with_bin_appended(glb, &data, |j, offset| {
        let mut ids = Vec::new();
        let mut at = offset;
        for (k, (bytes, component, kind, count)) in parts.iter().enumerate() {
            let views = j["bufferViews"].as_array_mut().expect("buffer views");
            views.push(
                serde_json::json!({"buffer": 0, "byteOffset": at, "byteLength": bytes.len()}),
            );
            let view = views.len() - 1;
            let mut accessor = serde_json::json!({
                "bufferView": view, "componentType": component, "count": count, "type": kind,
            });
            if k == 0 {
                accessor["min"] = serde_json::json!(lo);
                accessor["max"] = serde_json::json!(hi);
            }
            let accessors = j["accessors"].as_array_mut().expect("accessors");
            accessors.push(accessor);
            ids.push(accessors.len() - 1);
            at += bytes.len();
        }
        let primitive = serde_json::json!({
            "attributes": {"POSITION": ids[0], "NORMAL": ids[1], "JOINTS_0": ids[2], "WEIGHTS_0": ids[3]},
            "indices": ids[4],
        });
        (j["meshes"][mesh]["primitives"].as_array_mut())
            .expect("primitives")
            .push(primitive);
    })
}

/// Appends to `json` a buffer view over bytes `[offset, offset + length)` of buffer 0 (with
/// `byteStride` when `stride` is given) and `accessor` reading it (its `bufferView` set);
/// returns the accessor's index.
pub fn push_accessor(
    json: &mut Value,
    (offset, length): (usize, usize),
    stride: Option<usize>,
    mut accessor: Value,
) -> usize {
    let mut view = serde_json::json!({"buffer": 0, "byteOffset": offset, "byteLength": length});
    if let Some(stride) = stride {
        view["byteStride"] = Value::from(stride);
    }
    let views = json["bufferViews"].as_array_mut().expect("buffer views");
    views.push(view);
    accessor["bufferView"] = Value::from(views.len() - 1);
    let accessors = json["accessors"].as_array_mut().expect("accessors");
    accessors.push(accessor);
    accessors.len() - 1
}
