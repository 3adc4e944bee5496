//! The Boykov-Kolmogorov max-flow algorithm (Boykov & Kolmogorov 2004, *An Experimental
//! Comparison of Min-Cut/Max-Flow Algorithms for Energy Minimization in Vision*, Sec. 3).
//!
//! # Algorithm
//!
//! Two non-overlapping search trees are kept: S rooted at the source and T rooted at the sink.
//! In S every tree arc parent -> child has residual capacity, in T every tree arc child -> parent
//! has. Nodes in no tree are *free*. The algorithm repeats three stages (paper, Sec. 3.2):
//!
//! 1. **growth**: an *active* node (one on the tree's border) takes the free nodes it reaches
//!    through non-saturated arcs as children, until it touches the other tree: that gives an
//!    augmenting path source -> ... -> S node -> T node -> ... -> sink;
//! 2. **augmentation**: the path's bottleneck is pushed; the saturated arcs split the trees,
//!    and the nodes below them become *orphans*;
//! 3. **adoption**: each orphan looks for a new parent in its own tree, linked to it by a
//!    non-saturated arc and itself attached to the terminal; failing that it becomes free, its
//!    children become orphans and its tree neighbours become active (they may grow into it again).
//!
//! It stops when no node is active; S is then the set of nodes reachable from the source in the
//! residual graph (see the tie rule in the [module](super) docs).
//!
//! As in the authors' implementation, the adoption stage prefers the candidate parent closest to
//! its terminal, using per-node distance labels validated by a timestamp (the number of the
//! augmentation at which they were computed), and growth re-parents a neighbour through the
//! growing node when that shortens its path (same labels).
//!
//! # Data structures
//!
//! * **Arcs.** Edge `k` gives two paired arcs, `2k` (`u -> v`) and `2k + 1` (`v -> u`): the
//!   reverse of arc `r` is `r ^ 1`. Both residual capacities and both heads of an edge sit side
//!   by side in one `ArcPair`, so pushing `f` along an arc (subtract `f` from its residual, add
//!   it to its sister's) touches one cache line.
//! * **Adjacency.** Compressed sparse rows: the arcs leaving node `u` are
//!   `out[first[u]..first[u + 1]]`, in the order the edges were added.
//! * **Terminal arcs** are folded into one signed residual per node, `tr_cap = source_cap -
//!   sink_cap` (after pushing `min(source_cap, sink_cap)` straight through the node): positive
//!   means residual from the source, negative means residual to the sink.
//! * **Trees.** A node's `parent` is the arc from the node to its parent, or one of the sentinels
//!   `TERMINAL` (child of the source or sink itself), `ORPHAN`, `FREE`; a flag says which
//!   tree. `up` caches the parent node, so that walks up a tree (tracing an augmenting path,
//!   measuring a candidate parent's distance in adoption) chain through nodes only.
//! * The active nodes form a FIFO queue (a node is queued at most once), the orphans a deque;
//!   the current augmenting path is kept in a buffer so that it is walked once.
//!
//! Capacities are `f64`; `f64::INFINITY` is allowed. Each augmentation saturates at least one arc
//! exactly (`r - r == 0` in IEEE arithmetic), which is what makes orphans and ends the
//! algorithm; an augmenting path whose bottleneck is infinite means that every cut is infinite
//! ([`MinCutError::InfiniteCut`]).

use super::{CutGraph, MinCut, MinCutError};
use std::collections::VecDeque;

/// `parent` sentinel: the node is in no tree.
const FREE: u32 = u32::MAX;
/// `parent` sentinel: the node's parent is its terminal (source for S, sink for T).
const TERMINAL: u32 = u32::MAX - 1;
/// `parent` sentinel: the node lost its parent during an augmentation.
const ORPHAN: u32 = u32::MAX - 2;
/// Largest number of nodes or arcs (two per edge): indices must stay below the sentinels.
pub const MAX_INDEX: usize = (u32::MAX - 3) as usize;

/// The two arcs of edge `k`: index 0 is arc `2k` (`u -> v`), index 1 is arc `2k + 1`
/// (`v -> u`).
#[derive(Debug, Clone, Copy, Default)]
struct ArcPair {
    /// Residual capacities of the two arcs.
    rcap: [f64; 2],
    /// Heads of the two arcs (`[v, u]`).
    head: [u32; 2],
}

