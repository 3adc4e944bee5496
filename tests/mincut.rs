//! Tests of the Boykov-Kolmogorov min-cut (`contact_skin::mincut`): against petgraph's Dinic
//! max-flow, against brute force over all partitions, hard terminals, grids with a known cut,
//! errors and degenerate inputs.

use contact_skin::mincut::{min_cut, BkSolver, CapacitySite, CutGraph, MinCut, MinCutError};
use petgraph::algo::dinics;
use petgraph::graph::{DiGraph, NodeIndex, UnGraph};

/// xorshift64* generator: deterministic, no dependency.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in `[0, 1)`.
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in `lo..hi`.
    fn range(&mut self, lo: usize, hi: usize) -> usize {
        lo + (self.next_u64() % (hi - lo) as u64) as usize
    }
    fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
}

/// A graph kept as plain lists, so that reference solvers can be run on the same data.
#[derive(Debug, Clone, Default)]
struct Problem {
    n: usize,
    /// `(u, v, cap u->v, cap v->u)`.
    edges: Vec<(usize, usize, f64, f64)>,
    /// `(u, source cap, sink cap)`.
    terminals: Vec<(usize, f64, f64)>,
}

impl Problem {
    fn cut_graph(&self) -> CutGraph {
        let mut g = CutGraph::new(self.n);
        for &(u, v, c, r) in &self.edges {
            g.add_edge(u, v, c, r).expect("valid edge");
        }
        for &(u, s, t) in &self.terminals {
            g.add_terminal(u, s, t).expect("valid terminal");
        }
        g
    }

    /// Max-flow value by petgraph's Dinic algorithm, on a DiGraph with a super source (node `n`)
    /// and a super sink (node `n + 1`). Self-loops are left out.
    fn dinics_value(&self) -> f64 {
        let mut g = DiGraph::<(), f64>::new();
        for _ in 0..self.n + 2 {
            g.add_node(());
        }
        let node = |i: usize| NodeIndex::new(i);
        let (s, t) = (node(self.n), node(self.n + 1));
        for &(u, v, c, r) in &self.edges {
            if u == v {
                continue;
            }
            if c > 0.0 {
                g.add_edge(node(u), node(v), c);
            }
            if r > 0.0 {
                g.add_edge(node(v), node(u), r);
            }
        }
        for &(u, a, b) in &self.terminals {
            if a > 0.0 {
                g.add_edge(s, node(u), a);
            }
            if b > 0.0 {
                g.add_edge(node(u), t, b);
            }
        }
        dinics(&g, s, t).0
    }

    /// Cut capacity of a partition, recomputed from the lists (independent of the crate).
    fn cut_cost(&self, source_side: &[bool]) -> f64 {
        let mut cost = 0.0;
        for &(u, v, c, r) in &self.edges {
            if source_side[u] && !source_side[v] {
                cost += c;
            }
            if !source_side[u] && source_side[v] {
                cost += r;
            }
        }
        for &(u, a, b) in &self.terminals {
            cost += if source_side[u] { b } else { a };
        }
        cost
    }
}

/// A random capacity: mostly uniform, sometimes zero, sometimes large.
fn random_cap(rng: &mut Rng, integer: bool) -> f64 {
    if rng.chance(0.1) {
        return 0.0;
    }
    if integer {
        rng.range(1, 6) as f64
    } else if rng.chance(0.05) {
        100.0 * rng.unit()
    } else {
        rng.unit()
    }
}

