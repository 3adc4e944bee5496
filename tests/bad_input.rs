//! Malformed and hostile inputs: every one must give a typed error naming the file and the
//! element, or a documented fallback with a warning — never a panic.

#[path = "common/glb.rs"]
mod glb;

use base64::Engine;
use contact_skin::rig::{self, RigError};
use serde_json::{json, Value};
use std::path::Path;

/// Binary layout of the minimal valid rig: a skinned triangle with two joints and an animation.
struct Layout {
    bytes: Vec<u8>,
}

fn f32s(out: &mut Vec<u8>, v: &[f32]) {
    out.extend(v.iter().flat_map(|x| x.to_le_bytes()));
}

impl Layout {
    /// positions @0 (36 B), normals @36 (36), joints u16 @72 (24), weights @96 (48),
    /// indices u16 @144 (6, padded to 8), ibm @152 (128), times @280 (8), rotations @288 (32).
    fn new(weights: [[f32; 4]; 3], positions: [[f32; 3]; 3]) -> Self {
        let mut b = Vec::new();
        f32s(&mut b, &positions.concat());
        f32s(&mut b, &[0., 0., 1., 0., 0., 1., 0., 0., 1.]);
        for j in [[0u16, 1, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0]] {
            b.extend(j.iter().flat_map(|x| x.to_le_bytes()));
        }
        f32s(&mut b, &weights.concat());
        b.extend([0u16, 1, 2, 0].iter().flat_map(|x| x.to_le_bytes()));
        let id = [
            1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
        ];
        f32s(&mut b, &id);
        f32s(&mut b, &id);
        f32s(&mut b, &[0.0, 1.0]);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        f32s(&mut b, &[0., 0., 0., 1., 0., 0., h, h]);
        Self { bytes: b }
    }

    fn valid() -> Self {
        Self::new(
            [[0.5, 0.5, 0., 0.], [1., 0., 0., 0.], [1., 0., 0., 0.]],
            [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]],
        )
    }
}

fn view(offset: usize, len: usize) -> Value {
    json!({"buffer": 0, "byteOffset": offset, "byteLength": len})
}

fn acc(view: usize, ctype: u32, count: usize, ty: &str) -> Value {
    json!({"bufferView": view, "componentType": ctype, "count": count, "type": ty})
}

/// The glTF JSON of the minimal rig, with the buffer embedded as a data URI.
fn doc(layout: &Layout) -> Value {
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&layout.bytes)
    );
    let mut pos = acc(0, 5126, 3, "VEC3");
    pos["min"] = json!([0, 0, 0]);
    pos["max"] = json!([1, 1, 0]);
    let mut times = acc(7, 5126, 2, "SCALAR");
    times["min"] = json!([0]);
    times["max"] = json!([1]);
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0, "skin": 0},
            {"children": [2], "name": "root"},
            {"name": "tip", "translation": [0, 1, 0]}
        ],
        "skins": [{"joints": [1, 2], "inverseBindMatrices": 5}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "JOINTS_0": 2, "WEIGHTS_0": 3},
            "indices": 4
        }]}],
        "animations": [{"channels": [{"sampler": 0, "target": {"node": 2, "path": "rotation"}}],
                        "samplers": [{"input": 6, "output": 7}]}],
        "accessors": [pos, acc(1, 5126, 3, "VEC3"), acc(2, 5123, 3, "VEC4"), acc(3, 5126, 3, "VEC4"),
                      acc(4, 5123, 3, "SCALAR"), acc(5, 5126, 2, "MAT4"), times, acc(8, 5126, 2, "VEC4")],
        "bufferViews": [view(0, 36), view(36, 36), view(72, 24), view(96, 48), view(144, 6),
                        view(152, 128), view(280, 8), view(288, 32)],
        "buffers": [{"byteLength": layout.bytes.len(), "uri": uri}]
    })
}

fn load_json(v: &Value) -> Result<rig::Rig, RigError> {
    let text = serde_json::to_vec(v).expect("serializable");
    rig::load_from_bytes(Path::new("test.gltf"), &text)
}

fn fixed_doc() -> Value {
    fixed_doc_of(&Layout::valid())
}

fn fixed_doc_of(layout: &Layout) -> Value {
    let mut d = doc(layout);
    // accessors[6] holds the times: the sampler must read input 6, output 7.
    d["animations"][0]["samplers"][0] = json!({"input": 6, "output": 7});
    d["accessors"][6] = {
        let mut t = acc(6, 5126, 2, "SCALAR");
        t["min"] = json!([0]);
        t["max"] = json!([1]);
        t
    };
    d["accessors"][7] = acc(7, 5126, 2, "VEC4");
    d
}

/// Requires a warning of `rig` mentioning `needle`.
fn assert_warned(rig: &rig::Rig, needle: &str) {
    assert!(
        rig.warnings.iter().any(|w| w.contains(needle)),
        "no warning mentions '{needle}': {:?}",
        rig.warnings
    );
}

fn expect_err(v: &Value, needle: &str) -> RigError {
    match load_json(v) {
        Ok(_) => panic!("expected an error mentioning '{needle}'"),
        Err(e) => {
            let msg = e.to_string();
            assert!(
                msg.contains(needle),
                "error '{msg}' should mention '{needle}'"
            );
            assert!(
                msg.starts_with("test.gltf"),
                "error '{msg}' should name the file"
            );
            e
        }
    }
}

#[test]
fn the_minimal_rig_is_valid_and_poses() {
    let rig = load_json(&fixed_doc()).expect("valid rig");
    assert_eq!(rig.bodies.len(), 1);
    assert_eq!(rig.bodies[0].vertex_count(), 3);
    assert_eq!(rig.animations.len(), 1);
    assert!(rig.warnings.is_empty(), "{:?}", rig.warnings);
    // At t = 1 the tip joint turned 90° about z; vertex 0 (half on it) moves, vertex 1 does not.
    let pose = rig.pose_at(Some(0), 1.0);
    let mats = pose.skin_matrices(&rig.skins[0]);
    let s = contact_skin::skinning::lbs::skin(&rig.bodies[0], &mats);
    assert!((s.positions[1] - rig.bodies[0].positions[1]).norm() < 1e-12);
    assert!((s.positions[0] - rig.bodies[0].positions[0]).norm() > 0.1);
}

