//! Intersection regions `I_l` (2021 Sec. 4, Algorithm 1 line 3): the part of surface `l` inside
//! the other body, bounded exactly by the intersection curves, and area integrals over it
//! (Sec. 4.1, Eq. 2: area-weighted mean normals and total variation).
//!
//! Vertices are classified from the crossing signs at cut edges, then flood-filled across uncut
//! edges. Faces crossed by a curve are clipped along it: the inside part is traced as polygons
//! (curve chains inside the face, closed by arcs of the face boundary, the inside always on the
//! left of the oriented curve) and triangulated, so integrals of piecewise-linear data over
//! `I_l` are exact.
//!
//! This file holds the regions' types, their integrals and the sequence; beside it:
//! `classify.rs` (the vertices' status), `clip.rs` (the crossed faces' polygons) and
//! `triangulate.rs` (their sub-triangles).

use super::index::PosedMesh;
use super::mesh_mesh::{Intersections, Side};
use super::IntersectError;
use nalgebra::{Point3, Vector3};

mod classify;
mod clip;
mod triangulate;

use classify::classify_vertices;
use clip::{FaceClip, FaceCurves};

/// A triangle inside one face, given by barycentric coordinates on that face and 3D corners.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubTriangle {
    /// Barycentric coordinates (on the parent face) of the three corners, counter-clockwise.
    pub bary: [[f64; 3]; 3],
    /// 3D corners.
    pub points: [Point3<f64>; 3],
}

impl SubTriangle {
    /// Area.
    pub fn area(&self) -> f64 {
        let [a, b, c] = &self.points;
        0.5 * (b - a).cross(&(c - a)).norm()
    }
}

/// The part of a face crossed by an intersection curve that lies in the region: the union of
/// `sub_triangles` minus the union of `holes` (holes only occur when a curve loop lies entirely
/// inside one face and encloses a part outside the region).
#[derive(Clone, Debug, PartialEq)]
pub struct CutFace {
    /// The face.
    pub face: u32,
    /// Triangles of the region part.
    pub sub_triangles: Vec<SubTriangle>,
    /// Triangles to subtract.
    pub holes: Vec<SubTriangle>,
}

/// Counters of inconsistencies met while building a region. All zero for two closed,
/// non-self-intersecting surfaces; open surfaces (working regions cut out of a mesh) and
/// self-contact parts can leave curves ending inside a face.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RegionStats {
    /// Flood-fill components that received both inside and outside votes (majority wins,
    /// ties go outside).
    pub conflicting_components: usize,
    /// Curve pieces inside a face that do not reach the face boundary nor close (ignored).
    pub dangling_chains: usize,
    /// Faces without a curve whose corners disagree (majority wins).
    pub mixed_uncut_faces: usize,
    /// Boundary walks that found the curve exits and entries out of order (polygon closed early).
    pub boundary_mismatches: usize,
    /// Polygons triangulated by a signed fan because ear clipping failed (integrals stay exact).
    pub fan_fallbacks: usize,
}

/// The part `I_l` of one surface inside the other body (or its complement).
#[derive(Clone, Debug, PartialEq)]
pub struct IntersectionRegion {
    /// Which surface.
    pub side: Side,
    /// Per vertex of the mesh: inside the region (false for vertices of no face of the side).
    pub inside: Vec<bool>,
    /// Faces entirely in the region, sorted.
    pub whole_faces: Vec<u32>,
    /// Faces crossed by a curve, with their part in the region, sorted by face.
    pub cut_faces: Vec<CutFace>,
    /// Inconsistencies met.
    pub stats: RegionStats,
}

/// Quadrature rules on triangles (both exact for linear data).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QuadratureRule {
    /// One point at the centroid: exact for degree 1.
    Centroid,
    /// Three points at barycentric `(2/3, 1/6, 1/6)` and permutations: exact for degree 2
    /// (the "degree two Gauss quadrature" of Sec. 4.1 for the total variation of normals).
    Degree2,
}

/// A quadrature point: a location on a face and its weight (area share; negative inside holes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadraturePoint {
    /// The face.
    pub face: u32,
    /// Barycentric coordinates on the face.
    pub bary: [f64; 3],
    /// Weight (area units).
    pub weight: f64,
}

