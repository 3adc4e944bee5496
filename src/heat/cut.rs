//! The cut mesh: a region with the source curve's points inserted on its edges (see the
//! module doc of [`crate::heat`]).

use crate::mesh::operators::FaceGeometry;
use crate::mesh::Queued;
use crate::mesh::Region;
use crate::solve::{SolveError, SpdPattern};
use nalgebra::Point3;
use petgraph::unionfind::UnionFind;
use std::collections::{BinaryHeap, HashMap};

/// Smallest and largest edge parameter of an inserted point (`PIPELINE.md`): keeps the cut
/// sub-triangles away from zero area.
pub const ALPHA_CLAMP: f64 = 1e-3;

/// A point on a region edge: `(1 - α) p[e0] + α p[e1]`, `e0 < e1` the edge's local vertices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgePoint {
    /// Local edge index in the region.
    pub edge: u32,
    /// Parameter from the edge's first vertex.
    pub alpha: f64,
}

/// The Dirichlet boundary of a cut: which vertices lie inside the source region `C`, the exact
/// points of `∂C` on the edges joining inside and outside vertices, and vertices that are
/// Dirichlet nodes themselves (point sources).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Boundary {
    /// Per local vertex: inside `C` (removed from the domain).
    pub inside: Vec<bool>,
    /// One point on every edge with exactly one inside vertex.
    pub points: Vec<EdgePoint>,
    /// Local vertices held at a prescribed value.
    pub vertices: Vec<u32>,
}

impl Boundary {
    /// A point source at the given vertices (no cut).
    pub fn vertices(vertex_count: usize, vertices: Vec<u32>) -> Self {
        Self {
            inside: vec![false; vertex_count],
            points: Vec::new(),
            vertices,
        }
    }

    /// The zero level set of a per-vertex function: inside where `f < 0`, points where `f`
    /// changes sign along an edge (linear interpolation).
    pub fn from_level_set(region: &Region, f: &[f64]) -> Self {
        let inside: Vec<bool> = f.iter().map(|&x| x < 0.0).collect();
        let points = region
            .edges
            .iter()
            .enumerate()
            .filter(|(_, e)| inside[e[0] as usize] != inside[e[1] as usize])
            .map(|(i, e)| {
                let (a, b) = (f[e[0] as usize], f[e[1] as usize]);
                EdgePoint {
                    edge: i as u32,
                    alpha: a / (a - b),
                }
            })
            .collect();
        Self {
            inside,
            points,
            vertices: Vec::new(),
        }
    }

    /// Number of Dirichlet values a problem on this boundary takes.
    pub fn dirichlet_count(&self) -> usize {
        self.points.len() + self.vertices.len()
    }
}

/// Why a cut or a solve could not be done.
#[derive(Debug, thiserror::Error)]
pub enum HeatError {
    /// The boundary does not match the region.
    #[error("inconsistent boundary: {0}")]
    InconsistentBoundary(String),
    /// Wrong number of Dirichlet values.
    #[error("{got} Dirichlet values given, {expected} expected")]
    ValueCount {
        /// Expected.
        expected: usize,
        /// Given.
        got: usize,
    },
    /// The region has no usable edge (zero mean edge length).
    #[error("degenerate region: zero mean edge length")]
    DegenerateRegion,
    /// A factorization failed.
    #[error(transparent)]
    Solve(#[from] SolveError),
    /// A bug: an invariant of this module was broken.
    #[error("internal error: {0}")]
    Internal(&'static str),
}

/// Role of a region vertex in the cut problem.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Free,
    Dirichlet(u32),
    Inside,
}

/// The region with `∂C` inserted: sub-triangles of the outside part and the assembled
/// operators. Nodes `0..n` are the region's vertices, nodes `n + k` the boundary points.
#[derive(Clone, Debug)]
pub struct CutMesh {
    n: usize,
    /// Positions of all nodes (vertices, then boundary points).
    pub nodes: Vec<Point3<f64>>,
    /// Outside (sub-)triangles in node indices.
    pub triangles: Vec<[u32; 3]>,
    /// Geometry of each sub-triangle.
    pub geometry: Vec<crate::mesh::operators::FaceGeometry>,
    /// Region face each sub-triangle comes from.
    pub parent: Vec<u32>,
    role: Vec<Role>,
    dirichlet_count: usize,
    mass: Vec<f64>,
    stiffness: Vec<f64>,
    couplings: Vec<(u32, u32, f64)>,
    /// Free vertices that no Dirichlet node reaches.
    pub unreached: Vec<bool>,
    /// Mean edge length of the region in this frame (`h_W`).
    pub mean_edge_length: f64,
}

impl CutMesh {
    /// Cuts `region` (at local `positions`) along `boundary` and assembles `K` and `M`.
    pub fn new(
        region: &Region,
        positions: &[Point3<f64>],
        boundary: &Boundary,
    ) -> Result<Self, HeatError> {
        let n = region.vertex_count();
        if positions.len() != n || boundary.inside.len() != n {
            return Err(HeatError::InconsistentBoundary(format!(
                "{} positions and {} inside flags for {n} vertices",
                positions.len(),
                boundary.inside.len()
            )));
        }
        let role = roles(n, boundary)?;
        let point_node = point_nodes(region, boundary)?;
        let mut nodes = positions.to_vec();
        for p in &boundary.points {
            let e = region.edges[p.edge as usize];
            let a = p.alpha.clamp(ALPHA_CLAMP, 1.0 - ALPHA_CLAMP);
            nodes.push(
                positions[e[0] as usize]
                    + (positions[e[1] as usize] - positions[e[0] as usize]) * a,
            );
        }
        // About one piece per face (kept, dropped, or split in two where the boundary cuts off
        // a corner).
        let pieces = region.triangles.len() + boundary.points.len();
        let mut mesh = Self {
            n,
            nodes,
            triangles: Vec::with_capacity(pieces),
            geometry: Vec::with_capacity(pieces),
            parent: Vec::with_capacity(pieces),
            role,
            dirichlet_count: boundary.dirichlet_count(),
            mass: vec![0.0; n],
            stiffness: Vec::new(),
            couplings: Vec::new(),
            unreached: vec![false; n],
            mean_edge_length: crate::mesh::operators::mean_edge_length(
                positions,
                &region.triangles,
            ),
        };
        for (f, t) in region.triangles.iter().enumerate() {
            mesh.cut_face(f as u32, *t, &boundary.inside, &point_node, region)?;
        }
        mesh.assemble(region);
        mesh.find_unreached(region);
        Ok(mesh)
    }

