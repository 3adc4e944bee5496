//! The potential contact surface `S` (2021 Sec. 4.3) and the contact zones with their exact
//! boundaries (Sec. 4.4, Eq. 3-5; Algorithm 1 lines 17-27).
//!
//! Every point of a mapping region is sampled on `S`: `p' = p + (1 - k̄_l) δ` with
//! `δ = p'' - p` (line 20, `k̄_l` the relative stiffness of the own side), and its normal on
//! `S` is the corrected formula of `PIPELINE.md` (Appendix A as printed is off by up to 90°):
//! with `c_o = n_o·m̂`, `c_x = n_x·m̂` (`m̂` the own cast direction),
//! `v = k̄_own |c_x| sgn(c_o) n_o + k̄_other |c_o| sgn(c_x) n_x`, `n' = v / |v|`. Then `δ·n' ≥ 0`
//! and the other side gets the same value at the same point of `S` (symmetry).
//!
//! The threshold `ε_c = m_S + τ σ_S` (Eq. 4) uses the area-weighted mean and standard deviation
//! of `δ·n'` over both projected mapping regions, clipped exactly at their boundary points, so
//! it moves continuously as vertices enter or leave the regions.

use super::mapping::{
    interpolated_normal, map_point, mapping_of, Mapping, MappingRegion, SideFrame,
};
use crate::intersect::SegmentRays;
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;

/// The safeguard angle of Sec. 4.4 (degrees): a vertex stays out of the contact zone unless
/// its own normal is within this angle of its side's direction `d̄_l` and the other side's
/// normal at its mapping within this angle of `-d̄_l` (`min(-d̂ᵀn_i, d̂ᵀn''_i) ≥ cos 80°`,
/// `d̂` the ray's direction). The paper's value; [`crate::contact::PairParams::safeguard_angle`].
pub const DEFAULT_SAFEGUARD_ANGLE: f64 = 80.0;

/// `cos 80°` correctly rounded: the default's cosine does not depend on the platform's `cos`
/// (one unit in the last place of the threshold moves CesiumMan's count of penetrating
/// vertices by several: round-off at the pass's ties).
const DEFAULT_SAFEGUARD_COS: f64 = 0.173_648_177_666_930_4;

/// The safeguard of [`SurfaceSample::safeguard`] for an angle in degrees: its cosine, exactly
/// 0 from 90° on.
pub fn safeguard_cos(angle_degrees: f64) -> f64 {
    if angle_degrees == DEFAULT_SAFEGUARD_ANGLE {
        DEFAULT_SAFEGUARD_COS
    } else if angle_degrees >= 90.0 {
        0.0
    } else {
        angle_degrees.to_radians().cos()
    }
}

/// A point of a mapping region and its image on the potential contact surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceSample {
    /// The point on the own surface.
    pub point: Point3<f64>,
    /// Unit own normal at the point.
    pub own_normal: Vector3<f64>,
    /// Its mapping onto the other surface.
    pub mapping: Mapping,
    /// `p'`: the point on `S`.
    pub surface_point: Point3<f64>,
    /// `n'`: the normal of `S` there (zero where undefined).
    pub surface_normal: Vector3<f64>,
    /// `δ·n'` (Eq. 3).
    pub depth: f64,
    /// `min(n_own·d̄_l, -n_other·d̄_l)` (the safeguard of Sec. 4.4).
    pub safeguard: f64,
}

/// How the potential surface is built on one side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceFrame {
    /// `m̂_l`.
    pub cast: Vector3<f64>,
    /// `k̄_l`, the relative stiffness of this side.
    pub stiffness: f64,
}

impl SurfaceFrame {
    /// Samples `point` (with unit own normal `own_normal`) mapped to `mapping`.
    pub fn sample(
        &self,
        point: Point3<f64>,
        own_normal: Vector3<f64>,
        mapping: Mapping,
    ) -> SurfaceSample {
        let delta = mapping.target - point;
        let (k_own, k_other) = (self.stiffness, 1.0 - self.stiffness);
        let n_x = mapping.target_normal;
        let (c_o, c_x) = (own_normal.dot(&self.cast), n_x.dot(&self.cast));
        let v =
            own_normal * (k_own * c_x.abs() * sign(c_o)) + n_x * (k_other * c_o.abs() * sign(c_x));
        let surface_normal = v.try_normalize(1e-300).unwrap_or_else(Vector3::zeros);
        SurfaceSample {
            point,
            own_normal,
            mapping,
            surface_point: point + delta * k_other,
            surface_normal,
            depth: delta.dot(&surface_normal),
            safeguard: (-c_o).min(c_x),
        }
    }
}

fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// Samples indexed by mesh vertex, stored only for the vertices that have one (a mapping
/// region is a small part of its mesh: a mesh-sized array of samples cost page faults per fold).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VertexSamples {
    /// Per mesh vertex, the index of its sample in `values` (`u32::MAX`: none).
    slot: Vec<u32>,
    values: Vec<SurfaceSample>,
}

impl VertexSamples {
    /// No sample on a mesh of `vertex_count` vertices.
    pub fn new(vertex_count: usize) -> Self {
        Self {
            slot: vec![u32::MAX; vertex_count],
            values: Vec::new(),
        }
    }

    /// Number of mesh vertices (not of samples).
    pub fn len(&self) -> usize {
        self.slot.len()
    }

    /// Whether the mesh has no vertex.
    pub fn is_empty(&self) -> bool {
        self.slot.is_empty()
    }

    /// The sample of mesh vertex `v`, if it has one (`None` also out of range).
    pub fn get(&self, v: usize) -> Option<&SurfaceSample> {
        let k = *self.slot.get(v)?;
        self.values.get(k as usize)
    }

    /// Whether mesh vertex `v` has a sample.
    pub fn contains(&self, v: usize) -> bool {
        self.slot.get(v).is_some_and(|&k| k != u32::MAX)
    }

    /// Sets the sample of mesh vertex `v` (ignored out of range).
    pub fn insert(&mut self, v: usize, sample: SurfaceSample) {
        let Some(k) = self.slot.get_mut(v) else {
            return;
        };
        if *k == u32::MAX {
            *k = self.values.len() as u32;
            self.values.push(sample);
        } else {
            self.values[*k as usize] = sample;
        }
    }
}

/// Ray casts of the bisection that places a boundary point of `M_l` on an edge with neither an
/// intersection point nor a quad crossing: the point is found to `2^-16` of the edge (1.5e-5
/// edge lengths). Each step casts one ray; these rays outnumbered the mapping's own by 12 to 1
/// on the finger at the former 30 steps (47 bisected edges per fold, 119 mapping rays).
pub const BISECTION_STEPS: usize = 16;

/// The samples of one side: at its mapped vertices, and at the boundary of its mapping region
/// on every edge leaving it.
#[derive(Clone, Debug, Default)]
pub struct SideSamples {
    /// Per mesh vertex, the sample of a vertex of `M_l`.
    pub vertices: VertexSamples,
    /// Per directed edge `(inside, outside)` of `M_l`: parameter from the inside vertex of the
    /// boundary point of `M_l`, and its sample.
    pub boundary: HashMap<(u32, u32), (f64, SurfaceSample)>,
    /// Boundary points found by bisection of ray hits (no intersection point nor quad on the
    /// edge): approximate to `2^-BISECTION_STEPS` of the edge.
    pub bisected: usize,
}

/// The edge–face intersection points of one side, per edge, as mappings onto the other side.
pub type EdgeHits = HashMap<[u32; 2], Vec<(f64, Mapping)>>;

/// Everything needed to sample one side.
#[derive(Clone, Copy)]
pub struct SideInput<'r, 'm, 'a> {
    /// The own surface.
    pub own: SideFrame<'m, 'a>,
    /// The other surface.
    pub other: SideFrame<'m, 'a>,
    /// `M_l`.
    pub region: &'r MappingRegion,
    /// Intersection points on own edges.
    pub hits: &'r EdgeHits,
    /// Cast direction and stiffness.
    pub frame: SurfaceFrame,
    /// Ray length bound.
    pub reach: f64,
}

