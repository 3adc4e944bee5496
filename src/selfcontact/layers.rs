//! Layers sunk into the skin at rest: separate pieces of one mesh modeled through each other
//! across a joint (a belt sunk into the waist, a collar into the neck, buttons into a coat, a
//! head mesh pushed into the neck). Not in the paper, whose meshes are single surfaces.
//!
//! A fold runs on the pieces (connected components of the welded mesh) holding its shared
//! region, without:
//! - where its two sides cross at rest ([`super::pass::SelfContactPass::crossing_at_rest`])
//!   and *different* pieces meet there, the smaller piece of each such meeting (a belt);
//! - the pieces of its working regions lying inside a larger piece at rest
//!   ([`Components::inside_larger`]: teeth in a head, a lining under a coat);
//! - the pieces of its working regions holding no vertex of its shared region (a stud on one
//!   side), and every other piece of the body.
//!
//! Their faces leave the fold's working regions (no contact, no deformation, no bulge: they
//! follow the skinning), its inside-twice tree and its closed-surface test. The fold is then
//! detected again at rest; if it still crosses there (a piece crossing itself, a broken
//! mesh), it stays as it was, a fold crossing at rest. A mesh of one piece (every sample) is
//! not affected. (Pieces lying wholly in a shared region leave it when the pair is derived:
//! no partition of unity reaches them, [`super::regions`].)
//!
//! The trade-off: a layer is not pushed by the fold, so the skin under it may bulge through
//! it, as it does in the skinning when the layer is thin.

use crate::intersect::Aabb;
use crate::report::metrics::{WindingNumber, WINDING_BETA};
use nalgebra::Point3;
use petgraph::unionfind::UnionFind;
use std::collections::HashMap;

/// The connected components of a welded mesh (faces sharing a vertex), with their rest area.
#[derive(Clone, Debug)]
pub struct Components {
    /// Component of each face.
    of_face: Vec<u32>,
    /// Per component: its rest area, face count, vertex count and lowest vertex.
    parts: Vec<Layer>,
    /// Per component: its faces (ascending) and the bounding box of its corners at rest.
    faces: Vec<Vec<u32>>,
    boxes: Vec<Aabb>,
}

/// What [`Components::inside_larger`] keeps between its calls on one mesh: the pieces
/// answered, and the winding-number trees of the larger pieces tested.
#[derive(Debug, Default)]
pub struct InsideMemo {
    known: HashMap<u32, bool>,
    trees: HashMap<u32, WindingNumber>,
}

/// One connected component of a body's welded mesh that a fold runs without
/// ([`super::pass::SelfContactPass::layers`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Layer {
    /// Its faces.
    pub faces: usize,
    /// Its welded vertices.
    pub vertices: usize,
    /// Its area at rest.
    pub area: f64,
    /// Its lowest welded vertex (a handle on the piece: [`crate::mesh::WeldedMesh::
    /// representative`] gives its file vertex).
    pub first_vertex: u32,
}

impl Components {
    /// The components of `triangles` over `rest` (welded indices; out-of-range corners and
    /// non-finite areas count as none and 0).
    pub fn of(rest: &[Point3<f64>], triangles: &[[u32; 3]]) -> Self {
        let n = rest.len();
        let mut union = UnionFind::<u32>::new(n);
        let valid = |t: &[u32; 3]| t.iter().all(|&v| (v as usize) < n);
        for t in triangles.iter().filter(|t| valid(t)) {
            union.union(t[0], t[1]);
            union.union(t[0], t[2]);
        }
        let roots = union.into_labeling();
        let mut id = vec![u32::MAX; n];
        let mut parts: Vec<Layer> = Vec::new();
        let mut counted = vec![false; n];
        let mut of_face = Vec::with_capacity(triangles.len());
        let mut faces: Vec<Vec<u32>> = Vec::new();
        let mut boxes: Vec<Aabb> = Vec::new();
        for (f, t) in triangles.iter().enumerate() {
            if !valid(t) {
                of_face.push(u32::MAX);
                continue;
            }
            let root = roots[t[0] as usize] as usize;
            if id[root] == u32::MAX {
                id[root] = parts.len() as u32;
                parts.push(Layer {
                    faces: 0,
                    vertices: 0,
                    area: 0.0,
                    first_vertex: u32::MAX,
                });
                faces.push(Vec::new());
                boxes.push(Aabb::EMPTY);
            }
            let part = &mut parts[id[root] as usize];
            part.faces += 1;
            let [a, b, c] = t.map(|v| rest[v as usize]);
            let area = 0.5 * (b - a).cross(&(c - a)).norm();
            if area.is_finite() {
                part.area += area;
            }
            let c = id[root] as usize;
            faces[c].push(f as u32);
            let b = &mut boxes[c];
            for &v in t {
                part.first_vertex = part.first_vertex.min(v);
                part.vertices += usize::from(!std::mem::replace(&mut counted[v as usize], true));
                *b = b.grown(&rest[v as usize]);
            }
            of_face.push(id[root]);
        }
        Self {
            of_face,
            parts,
            faces,
            boxes,
        }
    }