    fn cut_face(
        &mut self,
        f: u32,
        t: [u32; 3],
        inside: &[bool],
        point_node: &HashMap<u32, u32>,
        region: &Region,
    ) -> Result<(), HeatError> {
        let flags = t.map(|v| inside[v as usize]);
        let count = flags.iter().filter(|&&x| x).count();
        if count == 0 {
            self.push(f, t);
            return Ok(());
        }
        if count == 3 {
            return Ok(());
        }
        // Rotate so that corner `a` is the odd one out (the only inside or only outside corner).
        let odd = (0..3)
            .find(|&k| flags[k] == (count == 1))
            .ok_or(HeatError::Internal("odd corner"))?;
        let (a, b, c) = (t[odd], t[(odd + 1) % 3], t[(odd + 2) % 3]);
        let node = |u: u32, v: u32| -> Result<u32, HeatError> {
            let e = region.edge(u, v).ok_or(HeatError::Internal("face edge"))?;
            point_node.get(&e).copied().ok_or_else(|| {
                HeatError::InconsistentBoundary(format!("no boundary point on crossed edge {e}"))
            })
        };
        let (pab, pca) = (node(a, b)?, node(c, a)?);
        if count == 2 {
            self.push(f, [a, pab, pca]);
        } else {
            let d1 = (self.nodes[pab as usize] - self.nodes[c as usize]).norm();
            let d2 = (self.nodes[b as usize] - self.nodes[pca as usize]).norm();
            if d1 <= d2 {
                self.push(f, [pab, b, c]);
                self.push(f, [pab, c, pca]);
            } else {
                self.push(f, [b, c, pca]);
                self.push(f, [b, pca, pab]);
            }
        }
        Ok(())
    }

    fn push(&mut self, parent: u32, t: [u32; 3]) {
        self.geometry
            .push(FaceGeometry::new(t.map(|i| self.nodes[i as usize])));
        self.triangles.push(t);
        self.parent.push(parent);
    }

    /// Dirichlet index of a node, if it is a Dirichlet node.
    fn dirichlet_of(&self, node: u32) -> Option<u32> {
        if node as usize >= self.n {
            return Some(node - self.n as u32);
        }
        match self.role[node as usize] {
            Role::Dirichlet(k) => Some(k),
            _ => None,
        }
    }

