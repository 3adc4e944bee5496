//! Pair queries between two trees (or a tree and itself): the face pairs whose boxes overlap,
//! within a budget, optionally between labelled sets of faces or among faces apart.

use super::{face_box, Aabb, Node, TriangleBvh, MAX_LEAF};
use crate::intersect::IntersectError;
use nalgebra::Point3;
use rayon::prelude::*;

/// Candidate pairs from which their visits run in parallel (a rayon call costs tens of
/// microseconds on a busy machine, a pair test a fraction of one).
const PARALLEL_PAIRS: usize = 2048;

/// Candidate face pairs a bounded query ([`TriangleBvh::overlapping_pairs_bounded`],
/// [`TriangleBvh::pairs_between_sets`]) collects at most, per face of its two trees (and at
/// least [`MIN_PAIR_BUDGET`]). Two surfaces meeting along curves give each face a few
/// candidates near the curves and none elsewhere: at most 1.06 pairs per face in every
/// query of the committed rigs, CesiumMan and Fox with LBS, DQS and CoR input (2026-12-05).
/// Broken rigs found by fuzzing (a joint collapsed onto a line, positions read as bytes, every
/// triangle listed twice, the joints permuted, projective node matrices) reach 8.5 to 132 and
/// took 10 s to minutes per frame in the self-contact pass; past the budget the query stops.
pub const PAIRS_PER_FACE: usize = 8;

/// The smallest budget of a bounded query, whatever its trees' sizes.
pub const MIN_PAIR_BUDGET: usize = 4096;

/// Set A's bit in [`FaceSets`].
const SET_A: u8 = 1;

/// Set B's bit in [`FaceSets`].
const SET_B: u8 = 2;

impl TriangleBvh {
    /// All face pairs `(face of self, face of other)` whose boxes overlap, sorted.
    pub fn candidate_pairs(&self, other: &TriangleBvh) -> Vec<(u32, u32)> {
        let mut pairs = self.pairs_in_tree_order(other, usize::MAX);
        pairs.sort_unstable();
        pairs
    }

    /// The candidate pairs mapped through `visit` (which may drop a pair), sorted by pair. The
    /// visits run in parallel when there are many; the output does not depend on the tree nor
    /// on the number of threads.
    pub fn overlapping_pairs<R, F>(&self, other: &TriangleBvh, visit: F) -> Vec<R>
    where
        R: Send,
        F: Fn(u32, u32) -> Option<R> + Sync,
    {
        visit_sorted(&self.pairs_in_tree_order(other, usize::MAX), visit)
    }

    /// [`TriangleBvh::overlapping_pairs`], or [`IntersectError::Entangled`] as soon as the
    /// candidates outnumber [`PAIRS_PER_FACE`] per face of both trees, times the ratio of the
    /// larger tree's faces to the smaller's (rounded up): each long face of a coarse surface
    /// (a low-poly prop in a finely tessellated hand) has a box over many faces of the other,
    /// and such a pair is a contact (`bounded_queries_allow_coarse_against_fine`: a 16-triangle
    /// tube through a 20480-face sphere, more than 8 candidates per face); the trees of one
    /// mesh's parts, as large as each other, keep the plain budget.
    pub fn overlapping_pairs_bounded<R, F>(
        &self,
        other: &TriangleBvh,
        visit: F,
    ) -> Result<Vec<R>, IntersectError>
    where
        R: Send,
        F: Fn(u32, u32) -> Option<R> + Sync,
    {
        let (a, b) = (self.faces.len(), other.faces.len());
        let ratio = a.max(b).div_ceil(a.min(b).max(1));
        let budget = pair_budget(a + b).saturating_mul(ratio);
        let pairs = self.pairs_in_tree_order(other, budget);
        entangled(&pairs, budget)?;
        Ok(visit_sorted(&pairs, visit))
    }

