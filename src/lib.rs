//! # contact-skin
//!
//! Poses rigged glTF characters and resolves their contacts geometrically, after
//! Brunel, Bénard and Guennebaud, *A Time-independent Deformer for Elastic Contacts* (2021),
//! with the implicit-layer model of Cani and Desbrun (1997) as a comparison.
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
//! | self-contact of adjacent working regions: regions, partition of unity, direction (Sec. 6) | [`selfcontact`] |
//!
//! Everything that does not depend on the pose is precomputed once per rig
//! ([`frames::Precomputed`]); every frame is a pure function of the pose.

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
