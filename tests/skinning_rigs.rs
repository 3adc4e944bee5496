//! Skinning on the committed bending capsule (`rigs/bending_capsule.glb`): DQS and CoR keep the
//! bent capsule's volume far better than LBS, and neither collapses under a 150° twist
//! (the candy-wrapper artefact of LBS).

#[path = "common/glb.rs"]
mod glb;

use contact_skin::frames::{self, Precomputed};
use contact_skin::mesh::signed_volume;
use contact_skin::rig::{self, Rig};
use contact_skin::skinning::Method;
use std::path::Path;

fn capsule() -> Rig {
    rig::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("rigs/bending_capsule.glb"))
        .expect("committed rig")
}

/// Relative volume change of the last frame of `animation` against its first frame.
fn volume_change(rig: &Rig, method: Method, animation: &str) -> f64 {
    let a = rig.find_animation(animation).expect("animation");
    let pre = Precomputed::new(rig, method);
    let welded = &pre.welded[0];
    assert!(welded.report.is_closed_manifold());
    let times = frames::sample_times(rig, Some(a), Some(2)).expect("frames");
    let vol = |i: usize| {
        let f = frames::evaluate(rig, &pre, Some(a), i, times[i]);
        signed_volume(&welded.gather(&f.bodies[0].positions), &welded.triangles)
    };
    let (v0, v1) = (vol(0), vol(1));
    assert!(v0 > 0.0);
    (v1 - v0) / v0
}

#[test]
fn dqs_and_cor_keep_the_bent_volume_far_better_than_lbs() {
    let rig = capsule();
    let lbs = volume_change(&rig, Method::Lbs, "bend").abs();
    let dqs = volume_change(&rig, Method::Dqs, "bend").abs();
    let cor = volume_change(&rig, Method::Cor, "bend").abs();
    println!("150° bend volume change: LBS {lbs:.4}, DQS {dqs:.4}, CoR {cor:.4}");
    assert!(lbs > 0.01, "LBS should visibly lose volume at 150°");
    assert!(dqs < lbs / 3.0, "DQS {dqs} vs LBS {lbs}");
    assert!(cor < lbs / 2.0, "CoR {cor} vs LBS {lbs}");
}

