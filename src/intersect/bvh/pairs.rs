//! Pair queries between two trees (or a tree and itself): the face pairs whose boxes overlap,
//! within a budget, optionally between labelled sets of faces or among faces apart.

use super::meeting::Meeting;
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
        let mut sets = FaceSets {
            node_bits,
            slot_bits,
            meeting: Meeting::default(),
        };
        if !self.nodes.is_empty() && sets.may_pair(0, 0) {
            sets.meeting.roots.push((0, 0));
        }
        sets
    }

    /// [`TriangleBvh::face_sets`], with where the two sets meet along the surface `triangles`
    /// (those the tree was built over) found once: the queries between them find the same
    /// pairs without testing the boxes of the node pairs whose faces share a vertex (which
    /// overlap at any positions), most of those a query from the root tests where two sides of
    /// a joint meet along a seam.
    pub fn face_sets_on(&self, label: impl Fn(u32) -> u8, triangles: &[[u32; 3]]) -> FaceSets {
        let mut sets = self.face_sets(label);
        sets.meeting = self.meeting(&sets, triangles);
        sets
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
        let boxes = FaceBoxes {
            positions,
            triangles,
        };
        let budget = pair_budget(2 * self.faces.len());
        let pairs = self.pairs_where(self, filter, &boxes, &sets.meeting, budget);
        let dropped = filter.dropped();
        if pairs.len() + dropped > budget {
            return Err(IntersectError::Entangled { budget });
        }
        Ok((visit_sorted(&pairs, visit), dropped))
    }

    /// The candidate pairs with `other` in tree order, more than `budget` of them only when the
    /// traversal stopped there.
    fn pairs_in_tree_order(&self, other: &TriangleBvh, budget: usize) -> Vec<(u32, u32)> {
        let roots = if self.nodes.is_empty() || other.nodes.is_empty() {
            Vec::new()
        } else {
            vec![(0, 0)]
        };
        let whole = Meeting {
            leaves: Vec::new(),
            roots,
        };
        self.pairs_where(other, &EveryFace, &StoredBoxes, &whole, budget)
    }

    /// The face pairs `(face of self, face of other)` whose leaf slots `filter` admits and whose
    /// boxes overlap: those of the leaf pairs of `start` ([`Meeting::leaves`], not tested), then
    /// those under each of its roots, node pairs with overlapping boxes split depth first
    /// (internal nodes split, both at once when both are internal) and pruned by `filter`'s
    /// node test (which `start`'s pairs pass). The leaf slots' boxes are read from `boxes`. The
    /// query stops once it holds more than `budget` pairs.
    fn pairs_where(
        &self,
        other: &TriangleBvh,
        filter: &impl PairFilter,
        boxes: &impl SlotBoxes,
        start: &Meeting,
        budget: usize,
    ) -> Vec<(u32, u32)> {
        let mut pairs = Vec::new();
        let (mut recent_a, mut recent_b) = (RecentLeaves::new(), RecentLeaves::new());
        // The pairs of two leaves; whether the query is past its budget.
        let mut leaf_pairs = |a: u32, b: u32, pairs: &mut Vec<(u32, u32)>| {
            let leaves = LeafPair {
                other,
                na: &self.nodes[a as usize],
                nb: &other.nodes[b as usize],
                slots_a: recent_a.slots((self, a), |i| filter.first_slot(i), boxes),
                slots_b: recent_b.slots((other, b), |j| filter.second_slot(j), boxes),
            };
            self.leaf_pairs(leaves, filter, pairs);
            pairs.len() + filter.dropped() > budget
        };
        for &(a, b) in &start.leaves {
            if leaf_pairs(a, b, &mut pairs) {
                return pairs;
            }
        }
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
        // The roots' filter was passed when they were found.
        let overlap = |&(a, b): &(u32, u32)| {
            let (ba, bb) = (&self.nodes[a as usize].aabb, &other.nodes[b as usize].aabb);
            ba.overlaps(bb)
        };
        stack.extend(start.roots.iter().filter(|r| overlap(r)));
        while let Some((a, b)) = stack.pop() {
            let (na, nb) = (&self.nodes[a as usize], &other.nodes[b as usize]);
            match (na.count > 0, nb.count > 0) {
                (true, true) => {
                    if leaf_pairs(a, b, &mut pairs) {
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

    /// The pairs of two leaves: each face of the first taking part whose box overlaps the
    /// second leaf's, with each face of the second taking part whose box overlaps its own.
    fn leaf_pairs(
        &self,
        leaves: LeafPair<'_>,
        filter: &impl PairFilter,
        out: &mut Vec<(u32, u32)>,
    ) {
        let LeafPair {
            other,
            na,
            nb,
            slots_a,
            slots_b,
        } = leaves;
        for i in slots_a.taking() {
            let bi = &slots_a.boxes[i];
            if !bi.overlaps(&nb.aabb) {
                continue;
            }
            let fa = self.faces[na.first as usize + i];
            for j in slots_b.taking() {
                let fb = other.faces[nb.first as usize + j];
                if bi.overlaps(&slots_b.boxes[j]) && filter.faces(fa, fb) {
                    out.push((fa, fb));
                }
            }
        }
    }
}

/// The slots of one leaf taking part in one side of a pair query, with their boxes.
#[derive(Clone, Copy)]
struct LeafSlots {
    /// Bit `k`: the leaf's slot `k` takes part (a leaf holds at most 32).
    taking: u32,
    /// The box of each slot taking part, in slot order (the others' left as they were).
    boxes: [Aabb; MAX_LEAF],
}

impl LeafSlots {
    /// The slots taking part, first to last (relative to the leaf's first slot).
    #[inline]
    fn taking(&self) -> impl Iterator<Item = usize> {
        let mut bits = self.taking;
        std::iter::from_fn(move || {
            let k = bits.trailing_zeros() as usize;
            bits &= bits.wrapping_sub(1);
            (k < MAX_LEAF).then_some(k)
        })
    }
}

const _: () = assert!(MAX_LEAF <= u32::BITS as usize);

/// Leaves whose slots one side of a pair query keeps: a depth-first traversal meets a leaf in
/// several leaf pairs close together, and a box made from positions costs a gather of its
/// corners. The finger's five folds (a frame without contact) met 120 distinct leaves in 168
/// leaf pairs, in depth-first order: the boxes of 336 leaves were made before, of 121 with 8
/// leaves kept per side (136 with 4, 167 with 2).
const RECENT_LEAVES: usize = 8;

/// The last [`RECENT_LEAVES`] leaves one side of a pair query met, with their slots (the
/// oldest replaced first).
struct RecentLeaves {
    leaves: [u32; RECENT_LEAVES],
    slots: [LeafSlots; RECENT_LEAVES],
    next: usize,
}

impl RecentLeaves {
    fn new() -> Self {
        let none = LeafSlots {
            taking: 0,
            boxes: [Aabb::EMPTY; MAX_LEAF],
        };
        Self {
            leaves: [u32::MAX; RECENT_LEAVES],
            slots: [none; RECENT_LEAVES],
            next: 0,
        }
    }

    /// The slots of leaf node `index` of `tree`: those kept, else those that `take_part`, each
    /// with its box from `boxes`.
    #[inline]
    fn slots(
        &mut self,
        (tree, index): (&TriangleBvh, u32),
        takes_part: impl Fn(usize) -> bool,
        boxes: &impl SlotBoxes,
    ) -> &LeafSlots {
        match self.leaves.iter().position(|&l| l == index) {
            Some(k) => &self.slots[k],
            None => self.keep((tree, index), takes_part, boxes),
        }
    }

    /// [`RecentLeaves::slots`] of a leaf not kept, in place of the oldest.
    fn keep(
        &mut self,
        (tree, index): (&TriangleBvh, u32),
        takes_part: impl Fn(usize) -> bool,
        boxes: &impl SlotBoxes,
    ) -> &LeafSlots {
        let k = self.next;
        self.next = (k + 1) % RECENT_LEAVES;
        self.leaves[k] = index;
        let kept = &mut self.slots[k];
        kept.taking = 0;
        let leaf = &tree.nodes[index as usize];
        for (bit, slot) in (leaf.first as usize..(leaf.first + leaf.count) as usize).enumerate() {
            if takes_part(slot) {
                kept.taking |= 1 << bit;
                kept.boxes[bit] = boxes.slot_box(tree, slot, leaf);
            }
        }
        kept
    }
}

/// How a pair query reads the box of a leaf slot of a tree.
trait SlotBoxes {
    /// The box of slot `slot` of leaf `leaf` of `tree`.
    fn slot_box(&self, tree: &TriangleBvh, slot: usize, leaf: &Node) -> Aabb;
}

/// The boxes a tree stores ([`TriangleBvh::stored_box`]).
struct StoredBoxes;

impl SlotBoxes for StoredBoxes {
    #[inline(always)]
    fn slot_box(&self, tree: &TriangleBvh, slot: usize, leaf: &Node) -> Aabb {
        tree.stored_box(slot, leaf)
    }
}

/// The boxes of the faces at `positions` (a tree refit at its nodes only stores none). Made in
/// line: a box returned by a call went through memory, and its reads waited for its writes (a
/// load spanning two stores is not forwarded).
struct FaceBoxes<'m> {
    positions: &'m [Point3<f64>],
    triangles: &'m [[u32; 3]],
}

impl SlotBoxes for FaceBoxes<'_> {
    #[inline(always)]
    fn slot_box(&self, tree: &TriangleBvh, slot: usize, _: &Node) -> Aabb {
        face_box(self.positions, &self.triangles[tree.faces[slot] as usize])
    }
}

/// Two leaves, of this tree and of `other`, with their slots taking part
/// ([`TriangleBvh::pairs_where`]).
struct LeafPair<'t> {
    other: &'t TriangleBvh,
    na: &'t Node,
    nb: &'t Node,
    slots_a: &'t LeafSlots,
    slots_b: &'t LeafSlots,
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
    /// Where the queries between the sets start (from the root, unless made on the surface:
    /// [`TriangleBvh::face_sets_on`]), every pair holding a face of each set.
    pub(super) meeting: Meeting,
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

impl FaceSets {
    /// Whether node `a` holds a face of set A and node `b` one of set B.
    pub(super) fn may_pair(&self, a: u32, b: u32) -> bool {
        PairFilter::nodes(self, a, b)
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