    /// Marks which faces of the tree belong to set A (`label(face) == 1`) and to set B
    /// (`== 2`), for [`TriangleBvh::pairs_between_sets`]. Pose-independent: compute once.
    pub fn face_sets(&self, label: impl Fn(u32) -> u8) -> FaceSets {
        let slot_bits: Vec<u8> = self
            .faces
            .iter()
            .enumerate()
            .map(|(slot, &f)| match label(f) {
                _ if self.live.as_ref().is_some_and(|l| !l[slot]) => 0,
                1 => SET_A,
                2 => SET_B,
                _ => 0,
            })
            .collect();
        let mut node_bits = vec![0u8; self.nodes.len()];
        for i in (0..self.nodes.len()).rev() {
            let n = self.nodes[i];
            let (first, count) = (n.first as usize, n.count as usize);
            node_bits[i] = if count > 0 {
                slot_bits[first..first + count].iter().fold(0, |a, b| a | b)
            } else {
                node_bits[first] | node_bits[first + 1]
            };
        }
        FaceSets {
            node_bits,
            slot_bits,
        }
    }

    /// [`TriangleBvh::overlapping_pairs`] between two disjoint sets of this tree's faces: the
    /// pairs `(face of A, face of B)` whose boxes overlap, mapped through `visit`, sorted by
    /// pair. The same pairs as between two trees built over each set (node boxes here also
    /// cover faces of neither set, which only costs box tests), with one refit for both sets;
    /// one tree over a body serves every joint's two sides (2021 Sec. 6 detection).
    /// [`IntersectError::FaceSetsMismatch`] when `sets` was not made by
    /// [`TriangleBvh::face_sets`] on a tree of this shape; bounded as
    /// [`TriangleBvh::overlapping_pairs_bounded`] (the tree's faces counted twice).
    /// The faces' boxes are made from `positions` (those of the last refit; `triangles` the
    /// mesh's), so that the tree may be refit at its nodes only
    /// ([`TriangleBvh::refit_nodes_at`]).
    pub fn pairs_between_sets<R, F>(
        &self,
        sets: &FaceSets,
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        visit: F,
    ) -> Result<Vec<R>, IntersectError>
    where
        R: Send,
        F: Fn(u32, u32) -> Option<R> + Sync,
    {
        let found = self.between_sets_where(sets, sets, (positions, triangles), visit)?;
        Ok(found.0)
    }

    /// [`TriangleBvh::pairs_between_sets`] without the face pairs sharing a vertex of
    /// `triangles`, which are counted instead (against the budget as well): the visited pairs'
    /// results and that count.
    pub fn apart_pairs_between_sets<R, F>(
        &self,
        sets: &FaceSets,
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        visit: F,
    ) -> Result<(Vec<R>, usize), IntersectError>
    where
        R: Send,
        F: Fn(u32, u32) -> Option<R> + Sync,
    {
        let apart = ApartSets {
            sets,
            triangles,
            adjacent: std::cell::Cell::new(0),
        };
        self.between_sets_where(sets, &apart, (positions, triangles), visit)
    }

    /// The pairs between `sets` that `filter` (over those sets) keeps, visited, and how many
    /// overlapping pairs it dropped ([`PairFilter::dropped`]).
    fn between_sets_where<R, F>(
        &self,
        sets: &FaceSets,
        filter: &impl PairFilter,
        (positions, triangles): (&[Point3<f64>], &[[u32; 3]]),
        visit: F,
    ) -> Result<(Vec<R>, usize), IntersectError>
    where
        R: Send,
        F: Fn(u32, u32) -> Option<R> + Sync,
    {
        let fits =
            sets.node_bits.len() == self.nodes.len() && sets.slot_bits.len() == self.faces.len();
        if !fits {
            return Err(IntersectError::FaceSetsMismatch);
        }
        let slot_box =
            |slot: usize, _: &Node| face_box(positions, &triangles[self.faces[slot] as usize]);
        let budget = pair_budget(2 * self.faces.len());
        let pairs = self.pairs_where(self, filter, (slot_box, slot_box), budget);
        let dropped = filter.dropped();
        if pairs.len() + dropped > budget {
            return Err(IntersectError::Entangled { budget });
        }
        Ok((visit_sorted(&pairs, visit), dropped))
    }

    /// The candidate pairs with `other` in tree order, more than `budget` of them only when the
    /// traversal stopped there.
    fn pairs_in_tree_order(&self, other: &TriangleBvh, budget: usize) -> Vec<(u32, u32)> {
        let (mine, theirs) = (
            |slot: usize, leaf: &Node| self.stored_box(slot, leaf),
            |slot: usize, leaf: &Node| other.stored_box(slot, leaf),
        );
        self.pairs_where(other, &EveryFace, (mine, theirs), budget)
    }

