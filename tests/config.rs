//! The rig's contact configuration (`src/config/`): parsing, resolution against a rig,
//! painted bulge maps (text files and glTF vertex attributes), and a typed error naming the
//! file and the field for every mistake.

use base64::Engine;
use contact_skin::config::{BodyRef, ConfigError, ContactConfig};
use contact_skin::mesh::WeldedMesh;
use contact_skin::pass::{DirectionTrack, ObjectParams, DEFAULT_PASSES};
use contact_skin::rig::{self, Rig};
use nalgebra::Vector3;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// A fresh temporary folder holding a copy of the committed rig `rigs/{rig}.glb`.
fn rig_dir(rig: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cs-config-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    let from = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("rigs/{rig}.glb"));
    std::fs::copy(from, d.join(format!("{rig}.glb"))).expect("copy rig");
    d
}

/// The rig `{rig}.glb` of `dir` and its welded bodies.
fn load_rig_named(dir: &Path, rig: &str) -> (Rig, Vec<WeldedMesh>) {
    let rig = rig::load(&dir.join(format!("{rig}.glb"))).expect("rig loads");
    let welded = rig
        .bodies
        .iter()
        .map(|b| WeldedMesh::weld(&b.positions, &b.triangles))
        .collect();
    (rig, welded)
}

/// A copy of `rigs/fingertips_ball.glb` (bodies `ball` 1514 vertices, `thumb`, `index`,
/// `middle` 402 each).
fn scene_dir(name: &str) -> PathBuf {
    rig_dir("fingertips_ball", name)
}

fn load_rig(dir: &Path) -> (Rig, Vec<WeldedMesh>) {
    load_rig_named(dir, "fingertips_ball")
}

/// Writes `text` as `dir/contact.toml` and loads it.
fn write_config(dir: &Path, text: &str) -> Result<ContactConfig, ConfigError> {
    let path = dir.join("contact.toml");
    std::fs::write(&path, text).expect("write config");
    ContactConfig::load(&path)
}

/// Loads and resolves `text` against the scene in `dir`.
fn resolve(dir: &Path, text: &str) -> Result<contact_skin::config::Resolved, ConfigError> {
    let cfg = write_config(dir, text)?;
    let (rig, welded) = load_rig(dir);
    cfg.resolve(&rig, &welded)
}

fn zeros_map(n: usize) -> String {
    let mut s = String::from("# painted bulge map\n");
    for i in 0..n {
        s.push_str(if i % 7 == 6 { "0.0\n" } else { "0.0 " });
    }
    s
}

/// The error must name the configuration file and the field.
fn check_names(e: &ConfigError, dir: &Path, field: &str) {
    let msg = e.to_string();
    let file = dir.join("contact.toml");
    assert!(
        msg.starts_with(&file.display().to_string()),
        "'{msg}' should start with the file"
    );
    assert_eq!(e.field(), field, "{msg}");
    assert!(msg.contains(field), "'{msg}' should name {field}");
}

const FULL: &str = r#"
passes = 1                      # one pass, as in the paper
[defaults]
stiffness = 1.0
tau = 0.1
extent = 0.3
gamma = 1.0
omega = 2.0

[[object]]
name = "ball"
stiffness = 0.5
bulge_map = "ball_bulge.txt"

[[object]]
name = 1                        # the thumb, by index
stiffness = "rigid"
extent_factor = 0.5
gamma = 0.0
contact = false                 # meets nothing

[[object]]
name = "3"                      # the middle finger, by index as a string
omega = 0

[[pair]]
objects = ["ball", "index"]
tau = 0.6
safeguard_angle = 70            # degrees
direction = [0.0, 1.0, 0.0]

[[pair]]
objects = ["middle", "ball"]
direction_keys = [[1.5, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 2.0], [0.5, 0.0, 1, 0]]
enabled = false
"#;