/// A random graph: edges (symmetric or not, some parallel, some self-loops) and terminals on a
/// random subset of nodes.
fn random_problem(rng: &mut Rng, n: usize, integer: bool) -> Problem {
    let mut p = Problem {
        n,
        ..Problem::default()
    };
    let m = n * rng.range(1, 5) + rng.range(0, n + 1);
    for _ in 0..m {
        let u = rng.range(0, n);
        let v = if rng.chance(0.02) { u } else { rng.range(0, n) };
        let c = random_cap(rng, integer);
        let r = if rng.chance(0.5) {
            c
        } else {
            random_cap(rng, integer)
        };
        p.edges.push((u, v, c, r));
        if rng.chance(0.05) {
            p.edges.push((u, v, c, r)); // parallel edge
        }
    }
    for u in 0..n {
        if rng.chance(0.3) {
            let s = if rng.chance(0.6) {
                random_cap(rng, integer)
            } else {
                0.0
            };
            let t = if rng.chance(0.6) {
                random_cap(rng, integer)
            } else {
                0.0
            };
            p.terminals.push((u, s, t));
        }
    }
    p
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()).max(1.0)
}

/// Checks the internal consistency of a result: length, value = recomputed cut capacity, and
/// value = flow pushed by the solver (max-flow min-cut).
fn check_consistent(p: &Problem, cut: &MinCut, flow: f64) {
    assert_eq!(cut.source_side.len(), p.n);
    let recomputed = p.cut_cost(&cut.source_side);
    assert!(
        close(cut.value, recomputed, 1e-12),
        "value {} vs partition {}",
        cut.value,
        recomputed
    );
    assert!(
        close(cut.value, flow, 1e-9),
        "cut {} vs pushed flow {}",
        cut.value,
        flow
    );
}

#[test]
fn value_matches_petgraph_dinics_on_random_graphs() {
    let mut rng = Rng::new(1);
    let mut solver = BkSolver::new();
    for case in 0..300 {
        let n = rng.range(5, 201);
        let p = random_problem(&mut rng, n, case % 3 == 0);
        let cut = solver.solve(&p.cut_graph()).expect("finite cut");
        check_consistent(&p, &cut, solver.flow());
        let reference = p.dinics_value();
        assert!(
            close(cut.value, reference, 1e-9),
            "case {case} (n = {n}): BK {} vs Dinic {reference}",
            cut.value
        );
    }
}

/// Minimum over all 2^n partitions, and all partitions achieving it (exact for integer
/// capacities). Partitions are bit masks, bit i set = node i on the source side.
fn brute_force(p: &Problem) -> (f64, Vec<u32>) {
    let mut best = f64::INFINITY;
    let mut argmin = Vec::new();
    let mut side = vec![false; p.n];
    for mask in 0u32..(1 << p.n) {
        for (i, s) in side.iter_mut().enumerate() {
            *s = mask & (1 << i) != 0;
        }
        let cost = p.cut_cost(&side);
        if cost < best {
            best = cost;
            argmin.clear();
        }
        if cost == best {
            argmin.push(mask);
        }
    }
    (best, argmin)
}

fn mask_of(side: &[bool]) -> u32 {
    side.iter()
        .enumerate()
        .filter(|(_, &s)| s)
        .map(|(i, _)| 1u32 << i)
        .sum()
}

#[test]
fn brute_force_minimum_and_smallest_source_side() {
    let mut rng = Rng::new(2);
    for case in 0..300 {
        let n = rng.range(1, 13);
        let integer = case % 4 != 0;
        let p = random_problem(&mut rng, n, integer);
        let cut = min_cut(&p.cut_graph()).expect("finite cut");
        let (best, argmin) = brute_force(&p);
        let returned = p.cut_cost(&cut.source_side);
        assert!(
            close(cut.value, best, 1e-12),
            "case {case}: value {} vs brute force {best}",
            cut.value
        );
        assert!(
            close(returned, best, 1e-12),
            "case {case}: partition costs {returned}, minimum {best}"
        );
        if integer {
            // Tie rule: the returned source side is contained in every minimum cut's.
            let mine = mask_of(&cut.source_side);
            for &other in &argmin {
                assert_eq!(
                    mine & !other,
                    0,
                    "case {case}: source side {mine:b} not within minimum cut {other:b}"
                );
            }
            assert!(argmin.contains(&mine));
        }
    }
}

