//! The crease partition of a shared region (2021 Sec. 6 "Crease detection & Partitioning",
//! `PIPELINE.md` "Self-contact: crease cut"), computed in every frame where the shared region
//! folds into contact.
//!
//! A graph over the vertices of the shared region `R`, solved by min-cut (Boykov-Kolmogorov,
//! [`crate::mincut`]):
//! - terminals: vertices of `R` adjacent to `W1 \ R` are tied to W1 (source), those adjacent to
//!   `W2 \ R` to W2 (sink), with infinite capacity;
//! - edges: `c_ij = ℓ*_ij (0.1 + min_{x ∈ ij} |n(x)·d̂|)`, so the cut runs along the silhouette
//!   of `R` seen from `d̂`; `ℓ*_ij` is the length of the dual edge (barycentric: from the edge
//!   midpoint to the centroids of its faces, always positive), so the balance does not depend on
//!   the resolution. With `n` interpolated linearly along the edge, the minimum is 0 when the
//!   sign of `n·d̂` changes, else the smaller end value;
//! - vertex terms: on the vertices of intersecting faces and those of `R` inside the other
//!   part (the fold's choice, see `fold::with_buried`), plus one ring,
//!   `λ_I A_i |n_i·d̂|` toward the side given by `sign(n_i·d̂)` (`+` means W1, as `d̂` is W1's
//!   outward direction at the fold); elsewhere `λ_β A_i |2β_i - 1|` toward the side `β`
//!   prefers; both `λ` scale as `1 / ℓ̄` (mean edge length).
//!
//! After the cut, only the components attached to each side's terminals are kept; stray
//! components switch sides.

use crate::mincut::{min_cut, CutGraph, MinCutError};
use nalgebra::{Point3, Vector3};
use petgraph::unionfind::UnionFind;

/// Weights of the crease graph.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CreaseParams {
    /// `λ_I ℓ̄`: weight of the intersection vertex terms.
    pub intersection_weight: f64,
    /// `λ_β ℓ̄`: weight of the partition-of-unity terms.
    pub beta_weight: f64,
}

impl Default for CreaseParams {
    fn default() -> Self {
        Self {
            intersection_weight: 1.0,
            beta_weight: 0.2,
        }
    }
}

/// Inputs of one crease cut (all arrays per mesh vertex unless said otherwise).
pub struct CreaseInput<'a> {
    /// Positions of the frame.
    pub positions: &'a [Point3<f64>],
    /// Unit normals of the frame.
    pub normals: &'a [Vector3<f64>],
    /// Mesh triangles.
    pub triangles: &'a [[u32; 3]],
    /// Faces of `W1 ∪ W2` (ids into `triangles`).
    pub faces: &'a [u32],
    /// Vertex in W1 / in W2.
    pub w1: &'a [bool],
    /// Vertex in W2.
    pub w2: &'a [bool],
    /// Partition of unity (1 on W1's side).
    pub beta: &'a [f64],
    /// `d̂_12`, W1's outward direction.
    pub direction: Vector3<f64>,
    /// Vertices that get the intersection terms: those of intersecting faces (and, in the
    /// fold, those of `R` inside the other part).
    pub intersecting: &'a [u32],
    /// The precomputed edges of `faces` (recomputed when `None`).
    pub topology: Option<&'a CreaseTopology>,
}

/// The partition of the shared region.
#[derive(Clone, Debug, PartialEq)]
pub struct Crease {
    /// Per mesh vertex of `W1 ∪ W2`: on W1's side (`W1' = W1 \ R ∪ {R on W1's side}`).
    pub on_w1: Vec<bool>,
    /// Cut value.
    pub value: f64,
    /// Vertices of `R` that switched side because their component was not attached to
    /// their side's terminals.
    pub stray: usize,
}

/// Cuts the shared region (see the module doc).
pub fn crease_cut(input: &CreaseInput, params: &CreaseParams) -> Result<Crease, MinCutError> {
    let n = input.positions.len();
    let shared: Vec<bool> = (0..n).map(|v| input.w1[v] && input.w2[v]).collect();
    let verts: Vec<u32> = (0..n as u32).filter(|&v| shared[v as usize]).collect();
    let mut node = vec![u32::MAX; n];
    for (k, &v) in verts.iter().enumerate() {
        node[v as usize] = k as u32;
    }
    let edges = region_edges(input);
    let mut g = CutGraph::new(verts.len());
    add_edges(&mut g, input, &edges, &shared, &node)?;
    let computed;
    let borders = match precomputed(input) {
        Some(topo) => topo.borders.as_slice(),
        None => {
            computed = border_flags(edges.iter().map(|e| e.ends), input.w1, input.w2);
            computed.as_slice()
        }
    };
    let terms = VertexTerms {
        area: vertex_areas(input),
        near_intersection: ring(input, &edges, input.intersecting),
        mean_edge: mean_length(input.positions, &edges).max(1e-300),
        borders,
    };
    for (k, &v) in verts.iter().enumerate() {
        let (src, snk) = terms.of(input, params, v as usize);
        g.add_terminal(k, src, snk)?;
    }
    let cut = min_cut(&g)?;
    let mut on_w1: Vec<bool> = (0..n).map(|v| input.w1[v] && !input.w2[v]).collect();
    for (k, &v) in verts.iter().enumerate() {
        on_w1[v as usize] = cut.source_side[k];
    }
    let stray = keep_attached(input, &edges, &shared, &mut on_w1);
    Ok(Crease {
        on_w1,
        value: cut.value,
        stray,
    })
}