#[test]
fn a_full_example_parses_and_resolves() {
    let dir = scene_dir("full");
    let mut map = String::from("# ramp over the ball\n");
    for i in 0..1514 {
        map.push_str(&format!("{} # vertex {i}\n", i as f64 / 1513.0));
    }
    std::fs::write(dir.join("ball_bulge.txt"), map).expect("map");
    let cfg = write_config(&dir, FULL).expect("parses");
    assert_eq!(cfg.passes, Some(1));
    assert_eq!(cfg.objects.len(), 3);
    assert_eq!(cfg.objects[1].name, BodyRef::Index(1));
    assert_eq!(cfg.file, dir.join("contact.toml"));
    let (rig, welded) = load_rig(&dir);
    let (params, overrides, passes) = cfg.resolve(&rig, &welded).expect("resolves");
    assert_eq!(passes, 1);
    assert_eq!(params.len(), 4);
    // ball: its own stiffness, the defaults for the rest, the painted ramp gathered to welded.
    let ball = &params[0];
    assert_eq!(
        (ball.stiffness, ball.tau, ball.extent),
        (0.5, 0.1, Some(0.3))
    );
    let painted = ball.painted.as_ref().expect("painted map");
    assert_eq!(painted.len(), welded[0].vertex_count());
    for (w, &f) in welded[0].representative.iter().enumerate() {
        assert_eq!(painted[w], f as f64 / 1513.0);
    }
    // thumb: rigid, extent from its own factor times the rest size.
    let thumb = &params[1];
    assert!(thumb.stiffness.is_infinite());
    assert_eq!(thumb.gamma, 0.0);
    let size = contact_skin::config::rest_sizes(&rig)[1];
    assert!((thumb.extent.expect("extent") - 0.5 * size).abs() < 1e-12);
    // index: untouched defaults; middle: omega 0 (an integer in the file).
    assert_eq!(
        params[2],
        ObjectParams {
            tau: 0.1,
            extent: Some(0.3),
            ..ObjectParams::default()
        }
    );
    assert_eq!(params[3].omega, 0.0);
    let contact: Vec<bool> = params.iter().map(|p| p.contact).collect();
    assert_eq!(
        contact,
        [true, false, true, true],
        "the thumb meets nothing"
    );
    // pairs: bodies in the file's order, keyed directions sorted by time.
    assert_eq!(overrides.len(), 2);
    assert_eq!(overrides[0].bodies, [0, 2]);
    assert_eq!(overrides[0].tau, Some(0.6));
    assert_eq!(overrides[0].safeguard_angle, Some(70.0));
    assert_eq!(
        [overrides[0].enabled, overrides[1].enabled],
        [None, Some(false)]
    );
    let pre = contact_skin::frames::Precomputed::new(&rig, contact_skin::skinning::Method::Lbs);
    let rest = contact_skin::frames::welded_positions(&rig, &pre, None, 0.0);
    let bodies = contact_skin::pass::rest_bodies(&rest, &pre.welded);
    let pass = contact_skin::pass::ContactPass::new(&bodies, params.clone(), overrides.clone())
        .expect("pass");
    assert_eq!(pass.pair_params(0, 2, 0.0).safeguard_angle, 70.0);
    assert_eq!(
        pass.pair_params(2, 0, 0.0).safeguard_angle,
        70.0,
        "either order"
    );
    assert_eq!(
        pass.pair_params(0, 1, 0.0).safeguard_angle,
        80.0,
        "the paper's default"
    );
    assert_eq!(
        overrides[0].direction,
        Some(DirectionTrack::constant(Vector3::new(0.0, 1.0, 0.0)))
    );
    assert_eq!(overrides[1].bodies, [3, 0]);
    assert_eq!(overrides[1].tau, None);
    assert_eq!(overrides[1].safeguard_angle, None);
    let track = overrides[1].direction.as_ref().expect("keyed");
    let sorted = DirectionTrack::keyed(vec![
        (0.0, Vector3::new(0.0, 0.0, 2.0)),
        (0.5, Vector3::new(0.0, 1.0, 0.0)),
        (1.5, Vector3::new(1.0, 0.0, 0.0)),
    ])
    .expect("valid keys");
    assert_eq!(track, &sorted);
    assert!(
        (track.at(-1.0) - Vector3::z()).norm() < 1e-12,
        "held before"
    );
    assert!((track.at(0.5) - Vector3::y()).norm() < 1e-12);
    assert!((track.at(9.0) - Vector3::x()).norm() < 1e-12, "held after");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_empty_file_gives_the_pass_defaults() {
    let dir = scene_dir("empty");
    let (params, overrides, passes) = resolve(&dir, "# nothing\n").expect("resolves");
    assert!(params.iter().all(|p| *p == ObjectParams::default()));
    assert!(overrides.is_empty());
    assert_eq!(passes, DEFAULT_PASSES);
    let inline = ContactConfig::from_str_with_base("[defaults]\ngamma = 2\n", &dir).expect("ok");
    assert_eq!(inline.defaults.gamma, Some(2.0));
    assert_eq!(inline.base_dir, dir);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn discovery_finds_the_rig_config_and_an_explicit_missing_file_is_an_error() {
    let dir = scene_dir("discover");
    let rig_path = dir.join("fingertips_ball.glb");
    assert!(ContactConfig::for_rig(&rig_path, None)
        .expect("no file")
        .is_none());
    let own = dir.join("fingertips_ball.contact.toml");
    std::fs::write(&own, "passes = 3\n").expect("write");
    let found = ContactConfig::for_rig(&rig_path, None)
        .expect("ok")
        .expect("found");
    assert_eq!((found.passes, found.file), (Some(3), own));
    let missing = dir.join("missing.toml");
    match ContactConfig::for_rig(&rig_path, Some(&missing)) {
        Err(e @ ConfigError::Io { .. }) => {
            assert!(e.to_string().contains("missing.toml"), "{e}")
        }
        other => panic!("expected an Io error, got {other:?}"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unknown_fields_and_wrong_types_are_parse_errors_naming_the_field() {
    let dir = scene_dir("unknown");
    let cases = [
        (
            "[[object]]\nname = \"ball\"\nstifness = 2\n",
            "object[0].stifness",
        ),
        ("[defaults]\ntau = 0\nbulge = 1\n", "defaults.bulge"),
        ("colour = 1\n", "colour"),
        (
            "[[object]]\nname = \"ball\"\n[[object]]\nname = \"thumb\"\nstiffness = \"soft\"\n",
            "object[1].stiffness",
        ),
        ("[[pair]]\nobjects = [\"ball\"]\n", "pair[0].objects"),
        ("passes = -1\n", "passes"),
        // Arrays longer than their fixed length: until 2026-12-05 the extra values were
        // dropped without a word.
        (
            "[[pair]]\nobjects = [\"ball\", \"thumb\", \"palm\"]\n",
            "pair[0].objects",
        ),
        (
            "[[pair]]\nobjects = [0, 1]\ndirection = [0, 1, 0, 7]\n",
            "pair[0].direction",
        ),
        (
            "[[pair]]\nobjects = [0, 1]\ndirection_keys = [[0, 1, 0, 0, 9]]\n",
            "pair[0].direction_keys",
        ),
        (
            "[self_contact]\n[[self_contact.separated]]\nsides = [[\"a\"], [\"b\"], [\"c\"]]\n",
            "self_contact.separated[0].sides",
        ),
    ];
    for (text, field) in cases {
        let e = write_config(&dir, text).expect_err(text);
        assert!(matches!(e, ConfigError::Parse { .. }), "{text}: {e:?}");
        check_names(&e, &dir, field);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_numbers_are_invalid_and_name_the_field() {
    let dir = scene_dir("numbers");
    let cases = [
        ("[[object]]\nname = \"ball\"\nstiffness = nan\n", "object[0].stiffness"),
        ("[[object]]\nname = \"ball\"\nstiffness = -1.0\n", "object[0].stiffness"),
        ("[defaults]\nstiffness = 0\n", "defaults.stiffness"),
        ("[defaults]\nstiffness = -inf\n", "defaults.stiffness"),
        ("[defaults]\ntau = inf\n", "defaults.tau"),
        ("[defaults]\ngamma = nan\n", "defaults.gamma"),
        // A bulge outside [0, 10] times the lost volume: 1e300 overflowed the written
        // positions, -100 did not finish a frame in two minutes (2026-12-05).
        ("[defaults]\ngamma = 1e300\n", "defaults.gamma"),
        ("[defaults]\ngamma = -1\n", "defaults.gamma"),
        ("[[object]]\nname = \"ball\"\ngamma = 10.5\n", "object[0].gamma"),
        ("[defaults]\nomega = -0.5\n", "defaults.omega"),
        ("[defaults]\nextent = 0.0\n", "defaults.extent"),
        ("[defaults]\nextent_factor = -2\n", "defaults.extent_factor"),
        ("[defaults]\nextent = 1\nextent_factor = 0.5\n", "defaults.extent_factor"),
        ("passes = 0\n", "passes"),
        ("passes = 1000\n", "passes"),
        ("[[pair]]\nobjects = [0, 1]\ntau = nan\n", "pair[0].tau"),
        ("[[pair]]\nobjects = [0, 1]\nsafeguard_angle = -10\n", "pair[0].safeguard_angle"),
        ("[[pair]]\nobjects = [0, 1]\nsafeguard_angle = 180\n", "pair[0].safeguard_angle"),
        ("[[pair]]\nobjects = [0, 1]\nsafeguard_angle = inf\n", "pair[0].safeguard_angle"),
        ("[[pair]]\nobjects = [0, 1]\ndirection = [0, 0, 0]\n", "pair[0].direction"),
        (
            "[[pair]]\nobjects = [0, 1]\ndirection = [1e308, 1e308, 1e308]\n",
            "pair[0].direction",
        ),
        (
            "[[pair]]\nobjects = [0, 1]\ndirection_keys = [[0, 1e308, 1e308, 0]]\n",
            "pair[0].direction_keys[0]",
        ),
        (
            "[[pair]]\nobjects = [0, 1]\ndirection = [0, 0, 1]\ndirection_keys = [[0, 1, 0, 0]]\n",
            "pair[0].direction_keys",
        ),
        ("[[pair]]\nobjects = [0, 1]\ndirection_keys = []\n", "pair[0].direction_keys"),
        (
            "[[pair]]\nobjects = [0, 1]\ndirection_keys = [[0, 1, 0, 0], [1, 0, 0, 0]]\n",
            "pair[0].direction_keys[1]",
        ),
        (
            "[[pair]]\nobjects = [0, 1]\ndirection_keys = [[0, 1, 0, 0], [nan, 0, 1, 0]]\n",
            "pair[0].direction_keys[1]",
        ),
        (
            "[[pair]]\nobjects = [0, 1]\ndirection_keys = [[1, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 1]]\n",
            "pair[0].direction_keys[2]",
        ),
        ("[[object]]\nname = 0\nbulge_map = \"attribute:\"\n", "object[0].bulge_map"),
    ];
    for (text, field) in cases {
        let e = write_config(&dir, text).expect_err(text);
        assert!(matches!(e, ConfigError::Invalid { .. }), "{text}: {e:?}");
        check_names(&e, &dir, field);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unknown_and_duplicate_bodies_are_typed_errors() {
    let dir = scene_dir("names");
    let e = resolve(&dir, "[[object]]\nname = \"fingertip_1\"\n").expect_err("unknown");
    match &e {
        ConfigError::UnknownBody {
            name, available, ..
        } => {
            assert_eq!(name, "fingertip_1");
            assert!(available.contains("0 'ball'") && available.contains("3 'middle'"));
        }
        other => panic!("{other:?}"),
    }
    check_names(&e, &dir, "object[0].name");
    let e = resolve(&dir, "[[object]]\nname = 4\n").expect_err("index out of range");
    assert!(matches!(e, ConfigError::UnknownBody { .. }));
    let e = resolve(&dir, "[[pair]]\nobjects = [\"ball\", \"pinky\"]\n").expect_err("pair");
    assert!(matches!(e, ConfigError::UnknownBody { .. }));
    check_names(&e, &dir, "pair[0].objects[1]");
    // The same body by name and by index.
    let text = "[[object]]\nname = \"thumb\"\n[[object]]\nname = 1\n";
    let e = resolve(&dir, text).expect_err("duplicate");
    match &e {
        ConfigError::Duplicate { first, what, .. } => {
            assert_eq!(first, "object[0]");
            assert!(what.contains("thumb"));
        }
        other => panic!("{other:?}"),
    }
    check_names(&e, &dir, "object[1].name");
    let text = "[[pair]]\nobjects = [\"ball\", \"thumb\"]\n[[pair]]\nobjects = [\"thumb\", 0]\n";
    let e = resolve(&dir, text).expect_err("duplicate pair");
    assert!(matches!(e, ConfigError::Duplicate { .. }), "{e:?}");
    check_names(&e, &dir, "pair[1].objects");
    let e = resolve(&dir, "[[pair]]\nobjects = [\"ball\", 0]\n").expect_err("same body");
    assert!(matches!(e, ConfigError::Invalid { .. }));
    check_names(&e, &dir, "pair[0].objects");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bulge_map_files_must_stay_in_the_folder() {
    let dir = scene_dir("escape");
    let inner = dir.join("cfg");
    std::fs::create_dir_all(&inner).expect("dir");
    std::fs::write(dir.join("outside.txt"), zeros_map(1514)).expect("map");
    std::fs::write(inner.join("inside.txt"), zeros_map(1514)).expect("map");
    std::fs::copy(
        dir.join("fingertips_ball.glb"),
        inner.join("fingertips_ball.glb"),
    )
    .expect("copy");
    let object = |map: &str| format!("[[object]]\nname = \"ball\"\nbulge_map = '{map}'\n");
    resolve(&inner, &object("inside.txt")).expect("a sibling map is fine");
    resolve(&inner, &object("./inside.txt")).expect("./ is fine");
    let outside = dir.join("outside.txt");
    let absolute = outside.display().to_string();
    for bad in [
        "../outside.txt",
        "sub/../../outside.txt",
        absolute.as_str(),
        "C:/x.txt",
    ] {
        let e = resolve(&inner, &object(bad)).expect_err(bad);
        match &e {
            ConfigError::BulgeMap { map, message, .. } => {
                assert_eq!(map, bad);
                assert!(message.contains("folder"), "{message}");
            }
            other => panic!("{bad}: {other:?}"),
        }
        check_names(&e, &inner, "object[0].bulge_map");
    }
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&outside, inner.join("link.txt")).expect("symlink");
        let e = resolve(&inner, &object("link.txt")).expect_err("link out");
        assert!(matches!(e, ConfigError::BulgeMap { .. }), "{e:?}");
    }
    let e = resolve(&inner, &object("missing.txt")).expect_err("missing");
    assert!(matches!(e, ConfigError::BulgeMap { .. }), "{e:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bulge_map_values_are_counted_and_checked() {
    let dir = scene_dir("values");
    let object = "[[object]]\nname = \"ball\"\nbulge_map = \"map.txt\"\n";
    std::fs::write(dir.join("map.txt"), zeros_map(1513)).expect("map");
    let e = resolve(&dir, object).expect_err("count");
    match &e {
        ConfigError::BulgeCount {
            expected,
            got,
            body,
            ..
        } => assert_eq!((*expected, *got, body.as_str()), (1514, 1513, "ball")),
        other => panic!("{other:?}"),
    }
    check_names(&e, &dir, "object[0].bulge_map");
    for bad in ["nan", "inf", "-inf", "1e999", "zero"] {
        let mut text = zeros_map(1513);
        text.push_str(&format!("\n{bad}\n"));
        std::fs::write(dir.join("map.txt"), text).expect("map");
        let e = resolve(&dir, object).expect_err(bad);
        match &e {
            ConfigError::BulgeMap { message, .. } => assert!(message.contains("line"), "{message}"),
            other => panic!("{bad}: {other:?}"),
        }
        check_names(&e, &dir, "object[0].bulge_map");
    }
    std::fs::write(dir.join("map.txt"), zeros_map(1514)).expect("map");
    let (params, _, _) = resolve(&dir, object).expect("zeros are fine");
    assert!(params[0]
        .painted
        .as_ref()
        .expect("map")
        .iter()
        .all(|&v| v == 0.0));
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------------------------------------
// `attribute:NAME` maps, read from a small glTF built here

fn f32s(out: &mut Vec<u8>, v: &[f32]) {
    out.extend(v.iter().flat_map(|x| x.to_le_bytes()));
}

/// A skinned quad (4 vertices, two seam copies of one corner welded) with custom attributes:
/// `_BULGE` (SCALAR f32), `_SHADE` (SCALAR normalized u8), `_VEC` (VEC3 f32, ignored), `_RAW`
/// (SCALAR u8 not normalized, ignored).
fn attribute_gltf() -> Value {
    let mut b = Vec::new();
    // positions @0 (60: 5 vertices, the last a copy of vertex 0)
    f32s(
        &mut b,
        &[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0., 0., 0., 0.],
    );
    // joints u16 @60 (40), weights @100 (80)
    for _ in 0..5 {
        b.extend([0u16, 0, 0, 0].iter().flat_map(|x| x.to_le_bytes()));
    }
    for _ in 0..5 {
        f32s(&mut b, &[1., 0., 0., 0.]);
    }
    // indices u16 @180 (12)
    b.extend([4u16, 1, 2, 0, 2, 3].iter().flat_map(|x| x.to_le_bytes()));
    // ibm @192 (64)
    f32s(
        &mut b,
        &[
            1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
        ],
    );
    // _BULGE @256 (20), _VEC @276 (60), _SHADE u8 @336 (5, padded 8), _RAW u8 @344 (5, padded 8)
    f32s(&mut b, &[0.25, -1.0, 2.0, 0.5, 9.0]);
    f32s(&mut b, &[0.0; 15]);
    b.extend([0u8, 51, 102, 255, 0, 0, 0, 0]);
    b.extend([1u8, 2, 3, 4, 5, 0, 0, 0]);
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&b)
    );
    let view = |o: usize, l: usize| json!({"buffer": 0, "byteOffset": o, "byteLength": l});
    let acc = |v: usize, c: u32, n: usize, t: &str| json!({"bufferView": v, "componentType": c, "count": n, "type": t});
    let mut pos = acc(0, 5126, 5, "VEC3");
    pos["min"] = json!([0, 0, 0]);
    pos["max"] = json!([1, 1, 0]);
    let mut shade = acc(7, 5121, 5, "SCALAR");
    shade["normalized"] = json!(true);
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0, "skin": 0, "name": "quad"}, {"name": "root"}],
        "skins": [{"joints": [1], "inverseBindMatrices": 4}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0, "JOINTS_0": 1, "WEIGHTS_0": 2,
                           "_BULGE": 5, "_VEC": 6, "_SHADE": 7, "_RAW": 8},
            "indices": 3
        }]}],
        "accessors": [pos, acc(1, 5123, 5, "VEC4"), acc(2, 5126, 5, "VEC4"),
                      acc(3, 5123, 6, "SCALAR"), acc(4, 5126, 1, "MAT4"),
                      acc(5, 5126, 5, "SCALAR"), acc(6, 5126, 5, "VEC3"), shade,
                      acc(8, 5121, 5, "SCALAR")],
        "bufferViews": [view(0, 60), view(60, 40), view(100, 80), view(180, 12), view(192, 64),
                        view(256, 20), view(276, 60), view(336, 5), view(344, 5)],
        "buffers": [{"byteLength": b.len(), "uri": uri}]
    })
}