/// Per-node state of the search trees.
#[derive(Debug, Clone, Copy)]
struct Node {
    /// Residual terminal capacity: `> 0` from the source, `< 0` to the sink.
    tr_cap: f64,
    /// Timestamp of `dist`: the augmentation count when it was last known valid.
    ts: u64,
    /// Arc to the parent, or `TERMINAL`, `ORPHAN`, `FREE`.
    parent: u32,
    /// The parent node (head of `parent`) when `parent` is an arc: walks up the tree follow it
    /// without touching the arcs.
    up: u32,
    /// Distance to the terminal along the tree (an upper bound; exact when `ts` is current).
    dist: u32,
    /// Which tree (meaningful when `parent != FREE`): `true` = T (sink), `false` = S (source).
    in_sink: bool,
    /// Whether the node is in the active queue.
    queued: bool,
}

impl Node {
    const EMPTY: Node = Node {
        tr_cap: 0.0,
        ts: 0,
        parent: FREE,
        up: FREE,
        dist: 0,
        in_sink: false,
        queued: false,
    };
}

/// An augmenting path found by growth, through the arc `mid` from `s_end` (in S) to `t_end`
/// (in T).
#[derive(Debug, Clone, Copy)]
struct Bridge {
    s_end: u32,
    mid: u32,
    t_end: u32,
}

/// Boykov-Kolmogorov solver. Holds the adjacency and the search trees; reuse one across frames
/// to keep its allocations ([`solve`](Self::solve) rebuilds everything from the given graph).
#[derive(Debug, Clone, Default)]
pub struct BkSolver {
    /// CSR row offsets into `out`, `n + 1` long.
    first: Vec<u32>,
    /// Arc indices grouped by tail node.
    out: Vec<u32>,
    /// Residuals and heads, one entry per edge.
    pairs: Vec<ArcPair>,
    nodes: Vec<Node>,
    active: VecDeque<u32>,
    orphans: VecDeque<u32>,
    /// The current augmenting path: `(node, arc to push)` from the bridge to each root.
    path_s: Vec<(u32, u32)>,
    path_t: Vec<(u32, u32)>,
    /// Augmentation counter, the clock of the distance labels.
    time: u64,
    /// Flow pushed by the last solve.
    flow: f64,
    /// Augmenting paths of the last solve.
    augmentations: usize,
}

impl BkSolver {
    /// An empty solver.
    pub fn new() -> Self {
        Self::default()
    }

    /// Minimum s-t cut of `g` (see [`super::min_cut`]).
    pub fn solve(&mut self, g: &CutGraph) -> Result<MinCut, MinCutError> {
        g.validate()?;
        self.build(g)?;
        self.init_terminals(g)?;
        self.run()?;
        let source_side: Vec<bool> = self
            .nodes
            .iter()
            .map(|n| n.parent != FREE && !n.in_sink)
            .collect();
        let value = g.cut_capacity(&source_side)?;
        if !value.is_finite() {
            return Err(MinCutError::InfiniteCut);
        }
        Ok(MinCut { value, source_side })
    }

    /// Total flow pushed by the last [`solve`](Self::solve), accumulated in floating point: equal
    /// to the cut value up to rounding (the max-flow min-cut theorem), a self-check.
    pub fn flow(&self) -> f64 {
        self.flow
    }

    /// Number of augmenting paths of the last [`solve`](Self::solve).
    pub fn augmentations(&self) -> usize {
        self.augmentations
    }

    /// Builds the paired arcs and the CSR adjacency.
    fn build(&mut self, g: &CutGraph) -> Result<(), MinCutError> {
        let n = g.node_count();
        let edges = g.edges();
        let m = 2 * edges.len();
        if n > MAX_INDEX || m > MAX_INDEX {
            return Err(MinCutError::TooLarge {
                nodes: n,
                arcs: m,
                max: MAX_INDEX,
            });
        }
        self.pairs.clear();
        self.pairs.extend(edges.iter().map(|e| ArcPair {
            rcap: [e.cap, e.rev_cap],
            head: [e.v as u32, e.u as u32],
        }));
        self.first.clear();
        self.first.resize(n + 1, 0);
        for e in edges {
            self.first[e.u + 1] += 1;
            self.first[e.v + 1] += 1;
        }
        for u in 0..n {
            self.first[u + 1] += self.first[u];
        }
        let mut cursor: Vec<u32> = self.first[..n].to_vec();
        self.out.clear();
        self.out.resize(m, 0);
        for (k, e) in edges.iter().enumerate() {
            self.out[cursor[e.u] as usize] = 2 * k as u32;
            self.out[cursor[e.v] as usize] = 2 * k as u32 + 1;
            cursor[e.u] += 1;
            cursor[e.v] += 1;
        }
        Ok(())
    }

