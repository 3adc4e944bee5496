//! A face crossed by intersection curves clipped along them (Sec. 4.1): the inside part traced
//! as polygons, curve chains inside the face closed by arcs of its boundary, the inside always on
//! the left of the oriented curve.

use super::triangulate::{signed_area, triangulate_into};
use super::{CutFace, RegionStats};
use crate::intersect::index::PosedMesh;
use crate::intersect::mesh_mesh::{EdgeHit, Intersections, Side};
use nalgebra::Point3;

/// A polygon vertex inside a face.
#[derive(Clone, Copy, Debug)]
pub(super) struct Node {
    pub(super) bary: [f64; 3],
    pub(super) point: Point3<f64>,
}

impl Node {
    pub(super) fn uv(&self) -> [f64; 2] {
        [self.bary[1], self.bary[2]]
    }
}

/// A curve piece crossing a face from boundary to boundary.
struct Chain {
    hits: Vec<u32>,
    /// Boundary positions (see `FaceClip::boundary_position`) of entry and exit.
    entry: f64,
    exit: f64,
}

/// The curve pieces inside one face.
pub(super) struct FaceCurves {
    pub(super) face: u32,
    chains: Vec<Chain>,
    loops: Vec<Vec<u32>>,
}

impl FaceCurves {
    /// The same curves run backwards (the complement region on their left).
    pub(super) fn reversed(mut self) -> Self {
        for c in &mut self.chains {
            c.hits.reverse();
            std::mem::swap(&mut c.entry, &mut c.exit);
        }
        for l in &mut self.loops {
            l.reverse();
        }
        self
    }
}

/// Clipping of one face of `side` along the curve segments in it.
pub(super) struct FaceClip<'a, 'm> {
    pub(super) ints: &'a Intersections,
    pub(super) side: Side,
    pub(super) mesh: &'a PosedMesh<'m>,
    pub(super) face: u32,
}

impl FaceClip<'_, '_> {
    pub(super) fn clip(
        &self,
        curves: FaceCurves,
        corners_in: [bool; 3],
        stats: &mut RegionStats,
    ) -> CutFace {
        let FaceCurves { chains, loops, .. } = curves;
        let mut polygons: Vec<Vec<Node>> = Vec::new();
        if chains.is_empty() {
            if corners_in.iter().filter(|&&x| x).count() >= 2 {
                polygons.push((0..3).map(|k| self.corner(k)).collect());
            }
        } else {
            polygons.extend(self.boundary_polygons(&chains, stats));
        }
        let mut cut = CutFace {
            face: self.face,
            sub_triangles: Vec::new(),
            holes: Vec::new(),
        };
        for poly in polygons {
            triangulate_into(&poly, &mut cut, stats);
        }
        for lp in loops {
            let mut poly: Vec<Node> = lp.iter().map(|&h| self.hit_node(h)).collect();
            if signed_area(&poly) < 0.0 {
                poly.reverse();
                let mut hole = CutFace {
                    face: self.face,
                    sub_triangles: Vec::new(),
                    holes: Vec::new(),
                };
                triangulate_into(&poly, &mut hole, stats);
                cut.holes.extend(hole.sub_triangles);
                cut.sub_triangles.extend(hole.holes);
            } else {
                triangulate_into(&poly, &mut cut, stats);
            }
        }
        cut
    }

    fn hit(&self, h: u32) -> &EdgeHit {
        &self.ints.hits[h as usize]
    }

    /// A hit on this face's boundary (an edge of this surface), rather than inside it.
    fn on_boundary(&self, h: u32) -> bool {
        self.hit(h).side == self.side
    }

    fn corner(&self, k: usize) -> Node {
        let mut bary = [0.0; 3];
        bary[k] = 1.0;
        Node {
            bary,
            point: *self.mesh.corners(self.face)[k],
        }
    }

    /// Local edge `k` of a boundary hit and its parameter along that edge, counter-clockwise.
    fn boundary_location(&self, h: u32) -> (usize, f64) {
        let hit = self.hit(h);
        let t = self.mesh.triangles()[self.face as usize];
        for k in 0..3 {
            let (u, v) = (t[k], t[(k + 1) % 3]);
            if [u.min(v), u.max(v)] == hit.edge {
                let along = if u == hit.edge[0] { hit.t } else { 1.0 - hit.t };
                return (k, along);
            }
        }
        (0, 0.0)
    }

    /// Position of a boundary hit along the face boundary, in `(0, 3)`: local edge `k` maps to
    /// `[k + η, k + 1 - η]` and corner `j` sits at `j`, so a hit at a corner (t = 0 or 1, from
    /// an exact tie) stays on its own edge's side of the corner.
    fn boundary_position(&self, h: u32) -> f64 {
        const ETA: f64 = 1.0 / (1u64 << 20) as f64;
        let (k, along) = self.boundary_location(h);
        k as f64 + ETA + along * (1.0 - 2.0 * ETA)
    }

