//! Farthest-hit ray casts (2021 Sec. 4.2, Algorithm 1 line 16: `farthest_intersection`): each
//! vertex of a mapping region is matched with the most distant point of the other surface along
//! the mapping direction.
//!
//! The BVH is traversed like a ray cast from the far end `origin + max_t dir` back toward the
//! origin (PIPELINE.md): nodes that reach farthest are visited first, and subtrees that cannot
//! beat the best hit so far are skipped. Crossing decisions are exact (closed triangles, so a
//! ray through an edge or a vertex never slips between faces).

use super::index::PosedMesh;
use super::mesh_mesh::barycentric;
use super::predicates::orient3d;
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

/// A ray `origin + t dir`, `t ∈ [0, max_t]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start point.
    pub origin: Point3<f64>,
    /// Direction (unit for `t` to be a distance).
    pub dir: Vector3<f64>,
    /// Largest parameter considered.
    pub max_t: f64,
}

/// The intersection of a ray with a face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// The face hit.
    pub face: u32,
    /// Ray parameter of the hit.
    pub t: f64,
    /// Barycentric coordinates on the face (order of its corners).
    pub bary: [f64; 3],
    /// `origin + t dir`.
    pub point: Point3<f64>,
}

impl Ray {
    /// The ray `origin + t dir` for `t ∈ [0, max_t]`.
    pub fn new(origin: Point3<f64>, dir: Vector3<f64>, max_t: f64) -> Self {
        Self { origin, dir, max_t }
    }

    fn is_valid(&self) -> bool {
        self.origin
            .iter()
            .chain(self.dir.iter())
            .all(|x| x.is_finite())
            && self.max_t.is_finite()
            && self.max_t >= 0.0
            && self.dir != Vector3::zeros()
    }
}

/// The farthest intersection of `ray` with the faces of `mesh` (largest `t` in `[0, max_t]`; ties
/// go to the smallest face id). `None` when nothing is hit or the ray is invalid (non-finite,
/// zero direction, negative `max_t`).
pub fn farthest_hit(mesh: &PosedMesh, ray: &Ray) -> Option<RayHit> {
    farthest_hit_among(mesh, ray, None)
}

/// [`farthest_hit`] among the faces `f` with `hittable[f]` (all faces for `None`; a face
/// beyond the mask is not hittable).
pub fn farthest_hit_among(
    mesh: &PosedMesh,
    ray: &Ray,
    hittable: Option<&[bool]>,
) -> Option<RayHit> {
    if !ray.is_valid() {
        return None;
    }
    let end = ray.origin + ray.dir * ray.max_t;
    let mut best: Option<RayHit> = None;
    mesh.bvh()
        .farthest_along(&ray.origin, &ray.dir, ray.max_t, |f, range| {
            if hittable.is_some_and(|m| !m.get(f as usize).copied().unwrap_or(false)) {
                return None;
            }
            let hit = segment_hit(mesh, f, ray, &end, range)?;
            let better = best
                .as_ref()
                .is_none_or(|b| hit.t > b.t || (hit.t == b.t && hit.face < b.face));
            if better {
                best = Some(hit);
            }
            Some(hit.t)
        });
    best
}

/// [`farthest_hit`] for many rays, in parallel; the output follows the input order.
pub fn farthest_hits(mesh: &PosedMesh, rays: &[Ray]) -> Vec<Option<RayHit>> {
    farthest_hits_among(mesh, rays, None)
}

/// [`farthest_hit_among`] for many rays, in parallel; the output follows the input order.
pub fn farthest_hits_among(
    mesh: &PosedMesh,
    rays: &[Ray],
    hittable: Option<&[bool]>,
) -> Vec<Option<RayHit>> {
    rays.par_iter()
        .with_min_len(64)
        .map(|r| farthest_hit_among(mesh, r, hittable))
        .collect()
}

/// Exact test of the segment `origin -> end` against face `f` (closed triangle), with the hit
/// parameter measured from the origin and clamped to `range` (the ray inside the face's box).
fn segment_hit(
    mesh: &PosedMesh,
    f: u32,
    ray: &Ray,
    end: &Point3<f64>,
    range: [f64; 2],
) -> Option<RayHit> {
    let c = mesh.corners(f);
    let o = &ray.origin;
    let (so, se) = (
        orient3d(c[0], c[1], c[2], o),
        orient3d(c[0], c[1], c[2], end),
    );
    if (so == 0 && se == 0) || so * se > 0 {
        return None;
    }
    let e: [i8; 3] = std::array::from_fn(|k| orient3d(o, end, c[k], c[(k + 1) % 3]));
    let s = e.iter().copied().find(|&x| x != 0)?;
    if e.iter().any(|&x| x == -s) {
        return None;
    }
    let t = hit_parameter(c, ray, so, se).clamp(range[0], range[1].max(range[0]));
    Some(RayHit {
        face: f,
        t,
        bary: barycentric(o, end, c, s),
        point: ray.origin + ray.dir * t,
    })
}

/// `t` of the plane crossing, consistent with the exact signs at both ends.
fn hit_parameter(c: [&Point3<f64>; 3], ray: &Ray, so: i8, se: i8) -> f64 {
    if so == 0 {
        return 0.0;
    }
    if se == 0 {
        return ray.max_t;
    }
    let n = (c[1] - c[0]).cross(&(c[2] - c[0]));
    let t = n.dot(&(c[0] - ray.origin)) / n.dot(&ray.dir);
    if t.is_finite() {
        t.clamp(0.0, ray.max_t)
    } else {
        0.5 * ray.max_t
    }
}
