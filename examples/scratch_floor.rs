#[path = "../tests/common/scenes.rs"]
mod scenes;
use contact_skin::selfcontact::fold::FoldParams;
use contact_skin::selfcontact::pass::SelfContactPass;
use contact_skin::selfcontact::{DirectionSource, RegionOptions};
use contact_skin::skinning::Method;
use nalgebra::Vector3;
use scenes::{load_with, welded_positions};

fn main() {
    for (name, m) in [
        ("finger", Method::Lbs),
        ("bending_capsule", Method::Lbs),
        ("bending_capsule", Method::Cor),
        ("mouth", Method::Lbs),
    ] {
        let l = load_with(name, 31, m);
        let rest = welded_positions(&l.rig, &l.pre, 0.0, None);
        let dirs = [(
            "lips/head-jaw".to_string(),
            DirectionSource::Fixed(-Vector3::y()),
        )];
        let pass = SelfContactPass::new(
            &l.rig,
            &l.pre.welded,
            &rest,
            &RegionOptions::default(),
            FoldParams::default(),
            &dirs,
        )
        .unwrap();
        let (mut n, mut bound_floor, mut maxratio) = (0, 0, 0.0f64);
        for f in 0..31 {
            let mut out = l.frame(f);
            let pose = l.rig.pose_at(Some(0), l.times[f]);
            let res = pass.run(&l.rig, &pose, &mut out).unwrap();
            for fr in &res.folds {
                for st in &fr.output.stats {
                    n += 1;
                    let phibar = st.extent.min(f64::INFINITY);
                    if st.extent_floor > 0.0 && st.extent_floor >= st.extent * 0.999 {
                        bound_floor += 1;
                    }
                    let _ = phibar;
                    maxratio = maxratio.max(st.extent_floor / st.extent);
                }
            }
        }
        println!("{name} {m:?}: {n} region deformations, floor sets the extent in {bound_floor}, max floor/extent {maxratio:.2}");
    }
}