impl SideInput<'_, '_, '_> {
    /// Samples every vertex of `M_l` and the boundary point of every edge leaving it.
    pub fn samples(&self) -> SideSamples {
        let positions = self.own.mesh.positions();
        let index = self.own.mesh.index();
        let mut out = SideSamples {
            vertices: VertexSamples::new(positions.len()),
            ..Default::default()
        };
        for &v in &self.region.members {
            if let Some(m) = self.region.mapped[v as usize] {
                let s = self
                    .frame
                    .sample(positions[v as usize], self.own.normals[v as usize], m);
                out.vertices.insert(v as usize, s);
            }
        }
        for &v in &self.region.members {
            for &e in index.vertex_edges(v) {
                let [a, b] = index.edges()[e as usize];
                let w = if a == v { b } else { a };
                if out.vertices.contains(w as usize) {
                    continue;
                }
                let (t, s, bisected) = self.boundary_sample(v, w);
                out.bisected += bisected as usize;
                out.boundary.insert((v, w), (t, s));
            }
        }
        out
    }

    /// The boundary point of `M_l` on edge `i -> j` (`i` mapped, `j` not): the nearest
    /// intersection point or quad crossing on the edge, else the last point whose ray hits.
    fn boundary_sample(&self, i: u32, j: u32) -> (f64, SurfaceSample, bool) {
        let key = [i.min(j), i.max(j)];
        let from_i = |t: f64| if i < j { t } else { 1.0 - t };
        let mut best: Option<(f64, Mapping)> = None;
        let hits = self.hits.get(&key).into_iter().flatten().copied();
        let walls = self
            .region
            .walls
            .get(&key)
            .into_iter()
            .flatten()
            .map(|w| (w.t, w.mapping));
        for (t, m) in hits.chain(walls) {
            let t = from_i(t);
            if best.is_none_or(|(bt, _)| t < bt) {
                best = Some((t, m));
            }
        }
        let (pi, pj) = (self.point(i), self.point(j));
        if let Some((t, m)) = best {
            let p = pi + (pj - pi) * t;
            return (
                t,
                self.frame.sample(p, self.normal_on_edge(i, j, t), m),
                false,
            );
        }
        let (t, m) = self.bisect(i, j);
        let p = pi + (pj - pi) * t;
        (
            t,
            self.frame.sample(p, self.normal_on_edge(i, j, t), m),
            true,
        )
    }

    fn bisect(&self, i: u32, j: u32) -> (f64, Mapping) {
        let (pi, pj) = (self.point(i), self.point(j));
        let mut last = self.region.mapped[i as usize].unwrap_or(Mapping {
            target: pi,
            target_normal: Vector3::zeros(),
        });
        // Every step's ray starts on the edge: its candidate faces gathered once.
        let rays = SegmentRays::new(
            self.other.mesh,
            self.other.hittable,
            [pi, pj],
            self.frame.cast,
            self.reach,
        );
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            match rays
                .farthest_hit(pi + (pj - pi) * mid)
                .map(|h| mapping_of(self.other, &h))
            {
                Some(m) => {
                    lo = mid;
                    last = m;
                }
                None => hi = mid,
            }
        }
        (lo, last)
    }

    fn point(&self, v: u32) -> Point3<f64> {
        self.own.mesh.positions()[v as usize]
    }

    /// Unit interpolated own normal at parameter `t` from `i` toward `j`.
    pub fn normal_on_edge(&self, i: u32, j: u32, t: f64) -> Vector3<f64> {
        let n = self.own.normals;
        (n[i as usize] * (1.0 - t) + n[j as usize] * t)
            .try_normalize(1e-12)
            .unwrap_or(n[i as usize])
    }
}

/// Area-weighted first and second moments of `δ·n'` over the projected mapping region of one
/// side (its `faces` with at least one mapped corner, clipped at the boundary points; linear
/// data integrated exactly). Only the side's own faces: two parts of one mesh share the
/// crease cut's vertices, whose samples would otherwise bring the other part's faces along
/// that seam into this side's region.
pub fn depth_moments(triangles: &[[u32; 3]], faces: &[u32], samples: &SideSamples) -> [f64; 3] {
    let mut m = [0.0; 3];
    for t in faces.iter().map(|&f| &triangles[f as usize]) {
        if !t.iter().any(|&v| samples.vertices.contains(v as usize)) {
            continue;
        }
        let mut poly: Vec<&SurfaceSample> = Vec::with_capacity(4);
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let (sa, sb) = (
                samples.vertices.get(a as usize),
                samples.vertices.get(b as usize),
            );
            if let Some(s) = sa {
                poly.push(s);
            }
            let crossing = match (sa, sb) {
                (Some(_), None) => samples.boundary.get(&(a, b)),
                (None, Some(_)) => samples.boundary.get(&(b, a)),
                _ => None,
            };
            if let Some((_, s)) = crossing {
                poly.push(s);
            }
        }
        for k in 1..poly.len().saturating_sub(1) {
            let [a, b, c] = [poly[0], poly[k], poly[k + 1]];
            let area = 0.5
                * (b.surface_point - a.surface_point)
                    .cross(&(c.surface_point - a.surface_point))
                    .norm();
            let [fa, fb, fc] = [a.depth, b.depth, c.depth];
            m[0] += area;
            m[1] += area * (fa + fb + fc) / 3.0;
            m[2] += area / 6.0 * (fa * fa + fb * fb + fc * fc + fa * fb + fb * fc + fc * fa);
        }
    }
    m
}