/// Adds the edges inside `R` with capacity `ℓ*_ij (0.1 + min |n·d̂|)` both ways.
fn add_edges(
    g: &mut CutGraph,
    input: &CreaseInput,
    edges: &[Edge],
    shared: &[bool],
    node: &[u32],
) -> Result<(), MinCutError> {
    for e in edges {
        let [a, b] = e.ends;
        if shared[a as usize] && shared[b as usize] {
            let cap = e.dual * (0.1 + min_facing(input, a, b));
            g.add_edge(
                node[a as usize] as usize,
                node[b as usize] as usize,
                cap,
                cap,
            )?;
        }
    }
    Ok(())
}

/// Per mesh vertex: whether it is a vertex of `R = W1 ∩ W2` adjacent over `edges` to
/// `W1 \ R`, and to `W2 \ R` (the terminals of the cut, and the borders where `σ` is ±1).
fn border_flags(
    edges: impl IntoIterator<Item = [u32; 2]>,
    w1: &[bool],
    w2: &[bool],
) -> Vec<(bool, bool)> {
    let shared = |v: u32| w1[v as usize] && w2[v as usize];
    let mut borders = vec![(false, false); w1.len()];
    for [a, b] in edges {
        for (s, o) in [(a, b), (b, a)] {
            if shared(s) && !shared(o) {
                borders[s as usize].0 |= w1[o as usize];
                borders[s as usize].1 |= w2[o as usize];
            }
        }
    }
    borders
}

/// Barycentric vertex areas over the faces of `W1 ∪ W2`.
fn vertex_areas(input: &CreaseInput) -> Vec<f64> {
    let mut area = vec![0.0; input.positions.len()];
    for &f in input.faces {
        let t = input.triangles[f as usize];
        let [a, b, c] = t.map(|v| input.positions[v as usize]);
        let third = (b - a).cross(&(c - a)).norm() / 6.0;
        for v in t {
            area[v as usize] += third;
        }
    }
    area
}

/// What the terminal capacities of a vertex of `R` depend on.
struct VertexTerms<'a> {
    area: Vec<f64>,
    near_intersection: Vec<bool>,
    mean_edge: f64,
    /// Per mesh vertex: adjacent to `W1 \ R`, to `W2 \ R` ([`border_flags`]).
    borders: &'a [(bool, bool)],
}

impl VertexTerms<'_> {
    /// `(source, sink)` capacities of vertex `v` of `R`: infinite toward the only side it
    /// borders; else the intersection term near the intersection, the `β` term elsewhere.
    fn of(&self, input: &CreaseInput, params: &CreaseParams, v: usize) -> (f64, f64) {
        let toward = |w1: bool, w: f64| if w1 { (w, 0.0) } else { (0.0, w) };
        match self.borders[v] {
            (true, false) => (f64::INFINITY, 0.0),
            (false, true) => (0.0, f64::INFINITY),
            _ if self.near_intersection[v] => {
                let g = input.normals[v].dot(&input.direction);
                let w = params.intersection_weight / self.mean_edge * self.area[v] * g.abs();
                toward(g > 0.0, w)
            }
            _ => {
                let b = input.beta[v].clamp(0.0, 1.0);
                let w = params.beta_weight / self.mean_edge * self.area[v] * (2.0 * b - 1.0).abs();
                toward(b > 0.5, w)
            }
        }
    }
}

/// An edge of `W1 ∪ W2` with its dual length.
struct Edge {
    ends: [u32; 2],
    dual: f64,
}

/// The edges of the faces of `W1 ∪ W2` and the borders of `R` (topology only: precomputed
/// once per joint pair).
#[derive(Clone, Debug, Default)]
pub struct CreaseTopology {
    edges: Vec<[u32; 2]>,
    /// Per face of the input list: its three edges, in corner order `(k, k + 1)`.
    face_edges: Vec<[u32; 3]>,
    /// Per mesh vertex: a vertex of `R` next to `W1 \ R`, next to `W2 \ R`.
    borders: Vec<(bool, bool)>,
}

impl CreaseTopology {
    /// The edges of `faces` (ids into `triangles`: the faces of `W1 ∪ W2`), sorted, and the
    /// borders of `R` over them (`w1`, `w2`: per mesh vertex, in W1, in W2).
    pub fn new(triangles: &[[u32; 3]], faces: &[u32], w1: &[bool], w2: &[bool]) -> Self {
        let key = |a: u32, b: u32| [a.min(b), a.max(b)];
        let mut edges: Vec<[u32; 2]> = faces
            .iter()
            .flat_map(|&f| {
                let t = triangles[f as usize];
                (0..3).map(move |k| key(t[k], t[(k + 1) % 3]))
            })
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let id = |e: [u32; 2]| edges.binary_search(&e).map_or(0, |i| i as u32);
        let face_edges = faces
            .iter()
            .map(|&f| {
                let t = triangles[f as usize];
                std::array::from_fn(|k| id(key(t[k], t[(k + 1) % 3])))
            })
            .collect();
        let borders = border_flags(edges.iter().copied(), w1, w2);
        Self {
            edges,
            face_edges,
            borders,
        }
    }

