//! Pose-independent data of one surface (its faces, edges, a BVH built on a reference pose) and
//! its per-frame counterpart.

use super::bvh::{Aabb, FaceSets, LeafCorners, TriangleBvh};
use super::IntersectError;
use nalgebra::Point3;
use std::borrow::Cow;
use std::sync::OnceLock;

/// The pose-independent part of one surface: a triangle mesh, or the subset of its faces that
/// forms one side of a self-contact (2021 Sec. 6). Build once per rig, share between frames.
///
/// Faces with a repeated vertex index are left out (counted in
/// [`MeshIndex::index_degenerate_faces`]); geometrically degenerate faces (collinear corners)
/// are kept: the exact predicates handle them.
#[derive(Clone, Debug)]
pub struct MeshIndex {
    triangles: Vec<[u32; 3]>,
    vertex_count: usize,
    faces: Vec<u32>,
    edges: Vec<[u32; 2]>,
    /// Edges around each vertex (CSR over `edges`).
    vertex_edge_offsets: Vec<u32>,
    vertex_edge_ids: Vec<u32>,
    /// Vertex used by a face of this surface.
    used: Vec<bool>,
    index_degenerate: usize,
    bvh: TriangleBvh,
    /// The corners of each leaf of `bvh`, made at the first [`MeshIndex::refit_nodes_in`]
    /// (most indices, a self-contact's parts made per frame, never need them).
    leaf_corners: OnceLock<LeafCorners>,
}

impl MeshIndex {
    /// Index over every face of `triangles`, with the BVH built on `rest_positions`.
    pub fn new(
        rest_positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
    ) -> Result<Self, IntersectError> {
        let all: Vec<u32> = (0..triangles.len() as u32).collect();
        Self::with_faces(rest_positions, triangles, &all)
    }

    /// Index over the faces `faces` (ids into `triangles`) only; vertex ids stay those of the
    /// whole mesh.
    pub fn with_faces(
        rest_positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        faces: &[u32],
    ) -> Result<Self, IntersectError> {
        Self::with_faces_in(rest_positions, triangles, faces, None)
    }

    /// [`MeshIndex::with_faces`], its edges picked from `within`'s and its BVH restricted from
    /// `within`'s when `within` holds every face (see [`TriangleBvh::restricted_at`]), else
    /// sorted and built.
    fn with_faces_in(
        rest_positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        faces: &[u32],
        within: Option<&PartsUnion>,
    ) -> Result<Self, IntersectError> {
        check_positions(rest_positions)?;
        let vertex_count = rest_positions.len();
        let (kept, index_degenerate) = valid_faces(triangles, faces, vertex_count)?;
        let edges = within
            .and_then(|w| w.edges_of(&kept))
            .unwrap_or_else(|| sorted_edges(triangles, &kept));
        let bvh = within
            .and_then(|w| w.tree.restricted_at(&kept, rest_positions, triangles))
            .unwrap_or_else(|| TriangleBvh::build(rest_positions, triangles, &kept));
        let (vertex_edge_offsets, vertex_edge_ids) = vertex_edges(vertex_count, &edges);
        let mut used = vec![false; vertex_count];
        for &f in &kept {
            for v in triangles[f as usize] {
                used[v as usize] = true;
            }
        }
        Ok(Self {
            triangles: triangles.to_vec(),
            vertex_count,
            faces: kept,
            edges,
            vertex_edge_offsets,
            vertex_edge_ids,
            used,
            index_degenerate,
            bvh,
            leaf_corners: OnceLock::new(),
        })
    }

    /// One index per part of a self-contact: faces labelled `1` and faces labelled `2` in
    /// `parts` (one label per face; other labels belong to neither part).
    pub fn self_contact_parts(
        rest_positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        parts: &[u8],
    ) -> Result<[Self; 2], IntersectError> {
        Self::self_contact_parts_within(None, rest_positions, triangles, parts)
    }

    /// [`MeshIndex::self_contact_parts`] at `positions`, each part's edges picked and its BVH
    /// restricted from `within` (a superset of both parts, e.g. the faces of both working
    /// regions of a joint, indexed once) instead of sorted and built: the crease cut moves the
    /// parts' faces in every frame, their union does not change. Queries give the same results
    /// either way.
    pub fn self_contact_parts_within(
        within: Option<&PartsUnion>,
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        parts: &[u8],
    ) -> Result<[Self; 2], IntersectError> {
        if parts.len() != triangles.len() {
            return Err(IntersectError::PartCount {
                expected: triangles.len(),
                got: parts.len(),
            });
        }
        let part = |label: u8| -> Vec<u32> {
            (0..triangles.len() as u32)
                .filter(|&f| parts[f as usize] == label)
                .collect()
        };
        let (a, b) = rayon::join(
            || Self::with_faces_in(positions, triangles, &part(1), within),
            || Self::with_faces_in(positions, triangles, &part(2), within),
        );
        Ok([a?, b?])
    }