    /// Pushes flow straight through each node's terminal arcs and seeds the trees: nodes with
    /// residual from the source start S, nodes with residual to the sink start T.
    fn init_terminals(&mut self, g: &CutGraph) -> Result<(), MinCutError> {
        let (source_cap, sink_cap) = g.terminal_caps();
        self.nodes.clear();
        self.nodes.resize(g.node_count(), Node::EMPTY);
        self.active.clear();
        self.orphans.clear();
        self.time = 0;
        self.flow = 0.0;
        self.augmentations = 0;
        for (u, (&s, &t)) in source_cap.iter().zip(sink_cap).enumerate() {
            if s == f64::INFINITY && t == f64::INFINITY {
                return Err(MinCutError::InfiniteCut);
            }
            self.flow += s.min(t);
            let tr_cap = s - t;
            if tr_cap != 0.0 {
                self.nodes[u] = Node {
                    tr_cap,
                    parent: TERMINAL,
                    dist: 1,
                    in_sink: tr_cap < 0.0,
                    ..Node::EMPTY
                };
                self.set_active(u as u32);
            }
        }
        Ok(())
    }

    /// The main loop: growth, augmentation, adoption until no node is active.
    fn run(&mut self) -> Result<(), MinCutError> {
        let mut current = None;
        while let Some(p) = current.take().or_else(|| self.next_active()) {
            if let Some(bridge) = self.grow(p) {
                self.time += 1;
                self.augment(bridge)?;
                self.adopt_orphans();
                // Keep growing from `p` while it is still in a tree (as the reference code does).
                if self.nodes[p as usize].parent != FREE {
                    current = Some(p);
                }
            }
        }
        Ok(())
    }

    /// Queues `u` unless it is already queued.
    fn set_active(&mut self, u: u32) {
        let node = &mut self.nodes[u as usize];
        if !node.queued {
            node.queued = true;
            self.active.push_back(u);
        }
    }

    /// Pops the next active node that is still in a tree.
    fn next_active(&mut self) -> Option<u32> {
        while let Some(u) = self.active.pop_front() {
            let node = &mut self.nodes[u as usize];
            node.queued = false;
            if node.parent != FREE {
                return Some(u);
            }
        }
        None
    }

    /// Positions in `out` of the arcs leaving `u`.
    fn row(&self, u: u32) -> std::ops::Range<usize> {
        self.first[u as usize] as usize..self.first[u as usize + 1] as usize
    }

    /// Head of arc `r`.
    fn head(&self, r: u32) -> u32 {
        self.pairs[(r >> 1) as usize].head[(r & 1) as usize]
    }

    /// Residual capacity of arc `r`.
    fn rcap(&self, r: u32) -> f64 {
        self.pairs[(r >> 1) as usize].rcap[(r & 1) as usize]
    }

    /// Residual capacity of arc `r` (leaving a node of the given tree) in the direction that tree
    /// would use it to reach the arc's head: the arc itself in S, its reverse in T.
    fn outward_rcap(&self, r: u32, in_sink: bool) -> f64 {
        self.rcap(r ^ in_sink as u32)
    }

    /// Growth stage from the active node `p`: free neighbours reachable through non-saturated
    /// arcs join `p`'s tree; returns the bridge to the other tree if one is met.
    fn grow(&mut self, p: u32) -> Option<Bridge> {
        let pn = self.nodes[p as usize];
        for pos in self.row(p) {
            let r = self.out[pos];
            if self.outward_rcap(r, pn.in_sink) <= 0.0 {
                continue;
            }
            let q = self.head(r);
            let qn = &mut self.nodes[q as usize];
            if qn.parent == FREE {
                *qn = Node {
                    parent: r ^ 1,
                    up: p,
                    in_sink: pn.in_sink,
                    ts: pn.ts,
                    dist: pn.dist + 1,
                    ..*qn
                };
                self.set_active(q);
            } else if qn.in_sink != pn.in_sink {
                return Some(if pn.in_sink {
                    Bridge {
                        s_end: q,
                        mid: r ^ 1,
                        t_end: p,
                    }
                } else {
                    Bridge {
                        s_end: p,
                        mid: r,
                        t_end: q,
                    }
                });
            } else if qn.ts <= pn.ts && qn.dist > pn.dist {
                // Heuristic of the reference code: reattach q through p, which is closer to the
                // terminal. (ts, -dist) strictly increases towards the root, so no cycle forms.
                qn.parent = r ^ 1;
                qn.up = p;
                qn.ts = pn.ts;
                qn.dist = pn.dist + 1;
            }
        }
        None
    }

