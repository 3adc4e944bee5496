use contact_skin::mesh::WeldedMesh;
use contact_skin::rig;
use contact_skin::selfcontact::*;
use std::path::Path;

#[test]
fn explore() {
    for name in ["bending_capsule", "finger", "mouth"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("rigs").join(format!("{name}.glb"));
        let rig = rig::load(&path).unwrap();
        let welded: Vec<WeldedMesh> = rig.bodies.iter().map(|b| WeldedMesh::weld(&b.positions, &b.triangles)).collect();
        let t0 = std::time::Instant::now();
        let pairs = derive_pairs(&rig, &welded, &RegionOptions::default());
        println!("{name}: {:?}", t0.elapsed());
        match pairs {
            Ok(pairs) => for p in &pairs {
                println!("  {}", p.reason);
                let axes = BoneAxes::new(&rig, &welded[p.pair.body], p);
                println!("  axes {:?}", axes);
                let pose = rig.pose_at(None, 0.0);
                println!("  rest dir {:?}", skeleton_direction(&rig, &pose, &p.pair, axes.leaf_axis));
                let pos = welded[p.pair.body].gather(&rig.bodies[p.pair.body].positions);
                let (mut lo, mut hi) = ([f64::MAX;3],[f64::MIN;3]);
                for &v in &p.shared { for k in 0..3 { lo[k]=lo[k].min(pos[v as usize][k]); hi[k]=hi[k].max(pos[v as usize][k]); } }
                println!("  R bbox {:?} {:?}", lo, hi);
            },
            Err(e) => println!("  ERR {e}"),
        }
    }
}
