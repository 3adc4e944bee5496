//! Self-contact on the real characters of `../shared/gltf-samples/` (read from there, never
//! copied): which animations fold a joint into contact, and what the pass does to them.

#[path = "common/scenes.rs"]
mod scenes;

use contact_skin::frames::{self, Precomputed};
use contact_skin::mesh::operators::{mean_edge_length, vertex_normals, NormalWeighting};
use contact_skin::report::metrics;
use contact_skin::rig;
use contact_skin::selfcontact::fold::FoldParams;
use contact_skin::selfcontact::pass::SelfContactPass;
use contact_skin::selfcontact::RegionOptions;
use contact_skin::skinning::Method;
use std::path::Path;

fn sample(rel: &str) -> Option<std::path::PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/gltf-samples")
        .join(rel);
    p.exists().then_some(p)
}

#[test]
fn real_characters_never_get_worse() {
    for rel in [
        "CesiumMan/CesiumMan.glb",
        "Fox/Fox.glb",
        "QuaterniusRobot/robot.glb",
        "WebXRGenericHand/left.glb",
        "RiggedFigure/RiggedFigure.glb",
    ] {
        let Some(path) = sample(rel) else {
            println!("{rel}: not found, skipped");
            continue;
        };
        let rig = rig::load(&path).expect("sample loads");
        let pre = Precomputed::new(&rig, Method::Lbs);
        let rest = scenes::welded_positions(&rig, &pre, 0.0, None);
        let pass = SelfContactPass::new(
            &rig,
            &pre.welded,
            &rest,
            &RegionOptions::default(),
            FoldParams::default(),
            &[],
        )
        .expect("pairs derive");
        let anim = if rig.animations.is_empty() {
            None
        } else {
            Some(0)
        };
        let times = frames::sample_times(&rig, anim, Some(21));
        let (mut folded, mut before, mut after, mut vol, mut unbalanced) = (0, 0, 0, 0.0f64, 0);
        // Largest displacement by the pass in any frame, in rest edge lengths.
        let mut largest = 0.0f64;
        let mut turned = metrics::TurnedFaces::default();
        for (k, &t) in times.iter().enumerate() {
            let frame = frames::evaluate(&rig, &pre, anim, k, t);
            let (input, skinned) = (frame.welded(&pre), frame.welded_normals(&pre));
            let mut out = input.clone();
            let pose = rig.pose_at(anim, t);
            let res = pass.run(&rig, &pose, &mut out).expect("self-contact runs");
            folded += usize::from(!res.folds.is_empty());
            unbalanced += res.unbalanced;
            for (b, w) in pre.welded.iter().enumerate() {
                assert_eq!(metrics::non_finite(&out[b]), 0, "{rel}: NaN");
                let h = mean_edge_length(&rest[b], &w.triangles);
                let pen = |p: &[nalgebra::Point3<f64>]| {
                    let n = vertex_normals(p, &w.triangles, NormalWeighting::Area);
                    metrics::residual_penetration(p, &w.triangles, &n, h).vertices
                };
                if res.folds.iter().any(|f| f.body == b) {
                    let moved = input[b]
                        .iter()
                        .zip(&out[b])
                        .map(|(p, q)| (p - q).norm() / h)
                        .fold(0.0, f64::max);
                    largest = largest.max(moved);
                    before += pen(&input[b]);
                    after += pen(&out[b]);
                    turned +=
                        metrics::turned_faces(&w.triangles, &input[b], &out[b], &skinned[b], h);
                    let v0 = contact_skin::mesh::signed_volume(&input[b], &w.triangles);
                    let v1 = contact_skin::mesh::signed_volume(&out[b], &w.triangles);
                    vol = vol.max(metrics::volume_error(v0, v1));
                }
            }
        }
        println!(
            "{rel}: pairs {}, frames with a fold {folded}/{}, penetrating vertices (summed over those frames) {before} -> {after}, faces turned (summed): input against skinning {}, output against input {}, against skinning {}, against both {} ({} buried), worst volume error {vol:.1e}, folds left unbalanced {unbalanced}, largest displacement {largest:.1} h",
            pass.pairs().len(),
            times.len(),
            turned.input_against_skinning,
            turned.against_input,
            turned.against_skinning,
            turned.turned,
            turned.buried,
        );
        assert!(
            after <= before,
            "{rel}: self-contact made penetration worse ({before} -> {after})"
        );
        assert!(vol < 1e-4, "{rel}: volume error {vol:.1e}");
        // No spike: measured 9.1 edge lengths at most (CesiumMan, frame 5); 23 before folds
        // whose bulge rises higher than its band is wide were refused (`STEEPEST_BULGE`).
        assert!(
            largest < 12.0,
            "{rel}: the pass moved a vertex by {largest:.1} edge lengths"
        );
    }
}
