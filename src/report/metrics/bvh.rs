//! A small bounding volume hierarchy over finite triangles, shared by the winding number and
//! the distances.

use super::triangle::distance2;
use super::*;

/// Faces per BVH leaf at most.
const LEAF_SIZE: usize = 4;

#[derive(Clone, Copy, Debug)]
pub(super) struct Node {
    pub(super) min: Point3<f64>,
    pub(super) max: Point3<f64>,
    /// First slot of the subtree.
    pub(super) first: u32,
    /// Number of slots of the subtree.
    pub(super) len: u32,
    /// Right child (the left child is the next node); 0 for a leaf.
    pub(super) right: u32,
}

impl Node {
    #[inline]
    pub(super) fn is_leaf(&self) -> bool {
        self.right == 0
    }

    #[inline]
    pub(super) fn slots(&self) -> std::ops::Range<usize> {
        self.first as usize..(self.first + self.len) as usize
    }

    /// Squared distance from `q` to the box (0 inside).
    #[inline]
    fn distance2(&self, q: &Point3<f64>) -> f64 {
        let mut d = 0.0;
        for k in 0..3 {
            let e = (self.min[k] - q[k]).max(q[k] - self.max[k]).max(0.0);
            d += e * e;
        }
        d
    }
}

/// Median-split BVH over a set of faces, nodes in depth-first order, with a copy of the corners
/// of every face in leaf order. The split is by a total order (centroid coordinate, then face
/// id), so the tree is a pure function of its input.
#[derive(Clone, Debug, Default)]
pub(super) struct Bvh {
    pub(super) nodes: Vec<Node>,
    /// Face id (into the caller's triangles) of each slot.
    pub(super) faces: Vec<u32>,
    /// Corners of each slot's face.
    pub(super) tris: Vec<[Point3<f64>; 3]>,
}

impl Bvh {
    /// Tree over `faces` (ids into `triangles`); faces that are out of range or have an invalid
    /// corner are left out. Returns the tree and the number left out.
    pub(super) fn build(
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        faces: impl Iterator<Item = u32>,
    ) -> (Self, usize) {
        let mut ids = Vec::new();
        let mut tris = Vec::new();
        let mut skipped = 0;
        for f in faces {
            match triangles
                .get(f as usize)
                .and_then(|t| corners(positions, t))
            {
                Some(c) => {
                    ids.push(f);
                    tris.push(c);
                }
                None => skipped += 1,
            }
        }
        let centroids: Vec<Point3<f64>> = tris
            .iter()
            .map(|t| Point3::from((t[0].coords + t[1].coords + t[2].coords) / 3.0))
            .collect();
        let mut order: Vec<u32> = (0..ids.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * ids.len() / LEAF_SIZE + 1);
        if !ids.is_empty() {
            build_range(&tris, &centroids, &ids, &mut order, 0, &mut nodes);
        }
        let bvh = Bvh {
            nodes,
            faces: order.iter().map(|&i| ids[i as usize]).collect(),
            tris: order.iter().map(|&i| tris[i as usize]).collect(),
        };
        (bvh, skipped)
    }

    /// The nearest accepted face to `q` (finite) and its squared distance. Ties go to the
    /// smallest face id, so the answer does not depend on the tree.
    pub(super) fn nearest(
        &self,
        q: &Point3<f64>,
        accept: impl Fn(u32) -> bool,
    ) -> Option<(f64, u32)> {
        let root = self.nodes.first()?;
        let mut best = f64::INFINITY;
        let mut best_face: Option<u32> = None;
        let mut stack: Vec<(u32, f64)> = Vec::with_capacity(64);
        stack.push((0, root.distance2(q)));
        while let Some((i, d2)) = stack.pop() {
            if d2 > best {
                continue;
            }
            let n = &self.nodes[i as usize];
            if n.is_leaf() {
                for s in n.slots() {
                    let f = self.faces[s];
                    if !accept(f) {
                        continue;
                    }
                    let d = distance2(q, &self.tris[s]);
                    if d < best || (d == best && best_face.is_some_and(|b| f < b)) {
                        best = d;
                        best_face = Some(f);
                    }
                }
            } else {
                let (l, r) = (i + 1, n.right);
                let dl = self.nodes[l as usize].distance2(q);
                let dr = self.nodes[r as usize].distance2(q);
                let (near, far) = if dl <= dr {
                    ((l, dl), (r, dr))
                } else {
                    ((r, dr), (l, dl))
                };
                if far.1 <= best {
                    stack.push(far);
                }
                if near.1 <= best {
                    stack.push(near);
                }
            }
        }
        best_face.map(|f| (best, f))
    }
}

/// Builds the subtree over `order` (slots `offset..offset + order.len()`), depth first.
fn build_range(
    tris: &[[Point3<f64>; 3]],
    centroids: &[Point3<f64>],
    ids: &[u32],
    order: &mut [u32],
    offset: usize,
    nodes: &mut Vec<Node>,
) {
    let (mut min, mut max) = (
        Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY),
        Point3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY),
    );
    let (mut cmin, mut cmax) = (min, max);
    for &i in order.iter() {
        for p in &tris[i as usize] {
            min = min.inf(p);
            max = max.sup(p);
        }
        let c = &centroids[i as usize];
        cmin = cmin.inf(c);
        cmax = cmax.sup(c);
    }
    let me = nodes.len();
    nodes.push(Node {
        min,
        max,
        first: offset as u32,
        len: order.len() as u32,
        right: 0,
    });
    if order.len() <= LEAF_SIZE {
        return;
    }
    let extent = cmax - cmin;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&i, &j| {
        centroids[i as usize][axis]
            .total_cmp(&centroids[j as usize][axis])
            .then(ids[i as usize].cmp(&ids[j as usize]))
    });
    let (left, right) = order.split_at_mut(mid);
    build_range(tris, centroids, ids, left, offset, nodes);
    nodes[me].right = nodes.len() as u32;
    build_range(tris, centroids, ids, right, offset + mid, nodes);
}
