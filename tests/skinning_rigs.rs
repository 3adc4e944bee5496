//! Skinning on the committed bending capsule (`rigs/bending_capsule.glb`): DQS and CoR keep the
//! bent capsule's volume far better than LBS, and neither collapses under a 150° twist
//! (the candy-wrapper artefact of LBS).

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
