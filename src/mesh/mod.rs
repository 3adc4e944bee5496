//! Welded topology of a skinned body.
//!
//! glTF splits vertices along UV and normal seams, so a closed character is an open soup of
//! patches in the file. Geometry processing needs the manifold surface: [`WeldedMesh::weld`]
//! merges file vertices whose bind positions coincide (within a tolerance relative to the
//! bounding box), keeps the map back to the file vertices so every result can be written to
//! every split copy, and reports what is not a clean 2-manifold instead of failing on it.

pub mod operators;
pub mod region;

pub use region::Region;

use nalgebra::{Point3, Vector3};
use std::collections::HashMap;

/// Default weld tolerance, relative to the bounding-box diagonal.
pub const WELD_TOLERANCE: f64 = 1e-6;

/// What is not a closed, consistently oriented 2-manifold.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct TopologyReport {
    /// Edges with one face (open border).
    pub boundary_edges: usize,
    /// Edges with more than two faces.
    pub non_manifold_edges: usize,
    /// Manifold edges whose two faces traverse them in the same direction.
    pub inconsistent_edges: usize,
    /// Faces with a repeated welded vertex or zero area.
    pub degenerate_faces: usize,
    /// Faces that repeat another face's vertex set.
    pub duplicate_faces: usize,
    /// Welded vertices used by no face.
    pub isolated_vertices: usize,
}

impl TopologyReport {
    /// True for a closed, consistently oriented 2-manifold without degenerate faces.
    pub fn is_closed_manifold(&self) -> bool {
        *self == TopologyReport::default()
    }
}

/// The welded surface of one body.
#[derive(Clone, Debug)]
pub struct WeldedMesh {
    /// Welded vertex of each file vertex.
    pub to_welded: Vec<u32>,
    /// First file vertex of each welded vertex (its representative).
    pub representative: Vec<u32>,
    /// Triangles in welded indices, in the file's order, without the faces that repeat an
    /// earlier face's welded vertices in either winding (a double-sided copy: counted in
    /// [`TopologyReport::duplicate_faces`], and moved with the face it repeats, whose
    /// vertices it shares).
    pub triangles: Vec<[u32; 3]>,
    /// Defects found.
    pub report: TopologyReport,
    /// Closed and consistently oriented ([`closed_and_oriented`]): a signed volume that does
    /// not depend on the origin.
    pub closed: bool,
}

impl WeldedMesh {
    /// Number of welded vertices.
    pub fn vertex_count(&self) -> usize {
        self.representative.len()
    }

    /// Number of file vertices merged away (seam copies).
    pub fn seams_welded(&self) -> usize {
        self.to_welded.len() - self.representative.len()
    }

    /// Welds `positions` (file vertices) with a tolerance of [`WELD_TOLERANCE`] times the
    /// bounding-box diagonal and re-indexes `triangles`, leaving out the faces that repeat an
    /// earlier one ([`WeldedMesh::triangles`]).
    pub fn weld(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> Self {
        let tol = WELD_TOLERANCE * bbox_diagonal(positions).max(f64::MIN_POSITIVE);
        let (to_welded, representative) = weld_points(positions, tol);
        let welded: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| to_welded[i as usize]))
            .collect();
        let mut report = analyse(positions, &representative, &welded);
        let count = welded.len();
        let triangles = without_repeated_faces(welded);
        report.duplicate_faces = count - triangles.len();
        Self {
            to_welded,
            representative,
            closed: closed_and_oriented(&triangles),
            triangles,
            report,
        }
    }

    /// Gathers per-welded-vertex values from per-file-vertex values (representatives).
    pub fn gather<T: Copy>(&self, file_values: &[T]) -> Vec<T> {
        self.representative
            .iter()
            .map(|&f| file_values[f as usize])
            .collect()
    }

    /// Scatters per-welded-vertex values back to every file vertex (all seam copies).
    pub fn scatter<T: Copy>(&self, welded_values: &[T]) -> Vec<T> {
        self.to_welded
            .iter()
            .map(|&w| welded_values[w as usize])
            .collect()
    }
}

