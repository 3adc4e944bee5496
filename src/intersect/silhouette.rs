//! Interpolated silhouette contours (Hertzmann & Zorin 2000, "Illustrating smooth surfaces";
//! 2021 Sec. 4.2): with per-vertex unit normals `n_i` and a view direction `d`, the orientation
//! function `g_i = n_i·d` is interpolated linearly; a contour point lies on every edge whose
//! endpoints differ in facing, at `t = g_a / (g_a - g_b)`, and every face with mixed facing holds
//! one contour segment. The front-facing region `B_l` (Fig. 3) is delimited by these contours.

use super::curves::{chain, Curve};
use super::index::canonical;
use super::IntersectError;
use nalgebra::{Point3, Vector3};

/// Which sign of `g = n·d` is front-facing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrontSide {
    /// `g ≤ 0` is front-facing (the paper's convention, Sec. 4.2).
    NonPositive,
    /// `g ≥ 0` is front-facing.
    NonNegative,
}

impl FrontSide {
    /// Whether orientation value `g` is front-facing.
    pub fn is_front(self, g: f64) -> bool {
        match self {
            FrontSide::NonPositive => g <= 0.0,
            FrontSide::NonNegative => g >= 0.0,
        }
    }
}

/// Facing of a face from the facing of its corners.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Facing {
    /// All corners front-facing.
    Front,
    /// All corners back-facing.
    Back,
    /// Mixed: the face holds a contour segment.
    Mixed,
}

/// A contour point on an edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContourPoint {
    /// Edge vertex ids, `edge[0] < edge[1]`.
    pub edge: [u32; 2],
    /// `point = (1 - t) p[edge[0]] + t p[edge[1]]`, `t = g_0 / (g_0 - g_1)`.
    pub t: f64,
    /// 3D position.
    pub point: Point3<f64>,
}

/// The contour segment of a mixed face, oriented with the front-facing part on its left (seen
/// from outside, faces counter-clockwise).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ContourSegment {
    /// The face.
    pub face: u32,
    /// `[start, end]` point indices.
    pub points: [u32; 2],
}

/// Contour points (sorted by edge), segments (sorted by face) and the curves chained from them
/// (closed where the surface is closed).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Silhouette {
    /// Contour points.
    pub points: Vec<ContourPoint>,
    /// One segment per mixed face.
    pub segments: Vec<ContourSegment>,
    /// Chains of segments; their nodes index `points`.
    pub curves: Vec<Curve>,
}

impl Silhouette {
    /// Contours over every face.
    pub fn compute(
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        normals: &[Vector3<f64>],
        direction: &Vector3<f64>,
        front: FrontSide,
    ) -> Result<Self, IntersectError> {
        let all: Vec<u32> = (0..triangles.len() as u32).collect();
        Self::compute_on_faces(positions, triangles, normals, direction, front, &all)
    }

    /// Contours over the faces `faces` only (e.g. the faces of `I_l`, Algorithm 1 line 9);
    /// curves are open where they leave the subset.
    pub fn compute_on_faces(
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        normals: &[Vector3<f64>],
        direction: &Vector3<f64>,
        front: FrontSide,
        faces: &[u32],
    ) -> Result<Self, IntersectError> {
        check_inputs(positions, triangles, normals, direction, faces)?;
        let g: Vec<f64> = normals.iter().map(|n| n.dot(direction)).collect();
        let is_front: Vec<bool> = g.iter().map(|&x| front.is_front(x)).collect();
        let mut faces = faces.to_vec();
        faces.sort_unstable();
        faces.dedup();
        let raw: Vec<(u32, [[u32; 2]; 2])> = faces
            .iter()
            .filter_map(|&f| face_segment(&triangles[f as usize], &is_front).map(|s| (f, s)))
            .collect();
        let mut edges: Vec<[u32; 2]> = raw.iter().flat_map(|(_, s)| *s).collect();
        edges.sort_unstable();
        edges.dedup();
        let points = edges
            .iter()
            .map(|&e| contour_point(positions, &g, e))
            .collect();
        let id = |e: &[u32; 2]| edges.binary_search(e).map_or(u32::MAX, |i| i as u32);
        let segments: Vec<ContourSegment> = raw
            .iter()
            .map(|(f, [a, b])| ContourSegment {
                face: *f,
                points: [id(a), id(b)],
            })
            .collect();
        let links: Vec<[u32; 2]> = segments.iter().map(|s| s.points).collect();
        let curves = chain(edges.len(), &links);
        Ok(Self {
            points,
            segments,
            curves,
        })
    }
}

