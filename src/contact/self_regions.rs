//! Two parts of one mesh (2021 Sec. 6): their intersection regions `I_l` found by the
//! inside-twice test (the truncated parts are open: the flood fill of [`IntersectionRegion`]
//! has nothing to stop it), and the faces near them that each part's mapping rays may land on.

use super::SideFrame;
use crate::intersect::{IntersectionRegion, Intersections, PosedMesh};
use nalgebra::{Point3, Vector3};

/// Two parts of one mesh (Sec. 6): the intersection regions `I_l` completed by the
/// inside-twice test (built here when not `given`), and, per part, the faces its rays may
/// land on: those within `HIT_REACH` edge lengths of its intersection region.
pub(super) fn parts_of_one_mesh(
    parts: [SideFrame; 2],
    ints: &Intersections,
    given: Option<&InsideTwice>,
    regions: &mut [IntersectionRegion; 2],
) -> [Vec<bool>; 2] {
    let built;
    let inside = match given {
        Some(t) => t,
        None => {
            built = InsideTwice::build(parts[0].mesh.positions(), parts[0].mesh.triangles());
            &built
        }
    };
    inside_by_winding(parts, ints, inside, regions);
    let reach = HIT_REACH * inside.h;
    [
        near_region(parts[0].mesh, &regions[0], reach),
        near_region(parts[1].mesh, &regions[1], reach),
    ]
}

/// How far from a part's intersection region (along its edges, in mean edge lengths) the
/// other part's rays may land in a self-contact.
const HIT_REACH: f64 = 8.0;

/// Faces of `mesh` with a corner within `reach` (edge-path length) of `region` (its vertices
/// and the corners of its cut faces).
///
/// In a self-contact the farthest hit of a mapping ray (Algorithm 1 line 12) belongs near the
/// other part's intersection region: the segment from a vertex inside the other part to the
/// other surface crosses the intersection volume. The truncated parts are open and curve back
/// on themselves (a lip wraps around the mouth's corner), so an unrestricted farthest hit can
/// land on a far layer of the other part: the vertex is then mapped through the lip (measured
/// on the mouth: a jump of 4 h in one frame, temporal ratio 12.5). Not in the paper. The reach
/// is generous on purpose: on the bending capsule at 150°, 2 edges of reach leave 7
/// penetrating vertices, 4 or more none; the mouth's far layer is more than 16 edges away.
fn near_region(mesh: &PosedMesh, region: &IntersectionRegion, reach: f64) -> Vec<bool> {
    use crate::mesh::Queued;
    let (index, positions) = (mesh.index(), mesh.positions());
    let mut dist = vec![f64::INFINITY; positions.len()];
    let mut heap = std::collections::BinaryHeap::new();
    let corners = region
        .cut_faces
        .iter()
        .flat_map(|c| mesh.triangles()[c.face as usize]);
    let seeds = (0..region.inside.len() as u32).filter(|&v| region.inside[v as usize]);
    for v in seeds.chain(corners) {
        dist[v as usize] = 0.0;
        heap.push(Queued(0.0, v));
    }
    while let Some(Queued(d, v)) = heap.pop() {
        if d > dist[v as usize] {
            continue;
        }
        for &e in index.vertex_edges(v) {
            let [p, q] = index.edges()[e as usize];
            let w = if p == v { q } else { p };
            let dw = d + (positions[w as usize] - positions[v as usize]).norm();
            if dw <= reach && dw < dist[w as usize] {
                dist[w as usize] = dw;
                heap.push(Queued(dw, w));
            }
        }
    }
    mesh.triangles()
        .iter()
        .map(|t| t.iter().any(|&v| dist[v as usize].is_finite()))
        .collect()
}

/// Whether a point of a closed body with unit normal `n` lies inside it twice over (inside its
/// own side and inside another part of the same body): the generalized winding number of the
/// body at the point nudged `10⁻³ h` inward is at least 1.5.
pub fn inside_twice(
    winding: &crate::report::metrics::WindingNumber,
    p: &Point3<f64>,
    n: &Vector3<f64>,
    h: f64,
) -> bool {
    winding.query(&(p - n * (1e-3 * h))) >= 1.5
}

/// [`inside_twice`] for the vertices of one body at one frame, each vertex queried at most
/// once: the self-contact of a joint asks it for the crease cut, `I_l` and the crease zones,
/// often of the same vertices (a winding query costs microseconds near a fold).
pub struct InsideTwice<'w> {
    winding: std::borrow::Cow<'w, crate::report::metrics::WindingNumber>,
    /// The nudge length: the body's mean edge length.
    pub h: f64,
    /// Per vertex: 0 not asked yet, 1 outside, 2 inside.
    known: Vec<std::sync::atomic::AtomicU8>,
}

