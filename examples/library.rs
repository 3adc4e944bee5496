//! The library's two passes on one frame of a rig, built as `pose --self-contact` builds them
//! (README, "Library"): `cargo run --release --example library [RIG] [FRAME]` (default
//! `rigs/finger.glb`, its last frame). `cargo test` compiles this file.
//!
//! Prints the contacts between bodies and the folds resolved, and the penetrating vertices
//! (`MEASURING.md`) of the skinned input and of the output.

use contact_skin::config::ContactConfig;
use contact_skin::pass::{ContactPass, RestBody, RestOverlaps};
use contact_skin::report::metrics;
use contact_skin::{frames, rig, skinning::Method};
use nalgebra::Point3;
use std::error::Error;

fn main() -> Result<(), Box<dyn Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().unwrap_or_else(|| "rigs/finger.glb".into());
    let rig = rig::load(path.as_ref())?;
    let pre = frames::Precomputed::new(&rig, Method::Lbs); // once per rig
    let times = frames::sample_times(&rig, Some(0), None)?;
    let last = times.len().saturating_sub(1);
    let index = match args.next() {
        Some(i) => i.parse::<usize>()?.min(last),
        None => last,
    };
    let t = times.get(index).copied().unwrap_or(0.0);

    // Once per rig, on the rest pose, from the rig's configuration as `pose` finds it
    // (`<rig stem>.contact.toml` next to the rig, else the defaults): the contact pass between
    // separate bodies, and the self-contact pass (its joint pairs from the skin weights, the
    // separated regions named or derived from the skeleton, the configured sweeps and
    // parameters). Pairs crossing at rest are modeled overlaps, left out by both.
    let config = ContactConfig::for_rig(path.as_ref(), None)?.unwrap_or_default();
    let rest = frames::welded_positions(&rig, &pre, None, 0.0);
    let bodies: Vec<RestBody> = (rest.iter().zip(&pre.welded))
        .map(|(p, w)| (p.as_slice(), w.triangles.as_slice()))
        .collect();
    let (params, overrides, passes) = config.resolve(&rig, &pre.welded)?;
    let objects = ContactPass::new(&bodies, params, overrides)?
        .with_passes(passes)
        .with_rest_overlaps(RestOverlaps::LeftOut);
    let settings = config.resolve_self_contact(&rig, &pre.welded)?;
    let folds = settings.pass(&rig, &pre.welded, &rest)?;

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
    // Penetrating vertices (`MEASURING.md`) over all bodies at once: inside another body or
    // another part of their own, as `pose --metrics` counts them.
    let triangles: Vec<&[[u32; 3]]> = pre.welded.iter().map(|w| w.triangles.as_slice()).collect();
    let h = metrics::h_rest(&rest, &triangles);
    let inside = |positions: &[Vec<Point3<f64>>]| {
        metrics::residual_penetration_posed(positions, &triangles, h).vertices
    };
    println!(
        "  penetrating vertices: {} skinned, {} after both passes",
        inside(&skinned),
        inside(&positions)
    );
    Ok(())
}
