//! The procedural scenes of `rigs/`: every scene loads back, every body is a closed oriented
//! 2-manifold whose volume matches its primitive, the skin data is clean, the animation
//! starts at rest and ends in interpenetration, the output is deterministic, and the
//! committed `rigs/*.glb` files are exactly what the generator writes.

use contact_skin::rig::{self, Body, Rig};
use contact_skin::scenes::{
    self, Scene, SceneError, DEFAULT_RESOLUTION, MAX_RESOLUTION, MIN_RESOLUTION,
};
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A resolution below the default, to check growth and convergence.
const LOW: u32 = 4;

fn load(scene: Scene, resolution: u32) -> Rig {
    let bytes = scenes::build_glb(scene, resolution).expect("build");
    rig::load_from_bytes(Path::new(scene.name()), &bytes).expect("load back")
}

fn expected_bodies(scene: Scene) -> &'static [&'static str] {
    match scene {
        Scene::BendingCapsule => &["capsule"],
        Scene::Finger | Scene::FingerLong => &["finger"],
        Scene::Mouth => &["lips"],
        Scene::CapsulePair => &["capsule_lower", "capsule_upper"],
        Scene::FingertipsOnBall => &["ball", "thumb", "index", "middle"],
        Scene::SphereOnPlane => &["plane", "sphere"],
        Scene::TwoFingers => &["fingers"],
    }
}

fn expected_animations(scene: Scene) -> &'static [&'static str] {
    match scene {
        Scene::BendingCapsule => &["bend", "twist"],
        Scene::Finger | Scene::FingerLong => &["flex"],
        Scene::Mouth => &["close"],
        Scene::CapsulePair | Scene::SphereOnPlane | Scene::TwoFingers => &["press"],
        Scene::FingertipsOnBall => &["squeeze"],
    }
}

/// Welds exactly coincident positions (the files repeat seam vertices bit for bit).
fn weld(positions: &[Point3<f64>]) -> Vec<u32> {
    let mut ids: HashMap<[u64; 3], u32> = HashMap::new();
    positions
        .iter()
        .map(|p| {
            let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
            let next = ids.len() as u32;
            *ids.entry(key).or_insert(next)
        })
        .collect()
}

/// Checks that the welded triangles form a closed, consistently oriented 2-manifold: every
/// directed edge occurs exactly once and its reverse exactly once; no degenerate triangle.
fn assert_closed_oriented(label: &str, body: &Body) {
    let w = weld(&body.positions);
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for t in &body.triangles {
        let [a, b, c] = t.map(|i| w[i as usize]);
        assert!(
            a != b && b != c && c != a,
            "{label}: degenerate triangle {t:?}"
        );
        for e in [(a, b), (b, c), (c, a)] {
            *directed.entry(e).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(n, 1, "{label}: directed edge ({a},{b}) used {n} times");
        assert_eq!(
            directed.get(&(b, a)),
            Some(&1),
            "{label}: edge ({a},{b}) has no opposite half"
        );
    }
    let used: std::collections::HashSet<u32> = body
        .triangles
        .iter()
        .flatten()
        .map(|&i| w[i as usize])
        .collect();
    let welded = w.iter().copied().max().map_or(0, |m| m as usize + 1);
    assert_eq!(used.len(), welded, "{label}: isolated vertices");
}

fn volume(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> f64 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize].coords);
            a.dot(&b.cross(&c)) / 6.0
        })
        .sum()
}

fn relative_volume_error(scene: Scene, resolution: u32) -> Vec<f64> {
    let rig = load(scene, resolution);
    let summary = scenes::summarize(scene, resolution).expect("summary");
    rig.bodies
        .iter()
        .zip(&summary)
        .map(|(b, s)| {
            assert_eq!(b.name, s.name);
            let v = volume(&b.positions, &b.triangles);
            assert!(v > 0.0, "{scene} {}: volume {v} not positive", b.name);
            (s.analytic_volume - v) / s.analytic_volume
        })
        .collect()
}

