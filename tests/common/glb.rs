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
