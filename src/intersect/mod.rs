//! Mesh–mesh intersections and the geometric queries of the contact-surface stage
//! (Brunel et al. 2021, Sec. 4.1–4.2 and Algorithm 1 lines 2–16).
//!
//! | building block | paper | module |
//! | --- | --- | --- |
//! | BVH per surface, built once, refitted per frame | | [`bvh`] |
//! | edge–face intersection points, intersection curves | Alg. 1 line 3 | [`mesh_mesh`] |
//! | intersection regions `I_l`, area integrals (Eq. 2) | Sec. 4.1 | [`regions`] |
//! | farthest-hit ray casts | Sec. 4.2, Alg. 1 line 16 | [`rays`] |
//! | interpolated silhouettes, front-facing masks | Sec. 4.2 | [`silhouette`] |
//!
//! Everything is `f64`. Crossing decisions use exact orientation predicates with a symbolic
//! perturbation (simulation of simplicity: the second surface is translated by an infinitesimal
//! `ε e_x + ε² e_y + ε³ e_z`), so touching and coplanar configurations are resolved as one
//! consistent generic configuration: every intersecting face pair has exactly two hits and the
//! curves of closed surfaces are closed loops. Outputs are sorted by element ids, so they do not
//! depend on the BVH, on the rayon pool size or on the run.
//!
//! Typical per-frame use (the [`MeshIndex`] values are precomputed once per rig):
//!
//! ```
//! use contact_skin::intersect::{IntersectionRegion, Intersections, MeshIndex, Side};
//! use nalgebra::Point3;
//! // A: a square in z = 0 (normal +z); B: a tetrahedron poking up through it.
//! let pa = [(-2., -2.), (2., -2.), (2., 2.), (-2., 2.)].map(|(x, y)| Point3::new(x, y, 0.0));
//! let ta = [[0, 1, 2], [0, 2, 3]];
//! let pb = [(-0.5, -0.5, -1.), (1., -0.2, -1.), (0., 1., -1.), (0.3, 0.25, 0.5)]
//!     .map(|(x, y, z)| Point3::new(x, y, z));
//! let tb = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];
//! // Once per rig:
//! let (ia, ib) = (MeshIndex::new(&pa, &ta)?, MeshIndex::new(&pb, &tb)?);
//! // Per frame (here the same positions): refit, intersect, regions.
//! let (a, b) = (ia.pose(&pa)?, ib.pose(&pb)?);
//! let ints = Intersections::between(&a, &b)?;
//! assert_eq!(ints.curves.len(), 1);
//! assert!(ints.curves[0].closed);
//! // The part of the square inside the tetrahedron: its cross-section triangle.
//! let section = IntersectionRegion::inside(&ints, Side::A, &a)?;
//! assert!(section.area(&a) > 0.0);
//! # Ok::<(), contact_skin::intersect::IntersectError>(())
//! ```

pub mod bvh;
mod curves;
mod index;
pub mod mesh_mesh;
mod predicates;
pub mod rays;
pub mod regions;
pub mod silhouette;

pub use bvh::{Aabb, FaceSets, LeafCorners, TriangleBvh};
pub use curves::Curve;
pub use index::{MeshIndex, PartsUnion, PosedMesh};
pub use mesh_mesh::{
    intersect_meshes, intersect_parts, EdgeHit, IntersectionSegment, IntersectionStats,
    Intersections, Side,
};
pub use rays::{
    farthest_hit, farthest_hit_among, farthest_hits, farthest_hits_among, Ray, RayHit, SegmentRays,
};
pub use regions::{
    CutFace, IntersectionRegion, QuadraturePoint, QuadratureRule, RegionStats, SubTriangle,
};
pub use silhouette::{
    face_facing, vertex_front_mask, ContourPoint, ContourSegment, Facing, FrontSide, Silhouette,
};

/// Invalid input to an intersection query.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum IntersectError {
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {face} refers to vertex {vertex}, but the mesh has {vertex_count} vertices")]
    VertexOutOfRange {
        /// The face.
        face: u32,
        /// The vertex id.
        vertex: u32,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// A face id is out of range.
    #[error("face {0} does not exist")]
    FaceOutOfRange(u32),
    /// Positions of a frame do not match the index.
    #[error("expected {expected} positions, got {got}")]
    PositionCount {
        /// Vertex count of the index.
        expected: usize,
        /// Positions given.
        got: usize,
    },
    /// The surfaces are entangled rather than in contact: a bounded query
    /// ([`bvh::PAIRS_PER_FACE`]) found more candidate face pairs than its budget.
    #[error(
        "the surfaces are entangled, not in contact: more than {budget} candidate face pairs \
         (a broken or wildly posed mesh)"
    )]
    Entangled {
        /// The query's budget.
        budget: usize,
    },
    /// A position is NaN or infinite.
    #[error("position {0} is not finite")]
    NonFinitePosition(u32),
    /// A per-vertex value (normal, field) is NaN or infinite.
    #[error("per-vertex value {0} is not finite")]
    NonFiniteValue(u32),
    /// Per-vertex values do not match the vertex count.
    #[error("expected {expected} per-vertex values, got {got}")]
    ValueCount {
        /// Vertex count.
        expected: usize,
        /// Values given.
        got: usize,
    },
    /// Part labels do not match the face count.
    #[error("expected {expected} part labels (one per face), got {got}")]
    PartCount {
        /// Face count.
        expected: usize,
        /// Labels given.
        got: usize,
    },
    /// The two parts of a self-contact were not posed on the same mesh and positions.
    #[error("self-contact parts must share their triangles and be posed with the same positions")]
    SelfContactMismatch,
    /// Face sets marked on another tree than the one queried
    /// ([`crate::intersect::Intersections::between_sets`]).
    #[error("the face sets were marked on a different tree")]
    FaceSetsMismatch,
    /// [`LeafCorners`] of another tree given to a refit ([`TriangleBvh::refit_nodes_at`]).
    #[error("the leaf corners were made for a different tree")]
    LeafCornersMismatch,
    /// Intersections passed with a mesh they were not computed on.
    #[error("the intersections refer to vertices or faces this mesh does not have")]
    Mismatch,
    /// A direction is not finite.
    #[error("direction is not finite")]
    BadDirection,
}