#[test]
fn bodies_are_closed_oriented_manifolds() {
    for scene in Scene::ALL {
        for resolution in [MIN_RESOLUTION, LOW, DEFAULT_RESOLUTION] {
            let rig = load(scene, resolution);
            let names: Vec<&str> = rig.bodies.iter().map(|b| b.name.as_str()).collect();
            assert_eq!(names, expected_bodies(scene), "{scene}");
            for body in &rig.bodies {
                assert_closed_oriented(&format!("{scene}@{resolution} {}", body.name), body);
            }
        }
    }
}

#[test]
fn volumes_match_the_primitives_and_converge() {
    for scene in Scene::ALL {
        let coarse = relative_volume_error(scene, LOW);
        let fine = relative_volume_error(scene, DEFAULT_RESOLUTION);
        for (c, f) in coarse.iter().zip(&fine) {
            // Inscribed polyhedra: never larger than the smooth primitive (the slab is exact).
            assert!(
                *c > -1e-6 && *f > -1e-6,
                "{scene}: mesh larger than its primitive ({c}, {f})"
            );
            assert!(
                *f < 0.03,
                "{scene}: volume off by {:.2}% at the default resolution",
                100.0 * f
            );
            assert!(
                *f <= *c + 1e-9,
                "{scene}: volume error grows with resolution ({c} -> {f})"
            );
        }
    }
}

#[test]
fn vertex_count_grows_with_resolution() {
    for scene in Scene::ALL {
        let count = |r| load(scene, r).vertex_count();
        let (a, b, c) = (count(MIN_RESOLUTION), count(LOW), count(DEFAULT_RESOLUTION));
        assert!(a < b && b < c, "{scene}: {a} {b} {c}");
    }
}

/// Raw accessor checks (the loader renormalizes, so read the file itself): unit normals
/// pointing out of the surface, weights summing to 1, joints within the skin.
#[test]
fn raw_attributes_are_clean() {
    for scene in Scene::ALL {
        let bytes = scenes::build_glb(scene, LOW).expect("build");
        let gltf = gltf::Gltf::from_slice(&bytes).expect("parse");
        let blob = gltf.blob.as_deref();
        for node in gltf.nodes().filter(|n| n.mesh().is_some()) {
            let (Some(mesh), Some(skin)) = (node.mesh(), node.skin()) else {
                panic!("{scene}: mesh node without skin");
            };
            assert!(
                has_identity_transform(&node),
                "{scene}: mesh node has a transform"
            );
            let joints = skin.joints().count();
            for prim in mesh.primitives() {
                let r = prim.reader(|_| blob);
                let pos: Vec<[f32; 3]> = r.read_positions().expect("POSITION").collect();
                let nrm: Vec<[f32; 3]> = r.read_normals().expect("NORMAL").collect();
                let idx: Vec<u32> = r.read_indices().expect("indices").into_u32().collect();
                let w: Vec<[f32; 4]> = r.read_weights(0).expect("WEIGHTS_0").into_f32().collect();
                let j: Vec<[u16; 4]> = r.read_joints(0).expect("JOINTS_0").into_u16().collect();
                assert!(matches!(
                    r.read_indices(),
                    Some(gltf::mesh::util::ReadIndices::U32(_))
                ));
                assert_eq!(
                    (nrm.len(), w.len(), j.len()),
                    (pos.len(), pos.len(), pos.len())
                );
                let geo = face_normals(&pos, &idx);
                for v in 0..pos.len() {
                    let n = Vector3::from(nrm[v].map(f64::from));
                    assert!(
                        (n.norm() - 1.0).abs() < 1e-5,
                        "{scene}: normal {v} not unit"
                    );
                    assert!(
                        n.dot(&geo[v]) > 0.9,
                        "{scene}: normal {v} disagrees with the faces"
                    );
                    let sum: f32 = w[v].iter().sum();
                    assert!(
                        (sum - 1.0).abs() < 1e-6,
                        "{scene}: weights of {v} sum to {sum}"
                    );
                    for k in 0..4 {
                        assert!(w[v][k] >= 0.0 && (j[v][k] as usize) < joints);
                    }
                }
            }
        }
    }
}

/// The glTF rule that skinned mesh nodes carry no transform of their own.
fn has_identity_transform(node: &gltf::Node) -> bool {
    let id = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    node.transform().matrix() == id
}