    /// All triangles of the mesh (vertex ids into the positions).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// The faces of this surface, sorted (index-degenerate faces excluded).
    pub fn faces(&self) -> &[u32] {
        &self.faces
    }

    /// The edges of this surface's faces, canonical (`[min, max]`) and sorted.
    pub fn edges(&self) -> &[[u32; 2]] {
        &self.edges
    }

    /// Ids (into [`MeshIndex::edges`]) of the edges around vertex `v`.
    pub fn vertex_edges(&self, v: u32) -> &[u32] {
        let (a, b) = (
            self.vertex_edge_offsets[v as usize] as usize,
            self.vertex_edge_offsets[v as usize + 1] as usize,
        );
        &self.vertex_edge_ids[a..b]
    }

    /// Whether vertex `v` belongs to a face of this surface.
    pub fn uses_vertex(&self, v: u32) -> bool {
        self.used[v as usize]
    }

    /// Number of vertices of the mesh.
    pub fn vertex_count(&self) -> usize {
        self.vertex_count
    }

    /// Faces left out because they repeat a vertex index.
    pub fn index_degenerate_faces(&self) -> usize {
        self.index_degenerate
    }

    /// Id of the edge `{a, b}` in [`MeshIndex::edges`].
    pub fn edge_id(&self, a: u32, b: u32) -> Option<u32> {
        self.edges
            .binary_search(&canonical(a, b))
            .ok()
            .map(|i| i as u32)
    }

    /// The surface at one frame: the BVH refitted to `positions` (same topology).
    pub fn pose<'a>(
        &'a self,
        positions: &'a [Point3<f64>],
    ) -> Result<PosedMesh<'a>, IntersectError> {
        Ok(PosedMesh {
            index: self,
            positions,
            bvh: Cow::Owned(self.refit_tree(positions)?),
        })
    }

    /// The box of the indexed faces at `positions` (checked as for a refit): the root box of
    /// the tree refit there, to the bit (the extremes of the same corners), without the refit;
    /// `None` without a face.
    pub fn bounding_box(&self, positions: &[Point3<f64>]) -> Result<Option<Aabb>, IntersectError> {
        self.check_frame(positions)?;
        let b = positions
            .iter()
            .zip(&self.used)
            .filter(|(_, &u)| u)
            .fold(Aabb::EMPTY, |acc, (p, _)| acc.grown(p));
        Ok((!b.is_empty()).then_some(b))
    }

    /// The BVH refitted to `positions`, to keep and view with [`MeshIndex::posed_with`] while
    /// the positions do not change (one refit shared by several queries).
    pub(crate) fn refit_tree(
        &self,
        positions: &[Point3<f64>],
    ) -> Result<TriangleBvh, IntersectError> {
        self.check_frame(positions)?;
        let mut bvh = self.bvh.clone();
        bvh.refit(positions, &self.triangles);
        Ok(bvh)
    }

    /// [`MeshIndex::refit_tree`] into `tree`, a tree an earlier [`MeshIndex::refit_tree`] of
    /// this index returned, at its nodes only ([`TriangleBvh::refit_nodes_at`], with the
    /// index's leaf corners, made once): for the pair queries between face sets alone
    /// ([`crate::intersect::Intersections::between_sets`]), which find the same pairs as on a
    /// full refit. Neither the copy of the tree nor its faces' boxes: a frame of the
    /// self-contact pass without contact is about this refit and those queries. `tree` is
    /// left as it was on an error. `finite`: the caller checked the positions finite (the
    /// self-contact pass checks its input), only their count is checked here.
    pub(crate) fn refit_nodes_in(
        &self,
        positions: &[Point3<f64>],
        tree: &mut TriangleBvh,
        finite: bool,
    ) -> Result<(), IntersectError> {
        if finite {
            self.check_count(positions)?;
        } else {
            self.check_frame(positions)?;
        }
        debug_assert!(tree.same_shape(&self.bvh), "a tree of another index");
        let corners = self
            .leaf_corners
            .get_or_init(|| self.bvh.leaf_corners(&self.triangles));
        match tree.refit_nodes_at(positions, corners) {
            true => Ok(()),
            // Checked positions: only corners of another index miss them.
            false => Err(IntersectError::LeafCornersMismatch),
        }
    }

    /// The surface at the positions the index was built (or restricted) at, its tree as it
    /// is: for an index made for one frame, such as a self-contact's truncated parts
    /// ([`MeshIndex::self_contact_parts_within`]), which [`MeshIndex::pose`] would refit a
    /// second time. Other positions would make queries miss.
    pub(crate) fn posed_as_built<'a>(
        &'a self,
        positions: &'a [Point3<f64>],
    ) -> Result<PosedMesh<'a>, IntersectError> {
        // Finite already: the index was built at these positions.
        self.check_count(positions)?;
        Ok(self.posed_with(positions, &self.bvh))
    }

    /// The surface at `positions` with `tree`, which [`MeshIndex::refit_tree`] returned for
    /// these same positions (a tree of another frame would make queries miss).
    pub(crate) fn posed_with<'a>(
        &'a self,
        positions: &'a [Point3<f64>],
        tree: &'a TriangleBvh,
    ) -> PosedMesh<'a> {
        debug_assert_eq!(positions.len(), self.vertex_count);
        PosedMesh {
            index: self,
            positions,
            bvh: Cow::Borrowed(tree),
        }
    }

    /// Two disjoint sets of this surface's faces (`label(face)` 1 and 2) marked in its BVH, for
    /// [`crate::intersect::Intersections::between_sets`].
    pub fn face_sets(&self, label: impl Fn(u32) -> u8) -> FaceSets {
        self.bvh.face_sets_on(label, &self.triangles)
    }

    /// The surface at one frame with a BVH rebuilt from scratch (tighter after large motions).
    pub fn pose_rebuilt<'a>(
        &'a self,
        positions: &'a [Point3<f64>],
    ) -> Result<PosedMesh<'a>, IntersectError> {
        self.check_frame(positions)?;
        let bvh = TriangleBvh::build(positions, &self.triangles, &self.faces);
        Ok(PosedMesh {
            index: self,
            positions,
            bvh: Cow::Owned(bvh),
        })
    }

    /// The BVH with each face's box covering its straight path from `from` to `to`
    /// ([`TriangleBvh::refit_swept`]).
    pub(crate) fn swept_tree(
        &self,
        from: &[Point3<f64>],
        to: &[Point3<f64>],
    ) -> Result<TriangleBvh, IntersectError> {
        self.check_frame(from)?;
        self.check_frame(to)?;
        let mut bvh = self.bvh.clone();
        bvh.refit_swept(from, to, &self.triangles);
        Ok(bvh)
    }

    /// One position per vertex of the mesh, all finite.
    pub(crate) fn check_frame(&self, positions: &[Point3<f64>]) -> Result<(), IntersectError> {
        self.check_count(positions)?;
        check_positions(positions)
    }

    /// One position per vertex of the mesh.
    fn check_count(&self, positions: &[Point3<f64>]) -> Result<(), IntersectError> {
        if positions.len() != self.vertex_count {
            return Err(IntersectError::PositionCount {
                expected: self.vertex_count,
                got: positions.len(),
            });
        }
        Ok(())
    }
}