#[test]
fn hard_terminals_are_respected() {
    let mut rng = Rng::new(3);
    for case in 0..200 {
        let n = rng.range(2, 13);
        let mut p = random_problem(&mut rng, n, case % 2 == 0);
        // Infinite source on node 0, infinite sink on node n - 1, plus a few more of each
        // (never both on one node, no infinite edge: the cut stays finite).
        let mut hard = vec![0i8; n];
        hard[0] = 1;
        hard[n - 1] = -1;
        for h in hard.iter_mut().take(n - 1).skip(1) {
            *h = [0, 0, 1, -1][rng.range(0, 4)];
        }
        for (u, &h) in hard.iter().enumerate() {
            match h {
                1 => p.terminals.push((u, f64::INFINITY, 0.0)),
                -1 => p.terminals.push((u, 0.0, f64::INFINITY)),
                _ => {}
            }
        }
        let cut = min_cut(&p.cut_graph()).expect("finite cut");
        for (u, &h) in hard.iter().enumerate() {
            if h != 0 {
                assert_eq!(cut.source_side[u], h > 0, "case {case}: hard node {u}");
            }
        }
        let (best, _) = brute_force(&p);
        assert!(best.is_finite());
        assert!(
            close(cut.value, best, 1e-12),
            "case {case}: {} vs {best}",
            cut.value
        );
    }
}

#[test]
fn infinite_edges_keep_their_ends_together() {
    // 0 (hard source) -inf- 1 -1- 2 -inf- 3 (hard sink), 1 pulled weakly to the sink, 2 to the
    // source: the infinite edges force the cut onto edge 1-2.
    let mut g = CutGraph::new(4);
    g.add_edge(0, 1, f64::INFINITY, f64::INFINITY).unwrap();
    g.add_edge(1, 2, 1.0, 1.0).unwrap();
    g.add_edge(2, 3, f64::INFINITY, f64::INFINITY).unwrap();
    g.add_terminal(0, f64::INFINITY, 0.0).unwrap();
    g.add_terminal(3, 0.0, f64::INFINITY).unwrap();
    g.add_terminal(1, 0.0, 5.0).unwrap();
    g.add_terminal(2, 5.0, 0.0).unwrap();
    let cut = min_cut(&g).unwrap();
    assert_eq!(cut.source_side, vec![true, true, false, false]);
    assert_eq!(cut.value, 11.0);
}

/// A `w` x `h` 4-connected grid, node `x + w * y`; `cap(a, b)` gives each edge's capacity.
fn grid(w: usize, h: usize, mut cap: impl FnMut((usize, usize), (usize, usize)) -> f64) -> Problem {
    let mut p = Problem {
        n: w * h,
        ..Problem::default()
    };
    for y in 0..h {
        for x in 0..w {
            if x + 1 < w {
                let c = cap((x, y), (x + 1, y));
                p.edges.push((x + w * y, x + 1 + w * y, c, c));
            }
            if y + 1 < h {
                let c = cap((x, y), (x, y + 1));
                p.edges.push((x + w * y, x + w * (y + 1), c, c));
            }
        }
    }
    p
}

/// Ties the left column to the source and the right column to the sink, infinitely.
fn tie_borders(p: &mut Problem, w: usize, h: usize) {
    for y in 0..h {
        p.terminals.push((w * y, f64::INFINITY, 0.0));
        p.terminals.push((w - 1 + w * y, 0.0, f64::INFINITY));
    }
}

