//! Minimum s-t cut / maximum flow on a vertex graph, for the crease cut of Brunel et al. 2021,
//! Sec. 6.
//!
//! The crease cut partitions the vertices of a shared self-contact region between its two sides
//! W1 and W2: a graph over the region's vertices with edge capacities (small along the crease),
//! terminal capacities (infinite on the vertices tied to W1 or W2, weak unary terms elsewhere),
//! solved in every frame where a joint folds into contact. `petgraph`'s `dinics` gives the flow but
//! not the cut and is far too slow for a per-frame solve (hundreds of milliseconds on a 10k-node
//! grid), so this module implements the augmenting-path algorithm of
//!
//! > Y. Boykov and V. Kolmogorov, *An Experimental Comparison of Min-Cut/Max-Flow Algorithms for
//! > Energy Minimization in Vision*, IEEE TPAMI 26(9), 2004,
//!
//! which grows two search trees, one from the source and one from the sink, and reuses them from
//! one augmentation to the next. See [`bk`] for the algorithm and its data structures.
//!
//! Usage: build a [`CutGraph`] (by hand, or from a `petgraph` graph with
//! [`CutGraph::from_petgraph`]), then call [`min_cut`] (one call) or keep a [`BkSolver`] to reuse
//! its buffers from frame to frame.
//!
//! ```
//! use contact_skin::mincut::{min_cut, CutGraph};
//!
//! // 0 -- 1 -- 2, node 0 tied to the source, node 2 to the sink, the weak edge is 1-2.
//! let mut g = CutGraph::new(3);
//! g.add_edge(0, 1, 3.0, 3.0)?;
//! g.add_edge(1, 2, 1.0, 1.0)?;
//! g.add_terminal(0, f64::INFINITY, 0.0)?;
//! g.add_terminal(2, 0.0, f64::INFINITY)?;
//! let cut = min_cut(&g)?;
//! assert_eq!(cut.value, 1.0);
//! assert_eq!(cut.source_side, vec![true, true, false]);
//! # Ok::<(), contact_skin::mincut::MinCutError>(())
//! ```
//!
//! **Ties.** When several minimum cuts exist, the returned source side is the set of nodes
//! reachable from the source in the residual graph of a maximum flow. That set is the same for
//! every maximum flow, and it is the smallest (inclusion-wise) source side among all minimum
//! cuts, so the result does not depend on the order of the augmentations. The solver visits nodes
//! and arcs in index and insertion order only (no hashing): the same input gives the same output.
//! Reachability is decided on the computed (floating-point) residuals: with exactly representable
//! capacities (small integers, dyadic fractions) the rule is exact; otherwise two cuts whose
//! values differ only by rounding may be told apart either way.
//!
//! **Cost.** On 4-connected crease-like grids (hard terminals on two opposite borders, weak unary
//! terms everywhere; `benches/mincut.rs`) a solve took about 1 ms at 1k nodes, 4-6 ms at 10k and
//! 14-20 ms at 50k on one core of the shared 2-core test machine, against 0.45-0.6 s for
//! `petgraph::algo::dinics` at 10k. Boykov-Kolmogorov has no polynomial bound better than
//! `O(mn²|C|)` (|C| the cut value, integer capacities), but on such graphs it is near linear.

pub mod bk;
mod graph;

pub use bk::BkSolver;
pub use graph::CutGraph;

use std::fmt;

/// A minimum s-t cut.
#[derive(Debug, Clone, PartialEq)]
pub struct MinCut {
    /// Capacity of the cut, recomputed from the original capacities of the graph: the sum of the
    /// capacities of the edges u -> v with u on the source side and v on the sink side, plus the
    /// sink capacities of the source-side nodes and the source capacities of the sink-side nodes.
    /// Equals the maximum flow.
    pub value: f64,
    /// One entry per node (`node_count` long): `true` = source side. This is the smallest source
    /// side among all minimum cuts (the nodes reachable from the source in the residual graph).
    pub source_side: Vec<bool>,
}

/// Where an invalid capacity was given.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CapacitySite {
    /// The capacity of the edge `u -> v` (or of its reverse `v -> u`).
    Edge {
        /// First end, as passed to [`CutGraph::add_edge`].
        u: usize,
        /// Second end.
        v: usize,
    },
    /// The capacity from the source to `node`.
    Source {
        /// The node.
        node: usize,
    },
    /// The capacity from `node` to the sink.
    Sink {
        /// The node.
        node: usize,
    },
}

impl fmt::Display for CapacitySite {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CapacitySite::Edge { u, v } => write!(f, "edge {u}-{v}"),
            CapacitySite::Source { node } => write!(f, "source -> {node}"),
            CapacitySite::Sink { node } => write!(f, "{node} -> sink"),
        }
    }
}

/// Errors of the min-cut module.
#[derive(Debug, Clone, thiserror::Error)]
pub enum MinCutError {
    /// A node index is not below the number of nodes of the graph.
    #[error("node {node} is out of range (the graph has {node_count} nodes)")]
    NodeOutOfRange {
        /// The offending index.
        node: usize,
        /// Number of nodes of the graph.
        node_count: usize,
    },
    /// A capacity is NaN or negative (`+inf` is allowed).
    #[error("capacity {value} of {site} is invalid (NaN or negative)")]
    InvalidCapacity {
        /// Where it was given.
        site: CapacitySite,
        /// The offending value.
        value: f64,
    },
    /// A path of infinite capacity joins the source and the sink: every cut is infinite.
    #[error("a path of infinite capacity joins the source and the sink")]
    InfiniteCut,
    /// The graph has more nodes or arcs than the solver's 32-bit indices can address.
    #[error("graph too large: {nodes} nodes, {arcs} arcs (at most {max} each)")]
    TooLarge {
        /// Number of nodes.
        nodes: usize,
        /// Number of arcs (two per edge).
        arcs: usize,
        /// The limit.
        max: usize,
    },
    /// A partition passed to [`CutGraph::cut_capacity`] does not have one entry per node.
    #[error("partition has {len} entries for a graph of {node_count} nodes")]
    PartitionLength {
        /// Length of the partition.
        len: usize,
        /// Number of nodes of the graph.
        node_count: usize,
    },
}

/// Minimum s-t cut of `g` by the Boykov-Kolmogorov algorithm (see the [module](self) docs for
/// the tie rule). Does not modify `g`; builds a fresh [`BkSolver`] (keep one and call
/// [`BkSolver::solve`] to reuse its buffers).
///
/// Errors: the first invalid capacity recorded by [`CutGraph::from_petgraph`],
/// [`MinCutError::InfiniteCut`] if a path of infinite capacity joins the terminals,
/// [`MinCutError::TooLarge`] beyond 32-bit indices.
pub fn min_cut(g: &CutGraph) -> Result<MinCut, MinCutError> {
    BkSolver::new().solve(g)
}