/// Eq. 4: `ε_c = m_S + τ σ_S` from the summed moments of both sides; also returns `(m, σ)`.
/// The two sides are summed in a canonical order, so swapping them gives the same bits.
pub fn threshold(mut moments: [[f64; 3]; 2], tau: f64) -> (f64, f64, f64) {
    let key = |m: &[f64; 3]| m.map(f64::to_bits);
    if key(&moments[1]) < key(&moments[0]) {
        moments.swap(0, 1);
    }
    let area = moments[0][0] + moments[1][0];
    if area.is_nan() || area <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let mean = (moments[0][1] + moments[1][1]) / area;
    let var = ((moments[0][2] + moments[1][2]) / area - mean * mean).max(0.0);
    let sigma = var.sqrt();
    (mean + tau * sigma, mean, sigma)
}

/// An exact boundary point of a contact zone (Eq. 5), projected onto `S`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZoneBoundaryPoint {
    /// The zone vertex of the edge.
    pub inside: u32,
    /// The vertex outside the zone.
    pub outside: u32,
    /// Parameter from `inside` toward `outside`.
    pub alpha: f64,
    /// Its sample on `S` (`surface_point` is `p'_ij`).
    pub sample: SurfaceSample,
}

/// The contact zone `C_l` of one side (Eq. 3 and the safeguard) and its exact boundary.
#[derive(Clone, Debug, Default)]
pub struct Zone {
    /// Per mesh vertex: in `C_l`.
    pub inside: Vec<bool>,
    /// The zone's vertices, sorted.
    pub vertices: Vec<u32>,
    /// One point per edge leaving the zone.
    pub boundary: Vec<ZoneBoundaryPoint>,
}

fn in_zone(s: &SurfaceSample, eps: f64, guard: f64) -> bool {
    s.depth >= eps && s.safeguard >= guard
}

/// Lines 23-27: the zone of one side for threshold `eps` and safeguard `guard` (the cosine of
/// the safeguard angle, [`safeguard_cos`]).
pub fn zone(input: &SideInput, samples: &SideSamples, eps: f64, guard: f64) -> Zone {
    let index = input.own.mesh.index();
    let n = samples.vertices.len();
    let inside: Vec<bool> = (0..n)
        .map(|v| {
            samples
                .vertices
                .get(v)
                .is_some_and(|s| in_zone(s, eps, guard))
        })
        .collect();
    let vertices: Vec<u32> = (0..n as u32).filter(|&v| inside[v as usize]).collect();
    let mut boundary = Vec::new();
    for &i in &vertices {
        let Some(si) = samples.vertices.get(i as usize) else {
            continue;
        };
        for &e in index.vertex_edges(i) {
            let [a, b] = index.edges()[e as usize];
            let j = if a == i { b } else { a };
            if inside[j as usize] {
                continue;
            }
            let (t_end, sj) = match (
                samples.vertices.get(j as usize),
                samples.boundary.get(&(i, j)),
            ) {
                (Some(s), _) => (1.0, s),
                (None, Some((t, s))) => (*t, s),
                (None, None) => continue,
            };
            let lambda = first_exit(si, sj, eps, guard);
            boundary.push(project(input, i, j, lambda * t_end, lambda, si, sj));
        }
    }
    Zone {
        inside,
        vertices,
        boundary,
    }
}