    /// Number of components.
    pub fn len(&self) -> usize {
        self.parts.len()
    }

    /// Whether the mesh has no face.
    pub fn is_empty(&self) -> bool {
        self.parts.is_empty()
    }

    /// The component of face `f` (`None` for a face out of range or with a corner out of
    /// range).
    pub fn of_face(&self, f: u32) -> Option<u32> {
        self.of_face
            .get(f as usize)
            .copied()
            .filter(|&c| c != u32::MAX)
    }

    /// Component `c`.
    pub fn part(&self, c: u32) -> &Layer {
        &self.parts[c as usize]
    }

    /// The smaller of two components: by rest area, then face count, then the later one.
    fn smaller(&self, a: u32, b: u32) -> u32 {
        let key = |c: u32| {
            let p = &self.parts[c as usize];
            (p.area, p.faces, std::cmp::Reverse(c))
        };
        match key(a).partial_cmp(&key(b)) {
            Some(std::cmp::Ordering::Greater) => b,
            _ => a,
        }
    }

    /// The layers of a crossing at rest: for every face pair of two different components,
    /// the smaller one; ascending, each once. Empty when every pair lies in one component.
    pub fn layers_of(&self, face_pairs: &[[u32; 2]]) -> Vec<u32> {
        let mut layers: Vec<u32> = face_pairs
            .iter()
            .filter_map(|&[a, b]| match (self.of_face(a), self.of_face(b)) {
                (Some(a), Some(b)) if a != b => Some(self.smaller(a, b)),
                _ => None,
            })
            .collect();
        layers.sort_unstable();
        layers.dedup();
        layers
    }

    /// The components of `faces` (ascending, each once).
    pub fn of_faces(&self, faces: impl IntoIterator<Item = u32>) -> Vec<u32> {
        let mut of: Vec<u32> = faces.into_iter().filter_map(|f| self.of_face(f)).collect();
        of.sort_unstable();
        of.dedup();
        of
    }

    /// Of `pieces`, those lying inside a larger component of the mesh at `rest` (of
    /// [`Components::of`]): most of their vertices at a generalized winding number of at least
    /// 1/2 of that component's faces. Teeth in a head, a tongue behind the lips, a lining
    /// under a coat: surfaces a fold of the outer one would otherwise press and bulge.
    /// Ascending. `memo` keeps the answers and the trees between the calls on one mesh (a
    /// body's folds share most pieces: a head's hair cards in its neck's and its jaw's).
    pub fn inside_larger(
        &self,
        rest: &[Point3<f64>],
        triangles: &[[u32; 3]],
        pieces: &[u32],
        memo: &mut InsideMemo,
    ) -> Vec<u32> {
        let mut inside: Vec<u32> = (pieces.iter().copied())
            .filter(|&c| {
                *memo
                    .known
                    .entry(c)
                    .or_insert_with(|| self.lies_inside(rest, triangles, c, &mut memo.trees))
            })
            .collect();
        inside.sort_unstable();
        inside
    }

    /// Whether piece `c` lies inside a larger piece ([`Components::inside_larger`]), with the
    /// larger pieces' `trees` built as needed.
    fn lies_inside(
        &self,
        rest: &[Point3<f64>],
        triangles: &[[u32; 3]],
        c: u32,
        trees: &mut HashMap<u32, WindingNumber>,
    ) -> bool {
        let vertices = self.vertices_of(c, triangles);
        let own = &self.boxes[c as usize];
        let enclosing = (0..self.parts.len() as u32).filter(|&o| {
            let other = &self.boxes[o as usize];
            let holds = other.contains(&own.min) && other.contains(&own.max);
            o != c && self.smaller(c, o) == c && holds
        });
        for o in enclosing {
            let tree = trees.entry(o).or_insert_with(|| {
                let faces = self.faces[o as usize].iter().copied();
                WindingNumber::with_faces_beta(rest, triangles, faces, WINDING_BETA)
            });
            let within = (vertices.iter())
                .filter(|&&v| tree.query(&rest[v as usize]) >= 0.5)
                .count();
            if 2 * within > vertices.len() {
                return true;
            }
        }
        false
    }

