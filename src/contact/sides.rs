//! The two sides of a contact (2021 Sec. 4.2-4.4; Algorithm 1 lines 6-27): each side's mapping
//! region, its samples on the potential contact surface `S`, the threshold both share (Eq. 4)
//! and their contact zones, assembled into [`ContactSide`]s.

use super::{mapping, zones, ContactSide, MappingRegion, SideFrame, Zone};
use crate::intersect::{IntersectionRegion, Intersections, Side};

/// The intersection points of a side's edges, by edge then `t` (not in the map's order,
/// which changes from run to run).
fn sorted_crossings(hits: &zones::EdgeHits) -> Vec<([u32; 2], f64)> {
    let mut out: Vec<([u32; 2], f64)> = hits
        .iter()
        .flat_map(|(e, list)| list.iter().map(move |(t, _)| (*e, *t)))
        .collect();
    out.sort_unstable_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
    out
}

/// Sec. 4.2: the mapping region `M_l` of each side, cast along its `frames[l].cast` (with the
/// seam vertices of two parts of one mesh when `seams`, [`mapping::mapping_region`]).
pub(super) fn mapping_regions(
    sides: [SideFrame; 2],
    regions: &[IntersectionRegion; 2],
    frames: &[zones::SurfaceFrame; 2],
    reach: f64,
    seams: bool,
) -> [MappingRegion; 2] {
    [0, 1].map(|k| {
        mapping::mapping_region(
            sides[k],
            sides[1 - k],
            &regions[k].inside,
            &regions[1 - k],
            &frames[k].cast,
            reach,
            seams,
        )
    })
}

/// The two sides' contact zones and the threshold they share (Sec. 4.3-4.4).
pub(super) struct ZonedSides {
    pub(super) sides: [ContactSide; 2],
    pub(super) threshold: f64,
    pub(super) mean_depth: f64,
    pub(super) depth_deviation: f64,
}

/// What puts a sample in a contact zone: `τ` of Eq. 4 and the cosine of the safeguard angle.
#[derive(Clone, Copy, Debug)]
pub(super) struct ZoneCriterion {
    pub(super) tau: f64,
    pub(super) guard: f64,
}

/// Sec. 4.3-4.4: the samples of each mapping region on the potential contact surface `S`,
/// the symmetric threshold of Eq. 4 (`τ`) and the zones with their exact boundaries.
pub(super) fn contact_zones(
    sides: [SideFrame; 2],
    ints: &Intersections,
    mapped: &[MappingRegion; 2],
    frames: [zones::SurfaceFrame; 2],
    reach: f64,
    criterion: ZoneCriterion,
) -> ZonedSides {
    let labels = [Side::A, Side::B];
    let hits: [zones::EdgeHits; 2] =
        [0, 1].map(|k| zones::edge_hits(ints, labels[k], sides[1 - k]));
    let inputs = [0, 1].map(|k| zones::SideInput {
        own: sides[k],
        other: sides[1 - k],
        region: &mapped[k],
        hits: &hits[k],
        frame: frames[k],
        reach,
    });
    let samples: [zones::SideSamples; 2] = [0, 1].map(|k| inputs[k].samples());
    let moments = [0, 1].map(|k| side_moments(&sides[k], &samples[k]));
    let (threshold, mean_depth, depth_deviation) = zones::threshold(moments, criterion.tau);
    let zones = [0, 1].map(|k| zones::zone(&inputs[k], &samples[k], threshold, criterion.guard));
    // The samples move into the sides (no copy).
    let side = |k: usize, own: zones::SideSamples, zone: Zone| ContactSide {
        direction: -frames[k].cast,
        cast: frames[k].cast,
        stiffness: frames[k].stiffness,
        samples: own.vertices,
        zone,
        mapping: mapped[k].stats,
        bisected_boundaries: own.bisected,
        crossings: sorted_crossings(&hits[k]),
    };
    let ([s0, s1], [z0, z1]) = (samples, zones);
    ZonedSides {
        sides: [side(0, s0, z0), side(1, s1, z1)],
        threshold,
        mean_depth,
        depth_deviation,
    }
}

/// Eq. 4's depth moments of one side, over its own faces: for a part of one mesh
/// (self-contact) the part's, not the whole mesh's, whose other part's faces along the seam
/// have sampled corners at depth 0 ([`zones::depth_moments`]).
fn side_moments(side: &SideFrame, samples: &zones::SideSamples) -> [f64; 3] {
    let mesh = side.mesh;
    zones::depth_moments(mesh.triangles(), mesh.index().faces(), samples)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::fixtures;
    use crate::intersect::MeshIndex;
    use nalgebra::Vector3;

    /// A part of one mesh takes Eq. 4's moments over its own faces: the folded square's flat
    /// part, every vertex sampled at depth `1 + x`, has area 1 and mean depth 1.5, although
    /// the other part's faces (area `√2`) have sampled corners too.
    #[test]
    fn a_parts_moments_are_over_its_own_faces() {
        let (positions, triangles) = fixtures::folded_square();
        let [a, _] =
            MeshIndex::self_contact_parts(&positions, &triangles, &[1, 1, 2, 2]).expect("parts");
        let a = a.pose(&positions).expect("A");
        let normals = vec![Vector3::z(); positions.len()];
        let side = SideFrame {
            mesh: &a,
            normals: &normals,
            hittable: None,
        };
        let samples = fixtures::sampled_at_depth(&positions, |q| 1.0 + q.x);
        let [area, first, _] = side_moments(&side, &samples);
        assert!((area - 1.0).abs() < 1e-14, "area {area}");
        assert!((first / area - 1.5).abs() < 1e-14, "mean {}", first / area);
    }
}
