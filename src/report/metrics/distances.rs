//! Point-to-surface and Hausdorff distances.

use super::bvh::Bvh;
use super::*;

/// Unsigned distance from each point to the closest point of the faces `faces` (ids into
/// `triangles`) of the surface over `positions`: exact point-triangle distances
/// ([`closest_point_on_triangle`]) found through a BVH. Used for contact consistency (the
/// distance between the two sides' contact zones, `MEASURING.md`).
///
/// Faces that are out of range or have a non-finite corner are ignored; a non-finite point, or
/// no face left, gives `f64::INFINITY`. Parallel over the points, output in their order.
pub fn surface_distance(
    points: &[Point3<f64>],
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    faces: &[u32],
) -> Vec<f64> {
    let (bvh, _) = Bvh::build(positions, triangles, faces.iter().copied());
    distances(points, &bvh)
}

fn distances(points: &[Point3<f64>], bvh: &Bvh) -> Vec<f64> {
    points
        .par_iter()
        .with_min_len(64)
        .map(|p| {
            if !finite(p) {
                return f64::INFINITY;
            }
            bvh.nearest(p, |_| true)
                .map_or(f64::INFINITY, |(d2, _)| d2.sqrt())
        })
        .collect()
}

/// Largest distance from the finite vertices used by `a_triangles` (indices in range) to the
/// surface `b`, over `b`'s valid faces.
fn one_sided(
    a_positions: &[Point3<f64>],
    a_triangles: &[[u32; 3]],
    b_positions: &[Point3<f64>],
    b_triangles: &[[u32; 3]],
) -> f64 {
    let mut used = vec![false; a_positions.len()];
    for t in a_triangles {
        for &i in t {
            if let Some(u) = used.get_mut(i as usize) {
                *u = true;
            }
        }
    }
    let points: Vec<Point3<f64>> = a_positions
        .iter()
        .zip(&used)
        .filter(|(p, &u)| u && finite(p))
        .map(|(p, _)| *p)
        .collect();
    if points.is_empty() {
        return 0.0;
    }
    let (bvh, _) = Bvh::build(b_positions, b_triangles, 0..b_triangles.len() as u32);
    distances(&points, &bvh).into_iter().fold(0.0, f64::max)
}

/// Symmetric Hausdorff distance between two triangle meshes, vertex to surface both ways:
/// `max(max_{v ∈ A} d(v, B), max_{v ∈ B} d(v, A))`, with exact point-triangle distances
/// (`MEASURING.md`: distance to a converged solution).
///
/// Only vertices used by a triangle are measured; non-finite vertices are skipped and faces
/// with an invalid corner ignored. 0 when neither mesh has a vertex to measure;
/// `f64::INFINITY` when one side has vertices and the other no valid face.
pub fn hausdorff(
    a_positions: &[Point3<f64>],
    a_triangles: &[[u32; 3]],
    b_positions: &[Point3<f64>],
    b_triangles: &[[u32; 3]],
) -> f64 {
    let ab = one_sided(a_positions, a_triangles, b_positions, b_triangles);
    let ba = one_sided(b_positions, b_triangles, a_positions, a_triangles);
    ab.max(ba)
}

/// Symmetric distance between two face sets of possibly different meshes (the two sides of a
/// contact zone, `MEASURING.md` "Contact consistency"): the largest distance from a finite
/// vertex of one set's faces to the other set's faces, both ways. 0 when both sets are empty,
/// `f64::INFINITY` when only one is (or has only invalid faces).
pub fn zone_distance(
    a_positions: &[Point3<f64>],
    a_triangles: &[[u32; 3]],
    a_faces: &[u32],
    b_positions: &[Point3<f64>],
    b_triangles: &[[u32; 3]],
    b_faces: &[u32],
) -> f64 {
    let pick = |tris: &[[u32; 3]], faces: &[u32]| -> Vec<[u32; 3]> {
        faces
            .iter()
            .filter_map(|&f| tris.get(f as usize).copied())
            .collect()
    };
    let (ta, tb) = (pick(a_triangles, a_faces), pick(b_triangles, b_faces));
    hausdorff(a_positions, &ta, b_positions, &tb)
}