#[test]
fn grid_cut_along_weak_column() {
    // Horizontal edges between columns 6 and 7 are weak: the cut is that column of edges.
    let (w, h) = (15, 10);
    let mut rng = Rng::new(4);
    let mut p = grid(w, h, |a, b| {
        if a.0 == 6 && b.0 == 7 {
            0.1
        } else {
            1.0 + rng.unit()
        }
    });
    tie_borders(&mut p, w, h);
    let cut = min_cut(&p.cut_graph()).unwrap();
    for y in 0..h {
        for x in 0..w {
            assert_eq!(cut.source_side[x + w * y], x <= 6, "node ({x}, {y})");
        }
    }
    assert!(close(cut.value, 0.1 * h as f64, 1e-12), "{}", cut.value);
    assert!(close(cut.value, p.dinics_value(), 1e-9));
}

#[test]
fn crease_cut_follows_weak_curve() {
    // Crease-like setting: the edges crossing a wavy curve x = b(y) have a small capacity, the
    // others ~1, hard terminals on the left and right borders and weak unary terms everywhere
    // (too weak to move the cut: their total is below one strong edge). Expected: exactly the
    // nodes left of the curve on the source side.
    let (w, h) = (40, 30);
    let b = |y: usize| (20.0 + 8.0 * (y as f64 * 0.35).sin()).round() as usize;
    let left = |(x, y): (usize, usize)| x <= b(y);
    let mut rng = Rng::new(5);
    let mut p = grid(w, h, |a, c| {
        if left(a) != left(c) {
            0.005 * (1.0 + rng.unit())
        } else {
            1.0 + rng.unit()
        }
    });
    tie_borders(&mut p, w, h);
    for u in 0..w * h {
        let lambda = 2e-4 * rng.unit();
        if rng.chance(0.5) {
            p.terminals.push((u, lambda, 0.0));
        } else {
            p.terminals.push((u, 0.0, lambda));
        }
    }
    let cut = min_cut(&p.cut_graph()).unwrap();
    let crossing = p
        .edges
        .iter()
        .filter(|e| left((e.0 % w, e.0 / w)) != left((e.1 % w, e.1 / w)))
        .count();
    assert!(
        crossing > h,
        "the curve is not straight ({crossing} crossing edges)"
    );
    for y in 0..h {
        for x in 0..w {
            assert_eq!(
                cut.source_side[x + w * y],
                left((x, y)),
                "node ({x}, {y}), curve at {}",
                b(y)
            );
        }
    }
    assert!(close(cut.value, p.dinics_value(), 1e-9));
}

#[test]
fn grids_with_crease_terms_match_dinics() {
    // Larger grids with random capacities and random-sign unary terms: many orphans.
    let mut rng = Rng::new(6);
    for &(w, h) in &[(20, 20), (50, 30), (64, 64)] {
        let mut p = grid(w, h, |_, _| 0.1 + rng.unit());
        tie_borders(&mut p, w, h);
        for u in 0..w * h {
            let lambda = 0.5 * rng.unit();
            if rng.chance(0.5) {
                p.terminals.push((u, lambda, 0.0));
            } else {
                p.terminals.push((u, 0.0, lambda));
            }
        }
        let mut solver = BkSolver::new();
        let cut = solver.solve(&p.cut_graph()).unwrap();
        check_consistent(&p, &cut, solver.flow());
        assert!(close(cut.value, p.dinics_value(), 1e-9), "{w}x{h}");
    }
}