#[test]
fn truncated_and_garbage_files_are_format_errors() {
    let text = serde_json::to_vec(&fixed_doc()).expect("json");
    for cut in [0, 1, 10, text.len() / 2, text.len() - 1] {
        let r = rig::load_from_bytes(Path::new("t.gltf"), &text[..cut]);
        assert!(matches!(r, Err(RigError::Format { .. })), "cut at {cut}");
    }
    let glb_header = b"glTF\x02\x00\x00\x00\xff\xff\xff\x7f\x10\x00\x00\x00JSON{}";
    let r = rig::load_from_bytes(Path::new("t.glb"), glb_header);
    assert!(matches!(r, Err(RigError::Format { .. })));
}

#[test]
fn accessor_out_of_bounds_is_an_accessor_error() {
    let mut d = fixed_doc();
    d["accessors"][0]["count"] = json!(4);
    match expect_err(&d, "accessors[0]") {
        RigError::Accessor { role, .. } => assert!(role.contains("POSITION")),
        e => panic!("unexpected {e:?}"),
    }
    let mut d = fixed_doc();
    d["accessors"][0]["byteOffset"] = json!(4);
    expect_err(&d, "do not fit");
}

#[test]
fn buffer_view_past_the_buffer_is_an_error() {
    let mut d = fixed_doc();
    d["bufferViews"][5]["byteLength"] = json!(100_000);
    expect_err(&d, "runs past the end");
}

/// A buffer is its first `byteLength` bytes: a view reaching past a `byteLength` shorter than
/// the data is an error (until 2026-12-05 it read the bytes beyond without a word).
#[test]
fn a_view_past_a_short_byte_length_is_an_error() {
    for short in [0, 100] {
        let mut d = fixed_doc();
        d["buffers"][0]["byteLength"] = json!(short);
        expect_err(&d, "runs past the end");
    }
}

/// A UTF-8 byte order mark before the JSON is a format error that says so.
#[test]
fn a_byte_order_mark_is_named() {
    let mut text = b"\xEF\xBB\xBF".to_vec();
    text.extend(serde_json::to_vec(&fixed_doc()).expect("json"));
    let e = rig::load_from_bytes(Path::new("bom.gltf"), &text).expect_err("refused");
    assert!(matches!(e, RigError::Format { .. }), "{e:?}");
    assert!(e.to_string().contains("byte order mark"), "{e}");
}

#[test]
fn absurd_counts_do_not_allocate() {
    let mut d = fixed_doc();
    d["accessors"][3]["count"] = json!(4_000_000_000u64);
    expect_err(&d, "accessors[3]");
    let mut d = fixed_doc();
    d["accessors"][1] = json!({"componentType": 5126, "count": 3_000_000_000u64, "type": "VEC3",
        "sparse": {"count": 1, "indices": {"bufferView": 4, "componentType": 5123},
                   "values": {"bufferView": 1}}});
    expect_err(&d, "exceeds the limit");
}

#[test]
fn stride_smaller_than_the_element_is_an_error() {
    let mut d = fixed_doc();
    d["bufferViews"][1]["byteStride"] = json!(8);
    let r = load_json(&d);
    assert!(r.is_err(), "stride 8 for VEC3 floats must be refused");
}

#[test]
fn joint_index_beyond_the_skin_is_an_error() {
    let mut l = Layout::valid();
    l.bytes[72..74].copy_from_slice(&7u16.to_le_bytes()); // vertex 0, first influence, weight 0.5
    let mut d = fixed_doc();
    d["buffers"][0] = doc(&l)["buffers"][0].clone();
    expect_err(&d, "uses joint 7");
}

/// glTF 2.0 never normalizes indices or joints (Meshes): read as fractions, a u16 joint index
/// 1 became 1/65535, joint 0, and the rig silently never bent (found by fuzzing, 2026-12-06).
/// Both are accessor errors now.
#[test]
fn normalized_joints_or_indices_are_an_error() {
    for (accessor, role) in [(2, "JOINTS_0"), (4, "indices")] {
        let mut d = fixed_doc();
        d["accessors"][accessor]["normalized"] = json!(true);
        let e = expect_err(&d, "is normalized where integers are required");
        assert!(e.to_string().contains(role), "{e}");
    }
}

#[test]
fn unused_joint_index_beyond_the_skin_is_ignored() {
    let mut l = Layout::valid();
    l.bytes[76..78].copy_from_slice(&9u16.to_le_bytes()); // vertex 0, third influence, weight 0
    let mut d = fixed_doc();
    d["buffers"][0] = doc(&l)["buffers"][0].clone();
    load_json(&d).expect("a zero-weight influence may name any joint");
}

fn with_weights(w: [[f32; 4]; 3]) -> Value {
    let l = Layout::new(w, [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]]);
    let mut d = fixed_doc();
    d["buffers"][0] = doc(&l)["buffers"][0].clone();
    d
}

#[test]
fn nan_and_negative_weights_fall_back_with_a_warning() {
    let d = with_weights([
        [f32::NAN, 1.0, 0., 0.],
        [1., -0.5, 0., 0.],
        [1., 0., 0., 0.],
    ]);
    let rig = load_json(&d).expect("documented fallback");
    assert_warned(&rig, "NaN");
    let w = &rig.bodies[0].weights;
    assert_eq!(w.row(0).collect::<Vec<_>>(), vec![(1, 1.0)]);
    assert_eq!(w.row(1).collect::<Vec<_>>(), vec![(0, 1.0)]);
}

