//! Sub-regions of a welded mesh: the working regions of the 2021 paper (Sec. 3), or bands
//! around a contact zone. A region re-indexes its vertices locally, lists its edges once
//! (the sparsity pattern of every operator on it) and marks its border vertices.

use std::collections::HashMap;

/// A connected or not set of faces of a mesh, with local indices.
#[derive(Clone, Debug, Default)]
pub struct Region {
    /// Mesh vertex of each local vertex.
    pub vertices: Vec<u32>,
    /// Mesh face of each local face.
    pub faces: Vec<u32>,
    /// Local triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Local edges `[a, b]` with `a < b`, in order of first appearance.
    pub edges: Vec<[u32; 2]>,
    /// For each local face, the edge opposite each corner.
    pub face_edges: Vec<[u32; 3]>,
    /// Whether each local vertex lies on the region's border (an edge with one region face).
    pub border: Vec<bool>,
    edge_lookup: HashMap<(u32, u32), u32>,
}

impl Region {
    /// The region made of `faces` of the mesh `triangles` (repeated faces are kept once).
    pub fn from_faces(triangles: &[[u32; 3]], faces: impl IntoIterator<Item = u32>) -> Self {
        let mut local_of: HashMap<u32, u32> = HashMap::new();
        let mut seen = std::collections::HashSet::new();
        let mut r = Region::default();
        for f in faces {
            let Some(t) = triangles.get(f as usize) else {
                continue;
            };
            if !seen.insert(f) {
                continue;
            }
            let local = t.map(|v| {
                *local_of.entry(v).or_insert_with(|| {
                    r.vertices.push(v);
                    (r.vertices.len() - 1) as u32
                })
            });
            r.faces.push(f);
            r.triangles.push(local);
        }
        r.build_edges();
        r
    }

    /// The whole mesh as one region (local indices equal mesh indices for used vertices
    /// listed in order of first use).
    pub fn whole(triangles: &[[u32; 3]]) -> Self {
        Self::from_faces(triangles, 0..triangles.len() as u32)
    }

    fn build_edges(&mut self) {
        let mut count: Vec<u32> = Vec::new();
        for t in &self.triangles {
            let mut fe = [0u32; 3];
            for (k, slot) in fe.iter_mut().enumerate() {
                let (a, b) = (t[(k + 1) % 3], t[(k + 2) % 3]);
                let key = (a.min(b), a.max(b));
                let next = self.edges.len() as u32;
                let e = *self.edge_lookup.entry(key).or_insert(next);
                if e == next {
                    self.edges.push([key.0, key.1]);
                    count.push(0);
                }
                count[e as usize] += 1;
                *slot = e;
            }
            self.face_edges.push(fe);
        }
        self.border = vec![false; self.vertices.len()];
        for (e, &c) in self.edges.iter().zip(&count) {
            if c == 1 {
                self.border[e[0] as usize] = true;
                self.border[e[1] as usize] = true;
            }
        }
    }

    /// True when no edge has a single face: the region is a whole closed surface.
    pub fn is_closed(&self) -> bool {
        !self.border.iter().any(|&b| b)
    }

    /// Number of local vertices.
    pub fn vertex_count(&self) -> usize {
        self.vertices.len()
    }

    /// The local edge joining local vertices `a` and `b`, if any.
    pub fn edge(&self, a: u32, b: u32) -> Option<u32> {
        self.edge_lookup.get(&(a.min(b), a.max(b))).copied()
    }

    /// Neighbours of each local vertex over the region's edges (local ids).
    pub fn adjacency(&self) -> Vec<Vec<u32>> {
        let mut adjacency = vec![Vec::new(); self.vertex_count()];
        for &[a, b] in &self.edges {
            adjacency[a as usize].push(b);
            adjacency[b as usize].push(a);
        }
        adjacency
    }

    /// Gathers mesh-indexed values onto the local vertices.
    pub fn gather<T: Copy>(&self, mesh_values: &[T]) -> Vec<T> {
        self.vertices
            .iter()
            .map(|&v| mesh_values[v as usize])
            .collect()
    }
}
