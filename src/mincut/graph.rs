//! The input of a cut: nodes, edges with a capacity in each direction, terminal capacities.

use super::{CapacitySite, MinCutError};
use petgraph::graph::UnGraph;

/// One edge as given: capacity `u -> v` is `cap`, `v -> u` is `rev_cap`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Edge {
    pub(crate) u: usize,
    pub(crate) v: usize,
    pub(crate) cap: f64,
    pub(crate) rev_cap: f64,
}

/// Graph with `n` nodes, directed edge capacities (an undirected edge is one with equal
/// capacities both ways) and terminal capacities from the source and to the sink.
///
/// This is a plain edge list plus two per-node arrays (`source_cap[u]`, `sink_cap[u]`, each
/// `n` long, accumulated by [`add_terminal`](Self::add_terminal)); the solver builds its own
/// compact adjacency from it (see [`super::bk`]). Self-loops are accepted and ignored (they
/// never cross a cut); parallel edges are kept as given, which is the same as one edge with the
/// summed capacities; edges with zero capacity both ways are dropped. Capacities must be `>= 0`
/// and not NaN; `f64::INFINITY` is allowed (a hard constraint).
#[derive(Debug, Clone, Default)]
pub struct CutGraph {
    n: usize,
    edges: Vec<Edge>,
    source_cap: Vec<f64>,
    sink_cap: Vec<f64>,
    /// First invalid capacity met by [`from_petgraph`](Self::from_petgraph), which cannot return
    /// an error; reported by [`validate`](Self::validate) and so by the solver.
    deferred: Option<MinCutError>,
}

/// `Ok` if `c` is a valid capacity (not NaN, `>= 0`, `+inf` allowed).
fn check_capacity(c: f64, site: CapacitySite) -> Result<(), MinCutError> {
    if c >= 0.0 {
        Ok(())
    } else {
        Err(MinCutError::InvalidCapacity { site, value: c })
    }
}

impl CutGraph {
    /// A graph with `n` nodes, no edges and zero terminal capacities.
    pub fn new(n: usize) -> Self {
        CutGraph {
            n,
            edges: Vec::new(),
            source_cap: vec![0.0; n],
            sink_cap: vec![0.0; n],
            deferred: None,
        }
    }

    /// A graph with the nodes and edges of an undirected `petgraph` graph (node `i` of the
    /// result is `NodeIndex(i)`), each edge with capacity `capacity(weight)` both ways. Terminal
    /// capacities start at zero.
    ///
    /// This constructor cannot fail: an invalid capacity (NaN, negative) is recorded and
    /// reported by [`validate`](Self::validate) and by the solver. Use
    /// [`try_from_petgraph`](Self::try_from_petgraph) to get the error at once.
    pub fn from_petgraph<N, E>(g: &UnGraph<N, E>, capacity: impl Fn(&E) -> f64) -> Self {
        let mut cut = CutGraph::new(g.node_count());
        cut.edges.reserve(g.edge_count());
        for e in g.raw_edges() {
            let c = capacity(&e.weight);
            if let Err(err) = cut.add_edge(e.source().index(), e.target().index(), c, c) {
                cut.deferred.get_or_insert(err);
            }
        }
        cut
    }

    /// [`from_petgraph`](Self::from_petgraph), failing on the first invalid capacity.
    pub fn try_from_petgraph<N, E>(
        g: &UnGraph<N, E>,
        capacity: impl Fn(&E) -> f64,
    ) -> Result<Self, MinCutError> {
        let cut = Self::from_petgraph(g, capacity);
        cut.validate()?;
        Ok(cut)
    }

    /// Adds an edge with capacity `u -> v` = `cap` and `v -> u` = `rev_cap` (both `>= 0`,
    /// finite or `f64::INFINITY`). Self-loops are checked, then ignored.
    pub fn add_edge(
        &mut self,
        u: usize,
        v: usize,
        cap: f64,
        rev_cap: f64,
    ) -> Result<(), MinCutError> {
        self.check_node(u)?;
        self.check_node(v)?;
        check_capacity(cap, CapacitySite::Edge { u, v })?;
        check_capacity(rev_cap, CapacitySite::Edge { u, v })?;
        if u != v && (cap > 0.0 || rev_cap > 0.0) {
            self.edges.push(Edge { u, v, cap, rev_cap });
        }
        Ok(())
    }

    /// Adds `source_cap` to the capacity from the source to `u` and `sink_cap` to the capacity
    /// from `u` to the sink (accumulated over calls; `f64::INFINITY` ties `u` to that terminal).
    pub fn add_terminal(
        &mut self,
        u: usize,
        source_cap: f64,
        sink_cap: f64,
    ) -> Result<(), MinCutError> {
        self.check_node(u)?;
        check_capacity(source_cap, CapacitySite::Source { node: u })?;
        check_capacity(sink_cap, CapacitySite::Sink { node: u })?;
        self.source_cap[u] += source_cap;
        self.sink_cap[u] += sink_cap;
        Ok(())
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.n
    }

    /// Number of stored edges (self-loops and edges of zero capacity both ways are not stored).
    pub fn edge_count(&self) -> usize {
        self.edges.len()
    }

    /// `(source capacity, sink capacity)` of node `u`, accumulated.
    pub fn terminal(&self, u: usize) -> Result<(f64, f64), MinCutError> {
        self.check_node(u)?;
        Ok((self.source_cap[u], self.sink_cap[u]))
    }

    /// `Err` with the first invalid capacity recorded by [`from_petgraph`](Self::from_petgraph).
    pub fn validate(&self) -> Result<(), MinCutError> {
        match &self.deferred {
            Some(err) => Err(err.clone()),
            None => Ok(()),
        }
    }

    /// Capacity of the cut whose source side is `source_side` (one entry per node): the sum of
    /// the capacities of the edges from the source side to the sink side, of the sink capacities
    /// of the source-side nodes and of the source capacities of the sink-side nodes.
    pub fn cut_capacity(&self, source_side: &[bool]) -> Result<f64, MinCutError> {
        if source_side.len() != self.n {
            return Err(MinCutError::PartitionLength {
                len: source_side.len(),
                node_count: self.n,
            });
        }
        let terminals: f64 = source_side
            .iter()
            .zip(self.source_cap.iter().zip(&self.sink_cap))
            .map(|(&s, (&to_source, &to_sink))| if s { to_sink } else { to_source })
            .sum();
        let edges: f64 = self
            .edges
            .iter()
            .map(|e| match (source_side[e.u], source_side[e.v]) {
                (true, false) => e.cap,
                (false, true) => e.rev_cap,
                _ => 0.0,
            })
            .sum();
        Ok(terminals + edges)
    }

    /// The stored edges, in insertion order.
    pub(crate) fn edges(&self) -> &[Edge] {
        &self.edges
    }

    /// Per-node capacities from the source and to the sink.
    pub(crate) fn terminal_caps(&self) -> (&[f64], &[f64]) {
        (&self.source_cap, &self.sink_cap)
    }

    fn check_node(&self, node: usize) -> Result<(), MinCutError> {
        if node < self.n {
            Ok(())
        } else {
            Err(MinCutError::NodeOutOfRange {
                node,
                node_count: self.n,
            })
        }
    }
}