/// Front-facing flag of every vertex.
pub fn vertex_front_mask(
    normals: &[Vector3<f64>],
    direction: &Vector3<f64>,
    front: FrontSide,
) -> Vec<bool> {
    normals
        .iter()
        .map(|n| front.is_front(n.dot(direction)))
        .collect()
}

/// Facing of every face from the vertex flags of [`vertex_front_mask`].
pub fn face_facing(triangles: &[[u32; 3]], vertex_front: &[bool]) -> Vec<Facing> {
    triangles
        .iter()
        .map(|t| {
            let n = t.iter().filter(|&&v| vertex_front[v as usize]).count();
            match n {
                3 => Facing::Front,
                0 => Facing::Back,
                _ => Facing::Mixed,
            }
        })
        .collect()
}

/// The two crossed edges of a mixed face, `[front -> back, back -> front]` in counter-clockwise
/// order (so the front part is on the left of the segment).
fn face_segment(t: &[u32; 3], is_front: &[bool]) -> Option<[[u32; 2]; 2]> {
    if t[0] == t[1] || t[1] == t[2] || t[2] == t[0] {
        return None;
    }
    let (mut from, mut to) = (None, None);
    for k in 0..3 {
        let (u, v) = (t[k], t[(k + 1) % 3]);
        match (is_front[u as usize], is_front[v as usize]) {
            (true, false) => from = Some(canonical(u, v)),
            (false, true) => to = Some(canonical(u, v)),
            _ => {}
        }
    }
    Some([from?, to?])
}

fn contour_point(positions: &[Point3<f64>], g: &[f64], e: [u32; 2]) -> ContourPoint {
    let (ga, gb) = (g[e[0] as usize], g[e[1] as usize]);
    let t = if ga == gb {
        0.5
    } else {
        (ga / (ga - gb)).clamp(0.0, 1.0)
    };
    let (p, q) = (&positions[e[0] as usize], &positions[e[1] as usize]);
    let point = if t <= 0.5 {
        p + (q - p) * t
    } else {
        q + (p - q) * (1.0 - t)
    };
    ContourPoint { edge: e, t, point }
}

fn check_inputs(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    normals: &[Vector3<f64>],
    direction: &Vector3<f64>,
    faces: &[u32],
) -> Result<(), IntersectError> {
    if normals.len() != positions.len() {
        return Err(IntersectError::ValueCount {
            expected: positions.len(),
            got: normals.len(),
        });
    }
    if !direction.iter().all(|x| x.is_finite()) {
        return Err(IntersectError::BadDirection);
    }
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    if let Some(i) = positions.iter().position(|p| !finite(p.coords.as_slice())) {
        return Err(IntersectError::NonFinitePosition(i as u32));
    }
    if let Some(i) = normals.iter().position(|n| !finite(n.as_slice())) {
        return Err(IntersectError::NonFiniteValue(i as u32));
    }
    for &f in faces {
        let t = triangles
            .get(f as usize)
            .ok_or(IntersectError::FaceOutOfRange(f))?;
        if let Some(&v) = t.iter().find(|&&v| v as usize >= positions.len()) {
            return Err(IntersectError::VertexOutOfRange {
                face: f,
                vertex: v,
                vertex_count: positions.len(),
            });
        }
    }
    Ok(())
}