/// Eq. 5: the smallest `λ ∈ (0, 1]` where the linearly interpolated criterion or safeguard
/// stops holding between samples `a` (inside) and `b`.
fn first_exit(a: &SurfaceSample, b: &SurfaceSample, eps: f64, guard: f64) -> f64 {
    let (da, db) = (a.mapping.target - a.point, b.mapping.target - b.point);
    let (na, nb) = (a.surface_normal, b.surface_normal);
    let c0 = na.dot(&da) - eps;
    let c1 = na.dot(&(db - da)) + (nb - na).dot(&da);
    let c2 = (nb - na).dot(&(db - da));
    let mut best = 1.0f64;
    for r in quadratic_roots(c0, c1, c2).into_iter().flatten() {
        if r > 0.0 && r <= 1.0 {
            best = best.min(r);
        }
    }
    let (ga, gb) = (a.safeguard - guard, b.safeguard - guard);
    if gb < 0.0 && ga >= 0.0 && ga != gb {
        best = best.min(ga / (ga - gb));
    }
    best.clamp(0.0, 1.0)
}

/// Real roots of `c0 + c1 x + c2 x²` (numerically stable form), without allocating: at most
/// two, in the order the formula gives them.
pub fn quadratic_roots(c0: f64, c1: f64, c2: f64) -> [Option<f64>; 2] {
    let scale = c0.abs().max(c1.abs()).max(c2.abs());
    if scale == 0.0 || !scale.is_finite() {
        return [None, None];
    }
    if c2.abs() <= 1e-14 * scale {
        return [(c1 != 0.0).then(|| -c0 / c1), None];
    }
    let disc = c1 * c1 - 4.0 * c2 * c0;
    if disc < 0.0 {
        return [None, None];
    }
    let q = -0.5 * (c1 + c1.signum() * disc.sqrt());
    [Some(q / c2), (q != 0.0).then(|| c0 / q)]
}

/// Places the boundary point at parameter `alpha` of edge `i -> j` and projects it onto `S`
/// along the cast direction (falling back to interpolating the two samples when the ray does not
/// land near them).
fn project(
    input: &SideInput,
    i: u32,
    j: u32,
    alpha: f64,
    lambda: f64,
    si: &SurfaceSample,
    sj: &SurfaceSample,
) -> ZoneBoundaryPoint {
    let positions = input.own.mesh.positions();
    let (pi, pj) = (positions[i as usize], positions[j as usize]);
    let point = pi + (pj - pi) * alpha;
    let normal = input.normal_on_edge(i, j, alpha);
    let lerp_target = si.mapping.target + (sj.mapping.target - si.mapping.target) * lambda;
    let edge_len = (pj - pi).norm();
    let cast = map_point(input.other, &point, &input.frame.cast, input.reach)
        .filter(|m| (m.target - lerp_target).norm() <= edge_len);
    let mapping = if lambda >= 1.0 {
        sj.mapping
    } else {
        cast.unwrap_or(Mapping {
            target: lerp_target,
            target_normal: (si.mapping.target_normal * (1.0 - lambda)
                + sj.mapping.target_normal * lambda)
                .try_normalize(1e-12)
                .unwrap_or(si.mapping.target_normal),
        })
    };
    ZoneBoundaryPoint {
        inside: i,
        outside: j,
        alpha,
        sample: input.frame.sample(point, normal, mapping),
    }
}

/// The intersection points of `side`'s edges as mappings onto the other surface.
pub fn edge_hits(
    ints: &crate::intersect::Intersections,
    side: crate::intersect::Side,
    other: SideFrame,
) -> EdgeHits {
    let mut out: EdgeHits = HashMap::new();
    for h in ints.hits.iter().filter(|h| h.side == side) {
        let m = Mapping {
            target: h.point,
            target_normal: interpolated_normal(other, h.face, h.bary),
        };
        out.entry(h.edge).or_default().push((h.t, m));
    }
    out
}

#[cfg(test)]
mod tests {
    //! The potential surface against analytic cases (`PIPELINE.md`: Appendix A as printed is
    //! off by up to 90°). A lies below with top surface `z = f_A(x, y)` (outward +z), B above
    //! with bottom surface `z = f_B(x, y)` (outward -z), `f_B < f_A` where they overlap. Both
    //! are cast along the vertical, so `S` is the height field
    //! `z_S = k̄_A f_A + (1 - k̄_A) f_B` with upward normal `normalize(-∇z_S, 1)`.
    use super::*;

    type Height = dyn Fn(f64, f64) -> (f64, [f64; 2]);