    /// Assembles the free-vertex stiffness (pattern slots), the couplings to Dirichlet nodes
    /// and the lumped mass.
    fn assemble(&mut self, region: &Region) {
        let n = self.n;
        let mut k = vec![0.0; n + region.edges.len()];
        for ((t, g), &parent) in self.triangles.iter().zip(&self.geometry).zip(&self.parent) {
            let original = region.triangles[parent as usize];
            let edges = region.face_edges[parent as usize];
            for i in 0..3 {
                let vi = t[i];
                if (vi as usize) < n && self.role[vi as usize] == Role::Free {
                    self.mass[vi as usize] += g.area / 3.0;
                }
                for (j, &vj) in t.iter().enumerate() {
                    if i == j || vi as usize >= n || self.role[vi as usize] != Role::Free {
                        continue;
                    }
                    let w = g.stiffness(i, j);
                    k[vi as usize] -= w;
                    if let Some(d) = self.dirichlet_of(vj) {
                        self.couplings.push((vi, d, w));
                    } else if vi < vj {
                        // Two original vertices of a piece of `parent`: an edge of `parent`,
                        // the one opposite its third corner.
                        if let Some(c) = original.iter().position(|&x| x != vi && x != vj) {
                            k[n + edges[c] as usize] += w;
                        }
                    }
                }
            }
        }
        self.stiffness = k;
    }

    /// Marks free vertices whose component (through free-free couplings) has no coupling to a
    /// Dirichlet node: the components by union-find over the coupled edges (no per-vertex
    /// lists: this runs for every region in every fold).
    fn find_unreached(&mut self, region: &Region) {
        let n = self.n;
        let mut components = UnionFind::<u32>::new(n);
        for (e, edge) in region.edges.iter().enumerate() {
            if self.stiffness[n + e] != 0.0 {
                components.union(edge[0], edge[1]);
            }
        }
        let mut reached = vec![false; n];
        for &(v, _, _) in &self.couplings {
            reached[components.find_mut(v) as usize] = true;
        }
        for (v, (u, role)) in self.unreached.iter_mut().zip(&self.role).enumerate() {
            *u = *role == Role::Free && !reached[components.find_mut(v as u32) as usize];
        }
    }

    /// Number of region vertices (unknowns).
    pub fn vertex_count(&self) -> usize {
        self.n
    }

    /// Number of Dirichlet values (boundary points, then Dirichlet vertices).
    pub fn dirichlet_count(&self) -> usize {
        self.dirichlet_count
    }

    /// Whether vertex `v` is an unknown of the solves (outside `C`, not Dirichlet, reached).
    pub fn is_free(&self, v: usize) -> bool {
        self.role[v] == Role::Free && !self.unreached[v]
    }

    /// Lumped mass of each vertex on the cut mesh (0 for non-free vertices).
    pub fn mass(&self) -> &[f64] {
        &self.mass
    }

    pub(super) fn check_values(&self, got: usize) -> Result<(), HeatError> {
        if got == self.dirichlet_count {
            Ok(())
        } else {
            Err(HeatError::ValueCount {
                expected: self.dirichlet_count,
                got,
            })
        }
    }

    /// Slot values of `K` with identity rows for non-free vertices.
    pub(super) fn stiffness_slots(&self, pattern: &SpdPattern) -> Vec<f64> {
        self.combined_slots(pattern, 0.0, 1.0)
    }

    /// Slot values of `M + t K` with identity rows for non-free vertices.
    pub(super) fn heat_slots(&self, pattern: &SpdPattern, t: f64) -> Vec<f64> {
        self.combined_slots(pattern, 1.0, t)
    }

    fn combined_slots(&self, pattern: &SpdPattern, mass_scale: f64, k_scale: f64) -> Vec<f64> {
        let n = self.n;
        let mut s: Vec<f64> = self.stiffness.iter().map(|x| x * k_scale).collect();
        for (v, slot) in s.iter_mut().take(n).enumerate() {
            *slot = if self.is_free(v) {
                *slot + mass_scale * self.mass[v]
            } else {
                1.0
            };
        }
        for (e, edge) in pattern.edges().iter().enumerate() {
            if !self.is_free(edge[0] as usize) || !self.is_free(edge[1] as usize) {
                s[n + e] = 0.0;
            }
        }
        s
    }

    /// `b_i -= scale Σ_k K_ik g_k` over the couplings of free vertices to Dirichlet nodes.
    pub(super) fn apply_dirichlet(&self, b: &mut [f64], values: &[f64], scale: f64) {
        for &(v, k, w) in &self.couplings {
            if self.is_free(v as usize) {
                b[v as usize] -= scale * w * values[k as usize];
            }
        }
    }

    /// Right-hand side of identity rows: the value of Dirichlet vertices, 0 elsewhere.
    pub(super) fn set_fixed_rows(&self, b: &mut [f64], values: &[f64]) {
        for (v, x) in b.iter_mut().enumerate().take(self.n) {
            if !self.is_free(v) {
                *x = match self.role[v] {
                    Role::Dirichlet(k) => values[k as usize],
                    _ => 0.0,
                };
            }
        }
    }