    /// Collects the augmenting path through `bridge` into `path_s` / `path_t` (with the arc to
    /// push for each non-root node: the reverse of its parent arc in S, its parent arc in T) and
    /// returns its bottleneck and the two roots.
    fn trace_path(&mut self, bridge: Bridge) -> (f64, u32, u32) {
        let mut b = self.rcap(bridge.mid);
        self.path_s.clear();
        let mut i = bridge.s_end;
        loop {
            let parent = self.nodes[i as usize].parent;
            if parent == TERMINAL {
                break;
            }
            b = b.min(self.rcap(parent ^ 1));
            self.path_s.push((i, parent ^ 1));
            i = self.nodes[i as usize].up;
        }
        b = b.min(self.nodes[i as usize].tr_cap);
        self.path_t.clear();
        let mut j = bridge.t_end;
        loop {
            let parent = self.nodes[j as usize].parent;
            if parent == TERMINAL {
                break;
            }
            b = b.min(self.rcap(parent));
            self.path_t.push((j, parent));
            j = self.nodes[j as usize].up;
        }
        (b.min(-self.nodes[j as usize].tr_cap), i, j)
    }

    /// Augmentation stage: pushes the bottleneck along the path through `bridge`; nodes whose
    /// parent arc (or terminal arc) saturates become orphans.
    fn augment(&mut self, bridge: Bridge) -> Result<(), MinCutError> {
        let (b, s_root, t_root) = self.trace_path(bridge);
        if b == f64::INFINITY {
            return Err(MinCutError::InfiniteCut);
        }
        self.push(bridge.mid, b);
        for k in 0..self.path_s.len() {
            let (node, arc) = self.path_s[k];
            if self.push(arc, b) {
                self.make_orphan_front(node);
            }
        }
        self.nodes[s_root as usize].tr_cap -= b;
        if self.nodes[s_root as usize].tr_cap == 0.0 {
            self.make_orphan_front(s_root);
        }
        for k in 0..self.path_t.len() {
            let (node, arc) = self.path_t[k];
            if self.push(arc, b) {
                self.make_orphan_front(node);
            }
        }
        self.nodes[t_root as usize].tr_cap += b;
        if self.nodes[t_root as usize].tr_cap == 0.0 {
            self.make_orphan_front(t_root);
        }
        self.flow += b;
        self.augmentations += 1;
        Ok(())
    }

    /// Pushes `f` along arc `r`; returns whether it saturated.
    fn push(&mut self, r: u32, f: f64) -> bool {
        let pair = &mut self.pairs[(r >> 1) as usize];
        let d = (r & 1) as usize;
        pair.rcap[d] -= f;
        pair.rcap[d ^ 1] += f;
        pair.rcap[d] == 0.0
    }

    fn make_orphan_front(&mut self, u: u32) {
        self.nodes[u as usize].parent = ORPHAN;
        self.orphans.push_front(u);
    }

    fn make_orphan_back(&mut self, u: u32) {
        self.nodes[u as usize].parent = ORPHAN;
        self.orphans.push_back(u);
    }

    /// Adoption stage: processes orphans until none is left.
    fn adopt_orphans(&mut self) {
        while let Some(p) = self.orphans.pop_front() {
            match self.find_parent(p) {
                Some((arc, q, dist)) => {
                    let node = &mut self.nodes[p as usize];
                    node.parent = arc;
                    node.up = q;
                    node.ts = self.time;
                    node.dist = dist + 1;
                }
                None => self.release(p),
            }
        }
    }

    /// A new parent for the orphan `p`: the arc from `p` to the neighbour of its tree, linked
    /// by a non-saturated arc and rooted at the terminal, closest to the terminal; with that
    /// neighbour and its distance.
    fn find_parent(&mut self, p: u32) -> Option<(u32, u32, u32)> {
        let in_sink = self.nodes[p as usize].in_sink;
        let mut best: Option<(u32, u32, u32)> = None;
        for pos in self.row(p) {
            let r = self.out[pos];
            // Residual from the neighbour to p in S, from p to the neighbour in T.
            if self.outward_rcap(r, !in_sink) <= 0.0 {
                continue;
            }
            let q = self.head(r);
            let qn = self.nodes[q as usize];
            if qn.parent == FREE || qn.in_sink != in_sink {
                continue;
            }
            if let Some(d) = self.root_distance(q) {
                if best.is_none_or(|(_, _, d_best)| d < d_best) {
                    best = Some((r, q, d));
                }
            }
        }
        best
    }