/// Area-weighted normals of each file vertex from its own triangles (no welding).
fn face_normals(pos: &[[f32; 3]], idx: &[u32]) -> Vec<Vector3<f64>> {
    let p: Vec<Vector3<f64>> = pos
        .iter()
        .map(|x| Vector3::from(x.map(f64::from)))
        .collect();
    let mut n = vec![Vector3::zeros(); p.len()];
    for t in idx.chunks_exact(3) {
        let (a, b, c) = (p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
        let f = (b - a).cross(&(c - a));
        for &i in t {
            n[i as usize] += f;
        }
    }
    n.into_iter().map(|x| x.normalize()).collect()
}

#[test]
fn loads_without_warnings_and_with_named_animations() {
    for scene in Scene::ALL {
        let rig = load(scene, LOW);
        assert!(rig.warnings.is_empty(), "{scene}: {:?}", rig.warnings);
        let names: Vec<&str> = rig
            .animations
            .iter()
            .filter_map(|a| a.name.as_deref())
            .collect();
        assert_eq!(names, expected_animations(scene), "{scene}");
        for a in &rig.animations {
            assert!(
                a.duration() >= 2.0 && a.duration() <= 4.0,
                "{scene}: duration {}",
                a.duration()
            );
            assert!(a
                .channels
                .iter()
                .all(|c| c.interpolation == rig::Interpolation::Linear));
        }
    }
}

/// Skinned (linear blend) positions of `body` in `pose`.
fn skinned(rig: &Rig, body: &Body, pose: &rig::Pose) -> Vec<Point3<f64>> {
    let mats = pose.skin_matrices(&rig.skins[body.skin]);
    (0..body.vertex_count())
        .map(|v| {
            let h = body.positions[v].to_homogeneous();
            let sum = body
                .weights
                .row(v)
                .fold(nalgebra::Vector4::zeros(), |acc, (j, w)| {
                    acc + mats[j] * h * w
                });
            Point3::from_homogeneous(sum).expect("affine")
        })
        .collect()
}

#[test]
fn animations_start_at_the_rest_pose() {
    for scene in Scene::ALL {
        let rig = load(scene, LOW);
        for a in 0..rig.animations.len() {
            let pose = rig.pose_at(Some(a), rig.animations[a].start);
            for body in &rig.bodies {
                let posed = skinned(&rig, body, &pose);
                let err = posed
                    .iter()
                    .zip(&body.positions)
                    .map(|(p, q)| (p - q).norm())
                    .fold(0.0, f64::max);
                assert!(
                    err < 1e-5,
                    "{scene} {}: rest pose moved by {err}",
                    body.name
                );
            }
        }
    }
}

/// Generalized winding number of `p` with respect to a closed triangle mesh.
fn winding_number(p: &Point3<f64>, pos: &[Point3<f64>], tris: &[[u32; 3]]) -> f64 {
    let mut total = 0.0;
    for t in tris {
        let [a, b, c] = t.map(|i| pos[i as usize] - p);
        let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
        let num = a.dot(&b.cross(&c));
        let den = la * lb * lc + a.dot(&b) * lc + b.dot(&c) * la + c.dot(&a) * lb;
        total += 2.0 * num.atan2(den);
    }
    total / (4.0 * std::f64::consts::PI)
}

/// Area-weighted normals over the welded surface (a box corner gets the diagonal), copied
/// back to every file vertex.
fn vertex_normals(pos: &[Point3<f64>], tris: &[[u32; 3]]) -> Vec<Vector3<f64>> {
    let w = weld(pos);
    let mut acc = vec![Vector3::zeros(); pos.len()];
    for t in tris {
        let [a, b, c] = t.map(|i| pos[i as usize]);
        let f = (b - a).cross(&(c - a));
        for &i in t {
            acc[w[i as usize] as usize] += f;
        }
    }
    w.iter().map(|&i| acc[i as usize].normalize()).collect()
}

/// Vertices of the posed bodies lying inside some body: for another body, winding number of
/// the vertex ≥ 0.5; for its own body, winding number of the vertex nudged 0.05 h inward ≥ 1.5
/// (the measure of `MEASURING.md`).
fn penetrating_vertices(rig: &Rig, pose: &rig::Pose, h: f64) -> Vec<usize> {
    use rayon::prelude::*;
    let posed: Vec<Vec<Point3<f64>>> = rig.bodies.iter().map(|b| skinned(rig, b, pose)).collect();
    let inside = |i: usize, p: &Point3<f64>, n: &Vector3<f64>| {
        let in_other = rig
            .bodies
            .iter()
            .enumerate()
            .any(|(k, other)| k != i && winding_number(p, &posed[k], &other.triangles) >= 0.5);
        in_other || winding_number(&(p - n * 0.05 * h), &posed[i], &rig.bodies[i].triangles) >= 1.5
    };
    (0..rig.bodies.len())
        .map(|i| {
            let normals = vertex_normals(&posed[i], &rig.bodies[i].triangles);
            let hits = posed[i]
                .par_iter()
                .zip(&normals)
                .filter(|(p, n)| inside(i, p, n));
            hits.count()
        })
        .collect()
}

#[test]
fn animations_drive_the_bodies_into_contact() {
    for scene in Scene::ALL {
        let rig = load(scene, DEFAULT_RESOLUTION);
        let h = scene.edge_length(DEFAULT_RESOLUTION);
        let rest = penetrating_vertices(&rig, &rig.pose_at(None, 0.0), h);
        assert!(
            rest.iter().all(|&c| c == 0),
            "{scene}: interpenetration at rest {rest:?}"
        );
        for (a, anim) in rig.animations.iter().enumerate() {
            if anim.name.as_deref() == Some("twist") {
                continue; // the twist collapses the joint, it does not bring parts into contact
            }
            let end = penetrating_vertices(&rig, &rig.pose_at(Some(a), anim.end), h);
            assert!(
                end.iter().all(|&c| c >= 10),
                "{scene}: too little interpenetration at the end {end:?}"
            );
        }
    }
}

#[test]
fn output_is_deterministic() {
    for scene in Scene::ALL {
        let a = scenes::build_glb(scene, LOW).expect("build");
        let b = scenes::build_glb(scene, LOW).expect("build");
        assert!(a == b, "{scene}: two builds differ");
    }
}

fn rigs_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("rigs")
}

