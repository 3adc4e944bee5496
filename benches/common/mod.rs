//! What the benchmarks share: loading a committed rig.

use contact_skin::rig::{self, Rig};
use std::path::Path;

/// The committed rig `rigs/<name>.glb`.
pub fn committed_rig(name: &str) -> Rig {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("rigs")
        .join(format!("{name}.glb"));
    rig::load(&path).expect("committed rig")
}