    /// The face pairs `(face of self, face of other)` whose leaf slots `filter` admits and whose
    /// boxes overlap, in tree order: node pairs with overlapping boxes split depth first (internal
    /// nodes split, both at once when both are internal), pruned by `filter`'s node test.
    /// The leaf slots' boxes are `box_a(slot, leaf)` in this tree and `box_b` in `other`. The
    /// traversal stops once it holds more than `budget` pairs.
    fn pairs_where<A, B>(
        &self,
        other: &TriangleBvh,
        filter: &impl PairFilter,
        (box_a, box_b): (A, B),
        budget: usize,
    ) -> Vec<(u32, u32)>
    where
        A: Fn(usize, &Node) -> Aabb,
        B: Fn(usize, &Node) -> Aabb,
    {
        let mut pairs = Vec::new();
        let mut stack = Vec::with_capacity(64);
        let push = |stack: &mut Vec<(u32, u32)>, a: u32, b: u32| {
            if filter.nodes(a, b)
                && self.nodes[a as usize]
                    .aabb
                    .overlaps(&other.nodes[b as usize].aabb)
            {
                stack.push((a, b));
            }
        };
        if !self.nodes.is_empty() && !other.nodes.is_empty() {
            push(&mut stack, 0, 0);
        }
        while let Some((a, b)) = stack.pop() {
            let (na, nb) = (&self.nodes[a as usize], &other.nodes[b as usize]);
            match (na.count > 0, nb.count > 0) {
                (true, true) => {
                    let leaves = LeafPair {
                        other,
                        na,
                        nb,
                        box_a: &box_a,
                        box_b: &box_b,
                    };
                    self.leaf_pairs(leaves, filter, &mut pairs);
                    if pairs.len() + filter.dropped() > budget {
                        break;
                    }
                }
                (false, true) => {
                    push(&mut stack, na.first, b);
                    push(&mut stack, na.first + 1, b);
                }
                (true, false) => {
                    push(&mut stack, a, nb.first);
                    push(&mut stack, a, nb.first + 1);
                }
                (false, false) => {
                    for ca in [na.first, na.first + 1] {
                        for cb in [nb.first, nb.first + 1] {
                            push(&mut stack, ca, cb);
                        }
                    }
                }
            }
        }
        pairs
    }

    fn leaf_pairs<A, B>(
        &self,
        leaves: LeafPair<'_, A, B>,
        filter: &impl PairFilter,
        out: &mut Vec<(u32, u32)>,
    ) where
        A: Fn(usize, &Node) -> Aabb,
        B: Fn(usize, &Node) -> Aabb,
    {
        let LeafPair {
            other,
            na,
            nb,
            box_a,
            box_b,
        } = leaves;
        let ra = na.first as usize..(na.first + na.count) as usize;
        let rb = nb.first as usize..(nb.first + nb.count) as usize;
        // The second leaf's boxes once (at most MAX_LEAF), not once per face of the first.
        let mut boxes_b = [Aabb::EMPTY; MAX_LEAF];
        for (b, j) in boxes_b.iter_mut().zip(rb.clone()) {
            if filter.second_slot(j) {
                *b = box_b(j, nb);
            }
        }
        for i in ra.filter(|&i| filter.first_slot(i)) {
            let bi = box_a(i, na);
            if !bi.overlaps(&nb.aabb) {
                continue;
            }
            for (j, bj) in rb.clone().zip(&boxes_b) {
                let (fa, fb) = (self.faces[i], other.faces[j]);
                if filter.second_slot(j) && bi.overlaps(bj) && filter.faces(fa, fb) {
                    out.push((fa, fb));
                }
            }
        }
    }
}

/// Two leaves, of this tree and of `other`, and how each gets a slot's box
/// ([`TriangleBvh::pairs_where`]).
struct LeafPair<'t, A, B> {
    other: &'t TriangleBvh,
    na: &'t Node,
    nb: &'t Node,
    box_a: &'t A,
    box_b: &'t B,
}

/// The budget of a bounded query over trees of `faces` faces in all ([`PAIRS_PER_FACE`]).
pub(super) fn pair_budget(faces: usize) -> usize {
    faces.saturating_mul(PAIRS_PER_FACE).max(MIN_PAIR_BUDGET)
}

