//! A bounding-volume hierarchy over the triangles of one mesh (or a subset of its faces), built
//! once on a reference pose and refitted per frame (same topology, new positions).
//!
//! Binned SAH build (Wald 2007), flat node array in which children always follow their parent
//! (so a refit is one reverse sweep), closed-interval box tests on exact per-face boxes: two
//! triangles that touch always have overlapping boxes, which keeps the candidate pairs
//! consistent with the exact predicates.
//!
//! The tree and its refits are here; its boxes in `aabb`, its build in `build`, its pair
//! queries in `pairs`, where two of its face sets meet (where those queries start) in `meeting`.

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

mod aabb;
mod build;
mod meeting;
mod pairs;

pub use aabb::Aabb;
use build::{build_nodes, depth_first, face_box};
pub use pairs::{FaceSets, MIN_PAIR_BUDGET, PAIRS_PER_FACE};

/// Faces per leaf at most (faces with coincident centroids are split in the middle of their
/// order, `split`). 8 rather than 4: a self-contact pass without contact (mostly this tree's
/// refit at its nodes and its pair traversals) took 54 instead of 58 µs on the finger and 28
/// instead of 30 µs on the bending capsule (one thread, medians of 20,000 frames, 2026-12-05);
/// 16 took 64 µs on the finger. The folds and the contact pass between bodies (ray casts, pair
/// queries) did not change beyond the machine's noise, and neither did any output (every face
/// pair and farthest hit is the same on any tree).
const MAX_LEAF: usize = 8;

#[derive(Clone, Copy, Debug)]
struct Node {
    aabb: Aabb,
    /// Leaf: first slot in `faces`; internal: index of the left child (right = left + 1).
    first: u32,
    /// Number of faces of a leaf, 0 for an internal node.
    count: u32,
}

/// A BVH over a set of faces of one triangle mesh.
///
/// Precompute once ([`TriangleBvh::build`]), then [`TriangleBvh::refit`] per frame: the tree
/// keeps its structure, only the boxes follow the positions. For large deformations a rebuild
/// gives tighter boxes; results of every query are independent of the tree (they are sorted or
/// reduced by a total order), so both give identical answers.
#[derive(Clone, Debug)]
pub struct TriangleBvh {
    nodes: Vec<Node>,
    /// Face id of each leaf slot.
    faces: Vec<u32>,
    /// Box of each leaf slot's face (current positions; [`Aabb::EMPTY`] for a masked slot)
    /// when `faces_fitted`, else those of an earlier refit.
    face_boxes: Vec<Aabb>,
    /// Whether `face_boxes` are at the positions of the node boxes: not after
    /// [`TriangleBvh::refit_nodes_at`], whose queries then take a face's box from its
    /// positions ([`TriangleBvh::pairs_between_sets`]) or its leaf's box (the others).
    faces_fitted: bool,
    /// Per leaf slot: the face belongs to the tree (`None`: every slot does). See
    /// [`TriangleBvh::restricted_at`].
    live: Option<Vec<bool>>,
}

impl TriangleBvh {
    /// Builds the tree over `faces` (ids into `triangles`, whose indices must be valid for
    /// `positions`).
    pub fn build(positions: &[Point3<f64>], triangles: &[[u32; 3]], faces: &[u32]) -> Self {
        let boxes: Vec<Aabb> = faces
            .iter()
            .map(|&f| face_box(positions, &triangles[f as usize]))
            .collect();
        let centroids: Vec<Point3<f64>> = boxes
            .iter()
            .map(|b| nalgebra::center(&b.min, &b.max))
            .collect();
        let mut order: Vec<u32> = (0..faces.len() as u32).collect();
        let nodes = depth_first(&build_nodes(&boxes, &centroids, &mut order));
        Self {
            nodes,
            faces: order.iter().map(|&i| faces[i as usize]).collect(),
            face_boxes: order.iter().map(|&i| boxes[i as usize]).collect(),
            faces_fitted: true,
            live: None,
        }
    }

