//! The contact zones extended to the crease cut's vertices inside the other part (not in the
//! paper; see [`zones_to_the_crease`]).

use super::*;

/// Extends the contact zones to the vertices of the crease cut (next to the other side) that
/// lie inside the other part ([`crate::contact::inside_twice`], as for `I_l`): each joins the
/// zone of its own side, else of the other side (a cut vertex belongs to faces of both parts),
/// whose sample is [`conditioned`]; only a side that already has a zone is extended.
///
/// Not in the paper. The threshold of Eq. 4 leaves out the shallow end of the intersection,
/// which in a fold is its bottom: the two sides meet at the crease, where the depth goes to 0.
/// Left to Sec. 5's profile, that band gets the amplitude diffused from the zone (about 0.7 h
/// on the bending capsule) along a direction that `σ` turns through the normals between the
/// two zones; LBS's loop has turned those normals over, and the band folded (40 to 100 faces
/// per frame turned against both the input and the skinning on the capsule and the finger).
/// As zone vertices, the crease vertices go to their own point on `S` (about where they are)
/// and keep their side's sign, whichever side the cut gives them from frame to frame. The cut
/// also runs round the outside of the joint, where nothing is inside the other part: those
/// vertices stay out (else the zones would jump there as the cut moves). With `connected_only`
/// ([`FoldParams::free_isolated_crease`]) a crease vertex joins only where it connects to the
/// zone it would join (next to one of its vertices, or to a crease vertex joining it).
///
/// In a further sweep, a crease vertex that the sweep before left penetrating
/// ([`FoldInput::left_penetrating`]) stays out: its sample is mostly the seam's own point at
/// depth 0 (`contact::mapping`'s seams), and as a zone vertex it is pinned where it is, inside
/// the other part, in every sweep (traced on the finger with CoR input, frame 24 of 31: three
/// of its seven penetrating vertices pinned through the six sweeps). Out of the zones the
/// profile carries it with its neighbours. A vertex that no sweep left penetrating (all of
/// them on LBS input, which takes no further sweep) joins as before.
pub(super) fn zones_to_the_crease(
    pre: &FoldPre,
    input: &CreaseVertices,
    contact: &mut Contact,
    connected_only: bool,
) {
    let candidates = crease_candidates(pre, input, contact);
    let inside = |v: usize| input.test.at(v, &input.positions[v], &input.normals[v]);
    let joining: Vec<(usize, usize)> = if connected_only {
        connected_candidates(pre, &candidates, contact, inside)
    } else {
        candidates.into_iter().filter(|&(v, _)| inside(v)).collect()
    };
    for (v, k) in joining {
        let side = &mut contact.sides[k];
        side.zone.inside[v] = true;
        side.zone.vertices.push(v as u32);
    }
    for side in &mut contact.sides {
        side.zone.vertices.sort_unstable();
    }
}

/// What [`zones_to_the_crease`] reads of the frame: the cut, the posed body and the
/// inside-twice test.
pub(super) struct CreaseVertices<'a> {
    pub(super) on_w1: &'a [bool],
    pub(super) positions: &'a [Point3<f64>],
    pub(super) normals: &'a [Vector3<f64>],
    pub(super) test: &'a InsideTwice<'a>,
    /// [`FoldInput::left_penetrating`].
    pub(super) left_penetrating: Option<&'a [bool]>,
}

impl<'a> CreaseVertices<'a> {
    /// The frame's `crease` on the body `g`, tested with `test`.
    pub(super) fn of(g: &FoldInput<'a>, crease: &'a Crease, test: &'a InsideTwice<'a>) -> Self {
        Self {
            on_w1: &crease.on_w1,
            positions: g.positions,
            normals: g.normals,
            test,
            left_penetrating: g.left_penetrating,
        }
    }
}