    /// Per mesh vertex: whether it is a vertex of `R` next to `W1 \ R`, and next to `W2 \ R`
    /// (over the edges of `W1 ∪ W2`).
    pub fn borders(&self) -> &[(bool, bool)] {
        &self.borders
    }
}

/// The input's precomputed topology when it fits the input (same faces and vertices).
fn precomputed<'a>(input: &CreaseInput<'a>) -> Option<&'a CreaseTopology> {
    input.topology.filter(|t| {
        t.face_edges.len() == input.faces.len() && t.borders.len() == input.positions.len()
    })
}

/// Edges of the faces of `W1 ∪ W2`, each with its barycentric dual length.
fn region_edges(input: &CreaseInput) -> Vec<Edge> {
    if let Some(topo) = precomputed(input) {
        let mut dual = vec![0.0; topo.edges.len()];
        for (&f, fe) in input.faces.iter().zip(&topo.face_edges) {
            let t = input.triangles[f as usize];
            let p = t.map(|v| input.positions[v as usize].coords);
            let centroid = (p[0] + p[1] + p[2]) / 3.0;
            for k in 0..3 {
                let mid = (p[k] + p[(k + 1) % 3]) * 0.5;
                dual[fe[k] as usize] += (centroid - mid).norm();
            }
        }
        return topo
            .edges
            .iter()
            .zip(dual)
            .map(|(&ends, dual)| Edge { ends, dual })
            .collect();
    }
    let mut map: std::collections::BTreeMap<(u32, u32), f64> = std::collections::BTreeMap::new();
    for &f in input.faces {
        let t = input.triangles[f as usize];
        let centroid = Point3::from(
            t.iter()
                .map(|&v| input.positions[v as usize].coords)
                .sum::<Vector3<f64>>()
                / 3.0,
        );
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let mid = Point3::from(
                (input.positions[a as usize].coords + input.positions[b as usize].coords) * 0.5,
            );
            *map.entry((a.min(b), a.max(b))).or_insert(0.0) += (centroid - mid).norm();
        }
    }
    map.into_iter()
        .map(|((a, b), dual)| Edge { ends: [a, b], dual })
        .collect()
}

fn mean_length(positions: &[Point3<f64>], edges: &[Edge]) -> f64 {
    let sum: f64 = edges
        .iter()
        .map(|e| (positions[e.ends[0] as usize] - positions[e.ends[1] as usize]).norm())
        .sum();
    sum / edges.len().max(1) as f64
}

/// `min_{x ∈ ab} |n(x)·d̂|` with `n` interpolated linearly.
fn min_facing(input: &CreaseInput, a: u32, b: u32) -> f64 {
    let (ga, gb) = (
        input.normals[a as usize].dot(&input.direction),
        input.normals[b as usize].dot(&input.direction),
    );
    if ga * gb <= 0.0 {
        0.0
    } else {
        ga.abs().min(gb.abs())
    }
}

/// The given vertices and their one-ring.
fn ring(input: &CreaseInput, edges: &[Edge], seeds: &[u32]) -> Vec<bool> {
    let mut mark = vec![false; input.positions.len()];
    for &v in seeds {
        if let Some(m) = mark.get_mut(v as usize) {
            *m = true;
        }
    }
    let seeded = mark.clone();
    for e in edges {
        let [a, b] = e.ends;
        if seeded[a as usize] || seeded[b as usize] {
            mark[a as usize] = true;
            mark[b as usize] = true;
        }
    }
    mark
}

/// Keeps only the components of each side attached to that side's part outside `R`; other
/// components switch. Returns the number of switched vertices.
fn keep_attached(
    input: &CreaseInput,
    edges: &[Edge],
    shared: &[bool],
    on_w1: &mut [bool],
) -> usize {
    // Components of same-side edges (union-find), attached when they hold a vertex of
    // `W1 ∪ W2` outside `R`.
    let n = on_w1.len();
    let mut components = UnionFind::<u32>::new(n);
    for e in edges {
        let [a, b] = e.ends;
        if on_w1[a as usize] == on_w1[b as usize] {
            components.union(a, b);
        }
    }
    let mut attached = vec![false; n];
    for v in 0..n as u32 {
        if (input.w1[v as usize] || input.w2[v as usize]) && !shared[v as usize] {
            attached[components.find_mut(v) as usize] = true;
        }
    }
    let mut switched = 0;
    for v in 0..n {
        if shared[v] && !attached[components.find_mut(v as u32) as usize] {
            on_w1[v] = !on_w1[v];
            switched += 1;
        }
    }
    switched
}