#[test]
fn attribute_maps_come_from_custom_gltf_attributes() {
    let dir = std::env::temp_dir().join(format!("cs-config-{}-attr", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    let gltf_path = dir.join("quad.gltf");
    std::fs::write(
        &gltf_path,
        serde_json::to_vec(&attribute_gltf()).expect("json"),
    )
    .expect("write");
    let rig = rig::load(&gltf_path).expect("custom attributes load");
    assert_eq!(
        rig.extra_attribute(0, "_BULGE"),
        Some(&[0.25, -1.0, 2.0, 0.5, 9.0][..])
    );
    let shade = rig
        .extra_attribute(0, "_SHADE")
        .expect("normalized u8 is read");
    assert!((shade[1] - 0.2).abs() < 1e-12 && shade[3] == 1.0);
    assert!(rig.extra_attribute(0, "_VEC").is_none());
    assert!(rig.extra_attribute(0, "_RAW").is_none());
    for ignored in ["_VEC", "_RAW"] {
        assert!(
            rig.warnings
                .iter()
                .any(|w| w.contains(ignored) && w.contains("ignored")),
            "{ignored}: {:?}",
            rig.warnings
        );
    }
    let welded: Vec<WeldedMesh> = rig
        .bodies
        .iter()
        .map(|b| WeldedMesh::weld(&b.positions, &b.triangles))
        .collect();
    assert_eq!(
        welded[0].vertex_count(),
        4,
        "the copy of vertex 0 is welded"
    );
    let path = dir.join("contact.toml");
    std::fs::write(
        &path,
        "[[object]]\nname = \"quad\"\nbulge_map = \"attribute:_BULGE\"\n",
    )
    .expect("write");
    let cfg = ContactConfig::load(&path).expect("parses");
    let (params, _, _) = cfg.resolve(&rig, &welded).expect("resolves");
    // Welded vertices take the value of their first file copy (vertex 0, not its copy 4).
    assert_eq!(
        params[0].painted.as_deref(),
        Some(&[0.25, -1.0, 2.0, 0.5][..])
    );
    std::fs::write(
        &path,
        "[[object]]\nname = 0\nbulge_map = \"attribute:_VEC\"\n",
    )
    .expect("write");
    let e = ContactConfig::load(&path)
        .expect("parses")
        .resolve(&rig, &welded)
        .expect_err("ignored attribute");
    match &e {
        ConfigError::UnknownAttribute {
            attribute,
            available,
            body,
            ..
        } => {
            assert_eq!((attribute.as_str(), body.as_str()), ("_VEC", "quad"));
            assert!(available.contains("_BULGE") && available.contains("_SHADE"));
        }
        other => panic!("{other:?}"),
    }
    assert!(e.to_string().starts_with(&path.display().to_string()));
    assert_eq!(e.field(), "object[0].bulge_map");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn non_finite_attribute_values_are_refused() {
    let dir = std::env::temp_dir().join(format!("cs-config-{}-attrnan", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    let mut doc = attribute_gltf();
    // Re-encode the buffer with a NaN in _BULGE (vertex 2).
    let uri = doc["buffers"][0]["uri"].as_str().expect("uri").to_string();
    let payload = uri.split(',').nth(1).expect("payload");
    let mut bytes = base64::engine::general_purpose::STANDARD
        .decode(payload)
        .expect("base64");
    bytes[264..268].copy_from_slice(&f32::NAN.to_le_bytes());
    doc["buffers"][0]["uri"] = json!(format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    ));
    std::fs::write(
        dir.join("quad.gltf"),
        serde_json::to_vec(&doc).expect("json"),
    )
    .expect("write");
    let rig = rig::load(&dir.join("quad.gltf")).expect("loads");
    let welded: Vec<WeldedMesh> = rig
        .bodies
        .iter()
        .map(|b| WeldedMesh::weld(&b.positions, &b.triangles))
        .collect();
    let cfg = ContactConfig::from_str_with_base(
        "[[object]]\nname = \"quad\"\nbulge_map = \"attribute:_BULGE\"\n",
        &dir,
    )
    .expect("parses");
    match cfg.resolve(&rig, &welded) {
        Err(ConfigError::BulgeMap { message, field, .. }) => {
            assert!(
                message.contains("vertex 2") && message.contains("not finite"),
                "{message}"
            );
            assert_eq!(field, "object[0].bulge_map");
        }
        other => panic!("{other:?}"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------------------------------------
// [self_contact]

use contact_skin::config::{SelfContactSettings, SelfDirection, SelfPairSpec};
use contact_skin::selfcontact::fold::FoldParams;
use contact_skin::selfcontact::pass::{DEFAULT_FOLD_PASSES, DEFAULT_MAX_FOLD_PASSES};
use contact_skin::selfcontact::DirectionSource;
use contact_skin::selfcontact::RegionOptions;

/// A copy of `rigs/mouth.glb` (body `lips`, joints `head` and `jaw`: one derived pair,
/// `lips/head-jaw`).
fn mouth_dir(name: &str) -> PathBuf {
    rig_dir("mouth", name)
}

fn load_mouth(dir: &Path) -> (Rig, Vec<WeldedMesh>) {
    load_rig_named(dir, "mouth")
}

fn resolve_self(dir: &Path, text: &str) -> Result<SelfContactSettings, ConfigError> {
    let cfg = write_config(dir, text)?;
    let (rig, welded) = load_mouth(dir);
    cfg.resolve_self_contact(&rig, &welded)
}

const SELF_FULL: &str = r#"
[defaults]
stiffness = 2.0                 # the object pass's, untouched by [self_contact]

[self_contact]
enabled = true
passes = 1
threshold = 0.1
grow_rings = 3
stiffness = 0.7                 # k̄ of the parent side
tau = 0.2
safeguard_angle = 75.5
extent_factor = 0.25
gamma = 0.5
omega = 1                       # an integer
separated_from_skeleton = false # on by default

[[self_contact.pair]]
name = "lips/head-jaw"
direction = [0.0, -2.0, 0]      # normalized on resolution
"#;

#[test]
fn the_self_contact_table_parses_and_resolves() {
    let dir = mouth_dir("self-full");
    let cfg = write_config(&dir, SELF_FULL).expect("parses");
    let spec = cfg.self_contact.as_ref().expect("table");
    assert_eq!(spec.enabled, Some(true));
    assert_eq!((spec.threshold, spec.grow_rings), (Some(0.1), Some(3)));
    assert_eq!(spec.omega, Some(1.0));
    assert_eq!(
        spec.pairs,
        vec![SelfPairSpec {
            name: "lips/head-jaw".into(),
            direction: Some(SelfDirection(DirectionSource::Fixed(Vector3::new(
                0.0, -2.0, 0.0
            )))),
            tau: None,
            gamma: None,
            omega: None,
            free_isolated_crease: None,
            enabled: None,
        }]
    );
    assert!(cfg.self_contact_enabled());
    assert!(cfg.self_contact_needs_pairs());
    let (rig, welded) = load_mouth(&dir);
    let settings = cfg.resolve_self_contact(&rig, &welded).expect("resolves");
    let size = contact_skin::config::rest_sizes(&rig)[0];
    let mut params = FoldParams {
        stiffness_1: 0.7,
        tau: 0.2,
        safeguard_angle: 75.5,
        joint_extent: None,
        ..Default::default()
    };
    params.deform.extent = 0.25 * size;
    params.deform.gamma = 0.5;
    params.deform.omega = 1.0;
    let expected = SelfContactSettings {
        enabled: true,
        regions: RegionOptions {
            threshold: 0.1,
            grow_rings: 3,
        },
        params,
        directions: vec![(
            "lips/head-jaw".into(),
            DirectionSource::Fixed(-Vector3::y()),
        )],
        pair_params: Vec::new(),
        pair_enabled: Vec::new(),
        passes: 1,
        max_passes: 1,
        separated: Vec::new(),
        separated_from_skeleton: false,
    };
    assert_eq!(settings, expected);
    // The same from the pairs given by the caller (as the pass lists them).
    let given = cfg
        .resolve_self_contact_with(&rig, &[(0, "lips/head-jaw".to_string())])
        .expect("resolves");
    assert_eq!(given, expected);
    // The object pass's parameters are not affected by the table.
    let (objects, _, _) = cfg.resolve(&rig, &welded).expect("object pass resolves");
    assert_eq!(objects[0].stiffness, 2.0);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `passes` is the sweep count (default 2); `max_passes` allows sweeps past it while a fold
/// still penetrates (default 6, none beyond a `passes` given alone), and alone bounds both; it
/// cannot be below `passes`.
#[test]
fn the_sweeps_are_a_count_and_a_bound() {
    let dir = mouth_dir("sweeps");
    for (text, passes, max) in [
        (
            "[self_contact]\n",
            DEFAULT_FOLD_PASSES,
            DEFAULT_MAX_FOLD_PASSES,
        ),
        ("[self_contact]\npasses = 3\n", 3, 3),
        ("[self_contact]\nmax_passes = 3\n", DEFAULT_FOLD_PASSES, 3),
        ("[self_contact]\nmax_passes = 1\n", 1, 1),
        ("[self_contact]\npasses = 1\nmax_passes = 5\n", 1, 5),
    ] {
        let s = resolve_self(&dir, text).expect(text);
        assert_eq!((s.passes, s.max_passes), (passes, max), "{text}");
    }
    for (text, field) in [
        (
            "[self_contact]\npasses = 3\nmax_passes = 2\n",
            "self_contact.max_passes",
        ),
        (
            "[self_contact]\nmax_passes = 0\n",
            "self_contact.max_passes",
        ),
        (
            "[self_contact]\nmax_passes = 100\n",
            "self_contact.max_passes",
        ),
    ] {
        let e = resolve_self(&dir, text).expect_err(text);
        assert!(e.to_string().contains(field), "{text}: {e}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `[[self_contact.separated]]` names joints of the rig, each once, on one side, and each
/// pair of sides once (in either order), else an error naming the file and the field (a
/// repeated pair was resolved twice per frame and a missing joint reported without the file
/// or field, found by review).
#[test]
fn separated_regions_are_checked_against_the_rig() {
    let dir = mouth_dir("separated");
    let table =
        |sides: &str| format!("[self_contact]\n[[self_contact.separated]]\nsides = {sides}\n");
    resolve_self(&dir, &table("[[\"head\"], [\"jaw\"]]")).expect("a valid pair");
    let twice = format!(
        "{}[[self_contact.separated]]\nsides = [[\"jaw\"], [\"head\"]]\n",
        table("[[\"head\"], [\"jaw\"]]")
    );
    for (text, field, message) in [
        (
            table("[[\"head\"], [\"nope\"]]"),
            "separated[0].sides[1]",
            "no node is named \"nope\"",
        ),
        (
            table("[[\"head\", \"head\"], [\"jaw\"]]"),
            "separated[0].sides[0]",
            "twice",
        ),
        (
            table("[[\"head\"], [\"head\"]]"),
            "separated[0].sides",
            "on both sides",
        ),
        (twice, "separated[1].sides", "separated[0]"),
    ] {
        let e = resolve_self(&dir, &text).expect_err(&text);
        let shown = e.to_string();
        assert!(
            shown.contains(field) && shown.contains(message),
            "{text}: {shown}"
        );
        assert!(shown.contains("contact.toml"), "{shown}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `turn_guard` is on by default and can be turned off.
#[test]
fn the_turn_guard_is_a_setting() {
    let dir = mouth_dir("turn-guard");
    let default = resolve_self(&dir, "[self_contact]\n").expect("resolves");
    assert!(default.params.turn_guard);
    let off = resolve_self(&dir, "[self_contact]\nturn_guard = false\n").expect("resolves");
    assert!(!off.params.turn_guard);
    assert!(resolve_self(&dir, "[self_contact]\nturn_guard = 1\n").is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `bulge_guard` is on by default and can be turned off.
#[test]
fn the_bulge_guard_is_a_setting() {
    let dir = mouth_dir("bulge-guard");
    let default = resolve_self(&dir, "[self_contact]\n").expect("resolves");
    assert!(default.params.bulge_guard);
    let off = resolve_self(&dir, "[self_contact]\nbulge_guard = false\n").expect("resolves");
    assert!(!off.params.bulge_guard);
    assert!(resolve_self(&dir, "[self_contact]\nbulge_guard = \"yes\"\n").is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `free_isolated_crease` is off by default and can be turned on for every pair or for one.
#[test]
fn freeing_isolated_crease_vertices_is_a_setting() {
    let dir = mouth_dir("free-crease");
    let default = resolve_self(&dir, "[self_contact]\n").expect("resolves");
    assert!(!default.params.free_isolated_crease);
    let on = resolve_self(&dir, "[self_contact]\nfree_isolated_crease = true\n").expect("resolves");
    assert!(on.params.free_isolated_crease);
    let pair = "[self_contact]\n[[self_contact.pair]]\nname = \"lips/head-jaw\"\n\
                free_isolated_crease = true\n";
    let own = resolve_self(&dir, pair).expect("resolves");
    assert!(!own.params.free_isolated_crease);
    assert_eq!(own.pair_params.len(), 1);
    assert_eq!(own.pair_params[0].0, "lips/head-jaw");
    assert!(own.pair_params[0].1.free_isolated_crease);
    // A pair can turn it off where the section turns it on.
    let off = "[self_contact]\nfree_isolated_crease = true\n[[self_contact.pair]]\n\
               name = \"lips/head-jaw\"\nfree_isolated_crease = false\n";
    let off = resolve_self(&dir, off).expect("resolves");
    assert!(off.params.free_isolated_crease);
    assert!(!off.pair_params[0].1.free_isolated_crease);
    assert!(resolve_self(&dir, "[self_contact]\nfree_isolated_crease = 1\n").is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `joint_extent` sets `φ̄` per joint (the default, 1.5); `extent` or `extent_factor` set it in
/// scene units for every joint instead.
#[test]
fn the_fold_extent_is_per_joint_unless_given_in_scene_units() {
    use contact_skin::selfcontact::fold::DEFAULT_JOINT_EXTENT;
    let dir = mouth_dir("joint-extent");
    let default = resolve_self(&dir, "[self_contact]\n").expect("resolves");
    assert_eq!(default.params.joint_extent, Some(DEFAULT_JOINT_EXTENT));
    let own = resolve_self(&dir, "[self_contact]\njoint_extent = 1.25\n").expect("resolves");
    assert_eq!(own.params.joint_extent, Some(1.25));
    let fixed = resolve_self(&dir, "[self_contact]\nextent = 0.3\n").expect("resolves");
    assert_eq!(fixed.params.joint_extent, None);
    assert_eq!(fixed.params.deform.extent, 0.3);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn without_a_self_contact_table_the_pass_defaults_apply() {
    let dir = mouth_dir("self-defaults");
    let defaults = SelfContactSettings {
        enabled: true,
        regions: RegionOptions::default(),
        params: FoldParams::default(),
        directions: Vec::new(),
        pair_params: Vec::new(),
        pair_enabled: Vec::new(),
        passes: DEFAULT_FOLD_PASSES,
        max_passes: DEFAULT_MAX_FOLD_PASSES,
        separated: Vec::new(),
        separated_from_skeleton: true,
    };
    // Without a table the pass is off (opt-in while experimental); an empty table turns it
    // on with the defaults.
    for (text, enabled) in [("# nothing\n", false), ("[self_contact]\n", true)] {
        let cfg = write_config(&dir, text).expect("parses");
        assert!(!cfg.self_contact_needs_pairs());
        let expected = SelfContactSettings {
            enabled,
            ..defaults.clone()
        };
        assert_eq!(resolve_self(&dir, text).expect("resolves"), expected);
    }
    let (rig, _) = load_mouth(&dir);
    assert_eq!(
        ContactConfig::default()
            .resolve_self_contact_with(&rig, &[])
            .expect("resolves"),
        SelfContactSettings {
            enabled: false,
            ..defaults
        }
    );
    let s = resolve_self(&dir, "[self_contact]\nextent = 0.2\n").expect("resolves");
    assert_eq!(s.params.deform.extent, 0.2);
    assert_eq!(s.params.stiffness_1, FoldParams::default().stiffness_1);
    let cfg = write_config(&dir, "[self_contact]\nenabled = false\n").expect("parses");
    assert!(!cfg.self_contact_enabled());
    assert!(
        !resolve_self(&dir, "[self_contact]\nenabled = false\n")
            .expect("resolves")
            .enabled
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_self_contact_values_are_typed_errors_naming_the_field() {
    let dir = mouth_dir("self-numbers");
    let pair = "[[self_contact.pair]]\nname = \"lips/head-jaw\"\n";
    let invalid = [
        (
            "[self_contact]\nthreshold = -0.1\n",
            "self_contact.threshold".to_string(),
        ),
        (
            "[self_contact]\nthreshold = 1.0\n",
            "self_contact.threshold".into(),
        ),
        (
            "[self_contact]\nthreshold = nan\n",
            "self_contact.threshold".into(),
        ),
        (
            "[self_contact]\ngrow_rings = 65\n",
            "self_contact.grow_rings".into(),
        ),
        ("[self_contact]\npasses = 0\n", "self_contact.passes".into()),
        (
            "[self_contact]\npasses = 17\n",
            "self_contact.passes".into(),
        ),
        (
            "[self_contact]\nstiffness = 1.5\n",
            "self_contact.stiffness".into(),
        ),
        (
            "[self_contact]\nstiffness = -0.1\n",
            "self_contact.stiffness".into(),
        ),
        (
            "[self_contact]\nstiffness = nan\n",
            "self_contact.stiffness".into(),
        ),
        ("[self_contact]\ntau = inf\n", "self_contact.tau".into()),
        (
            "[self_contact]\nsafeguard_angle = 0\n",
            "self_contact.safeguard_angle".into(),
        ),
        (
            "[self_contact]\nsafeguard_angle = 90.5\n",
            "self_contact.safeguard_angle".into(),
        ),
        (
            "[self_contact]\nsafeguard_angle = nan\n",
            "self_contact.safeguard_angle".into(),
        ),
        ("[self_contact]\nextent = 0\n", "self_contact.extent".into()),
        (
            "[self_contact]\nextent_factor = -1\n",
            "self_contact.extent_factor".into(),
        ),
        (
            "[self_contact]\nextent = 0.2\nextent_factor = 0.1\n",
            "self_contact.extent_factor".into(),
        ),
        ("[self_contact]\ngamma = nan\n", "self_contact.gamma".into()),
        (
            "[self_contact]\ngamma = -100\n",
            "self_contact.gamma".into(),
        ),
        ("[self_contact]\nomega = -1\n", "self_contact.omega".into()),
        (
            "[self_contact]\njoint_extent = 0\n",
            "self_contact.joint_extent".into(),
        ),
        (
            "[self_contact]\njoint_extent = 1.5\nextent = 0.2\n",
            "self_contact.joint_extent".into(),
        ),
        (
            "[self_contact]\njoint_extent = 1.5\nextent_factor = 0.1\n",
            "self_contact.joint_extent".into(),
        ),
    ];
    let with_pair = [
        ("gamma = inf\n", "self_contact.pair[0].gamma"),
        ("gamma = nan\n", "self_contact.pair[0].gamma"),
        ("gamma = 11\n", "self_contact.pair[0].gamma"),
        ("omega = -0.5\n", "self_contact.pair[0].omega"),
        ("tau = inf\n", "self_contact.pair[0].tau"),
        ("direction = [0, 0, 0]\n", "self_contact.pair[0].direction"),
        (
            "direction = [0, nan, 1]\n",
            "self_contact.pair[0].direction",
        ),
        (
            "direction = [inf, 0, 1]\n",
            "self_contact.pair[0].direction",
        ),
    ];
    let mut cases: Vec<(String, String)> = invalid
        .iter()
        .map(|(t, f)| (t.to_string(), f.clone()))
        .collect();
    for (d, f) in with_pair {
        cases.push((format!("{pair}{d}"), f.into()));
    }
    cases.push((
        "[[self_contact.pair]]\nname = \" \"\ndirection = [0, 1, 0]\n".into(),
        "self_contact.pair[0].name".into(),
    ));
    for (text, field) in &cases {
        let e = write_config(&dir, text).expect_err(text);
        assert!(matches!(e, ConfigError::Invalid { .. }), "{text}: {e:?}");
        check_names(&e, &dir, field);
    }
    // Wrong types, unknown or missing fields are parse errors naming the field.
    let parse = [
        ("[self_contact]\nbogus = 1\n", "self_contact.bogus"),
        (
            "[self_contact]\ngrow_rings = -1\n",
            "self_contact.grow_rings",
        ),
        ("[self_contact]\nenabled = 1\n", "self_contact.enabled"),
        (
            "[self_contact]\nthreshold = \"low\"\n",
            "self_contact.threshold",
        ),
        (
            "[[self_contact.pair]]\nname = \"lips/head-jaw\"\ndirection = [0, 1]\n",
            "self_contact.pair[0].direction",
        ),
        (
            "[[self_contact.pair]]\nname = \"lips/head-jaw\"\ndirection = [0, 1, 0]\nstiffness = 1\n",
            "self_contact.pair[0].stiffness",
        ),
        (
            "[[self_contact.pair]]\nname = \"lips/head-jaw\"\ngamma = \"none\"\n",
            "self_contact.pair[0].gamma",
        ),
    ];
    for (text, field) in parse {
        let e = write_config(&dir, text).expect_err(text);
        assert!(matches!(e, ConfigError::Parse { .. }), "{text}: {e:?}");
        check_names(&e, &dir, field);
    }
    // A pair that sets nothing is an error (a forgotten key), naming the pair.
    let e = write_config(&dir, "[[self_contact.pair]]\nname = \"lips/head-jaw\"\n")
        .expect_err("a pair that sets nothing");
    assert!(matches!(e, ConfigError::Invalid { .. }), "{e:?}");
    check_names(&e, &dir, "self_contact.pair[0]");
    for key in ["direction", "tau", "gamma", "omega"] {
        assert!(e.to_string().contains(key), "{e}");
    }
    // The same pair twice.
    let text = format!("{pair}direction = [0, 1, 0]\n{pair}direction = [0, -1, 0]\n");
    let e = write_config(&dir, &text).expect_err("duplicate");
    match &e {
        ConfigError::Duplicate { what, first, .. } => {
            assert!(what.contains("lips/head-jaw"), "{what}");
            assert_eq!(first, "self_contact.pair[0]");
        }
        other => panic!("{other:?}"),
    }
    check_names(&e, &dir, "self_contact.pair[1].name");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A pair's own `τ`, `γ`, `ω` (without a direction): the section's parameters with those
/// replaced, for that pair only; its direction stays the section's mode.
#[test]
fn a_pair_sets_its_own_bulge_and_threshold() {
    let dir = mouth_dir("self-pair-params");
    let cfg = write_config(
        &dir,
        "[self_contact]\ndirection = \"motion\"\ngamma = 0.8\njoint_extent = 2.0\n\
         [[self_contact.pair]]\nname = \"lips/head-jaw\"\ngamma = 0.0\ntau = 0.5\n",
    )
    .expect("parses");
    let (rig, _) = load_mouth(&dir);
    let derived = [
        (0, "lips/head-jaw".to_string()),
        (0, "lips/other-pair".to_string()),
    ];
    let s = cfg
        .resolve_self_contact_with(&rig, &derived)
        .expect("resolves");
    assert_eq!(s.params.deform.gamma, 0.8);
    let mut expected = s.params;
    expected.deform.gamma = 0.0;
    expected.tau = 0.5;
    assert_eq!(s.pair_params, vec![("lips/head-jaw".to_string(), expected)]);
    assert_eq!(
        s.pair_params[0].1.joint_extent,
        Some(2.0),
        "the section's extent"
    );
    assert_eq!(
        s.directions,
        vec![
            ("lips/head-jaw".to_string(), DirectionSource::Motion),
            ("lips/other-pair".to_string(), DirectionSource::Motion),
        ]
    );
    // A direction alone gives no parameters of its own.
    let cfg = write_config(
        &dir,
        "[[self_contact.pair]]\nname = \"lips/head-jaw\"\ndirection = [0, 1, 0]\n",
    )
    .expect("parses");
    let s = cfg
        .resolve_self_contact_with(&rig, &derived)
        .expect("resolves");
    assert!(s.pair_params.is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `"skeleton"` and `"motion"` per pair, `[self_contact] direction` as the other pairs'
/// default; anything else is an error naming the field.
#[test]
fn self_contact_direction_modes_parse_and_resolve() {
    let dir = mouth_dir("self-modes");
    let cfg = write_config(
        &dir,
        "[self_contact]\ndirection = \"motion\"\n[[self_contact.pair]]\nname = \"lips/head-jaw\"\ndirection = \"skeleton\"\n",
    )
    .expect("parses");
    let (rig, welded) = load_mouth(&dir);
    let derived = [
        (0, "lips/head-jaw".to_string()),
        (0, "lips/other-pair".to_string()),
    ];
    let settings = cfg
        .resolve_self_contact_with(&rig, &derived)
        .expect("resolves");
    assert_eq!(
        settings.directions,
        vec![
            ("lips/head-jaw".to_string(), DirectionSource::Skeleton),
            ("lips/other-pair".to_string(), DirectionSource::Motion),
        ]
    );
    // Per pair, or for every pair from the section alone (which `pose` once left unapplied:
    // without a pair named, the pairs were not derived and the mode reached none of them).
    for text in [
        "[[self_contact.pair]]\nname = \"lips/head-jaw\"\ndirection = \"motion\"\n",
        "[self_contact]\ndirection = \"motion\"\n",
    ] {
        let cfg = write_config(&dir, text).expect("parses");
        assert!(cfg.self_contact_needs_pairs(), "{text}");
        let settings = cfg.resolve_self_contact(&rig, &welded).expect("resolves");
        assert_eq!(
            settings.directions,
            vec![("lips/head-jaw".to_string(), DirectionSource::Motion)],
            "{text}"
        );
    }
    for (text, field) in [
        (
            "[[self_contact.pair]]\nname = \"lips/head-jaw\"\ndirection = \"sideways\"\n",
            "self_contact.pair[0].direction",
        ),
        (
            "[[self_contact.pair]]\nname = \"lips/head-jaw\"\ndirection = [0, 1, 0, 1]\n",
            "self_contact.pair[0].direction",
        ),
        (
            "[self_contact]\ndirection = \"up\"\n",
            "self_contact.direction",
        ),
    ] {
        let e = write_config(&dir, text).expect_err(text);
        assert!(matches!(e, ConfigError::Parse { .. }), "{text}: {e:?}");
        check_names(&e, &dir, field);
    }
    let e = write_config(&dir, "[self_contact]\ndirection = [0, 1, 0]\n").expect_err("vector");
    assert!(matches!(e, ConfigError::Invalid { .. }), "{e:?}");
    check_names(&e, &dir, "self_contact.direction");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_unknown_pair_name_lists_the_derived_pairs() {
    let dir = mouth_dir("self-unknown");
    let text = "[[self_contact.pair]]\nname = \"lips/jaw-head\"\ndirection = [0, 1, 0]\n";
    let e = resolve_self(&dir, text).expect_err("unknown pair");
    match &e {
        ConfigError::UnknownPair {
            name, available, ..
        } => {
            assert_eq!(name, "lips/jaw-head");
            assert_eq!(available, "lips/head-jaw");
        }
        other => panic!("{other:?}"),
    }
    check_names(&e, &dir, "self_contact.pair[0].name");
    assert!(e.to_string().contains("lips/head-jaw"), "{e}");
    // A rig without joint pairs (separate rigid bodies): none to choose from.
    let dir2 = scene_dir("self-none");
    let cfg = write_config(&dir2, text).expect("parses");
    let (rig, welded) = load_rig(&dir2);
    let e = cfg
        .resolve_self_contact(&rig, &welded)
        .expect_err("no pairs");
    match &e {
        ConfigError::UnknownPair { available, .. } => assert_eq!(available, "none"),
        other => panic!("{other:?}"),
    }
    check_names(&e, &dir2, "self_contact.pair[0].name");
    // Derivation errors (a threshold selecting nothing is fine: no pair, so unknown).
    let e = resolve_self(
        &dir,
        "[self_contact]\nthreshold = 0.999\n[[self_contact.pair]]\nname = \"lips/head-jaw\"\ndirection = [0, 1, 0]\n",
    )
    .expect_err("no pair above the threshold");
    assert!(matches!(e, ConfigError::UnknownPair { .. }), "{e:?}");
    for d in [&dir, &dir2] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn separated_regions_are_read_and_checked() {
    let dir = mouth_dir("self-separated");
    let text = "[[self_contact.separated]]\nsides = [[\"jaw\"], [\"head\", \"rig\"]]\n";
    let cfg = write_config(&dir, text).expect("parses");
    let (rig, welded) = load_mouth(&dir);
    let settings = cfg.resolve_self_contact(&rig, &welded).expect("resolves");
    let jaw = vec!["jaw".to_owned()];
    let head = vec!["head".to_owned(), "rig".to_owned()];
    assert_eq!(settings.separated, vec![[jaw, head]]);
    // An empty side is named by its field; a table without `sides` does not parse.
    let empty = write_config(
        &dir,
        "[[self_contact.separated]]\nsides = [[], [\"head\"]]\n",
    )
    .expect("parses");
    let err = empty
        .resolve_self_contact(&rig, &welded)
        .expect_err("empty side");
    assert!(
        err.to_string()
            .contains("self_contact.separated[0].sides[0]"),
        "{err}"
    );
    assert!(write_config(&dir, "[[self_contact.separated]]\n").is_err());
    assert!(write_config(&dir, "[[self_contact.separated]]\nsides = [[\"jaw\"]]\n").is_err());
}

/// A configuration or a bulge map that is not a regular file is refused before it is read: a
/// FIFO would block the read for ever, a device such as `/dev/zero` reports no size and never
/// ends (both hung `info` and `pose` until 2026-12-05).
#[cfg(unix)]
#[test]
fn fifos_and_devices_are_not_read() {
    let dir = scene_dir("fifo");
    let mkfifo = |name: &str| {
        std::process::Command::new("mkfifo")
            .arg(dir.join(name))
            .status()
            .is_ok_and(|s| s.success())
    };
    if !mkfifo("config.toml") || !mkfifo("map.txt") {
        println!("mkfifo unavailable: skipped");
        return;
    }
    let not_regular = |e: ConfigError| {
        assert!(
            matches!(e, ConfigError::Io { .. }) && format!("{e} {e:?}").contains("not a regular"),
            "{e:?}"
        )
    };
    not_regular(ContactConfig::load(&dir.join("config.toml")).expect_err("a FIFO"));
    not_regular(ContactConfig::load(Path::new("/dev/zero")).expect_err("a device"));
    let e = resolve(&dir, "[[object]]\nname = 0\nbulge_map = \"map.txt\"\n").expect_err("a FIFO");
    assert!(e.to_string().contains("not a regular file"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