impl QuadraturePoint {
    /// Linear interpolation of per-vertex values at this point.
    pub fn interpolate(&self, triangles: &[[u32; 3]], values: &[Vector3<f64>]) -> Vector3<f64> {
        let t = &triangles[self.face as usize];
        (0..3).fold(Vector3::zeros(), |acc, k| {
            acc + values[t[k] as usize] * self.bary[k]
        })
    }
}

impl IntersectionRegion {
    /// `I_l`: the part of surface `side` inside the other body. `mesh` is the surface `side`
    /// of the query that produced `ints`.
    pub fn inside(
        ints: &Intersections,
        side: Side,
        mesh: &PosedMesh,
    ) -> Result<Self, IntersectError> {
        check_belongs(ints, side, mesh)?;
        Ok(build(ints, side, mesh, false))
    }

    /// The complement of `I_l` on the faces of surface `side` (the part outside the other
    /// body). With [`IntersectionRegion::inside`] it tiles the surface exactly.
    pub fn outside(
        ints: &Intersections,
        side: Side,
        mesh: &PosedMesh,
    ) -> Result<Self, IntersectError> {
        check_belongs(ints, side, mesh)?;
        Ok(build(ints, side, mesh, true))
    }

    /// True when the region has no face.
    pub fn is_empty(&self) -> bool {
        self.whole_faces.is_empty() && self.cut_faces.is_empty()
    }

    /// Quadrature points covering the region (whole faces and clipped parts).
    pub fn quadrature(&self, mesh: &PosedMesh, rule: QuadratureRule) -> Vec<QuadraturePoint> {
        let mut out = Vec::new();
        for &f in &self.whole_faces {
            let unit = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            push_rule(&mut out, f, &unit, mesh.face_area(f), rule);
        }
        for c in &self.cut_faces {
            for (tris, sign) in [(&c.sub_triangles, 1.0), (&c.holes, -1.0)] {
                for st in tris {
                    push_rule(&mut out, c.face, &st.bary, sign * st.area(), rule);
                }
            }
        }
        out
    }

    /// Area of the region.
    pub fn area(&self, mesh: &PosedMesh) -> f64 {
        let whole: f64 = self.whole_faces.iter().map(|&f| mesh.face_area(f)).sum();
        let cut: f64 = self
            .cut_faces
            .iter()
            .map(|c| {
                c.sub_triangles.iter().map(SubTriangle::area).sum::<f64>()
                    - c.holes.iter().map(SubTriangle::area).sum::<f64>()
            })
            .sum();
        whole + cut
    }

    /// Integral over the region of the linear interpolation of per-vertex `values` (exact):
    /// with vertex normals this is `m_l` of Eq. 2.
    pub fn integrate_linear(
        &self,
        mesh: &PosedMesh,
        values: &[Vector3<f64>],
    ) -> Result<Vector3<f64>, IntersectError> {
        if values.len() != mesh.positions().len() {
            return Err(IntersectError::ValueCount {
                expected: mesh.positions().len(),
                got: values.len(),
            });
        }
        let tris = mesh.triangles();
        Ok(self
            .quadrature(mesh, QuadratureRule::Centroid)
            .iter()
            .fold(Vector3::zeros(), |acc, q| {
                acc + q.interpolate(tris, values) * q.weight
            }))
    }

    /// Integral of `f(face, bary)` over the region with `rule`.
    pub fn integrate(
        &self,
        mesh: &PosedMesh,
        rule: QuadratureRule,
        f: impl Fn(u32, [f64; 3]) -> f64,
    ) -> f64 {
        self.quadrature(mesh, rule)
            .iter()
            .map(|q| q.weight * f(q.face, q.bary))
            .sum()
    }
}