/// One surface at one frame: its [`MeshIndex`], positions and refitted BVH.
#[derive(Clone, Debug)]
pub struct PosedMesh<'a> {
    index: &'a MeshIndex,
    positions: &'a [Point3<f64>],
    bvh: Cow<'a, TriangleBvh>,
}

impl<'a> PosedMesh<'a> {
    /// The pose-independent data.
    pub fn index(&self) -> &'a MeshIndex {
        self.index
    }

    /// Vertex positions of this frame.
    pub fn positions(&self) -> &'a [Point3<f64>] {
        self.positions
    }

    /// All triangles of the mesh.
    pub fn triangles(&self) -> &'a [[u32; 3]] {
        &self.index.triangles
    }

    /// The BVH of this frame.
    pub fn bvh(&self) -> &TriangleBvh {
        &self.bvh
    }

    /// Corner positions of face `f`.
    pub fn corners(&self, f: u32) -> [&'a Point3<f64>; 3] {
        let t = &self.index.triangles[f as usize];
        t.map(|v| &self.positions[v as usize])
    }

    /// Area of face `f`.
    pub fn face_area(&self, f: u32) -> f64 {
        let [a, b, c] = self.corners(f);
        0.5 * (b - a).cross(&(c - a)).norm()
    }
}

/// The union of a self-contact's two parts (2021 Sec. 6: both working regions of a joint),
/// indexed once at rest: a BVH over its faces, its edges (canonical, sorted) and the ids of
/// each face's edges, from which [`MeshIndex::self_contact_parts_within`] indexes each
/// frame's parts without building a tree or sorting their edges.
#[derive(Clone, Debug)]
pub struct PartsUnion {
    tree: TriangleBvh,
    edges: Vec<[u32; 2]>,
    /// Per mesh face, the ids into `edges` of its three edges (`u32::MAX` for a face outside
    /// the union).
    face_edges: Vec<[u32; 3]>,
}