    /// The tree over a subset of its faces at `positions`, without a rebuild: the structure
    /// is kept and the other faces get empty boxes (which no query reaches), so every query
    /// gives what a tree built over the subset gives (and still after a
    /// [`TriangleBvh::refit`]). `None` when a face of `faces` (sorted ids) is not in the tree.
    /// Used for the truncated parts of a self-contact, whose faces move with the crease every
    /// frame while their union does not.
    pub fn restricted_at(
        &self,
        faces: &[u32],
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
    ) -> Option<Self> {
        // Membership by a mark per face id (not a binary search per slot: the self-contact
        // pass restricts two parts per fold from a union of thousands of faces).
        let size = self.faces.iter().max().map_or(0, |&f| f as usize + 1);
        let mut wanted = vec![false; size];
        for &f in faces {
            // A face beyond the tree's largest id is not in the tree.
            *wanted.get_mut(f as usize)? = true;
        }
        let live: Vec<bool> = self.faces.iter().map(|&f| wanted[f as usize]).collect();
        if live.iter().filter(|&&l| l).count() != faces.len() {
            return None;
        }
        let mut out = self.clone();
        out.live = Some(live);
        out.refit(positions, triangles);
        Some(out)
    }

    /// Recomputes every box for new positions of the same mesh (same triangles).
    pub fn refit(&mut self, positions: &[Point3<f64>], triangles: &[[u32; 3]]) {
        self.refit_boxes(|f| face_box(positions, &triangles[f as usize]));
    }

    /// Like [`TriangleBvh::refit`], each face's box covering the face at both `from` and `to`
    /// (and so, box and face being convex, its whole straight path between them).
    pub fn refit_swept(
        &mut self,
        from: &[Point3<f64>],
        to: &[Point3<f64>],
        triangles: &[[u32; 3]],
    ) {
        self.refit_boxes(|f| {
            let t = &triangles[f as usize];
            Aabb::of_triangle(t.map(|i| &from[i as usize]))
                .union(&Aabb::of_triangle(t.map(|i| &to[i as usize])))
        });
    }

    /// Every live slot's box from `face_box(face id)`, then the nodes'.
    fn refit_boxes(&mut self, face_box: impl Fn(u32) -> Aabb + Sync) {
        // In chunks of slots, each a plain loop (per slot through rayon, `face_box` was a call
        // per face).
        const CHUNK: usize = 1024;
        let live = self.live.as_deref();
        self.faces
            .par_chunks(CHUNK)
            .zip(self.face_boxes.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(chunk, (faces, boxes))| {
                let first = chunk * CHUNK;
                for (i, (&f, b)) in faces.iter().zip(boxes).enumerate() {
                    *b = if live.is_none_or(|l| l[first + i]) {
                        face_box(f)
                    } else {
                        Aabb::EMPTY
                    }
                }
            });
        self.faces_fitted = true;
        self.refit_nodes();
    }

    /// Each live slot's corners, per leaf node, for [`TriangleBvh::refit_nodes_at`]: each
    /// vertex once per leaf (the finger's leaves hold 6.0 faces and 7.6 corners on average,
    /// not 18).
    /// `triangles` are those the tree was built over (as for [`TriangleBvh::refit`]).
    pub fn leaf_corners(&self, triangles: &[[u32; 3]]) -> LeafCorners {
        let mut offsets = Vec::with_capacity(self.nodes.len() + 1);
        let mut vertices = Vec::new();
        offsets.push(0);
        for n in &self.nodes {
            let slots = n.first as usize..(n.first + n.count) as usize;
            let mut leaf: Vec<u32> = slots
                .filter(|&s| n.count > 0 && self.is_live(s))
                .flat_map(|s| triangles[self.faces[s] as usize])
                .collect();
            leaf.sort_unstable();
            leaf.dedup();
            vertices.extend(leaf);
            offsets.push(vertices.len() as u32);
        }
        let needs = vertices.iter().max().map_or(0, |&v| v as usize + 1);
        LeafCorners {
            offsets,
            vertices,
            needs,
        }
    }

    /// Like [`TriangleBvh::refit`] for the node boxes only, each leaf's from its distinct
    /// corners (`corners` from [`TriangleBvh::leaf_corners`] of this tree, the positions
    /// finite): no face's box is written (a sixth of a refit's instructions on the finger's
    /// detection tree), for a tree whose only query is [`TriangleBvh::pairs_between_sets`]
    /// (the self-contact pass's detection, which a frame without contact is made of). A
    /// leaf's box is the corners' box (which also holds the corners of faces collapsed to a
    /// point, whose own boxes are empty), empty when it is a point, so it holds its faces'
    /// boxes and the pairs found are the same. Whether the tree was refit: not when `corners`
    /// were made for a tree of another shape or `positions` miss one of them (the tree is
    /// then left as it was).
    pub fn refit_nodes_at(&mut self, positions: &[Point3<f64>], corners: &LeafCorners) -> bool {
        if corners.offsets.len() != self.nodes.len() + 1 || positions.len() < corners.needs {
            return false;
        }
        for i in (0..self.nodes.len()).rev() {
            let n = self.nodes[i];
            self.nodes[i].aabb = if n.count > 0 {
                let range = corners.offsets[i] as usize..corners.offsets[i + 1] as usize;
                let b = corners.vertices[range]
                    .iter()
                    .fold(Aabb::EMPTY, |b, &v| b.grown(&positions[v as usize]));
                if b.min == b.max {
                    Aabb::EMPTY
                } else {
                    b
                }
            } else {
                let first = n.first as usize;
                self.nodes[first].aabb.union(&self.nodes[first + 1].aabb)
            };
        }
        self.faces_fitted = false;
        true
    }