fn push_rule(
    out: &mut Vec<QuadraturePoint>,
    face: u32,
    corners: &[[f64; 3]; 3],
    area: f64,
    rule: QuadratureRule,
) {
    let at = |w: [f64; 3]| -> [f64; 3] {
        std::array::from_fn(|k| (0..3).map(|c| w[c] * corners[c][k]).sum())
    };
    match rule {
        QuadratureRule::Centroid => out.push(QuadraturePoint {
            face,
            bary: at([1.0 / 3.0; 3]),
            weight: area,
        }),
        QuadratureRule::Degree2 => {
            let (a, b) = (2.0 / 3.0, 1.0 / 6.0);
            for w in [[a, b, b], [b, a, b], [b, b, a]] {
                out.push(QuadraturePoint {
                    face,
                    bary: at(w),
                    weight: area / 3.0,
                });
            }
        }
    }
}

/// The ids in `ints` that refer to surface `side` are valid for `mesh`.
fn check_belongs(ints: &Intersections, side: Side, mesh: &PosedMesh) -> Result<(), IntersectError> {
    let (nv, nf, nh) = (
        mesh.index().vertex_count(),
        mesh.triangles().len(),
        ints.hits.len(),
    );
    let hits_ok = ints.hits.iter().all(|h| {
        if h.side == side {
            h.edge.iter().all(|&v| (v as usize) < nv)
        } else {
            (h.face as usize) < nf
        }
    });
    let k = if side == Side::A { 0 } else { 1 };
    let segments_ok = ints
        .segments
        .iter()
        .all(|s| (s.faces[k] as usize) < nf && s.hits.iter().all(|&h| (h as usize) < nh));
    if hits_ok && segments_ok {
        Ok(())
    } else {
        Err(IntersectError::Mismatch)
    }
}

fn build(
    ints: &Intersections,
    side: Side,
    mesh: &PosedMesh,
    complement: bool,
) -> IntersectionRegion {
    let mut stats = RegionStats::default();
    let clipper = |face| FaceClip {
        ints,
        side,
        mesh,
        face,
    };
    let by_face = segments_by_face(ints, side);
    let curves: Vec<FaceCurves> = by_face
        .chunk_by(|x, y| x.0 == y.0)
        .map(|g| {
            let segs: Vec<[u32; 2]> = g.iter().map(|x| x.1).collect();
            clipper(g[0].0).curves(&segs, &mut stats)
        })
        .collect();
    let loop_votes: Vec<(u32, bool)> = curves
        .iter()
        .filter_map(|c| clipper(c.face).corner_vote(c).map(|v| (c.face, v)))
        .collect();
    let inside = classify_vertices(ints, side, mesh, &loop_votes, complement, &mut stats);
    let mut whole_faces = Vec::new();
    let mut cut_faces = Vec::new();
    let mut pending = curves.into_iter().peekable();
    for &f in mesh.index().faces() {
        while pending.next_if(|c| c.face < f).is_some() {}
        let corners_in = mesh.triangles()[f as usize].map(|v| inside[v as usize]);
        if let Some(c) = pending.next_if(|c| c.face == f) {
            let c = if complement { c.reversed() } else { c };
            cut_faces.push(clipper(f).clip(c, corners_in, &mut stats));
            continue;
        }
        let n_in = corners_in.iter().filter(|&&x| x).count();
        if n_in == 1 || n_in == 2 {
            stats.mixed_uncut_faces += 1;
        }
        if n_in >= 2 {
            whole_faces.push(f);
        }
    }
    IntersectionRegion {
        side,
        inside,
        whole_faces,
        cut_faces,
        stats,
    }
}

/// Segments lying in faces of `side`, oriented with `I_l` on their left (seen from outside the
/// surface), as `(face, [from, to])`, sorted by face.
fn segments_by_face(ints: &Intersections, side: Side) -> Vec<(u32, [u32; 2])> {
    // Segments run along n_A × n_B: A's inside part is on their left, B's on their right.
    let reverse = side == Side::B;
    let mut v: Vec<(u32, [u32; 2])> = ints
        .segments
        .iter()
        .map(|s| {
            let face = if side == Side::A {
                s.faces[0]
            } else {
                s.faces[1]
            };
            let [h0, h1] = s.hits;
            (face, if reverse { [h1, h0] } else { [h0, h1] })
        })
        .collect();
    v.sort_unstable();
    v
}