/// Diagonal of the axis-aligned bounding box (0 for no point; finite whenever its sides are).
/// Takes any iterator of points, so that a subset of a mesh's vertices needs no copy.
pub fn bbox_diagonal<'a>(points: impl IntoIterator<Item = &'a Point3<f64>>) -> f64 {
    let mut points = points.into_iter();
    let Some(first) = points.next() else {
        return 0.0;
    };
    let (mut lo, mut hi) = (first.coords, first.coords);
    for p in points {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    let d = hi - lo;
    let plain = d.norm();
    if plain.is_finite() {
        return plain;
    }
    // Scaled, so that a box whose sides are finite has a finite diagonal (coordinates near
    // 1e200 overflow the plain norm's squares; found by fuzzing).
    let scale = d.amax();
    if !scale.is_finite() {
        return scale;
    }
    scale * (d / scale).norm()
}

/// The size of a surface: √12 times the root mean square distance of its points from its
/// centroid, both taken over its area (each triangle's exact second moment). A second moment,
/// so that no rotation or reflection of the surface changes it, and refining the mesh or
/// splitting its vertices does not either. √12 makes it the length of a thin rod, the diagonal
/// of a thin rectangular plate and the diagonal of a sphere's bounding box (`2√3 r`); a closed
/// box's surface measures more than its diagonal (`√5 a` for a cube of side `a`, against
/// `√3 a`). It is the size that scales the extent `φ̄` of a joint
/// ([`crate::selfcontact::regions::PairRegions::joint_size`]) and of an object
/// ([`crate::pass::DEFAULT_EXTENT_FACTOR`]), which were axis-aligned bounding-box diagonals
/// before, without their dependence on the orientation the rig is given in. Like any second
/// moment it weighs far material by its squared distance: a small triangle far away moves it
/// (though less than it moves a bounding box).
///
/// Triangles naming a vertex out of range are skipped; without area (no triangle, or only
/// degenerate ones) each triangle's corners count equally instead; 0 without any triangle;
/// not finite when a coordinate is not.
pub fn surface_size(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> f64 {
    let corners: Vec<[Vector3<f64>; 3]> = triangles
        .iter()
        .filter_map(|t| {
            let [a, b, c] = t.map(|v| positions.get(v as usize).map(|p| p.coords));
            Some([a?, b?, c?])
        })
        .collect();
    if let Some(bad) = corners
        .iter()
        .flatten()
        .flat_map(|v| v.iter())
        .find(|c| !c.is_finite())
    {
        return bad.abs();
    }
    // Scaled to the largest coordinate first, so that neither the differences of coordinates
    // near ±1e308 nor the squares of coordinates near 1e200 overflow.
    let scale = corners
        .iter()
        .flatten()
        .map(|v| v.amax())
        .fold(0.0, f64::max);
    if scale == 0.0 {
        return 0.0;
    }
    let local: Vec<[Vector3<f64>; 3]> = corners.iter().map(|t| t.map(|v| v / scale)).collect();
    let areas: Vec<f64> = local
        .iter()
        .map(|[a, b, c]| 0.5 * (b - a).cross(&(c - a)).norm())
        .collect();
    let total: f64 = areas.iter().sum();
    let weights = if total > 0.0 {
        areas
    } else {
        vec![1.0; local.len()]
    };
    let mass: f64 = weights.iter().sum();
    let centroid = local
        .iter()
        .zip(&weights)
        .fold(Vector3::zeros(), |s, (t, w)| {
            s + (t[0] + t[1] + t[2]) * (w / 3.0)
        })
        / mass;
    // The mean of |p|² over a triangle is (|a|² + |b|² + |c|² + |a + b + c|²) / 12; over its
    // corners alone (no area), (|a|² + |b|² + |c|²) / 3.
    let second: f64 = local
        .iter()
        .zip(&weights)
        .map(|(t, w)| {
            let [a, b, c] = t.map(|v| v - centroid);
            let squares = a.norm_squared() + b.norm_squared() + c.norm_squared();
            if total > 0.0 {
                w * (squares + (a + b + c).norm_squared()) / 12.0
            } else {
                w * squares / 3.0
            }
        })
        .sum::<f64>()
        / mass;
    scale * (12.0 * second).sqrt()
}

/// Merges points closer than `tol` (in file order: the first point of a cluster represents it).
fn weld_points(positions: &[Point3<f64>], tol: f64) -> (Vec<u32>, Vec<u32>) {
    let cell = |p: &Point3<f64>| {
        [
            (p.x / tol).floor() as i64,
            (p.y / tol).floor() as i64,
            (p.z / tol).floor() as i64,
        ]
    };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::with_capacity(positions.len());
    let mut to_welded = Vec::with_capacity(positions.len());
    let mut representative: Vec<u32> = Vec::new();
    for (i, p) in positions.iter().enumerate() {
        let c = cell(p);
        let mut found = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let key = [c[0] + dx, c[1] + dy, c[2] + dz];
                    for &w in grid.get(&key).map(Vec::as_slice).unwrap_or(&[]) {
                        let q = &positions[representative[w as usize] as usize];
                        if (p - q).norm() <= tol && found.is_none_or(|f| w < f) {
                            found = Some(w);
                        }
                    }
                }
            }
        }
        let w = found.unwrap_or_else(|| {
            let w = representative.len() as u32;
            representative.push(i as u32);
            grid.entry(c).or_default().push(w);
            w
        });
        to_welded.push(w);
    }
    (to_welded, representative)
}