#[test]
fn typed_errors() {
    let mut g = CutGraph::new(3);
    assert!(matches!(
        g.add_edge(0, 1, f64::NAN, 1.0),
        Err(MinCutError::InvalidCapacity {
            site: CapacitySite::Edge { u: 0, v: 1 },
            ..
        })
    ));
    assert!(matches!(
        g.add_edge(0, 1, 1.0, -1.0),
        Err(MinCutError::InvalidCapacity { .. })
    ));
    assert!(matches!(
        g.add_edge(2, 2, -0.5, 1.0),
        Err(MinCutError::InvalidCapacity { .. })
    ));
    assert!(matches!(
        g.add_terminal(1, f64::NAN, 0.0),
        Err(MinCutError::InvalidCapacity {
            site: CapacitySite::Source { node: 1 },
            ..
        })
    ));
    assert!(matches!(
        g.add_terminal(1, 0.0, -2.0),
        Err(MinCutError::InvalidCapacity {
            site: CapacitySite::Sink { node: 1 },
            ..
        })
    ));
    assert!(matches!(
        g.add_terminal(1, f64::NEG_INFINITY, 0.0),
        Err(MinCutError::InvalidCapacity { .. })
    ));
    assert!(matches!(
        g.add_edge(0, 3, 1.0, 1.0),
        Err(MinCutError::NodeOutOfRange {
            node: 3,
            node_count: 3
        })
    ));
    assert!(matches!(
        g.add_terminal(7, 1.0, 1.0),
        Err(MinCutError::NodeOutOfRange {
            node: 7,
            node_count: 3
        })
    ));
    assert!(matches!(
        g.terminal(3),
        Err(MinCutError::NodeOutOfRange { .. })
    ));
    assert!(matches!(
        g.cut_capacity(&[true]),
        Err(MinCutError::PartitionLength {
            len: 1,
            node_count: 3
        })
    ));
    // Rejected calls leave the graph unchanged.
    assert_eq!(g.edge_count(), 0);
    assert_eq!(g.terminal(1).unwrap(), (0.0, 0.0));
    let cut = min_cut(&g).unwrap();
    assert_eq!(cut.value, 0.0);
    // The error messages name the problem.
    let msg = CutGraph::new(1)
        .add_edge(0, 0, f64::NAN, 0.0)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("NaN"), "{msg}");
}

#[test]
fn infinite_cut_is_an_error() {
    // A node tied to both terminals.
    let mut g = CutGraph::new(2);
    g.add_terminal(1, f64::INFINITY, 0.0).unwrap();
    g.add_terminal(1, 0.0, f64::INFINITY).unwrap();
    assert!(matches!(min_cut(&g), Err(MinCutError::InfiniteCut)));
    // A chain of infinite edges between a hard source and a hard sink, with finite side paths.
    let mut g = CutGraph::new(5);
    g.add_terminal(0, f64::INFINITY, 1.0).unwrap();
    g.add_terminal(4, 1.0, f64::INFINITY).unwrap();
    for u in 0..4 {
        g.add_edge(u, u + 1, f64::INFINITY, 0.0).unwrap();
    }
    g.add_edge(0, 2, 3.0, 3.0).unwrap();
    assert!(matches!(min_cut(&g), Err(MinCutError::InfiniteCut)));
    // Infinite one way only, against the flow: finite.
    let mut g = CutGraph::new(2);
    g.add_terminal(0, f64::INFINITY, 0.0).unwrap();
    g.add_terminal(1, 0.0, f64::INFINITY).unwrap();
    g.add_edge(0, 1, 2.0, f64::INFINITY).unwrap();
    let cut = min_cut(&g).unwrap();
    assert_eq!((cut.value, cut.source_side), (2.0, vec![true, false]));
}

#[test]
fn degenerate_graphs() {
    // Empty graph.
    let cut = min_cut(&CutGraph::new(0)).unwrap();
    assert_eq!(cut.value, 0.0);
    assert!(cut.source_side.is_empty());
    // Isolated nodes and zero capacities: value 0, nothing is reachable from the source except
    // nodes with a positive source capacity.
    let mut g = CutGraph::new(4);
    g.add_edge(0, 1, 0.0, 0.0).unwrap();
    g.add_terminal(2, 0.0, 0.0).unwrap();
    g.add_terminal(3, 1.0, 0.0).unwrap();
    let cut = min_cut(&g).unwrap();
    assert_eq!(cut.value, 0.0);
    assert_eq!(cut.source_side, vec![false, false, false, true]);
    assert!(!cut.value.is_nan());
    // Self-loops are ignored, even infinite ones.
    let mut g = CutGraph::new(2);
    g.add_edge(0, 0, f64::INFINITY, f64::INFINITY).unwrap();
    g.add_edge(0, 1, 1.5, 1.5).unwrap();
    g.add_terminal(0, 10.0, 0.0).unwrap();
    g.add_terminal(1, 0.0, 10.0).unwrap();
    assert_eq!(g.edge_count(), 1);
    let cut = min_cut(&g).unwrap();
    assert_eq!((cut.value, cut.source_side), (1.5, vec![true, false]));
}