/// [`IntersectError::Entangled`] when a bounded query stopped past its `budget`.
fn entangled(pairs: &[(u32, u32)], budget: usize) -> Result<(), IntersectError> {
    if pairs.len() > budget {
        return Err(IntersectError::Entangled { budget });
    }
    Ok(())
}

/// Two disjoint sets of a tree's faces, marked on its leaf slots and nodes (which sets a
/// node's subtree holds): [`TriangleBvh::face_sets`], [`TriangleBvh::pairs_between_sets`].
#[derive(Clone, Debug)]
pub struct FaceSets {
    node_bits: Vec<u8>,
    slot_bits: Vec<u8>,
}

/// Which node pairs and leaf slots a pair query visits (on top of the box tests).
trait PairFilter {
    /// Whether node `a` of the first tree and node `b` of the second may hold a pair.
    fn nodes(&self, a: u32, b: u32) -> bool;
    /// Whether leaf slot `i` of the first tree takes part.
    fn first_slot(&self, i: usize) -> bool;
    /// Whether leaf slot `j` of the second tree takes part.
    fn second_slot(&self, j: usize) -> bool;
    /// Whether two faces whose boxes overlap make a pair (all by default).
    fn faces(&self, _a: u32, _b: u32) -> bool {
        true
    }
    /// The overlapping pairs [`PairFilter::faces`] dropped so far (counted against the
    /// query's budget as pairs).
    fn dropped(&self) -> usize {
        0
    }
}

/// [`FaceSets`] without the face pairs that share a vertex of `triangles`: the self-contact
/// detection never tests those (2021 Sec. 6, [`crate::intersect::Intersections::between_sets`]),
/// and dropping them in the traversal spares gathering them (about 320 of a finger fold's 340
/// candidates in a frame without contact, the two sides' seam).
struct ApartSets<'s> {
    sets: &'s FaceSets,
    triangles: &'s [[u32; 3]],
    adjacent: std::cell::Cell<usize>,
}

impl PairFilter for ApartSets<'_> {
    fn nodes(&self, a: u32, b: u32) -> bool {
        self.sets.nodes(a, b)
    }
    fn first_slot(&self, i: usize) -> bool {
        self.sets.first_slot(i)
    }
    fn second_slot(&self, j: usize) -> bool {
        self.sets.second_slot(j)
    }
    fn faces(&self, a: u32, b: u32) -> bool {
        let (ta, tb) = (self.triangles[a as usize], self.triangles[b as usize]);
        let shared = ta.iter().any(|v| tb.contains(v));
        self.adjacent.set(self.adjacent.get() + usize::from(shared));
        !shared
    }
    fn dropped(&self) -> usize {
        self.adjacent.get()
    }
}

/// Every face of two trees.
struct EveryFace;

impl PairFilter for EveryFace {
    fn nodes(&self, _: u32, _: u32) -> bool {
        true
    }
    fn first_slot(&self, _: usize) -> bool {
        true
    }
    fn second_slot(&self, _: usize) -> bool {
        true
    }
}

/// Set A's faces in the first place, set B's in the second, of one tree.
impl PairFilter for FaceSets {
    fn nodes(&self, a: u32, b: u32) -> bool {
        self.node_bits[a as usize] & SET_A != 0 && self.node_bits[b as usize] & SET_B != 0
    }
    fn first_slot(&self, i: usize) -> bool {
        self.slot_bits[i] == SET_A
    }
    fn second_slot(&self, j: usize) -> bool {
        self.slot_bits[j] == SET_B
    }
}

/// `pairs` mapped through `visit` (which may drop a pair), sorted by pair; in parallel when
/// there are many, the output independent of the order of `pairs` and of the thread count.
fn visit_sorted<R, F>(pairs: &[(u32, u32)], visit: F) -> Vec<R>
where
    R: Send,
    F: Fn(u32, u32) -> Option<R> + Sync,
{
    let keep = |&(a, b): &(u32, u32)| visit(a, b).map(|r| (a, b, r));
    let mut out: Vec<(u32, u32, R)> = if pairs.len() < PARALLEL_PAIRS {
        pairs.iter().filter_map(keep).collect()
    } else {
        pairs
            .par_iter()
            .with_min_len(PARALLEL_PAIRS / 4)
            .filter_map(keep)
            .collect()
    };
    out.sort_unstable_by_key(|&(a, b, _)| (a, b));
    out.into_iter().map(|(_, _, r)| r).collect()
}