    /// The vertices of component `c` (ascending).
    pub(crate) fn vertices_of(&self, c: u32, triangles: &[[u32; 3]]) -> Vec<u32> {
        let mut vertices: Vec<u32> = (self.faces[c as usize].iter())
            .flat_map(|&f| triangles[f as usize])
            .collect();
        vertices.sort_unstable();
        vertices.dedup();
        vertices
    }

    /// Per face, whether it lies in one of `layers`.
    pub fn faces_in(&self, layers: &[u32]) -> Vec<bool> {
        self.of_face
            .iter()
            .map(|c| layers.binary_search(c).is_ok())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square (two faces) and a small triangle crossing nothing: three faces, two
    /// components.
    fn square_and_triangle(scale: f64) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
        let rest = vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(1.0, 1.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(0.5, 0.5, -1.0),
            p(0.5 + scale, 0.5, -1.0),
            p(0.5, 0.5 + scale, 1.0),
        ];
        (rest, vec![[0, 1, 2], [0, 2, 3], [4, 5, 6]])
    }

    #[test]
    fn components_and_the_smaller_of_a_crossing() {
        let (rest, tris) = square_and_triangle(0.2);
        let c = Components::of(&rest, &tris);
        assert_eq!(c.len(), 2);
        assert_eq!(
            (c.of_face(0), c.of_face(1), c.of_face(2)),
            (Some(0), Some(0), Some(1))
        );
        assert_eq!(
            (c.part(0).faces, c.part(0).vertices, c.part(0).first_vertex),
            (2, 4, 0)
        );
        assert!((c.part(0).area - 1.0).abs() < 1e-15);
        assert_eq!(
            (c.part(1).faces, c.part(1).vertices, c.part(1).first_vertex),
            (1, 3, 4)
        );
        // The triangle is the smaller whichever side of the pair it is on.
        assert_eq!(c.layers_of(&[[0, 2], [2, 1]]), vec![1]);
        assert_eq!(c.faces_in(&[1]), vec![false, false, true]);
        // Pairs within one component give no layer.
        assert!(c.layers_of(&[[0, 1]]).is_empty());
        // A larger triangle: the square is the layer.
        let (rest, tris) = square_and_triangle(3.0);
        let c = Components::of(&rest, &tris);
        assert_eq!(c.layers_of(&[[2, 0]]), vec![0]);
    }

    /// A closed sphere with a small triangle at its centre and one beside it: only the first
    /// lies inside a larger piece; the sphere itself inside nothing.
    #[test]
    fn pieces_inside_a_larger_one() {
        let (mut rest, mut tris) = crate::scenes::icosphere(2);
        for (centre, piece) in [(0.0, 0u32), (3.0, 1)] {
            let n = rest.len() as u32;
            for k in 0..3 {
                let a = f64::from(k) * 2.0 * std::f64::consts::PI / 3.0;
                rest.push(Point3::new(
                    centre + 0.1 * a.cos(),
                    0.1 * a.sin(),
                    0.05 * f64::from(piece),
                ));
            }
            tris.push([n, n + 1, n + 2]);
        }
        let c = Components::of(&rest, &tris);
        assert_eq!(c.len(), 3);
        let f = tris.len() as u32;
        let (sphere, inner, outer) = (c.of_face(0), c.of_face(f - 2), c.of_face(f - 1));
        let [sphere, inner, outer] = [sphere, inner, outer].map(|x| x.expect("a piece"));
        assert_eq!(c.of_faces([f - 1, 0, f - 2, 1]), vec![0, 1, 2]);
        let mut memo = InsideMemo::default();
        let inside = c.inside_larger(&rest, &tris, &[sphere, inner, outer], &mut memo);
        assert_eq!(inside, vec![inner]);
        // Asked again (the answers kept): the same.
        assert_eq!(
            c.inside_larger(&rest, &tris, &[outer, inner], &mut memo),
            vec![inner]
        );
    }

    #[test]
    fn faces_out_of_range_belong_to_no_component() {
        let (rest, mut tris) = square_and_triangle(0.2);
        tris.push([0, 1, 99]);
        let c = Components::of(&rest, &tris);
        assert_eq!((c.len(), c.of_face(3), c.of_face(7)), (2, None, None));
        assert!(c.layers_of(&[[3, 2]]).is_empty());
    }
}