/// The crease vertices (on an edge of `R` across the cut) outside the zones and not left
/// penetrating by the sweep before, each with the zone it would join (its own side's, else the
/// other's, whose sample is [`conditioned`]), in the order of `R`'s edges. Zones are extended,
/// not created: a zone made of crease vertices alone can sit on the working region's border,
/// where the extent is capped to nothing and no bulge can compensate (measured on CesiumMan: a
/// one-vertex zone, volume error 7e-3).
fn crease_candidates(
    pre: &FoldPre,
    input: &CreaseVertices,
    contact: &Contact,
) -> Vec<(usize, usize)> {
    let region = &pre.shared.solver.region;
    // The body's mean edge length in this frame (computed once, with the test).
    let length = input.test.h;
    let extendable = contact
        .sides
        .each_ref()
        .map(|c| !c.zone.vertices.is_empty());
    let left = |v: usize| {
        input
            .left_penetrating
            .is_some_and(|l| l.get(v).copied().unwrap_or(false))
    };
    let mut seen = vec![false; input.positions.len()];
    let mut candidates = Vec::new();
    for &[a, b] in &region.edges {
        let (va, vb) = (
            region.vertices[a as usize] as usize,
            region.vertices[b as usize] as usize,
        );
        if input.on_w1[va] == input.on_w1[vb] {
            continue;
        }
        for v in [va, vb] {
            if std::mem::replace(&mut seen[v], true)
                || contact.sides.iter().any(|c| c.zone.inside[v])
                || left(v)
            {
                continue;
            }
            let own = usize::from(!input.on_w1[v]);
            let joins = [own, 1 - own]
                .into_iter()
                .find(|&k| extendable[k] && conditioned(&contact.sides[k], v, length));
            if let Some(k) = joins {
                candidates.push((v, k));
            }
        }
    }
    candidates
}

/// [`FoldParams::free_isolated_crease`]: of the `candidates`, those inside the other part and
/// connected to the zone they would join, next to one of its vertices or to a candidate that
/// joins it (a flood over `R`'s edges, [`FoldPre`]'s adjacency of `R`, from the zones); the
/// isolated ones stay out.
fn connected_candidates(
    pre: &FoldPre,
    candidates: &[(usize, usize)],
    contact: &Contact,
    inside: impl Fn(usize) -> bool,
) -> Vec<(usize, usize)> {
    let region = &pre.shared.solver.region;
    let neighbours = &pre.shared_adjacency;
    // Per local vertex: the zone it would join, while it has not been tried.
    let mut open: Vec<Option<usize>> = vec![None; region.vertices.len()];
    for &(v, k) in candidates {
        if let Some(&l) = pre.shared.local_of.get(v).filter(|&&l| l != u32::MAX) {
            open[l as usize] = Some(k);
        }
    }
    let next_to_zone = |l: usize, k: usize| {
        neighbours[l]
            .iter()
            .any(|&m| contact.sides[k].zone.inside[region.vertices[m as usize] as usize])
    };
    let mut queue: std::collections::VecDeque<usize> = (0..open.len())
        .filter(|&l| open[l].is_some_and(|k| next_to_zone(l, k)))
        .collect();
    let mut joining = Vec::new();
    while let Some(l) = queue.pop_front() {
        let Some(k) = open[l].take() else {
            continue;
        };
        let v = region.vertices[l] as usize;
        if !inside(v) {
            continue;
        }
        joining.push((v, k));
        let next = neighbours[l].iter().map(|&m| m as usize);
        queue.extend(next.filter(|&m| open[m] == Some(k)));
    }
    joining
}

/// Whether `side`'s sample of `v` places it on `S` by a displacement that agrees with its
/// depth (Eq. 3): the angle between the displacement and the normal of `S` is below 60°, or
/// the displacement is below 0.05 `length`. At the bottom of a fold `S` can turn parallel to
/// the mapping axis, where a vertex on `S` (depth 0) is sent along it by a whole edge length
/// (measured on the bending capsule with CoR input): such a sample is left to the profile.
fn conditioned(side: &ContactSide, v: usize, length: f64) -> bool {
    side.samples.get(v).is_some_and(|s| {
        let moved = (s.surface_point - s.point).norm();
        moved <= 0.05 * length || s.depth * (1.0 - side.stiffness) >= 0.5 * moved
    })
}
