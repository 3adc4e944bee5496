//! What the benchmarks share: loading a committed rig, the contact pass between its bodies,
//! a measurement loop on one thread.

// Each bench uses some of these.
#![allow(dead_code)]

use contact_skin::frames::{self, Precomputed};
use contact_skin::pass::{ContactPass, ObjectParams};
use contact_skin::rig::{self, Rig};
use std::path::Path;

/// The committed rig `rigs/<name>.glb`.
pub fn committed_rig(name: &str) -> Rig {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("rigs")
        .join(format!("{name}.glb"));
    rig::load(&path).expect("committed rig")
}

/// The contact pass between the bodies of `rig` (skinned as `pre`) at their defaults, as
/// `pose` without a configuration.
pub fn object_pass(rig: &Rig, pre: &Precomputed) -> ContactPass {
    let rest = frames::welded_positions(rig, pre, None, 0.0);
    let bodies = contact_skin::pass::rest_bodies(&rest, &pre.welded);
    let params = vec![ObjectParams::default(); bodies.len()];
    ContactPass::new(&bodies, params, Vec::new()).expect("contact pass")
}

/// Criterion's measurement loop of `b` run on `pool`'s thread (a one-thread pool: one core),
/// every iteration calling `routine` there. Handing each iteration to the pool instead
/// (`b.iter(|| pool.install(..))`) adds 30-45 µs per iteration to what is measured, as much
/// as a frame without contact costs.
pub fn on_one_thread<R>(
    pool: &rayon::ThreadPool,
    b: &mut criterion::Bencher,
    routine: impl Fn() -> R + Sync,
) {
    pool.install(|| b.iter(&routine));
}
