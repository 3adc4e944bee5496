//! The `pose` command's output contract (MEASURING.md): one OBJ per frame with the file's exact
//! vertex order and faces, bit-identical whatever the thread count; a baked glb whose morph
//! targets replay the same frames; the input is never overwritten.

use contact_skin::frames::{self, Precomputed};
use contact_skin::rig;
use contact_skin::skinning::Method;
use std::path::{Path, PathBuf};
use std::process::Command;

fn samples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-samples")
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cs-pose-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn pose(args: &[&str]) -> std::process::Output {
    let out = Command::new(env!("CARGO_BIN_EXE_contact-skin"))
        .args(args)
        .output()
        .expect("run contact-skin");
    assert!(
        out.status.success(),
        "contact-skin {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Parses the `v` lines of an OBJ.
fn obj_vertices(text: &str) -> Vec<[f64; 3]> {
    text.lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .map(|x| x.parse().expect("number"))
                .collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

fn obj_faces(text: &str) -> Vec<[usize; 3]> {
    text.lines()
        .filter_map(|l| l.strip_prefix("f "))
        .map(|l| {
            let v: Vec<usize> = l
                .split_whitespace()
                .map(|x| x.parse().expect("index"))
                .collect();
            [v[0] - 1, v[1] - 1, v[2] - 1]
        })
        .collect()
}

#[test]
fn obj_frames_follow_the_contract_and_do_not_depend_on_threads() {
    let rig_path = samples().join("CesiumMan/CesiumMan.glb");
    let (a, b) = (tmp("t1"), tmp("t2"));
    let ra = rig_path.to_str().expect("utf8");
    for (dir, threads) in [(&a, "1"), (&b, "2")] {
        pose(&[
            "--threads",
            threads,
            "pose",
            ra,
            "--out",
            dir.to_str().expect("utf8"),
            "--frames",
            "7",
            "--skinning",
            "dqs",
        ]);
    }
    let rig = rig::load(&rig_path).expect("load");
    let pre = Precomputed::new(&rig, Method::Dqs);
    let times = frames::sample_times(&rig, Some(0), Some(7));
    for (i, &t) in times.iter().enumerate() {
        let name = format!("frame_{i:04}.obj");
        let (fa, fb) = (
            std::fs::read(a.join(&name)).expect("frame"),
            std::fs::read(b.join(&name)).expect("frame"),
        );
        assert_eq!(fa, fb, "{name} differs between 1 and 2 threads");
        let text = String::from_utf8(fa).expect("utf8");
        let verts = obj_vertices(&text);
        let frame = frames::evaluate(&rig, &pre, Some(0), i, t);
        let posed: Vec<_> = frame
            .bodies
            .iter()
            .flat_map(|b| b.positions.iter())
            .collect();
        assert_eq!(
            verts.len(),
            rig.vertex_count(),
            "every file vertex, seams included"
        );
        for (v, p) in verts.iter().zip(&posed) {
            for c in 0..3 {
                assert!(
                    (v[c] - p[c]).abs() <= 1e-6 * (1.0 + p[c].abs()),
                    "written value drifted"
                );
            }
        }
        let faces = obj_faces(&text);
        let expected: Vec<[usize; 3]> = rig.bodies[0]
            .triangles
            .iter()
            .map(|t| t.map(|i| i as usize))
            .collect();
        assert_eq!(faces, expected, "faces are the file's, in order");
    }
    assert!(!a.join(format!("frame_{:04}.obj", times.len())).exists());
    let _ = std::fs::remove_dir_all(&a);
    let _ = std::fs::remove_dir_all(&b);
}

#[test]
fn baked_glb_replays_the_frames() {
    use contact_skin::rig::accessor::{read, Source};
    let rig_path = samples().join("RiggedFigure/RiggedFigure.glb");
    let out = tmp("glb");
    pose(&[
        "pose",
        rig_path.to_str().expect("utf8"),
        "--out",
        out.to_str().expect("utf8"),
        "--frames",
        "5",
        "--format",
        "glb",
        "--json",
    ]);
    let bytes = std::fs::read(out.join("RiggedFigure.baked.glb")).expect("baked glb");
    let gltf = gltf::Gltf::from_slice(&bytes).expect("valid glTF");
    let blob = gltf.blob.clone().expect("binary chunk");
    let buffers = vec![blob];
    let src = Source {
        file: Path::new("baked.glb"),
        buffers: &buffers,
    };
    let rig = rig::load(&rig_path).expect("load");
    let pre = Precomputed::new(&rig, Method::Lbs);
    let times = frames::sample_times(&rig, Some(0), Some(5));
    let mesh = gltf.document.meshes().next().expect("mesh");
    let prim = mesh.primitives().next().expect("primitive");
    let base_acc = prim.get(&gltf::Semantic::Positions).expect("POSITION");
    let base = read(&src, &gltf.document, base_acc.index(), "base", &[3], false).expect("base");
    let targets: Vec<_> = prim.morph_targets().collect();
    assert_eq!(targets.len(), times.len() - 1);
    for (k, &t) in times.iter().enumerate() {
        let frame = frames::evaluate(&rig, &pre, Some(0), k, t);
        let delta = if k == 0 {
            None
        } else {
            let acc = targets[k - 1].positions().expect("target positions");
            Some(read(&src, &gltf.document, acc.index(), "target", &[3], false).expect("target"))
        };
        for (i, p) in frame.bodies[0].positions.iter().enumerate() {
            for c in 0..3 {
                let d = delta.as_ref().map_or(0.0, |d| d.element(i)[c]);
                let v = base.element(i)[c] + d;
                assert!((v - p[c]).abs() < 1e-5, "frame {k} vertex {i}");
            }
        }
    }
    assert_eq!(gltf.document.animations().count(), 1);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn pose_never_overwrites_its_input() {
    let dir = tmp("input");
    std::fs::create_dir_all(&dir).expect("dir");
    let rig_path = dir.join("frame_0000.obj");
    std::fs::copy(samples().join("RiggedSimple/RiggedSimple.glb"), &rig_path).expect("copy");
    let before = std::fs::read(&rig_path).expect("read");
    let out = Command::new(env!("CARGO_BIN_EXE_contact-skin"))
        .args([
            "pose",
            rig_path.to_str().expect("utf8"),
            "--out",
            dir.to_str().expect("utf8"),
            "--frames",
            "2",
        ])
        .output()
        .expect("run");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("refusing to overwrite"));
    assert_eq!(std::fs::read(&rig_path).expect("read"), before);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_rig_gives_a_clear_error_and_exit_code() {
    let dir = tmp("bad");
    std::fs::create_dir_all(&dir).expect("dir");
    let p = dir.join("broken.glb");
    std::fs::write(&p, b"glTF\x02\x00\x00\x00garbage").expect("write");
    let out = Command::new(env!("CARGO_BIN_EXE_contact-skin"))
        .args([
            "pose",
            p.to_str().expect("utf8"),
            "--out",
            dir.to_str().expect("utf8"),
        ])
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("broken.glb") && err.starts_with("error:"),
        "{err}"
    );
    assert!(
        !dir.join("frame_0000.obj").exists(),
        "nothing written on error"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