#[test]
fn all_zero_weights_bind_to_the_first_joint_with_a_warning() {
    let d = with_weights([[0.; 4], [0.2, 0.2, 0., 0.], [1., 0., 0., 0.]]);
    let rig = load_json(&d).expect("documented fallback");
    assert_warned(&rig, "no usable weight");
    assert_warned(&rig, "renormalized");
    let w = &rig.bodies[0].weights;
    assert_eq!(w.row(0).collect::<Vec<_>>(), vec![(0, 1.0)]);
    let sum: f64 = w.row(1).map(|(_, x)| x).sum();
    assert!((sum - 1.0).abs() < 1e-12);
}

#[test]
fn nan_position_is_an_error() {
    let l = Layout::new(
        [[1., 0., 0., 0.]; 3],
        [[f32::NAN, 0., 0.], [1., 0., 0.], [0., 1., 0.]],
    );
    let mut d = fixed_doc();
    d["buffers"][0] = doc(&l)["buffers"][0].clone();
    expect_err(&d, "non-finite");
}

#[test]
fn missing_weights_are_an_error() {
    let mut d = fixed_doc();
    let attrs = d["meshes"][0]["primitives"][0]["attributes"]
        .as_object_mut()
        .expect("object");
    attrs.remove("WEIGHTS_0");
    attrs.remove("JOINTS_0");
    expect_err(&d, "without JOINTS_0");
}

#[test]
fn index_beyond_the_vertices_is_an_error() {
    let mut l = Layout::valid();
    l.bytes[146..148].copy_from_slice(&3u16.to_le_bytes());
    let mut d = fixed_doc();
    d["buffers"][0] = doc(&l)["buffers"][0].clone();
    expect_err(&d, "must be below 3");
}

#[test]
fn node_cycles_and_double_parents_are_errors() {
    let mut d = fixed_doc();
    d["nodes"][2]["children"] = json!([1]);
    assert!(load_json(&d).is_err(), "a cycle must be refused");
    let mut d = fixed_doc();
    d["nodes"][0]["children"] = json!([2]);
    expect_err(&d, "two parents");
}

#[test]
fn decreasing_key_times_are_an_error() {
    let mut l = Layout::valid();
    l.bytes[280..284].copy_from_slice(&2.0f32.to_le_bytes());
    let mut d = fixed_doc();
    d["buffers"][0] = doc(&l)["buffers"][0].clone();
    expect_err(&d, "strictly increasing");
}

/// A rotation key that is a zero quaternion (not a rotation) is read as the node's rest
/// rotation, with a warning: until 2026-12-05 it was the identity between keys and the rest
/// rotation at the key, without a word (a zero rotation at rest is an error).
#[test]
fn zero_rotation_keys_are_the_rest_rotation_with_a_warning() {
    let mut l = Layout::valid();
    l.bytes[304..320].fill(0);
    let mut d = fixed_doc();
    d["buffers"][0] = doc(&l)["buffers"][0].clone();
    let h = std::f32::consts::FRAC_1_SQRT_2;
    d["nodes"][2]["rotation"] = json!([0.0, h, 0.0, h]);
    let rig = load_json(&d).expect("loads");
    assert_warned(&rig, "1 rotation key(s) are zero");
    let key = &rig.animations[0].channels[0].values[4..8];
    let rest = [0.0, f64::from(h), 0.0, f64::from(h)];
    assert_eq!(key, rest.as_slice());
}

#[test]
fn zero_count_accessor_does_not_panic() {
    let mut d = fixed_doc();
    d["accessors"][7]["count"] = json!(0);
    d["accessors"][6]["count"] = json!(0);
    assert!(
        load_json(&d).is_err(),
        "an animation with no key is refused"
    );
}