/// Smallest distance to the capsule axis (the rest pose's y axis) among vertices near the joint.
fn min_radius_at_joint(rig: &Rig, method: Method) -> f64 {
    let a = rig.find_animation("twist").expect("twist");
    let pre = Precomputed::new(rig, method);
    let end = rig.animations[a].end;
    let f = frames::evaluate(rig, &pre, Some(a), 0, end);
    let body = &rig.bodies[0];
    f.bodies[0]
        .positions
        .iter()
        .zip(&body.positions)
        .filter(|(_, rest)| (rest.y - 1.0).abs() < 0.1)
        .map(|(p, _)| (p.x * p.x + p.z * p.z).sqrt())
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn cor_and_dqs_show_no_candy_wrapper_under_twist() {
    let rig = capsule();
    let r = 0.2;
    let lbs = min_radius_at_joint(&rig, Method::Lbs);
    let dqs = min_radius_at_joint(&rig, Method::Dqs);
    let cor = min_radius_at_joint(&rig, Method::Cor);
    println!(
        "150° twist, smallest radius at the joint / r: LBS {:.3}, DQS {:.3}, CoR {:.3}",
        lbs / r,
        dqs / r,
        cor / r
    );
    assert!(lbs < 0.5 * r, "LBS should collapse (candy wrapper)");
    assert!(cor > 0.95 * r && dqs > 0.95 * r);
}

/// The capsule as `gltfpack` writes it with `KHR_mesh_quantization` (required): POSITION as
/// normalized 16-bit integers, the dequantization `p = o + s q` folded into the inverse bind
/// matrices (`IBM · T(o) · S`), NORMAL as normalized bytes.
fn quantized_capsule() -> (Vec<u8>, f64) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("rigs/bending_capsule.glb");
    let bytes = std::fs::read(&path).expect("committed rig");
    let rig = capsule();
    let body = &rig.bodies[0];
    let (lo, hi) = body.positions.iter().fold(
        (
            nalgebra::Vector3::repeat(f64::INFINITY),
            nalgebra::Vector3::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)),
    );
    let (o, s) = ((lo + hi) / 2.0, (hi - lo).max() / 2.0);
    let mut data = Vec::new();
    for p in &body.positions {
        let q = (p.coords - o) / s * 32767.0;
        for c in q.iter() {
            data.extend((c.round() as i16).to_le_bytes());
        }
        data.extend([0, 0]); // byteStride 8
    }
    let normals_at = data.len();
    for n in &body.normals {
        data.extend(n.iter().map(|c| (c * 127.0).round() as i8 as u8));
        data.push(0); // byteStride 4
    }
    let ibm_at = data.len();
    let dequantize = nalgebra::Matrix4::new_translation(&o) * nalgebra::Matrix4::new_scaling(s);
    for ibm in &rig.skins[0].inverse_bind {
        let m = ibm * dequantize;
        data.extend(m.iter().flat_map(|&x| (x as f32).to_le_bytes()));
    }
    let (n, joints) = (body.vertex_count(), rig.skins[0].joints.len());
    let quantized = glb::with_bin_appended(&bytes, &data, |json, offset| {
        use serde_json::json;
        let positions = json!({"componentType": 5122, "normalized": true, "count": n,
                               "type": "VEC3", "min": [-32767, -32767, -32767],
                               "max": [32767, 32767, 32767]});
        let positions = glb::push_accessor(json, (offset, normals_at), Some(8), positions);
        let normals =
            json!({"componentType": 5120, "normalized": true, "count": n, "type": "VEC3"});
        let normals_span = (offset + normals_at, ibm_at - normals_at);
        let normals = glb::push_accessor(json, normals_span, Some(4), normals);
        let ibm = json!({"componentType": 5126, "count": joints, "type": "MAT4"});
        let ibm = glb::push_accessor(json, (offset + ibm_at, 64 * joints), None, ibm);
        let attributes = &mut json["meshes"][0]["primitives"][0]["attributes"];
        attributes["POSITION"] = json!(positions);
        attributes["NORMAL"] = json!(normals);
        json["skins"][0]["inverseBindMatrices"] = json!(ibm);
        json["extensionsUsed"] = json!(["KHR_mesh_quantization"]);
        json["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
    });
    (quantized, s / 32767.0)
}

/// A quantized file (`KHR_mesh_quantization`, required) poses as its float original: every
/// frame of `bend` within the quantization step, normals within a byte's.
#[test]
fn quantized_attributes_pose_as_the_float_original() {
    let (bytes, step) = quantized_capsule();
    let quantized = rig::load_from_bytes(Path::new("quantized.glb"), &bytes).expect("loads");
    let original = capsule();
    let (pq, po) = (
        Precomputed::new(&quantized, Method::Lbs),
        Precomputed::new(&original, Method::Lbs),
    );
    let a = original.find_animation("bend").expect("bend");
    for (i, &t) in frames::sample_times(&original, Some(a), Some(7))
        .expect("frames")
        .iter()
        .enumerate()
    {
        let q = frames::evaluate(&quantized, &pq, Some(a), i, t);
        let f = frames::evaluate(&original, &po, Some(a), i, t);
        let (q, f) = (&q.bodies[0], &f.bodies[0]);
        let far = (q.positions.iter().zip(&f.positions))
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        assert!(far < 2.0 * step, "t = {t}: {far} against the step {step}");
        let turned = (q.normals.iter().zip(&f.normals))
            .map(|(a, b)| a.angle(b))
            .fold(0.0, f64::max);
        assert!(turned < 0.02, "t = {t}: normals {turned} rad apart");
    }
    // The same file requiring Draco compression is refused, saying why.
    let draco = glb::with_json(&bytes, |json| {
        json["extensionsRequired"] = serde_json::json!(["KHR_draco_mesh_compression"]);
    });
    let refused = rig::load_from_bytes(Path::new("draco.glb"), &draco).expect_err("refused");
    assert!(refused.to_string().contains("decompress"), "{refused}");
}