/// `triangles` without the faces whose vertex set an earlier face has (either winding): a
/// surface made double-sided by a second copy of its faces would otherwise meet itself
/// everywhere (every face lies on its copy; measured on the bending capsule with its faces
/// copied: 8 folds that resolved nothing, 3.5 s instead of 0.5 s, and on the capsule pair with
/// reversed copies 2194 faces turned).
fn without_repeated_faces(triangles: Vec<[u32; 3]>) -> Vec<[u32; 3]> {
    let mut seen = std::collections::HashSet::with_capacity(triangles.len());
    triangles
        .into_iter()
        .filter(|t| {
            let mut key = *t;
            key.sort_unstable();
            seen.insert(key)
        })
        .collect()
}

/// The defects of `tris` as the file has them (the weld counts the repeated faces it drops).
fn analyse(positions: &[Point3<f64>], representative: &[u32], tris: &[[u32; 3]]) -> TopologyReport {
    let mut report = TopologyReport::default();
    // Directed edge counts per undirected edge: (forward a<b, backward).
    let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::with_capacity(tris.len() * 2);
    let mut used = vec![false; representative.len()];
    for t in tris {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || area(positions, representative, t) == 0.0
        {
            report.degenerate_faces += 1;
        }
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            used[a as usize] = true;
            if a == b {
                continue;
            }
            let e = edges.entry((a.min(b), a.max(b))).or_default();
            if a < b {
                e.0 += 1;
            } else {
                e.1 += 1;
            }
        }
    }
    for &(fwd, bwd) in edges.values() {
        match fwd + bwd {
            1 => report.boundary_edges += 1,
            2 if fwd != 1 => report.inconsistent_edges += 1,
            2 => {}
            _ => report.non_manifold_edges += 1,
        }
    }
    report.isolated_vertices = used.iter().filter(|&&u| !u).count();
    report
}

fn area(positions: &[Point3<f64>], representative: &[u32], t: &[u32; 3]) -> f64 {
    let [a, b, c] = t.map(|w| positions[representative[w as usize] as usize]);
    (b - a).cross(&(c - a)).norm() * 0.5
}

/// Signed volume enclosed by a triangle mesh (divergence theorem; positive for an outward
/// oriented closed surface).
pub fn signed_volume(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> f64 {
    let origin = positions
        .first()
        .map_or(nalgebra::Vector3::zeros(), |p| p.coords);
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize].coords - origin);
            a.dot(&b.cross(&c))
        })
        .sum::<f64>()
        / 6.0
}

/// Whether `triangles` form a closed, consistently oriented surface: every directed edge once,
/// its reverse once (the surfaces whose signed volume does not depend on the origin).
pub fn closed_and_oriented(triangles: &[[u32; 3]]) -> bool {
    let mut edges: Vec<[u32; 2]> = (triangles.iter())
        .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
        .collect();
    edges.sort_unstable();
    let once = edges.windows(2).all(|w| w[0] != w[1]);
    once && !edges.is_empty()
        && edges
            .iter()
            .all(|&[a, b]| a != b && edges.binary_search(&[b, a]).is_ok())
}

/// A closed body's orientation at rest, to tell when a pose turns it inside out (a joint
/// scaled by a negative factor in an animation: the rest pose's mirror is undone at load,
/// `rig::orientation`, an animated one cannot be).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestVolume {
    volume: f64,
    vertices: usize,
}

impl RestVolume {
    /// The rest signed volume of a closed, consistently oriented surface that encloses some
    /// (`None` otherwise: an open surface's signed volume depends on the origin; `None` too
    /// for a face naming a vertex `rest` does not have).
    pub fn of(rest: &[Point3<f64>], triangles: &[[u32; 3]]) -> Option<Self> {
        let n = rest.len();
        let indexed = triangles.iter().flatten().all(|&v| (v as usize) < n);
        if !(indexed && closed_and_oriented(triangles)) {
            return None;
        }
        let volume = signed_volume(rest, triangles);
        (volume.is_finite() && volume != 0.0).then_some(Self {
            volume,
            vertices: n,
        })
    }

