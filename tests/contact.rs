//! The elastic contact deformer between separate objects (2021 Sec. 4, 5, 7) on the committed
//! scenes: capsule pair, fingertips on ball, sphere on plane.

#[path = "common/scenes.rs"]
mod scenes;

use contact_skin::pass::ObjectParams;
use scenes::{load, Loaded};

fn params(n: usize, k: &[f64], tau: f64) -> Vec<ObjectParams> {
    (0..n)
        .map(|i| ObjectParams {
            stiffness: k[i.min(k.len() - 1)],
            tau,
            ..Default::default()
        })
        .collect()
}

#[allow(dead_code)]
fn probe(l: &Loaded, k: &[f64], tau: f64, frame: usize) {
    let pass = l.pass(params(l.triangles.len(), k, tau), vec![]);
    let input = l.frame(frame);
    let before = l.penetration(&input);
    let out = pass.run(&input).expect("pass runs");
    let after = l.penetration(&out.positions);
    println!(
        "frame {frame} k {k:?} tau {tau}: contacts {} penetration {} -> {} (max depth {:.3} h) timings {:?}",
        out.contacts.len(),
        before.vertices,
        after.vertices,
        after.max_depth / l.h_rest,
        out.timings
    );
    for c in &out.contacts {
        let ct = &c.contact;
        println!(
            "  pair {:?}: eps {:.4} m {:.4} s {:.4} zones {} / {} boundary {} / {} dir {:?} map {:?} / {:?}",
            c.bodies,
            ct.threshold,
            ct.mean_depth,
            ct.depth_deviation,
            ct.sides[0].zone.vertices.len(),
            ct.sides[1].zone.vertices.len(),
            ct.sides[0].zone.boundary.len(),
            ct.sides[1].zone.boundary.len(),
            ct.sides[0].direction,
            ct.sides[0].mapping,
            ct.sides[1].mapping
        );
    }
    for (b, d) in out.diagnostics.iter().enumerate() {
        if let Some(s) = &d.stats {
            println!(
                "  body {b}: volume error {:.2e} stats {:?}",
                l.volume_error(b, &input, &out),
                s
            );
        }
    }
}