    /// Whether leaf slot `slot` holds a face of the tree.
    fn is_live(&self, slot: usize) -> bool {
        self.live.as_ref().is_none_or(|l| l[slot])
    }

    /// The box of leaf slot `slot` of leaf `leaf` as stored: its face's when the faces are
    /// fitted, else the leaf's (which holds it).
    #[inline]
    fn stored_box(&self, slot: usize, leaf: &Node) -> Aabb {
        if self.faces_fitted {
            self.face_boxes[slot]
        } else {
            leaf.aabb
        }
    }

    /// Node boxes from the face boxes, bottom up.
    fn refit_nodes(&mut self) {
        for i in (0..self.nodes.len()).rev() {
            let n = self.nodes[i];
            let (first, count) = (n.first as usize, n.count as usize);
            self.nodes[i].aabb = if count > 0 {
                self.face_boxes[first..first + count]
                    .iter()
                    .fold(Aabb::EMPTY, |acc, b| acc.union(b))
            } else {
                self.nodes[first].aabb.union(&self.nodes[first + 1].aabb)
            };
        }
    }

    /// Whether `other` has this tree's nodes (their faces, not their boxes), leaf slots and
    /// live slots: a refit of either gives the other's boxes.
    pub(crate) fn same_shape(&self, other: &TriangleBvh) -> bool {
        self.faces == other.faces
            && self.live == other.live
            && self.nodes.len() == other.nodes.len()
            && (self.nodes.iter().zip(&other.nodes))
                .all(|(a, b)| (a.first, a.count) == (b.first, b.count))
    }

    /// Number of faces in the tree.
    pub fn face_count(&self) -> usize {
        self.live
            .as_ref()
            .map_or(self.faces.len(), |l| l.iter().filter(|&&x| x).count())
    }

    /// Box of the whole tree (`None` when empty).
    pub fn root_box(&self) -> Option<Aabb> {
        self.nodes.first().map(|n| n.aabb).filter(|b| !b.is_empty())
    }