    /// Whether `positions` (the rest's vertex count; any other count is not judged) enclose a
    /// signed volume of the other sign than at rest: the pose turned the body inside out.
    pub fn inside_out(&self, positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> bool {
        positions.len() == self.vertices && signed_volume(positions, triangles) * self.volume < 0.0
    }
}

/// The first point with a non-finite coordinate. A sum of coordinates is finite only when
/// every coordinate is (an infinity or a NaN stays one, whatever is added): branch-free sums
/// over the points decide (a sum of finite coordinates that overflowed to infinity only sends
/// it to the search), the search runs only when they are not finite. Four sums of whole points,
/// one per point of each group of four, so that no addition waits for the one before
/// (floating-point sums are not reordered by the compiler): 1.2 µs over the finger's 3962
/// welded points, against 1.4 µs for four sums of each point's coordinates times zero; over
/// its 4918 points, 4.0 µs for one such sum and 2.9-4.1 µs for the search alone. Every frame's
/// input is checked by each pass and index it reaches.
pub fn first_non_finite(points: &[Point3<f64>]) -> Option<usize> {
    let groups = points.chunks_exact(4);
    let rest: Vector3<f64> = groups.remainder().iter().map(|p| p.coords).sum();
    let mut lanes = [Vector3::zeros(); 4];
    for group in groups {
        for (lane, p) in lanes.iter_mut().zip(group) {
            *lane += p.coords;
        }
    }
    let total = lanes.iter().sum::<Vector3<f64>>() + rest;
    if total.iter().all(|c| c.is_finite()) {
        return None;
    }
    points.iter().position(|p| !p.iter().all(|c| c.is_finite()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fast probe does not take huge finite points for non-finite ones (their sum
    /// overflows), and finds the first NaN or infinite one.
    #[test]
    fn the_first_non_finite_point_is_found() {
        let huge = Point3::new(1e308, 1e308, 1e308);
        let mut p = vec![Point3::origin(), huge, huge];
        assert_eq!(first_non_finite(&p), None);
        assert_eq!(first_non_finite(&[]), None);
        p[2].z = f64::INFINITY;
        assert_eq!(first_non_finite(&p), Some(2));
        p[1].y = f64::NAN;
        assert_eq!(first_non_finite(&p), Some(1));
        // Past the first group of four, in a group and in the remainder, on each lane.
        let finite: Vec<Point3<f64>> = (0..11).map(|i| Point3::new(i as f64, 1.0, -2.0)).collect();
        assert_eq!(first_non_finite(&finite), None);
        for i in 0..finite.len() {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut q = finite.clone();
                q[i][i % 3] = bad;
                assert_eq!(first_non_finite(&q), Some(i), "point {i}, {bad}");
            }
        }
    }

    /// A closed tetrahedron has a rest volume, an open or doubly used one none; mirrored, its
    /// positions are inside out, moved rigidly or scaled they are not.
    #[test]
    fn a_mirrored_tetrahedron_is_inside_out() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ]
        .map(|[x, y, z]| Point3::new(x, y, z));
        let t = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let v = RestVolume::of(&p, &t).expect("closed");
        assert!(RestVolume::of(&p, &t[..3]).is_none(), "open");
        assert!(
            RestVolume::of(&p, &[t, t].concat()).is_none(),
            "edges used twice"
        );
        assert!(RestVolume::of(&p[..3], &t).is_none(), "a vertex missing");
        let moved = p.map(|q| Point3::new(2.0 * q.z + 5.0, q.x, 3.0 * q.y));
        assert!(!v.inside_out(&moved, &t), "a rotation and a scale");
        let mirrored = p.map(|q| Point3::new(-q.x, q.y, q.z));
        assert!(v.inside_out(&mirrored, &t));
        assert!(
            !v.inside_out(&mirrored[..3], &t),
            "another vertex count is not judged"
        );
    }

    #[test]
    fn the_diagonal_of_a_huge_box_stays_finite() {
        let p = [Point3::new(0.0, 0.0, 0.0), Point3::new(3e200, 4e200, 0.0)];
        assert!((bbox_diagonal(&p) - 5e200).abs() < 1e188);
        let q = [Point3::new(0.0, 0.0, 0.0), Point3::new(3.0, 4.0, 0.0)];
        assert_eq!(bbox_diagonal(&q), 5.0);
    }

    /// An icosphere-like closed surface: a UV sphere of radius `r` (poles shared).
    fn uv_sphere(r: f64, rings: u32, segments: u32) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let mut p = vec![Point3::new(0.0, 0.0, r)];
        for i in 1..rings {
            let th = std::f64::consts::PI * i as f64 / rings as f64;
            for j in 0..segments {
                let ph = std::f64::consts::TAU * j as f64 / segments as f64;
                p.push(Point3::new(
                    r * th.sin() * ph.cos(),
                    r * th.sin() * ph.sin(),
                    r * th.cos(),
                ));
            }
        }
        p.push(Point3::new(0.0, 0.0, -r));
        let south = p.len() as u32 - 1;
        let at = |i: u32, j: u32| 1 + (i - 1) * segments + j % segments;
        let mut t = Vec::new();
        for j in 0..segments {
            t.push([0, at(1, j), at(1, j + 1)]);
            t.push([south, at(rings - 1, j + 1), at(rings - 1, j)]);
            for i in 1..rings - 1 {
                t.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                t.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        (p, t)
    }

    #[test]
    fn the_surface_size_is_a_second_moment_that_does_not_turn_with_the_surface() {
        // A sphere: 2√3 r (its bounding box's diagonal), to the mesh's chord error.
        let (p, t) = uv_sphere(2.0, 48, 96);
        let size = surface_size(&p, &t);
        assert!((size / (4.0 * 3f64.sqrt()) - 1.0).abs() < 2e-3, "{size}");
        // A unit square plate (two triangles): its diagonal √2 exactly.
        let plate = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(1.0, 1.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ];
        let quads = [[0, 1, 2], [0, 2, 3]];
        assert!((surface_size(&plate, &quads) - 2f64.sqrt()).abs() < 1e-14);
        // A unit cube's surface (split corners, as glTF files have them): √5, not √3.
        let (cube, cube_t) = split_cube();
        assert!((surface_size(&cube, &cube_t) - 5f64.sqrt()).abs() < 1e-14);
        // Rotated and reflected, the same; the box diagonal is not.
        let r = nalgebra::Rotation3::from_euler_angles(0.3, 1.1, -0.7);
        let turned: Vec<Point3<f64>> = p.iter().map(|q| r * q).collect();
        let mirrored: Vec<Point3<f64>> = p.iter().map(|q| Point3::new(-q.x, q.y, q.z)).collect();
        assert!((surface_size(&turned, &t) - size).abs() < 1e-13 * size);
        assert!((surface_size(&mirrored, &t) - size).abs() < 1e-13 * size);
        let pt: Vec<Point3<f64>> = plate.iter().map(|q| r * q).collect();
        assert!((surface_size(&pt, &quads) - 2f64.sqrt()).abs() < 1e-14);
        assert!((bbox_diagonal(&pt) - 2f64.sqrt()).abs() > 0.1);
        // Refining the mesh barely moves it (an area measure, not a vertex count).
        let (pf, tf) = uv_sphere(2.0, 96, 192);
        assert!((surface_size(&pf, &tf) / size - 1.0).abs() < 2e-3);
        // Degenerate and bad input. Without area the corners count: a segment of length 2 as
        // the triangle (0, 1, 1) has corners 0, 2, 2, whose RMS distance from their mean is
        // √(8/9) and size √12 × that.
        assert_eq!(surface_size(&plate, &[]), 0.0);
        assert_eq!(surface_size(&plate, &[[0, 9, 1]]), 0.0);
        let line = [Point3::new(0.0, 0.0, 0.0), Point3::new(2.0, 0.0, 0.0)];
        let flat = surface_size(&line, &[[0, 1, 1]]);
        assert!(
            (flat - (12.0f64 * 8.0 / 9.0).sqrt()).abs() < 1e-14,
            "{flat}"
        );
        let huge = [
            plate[0],
            plate[1] * 1e200,
            plate[2] * 1e200,
            plate[3] * 1e200,
        ];
        assert!((surface_size(&huge, &quads) / 1e200 - 2f64.sqrt()).abs() < 1e-12);
        let far = |x: f64, y: f64| Point3::new(x, y, 0.0);
        let opposite = [far(-1e308, 0.0), far(1e308, 0.0), far(0.0, 1e308)];
        let s = surface_size(&opposite, &[[0, 1, 2]]);
        assert!(s.is_finite() && s > 1e308, "{s}");
        let nan = [plate[0], Point3::new(f64::NAN, 0.0, 0.0), plate[2]];
        assert!(surface_size(&nan, &[[0, 1, 2]]).is_nan());
        let inf = [plate[0], Point3::new(f64::INFINITY, 0.0, 0.0), plate[2]];
        assert_eq!(surface_size(&inf, &[[0, 1, 2]]), f64::INFINITY);
    }

    /// A unit cube with 4 split vertices per face (24 file vertices), outward CCW.
    fn split_cube() -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let faces: [[[f64; 3]; 4]; 6] = [
            [[0., 0., 0.], [0., 1., 0.], [1., 1., 0.], [1., 0., 0.]],
            [[0., 0., 1.], [1., 0., 1.], [1., 1., 1.], [0., 1., 1.]],
            [[0., 0., 0.], [1., 0., 0.], [1., 0., 1.], [0., 0., 1.]],
            [[0., 1., 0.], [0., 1., 1.], [1., 1., 1.], [1., 1., 0.]],
            [[0., 0., 0.], [0., 0., 1.], [0., 1., 1.], [0., 1., 0.]],
            [[1., 0., 0.], [1., 1., 0.], [1., 1., 1.], [1., 0., 1.]],
        ];
        let mut pos = Vec::new();
        let mut tris = Vec::new();
        for quad in faces {
            let b = pos.len() as u32;
            pos.extend(quad.iter().map(|c| Point3::new(c[0], c[1], c[2])));
            tris.push([b, b + 1, b + 2]);
            tris.push([b, b + 2, b + 3]);
        }
        (pos, tris)
    }

    #[test]
    fn split_cube_welds_to_a_closed_manifold() {
        let (pos, tris) = split_cube();
        let w = WeldedMesh::weld(&pos, &tris);
        assert_eq!(w.vertex_count(), 8);
        assert_eq!(w.seams_welded(), 16);
        assert!(w.report.is_closed_manifold(), "{:?}", w.report);
        let welded_pos = w.gather(&pos);
        assert!((signed_volume(&welded_pos, &w.triangles) - 1.0).abs() < 1e-12);
        // Scatter writes every split copy.
        let ids: Vec<u32> = (0..8).collect();
        let back = w.scatter(&ids);
        for (f, &wv) in back.iter().enumerate() {
            assert_eq!(pos[f], welded_pos[wv as usize]);
        }
    }

    #[test]
    fn near_coincident_copies_weld_within_tolerance_only() {
        let (mut pos, tris) = split_cube();
        pos[5].x += 1e-9; // below 1e-6 of the diagonal: welded
        assert_eq!(WeldedMesh::weld(&pos, &tris).vertex_count(), 8);
        pos[5].x += 1e-3; // far above: a separate vertex, leaving open edges
        let w = WeldedMesh::weld(&pos, &tris);
        assert_eq!(w.vertex_count(), 9);
        assert!(w.report.boundary_edges > 0);
    }

    #[test]
    fn defects_are_reported_not_fatal() {
        let (pos, mut tris) = split_cube();
        let removed = tris.pop().expect("face");
        let w = WeldedMesh::weld(&pos, &tris);
        assert_eq!(w.report.boundary_edges, 3);
        tris.push(removed);
        tris.push(removed);
        let w = WeldedMesh::weld(&pos, &tris);
        assert_eq!(w.report.duplicate_faces, 1);
        assert_eq!(w.report.non_manifold_edges, 3);
        tris.pop();
        tris[0].swap(1, 2);
        let w = WeldedMesh::weld(&pos, &tris);
        assert_eq!(w.report.inconsistent_edges, 3);
        tris[0] = [0, 0, 1];
        let w = WeldedMesh::weld(&pos, &tris);
        assert_eq!(w.report.degenerate_faces, 1);
    }

    #[test]
    fn empty_and_isolated_inputs_are_fine() {
        let w = WeldedMesh::weld(&[], &[]);
        assert_eq!(w.vertex_count(), 0);
        let pos = vec![Point3::origin(), Point3::new(1.0, 0.0, 0.0)];
        let w = WeldedMesh::weld(&pos, &[]);
        assert_eq!(w.report.isolated_vertices, 2);
    }
}

/// A vertex and its distance in a Dijkstra search: ordered so that [`std::collections::BinaryHeap`]
/// pops the nearest first (ties by vertex id).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Queued(pub f64, pub u32);

impl Eq for Queued {}

impl Ord for Queued {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
    }
}

impl PartialOrd for Queued {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
