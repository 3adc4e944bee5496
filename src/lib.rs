//! # contact-skin
//!
//! Poses rigged glTF characters and resolves their contacts geometrically, after
//! Brunel, Bénard and Guennebaud, *A Time-independent Deformer for Elastic Contacts* (2021).
//! The implicit-layer model of Cani and Desbrun (1997), the comparison model that
//! `PIPELINE.md` specifies ("Implicit-layer contact"), is not built yet.
//!
//! The crate is laid out by pipeline stage:
//!
//! | stage | module |
//! | --- | --- |
//! | glTF reading, skeleton, animation sampling | [`rig`] |
//! | welded topology of the skinned meshes, discrete operators | [`mesh`] |
//! | mesh-mesh intersections, farthest-hit rays, silhouettes | [`intersect`] |
//! | contact surface: direction, mapping, potential surface, zones (2021 Sec. 4) | [`contact`] |
//! | deformation: parametrization, directions, profile, volume, bulge (Sec. 5, 7) | [`deform`] |
//! | the per-frame contact pass over a set of bodies (Appendix B) | [`pass`] |
//! | contact parameters per rig (TOML) | [`config`] |
//! | error metrics of `MEASURING.md` | [`report`] |
//! | min-cut / max-flow (Boykov-Kolmogorov) | [`mincut`] |
//! | sparse SPD Cholesky with symbolic reuse | [`solve`] |
//! | heat method with a source curve, harmonic diffusion on cut meshes | [`heat`] |
//! | linear blend, dual quaternion and center-of-rotation skinning | [`skinning`] |
//! | evaluation of an animation, frame by frame | [`frames`] |
//! | OBJ frames and baked glb | [`output`] |
//! | the procedural test scenes of `rigs/` | [`scenes`] |
//! | self-contact of adjacent working regions: regions, partition of unity, direction, crease cut, folds (Sec. 6) | [`selfcontact`] |
//!
//! Everything that does not depend on the pose is precomputed once per rig
//! ([`frames::Precomputed`]); every frame is a pure function of the pose.
//!
//! `examples/library.rs` builds both contact passes from a rig's configuration as `pose`
//! does ([`config::ContactConfig::for_rig`], [`config::ContactConfig::resolve`],
//! [`config::ContactConfig::resolve_self_contact`], [`config::SelfContactSettings::pass`]) and
//! measures one frame.

/// `AddAssign` for a struct of summed fields (timings, counts), field by field, with a doc
/// line. The destructuring names every field: a field added to the struct and not to the
/// list is a compile error, not a sum that silently drops it.
macro_rules! add_assign_fields {
    ($doc:literal, $t:ty { $($f:ident),+ $(,)? }) => {
        impl std::ops::AddAssign for $t {
            #[doc = $doc]
            fn add_assign(&mut self, other: Self) {
                let Self { $($f),+ } = other;
                $(self.$f += $f;)+
            }
        }
    };
}

pub mod config;
pub mod contact;
pub mod deform;
pub mod frames;
pub mod heat;
pub mod intersect;
pub mod mesh;
pub mod mincut;
pub mod output;
pub mod pass;
pub mod report;
pub mod rig;
pub mod scenes;
pub mod selfcontact;
pub mod skinning;
pub mod solve;

/// Helpers shared by the unit tests.
#[cfg(test)]
mod test_support {
    /// A deterministic stream of numbers in `[0, 1)` (a 64-bit linear congruential generator,
    /// its top 53 bits) from `seed`.
    pub fn uniform(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }
}