    fn hit_node(&self, h: u32) -> Node {
        let hit = self.hit(h);
        if !self.on_boundary(h) {
            return Node {
                bary: hit.bary,
                point: hit.point,
            };
        }
        let (k, along) = self.boundary_location(h);
        let mut bary = [0.0; 3];
        bary[k] = 1.0 - along;
        bary[(k + 1) % 3] = along;
        Node {
            bary,
            point: hit.point,
        }
    }

    /// Whether the corners are in the region, when the face is crossed only by closed loops:
    /// the region is on the left of every loop, so the corners are in it iff the outermost
    /// (largest) loop runs clockwise.
    pub(super) fn corner_vote(&self, curves: &FaceCurves) -> Option<bool> {
        if !curves.chains.is_empty() {
            return None;
        }
        curves
            .loops
            .iter()
            .map(|l| signed_area(&l.iter().map(|&h| self.hit_node(h)).collect::<Vec<_>>()))
            .max_by(|x, y| x.abs().total_cmp(&y.abs()))
            .map(|a| a < 0.0)
    }

    /// Splits the face's segments into boundary-to-boundary chains and closed interior loops.
    pub(super) fn curves(&self, segs: &[[u32; 2]], stats: &mut RegionStats) -> FaceCurves {
        let mut used = vec![false; segs.len()];
        let next_from =
            |h: u32, used: &[bool]| (0..segs.len()).find(|&i| !used[i] && segs[i][0] == h);
        let mut chains = Vec::new();
        for start in 0..segs.len() {
            if used[start] || !self.on_boundary(segs[start][0]) {
                continue;
            }
            let mut hits = vec![segs[start][0]];
            let mut cur = start;
            let complete = loop {
                used[cur] = true;
                let to = segs[cur][1];
                hits.push(to);
                if self.on_boundary(to) {
                    break true;
                }
                match next_from(to, &used) {
                    Some(n) => cur = n,
                    None => break false,
                }
            };
            if complete {
                let entry = self.boundary_position(hits[0]);
                let exit = self.boundary_position(hits[hits.len() - 1]);
                chains.push(Chain { hits, entry, exit });
            } else {
                stats.dangling_chains += 1;
            }
        }
        let loops = self.loops(segs, &mut used, stats);
        FaceCurves {
            face: self.face,
            chains,
            loops,
        }
    }

    fn loops(
        &self,
        segs: &[[u32; 2]],
        used: &mut [bool],
        stats: &mut RegionStats,
    ) -> Vec<Vec<u32>> {
        let mut loops = Vec::new();
        for start in 0..segs.len() {
            if used[start] {
                continue;
            }
            let mut hits = vec![segs[start][0]];
            let mut cur = start;
            let closed = loop {
                used[cur] = true;
                let to = segs[cur][1];
                if to == segs[start][0] {
                    break true;
                }
                hits.push(to);
                match (0..segs.len()).find(|&i| !used[i] && segs[i][0] == to) {
                    Some(n) => cur = n,
                    None => break false,
                }
            };
            if closed && hits.len() >= 3 {
                loops.push(hits);
            } else if !closed {
                stats.dangling_chains += 1;
            }
        }
        loops
    }

    /// Polygons made of chains joined by counter-clockwise arcs of the face boundary.
    fn boundary_polygons(&self, chains: &[Chain], stats: &mut RegionStats) -> Vec<Vec<Node>> {
        let mut used = vec![false; chains.len()];
        let mut polygons = Vec::new();
        for first in 0..chains.len() {
            if used[first] {
                continue;
            }
            let mut poly = Vec::new();
            let mut cur = first;
            loop {
                used[cur] = true;
                poly.extend(chains[cur].hits.iter().map(|&h| self.hit_node(h)));
                let exit = chains[cur].exit;
                let next = next_entry(chains, exit);
                let gap = (chains[next].entry - exit).rem_euclid(3.0);
                poly.extend(corners_between(exit, gap).map(|k| self.corner(k)));
                if next == first {
                    break;
                }
                if used[next] {
                    stats.boundary_mismatches += 1;
                    break;
                }
                cur = next;
            }
            polygons.push(poly);
        }
        polygons
    }
}

/// The chain whose entry comes first counter-clockwise after boundary position `exit`.
fn next_entry(chains: &[Chain], exit: f64) -> usize {
    let mut best = (f64::INFINITY, 0);
    for (i, c) in chains.iter().enumerate() {
        let gap = (c.entry - exit).rem_euclid(3.0);
        if gap < best.0 {
            best = (gap, i);
        }
    }
    best.1
}

/// Local corners strictly between boundary position `from` and `from + gap`, in order.
fn corners_between(from: f64, gap: f64) -> impl Iterator<Item = usize> {
    let mut ks: Vec<(f64, usize)> = (0..3)
        .map(|k| ((k as f64 - from).rem_euclid(3.0), k))
        .filter(|&(d, _)| d > 0.0 && d < gap)
        .collect();
    ks.sort_by(|x, y| x.0.total_cmp(&y.0));
    ks.into_iter().map(|(_, k)| k)
}