#[test]
fn committed_rigs_match_the_generator() {
    for scene in Scene::ALL {
        let path = rigs_dir().join(format!("{}.glb", scene.name()));
        let committed = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(
            committed.len() < 1_500_000,
            "{}: {} bytes",
            path.display(),
            committed.len()
        );
        let rig = rig::load(&path).expect("committed rig loads");
        assert_eq!(rig.bodies.len(), expected_bodies(scene).len());
        let fresh = scenes::build_glb(scene, DEFAULT_RESOLUTION).expect("build");
        assert!(
            committed == fresh,
            "{} is stale: run `cargo run --release --example generate_rigs`",
            path.display()
        );
    }
}

#[test]
fn bad_resolutions_are_errors() {
    for scene in Scene::ALL {
        for r in [0, MAX_RESOLUTION + 1, u32::MAX] {
            assert!(
                matches!(scenes::build_glb(scene, r), Err(SceneError::Resolution(x)) if x == r)
            );
            assert!(scenes::summarize(scene, r).is_err());
        }
    }
    let dir = std::env::temp_dir().join(format!("contact_skin_scenes_bad_{}", std::process::id()));
    assert!(matches!(
        scenes::write_all(0, &dir),
        Err(SceneError::Resolution(0))
    ));
    assert!(!dir.exists(), "nothing may be written for a bad resolution");
}

#[test]
fn write_all_writes_every_scene() {
    let dir = std::env::temp_dir().join(format!("contact_skin_scenes_{}", std::process::id()));
    let paths = scenes::write_all(2, &dir).expect("write_all");
    assert_eq!(paths.len(), Scene::ALL.len());
    for (scene, path) in Scene::ALL.iter().zip(&paths) {
        assert_eq!(path, &dir.join(format!("{}.glb", scene.name())));
        let bytes = std::fs::read(path).expect("read back");
        assert!(bytes == scenes::build_glb(*scene, 2).expect("build"));
    }
    std::fs::remove_dir_all(&dir).expect("clean up");
}

#[test]
fn names_and_descriptions() {
    for scene in Scene::ALL {
        assert_eq!(Scene::from_name(scene.name()), Some(scene));
        assert!(!scene.description().is_empty());
        assert!(scene.reference_length() > 0.0);
    }
    assert_eq!(Scene::from_name("teapot"), None);
}