impl<'w> InsideTwice<'w> {
    /// The test with a tree (owned or borrowed) of the body at `positions`.
    pub fn new(
        winding: std::borrow::Cow<'w, crate::report::metrics::WindingNumber>,
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
    ) -> Self {
        Self {
            winding,
            h: crate::mesh::operators::mean_edge_length(positions, triangles),
            known: (0..positions.len())
                .map(|_| std::sync::atomic::AtomicU8::new(0))
                .collect(),
        }
    }

    /// The test with its own tree of the body at `positions`.
    pub fn build(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> InsideTwice<'static> {
        let tree = crate::report::metrics::WindingNumber::new(positions, triangles);
        InsideTwice::new(std::borrow::Cow::Owned(tree), positions, triangles)
    }

    /// Whether vertex `v` (at `p`, unit normal `n`) lies inside the body twice over.
    pub fn at(&self, v: usize, p: &Point3<f64>, n: &Vector3<f64>) -> bool {
        use std::sync::atomic::Ordering::Relaxed;
        match self.known.get(v).map(|k| k.load(Relaxed)) {
            Some(1) => false,
            Some(2) => true,
            slot => {
                let inside = inside_twice(&self.winding, p, n, self.h);
                if slot.is_some() {
                    self.known[v].store(if inside { 2 } else { 1 }, Relaxed);
                }
                inside
            }
        }
    }
}

/// Self-contact: the truncated parts are open surfaces whose intersection curves usually end
/// at the crease cut, so the flood fill of [`IntersectionRegion`] has nothing to stop it.
/// Instead, a vertex of a part is in `I_l` when it lies inside the closed body twice over:
/// the generalized winding number of the whole mesh at the vertex nudged inward by `10⁻³ h`
/// is at least 1.5 (the nudged point is inside its own body and inside the other part).
/// Faces with all corners inside are whole faces, faces with some are cut faces (without
/// sub-triangles: the self-contact direction comes from the skeleton, not from Eq. 2).
fn inside_by_winding(
    parts: [SideFrame; 2],
    ints: &Intersections,
    test: &InsideTwice,
    regions: &mut [IntersectionRegion; 2],
) {
    let positions = parts[0].mesh.positions();
    let triangles = parts[0].mesh.triangles();
    for (k, (part, region)) in parts.iter().zip(regions.iter_mut()).enumerate() {
        let index = part.mesh.index();
        let is_inside = |v: u32| {
            test.at(
                v as usize,
                &positions[v as usize],
                &part.normals[v as usize],
            )
        };
        // Every component of I_l touches the intersection curve: search from the corners of
        // the crossed faces.
        let seeds = ints
            .segments
            .iter()
            .flat_map(|s| triangles[s.faces[k] as usize]);
        let inside = inside_from(
            positions.len(),
            seeds,
            |v, out| {
                out.extend(index.vertex_edges(v).iter().map(|&e| {
                    let [a, b] = index.edges()[e as usize];
                    if a == v {
                        b
                    } else {
                        a
                    }
                }))
            },
            |v| index.uses_vertex(v) && is_inside(v),
        );
        let (mut whole, mut cut) = (Vec::new(), Vec::new());
        for &f in index.faces() {
            let n = triangles[f as usize]
                .iter()
                .filter(|&&v| inside[v as usize])
                .count();
            if n == 3 {
                whole.push(f);
            } else if n > 0 {
                cut.push(crate::intersect::CutFace {
                    face: f,
                    sub_triangles: Vec::new(),
                    holes: Vec::new(),
                });
            }
        }
        region.inside = inside;
        region.whole_faces = whole;
        region.cut_faces = cut;
    }
}

/// The vertices (ids below `n`) reached from `seeds` through vertices that pass `inside`:
/// the search crosses edges (`neighbours(v, out)` pushes the vertices next to `v`) but
/// expands only from vertices found inside, and asks `inside` once per vertex. This is how the
/// inside regions of a self-contact are found: each of their components touches the
/// intersection curve.
pub(crate) fn inside_from(
    n: usize,
    seeds: impl IntoIterator<Item = u32>,
    neighbours: impl Fn(u32, &mut Vec<u32>),
    mut inside: impl FnMut(u32) -> bool,
) -> Vec<bool> {
    let mut state = vec![0u8; n]; // 0 unseen, 1 outside, 2 inside
    let mut stack: Vec<u32> = seeds.into_iter().collect();
    while let Some(v) = stack.pop() {
        if state.get(v as usize) != Some(&0) {
            continue;
        }
        let found = inside(v);
        state[v as usize] = if found { 2 } else { 1 };
        if found {
            neighbours(v, &mut stack);
        }
    }
    state.iter().map(|&s| s == 2).collect()
}
