//! Self-contact between adjacent working regions of one skinned mesh (Brunel et al. 2021,
//! Sec. 6 "Adjacent working regions"; `PIPELINE.md`, "Working regions", "Self-contact: crease
//! cut", "Self-contact: direction", "Skeleton-derived direction").
//!
//! Two working regions `W1`, `W2` of the same mesh (the two sides of an articulation) overlap
//! on a *shared region* `R`. Inside `R` the final positions blend the two deformations with a
//! partition of unity `β` (Sec. 6, `p'_i = β_i p'_{i,1} + (1 - β_i) p'_{i,2}`), precomputed on
//! the rest pose; at run time the shared region is cut along the crease (graph cut driven by
//! the mapping direction `d̂_12` and by `β`), each truncated region is deformed on its own, and
//! the results are blended.
//!
//! The modules, in the order of a frame:
//! - [`regions`]: `W1`, `W2` and `R` of every parent/child joint pair that deforms a mesh,
//!   derived from the skin weights ([`derive_pairs`]) or named by a rig config
//!   ([`pairs_for_joints`]), over the skin's [`joint_tree`] (the node hierarchy, or a tracked
//!   hand's joint names when its joint nodes are not nested);
//! - [`partition`]: the harmonic partition of unity `β` on `R` ([`partition_of_unity`]);
//! - [`direction`]: the mapping direction `d̂_12` from the skeleton, orthogonal to the bones'
//!   bisector in their plane ([`skeleton_direction`]), from the parts' relative motion, or a
//!   fixed user direction ([`DirectionSource`]);
//! - [`crease`]: the per-frame crease cut of `R` (min-cut over `R`'s vertices, `PIPELINE.md`
//!   "Self-contact: crease cut");
//! - [`fold`]: one joint folding into itself: contact on the truncated regions, the signed
//!   direction field `d̄ = σ d̂_12`, both regions' deformation, the blend over `R` and one
//!   volume solve on the blended positions, with the [`turn_guard`] scaling the displacement
//!   back where it would turn faces over;
//! - [`pass`]: every joint pair of a rig, frame by frame, in sweeps, each without the separate
//!   pieces of the mesh sunk into its sides or lying inside a larger piece at rest
//!   ([`layers`]).
//!
//! The same machinery serves two working regions of one mesh that share no vertex
//! ([`separated_regions`], named by a rig config: sibling joints such as two fingers, which no
//! parent/child pair holds): with `R` empty there is no crease to cut and nothing to blend,
//! the mapping direction is Eq. 2's, and the fold is Sec. 4-5 on two parts of one mesh (the
//! paper's Fig. 14).

pub mod bulge_guard;
pub mod crease;
pub mod direction;
pub mod fold;
pub mod joint_tree;
pub mod layers;
pub mod partition;
pub mod pass;
pub mod regions;
pub mod separated;
pub mod turn_guard;

pub use direction::{skeleton_direction, BoneAxes, DirectionSource, LeafAxisSource, RestFold};
pub use joint_tree::{JointTree, TreeSource};
pub use partition::{partition_of_unity, partition_of_unity_with_stats, PartitionStats};
pub use regions::{
    derive_pairs, derive_pairs_reporting, pairs_for_joints, JointPair, PairRegions, RegionOptions,
    DEFAULT_GROW_RINGS, DEFAULT_THRESHOLD,
};
pub use separated::{extend_distinct, separated_from_skeleton, separated_regions};

use crate::heat::HeatError;
use crate::solve::SolveError;

/// Which Dirichlet border of a shared region (2021 Sec. 6, "Shared region & Partition of
/// unity").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BorderSide {
    /// Border vertices of `R` next to `W1 \ R` (where `W2` ends): `β = 1`.
    W1,
    /// Border vertices of `R` next to `W2 \ R` (where `W1` ends): `β = 0`.
    W2,
}

impl std::fmt::Display for BorderSide {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BorderSide::W1 => f.write_str("next to W1 \\ R (beta = 1)"),
            BorderSide::W2 => f.write_str("next to W2 \\ R (beta = 0)"),
        }
    }
}

/// Label used by [`partition_of_unity`] when it is called without a pair.
pub const UNNAMED_PAIR: &str = "(unnamed pair)";

/// Why self-contact regions could not be built.
#[derive(Debug, thiserror::Error)]
pub enum SelfContactError {
    /// Per-vertex inputs of different lengths, a triangle index out of range, a body without
    /// its welded mesh, or weights that do not match the mesh.
    #[error("inconsistent input: {0}")]
    InconsistentInput(String),
    /// A joint name of a rig config names no node.
    #[error("no node is named {0:?}")]
    UnknownJoint(String),
    /// A named joint pair that no body can use (no skin holds both joints, or no body gets a
    /// non-empty shared region).
    #[error("joint pair {parent:?} / {child:?}: {reason}")]
    UnusablePair {
        /// Parent joint name.
        parent: String,
        /// Child joint name.
        child: String,
        /// Why.
        reason: String,
    },
    /// The shared region's border has no vertex of one kind: `β` cannot go from 1 to 0
    /// (2021 Sec. 6 needs both Dirichlet borders).
    #[error(
        "pair {pair}: degenerate shared region ({shared} vertices): no border vertex {missing}"
    )]
    DegenerateSharedRegion {
        /// The pair.
        pair: String,
        /// Number of vertices of `R`.
        shared: usize,
        /// The missing border.
        missing: BorderSide,
    },
    /// A connected part of `R` touches no Dirichlet border at all, so `β` is undefined on it.
    #[error("pair {pair}: {vertices} vertices of the shared region reach no Dirichlet border")]
    UnreachedSharedRegion {
        /// The pair.
        pair: String,
        /// Number of vertices with no Dirichlet border in their component.
        vertices: usize,
    },
    /// The harmonic solve failed.
    #[error("pair {pair}: harmonic solve of beta: {source}")]
    Heat {
        /// The pair.
        pair: String,
        /// The underlying error.
        #[source]
        source: HeatError,
    },
    /// The symbolic factorization of the shared region failed.
    #[error("pair {pair}: factorization of the shared region: {source}")]
    Solve {
        /// The pair.
        pair: String,
        /// The underlying error.
        #[source]
        source: SolveError,
    },
}

impl SelfContactError {
    /// The same error attributed to the pair `name` (replaces [`UNNAMED_PAIR`]).
    pub fn for_pair(self, name: &str) -> Self {
        match self {
            SelfContactError::DegenerateSharedRegion {
                shared, missing, ..
            } => SelfContactError::DegenerateSharedRegion {
                pair: name.to_owned(),
                shared,
                missing,
            },
            SelfContactError::UnreachedSharedRegion { vertices, .. } => {
                SelfContactError::UnreachedSharedRegion {
                    pair: name.to_owned(),
                    vertices,
                }
            }
            SelfContactError::Heat { source, .. } => SelfContactError::Heat {
                pair: name.to_owned(),
                source,
            },
            SelfContactError::Solve { source, .. } => SelfContactError::Solve {
                pair: name.to_owned(),
                source,
            },
            other => other,
        }
    }
}
