//! Farthest-hit ray casts (2021 Sec. 4.2, Algorithm 1 line 16: `farthest_intersection`): each
//! vertex of a mapping region is matched with the most distant point of the other surface along
//! the mapping direction.
//!
//! The BVH is traversed like a ray cast from the far end `origin + max_t dir` back toward the
//! origin (PIPELINE.md): nodes that reach farthest are visited first, and subtrees that cannot
//! beat the best hit so far are skipped. Crossing decisions are exact (closed triangles, so a
//! ray through an edge or a vertex never slips between faces).

use super::bvh::{ray_reach, Aabb};
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
            if !can_hit(hittable, f) {
                return None;
            }
            let hit = segment_hit(mesh, f, ray, &end, range)?;
            keep_farther(&mut best, hit);
            Some(hit.t)
        });
    best
}

/// Whether face `f` is hittable under the mask (all faces for `None`; a face beyond the mask
/// is not).
fn can_hit(hittable: Option<&[bool]>, f: u32) -> bool {
    hittable.is_none_or(|m| m.get(f as usize).copied().unwrap_or(false))
}

/// Keeps `hit` in `best` when it is farther, or as far on a smaller face id (the tie rule that
/// makes the farthest hit independent of the order faces are tested in).
fn keep_farther(best: &mut Option<RayHit>, hit: RayHit) {
    if best
        .as_ref()
        .is_none_or(|b| hit.t > b.t || (hit.t == b.t && hit.face < b.face))
    {
        *best = Some(hit);
    }
}

/// Rays of one direction and reach whose origins lie on one segment `a -> b` (the bisection
/// of a mapping region's boundary along an edge, 2021 Sec. 4.2): the faces whose box the
/// ribbon they sweep may cross are gathered from the tree once, and each ray tests only them.
/// [`SegmentRays::farthest_hit`] gives [`farthest_hit_among`]'s hit to the bit: that hit is the
/// farthest over every hittable face whose box the ray reaches, whatever visits them (a face
/// skipped by the tree's pruning could not beat it), and every such face is a candidate (the
/// ribbon test is conservative, widened for the rounding of the origins and of the boxes'
/// slab test). An origin off the segment's box falls back to the tree.
pub struct SegmentRays<'m, 'a> {
    mesh: &'m PosedMesh<'a>,
    hittable: Option<&'m [bool]>,
    dir: Vector3<f64>,
    max_t: f64,
    /// Candidate faces with the box a ray cast tests for each.
    candidates: Vec<(u32, Aabb)>,
    /// The segment's box, widened by the margin: where an origin may lie.
    origins: Aabb,
    /// The ribbon's plane, when tested: a point on it, its normal and how far from it (in
    /// `|normal · (x - point)|`) an origin may lie.
    plane: Option<(Point3<f64>, Vector3<f64>, f64)>,
}

impl<'m, 'a> SegmentRays<'m, 'a> {
    /// The candidates for rays `o + t dir`, `t ∈ [0, max_t]`, from the points `o` of segment
    /// `a -> b`, on `mesh`'s faces `f` with `hittable[f]` (all for `None`).
    pub fn new(
        mesh: &'m PosedMesh<'a>,
        hittable: Option<&'m [bool]>,
        [a, b]: [Point3<f64>; 2],
        dir: Vector3<f64>,
        max_t: f64,
    ) -> Self {
        let mut out = Self {
            mesh,
            hittable,
            dir,
            max_t,
            candidates: Vec::new(),
            origins: Aabb::EMPTY,
            plane: None,
        };
        let reach = dir * max_t;
        let corners = [a, b, a + reach, b + reach];
        if !Ray::new(a, dir, max_t).is_valid()
            || !corners.iter().all(|c| c.iter().all(|x| x.is_finite()))
        {
            return out; // Every ray falls back to the tree.
        }
        // Margin: far above the rounding of an origin on the segment and of the slab test's
        // widening (relative to the coordinates and the reach).
        let scale = corners
            .iter()
            .flat_map(|c| c.iter().map(|x| x.abs()))
            .fold(0.0, f64::max);
        let margin = 1e-9 * scale;
        let widen = |bx: Aabb| Aabb {
            min: bx.min - Vector3::repeat(margin),
            max: bx.max + Vector3::repeat(margin),
        };
        out.origins = widen(Aabb::EMPTY.grown(&a).grown(&b));
        let ribbon = widen(corners.iter().fold(Aabb::EMPTY, |acc, c| acc.grown(c)));
        // The ribbon's plane (through `a`, spanned by the segment and the direction), when
        // they are far from parallel: else the rounding of the cross product tilts it.
        let normal = (b - a).cross(&dir);
        let plane = normal.iter().all(|x| x.is_finite())
            && normal.norm() >= 1e-4 * (b - a).norm() * dir.norm();
        // An origin this close to the plane sends a ray the candidates cover (half the
        // margin: the other half for the ray's drift from a plane whose normal is rounded).
        let slack = 0.5 * normal.abs().sum() * margin;
        out.plane = plane.then_some((a, normal, slack));
        let keep = |bx: &Aabb| {
            if !bx.overlaps(&ribbon) {
                return false;
            }
            if !plane {
                return true;
            }
            let center = nalgebra::center(&bx.min, &bx.max);
            let half = (bx.max - bx.min) * 0.5;
            let spread: f64 = (0..3).map(|k| normal[k].abs() * (half[k] + margin)).sum();
            normal.dot(&(center - a)).abs() <= spread
        };
        let candidates = &mut out.candidates;
        mesh.bvh().slots_where(keep, |f, bx| {
            if can_hit(hittable, f) {
                candidates.push((f, bx));
            }
        });
        out
    }

    /// The farthest hit of the ray from `origin` (a point of the segment, up to rounding; any
    /// other point is cast on the tree): [`farthest_hit_among`]'s.
    pub fn farthest_hit(&self, origin: Point3<f64>) -> Option<RayHit> {
        let ray = Ray::new(origin, self.dir, self.max_t);
        if !ray.is_valid() {
            return None;
        }
        if !self.covers(&origin) {
            return farthest_hit_among(self.mesh, &ray, self.hittable);
        }
        let end = ray.origin + ray.dir * ray.max_t;
        let inv = ray.dir.map(|d| 1.0 / d);
        let mut best: Option<RayHit> = None;
        let mut best_t = f64::NEG_INFINITY;
        for (f, bx) in &self.candidates {
            let Some(range) = ray_reach(bx, &origin, &inv, ray.max_t).filter(|r| r[1] >= best_t)
            else {
                continue;
            };
            let Some(hit) = segment_hit(self.mesh, *f, &ray, &end, range) else {
                continue;
            };
            keep_farther(&mut best, hit);
            best_t = best_t.max(hit.t);
        }
        best
    }

    /// Whether the ray from `origin` stays where the candidates were gathered: the origin in
    /// the segment's box and on the ribbon's plane (both widened by the margin).
    fn covers(&self, origin: &Point3<f64>) -> bool {
        self.origins.contains(origin)
            && self
                .plane
                .is_none_or(|(point, normal, slack)| normal.dot(&(origin - point)).abs() <= slack)
    }
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
