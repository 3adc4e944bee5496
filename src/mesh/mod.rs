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
    /// Triangles in welded indices (same order as the file's triangles).
    pub triangles: Vec<[u32; 3]>,
    /// Defects found.
    pub report: TopologyReport,
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
    /// bounding-box diagonal and re-indexes `triangles`.
    pub fn weld(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> Self {
        let tol = WELD_TOLERANCE * bbox_diagonal(positions).max(f64::MIN_POSITIVE);
        let (to_welded, representative) = weld_points(positions, tol);
        let welded: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| to_welded[i as usize]))
            .collect();
        let report = analyse(positions, &representative, &welded);
        Self {
            to_welded,
            representative,
            triangles: welded,
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
pub fn bbox_diagonal(points: &[Point3<f64>]) -> f64 {
    let Some(first) = points.first() else {
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

/// The diameter of a point set: the largest distance between two of its points (0 for fewer
/// than two points; not finite when a coordinate is not). Unlike [`bbox_diagonal`] it does not
/// change when the points are rotated or reflected: it is the size that scales the extent `φ̄`
/// of a joint ([`crate::selfcontact::regions::PairRegions::joint_size`]) and of an object
/// ([`crate::pass::DEFAULT_EXTENT_FACTOR`]).
///
/// Exact. Pairs are visited from the points farthest from the centroid inward and skipped by
/// the triangle inequality (`|p - q| ≤ r_p + r_q` with `r` the distance to the centroid), so
/// that elongated sets cost about `n log n`; a set whose points all lie at the same distance
/// from its centroid (a sphere) costs `n² / 2` distances.
pub fn diameter(points: &[Point3<f64>]) -> f64 {
    if points.len() < 2 {
        return 0.0;
    }
    if let Some(bad) = points
        .iter()
        .flat_map(|p| p.iter())
        .find(|c| !c.is_finite())
    {
        return bad.abs();
    }
    let centroid = points
        .iter()
        .fold(Vector3::zeros(), |s, p| s + p.coords / points.len() as f64);
    // Scaled to the largest offset, so that coordinates near 1e200 do not overflow the squares.
    let scale = points
        .iter()
        .map(|p| (p.coords - centroid).amax())
        .fold(0.0, f64::max);
    if scale == 0.0 || !scale.is_finite() {
        return scale;
    }
    let mut offsets: Vec<(f64, Vector3<f64>)> = points
        .iter()
        .map(|p| {
            let v = (p.coords - centroid) / scale;
            (v.norm(), v)
        })
        .collect();
    offsets.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
    let mut best = 0.0_f64;
    for (i, (ri, vi)) in offsets.iter().enumerate() {
        if 2.0 * ri <= best {
            break;
        }
        for (rj, vj) in &offsets[i + 1..] {
            if ri + rj <= best {
                break;
            }
            best = best.max((vi - vj).norm());
        }
    }
    best * scale
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

fn analyse(positions: &[Point3<f64>], representative: &[u32], tris: &[[u32; 3]]) -> TopologyReport {
    let mut report = TopologyReport::default();
    // Directed edge counts per undirected edge: (forward a<b, backward).
    let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::with_capacity(tris.len() * 2);
    let mut faces: HashMap<[u32; 3], u32> = HashMap::with_capacity(tris.len());
    let mut used = vec![false; representative.len()];
    for t in tris {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || area(positions, representative, t) == 0.0
        {
            report.degenerate_faces += 1;
        }
        let mut key = *t;
        key.sort_unstable();
        *faces.entry(key).or_default() += 1;
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
    report.duplicate_faces = faces.values().map(|&c| c as usize - 1).sum();
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_diagonal_of_a_huge_box_stays_finite() {
        let p = [Point3::new(0.0, 0.0, 0.0), Point3::new(3e200, 4e200, 0.0)];
        assert!((bbox_diagonal(&p) - 5e200).abs() < 1e188);
        let q = [Point3::new(0.0, 0.0, 0.0), Point3::new(3.0, 4.0, 0.0)];
        assert_eq!(bbox_diagonal(&q), 5.0);
    }

    #[test]
    fn the_diameter_is_the_largest_distance_and_does_not_turn_with_the_points() {
        // A cube: its space diagonal, whatever the rotation.
        let cube: Vec<Point3<f64>> = (0..8)
            .map(|i| Point3::new((i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2 & 1) as f64))
            .collect();
        assert!((diameter(&cube) - 3f64.sqrt()).abs() < 1e-15);
        let r = nalgebra::Rotation3::from_euler_angles(0.3, 1.1, -0.7);
        let turned: Vec<Point3<f64>> = cube.iter().map(|p| r * p).collect();
        assert!((diameter(&turned) - 3f64.sqrt()).abs() < 1e-14);
        // The box diagonal changes under the same rotation (the reason for the diameter).
        assert!((bbox_diagonal(&turned) - bbox_diagonal(&cube)).abs() > 0.1);
        // Against the brute force on a lopsided cloud, including points equidistant from the
        // centroid (a circle) where the pruning cannot skip anything.
        let mut cloud: Vec<Point3<f64>> = (0..60)
            .map(|k| {
                let a = k as f64 * 0.37;
                Point3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        cloud.extend((0..40).map(|k| Point3::new(0.1 * k as f64, 0.05 * (k * k % 7) as f64, 0.3)));
        let brute = cloud
            .iter()
            .flat_map(|p| cloud.iter().map(move |q| (p - q).norm()))
            .fold(0.0, f64::max);
        assert!((diameter(&cloud) - brute).abs() < 1e-14 * brute);
        assert_eq!(diameter(&cloud[..1]), 0.0);
        assert_eq!(diameter(&[]), 0.0);
        let huge = [Point3::new(0.0, 0.0, 0.0), Point3::new(3e200, 4e200, 0.0)];
        assert!((diameter(&huge) - 5e200).abs() < 1e188);
        let nan = [Point3::new(0.0, 0.0, 0.0), Point3::new(f64::NAN, 0.0, 0.0)];
        assert!(diameter(&nan).is_nan());
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
