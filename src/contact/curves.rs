//! Whether two surfaces' intersection amounts to a contact (2021 Sec. 4, Algorithm 1):
//! its curves longer than a touch, and separate surfaces lying on each other refused.

use super::{ContactError, PairParams, Surfaces};
use crate::intersect::{Intersections, PosedMesh};

/// Fraction of either surface's faces that may be exactly coplanar with faces of the other
/// before two separate surfaces count as coincident ([`ContactError::Coincident`]). A mesh and
/// its duplicate have every face coplanar with its twin (the two fingers with a second copy
/// of their body: 13760 of 13760); a flat side resting exactly on another (a box on a floor)
/// only its few faces there; the committed scenes none. Coplanar pairs never cross under the
/// predicates' perturbation, so the pass would resolve only the few real crossings of the
/// copies, slowly, and turn thousands of faces over.
pub const COINCIDENT_FRACTION: f64 = 0.5;

/// The intersection of the two sides when it amounts to a contact (curves longer than a
/// touch), else `None`; separate surfaces lying on each other refused when `params` say so.
pub(super) fn contact_curves(
    meshes: [&PosedMesh; 2],
    surfaces: Surfaces,
    params: &PairParams,
) -> Result<Option<Intersections>, ContactError> {
    let ints = match surfaces {
        Surfaces::PartsOfOneMesh(_) => Intersections::self_contact(meshes[0], meshes[1])?,
        Surfaces::Separate => Intersections::between(meshes[0], meshes[1])?,
    };
    if matches!(surfaces, Surfaces::Separate) && params.refuse_coincident {
        not_coincident(meshes, &ints)?;
    }
    let touch = TOUCH_TOLERANCE * reach_of(meshes[0], meshes[1]);
    let contact = !(ints.is_empty() || curve_length(&ints) <= touch);
    Ok(contact.then_some(ints))
}

/// [`ContactError::Coincident`] when the intersection of two separate surfaces found them
/// lying on each other.
fn not_coincident(meshes: [&PosedMesh; 2], ints: &Intersections) -> Result<(), ContactError> {
    for (k, mesh) in meshes.iter().enumerate() {
        let (coplanar, faces) = (ints.stats.coplanar_faces[k], mesh.triangles().len());
        if coplanar > 0 && coplanar as f64 >= COINCIDENT_FRACTION * faces as f64 {
            return Err(ContactError::Coincident { coplanar, faces });
        }
    }
    Ok(())
}

/// Intersection curves shorter than this fraction of the scene size are a touch (surfaces
/// meeting at a point or along a degenerate curve, e.g. two vertices placed on the same point
/// of `S` by a previous pass): nothing to resolve.
pub const TOUCH_TOLERANCE: f64 = 1e-9;

/// Total length of the intersection curves.
fn curve_length(ints: &Intersections) -> f64 {
    ints.segments
        .iter()
        .map(|s| (ints.hits[s.hits[1] as usize].point - ints.hits[s.hits[0] as usize].point).norm())
        .sum()
}

/// The diagonal of the box around both surfaces (at least the smallest positive number: a
/// floor of 1e-9, until 2026-12-05, made every contact of a rig scaled below 1e-18 a touch).
pub(super) fn reach_of(a: &PosedMesh, b: &PosedMesh) -> f64 {
    let boxes = [a.bvh().root_box(), b.bvh().root_box()];
    let mut it = boxes.iter().flatten();
    let Some(first) = it.next() else { return 1.0 };
    let all = it.fold(*first, |acc, x| acc.union(x));
    (all.max - all.min).norm().max(f64::MIN_POSITIVE)
}
