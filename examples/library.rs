//! The library's two passes on one frame of a committed rig, as `README.md` ("Library") shows
//! them: `cargo run --release --example library [RIG] [FRAME]` (default `rigs/finger.glb`, its
//! deepest frame). `cargo test` compiles this file, so the README's calls stay true.
//!
//! Prints, per body, the penetrating vertices (`MEASURING.md`) of the skinned input, after the
//! contact pass between bodies and after the self-contact pass, and the folds resolved.

use contact_skin::mesh::operators::{mean_edge_length, vertex_normals, NormalWeighting};
use contact_skin::pass::{ContactPass, ObjectParams, RestBody, RestOverlaps};
use contact_skin::report::metrics;
use contact_skin::selfcontact::separated::separated_from_skeleton;
use contact_skin::selfcontact::{fold::FoldParams, pass::SelfContactPass, RegionOptions};
use contact_skin::{frames, rig, skinning::Method};
use nalgebra::Point3;
use std::error::Error;

fn main() -> Result<(), Box<dyn Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().unwrap_or_else(|| "rigs/finger.glb".into());
    let rig = rig::load(path.as_ref())?;
    let pre = frames::Precomputed::new(&rig, Method::Lbs); // once per rig
    let times = frames::sample_times(&rig, Some(0), None)?;
    let index = match args.next() {
        Some(i) => i.parse::<usize>()?.min(times.len() - 1),
        None => times.len() - 1,
    };
    let t = times[index];

    // Once per rig, on the rest pose: the contact pass between separate bodies, and the
    // self-contact pass with the regions of every parent/child joint pair and the separated
    // regions the skeleton derives (`pose --self-contact`'s defaults without a configuration).
    let rest = frames::welded_positions(&rig, &pre, None, 0.0);
    let bodies: Vec<RestBody> = (rest.iter().zip(&pre.welded))
        .map(|(p, w)| (p.as_slice(), w.triangles.as_slice()))
        .collect();
    let params = vec![ObjectParams::default(); bodies.len()];
    let objects = ContactPass::new(&bodies, params, vec![])?
        // built on the true rest pose: pairs already crossing there are modeled overlaps
        .with_rest_overlaps(RestOverlaps::LeftOut);
    let options = RegionOptions::default();
    let separated = separated_from_skeleton(&rig, &pre.welded, &options)?;
    let folds = SelfContactPass::with_separated(
        &rig,
        &pre.welded,
        &rest,
        &options,
        FoldParams::default(),
        &[],
        separated,
    )?
    .with_rest_overlaps(RestOverlaps::LeftOut);

    // Per frame: a pure function of the pose.
    let skinned = frames::welded_positions(&rig, &pre, Some(0), t);
    let out = objects.run_at(&skinned, t)?;
    let mut positions = out.positions.clone();
    let pose = rig.pose_at(Some(0), t);
    let resolved = folds.run(&rig, &pose, &mut positions)?;

    println!("{path}, frame {index} (t = {t:.3} s)");
    println!("  contacts between bodies: {}", out.contacts.len());
    // One report per fold and sweep (a fold moved in the first sweep is checked again).
    let mut names: Vec<&str> = resolved.folds.iter().map(|f| f.name.as_str()).collect();
    names.sort_unstable();
    names.dedup();
    println!(
        "  folds resolved in {} sweep(s): {names:?}",
        resolved.sweeps
    );
    for (b, mesh) in pre.welded.iter().enumerate() {
        let tris = &mesh.triangles;
        let h = mean_edge_length(&rest[b], tris);
        let inside = |p: &[Point3<f64>]| {
            let n = vertex_normals(p, tris, NormalWeighting::Area);
            metrics::residual_penetration(p, tris, &n, h).vertices
        };
        println!(
            "  body {}: penetrating vertices {} skinned, {} after both passes",
            rig.bodies[b].name,
            inside(&skinned[b]),
            inside(&positions[b])
        );
    }
    Ok(())
}
