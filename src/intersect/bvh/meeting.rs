//! Where two face sets of a tree meet along its surface ([`Meeting`]), found once for the pair
//! queries between them ([`TriangleBvh::face_sets_on`]).

use super::{FaceSets, Node, TriangleBvh};
use std::ops::Range;

/// Where a pair query between two face sets of a tree starts. Two nodes whose faces share a
/// vertex have boxes that overlap at any positions (both hold the vertex), and the two sides of
/// a fold meet along a seam: in a frame without contact, 1080 of the 1104 node pairs the
/// finger's five folds visited from the root shared a vertex, and the branches on their box
/// tests were most of the query's time. They are found once, from the tree's shape and faces:
/// the pairs of leaves among them, visited without a box test, and the node pairs just past
/// them (sharing no vertex, their parents do), each the root of a traversal pruned by boxes.
/// Every pair of leaves the traversal from the root splits into lies under exactly one of
/// these, so the same face pairs are found at any positions (a box test passed over only costs
/// work: the faces' boxes decide).
#[derive(Clone, Debug, Default)]
pub(super) struct Meeting {
    /// Leaf pairs sharing a vertex, in depth-first order (as a traversal meets them).
    pub(super) leaves: Vec<(u32, u32)>,
    /// Node pairs sharing no vertex whose parents do, or the root pair when it shares none.
    pub(super) roots: Vec<(u32, u32)>,
}

impl TriangleBvh {
    /// Where `sets` (made on this tree) meet on the surface `triangles` ([`Meeting`]): the node
    /// pairs holding a face of set A and one of set B, split as a pair query splits them.
    pub(super) fn meeting(&self, sets: &FaceSets, triangles: &[[u32; 3]]) -> Meeting {
        let (mut leaves, mut roots) = (Vec::new(), Vec::new());
        if self.nodes.is_empty() || !sets.may_pair(0, 0) {
            return Meeting { leaves, roots };
        }
        let corners = self.subtree_corners(triangles);
        let share = |(a, b): (u32, u32)| share_one(&corners[a as usize], &corners[b as usize]);
        let mut stack = Vec::new();
        match share((0, 0)) {
            true => stack.push((0, 0)),
            false => roots.push((0, 0)),
        }
        while let Some((a, b)) = stack.pop() {
            let (na, nb) = (&self.nodes[a as usize], &self.nodes[b as usize]);
            if na.count > 0 && nb.count > 0 {
                leaves.push((a, b));
                continue;
            }
            for ca in split(na, a) {
                for cb in split(nb, b).filter(|&cb| sets.may_pair(ca, cb)) {
                    match share((ca, cb)) {
                        true => stack.push((ca, cb)),
                        false => roots.push((ca, cb)),
                    }
                }
            }
        }
        Meeting { leaves, roots }
    }

    /// Per node, the corners of the live faces under it (sorted, distinct).
    fn subtree_corners(&self, triangles: &[[u32; 3]]) -> Vec<Vec<u32>> {
        let mut corners: Vec<Vec<u32>> = vec![Vec::new(); self.nodes.len()];
        // Children after their parent: bottom up in reverse.
        for i in (0..self.nodes.len()).rev() {
            let n = self.nodes[i];
            corners[i] = if n.count > 0 {
                let slots = n.first as usize..(n.first + n.count) as usize;
                let mut own: Vec<u32> = slots
                    .filter(|&s| self.is_live(s))
                    .flat_map(|s| triangles[self.faces[s] as usize])
                    .collect();
                own.sort_unstable();
                own.dedup();
                own
            } else {
                let first = n.first as usize;
                merged(&corners[first], &corners[first + 1])
            };
        }
        corners
    }
}

/// The nodes a pair query splits node `i` (`n`) into: its children, itself for a leaf.
fn split(n: &Node, i: u32) -> Range<u32> {
    match n.count {
        0 => n.first..n.first + 2,
        _ => i..i + 1,
    }
}

/// The distinct values of two sorted lists of distinct values, sorted.
fn merged(x: &[u32], y: &[u32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(x.len() + y.len());
    let (mut i, mut j) = (0, 0);
    while i < x.len() && j < y.len() {
        let v = x[i].min(y[j]);
        out.push(v);
        i += usize::from(x[i] == v);
        j += usize::from(y[j] == v);
    }
    out.extend_from_slice(&x[i..]);
    out.extend_from_slice(&y[j..]);
    out
}

/// Whether two sorted lists hold a common value.
fn share_one(x: &[u32], y: &[u32]) -> bool {
    let (mut i, mut j) = (0, 0);
    while i < x.len() && j < y.len() {
        match x[i].cmp(&y[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => return true,
        }
    }
    false
}