    /// Distance from the tree node `q` to its terminal, or `None` if its path meets an orphan.
    /// Labels the nodes of the path with the current time (paper, Sec. 3.2, adoption stage).
    fn root_distance(&mut self, q: u32) -> Option<u32> {
        let mut j = q;
        let mut d: u32 = 0;
        loop {
            let nj = self.nodes[j as usize];
            if nj.ts == self.time {
                d += nj.dist;
                break;
            }
            d += 1;
            if nj.parent == TERMINAL {
                self.nodes[j as usize].ts = self.time;
                self.nodes[j as usize].dist = 1;
                break;
            }
            if nj.parent >= ORPHAN {
                return None;
            }
            j = nj.up;
        }
        let total = d;
        let mut j = q;
        while self.nodes[j as usize].ts != self.time {
            let node = &mut self.nodes[j as usize];
            node.ts = self.time;
            node.dist = d;
            d -= 1;
            j = node.up;
        }
        Some(total)
    }

    /// An orphan without a parent becomes free: its tree neighbours that can reach it become
    /// active, its children become orphans.
    fn release(&mut self, p: u32) {
        let in_sink = self.nodes[p as usize].in_sink;
        for pos in self.row(p) {
            let r = self.out[pos];
            let q = self.head(r);
            let qn = self.nodes[q as usize];
            if qn.parent == FREE || qn.in_sink != in_sink {
                continue;
            }
            if self.outward_rcap(r, !in_sink) > 0.0 {
                self.set_active(q);
            }
            if qn.parent < ORPHAN && qn.up == p {
                self.make_orphan_back(q);
            }
        }
        self.nodes[p as usize].parent = FREE;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic xorshift64* in `[0, 1)`.
    fn unit(state: &mut u64) -> f64 {
        *state ^= *state >> 12;
        *state ^= *state << 25;
        *state ^= *state >> 27;
        (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn random_graph(state: &mut u64, n: usize) -> CutGraph {
        let mut g = CutGraph::new(n);
        for _ in 0..3 * n {
            let u = (unit(state) * n as f64) as usize;
            let v = (unit(state) * n as f64) as usize;
            g.add_edge(u, v, unit(state), unit(state)).unwrap();
        }
        for u in 0..n {
            if unit(state) < 0.4 {
                g.add_terminal(u, unit(state), unit(state)).unwrap();
            }
        }
        g
    }

    /// After a solve, the source side is exactly the set of nodes reachable from the source in
    /// the residual graph (the documented tie rule), and no residual arc leaves it.
    #[test]
    fn source_side_is_residual_closure() {
        let mut state = 0x1234_5678_9ABC_DEF1;
        let mut solver = BkSolver::new();
        for _ in 0..100 {
            let n = 2 + (unit(&mut state) * 300.0) as usize;
            let g = random_graph(&mut state, n);
            let cut = solver.solve(&g).unwrap();
            let mut reach: Vec<bool> = solver.nodes.iter().map(|node| node.tr_cap > 0.0).collect();
            let mut stack: Vec<u32> = (0..n as u32).filter(|&u| reach[u as usize]).collect();
            while let Some(u) = stack.pop() {
                for pos in solver.row(u) {
                    let r = solver.out[pos];
                    let q = solver.head(r);
                    if solver.rcap(r) > 0.0 && !reach[q as usize] {
                        reach[q as usize] = true;
                        stack.push(q);
                    }
                }
            }
            assert_eq!(reach, cut.source_side);
            // No augmenting path is left: no source-side node has residual to the sink.
            for (node, &s) in solver.nodes.iter().zip(&cut.source_side) {
                assert!(!(s && node.tr_cap < 0.0));
            }
        }
    }

    /// Pushes are antisymmetric: residuals stay non-negative and each edge keeps its total
    /// capacity; every arc is listed once, in its tail's row.
    #[test]
    fn residuals_are_paired() {
        let mut state = 42;
        let g = random_graph(&mut state, 200);
        let mut solver = BkSolver::new();
        solver.solve(&g).unwrap();
        for (pair, e) in solver.pairs.iter().zip(g.edges()) {
            assert!(pair.rcap[0] >= 0.0 && pair.rcap[1] >= 0.0);
            let (total, expected) = (pair.rcap[0] + pair.rcap[1], e.cap + e.rev_cap);
            assert!((total - expected).abs() <= 1e-12 * expected.max(1.0));
        }
        let mut seen = vec![0; 2 * g.edge_count()];
        for u in 0..g.node_count() as u32 {
            for pos in solver.row(u) {
                let r = solver.out[pos];
                seen[r as usize] += 1;
                assert_eq!(solver.head(r ^ 1), u);
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
    }
}