    /// Step 2 and the load of step 3 of the heat method: `b_i = Σ A X·∇φ_i` with
    /// `X = -∇u / |∇u|`, `u = 1` on Dirichlet nodes.
    pub(super) fn normalized_gradient_load(&self, u: &[f64]) -> Vec<f64> {
        let mut b = vec![0.0; self.n];
        for (t, g) in self.triangles.iter().zip(&self.geometry) {
            let values = t.map(|node| {
                if self.dirichlet_of(node).is_some() {
                    1.0
                } else {
                    u[node as usize]
                }
            });
            let grad = g.gradient(values);
            let len = grad.norm();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let x = -grad / len;
            for (k, &node) in t.iter().enumerate() {
                if (node as usize) < self.n && self.is_free(node as usize) {
                    b[node as usize] += g.area * x.dot(&g.grad[k]);
                }
            }
        }
        b
    }
}

fn roles(n: usize, boundary: &Boundary) -> Result<Vec<Role>, HeatError> {
    let mut role: Vec<Role> = boundary
        .inside
        .iter()
        .map(|&i| if i { Role::Inside } else { Role::Free })
        .collect();
    for (j, &v) in boundary.vertices.iter().enumerate() {
        let slot = role.get_mut(v as usize).ok_or_else(|| {
            HeatError::InconsistentBoundary(format!("Dirichlet vertex {v} out of range"))
        })?;
        *slot = Role::Dirichlet((boundary.points.len() + j) as u32);
    }
    debug_assert_eq!(role.len(), n);
    Ok(role)
}

/// Node of the point on each crossed edge; checks every crossed edge has exactly one point.
fn point_nodes(region: &Region, boundary: &Boundary) -> Result<HashMap<u32, u32>, HeatError> {
    let n = region.vertex_count() as u32;
    let mut map = HashMap::with_capacity(boundary.points.len());
    for (k, p) in boundary.points.iter().enumerate() {
        let e = region.edges.get(p.edge as usize).ok_or_else(|| {
            HeatError::InconsistentBoundary(format!("edge {} out of range", p.edge))
        })?;
        if boundary.inside[e[0] as usize] == boundary.inside[e[1] as usize] {
            return Err(HeatError::InconsistentBoundary(format!(
                "point on edge {} which is not crossed",
                p.edge
            )));
        }
        if !p.alpha.is_finite() {
            return Err(HeatError::InconsistentBoundary(format!(
                "non-finite alpha on edge {}",
                p.edge
            )));
        }
        if map.insert(p.edge, n + k as u32).is_some() {
            return Err(HeatError::InconsistentBoundary(format!(
                "two points on edge {}",
                p.edge
            )));
        }
    }
    Ok(map)
}

/// Faces of `region` within Dijkstra distance `radius` (along edges, outside `C`) of the
/// source: the band on which the solves can run instead of the whole region (`PIPELINE.md`:
/// `radius = 1.5 φ_max + 3 h_W`). Returns local face indices.
pub fn band_faces(
    region: &Region,
    positions: &[Point3<f64>],
    boundary: &Boundary,
    radius: f64,
) -> Vec<u32> {
    let n = region.vertex_count();
    let mut dist = vec![f64::INFINITY; n];
    let mut heap = BinaryHeap::new();
    let seed = |v: u32, d: f64, dist: &mut Vec<f64>, heap: &mut BinaryHeap<Queued>| {
        if d < dist[v as usize] {
            dist[v as usize] = d;
            heap.push(Queued(d, v));
        }
    };
    for p in &boundary.points {
        let e = region.edges[p.edge as usize];
        let (a, b) = (e[0], e[1]);
        let point =
            positions[a as usize] + (positions[b as usize] - positions[a as usize]) * p.alpha;
        for v in [a, b] {
            if !boundary.inside[v as usize] {
                seed(
                    v,
                    (positions[v as usize] - point).norm(),
                    &mut dist,
                    &mut heap,
                );
            }
        }
    }
    for &v in &boundary.vertices {
        seed(v, 0.0, &mut dist, &mut heap);
    }
    let adjacency = region.adjacency();
    while let Some(Queued(d, v)) = heap.pop() {
        if d > dist[v as usize] || d > radius {
            continue;
        }
        for &w in &adjacency[v as usize] {
            if boundary.inside[w as usize] {
                continue;
            }
            let nd = d + (positions[v as usize] - positions[w as usize]).norm();
            seed(w, nd, &mut dist, &mut heap);
        }
    }
    region
        .triangles
        .iter()
        .enumerate()
        .filter(|(_, t)| {
            t.iter()
                .any(|&v| !boundary.inside[v as usize] && dist[v as usize] <= radius)
        })
        .map(|(f, _)| f as u32)
        .collect()
}