    /// Visits `(face, box)` for every leaf slot whose stored box passes `keep` (the box a ray
    /// cast tests, [`TriangleBvh::farthest_along`]), in tree order, descending only into the
    /// nodes whose box passes: `keep` must pass a box whenever it passes a box inside it (a
    /// conservative overlap test). Masked slots have empty boxes, which an overlap test fails.
    pub(crate) fn slots_where(
        &self,
        keep: impl Fn(&Aabb) -> bool,
        mut visit: impl FnMut(u32, Aabb),
    ) {
        if self.nodes.is_empty() || !keep(&self.nodes[0].aabb) {
            return;
        }
        let mut stack: Vec<u32> = vec![0];
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i as usize];
            if n.count > 0 {
                for slot in n.first as usize..(n.first + n.count) as usize {
                    let b = self.stored_box(slot, n);
                    if keep(&b) {
                        visit(self.faces[slot], b);
                    }
                }
                continue;
            }
            for c in [n.first + 1, n.first] {
                if keep(&self.nodes[c as usize].aabb) {
                    stack.push(c);
                }
            }
        }
    }

    /// Visits the faces whose box the ray `origin + t dir`, `t ∈ [0, max_t]`, may cross, nodes
    /// with the largest exit parameter first. `test(face, [t0, t1])` gets the parameter
    /// interval of the ray inside the face's box and returns the hit parameter clamped to it,
    /// if any. Subtrees whose exit parameter is below the best hit so far are skipped: box exits
    /// only grow from a face to its ancestors (exact min/max, monotone rounding), so the faces
    /// skipped could neither beat nor tie the best, and the result does not depend on the tree.
    pub(crate) fn farthest_along(
        &self,
        origin: &Point3<f64>,
        dir: &Vector3<f64>,
        max_t: f64,
        mut test: impl FnMut(u32, [f64; 2]) -> Option<f64>,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = dir.map(|d| 1.0 / d);
        let reach = |b: &Aabb| ray_reach(b, origin, &inv, max_t);
        let mut best = f64::NEG_INFINITY;
        let mut stack: Vec<(u32, f64)> = Vec::with_capacity(64);
        if let Some([_, t1]) = reach(&self.nodes[0].aabb) {
            stack.push((0, t1));
        }
        while let Some((i, t1)) = stack.pop() {
            if t1 < best {
                continue;
            }
            let n = &self.nodes[i as usize];
            if n.count > 0 {
                for slot in n.first as usize..(n.first + n.count) as usize {
                    let range = reach(&self.stored_box(slot, n)).filter(|r| r[1] >= best);
                    if let Some(t) = range.and_then(|r| test(self.faces[slot], r)) {
                        best = best.max(t);
                    }
                }
                continue;
            }
            let (l, r) = (n.first, n.first + 1);
            let exit = |c: u32| reach(&self.nodes[c as usize].aabb).map(|r| r[1]);
            let (tl, tr) = (exit(l), exit(r));
            // Push the farther-reaching child last so it is popped first.
            let mut kids = [(l, tl), (r, tr)];
            if tl.unwrap_or(f64::NEG_INFINITY) > tr.unwrap_or(f64::NEG_INFINITY) {
                kids.swap(0, 1);
            }
            stack.extend(kids.iter().filter_map(|&(c, t)| t.map(|t| (c, t))));
        }
    }
}

/// The parameter interval of the ray `origin + t dir` (`inv_dir` its componentwise inverse)
/// inside box `b`, clipped to `[0, max_t]`: what [`TriangleBvh::farthest_along`] reaches of a
/// node or a face's box.
#[inline]
pub(crate) fn ray_reach(
    b: &Aabb,
    origin: &Point3<f64>,
    inv_dir: &Vector3<f64>,
    max_t: f64,
) -> Option<[f64; 2]> {
    b.ray_interval(origin, inv_dir)
        .filter(|&(t0, t1)| t1 >= 0.0 && t0 <= max_t)
        .map(|(t0, t1)| [t0.max(0.0), t1.min(max_t)])
}

/// Per leaf node of a [`TriangleBvh`], the distinct corners of its live faces (compressed rows:
/// node `i`'s are `vertices[offsets[i]..offsets[i + 1]]`, none for an internal node).
#[derive(Clone, Debug)]
pub struct LeafCorners {
    offsets: Vec<u32>,
    vertices: Vec<u32>,
    /// One more than the largest vertex: the positions a refit needs.
    needs: usize,
}

#[cfg(test)]
mod tests {
    use super::pairs::pair_budget;
    use super::*;
    use crate::intersect::IntersectError;

    #[test]
    fn faces_collapsed_to_a_point_meet_nothing() {
        // A grid whose every vertex sits at one point (a bone scaled to 0): no pair, where
        // every face's box would otherwise overlap every other's.
        let (pos, tris) = wavy(6, 0.0, 0.0);
        let point = vec![Point3::new(0.3, 0.2, 0.1); pos.len()];
        let faces: Vec<u32> = (0..tris.len() as u32).collect();
        let collapsed = TriangleBvh::build(&point, &tris, &faces);
        assert!(collapsed.candidate_pairs(&collapsed).is_empty());
        assert!(collapsed.root_box().is_none());
        let mut refit = TriangleBvh::build(&pos, &tris, &faces);
        assert!(!refit.candidate_pairs(&refit).is_empty());
        let mut nodes_only = refit.clone();
        refit.refit(&point, &tris);
        assert!(refit.candidate_pairs(&refit).is_empty());
        // Refit at the nodes only, every leaf's corners are one point: empty too.
        assert!(nodes_only.refit_nodes_at(&point, &nodes_only.leaf_corners(&tris)));
        assert!(nodes_only.root_box().is_none());
        assert!(nodes_only.candidate_pairs(&nodes_only).is_empty());
        let label = |f: u32| 1 + (f % 2) as u8;
        for sets in [
            nodes_only.face_sets(label),
            nodes_only.face_sets_on(label, &tris),
        ] {
            let pairs = nodes_only.pairs_between_sets(&sets, &point, &tris, |x, y| Some((x, y)));
            assert_eq!(pairs.ok(), Some(Vec::new()));
        }
    }

