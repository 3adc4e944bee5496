//! The binned SAH build (Wald 2007): nodes split at the cheapest of `BINS` bins per axis,
//! then laid out depth first (children after their parent).

use super::{Aabb, Node, MAX_LEAF};
use nalgebra::Point3;

/// SAH bins per split.
const BINS: usize = 12;

/// The box of a face; empty for a face collapsed to a point (its three corners equal, e.g.
/// under a bone scaled to 0), which meets nothing: otherwise every such face overlaps every
/// other at that point and the pair queries turn quadratic (measured: a 3322-vertex capsule
/// scaled to 0 took a minute per frame). For finite corners, a box with `min == max` is such
/// a face; tested on the box rather than on the corners, which made the refit's face loop about
/// twice as slow (measured on the finger's detection).
#[inline]
pub(super) fn face_box(positions: &[Point3<f64>], t: &[u32; 3]) -> Aabb {
    Aabb::of_triangle(t.map(|i| &positions[i as usize])).empty_if_point()
}

/// Builds the node array (children after their parent) and permutes `order` into leaf order.
pub(super) fn build_nodes(
    boxes: &[Aabb],
    centroids: &[Point3<f64>],
    order: &mut [u32],
) -> Vec<Node> {
    if order.is_empty() {
        return Vec::new();
    }
    let mut nodes = vec![Node {
        aabb: Aabb::EMPTY,
        first: 0,
        count: 0,
    }];
    // (node index, slot range) still to split.
    let mut todo = vec![(0usize, 0usize, order.len())];
    while let Some((node, lo, hi)) = todo.pop() {
        let slots = &mut order[lo..hi];
        let aabb = slots
            .iter()
            .fold(Aabb::EMPTY, |acc, &i| acc.union(&boxes[i as usize]));
        nodes[node].aabb = aabb;
        let mid = if slots.len() <= MAX_LEAF {
            None
        } else {
            split(boxes, centroids, slots)
        };
        match mid {
            None => {
                nodes[node].first = lo as u32;
                nodes[node].count = (hi - lo) as u32;
            }
            Some(m) => {
                let left = nodes.len();
                nodes[node].first = left as u32;
                let blank = nodes[node];
                nodes.extend([blank, blank]);
                todo.push((left, lo, lo + m));
                todo.push((left + 1, lo + m, hi));
            }
        }
    }
    nodes
}

/// The same tree with every sibling pair stored right after its parent's subtree position in
/// depth-first order (left subtree first): traversals walk memory mostly forward.
pub(super) fn depth_first(nodes: &[Node]) -> Vec<Node> {
    let Some(&root) = nodes.first() else {
        return Vec::new();
    };
    let mut out = Vec::with_capacity(nodes.len());
    out.push(root);
    let mut stack = vec![(0usize, 0usize)];
    while let Some((old, new)) = stack.pop() {
        let n = nodes[old];
        if n.count > 0 {
            continue;
        }
        let (l, base) = (n.first as usize, out.len());
        out.extend([nodes[l], nodes[l + 1]]);
        out[new].first = base as u32;
        stack.push((l + 1, base + 1));
        stack.push((l, base));
    }
    out
}

/// Partitions `slots` by a binned SAH split; returns the size of the left part, or `None` to
/// make a leaf. Falls back to a median split when all centroids fall in one bin.
fn split(boxes: &[Aabb], centroids: &[Point3<f64>], slots: &mut [u32]) -> Option<usize> {
    let cb = slots.iter().fold(Aabb::EMPTY, |acc, &i| {
        let c = centroids[i as usize];
        acc.union(&Aabb { min: c, max: c })
    });
    let extent = cb.max - cb.min;
    let axis = extent.imax();
    if extent[axis] <= 0.0 {
        // Coincident centroids: split in the middle of the (arbitrary but fixed) order.
        return Some(slots.len() / 2);
    }
    let bin_of = |i: u32| {
        let x = (centroids[i as usize][axis] - cb.min[axis]) / extent[axis];
        ((x * BINS as f64) as usize).min(BINS - 1)
    };
    let mut counts = [0usize; BINS];
    let mut bin_boxes = [Aabb::EMPTY; BINS];
    for &i in slots.iter() {
        let b = bin_of(i);
        counts[b] += 1;
        bin_boxes[b] = bin_boxes[b].union(&boxes[i as usize]);
    }
    let best = best_bin_split(&counts, &bin_boxes);
    let mut m = partition(slots, |i| bin_of(i) < best);
    if m == 0 || m == slots.len() {
        slots.sort_unstable_by(|&x, &y| {
            centroids[x as usize][axis].total_cmp(&centroids[y as usize][axis])
        });
        m = slots.len() / 2;
    }
    Some(m)
}

/// Index `k` (1..BINS) minimizing the SAH cost of splitting bins `< k` from bins `>= k`.
fn best_bin_split(counts: &[usize; BINS], bin_boxes: &[Aabb; BINS]) -> usize {
    let mut right_cost = [0.0f64; BINS];
    let (mut acc, mut n) = (Aabb::EMPTY, 0usize);
    for k in (1..BINS).rev() {
        acc = acc.union(&bin_boxes[k]);
        n += counts[k];
        right_cost[k] = acc.half_area() * n as f64;
    }
    let (mut acc, mut n) = (Aabb::EMPTY, 0usize);
    let mut best = (f64::INFINITY, BINS / 2);
    for k in 1..BINS {
        acc = acc.union(&bin_boxes[k - 1]);
        n += counts[k - 1];
        let cost = acc.half_area() * n as f64 + right_cost[k];
        if cost < best.0 {
            best = (cost, k);
        }
    }
    best.1
}

/// Stable-order-free in-place partition; returns the number of elements satisfying `pred`.
fn partition(slots: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let mut m = 0;
    for i in 0..slots.len() {
        if pred(slots[i]) {
            slots.swap(i, m);
            m += 1;
        }
    }
    m
}
