//! Self-contact on skinned rigs (2021 Sec. 6): the bending capsule, the finger and the mouth.

#[path = "common/scenes.rs"]
mod scenes;

use contact_skin::mesh::operators::{vertex_normals, NormalWeighting};
use contact_skin::report::metrics;
use contact_skin::selfcontact::fold::FoldParams;
use contact_skin::selfcontact::pass::SelfContactPass;
use contact_skin::selfcontact::RegionOptions;
use nalgebra::Point3;
use scenes::{load, welded_positions, Loaded};

fn self_pass(l: &Loaded) -> SelfContactPass {
    let rest = welded_positions(&l.rig, &l.pre, 0.0, None);
    SelfContactPass::new(&l.rig, &l.pre.welded, &rest, &RegionOptions::default(), FoldParams::default(), &[])
        .expect("self-contact pass precomputes")
}

fn penetration(l: &Loaded, b: usize, p: &[Point3<f64>]) -> metrics::Penetration {
    let n = vertex_normals(p, &l.triangles[b], NormalWeighting::Area);
    metrics::residual_penetration(p, &l.triangles[b], &n, l.h_rest)
}

#[test]
fn probe_bending_capsule() {
    let name = std::env::var("PROBE_SCENE").unwrap_or("bending_capsule".into());
    let l = load(&name, 31);
    let pass = self_pass(&l);
    println!("pairs {:?}", pass.pairs());
    for f in [10, 15, 20, 25, 30] {
        let input = l.frame(f);
        let mut out = input.clone();
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let res = pass.run(&l.rig, &pose, &mut out).expect("runs");
        if let Ok(dir) = std::env::var("PROBE_OBJ") {
            for (tag, data) in [("in", &input), ("out", &out)] {
                let mut text = String::new();
                for (b, p) in data.iter().enumerate() {
                    for q in p { text += &format!("v {} {} {}\n", q.x, q.y, q.z); }
                    for t in &l.triangles[b] { text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1); }
                }
                std::fs::write(format!("{dir}/{name}_{f}_{tag}.obj"), text).expect("write");
            }
        }
        for b in 0..input.len() {
            let (pi, po) = (penetration(&l, b, &input[b]), penetration(&l, b, &out[b]));
            let v0 = contact_skin::mesh::signed_volume(&input[b], &l.triangles[b]);
            let v1 = contact_skin::mesh::signed_volume(&out[b], &l.triangles[b]);
            let inv = metrics::inverted_faces(&l.triangles[b], &input[b], &out[b]);
            println!(
                "frame {f} body {b}: folds {} penetration {} ({:.2} h) -> {} ({:.2} h), volume error {:.1e}, inverted {}, nan {}",
                res.folds.len(),
                pi.vertices,
                pi.max_depth / l.h_rest,
                po.vertices,
                po.max_depth / l.h_rest,
                ((v1 - v0) / v0).abs(),
                inv.inverted,
                metrics::non_finite(&out[b])
            );
        }
        for r in &res.folds {
            let o = &r.output;
            let t = &l.triangles[r.body];
            let (mut zone_faces, mut cut_faces, mut other, mut sigma_mixed) = (0, 0, 0, 0);
            for (fi, tri) in t.iter().enumerate() {
                let (a, b) = (&input[r.body], &out[r.body]);
                let n0 = (a[tri[1] as usize] - a[tri[0] as usize]).cross(&(a[tri[2] as usize] - a[tri[0] as usize]));
                let n1 = (b[tri[1] as usize] - b[tri[0] as usize]).cross(&(b[tri[2] as usize] - b[tri[0] as usize]));
                if n0.dot(&n1) >= 0.0 { continue; }
                let _ = fi;
                let z = |v: u32| o.contact.sides[0].zone.inside[v as usize] || o.contact.sides[1].zone.inside[v as usize];
                let sides: Vec<bool> = tri.iter().map(|&v| o.crease.on_w1[v as usize]).collect();
                if tri.iter().all(|&v| z(v)) { zone_faces += 1 } else if sides.iter().any(|&x| x) && sides.iter().any(|&x| !x) { cut_faces += 1 } else { other += 1 }
                let sg: Vec<f64> = tri.iter().map(|&v| o.sigma[v as usize]).collect();
                if sg.iter().any(|&x| x > 0.2) && sg.iter().any(|&x| x < -0.2) { sigma_mixed += 1 }
            }
            println!("   mapping {:?} / {:?}; m {:.4} s {:.4}; intersections {:?}", o.contact.sides[0].mapping, o.contact.sides[1].mapping, o.contact.mean_depth, o.contact.depth_deviation, o.contact.intersections);
            println!("   inverted: all-zone {zone_faces}, across the cut {cut_faces}, other {other}, sigma-mixed {sigma_mixed}; h_v {:.4}", o.bulge_height);
            let c = &r.output.contact;
            println!("   {} dir {:?} eps {:.4} zones {} {} crease value {:.4} stray {} stats {:?}", r.name, r.direction.as_slice(), c.threshold, c.sides[0].zone.vertices.len(), c.sides[1].zone.vertices.len(), r.output.crease.value, r.output.crease.stray, r.output.stats[0]);
        }
    }
}