    /// Angle between two vectors, accurate near 0 (unlike `acos`).
    fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        a.cross(b).norm().atan2(a.dot(b))
    }

    fn up_normal(grad: [f64; 2]) -> Vector3<f64> {
        Vector3::new(-grad[0], -grad[1], 1.0).normalize()
    }

    /// Largest angle (radians) between the sampled `n'` and the analytic normal of `S`, and
    /// largest distance between `p'` and `S`, over a grid, from both sides.
    fn worst(fa: &Height, fb: &Height, k_a: f64) -> (f64, f64) {
        let (mut angle, mut dist) = (0.0f64, 0.0f64);
        for i in -4..=4 {
            for j in -4..=4 {
                let (x, y) = (0.05 * f64::from(i), 0.05 * f64::from(j));
                let ((za, ga), (zb, gb)) = (fa(x, y), fb(x, y));
                let (zs, gs) = (
                    k_a * za + (1.0 - k_a) * zb,
                    [
                        k_a * ga[0] + (1.0 - k_a) * gb[0],
                        k_a * ga[1] + (1.0 - k_a) * gb[1],
                    ],
                );
                let n_s = up_normal(gs);
                let n_a = up_normal(ga);
                let n_b = -up_normal(gb);
                let (pa, pb) = (Point3::new(x, y, za), Point3::new(x, y, zb));
                let side_a = SurfaceFrame {
                    cast: -Vector3::z(),
                    stiffness: k_a,
                };
                let side_b = SurfaceFrame {
                    cast: Vector3::z(),
                    stiffness: 1.0 - k_a,
                };
                let sa = side_a.sample(
                    pa,
                    n_a,
                    Mapping {
                        target: pb,
                        target_normal: n_b,
                    },
                );
                let sb = side_b.sample(
                    pb,
                    n_b,
                    Mapping {
                        target: pa,
                        target_normal: n_a,
                    },
                );
                // A's n' points into A (down), B's into B (up); same point of S from both.
                angle = angle.max(self::angle(&-sa.surface_normal, &n_s));
                angle = angle.max(self::angle(&sb.surface_normal, &n_s));
                dist = dist.max((sa.surface_point.z - zs).abs());
                dist = dist.max((sb.surface_point - sa.surface_point).norm());
                assert!(sa.depth >= 0.0 && (sa.depth - sb.depth).abs() < 1e-14 * (1.0 + sa.depth));
            }
        }
        (angle, dist)
    }

    /// Eq. 5 with the safeguard: along an edge whose depth criterion holds throughout, the
    /// zone's boundary is where the linearly interpolated safeguard crosses the cosine of the
    /// safeguard angle, whatever the angle.
    #[test]
    fn the_zone_boundary_follows_the_safeguard_angle() {
        let frame = SurfaceFrame {
            cast: -Vector3::z(),
            stiffness: 0.5,
        };
        // Own normal in the x-z plane at `angle` from the direction `-cast = +z`; the other
        // side's normal exactly against it, one unit below.
        let sample = |x: f64, angle: f64| {
            let n = Vector3::new(angle.to_radians().sin(), 0.0, angle.to_radians().cos());
            let point = Point3::new(x, 0.0, 0.0);
            let mapping = Mapping {
                target: point - Vector3::z(),
                target_normal: -n,
            };
            frame.sample(point, n, mapping)
        };
        let (a, b) = (sample(0.0, 60.0), sample(1.0, 89.0));
        assert!((a.safeguard - 0.5).abs() < 1e-12 && a.depth > 0.0 && b.depth > 0.0);
        for angle in [80.0, 70.0, 65.0] {
            let guard = safeguard_cos(angle);
            let cos = |deg: f64| deg.to_radians().cos();
            let expected = (cos(60.0) - cos(angle)) / (cos(60.0) - cos(89.0));
            let lambda = first_exit(&a, &b, -1.0, guard);
            assert!(
                (lambda - expected).abs() < 1e-12,
                "{angle}°: {lambda} {expected}"
            );
            assert!(in_zone(&a, -1.0, guard) && !in_zone(&b, -1.0, guard));
        }
        assert_eq!(
            safeguard_cos(DEFAULT_SAFEGUARD_ANGLE),
            0.173_648_177_666_930_4
        );
        assert_eq!(safeguard_cos(90.0), 0.0);
    }

    /// A boundary point of a mapping region found by bisection is the last point of the edge
    /// whose ray lands on a hittable face of the other side: the self-contact pass's mask
    /// stops it where the hittable faces end, as it stops the vertices' rays.
    #[test]
    fn bisected_boundary_points_stop_where_the_hittable_faces_end() {
        use crate::contact::mapping::{mapping_of, MappingRegion};
        use crate::intersect::{MeshIndex, Ray};
        // Own side: one triangle at z = 0, cast up. Other side: a square at z = 1 over
        // x in [-1, 0.25] (faces 0, 1) and one at z = 3 over x in [-1, 1] (faces 2, 3).
        let own_pos = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(0.5, 0.0, 0.0),
            Point3::new(0.0, 0.5, 0.0),
        ];
        let own_tri = vec![[0, 1, 2]];
        let mut other_pos = Vec::new();
        for (x1, z) in [(0.25, 1.0), (1.0, 3.0)] {
            for (x, y) in [(-1.0, -1.0), (x1, -1.0), (x1, 1.0), (-1.0, 1.0)] {
                other_pos.push(Point3::new(x, y, z));
            }
        }
        let other_tri = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
        let (own_index, other_index) = (
            MeshIndex::new(&own_pos, &own_tri).expect("own"),
            MeshIndex::new(&other_pos, &other_tri).expect("other"),
        );
        let (own_mesh, other_mesh) = (
            own_index.pose(&own_pos).expect("own"),
            other_index.pose(&other_pos).expect("other"),
        );
        let (own_n, other_n) = (vec![Vector3::z(); 3], vec![-Vector3::z(); 8]);
        let near_only = [true, true, false, false];
        let hits = EdgeHits::new();
        let boundary_of_edge_0_1 = |hittable: Option<&[bool]>| {
            let other = SideFrame {
                mesh: &other_mesh,
                normals: &other_n,
                hittable,
            };
            let target = other.farthest_hit(&Ray::new(own_pos[0], Vector3::z(), 10.0));
            let region = MappingRegion {
                mapped: vec![target.map(|h| mapping_of(other, &h)), None, None],
                members: vec![0],
                ..Default::default()
            };
            let input = SideInput {
                own: SideFrame {
                    mesh: &own_mesh,
                    normals: &own_n,
                    hittable: None,
                },
                other,
                region: &region,
                hits: &hits,
                frame: SurfaceFrame {
                    cast: Vector3::z(),
                    stiffness: 0.5,
                },
                reach: 10.0,
            };
            let samples = input.samples();
            let (t, s) = samples.boundary[&(0, 1)];
            (t, s.mapping.target.z)
        };
        let (t, z) = boundary_of_edge_0_1(Some(&near_only));
        assert!((t - 0.5).abs() < 1e-4 && z == 1.0, "masked: t {t}, z {z}");
        let (t, z) = boundary_of_edge_0_1(None);
        assert!(t > 1.0 - 1e-4 && z == 3.0, "every face: t {t}, z {z}");
    }

    #[test]
    fn potential_surface_normal_matches_two_planes() {
        let fa = |x: f64, y: f64| (0.3 + 0.4 * x - 0.7 * y, [0.4, -0.7]);
        let fb = |x: f64, y: f64| (-0.7 - 1.3 * x + 0.2 * y, [-1.3, 0.2]);
        for k in [0.0, 0.25, 0.5, 0.75, 1.0] {
            let (angle, dist) = worst(&fa, &fb, k);
            assert!(angle < 1e-12 && dist < 1e-14, "k̄ {k}: {angle} rad, {dist}");
        }
    }

    #[test]
    fn potential_surface_normal_matches_two_spheres() {
        // A: sphere of radius 1 centered at (0, 0, -0.8) (top cap); B: radius 0.6 centered at
        // (0.1, -0.05, 0.4) (bottom cap).
        let fa = |x: f64, y: f64| {
            let r = (1.0 - x * x - y * y).sqrt();
            (-0.8 + r, [-x / r, -y / r])
        };
        let fb = |x: f64, y: f64| {
            let (dx, dy) = (x - 0.1, y + 0.05);
            let r = (0.36 - dx * dx - dy * dy).sqrt();
            (0.4 - r, [dx / r, dy / r])
        };
        for k in [0.0, 0.25, 0.5, 0.75, 1.0] {
            let (angle, dist) = worst(&fa, &fb, k);
            assert!(angle < 1e-12 && dist < 1e-14, "k̄ {k}: {angle} rad, {dist}");
        }
    }

    #[test]
    fn printed_appendix_a_formula_is_off_against_two_spheres() {
        // Appendix A as printed, for a vertex of M_1 (here A, d̂ oriented along the second
        // mesh's normal field, i.e. d̂ = -z... we evaluate it as printed with d̂ = -z):
        // η = (I - d̂ᵀd̂)(k̄_2 |n2·d̂| / sgn(n1·d̂) n1 + (1 - k̄_2)|n1·d̂| / sgn(n2·d̂) n2)
        //     - |n1·d̂||n2·d̂| d̂. It disagrees with the analytic normal by many degrees.
        let d = -Vector3::z();
        let (x, y) = (0.2, 0.15);
        let r = (1.0f64 - x * x - y * y).sqrt();
        let n1 = up_normal([-x / r, -y / r]);
        let (dx, dy) = (x - 0.1, y + 0.05);
        let rb = (0.36f64 - dx * dx - dy * dy).sqrt();
        let n2 = -up_normal([dx / rb, dy / rb]);
        let k2 = 0.5;
        let proj = |v: Vector3<f64>| v - d * d.dot(&v);
        let eta = proj(
            n1 * (k2 * n2.dot(&d).abs() / n1.dot(&d).signum())
                + n2 * ((1.0 - k2) * n1.dot(&d).abs() / n2.dot(&d).signum()),
        ) - d * (n1.dot(&d).abs() * n2.dot(&d).abs());
        let analytic = up_normal([
            0.5 * (-x / r) + 0.5 * (dx / rb),
            0.5 * (-y / r) + 0.5 * (dy / rb),
        ]);
        let printed = eta.normalize();
        let off = printed
            .angle(&analytic)
            .min(printed.angle(&-analytic))
            .to_degrees();
        eprintln!("printed Appendix A normal off by {off:.1}°");
        assert!(off > 5.0, "printed formula off by {off}°");
    }

    /// The sparse per-vertex store answers like the mesh-sized `Vec<Option<_>>` it replaced.
    #[test]
    fn vertex_samples_behave_like_a_mesh_sized_array() {
        let frame = SurfaceFrame {
            cast: -Vector3::z(),
            stiffness: 0.5,
        };
        let at = |z: f64| {
            frame.sample(
                Point3::new(0.0, 0.0, z),
                Vector3::z(),
                Mapping {
                    target: Point3::new(0.0, 0.0, 2.0),
                    target_normal: -Vector3::z(),
                },
            )
        };
        let mut store = VertexSamples::new(5);
        let mut dense: Vec<Option<SurfaceSample>> = vec![None; 5];
        for (v, z) in [(3, 0.0), (1, 0.5), (3, 1.0), (7, 0.2)] {
            store.insert(v, at(z));
            if let Some(slot) = dense.get_mut(v) {
                *slot = Some(at(z));
            }
        }
        assert_eq!(store.len(), 5);
        for v in 0..8 {
            assert_eq!(
                store.get(v),
                dense.get(v).and_then(Option::as_ref),
                "vertex {v}"
            );
            assert_eq!(store.contains(v), dense.get(v).is_some_and(|s| s.is_some()));
        }
        // The second insert at vertex 3 replaced the first.
        assert_ne!(at(0.0), at(1.0));
        assert_eq!(store.get(3), Some(&at(1.0)));
    }

    /// Eq. 4's moments integrate over the side's own faces. Two parts of one mesh share the
    /// crease cut's vertices (here the edge `x = 0` of a square in `z = 0` and of a square
    /// in the plane `x = z` below it), so the other part's faces have sampled corners too: with
    /// every vertex sampled at the depth `1 + x` (`S` taken at the vertices themselves), the
    /// square's moments are its own integrals (area 1, mean depth 1.5, second moment 7/3), not
    /// the whole mesh's (area `1 + √2`).
    #[test]
    fn depth_moments_integrate_over_the_sides_own_faces() {
        let (positions, triangles) = crate::contact::fixtures::folded_square();
        let samples = crate::contact::fixtures::sampled_at_depth(&positions, |q| 1.0 + q.x);
        let [area, first, second] = depth_moments(&triangles, &[0, 1], &samples);
        assert!((area - 1.0).abs() < 1e-14, "area {area}");
        assert!((first / area - 1.5).abs() < 1e-14, "mean {}", first / area);
        assert!((second - 7.0 / 3.0).abs() < 1e-14, "second moment {second}");
        let [whole, ..] = depth_moments(&triangles, &[0, 1, 2, 3], &samples);
        assert!(
            (whole - 1.0 - 2f64.sqrt()).abs() < 1e-14,
            "whole mesh {whole}"
        );
    }
}