#[test]
fn buffer_uris_cannot_leave_the_folder() {
    let dir = std::env::temp_dir().join(format!("cs-uri-{}", std::process::id()));
    let inner = dir.join("rig");
    std::fs::create_dir_all(&inner).expect("temp dir");
    let l = Layout::valid();
    std::fs::write(dir.join("secret.bin"), &l.bytes).expect("write");
    std::fs::write(inner.join("ok.bin"), &l.bytes).expect("write");
    let write_rig = |uri: &str| {
        let mut d = fixed_doc();
        d["buffers"][0]["uri"] = json!(uri);
        let p = inner.join("rig.gltf");
        std::fs::write(&p, serde_json::to_vec(&d).expect("json")).expect("write");
        rig::load(&p)
    };
    write_rig("ok.bin").expect("a sibling buffer is fine");
    write_rig("./ok.bin").expect("./ is fine");
    for bad in [
        "../secret.bin",
        "%2e%2e/secret.bin",
        "sub/../../secret.bin",
        "/etc/passwd",
        "file:///etc/passwd",
        "http://example.com/x.bin",
        "C:/x.bin",
        "..\\secret.bin",
    ] {
        match write_rig(bad) {
            Err(RigError::Buffer { message, .. }) => {
                assert!(
                    message.contains(bad) || message.contains("URI"),
                    "{message}"
                )
            }
            other => panic!("{bad}: expected a buffer error, got {other:?}"),
        }
    }
    #[cfg(unix)]
    {
        let link = inner.join("link.bin");
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink(dir.join("secret.bin"), &link).expect("symlink");
        assert!(matches!(
            write_rig("link.bin"),
            Err(RigError::Buffer { .. })
        ));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Only `buffers[0]` refers to a GLB's binary chunk (glTF 2.0 §4.4.3.3): a later buffer
/// without a URI is refused, where it copied the whole chunk (found by review: 2 000 one-byte
/// buffers in a 1 MB glb took 2 GB). Buffers naming one file share it (read once).
#[test]
fn only_the_first_buffer_is_the_glb_chunk() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("rigs/bending_capsule.glb");
    let bytes = std::fs::read(&path).expect("committed rig");
    let edited = glb::with_json(&bytes, |json| {
        let buffers = json["buffers"].as_array_mut().expect("buffers");
        buffers.push(json!({"byteLength": 1}));
    });
    match rig::load_from_bytes(Path::new("test.glb"), &edited) {
        Err(RigError::Buffer {
            buffer: 1, message, ..
        }) => {
            assert!(message.contains("only buffers[0]"), "{message}")
        }
        other => panic!("expected a buffer error, got {other:?}"),
    }
    // Two buffers naming one file: each view reads its own buffer's bytes.
    let dir = std::env::temp_dir().join(format!("cs-shared-bin-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::write(dir.join("rig.bin"), &Layout::valid().bytes).expect("write");
    let mut d = fixed_doc();
    d["buffers"][0]["uri"] = json!("rig.bin");
    let second = d["buffers"][0].clone();
    d["buffers"].as_array_mut().expect("buffers").push(second);
    d["bufferViews"][0]["buffer"] = json!(1);
    std::fs::write(dir.join("rig.gltf"), serde_json::to_vec(&d).expect("json")).expect("write");
    let shared = rig::load(&dir.join("rig.gltf")).expect("two buffers, one file");
    let single = load_json(&fixed_doc()).expect("the same rig");
    assert_eq!(shared.bodies[0].positions, single.bodies[0].positions);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Accessor reads are bounded per file (`MAX_READ_COMPONENTS`): five skins naming one
/// view-less accessor of 4M matrices read 5 × 64M values (found by review: 500 such skins took
/// 55 s from 23 kB); one such skin loads.
#[test]
fn accessor_reads_are_bounded_per_file() {
    let with_skins = |count: usize| {
        let mut d = fixed_doc();
        // View-less: zeros but for one sparse matrix (indices from view 4, values from 5).
        let sparse = json!({"count": 1, "indices": {"bufferView": 4, "componentType": 5123},
                            "values": {"bufferView": 5}});
        let big = json!({"componentType": 5126, "count": 1 << 22, "type": "MAT4",
                         "sparse": sparse});
        d["accessors"].as_array_mut().expect("accessors").push(big);
        let skin = json!({"joints": [1, 2], "inverseBindMatrices": 8});
        d["skins"] = Value::Array(vec![skin; count]);
        d
    };
    load_json(&with_skins(1)).expect("one skin reads its matrices once");
    let e = load_json(&with_skins(5)).expect_err("five reads of 64M values");
    assert!(e.to_string().contains("accessor reads exceed"), "{e}");
}

/// The vertices of a file's bodies are bounded (`MAX_FILE_VERTICES`), checked before a
/// primitive is read: three primitives naming one view-less accessor of 4M positions (found by
/// review: six took 3 GB and 31 s from 758 bytes).
#[test]
fn the_bodies_vertices_are_bounded_per_file() {
    let mut d = fixed_doc();
    let sparse = json!({"count": 1, "indices": {"bufferView": 4, "componentType": 5123},
                        "values": {"bufferView": 0}});
    let big = json!({"componentType": 5126, "count": 1 << 22, "type": "VEC3", "sparse": sparse,
                     "min": [0, 0, 0], "max": [1, 1, 1]});
    d["accessors"].as_array_mut().expect("accessors").push(big);
    let primitive = json!({"attributes": {"POSITION": 8}});
    d["meshes"] = json!([{"primitives": [primitive.clone(), primitive.clone(), primitive]}]);
    d["nodes"][0] = json!({"mesh": 0});
    let e = load_json(&d).expect_err("12M vertices");
    let message = e.to_string();
    assert!(
        message.contains("primitives[2]") && message.contains("would hold 12582912 vertices"),
        "{message}"
    );
}

/// JOINTS_n / WEIGHTS_n sets past the second are read (glTF puts influences beyond four in
/// the following sets), up to four sets; a fifth is ignored with a warning (found by review:
/// a third set was dropped with no word but the renormalization's).
#[test]
fn later_weight_sets_are_read_up_to_four() {
    // The minimal rig's buffer, then joints [1, 0, 0, 0] (u16, @320) and zero weights (@344).
    let mut layout = Layout::valid();
    let at = layout.bytes.len();
    for _ in 0..3 {
        layout
            .bytes
            .extend([1u16, 0, 0, 0].iter().flat_map(|x| x.to_le_bytes()));
    }
    f32s(&mut layout.bytes, &[0.0; 12]);
    let mut d = fixed_doc_of(&layout);
    let views = d["bufferViews"].as_array_mut().expect("views");
    views.extend([view(at, 24), view(at + 24, 48)]);
    let accessors = d["accessors"].as_array_mut().expect("accessors");
    accessors.extend([acc(8, 5123, 3, "VEC4"), acc(9, 5126, 3, "VEC4")]);
    // Set 1: no weight; set 2: vertex 1 (on joint 0 in set 0) gets weight 1 on joint 1; sets 3
    // and 4 like set 1.
    let attributes = &mut d["meshes"][0]["primitives"][0]["attributes"];
    for (set, joints, weights) in [(1, 2, 9), (2, 8, 3), (3, 2, 9), (4, 2, 9)] {
        attributes[format!("JOINTS_{set}")] = json!(joints);
        attributes[format!("WEIGHTS_{set}")] = json!(weights);
    }
    let rig = load_json(&d).expect("five sets");
    assert_warned(&rig, "JOINTS_4 / WEIGHTS_4 and later sets ignored");
    let row: Vec<(usize, f64)> = rig.bodies[0].weights.row(1).collect();
    assert_eq!(row, vec![(0, 0.5), (1, 0.5)]);
}

/// An animated node given by a matrix (glTF 2.0 §3.11 requires TRS) is read with a warning
/// saying its matrix is decomposed (it posed a sheared matrix wrong without a word).
#[test]
fn an_animated_matrix_node_is_a_warning() {
    let mut d = fixed_doc();
    d["nodes"][2] =
        json!({"name": "tip", "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 1]});
    let rig = load_json(&d).expect("loads");
    assert_warned(&rig, "nodes[2]: animated but given by a matrix");
    assert!(!load_json(&fixed_doc())
        .expect("loads")
        .warnings
        .iter()
        .any(|w| w.contains("matrix")));
}

#[test]
fn missing_file_is_an_io_error() {
    let r = rig::load(Path::new("/nonexistent/nowhere.glb"));
    assert!(matches!(r, Err(RigError::Io { .. })));
}

/// Deterministic byte mutations of valid GLBs (half of them inside the JSON chunk, where the
/// structure lives): whatever happens, no panic and no non-finite position.
#[test]
fn random_corruptions_never_panic() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-samples");
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for name in [
        "RiggedSimple/RiggedSimple.glb",
        "RiggedFigure/RiggedFigure.glb",
        "Fox/Fox.glb",
    ] {
        let base = std::fs::read(root.join(name)).expect("the shared samples must be present");
        let json_len = u32::from_le_bytes([base[12], base[13], base[14], base[15]]) as usize + 20;
        let (mut ok, mut err) = (0, 0);
        for _ in 0..4000 {
            let mut bytes = base.clone();
            let span = if next() % 2 == 0 {
                json_len.min(bytes.len())
            } else {
                bytes.len()
            };
            for _ in 0..1 + next() % 4 {
                let at = (next() as usize) % span;
                bytes[at] = (next() & 0xff) as u8;
            }
            if next() % 8 == 0 {
                let keep = (next() as usize) % bytes.len();
                bytes.truncate(keep);
            }
            match rig::load_from_bytes(Path::new("fuzz.glb"), &bytes) {
                Ok(r) => {
                    ok += 1;
                    for b in &r.bodies {
                        assert!(b
                            .positions
                            .iter()
                            .all(|p| p.coords.iter().all(|x| x.is_finite())));
                    }
                }
                Err(_) => err += 1,
            }
        }
        println!("{name}: {ok} corruptions loaded, {err} refused");
        assert!(err > 0);
    }
}

/// Keys spanning a billion seconds: the default 30 frames per second would be 3e10 frames
/// (found by fuzzing: an allocation abort); the frame count is refused with a typed error
/// naming `--frames`, and a given count still samples the animation.
#[test]
fn absurd_animation_lengths_refuse_the_default_frame_count() {
    use contact_skin::frames::{sample_times, MAX_FRAMES};
    let mut l = Layout::valid();
    l.bytes[284..288].copy_from_slice(&1e9f32.to_le_bytes());
    let mut d = fixed_doc();
    d["buffers"][0] = doc(&l)["buffers"][0].clone();
    d["accessors"][6]["max"] = json!([1e9]);
    let rig = load_json(&d).expect("valid rig");
    let err = sample_times(&rig, Some(0), None).expect_err("too many frames");
    assert!(err.to_string().contains("--frames"), "{err}");
    assert!(sample_times(&rig, Some(0), Some(MAX_FRAMES + 1)).is_err());
    let times = sample_times(&rig, Some(0), Some(5)).expect("five frames");
    assert_eq!(times.len(), 5);
    assert_eq!(times[4], 1e9);
}

/// A FIFO given as the rig (or named by a buffer URI) would block the read forever (found by
/// fuzzing): only regular files are read.
#[cfg(unix)]
#[test]
fn a_fifo_is_not_read() {
    let dir = std::env::temp_dir().join(format!("cs-fifo-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    let fifo = dir.join("rig.gltf");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        println!("mkfifo unavailable: skipped");
        return;
    }
    let err = rig::load(&fifo).expect_err("refused");
    assert!(err.to_string().contains("not a regular file"), "{err}");
    // A buffer URI naming a FIFO in the rig's folder.
    let mut d = fixed_doc();
    d["buffers"][0] = json!({"uri": "data.bin", "byteLength": 280});
    std::process::Command::new("mkfifo")
        .arg(dir.join("data.bin"))
        .status()
        .expect("mkfifo");
    let gltf = dir.join("buffer.gltf");
    std::fs::write(&gltf, serde_json::to_vec(&d).expect("json")).expect("write");
    let err = rig::load(&gltf).expect_err("refused");
    assert!(err.to_string().contains("not a regular file"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Scales that are finite one by one (glTF stores `f32`) but overflow once composed down a
/// chain (eleven ancestors of scale 1e30 above the root joint: 1e330): refused at load, naming
/// the first node whose world transform overflows (found by fuzzing: the rest pose came out
/// NaN and was written as such).
#[test]
fn transforms_that_overflow_when_composed_are_an_error() {
    let chain = |depth: usize| {
        let mut d = fixed_doc();
        let first = d["nodes"].as_array().expect("nodes").len();
        for k in 0..depth {
            let child = if k + 1 < depth { first + k + 1 } else { 1 };
            d["nodes"]
                .as_array_mut()
                .expect("nodes")
                .push(json!({"scale": [1e30, 1e30, 1e30], "children": [child]}));
        }
        d["scenes"][0]["nodes"] = json!([0, first]);
        d
    };
    let e = expect_err(&chain(11), "overflows");
    assert!(e.to_string().contains("nodes["), "{e}");
    // Ten ancestors compose to 1e300: finite, loaded.
    assert!(load_json(&chain(10)).is_ok());
}

/// A node matrix or an inverse bind matrix whose last row is not `[0, 0, 0, 1]` (projective,
/// invalid in glTF; the skinning divided by its homogeneous coordinate) is read as
/// its affine part, with one warning per kind naming the first: the rig poses exactly as with
/// the row fixed.
#[test]
fn matrices_that_are_not_affine_use_their_affine_part_with_a_warning() {
    let mut valid = fixed_doc();
    // The root joint as a matrix (column-major): a translation along x.
    valid["nodes"][1]["matrix"] = json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.25, 0, 0, 1]);
    let mut layout = Layout::valid();
    // The first inverse bind matrix's m[3][3] (float 15 of the matrix at byte 152) set to 0.
    layout.bytes[212..216].copy_from_slice(&0f32.to_le_bytes());
    let mut broken = fixed_doc_of(&layout);
    broken["nodes"][1]["matrix"] = json!([1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 0, 0.25, 0, 0, 0]);
    let posed = |rig: &rig::Rig| {
        let pose = rig.pose_at(Some(0), 1.0);
        let mats = pose.skin_matrices(&rig.skins[0]);
        contact_skin::skinning::lbs::skin(&rig.bodies[0], &mats).positions
    };
    let good = load_json(&valid).expect("valid rig");
    assert!(good.warnings.is_empty(), "{:?}", good.warnings);
    let fixed = load_json(&broken).expect("loaded with its affine parts");
    let warned: Vec<&String> = fixed
        .warnings
        .iter()
        .filter(|w| w.contains("not affine"))
        .collect();
    assert_eq!(warned.len(), 2, "{:?}", fixed.warnings);
    assert!(warned[0].contains("1 matrices") && warned[0].contains("nodes[1]"));
    assert!(warned[1].contains("inverseBindMatrices of skins[0][0]"));
    assert_eq!(posed(&fixed), posed(&good));
    assert!(posed(&good)
        .iter()
        .flat_map(|p| p.iter())
        .all(|c| c.is_finite()));
}

/// A glTF of another major version is refused, not read as 2.0 (found by fuzzing).
#[test]
fn other_gltf_versions_are_refused() {
    let mut d = fixed_doc();
    d["asset"]["version"] = json!("3.0");
    expect_err(&d, "not supported");
    d["asset"]["version"] = json!("2.1");
    assert!(load_json(&d).is_ok());
}

/// A chunk after the JSON and BIN chunks that declares more bytes than the file holds (4 GB
/// here) is ignored, as before, but with a warning (found by fuzzing: ignored without a word);
/// a well-formed extra chunk gives none.
#[test]
fn a_trailing_glb_chunk_past_the_end_is_a_warning() {
    let mut json = serde_json::to_vec(&fixed_doc()).expect("json");
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let glb = |extra: &[u8]| {
        let bin = [0u8; 4];
        let total = 12 + 8 + json.len() + 8 + bin.len() + extra.len();
        let mut b = b"glTF".to_vec();
        b.extend(2u32.to_le_bytes());
        b.extend((total as u32).to_le_bytes());
        b.extend((json.len() as u32).to_le_bytes());
        b.extend(b"JSON");
        b.extend(&json);
        b.extend((bin.len() as u32).to_le_bytes());
        b.extend(b"BIN\0");
        b.extend(bin);
        b.extend(extra);
        b
    };
    let chunk = |declared: u32, body: &[u8]| {
        let mut c = declared.to_le_bytes().to_vec();
        c.extend(b"XTRA");
        c.extend(body);
        c
    };
    let fine = rig::load_from_bytes(Path::new("test.glb"), &glb(&chunk(4, &[1, 2, 3, 4])))
        .expect("an extra chunk is ignored");
    assert!(fine.warnings.is_empty(), "{:?}", fine.warnings);
    let bogus = rig::load_from_bytes(Path::new("test.glb"), &glb(&chunk(0xffff_fff0, &[1, 2])))
        .expect("still read");
    assert!(
        bogus
            .warnings
            .iter()
            .any(|w| w.contains("\"XTRA\"") && w.contains("beyond the file's end")),
        "{:?}",
        bogus.warnings
    );
}

/// A GLB whose header declares fewer bytes than the file holds is read by its chunks, with a
/// warning; the exact length gives none (found by fuzzing: accepted silently).
#[test]
fn a_short_glb_length_is_a_warning() {
    let mut json = serde_json::to_vec(&fixed_doc()).expect("json");
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let glb = |declared: Option<u32>| {
        let total = 12 + 8 + json.len();
        let mut b = b"glTF".to_vec();
        b.extend(2u32.to_le_bytes());
        b.extend(declared.unwrap_or(total as u32).to_le_bytes());
        b.extend((json.len() as u32).to_le_bytes());
        b.extend(b"JSON");
        b.extend(&json);
        b
    };
    let exact = rig::load_from_bytes(Path::new("test.glb"), &glb(None)).expect("valid glb");
    assert!(exact.warnings.is_empty(), "{:?}", exact.warnings);
    let short = rig::load_from_bytes(Path::new("test.glb"), &glb(Some(20))).expect("read");
    assert!(
        short
            .warnings
            .iter()
            .any(|w| w.contains("GLB header declares 20 bytes")),
        "{:?}",
        short.warnings
    );
}

/// The minimal rig with one morph target on its primitive (accessor 1, the normals (0, 0, 1),
/// read as displacements) at default weight `weight`.
fn with_morph_target(weight: f64) -> Value {
    let mut d = fixed_doc();
    d["meshes"][0]["primitives"][0]["targets"] = json!([{"POSITION": 1}]);
    d["meshes"][0]["weights"] = json!([weight]);
    d
}

/// Morph targets read and applied (glTF 2.0 §3.7.2.2): the target's +z moves every vertex at
/// its weight; malformed targets or weights are errors naming the element.
#[test]
fn morph_targets_are_applied_and_checked() {
    use contact_skin::frames::{self, Precomputed};
    use contact_skin::skinning::Method;
    let rig = load_json(&with_morph_target(0.5)).expect("a valid morph target");
    assert_eq!(rig.bodies[0].morphs.len(), 1);
    let pre = Precomputed::new(&rig, Method::Lbs);
    let rest = frames::evaluate(&rig, &pre, None, 0, 0.0);
    for (p, bind) in rest.bodies[0]
        .positions
        .iter()
        .zip(&rig.bodies[0].positions)
    {
        assert_eq!((p - bind).z, 0.5, "{p} from {bind}");
    }
    // As many weights as targets, finite.
    let mut d = with_morph_target(0.5);
    d["meshes"][0]["weights"] = json!([0.5, 1.0]);
    expect_err(&d, "2 weights for 1 morph targets");
    let mut d = with_morph_target(0.5);
    d["nodes"][0]["weights"] = json!([1e39]);
    expect_err(&d, "nodes[0].weights");
    // As many targets on every triangle primitive.
    let mut d = with_morph_target(0.5);
    let mut second = d["meshes"][0]["primitives"][0].clone();
    second["targets"] = json!([]);
    d["meshes"][0]["primitives"] = json!([d["meshes"][0]["primitives"][0].clone(), second]);
    expect_err(&d, "1 and 0 morph targets");
    // One finite displacement per vertex.
    let mut d = with_morph_target(0.5);
    d["accessors"]
        .as_array_mut()
        .expect("accessors")
        .push(acc(1, 5126, 2, "VEC3"));
    d["meshes"][0]["primitives"][0]["targets"] = json!([{"POSITION": 8}]);
    expect_err(&d, "2 elements for 3 vertices");
    let l = Layout::new(
        [[0.5, 0.5, 0., 0.], [1., 0., 0., 0.], [1., 0., 0., 0.]],
        [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]],
    );
    let mut bytes = l.bytes.clone();
    bytes[36..40].copy_from_slice(&f32::INFINITY.to_le_bytes());
    let mut d = with_morph_target(0.5);
    d["buffers"][0] = doc(&Layout { bytes })["buffers"][0].clone();
    expect_err(&d, "POSITION of meshes[0].primitives[0].targets[0]");
}

/// A skin that mirrors its body (its root joint scaled by -1) mirrors the morphed normals
/// with it: the mirrored rig's posed normals are the mirror images of the plain rig's where a
/// target turns them. Found by review: the bind normals were negated at load but not the
/// targets' normal displacements, so a displaced normal came out turned away from both
/// (`[-0.09, 0.70, 0.70]` for `[-1, 0, 0]`).
#[test]
fn a_mirrored_body_mirrors_its_morphed_normals() {
    use contact_skin::frames::{self, Precomputed};
    use contact_skin::skinning::Method;
    use nalgebra::Vector3;
    // The positions (0, 0, 0), (1, 0, 0), (0, 1, 0) as normal displacements at weight 1:
    // vertex 1's normal (0, 0, 1) turns 45° toward +x, vertex 2's toward +y.
    let mut plain = fixed_doc();
    plain["meshes"][0]["primitives"][0]["targets"] = json!([{"NORMAL": 0}]);
    plain["meshes"][0]["weights"] = json!([1.0]);
    let mut mirrored = plain.clone();
    mirrored["nodes"][1]["scale"] = json!([-1, 1, 1]);
    let posed = |d: &Value| {
        let rig = load_json(d).expect("a valid rig");
        let pre = Precomputed::new(&rig, Method::Lbs);
        frames::evaluate(&rig, &pre, None, 0, 0.0).bodies[0]
            .normals
            .clone()
    };
    let (normals, images) = (posed(&plain), posed(&mirrored));
    let h = std::f64::consts::FRAC_1_SQRT_2;
    assert!(
        (normals[1] - Vector3::new(h, 0.0, h)).norm() < 1e-6,
        "{}",
        normals[1]
    );
    for (v, (n, m)) in normals.iter().zip(&images).enumerate() {
        let image = Vector3::new(-n.x, n.y, n.z);
        assert!((m - image).norm() < 1e-12, "vertex {v}: {m} for {image}");
    }
}

/// An animation's `weights` channel: one value per target and key, else an error; on a node
/// without morph targets it is ignored with a warning.
#[test]
fn morph_weight_channels_are_checked() {
    use contact_skin::frames::{self, Precomputed};
    use contact_skin::skinning::Method;
    use nalgebra::Vector3;
    let channel = json!({"sampler": 1, "target": {"node": 0, "path": "weights"}});
    // Two keys (accessor 6, times 0 and 1) of one weight each: 0 then 1.
    let mut d = with_morph_target(0.0);
    d["animations"][0]["channels"]
        .as_array_mut()
        .expect("channels")
        .push(channel.clone());
    d["animations"][0]["samplers"]
        .as_array_mut()
        .expect("samplers")
        .push(json!({"input": 6, "output": 6}));
    let rig = load_json(&d).expect("a valid weights channel");
    let pre = Precomputed::new(&rig, Method::Lbs);
    for (t, dz) in [(0.0, 0.0), (0.25, 0.25), (1.0, 1.0)] {
        let pose = rig.pose_at(Some(0), t);
        assert_eq!(pose.morph_weights_of(0), Some(&[t][..]));
        // Vertex 1 is on the root joint alone, which the animation leaves at rest.
        let frame = frames::evaluate_pose(&rig, &pre, &pose, 0, t);
        let moved = frame.bodies[0].positions[1] - rig.bodies[0].positions[1];
        assert!(
            (moved - Vector3::new(0.0, 0.0, dz)).norm() < 1e-12,
            "t = {t}: {moved}"
        );
    }
    // Two targets need two values per key.
    let mut two = d.clone();
    two["meshes"][0]["primitives"][0]["targets"] = json!([{"POSITION": 1}, {"POSITION": 1}]);
    two["meshes"][0]["weights"] = json!([0.0, 0.0]);
    expect_err(&two, "2 output values for 2 keys");
    // No target: ignored, with a warning.
    let mut none = d.clone();
    none["meshes"][0]["primitives"][0]
        .as_object_mut()
        .expect("primitive")
        .remove("targets");
    none["meshes"][0]
        .as_object_mut()
        .expect("mesh")
        .remove("weights");
    let rig = load_json(&none).expect("an ignored channel");
    assert_warned(&rig, "without morph targets");
    // A first primitive of points (ignored, without targets) does not set the channel's
    // width: the triangles' target is driven (found by review: the channel was dropped).
    let mut points_first = d.clone();
    let triangles = points_first["meshes"][0]["primitives"][0].clone();
    let points = json!({"attributes": {"POSITION": 0}, "mode": 0});
    points_first["meshes"][0]["primitives"] = json!([points, triangles]);
    let rig = load_json(&points_first).expect("a points primitive first");
    assert!(
        !rig.warnings
            .iter()
            .any(|w| w.contains("without morph targets")),
        "{:?}",
        rig.warnings
    );
    assert_eq!(
        rig.pose_at(Some(0), 0.25).morph_weights_of(0),
        Some(&[0.25][..])
    );
}

/// Many morph targets reading one dense accessor: past `MAX_MORPH_DISPLACEMENTS` stored
/// displacements a body is refused (the file's size does not bound them).
#[test]
fn morph_targets_sharing_an_accessor_are_bounded() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("rigs/bending_capsule.glb");
    let bytes = std::fs::read(&path).expect("committed rig");
    let n = rig::load(&path).expect("loads").bodies[0].vertex_count();
    let per_target = 2 * n; // its positions and normals, nearly all non-zero
    let count = contact_skin::rig::MAX_MORPH_DISPLACEMENTS / per_target + 2;
    let edited = |count: usize| {
        glb::with_json(&bytes, |json| {
            let attributes = json["meshes"][0]["primitives"][0]["attributes"].clone();
            let target =
                json!({"POSITION": attributes["POSITION"], "NORMAL": attributes["NORMAL"]});
            json["meshes"][0]["primitives"][0]["targets"] = Value::Array(vec![target; count]);
        })
    };
    let refused = rig::load_from_bytes(Path::new("test.glb"), &edited(count));
    let message = refused.expect_err("too many displacements").to_string();
    let cap = contact_skin::rig::MAX_MORPH_DISPLACEMENTS;
    assert!(
        message.contains(&format!("more than {cap} displacements")),
        "{message}"
    );
    // A few such targets load (default weights 0: the bind shape).
    let rig = rig::load_from_bytes(Path::new("test.glb"), &edited(3)).expect("three targets");
    assert_eq!(rig.bodies[0].morphs.len(), 3);
}

/// The bound holds for the file, not for each body: two nodes instancing one mesh read its
/// targets twice, and used to get the bound each (a 1.6 MB file of 8 such nodes took 4.3 GB
/// to load, found by review); a body under the bound alone loads.
#[test]
fn morph_displacements_are_bounded_per_file() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("rigs/bending_capsule.glb");
    let bytes = std::fs::read(&path).expect("committed rig");
    let n = rig::load(&path).expect("loads").bodies[0].vertex_count();
    // Positions only, nearly all non-zero: 0.6 of the bound per body.
    let count = 6 * contact_skin::rig::MAX_MORPH_DISPLACEMENTS / (10 * n);
    let edited = |instances: usize| {
        glb::with_json(&bytes, |json| {
            let position = json["meshes"][0]["primitives"][0]["attributes"]["POSITION"].clone();
            let targets = vec![json!({ "POSITION": position }); count];
            json["meshes"][0]["primitives"][0]["targets"] = Value::Array(targets);
            let body = json["nodes"]
                .as_array()
                .and_then(|nodes| nodes.iter().position(|node| node.get("mesh").is_some()))
                .expect("the capsule's node");
            for _ in 1..instances {
                let copy = json["nodes"][body].clone();
                let nodes = json["nodes"].as_array_mut().expect("nodes");
                nodes.push(copy);
                let added = nodes.len() - 1;
                let roots = json["scenes"][0]["nodes"].as_array_mut().expect("roots");
                roots.push(json!(added));
            }
        })
    };
    let one = rig::load_from_bytes(Path::new("test.glb"), &edited(1)).expect("one instance");
    assert_eq!(one.bodies.len(), 1);
    assert_eq!(one.bodies[0].morphs.len(), count);
    drop(one);
    let two = rig::load_from_bytes(Path::new("test.glb"), &edited(2));
    let message = two.expect_err("two instances").to_string();
    assert!(
        message.contains("the file's morph targets hold more than"),
        "{message}"
    );
}

/// Required extensions (glTF 2.0 §3.12): those that only change rendering, and
/// `KHR_mesh_quantization`, load; compressed geometry, GPU instancing and unknown ones are
/// refused, naming the extension.
#[test]
fn required_extensions_are_honoured_or_refused() {
    for accepted in [
        "KHR_texture_basisu",
        "KHR_materials_clearcoat",
        "KHR_mesh_quantization",
    ] {
        let mut d = fixed_doc();
        d["extensionsUsed"] = json!([accepted]);
        d["extensionsRequired"] = json!([accepted]);
        load_json(&d).unwrap_or_else(|e| panic!("{accepted}: {e}"));
    }
    for (refused, why) in [
        ("EXT_meshopt_compression", "decompress"),
        ("EXT_mesh_gpu_instancing", "instances"),
        ("EXT_unknown", "does not support"),
    ] {
        let mut d = fixed_doc();
        d["extensionsUsed"] = json!(["KHR_texture_basisu", refused]);
        d["extensionsRequired"] = json!(["KHR_texture_basisu", refused]);
        let e = expect_err(&d, why);
        assert!(
            e.to_string()
                .contains(&format!("extensionsRequired[1]: {refused}")),
            "{e}"
        );
    }
}