    /// A bounded query answers as the unbounded one on surfaces that meet along curves (two
    /// wavy grids crossing), and stops with [`IntersectError::Entangled`] on a crumpled mesh
    /// (a grid whose vertices are scattered through a cube: every face crosses most others).
    #[test]
    fn bounded_queries_stop_on_entangled_surfaces() {
        let (pa, ta) = wavy(12, 0.0, 0.0);
        let (pb, tb) = wavy(12, 0.05, 1.0);
        let all = |t: &[[u32; 3]]| (0..t.len() as u32).collect::<Vec<_>>();
        let a = TriangleBvh::build(&pa, &ta, &all(&ta));
        let b = TriangleBvh::build(&pb, &tb, &all(&tb));
        let visit = |x: u32, y: u32| Some((x, y));
        let unbounded = a.overlapping_pairs(&b, visit);
        assert!(!unbounded.is_empty());
        assert_eq!(a.overlapping_pairs_bounded(&b, visit).ok(), Some(unbounded));
        let mut next = crate::test_support::uniform(12345);
        let crumpled: Vec<Point3<f64>> = pa
            .iter()
            .map(|_| Point3::new(next(), next(), next()))
            .collect();
        let c = TriangleBvh::build(&crumpled, &ta, &all(&ta));
        assert!(c.overlapping_pairs(&c, visit).len() > pair_budget(2 * ta.len()));
        assert!(matches!(
            c.overlapping_pairs_bounded(&c, visit),
            Err(IntersectError::Entangled { budget }) if budget == pair_budget(2 * ta.len())
        ));
        let label = |f: u32| 1 + (f % 2) as u8;
        for sets in [c.face_sets(label), c.face_sets_on(label, &ta)] {
            assert!(matches!(
                c.pairs_between_sets(&sets, &crumpled, &ta, visit),
                Err(IntersectError::Entangled { .. })
            ));
        }
    }

