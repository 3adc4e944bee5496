//! Min-cut benchmarks: the Boykov-Kolmogorov solver of `contact_skin::mincut` against petgraph's
//! Dinic max-flow, on 4-connected grids shaped like the crease cut of Brunel et al. 2021, Sec. 6.
//!
//! Each grid has crease-like edge capacities `0.1 + u` (u uniform in [0, 1), the dual-edge
//! length taken as 1), hard terminals on two opposite borders (left column tied to the source,
//! right column to the sink, infinite capacity) and a weak unary term on every node (up to 0.05)
//! towards the side a smooth, noisy field prefers (like the β term). Sizes 32x32 (1k nodes),
//! 100x100 (10k) and 224x224 (50k); Dinic only up to 10k.
//!
//! * `bk/min_cut`: the one-call [`min_cut`], including the adjacency build;
//! * `bk/solver_reuse`: a [`BkSolver`] kept across iterations (buffers reused);
//! * `dinics`: `petgraph::algo::dinics` on a prebuilt `DiGraph` with a super source and sink
//!   (graph construction not timed); it gives the flow, not the cut.
//!
//! Run with `cargo bench --bench mincut`.

use contact_skin::mincut::{min_cut, BkSolver, CutGraph};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use petgraph::algo::dinics;
use petgraph::graph::{DiGraph, NodeIndex};
use std::hint::black_box;
use std::time::Duration;

/// xorshift64* in `[0, 1)`.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The benchmark problem as plain lists: `(u, v, capacity)` undirected edges and
/// `(u, source cap, sink cap)` terminals.
struct Problem {
    n: usize,
    edges: Vec<(usize, usize, f64)>,
    terminals: Vec<(usize, f64, f64)>,
}

/// A `side` x `side` crease-cut-like grid (see the file docs).
fn crease_grid(side: usize, seed: u64) -> Problem {
    let mut rng = Rng(seed | 1);
    let id = |x: usize, y: usize| x + side * y;
    let mut edges = Vec::with_capacity(2 * side * side);
    let mut terminals = Vec::with_capacity(side * side + 2 * side);
    for y in 0..side {
        for x in 0..side {
            if x + 1 < side {
                edges.push((id(x, y), id(x + 1, y), 0.1 + rng.unit()));
            }
            if y + 1 < side {
                edges.push((id(x, y), id(x, y + 1), 0.1 + rng.unit()));
            }
            let field = side as f64 / 2.0 - x as f64
                + 0.1 * side as f64 * (y as f64 * 6.0 / side as f64).sin();
            let lambda = 0.05 * rng.unit();
            if field + 3.0 * (rng.unit() - 0.5) > 0.0 {
                terminals.push((id(x, y), lambda, 0.0));
            } else {
                terminals.push((id(x, y), 0.0, lambda));
            }
        }
        terminals.push((id(0, y), f64::INFINITY, 0.0));
        terminals.push((id(side - 1, y), 0.0, f64::INFINITY));
    }
    Problem {
        n: side * side,
        edges,
        terminals,
    }
}

impl Problem {
    fn cut_graph(&self) -> CutGraph {
        let mut g = CutGraph::new(self.n);
        for &(u, v, c) in &self.edges {
            g.add_edge(u, v, c, c).expect("valid edge");
        }
        for &(u, s, t) in &self.terminals {
            g.add_terminal(u, s, t).expect("valid terminal");
        }
        g
    }

    /// DiGraph for Dinic: nodes `0..n`, super source `n`, super sink `n + 1`.
    fn digraph(&self) -> DiGraph<(), f64> {
        let mut g = DiGraph::with_capacity(self.n + 2, 2 * self.edges.len() + self.terminals.len());
        for _ in 0..self.n + 2 {
            g.add_node(());
        }
        let node = NodeIndex::new;
        for &(u, v, c) in &self.edges {
            g.add_edge(node(u), node(v), c);
            g.add_edge(node(v), node(u), c);
        }
        for &(u, s, t) in &self.terminals {
            if s > 0.0 {
                g.add_edge(node(self.n), node(u), s);
            }
            if t > 0.0 {
                g.add_edge(node(u), node(self.n + 1), t);
            }
        }
        g
    }
}

fn bench_mincut(c: &mut Criterion) {
    let mut group = c.benchmark_group("mincut");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    for side in [32usize, 100, 224] {
        let problem = crease_grid(side, 0x5EED + side as u64);
        let n = problem.n;
        let g = problem.cut_graph();
        let mut solver = BkSolver::new();
        let cut = solver.solve(&g).expect("finite cut");
        eprintln!(
            "{side}x{side}: cut {:.6}, {} source-side nodes, {} augmentations",
            cut.value,
            cut.source_side.iter().filter(|&&s| s).count(),
            solver.augmentations()
        );
        group.bench_with_input(BenchmarkId::new("bk/min_cut", n), &g, |b, g| {
            b.iter(|| min_cut(black_box(g)))
        });
        group.bench_with_input(BenchmarkId::new("bk/solver_reuse", n), &g, |b, g| {
            b.iter(|| solver.solve(black_box(g)).map(|cut| cut.value))
        });
        if n <= 10_000 {
            let dg = problem.digraph();
            let (s, t) = (NodeIndex::new(n), NodeIndex::new(n + 1));
            let flow = dinics(&dg, s, t).0;
            assert!(
                (flow - cut.value).abs() <= 1e-9 * cut.value.max(1.0),
                "Dinic {flow} vs BK {}",
                cut.value
            );
            group.bench_with_input(BenchmarkId::new("dinics", n), &dg, |b, dg| {
                b.iter(|| dinics(black_box(dg), s, t).0)
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench_mincut);
criterion_main!(benches);