impl PartsUnion {
    /// Indexes the union `faces` of `triangles` at `rest_positions` (faces with a repeated
    /// vertex index left out, as [`MeshIndex::with_faces`] does).
    pub fn new(
        rest_positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        faces: &[u32],
    ) -> Result<Self, IntersectError> {
        check_positions(rest_positions)?;
        let (kept, _) = valid_faces(triangles, faces, rest_positions.len())?;
        let edges = sorted_edges(triangles, &kept);
        let mut face_edges = vec![[u32::MAX; 3]; triangles.len()];
        for &f in &kept {
            let t = triangles[f as usize];
            for (k, id) in face_edges[f as usize].iter_mut().enumerate() {
                let edge = canonical(t[k], t[(k + 1) % 3]);
                // Every edge of a kept face is in `edges`.
                *id = edges.binary_search(&edge).map_or(u32::MAX, |i| i as u32);
            }
        }
        Ok(Self {
            tree: TriangleBvh::build(rest_positions, triangles, &kept),
            edges,
            face_edges,
        })
    }

    /// The sorted edges of `faces` (valid faces of the mesh), picked from the union's: the
    /// same as [`sorted_edges`] gives; `None` when a face is not in the union.
    fn edges_of(&self, faces: &[u32]) -> Option<Vec<[u32; 2]>> {
        let mut used = vec![false; self.edges.len()];
        for &f in faces {
            for id in *self.face_edges.get(f as usize)? {
                *used.get_mut(id as usize)? = true;
            }
        }
        Some(
            self.edges
                .iter()
                .zip(&used)
                .filter(|(_, &u)| u)
                .map(|(e, _)| *e)
                .collect(),
        )
    }
}

/// The edges of `faces` (valid faces of `triangles`), canonical, sorted and unique.
fn sorted_edges(triangles: &[[u32; 3]], faces: &[u32]) -> Vec<[u32; 2]> {
    // Sorted as `u64` keys (`a << 32 | b`, the same order as `[a, b]`): twice as fast as
    // comparing pairs.
    let mut keys: Vec<u64> = faces
        .iter()
        .flat_map(|&f| {
            let t = triangles[f as usize];
            (0..3).map(move |k| {
                let [a, b] = canonical(t[k], t[(k + 1) % 3]);
                (u64::from(a) << 32) | u64::from(b)
            })
        })
        .collect();
    keys.sort_unstable();
    keys.dedup();
    keys.iter().map(|&k| [(k >> 32) as u32, k as u32]).collect()
}

/// The faces to keep (sorted, unique, without repeated vertex index) and the number left out;
/// an error for an out-of-range face or vertex id.
fn valid_faces(
    triangles: &[[u32; 3]],
    faces: &[u32],
    vertex_count: usize,
) -> Result<(Vec<u32>, usize), IntersectError> {
    let mut kept = Vec::with_capacity(faces.len());
    let mut index_degenerate = 0;
    for &f in faces {
        let t = triangles
            .get(f as usize)
            .ok_or(IntersectError::FaceOutOfRange(f))?;
        if let Some(&v) = t.iter().find(|&&v| v as usize >= vertex_count) {
            return Err(IntersectError::VertexOutOfRange {
                face: f,
                vertex: v,
                vertex_count,
            });
        }
        if t[0] == t[1] || t[1] == t[2] || t[2] == t[0] {
            index_degenerate += 1;
        } else {
            kept.push(f);
        }
    }
    kept.sort_unstable();
    kept.dedup();
    Ok((kept, index_degenerate))
}

/// CSR of the edges around each vertex.
fn vertex_edges(vertex_count: usize, edges: &[[u32; 2]]) -> (Vec<u32>, Vec<u32>) {
    let mut offsets = vec![0u32; vertex_count + 1];
    for e in edges {
        offsets[e[0] as usize + 1] += 1;
        offsets[e[1] as usize + 1] += 1;
    }
    for i in 0..vertex_count {
        offsets[i + 1] += offsets[i];
    }
    let mut fill: Vec<u32> = offsets[..vertex_count].to_vec();
    let mut ids = vec![0u32; 2 * edges.len()];
    for (id, e) in edges.iter().enumerate() {
        for v in e {
            ids[fill[*v as usize] as usize] = id as u32;
            fill[*v as usize] += 1;
        }
    }
    (offsets, ids)
}

/// `[min, max]` of two vertex ids.
pub(crate) fn canonical(a: u32, b: u32) -> [u32; 2] {
    [a.min(b), a.max(b)]
}

/// [`IntersectError::NonFinitePosition`] for the first non-finite position.
pub(crate) fn check_positions(positions: &[Point3<f64>]) -> Result<(), IntersectError> {
    match crate::mesh::first_non_finite(positions) {
        Some(i) => Err(IntersectError::NonFinitePosition(i as u32)),
        None => Ok(()),
    }
}