    /// A wavy grid (open surface) of `2 n²` triangles.
    fn wavy(n: usize, z: f64, phase: f64) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let mut pos = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
                pos.push(Point3::new(
                    x,
                    y,
                    z + 0.1 * (7.0 * x + phase).sin() * (5.0 * y).cos(),
                ));
            }
        }
        let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let mut tris = Vec::new();
        for j in 0..n {
            for i in 0..n {
                tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        (pos, tris)
    }

    fn brute(
        a: &(Vec<Point3<f64>>, Vec<[u32; 3]>),
        b: &(Vec<Point3<f64>>, Vec<[u32; 3]>),
    ) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        for (fa, ta) in a.1.iter().enumerate() {
            for (fb, tb) in b.1.iter().enumerate() {
                if face_box(&a.0, ta).overlaps(&face_box(&b.0, tb)) {
                    out.push((fa as u32, fb as u32));
                }
            }
        }
        out
    }

    #[test]
    fn candidate_pairs_match_brute_force_after_build_and_refit() {
        let (a, b) = (wavy(12, 0.0, 0.0), wavy(10, 0.02, 1.0));
        let (fa, fb): (Vec<u32>, Vec<u32>) = (
            (0..a.1.len() as u32).collect(),
            (0..b.1.len() as u32).collect(),
        );
        let mut ta = TriangleBvh::build(&a.0, &a.1, &fa);
        let tb = TriangleBvh::build(&b.0, &b.1, &fb);
        let expected = brute(&a, &b);
        assert!(!expected.is_empty());
        assert_eq!(ta.candidate_pairs(&tb), expected);
        // Deform A (same topology) and refit.
        let moved = wavy(12, 0.01, 2.0);
        ta.refit(&moved.0, &moved.1);
        assert_eq!(ta.candidate_pairs(&tb), brute(&moved, &b));
        let rebuilt = TriangleBvh::build(&moved.0, &moved.1, &fa);
        assert_eq!(rebuilt.candidate_pairs(&tb), brute(&moved, &b));
        assert_eq!(
            ta.overlapping_pairs(&tb, |x, y| Some((x, y))),
            brute(&moved, &b)
        );
    }

    /// Two wavy grids in one mesh (the second's faces after the first's).
    fn two_grids(phase: f64) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let (mut pos, mut tris) = wavy(12, 0.0, phase);
        let (p2, t2) = wavy(10, 0.02, 1.0 + phase);
        let offset = pos.len() as u32;
        pos.extend(p2);
        tris.extend(t2.iter().map(|t| t.map(|v| v + offset)));
        (pos, tris)
    }

    /// The pairs between two face sets of one tree are those of two trees built over each set
    /// (and brute force's), at the build and after a refit; with the sets interleaved in one
    /// grid too, where both sets share every node.
    #[test]
    fn pairs_between_sets_match_two_trees_and_brute_force() {
        let first = wavy(12, 0.0, 0.0).1.len() as u32;
        let labelings: [&dyn Fn(u32) -> u8; 2] = [
            // The first grid against the second, every fifth face in neither set.
            &|f: u32| match (f < first, f % 5 == 0) {
                (_, true) => 0,
                (true, false) => 1,
                (false, false) => 2,
            },
            // Interleaved in strips across both grids.
            &|f: u32| [1, 2, 0][(f / 3 % 3) as usize],
        ];
        let grids = two_grids(0.0);
        let empty = TriangleBvh::build(&grids.0, &grids.1, &[]);
        let sets_of_none = empty.face_sets(|_| 1);
        let none = empty.pairs_between_sets(&sets_of_none, &grids.0, &grids.1, |x, y| Some((x, y)));
        assert_eq!(none.ok(), Some(Vec::new()));
        let mut adjacent_seen = 0;
        for label in labelings {
            let mesh = two_grids(0.0);
            let all: Vec<u32> = (0..mesh.1.len() as u32).collect();
            let set =
                |k: u8| -> Vec<u32> { all.iter().copied().filter(|&f| label(f) == k).collect() };
            let (a, b) = (set(1), set(2));
            let mut tree = TriangleBvh::build(&mesh.0, &mesh.1, &all);
            // From the root, and from where the sets meet on the surface.
            let both = [tree.face_sets(label), tree.face_sets_on(label, &mesh.1)];
            let corners = tree.leaf_corners(&mesh.1);
            let pairs = |t: &TriangleBvh, sets: &FaceSets, p: &[Point3<f64>]| {
                t.pairs_between_sets(sets, p, &mesh.1, |x, y| Some((x, y)))
                    .ok()
            };
            for positions in [mesh.0.clone(), two_grids(1.5).0] {
                // Refit at the nodes only, the pairs are the same; the other queries take
                // each face's box as its leaf's, so they find more pairs, those among them.
                let mut nodes_only = tree.clone();
                assert!(nodes_only.refit_nodes_at(&positions, &corners));
                // Corners of another tree, or positions that miss some: refused.
                let mut kept = nodes_only.clone();
                assert!(!kept.refit_nodes_at(&positions[..10], &corners));
                let other_corners =
                    TriangleBvh::build(&positions, &mesh.1, &a).leaf_corners(&mesh.1);
                assert!(!kept.refit_nodes_at(&positions, &other_corners));
                assert_eq!(kept.root_box(), nodes_only.root_box());
                tree.refit(&positions, &mesh.1);
                let roots = |t: &TriangleBvh| t.root_box().expect("faces");
                assert_eq!(roots(&nodes_only), roots(&tree));
                let expected: Vec<(u32, u32)> = a
                    .iter()
                    .flat_map(|&fa| b.iter().map(move |&fb| (fa, fb)))
                    .filter(|&(fa, fb)| {
                        let bx = |f: u32| face_box(&positions, &mesh.1[f as usize]);
                        bx(fa).overlaps(&bx(fb))
                    })
                    .collect();
                assert!(!expected.is_empty());
                // Without the pairs sharing a vertex: the others, and how many were dropped.
                let tris = &mesh.1;
                let shares = |&&(x, y): &&(u32, u32)| {
                    tris[x as usize]
                        .iter()
                        .any(|v| tris[y as usize].contains(v))
                };
                let (adjacent, separate): (Vec<_>, Vec<_>) = expected.iter().partition(shares);
                let separate: Vec<(u32, u32)> = separate.into_iter().copied().collect();
                let other = TriangleBvh::build(&positions, &mesh.1, &a);
                for sets in &both {
                    let got = pairs(&tree, sets, &positions);
                    assert_eq!(got.as_ref(), Some(&expected));
                    assert_eq!(pairs(&nodes_only, sets, &positions), got);
                    let visit = |x, y| Some((x, y));
                    let apart = tree.apart_pairs_between_sets(sets, &positions, tris, visit);
                    assert_eq!(apart.ok(), Some((separate.clone(), adjacent.len())));
                    let apart = nodes_only.apart_pairs_between_sets(sets, &positions, tris, visit);
                    assert_eq!(apart.ok(), Some((separate.clone(), adjacent.len())));
                    assert!(pairs(&other, sets, &positions).is_none());
                }
                adjacent_seen += adjacent.len();
                let ta = TriangleBvh::build(&positions, &mesh.1, &a);
                let tb = TriangleBvh::build(&positions, &mesh.1, &b);
                assert_eq!(ta.candidate_pairs(&tb), expected);
                let every = tree.candidate_pairs(&tree);
                let coarse = nodes_only.candidate_pairs(&nodes_only);
                assert!(coarse.len() > every.len());
                assert!(every.iter().all(|p| coarse.binary_search(p).is_ok()));
                // A restricted tree: its masked faces are in neither set.
                let half: Vec<u32> = all.iter().copied().filter(|f| f / 4 % 2 == 0).collect();
                let restricted = tree
                    .restricted_at(&half, &positions, &mesh.1)
                    .expect("subset");
                let kept: Vec<(u32, u32)> = expected
                    .iter()
                    .copied()
                    .filter(|(x, y)| x / 4 % 2 == 0 && y / 4 % 2 == 0)
                    .collect();
                assert!(!kept.is_empty() && kept.len() < expected.len());
                for restricted_sets in [
                    restricted.face_sets(label),
                    restricted.face_sets_on(label, &mesh.1),
                ] {
                    let got = pairs(&restricted, &restricted_sets, &positions);
                    assert_eq!(got.as_ref(), Some(&kept));
                }
            }
        }
        assert!(adjacent_seen > 0, "the strips share vertices");
    }

    /// Where two sets meet: leaf pairs sharing a vertex and roots sharing none, which together
    /// hold every pair of leaves with a face of each set once (a query from them finds the
    /// pairs a query from the root finds: `pairs_between_sets_match_two_trees_and_brute_force`).
    #[test]
    fn the_meeting_of_two_sets_covers_their_leaf_pairs_once() {
        let (pos, tris) = two_grids(0.0);
        let all: Vec<u32> = (0..tris.len() as u32).collect();
        let tree = TriangleBvh::build(&pos, &tris, &all);
        let sets = tree.face_sets_on(|f| [1, 2, 0][(f / 3 % 3) as usize], &tris);
        let meeting = &sets.meeting;
        assert!(!meeting.leaves.is_empty() && !meeting.roots.is_empty());
        // The corners of the faces under each node.
        let mut under: Vec<Vec<u32>> = vec![Vec::new(); tree.nodes.len()];
        let mut parent = vec![None; tree.nodes.len()];
        for (i, n) in tree.nodes.iter().enumerate().rev() {
            under[i] = match n.count {
                0 => {
                    let first = n.first as usize;
                    parent[first] = Some(i);
                    parent[first + 1] = Some(i);
                    [under[first].clone(), under[first + 1].clone()].concat()
                }
                _ => (n.first..n.first + n.count)
                    .flat_map(|s| tris[tree.faces[s as usize] as usize])
                    .collect(),
            };
        }
        let share = |a: u32, b: u32| {
            under[a as usize]
                .iter()
                .any(|v| under[b as usize].contains(v))
        };
        assert!(meeting.leaves.iter().all(|&(a, b)| share(a, b)));
        assert!(meeting.roots.iter().all(|&(a, b)| !share(a, b)));
        // Node `i` and its ancestors.
        let line = |i: u32| std::iter::successors(Some(i as usize), |&n| parent[n]);
        let leaves = (0..tree.nodes.len() as u32).filter(|&i| tree.nodes[i as usize].count > 0);
        let mut checked = 0;
        for la in leaves.clone() {
            for lb in leaves.clone().filter(|&lb| sets.may_pair(la, lb)) {
                let met = meeting.leaves.iter().filter(|&&p| p == (la, lb)).count();
                let rooted = (meeting.roots.iter())
                    .filter(|&&(a, _)| line(la).any(|n| n == a as usize))
                    .filter(|&&(_, b)| line(lb).any(|n| n == b as usize))
                    .count();
                assert_eq!(met + rooted, 1, "leaves {la} and {lb}");
                checked += 1;
            }
        }
        assert!(checked > meeting.leaves.len());
    }

    /// Every face hit by the vertical ray through `(x, y)`, at its parameter (brute force).
    fn hits_brute(
        m: &(Vec<Point3<f64>>, Vec<[u32; 3]>),
        faces: &[u32],
        x: f64,
        y: f64,
    ) -> Option<f64> {
        let o = Point3::new(x, y, -1.0);
        faces
            .iter()
            .filter_map(|&f| {
                let [a, b, c] = m.1[f as usize].map(|v| m.0[v as usize]);
                let d = |p: Point3<f64>, q: Point3<f64>| {
                    (q.x - p.x) * (y - p.y) - (q.y - p.y) * (x - p.x)
                };
                let (u, v, w) = (d(a, b), d(b, c), d(c, a));
                let inside =
                    (u >= 0.0 && v >= 0.0 && w >= 0.0) || (u <= 0.0 && v <= 0.0 && w <= 0.0);
                let n = (b - a).cross(&(c - a));
                (inside && n.z != 0.0).then(|| (a - o).dot(&n) / n.z)
            })
            .reduce(f64::max)
    }

    /// A tree restricted to a subset of its faces answers every query as a tree built over the
    /// subset (and as brute force), after a refit to new positions too.
    #[test]
    fn restricted_tree_matches_a_tree_built_over_the_subset() {
        let (a, b) = (wavy(12, 0.0, 0.0), wavy(10, 0.02, 1.0));
        let all: Vec<u32> = (0..a.1.len() as u32).collect();
        let half: Vec<u32> = all.iter().copied().filter(|f| (f / 7) % 2 == 0).collect();
        let tb = TriangleBvh::build(&b.0, &b.1, &(0..b.1.len() as u32).collect::<Vec<_>>());
        let mut restricted = TriangleBvh::build(&a.0, &a.1, &all)
            .restricted_at(&half, &a.0, &a.1)
            .expect("subset");
        assert_eq!(restricted.face_count(), half.len());
        let moved = wavy(12, 0.01, 2.0);
        restricted.refit(&moved.0, &moved.1);
        let built = TriangleBvh::build(&moved.0, &moved.1, &half);
        let expected: Vec<(u32, u32)> = brute(&moved, &b)
            .into_iter()
            .filter(|(f, _)| half.binary_search(f).is_ok())
            .collect();
        assert!(!expected.is_empty() && expected.len() < brute(&moved, &b).len());
        assert_eq!(restricted.candidate_pairs(&tb), expected);
        assert_eq!(built.candidate_pairs(&tb), expected);
        let mut rays = 0;
        for k in 0..40 {
            let (x, y) = (0.013 + 0.024 * k as f64, 0.5 + 0.011 * k as f64);
            let farthest = |t: &TriangleBvh| {
                let mut best = None::<f64>;
                t.farthest_along(
                    &Point3::new(x, y, -1.0),
                    &Vector3::z(),
                    3.0,
                    |f, [t0, t1]| {
                        let hit = hits_brute(&moved, &[f], x, y).filter(|h| *h >= t0 && *h <= t1);
                        if let Some(h) = hit {
                            best = Some(best.map_or(h, |b: f64| b.max(h)));
                        }
                        hit
                    },
                );
                best
            };
            let want = hits_brute(&moved, &half, x, y);
            rays += usize::from(want.is_some());
            assert_eq!(farthest(&restricted), want, "ray {k}");
            assert_eq!(farthest(&built), want, "ray {k}");
        }
        assert!(rays > 10, "rays hitting the subset: {rays}");
        // A face outside the tree cannot be restricted to.
        let small = TriangleBvh::build(&a.0, &a.1, &half);
        assert!(small.restricted_at(&all, &a.0, &a.1).is_none());
        // Nor an id beyond every face (no mark array that large is made).
        assert!(small.restricted_at(&[u32::MAX], &a.0, &a.1).is_none());
    }

    #[test]
    fn ray_interval_is_conservative_on_touching_boxes() {
        let b = Aabb {
            min: Point3::new(0.0, 0.0, 0.0),
            max: Point3::new(1.0, 1.0, 1.0),
        };
        let inv = Vector3::new(1.0, 0.0, 0.0).map(|d| 1.0 / d);
        // Along the face y = 1 of the box.
        assert!(b.ray_interval(&Point3::new(-1.0, 1.0, 0.5), &inv).is_some());
        assert!(b
            .ray_interval(&Point3::new(-1.0, 1.0 + 1e-12, 0.5), &inv)
            .is_none());
    }
}