#[test]
fn parallel_edges_sum() {
    let mut rng = Rng::new(7);
    for _ in 0..50 {
        let n = rng.range(2, 30);
        let p = random_problem(&mut rng, n, true);
        // The same graph with every edge split into two parallel halves (integer / 2: exact).
        let mut split = p.clone();
        split.edges = p
            .edges
            .iter()
            .flat_map(|&(u, v, c, r)| [(u, v, c / 2.0, r / 2.0), (v, u, r / 2.0, c / 2.0)])
            .collect();
        let a = min_cut(&p.cut_graph()).unwrap();
        let b = min_cut(&split.cut_graph()).unwrap();
        assert_eq!(a, b);
    }
}

#[test]
fn deterministic_and_solver_reusable() {
    let mut rng = Rng::new(8);
    let p1 = random_problem(&mut rng, 150, false);
    let p2 = random_problem(&mut rng, 90, true);
    let fresh1 = min_cut(&p1.cut_graph()).unwrap();
    let fresh2 = min_cut(&p2.cut_graph()).unwrap();
    let mut solver = BkSolver::new();
    for _ in 0..3 {
        assert_eq!(solver.solve(&p1.cut_graph()).unwrap(), fresh1);
        assert_eq!(solver.solve(&p2.cut_graph()).unwrap(), fresh2);
    }
    // After an error, the solver still works.
    let mut bad = CutGraph::new(1);
    bad.add_terminal(0, f64::INFINITY, f64::INFINITY).unwrap();
    assert!(solver.solve(&bad).is_err());
    assert_eq!(solver.solve(&p1.cut_graph()).unwrap(), fresh1);
}

#[test]
fn from_petgraph_builds_symmetric_edges() {
    // Path a - b - c - d with weights 3, 1, 2: tying a to the source and d to the sink cuts b-c.
    let mut pg = UnGraph::<&str, f64>::new_undirected();
    let a = pg.add_node("a");
    let b = pg.add_node("b");
    let c = pg.add_node("c");
    let d = pg.add_node("d");
    pg.extend_with_edges([(a, b, 3.0), (b, c, 1.0), (c, d, 2.0)]);
    let mut g = CutGraph::from_petgraph(&pg, |&w| w);
    assert_eq!((g.node_count(), g.edge_count()), (4, 3));
    g.add_terminal(a.index(), f64::INFINITY, 0.0).unwrap();
    g.add_terminal(d.index(), 0.0, f64::INFINITY).unwrap();
    let cut = min_cut(&g).unwrap();
    assert_eq!(
        (cut.value, cut.source_side),
        (1.0, vec![true, true, false, false])
    );
    // Symmetric: tied the other way round, the same edge is cut.
    let mut g = CutGraph::from_petgraph(&pg, |&w| w);
    g.add_terminal(d.index(), f64::INFINITY, 0.0).unwrap();
    g.add_terminal(a.index(), 0.0, f64::INFINITY).unwrap();
    assert_eq!(
        min_cut(&g).unwrap().source_side,
        vec![false, false, true, true]
    );
    // An invalid capacity is reported by the solver (and at once by try_from_petgraph).
    pg.add_edge(a, c, f64::NAN);
    assert!(matches!(
        min_cut(&CutGraph::from_petgraph(&pg, |&w| w)),
        Err(MinCutError::InvalidCapacity { .. })
    ));
    assert!(CutGraph::try_from_petgraph(&pg, |&w| w).is_err());
}
