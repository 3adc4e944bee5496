//! What a fold precomputes once per joint pair (its working regions and their symbolic
//! factorizations, the rest partition, the trees) and its detection per frame: whether the
//! two sides of the rest partition cross (2021 Sec. 6, "Crease detection & Partitioning").

use super::FoldError;
use crate::deform::WorkingRegion;
use crate::intersect::{Aabb, FaceSets, Intersections, MeshIndex, PartsUnion, PosedMesh};
use crate::report::metrics::WindingNumber;
use crate::selfcontact::crease::CreaseTopology;
use crate::selfcontact::regions::PairRegions;
use nalgebra::Point3;
use std::sync::Arc;
use std::time::Instant;

/// β of the fold's winding-number tree. Its queries only decide "inside twice" (a winding
/// number of at least 1.5 between 1 and 2): at β = 1.5 the error stays below 0.03 (measured
/// against the brute force near the surfaces of the bent finger and capsule; 0.39 at β = 1),
/// and the contact step of the finger takes 9.8 ms instead of 11.2 at the metrics' β = 2.
const INSIDE_BETA: f64 = 1.5;

/// What is precomputed once per joint pair.
#[derive(Debug)]
pub struct FoldPre {
    /// The regions, `R` and `β`.
    pub regions: PairRegions,
    pub(super) w1: WorkingRegion,
    pub(super) w2: WorkingRegion,
    pub(super) shared: WorkingRegion,
    /// Faces at rest: 1 on W1's side, 2 on W2's, 0 elsewhere ([`rest_labels`]).
    pub(super) labels: Vec<u8>,
    pub(super) faces: Vec<u32>,
    /// `faces` indexed at rest, from which each frame's truncated parts are indexed.
    pub(super) parts: PartsUnion,
    /// Separated regions: their two parts (the rest labels', which no crease moves) indexed
    /// once at rest, their trees refit per frame (built per frame until 2026-12-04).
    pub(super) separated_parts: Option<[MeshIndex; 2]>,
    pub(super) closed: bool,
    /// The surface its inside-twice and closed-surface tests read ([`FoldPre::on_surface`]);
    /// `None`: the whole body's.
    pub(super) surface: Option<Arc<Vec<[u32; 3]>>>,
    /// The body's winding-number tree at rest ([`FoldPre::body_winding`]), shared by the
    /// body's folds.
    pub(super) winding: Arc<WindingNumber>,
    pub(super) topology: CreaseTopology,
    /// Neighbours of each local vertex of `shared` (local ids).
    pub(super) shared_adjacency: Vec<Vec<u32>>,
    /// The joint's size at rest ([`PairRegions::joint_size`]).
    pub joint_size: f64,
    /// The diagonal of the shared region's bounding box at rest ([`FoldPre::collapsed`]).
    pub(super) rest_box: f64,
    /// The vertices whose box [`FoldPre::collapsed`] measures
    /// ([`PairRegions::sized_vertices`]).
    pub(super) sized_vertices: Vec<u32>,
    /// Of `sized_vertices`, the lowest and highest at rest along each axis: their box lies
    /// in the whole box, so a sample box at least the collapse bound settles
    /// [`FoldPre::collapsed`] without reading the rest.
    pub(super) sized_sample: Vec<u32>,
    /// The mean edge length of the working regions' faces at rest (the bulge guard's unit).
    pub(super) rest_edge: f64,
    /// The faces the turn guard checks: every face with a corner in `W1 ∪ W2`, those beyond
    /// the working regions' border included, since the bulge moves the border's vertices too
    /// (until 2026-12-03 only `W1 ∪ W2`'s faces: with the seam samples of
    /// [`crate::contact::mapping`] a fold of Fox's hip turned face 33, next to the border, and
    /// no guard saw it).
    pub(super) guarded_faces: Vec<u32>,
}

impl FoldPre {
    /// Precomputes a fold on a mesh at rest.
    pub fn new(
        rest: &[Point3<f64>],
        triangles: &[[u32; 3]],
        regions: PairRegions,
    ) -> Result<Self, FoldError> {
        let winding = Arc::new(Self::body_winding(rest, triangles));
        Self::with_winding(rest, triangles, regions, winding)
    }

    /// The winding-number tree of the whole body at rest that a fold's inside-twice tests
    /// use (refit per fold and frame): one per body, whatever its number of folds.
    pub fn body_winding(rest: &[Point3<f64>], triangles: &[[u32; 3]]) -> WindingNumber {
        WindingNumber::with_beta(rest, triangles, INSIDE_BETA)
    }

    /// The tree this fold's inside-twice test starts from, shared.
    pub fn shared_winding(&self) -> Arc<WindingNumber> {
        Arc::clone(&self.winding)
    }

    /// A copy of the body's tree at rest, for [`super::resolve_detected_in`].
    pub fn body_tree(&self) -> WindingNumber {
        WindingNumber::clone(&self.winding)
    }

    /// [`FoldPre::new`] with the body's tree from [`FoldPre::body_winding`] on the same rest
    /// positions and triangles, shared with the body's other folds.
    pub fn with_winding(
        rest: &[Point3<f64>],
        triangles: &[[u32; 3]],
        regions: PairRegions,
        winding: Arc<WindingNumber>,
    ) -> Result<Self, FoldError> {
        // Only the topology is needed here (no factorization of the whole mesh).
        let closed = crate::mesh::Region::whole(triangles).is_closed();
        let n = rest.len();
        let w1 = WorkingRegion::new(triangles, regions.w1_faces.iter().copied(), n)?;
        let w2 = WorkingRegion::new(triangles, regions.w2_faces.iter().copied(), n)?;
        let shared = WorkingRegion::new(triangles, regions.shared_faces.iter().copied(), n)?;
        let mut faces: Vec<u32> = regions
            .w1_faces
            .iter()
            .chain(&regions.w2_faces)
            .copied()
            .collect();
        faces.sort_unstable();
        faces.dedup();
        let labels = rest_labels(triangles, &regions);
        // Checks the positions (finite) before any tree is built on them.
        let parts = PartsUnion::new(rest, triangles, &faces)?;
        let separated_parts = regions
            .separated()
            .then(|| MeshIndex::self_contact_parts_within(Some(&parts), rest, triangles, &labels))
            .transpose()?;
        let topology = CreaseTopology::new(triangles, &faces, &regions.w1, &regions.w2);
        let joint_size = regions.joint_size(rest, triangles);
        let sized_vertices = regions.sized_vertices();
        let rest_box = crate::selfcontact::regions::box_diagonal_of(&sized_vertices, rest);
        let sized_sample = extremes(&sized_vertices, rest);
        let region_triangles: Vec<[u32; 3]> =
            faces.iter().map(|&f| triangles[f as usize]).collect();
        let rest_edge = crate::mesh::operators::mean_edge_length(rest, &region_triangles);
        let shared_adjacency = shared.solver.region.adjacency();
        let guarded_faces = faces_touching(triangles, &regions.w1, &regions.w2);
        Ok(Self {
            joint_size,
            rest_box,
            sized_vertices,
            sized_sample,
            rest_edge,
            regions,
            w1,
            w2,
            shared,
            labels,
            faces,
            parts,
            separated_parts,
            closed,
            surface: None,
            winding,
            topology,
            shared_adjacency,
            guarded_faces,
        })
    }

    /// The surface the inside-twice test reads, of the body's `triangles`
    /// ([`FoldPre::on_surface`]).
    pub(crate) fn inside_surface<'t>(&'t self, triangles: &'t [[u32; 3]]) -> &'t [[u32; 3]] {
        self.surface.as_deref().map_or(triangles, Vec::as_slice)
    }

    /// The inside-twice tree of the body's `triangles` at `rest` without the faces `left`
    /// marks ([`FoldPre::on_surface`]).
    pub fn surface_winding(
        rest: &[Point3<f64>],
        triangles: &[[u32; 3]],
        left: &[bool],
    ) -> WindingNumber {
        let kept = (0..triangles.len() as u32)
            .filter(|&f| !left.get(f as usize).copied().unwrap_or(false));
        WindingNumber::with_faces_beta(rest, triangles, kept, INSIDE_BETA)
    }

    /// The fold on a surface of its body: its `kept` triangles and their inside-twice tree
    /// ([`FoldPre::surface_winding`]), without separate pieces of the mesh that are not its
    /// own (other pieces, and those sunk into it or lying inside a larger one at rest,
    /// [`crate::selfcontact::layers`]). Its inside-twice test and its closed-surface test read
    /// that surface; the volume solve still reads the whole body, whose other pieces do not
    /// move and so change no volume difference.
    pub fn on_surface(&mut self, kept: Arc<Vec<[u32; 3]>>, winding: Arc<WindingNumber>) {
        self.closed = crate::mesh::Region::whole(&kept).is_closed();
        self.surface = Some(kept);
        self.winding = winding;
    }
}

/// Of `vertices`, the lowest and highest at `positions` along each axis (at most six, sorted,
/// those out of range left out).
fn extremes(vertices: &[u32], positions: &[Point3<f64>]) -> Vec<u32> {
    let at = |v: &u32| positions.get(*v as usize).map(|p| (*v, p));
    let mut sample: Vec<u32> = (0..3)
        .flat_map(|axis| {
            let key = move |(_, p): &(u32, &Point3<f64>)| p[axis];
            let low = vertices
                .iter()
                .filter_map(at)
                .min_by(|a, b| key(a).total_cmp(&key(b)));
            let high = vertices
                .iter()
                .filter_map(at)
                .max_by(|a, b| key(a).total_cmp(&key(b)));
            [low, high].into_iter().flatten().map(|(v, _)| v)
        })
        .collect();
    sample.sort_unstable();
    sample.dedup();
    sample
}

/// The faces with a corner in `W1 ∪ W2` (flags per vertex), sorted.
fn faces_touching(triangles: &[[u32; 3]], w1: &[bool], w2: &[bool]) -> Vec<u32> {
    let inside = |v: u32| {
        let v = v as usize;
        w1.get(v).copied().unwrap_or(false) || w2.get(v).copied().unwrap_or(false)
    };
    (0..triangles.len() as u32)
        .filter(|&f| triangles[f as usize].iter().any(|&v| inside(v)))
        .collect()
}

/// The detection step of a fold: the vertices of the faces crossing the other part (rest
/// partition), and how long it took.
#[derive(Clone, Debug)]
pub struct Detection {
    /// Vertices of the crossed faces, sorted.
    pub vertices: Vec<u32>,
    /// The crossing face pairs (W1's side's face first), sorted.
    pub face_pairs: Vec<[u32; 2]>,
    /// Seconds, with the refit of the body's tree when this detection did it (in the
    /// self-contact pass: the first fold of a body in a frame, or the first after a fold moved
    /// the body; the others reuse that tree).
    pub seconds: f64,
}

impl FoldPre {
    /// Whether the shared region (both regions, when separated) is posed smaller than
    /// [`crate::pass::COLLAPSED`] times its rest size (a joint scaled to 0): such a fold is not
    /// resolved (nothing to resolve at that size, and all its faces overlap each other). Sizes here are the diagonals of the
    /// region's bounding box, posed and at rest (cheaper than the joint's size, and a guard
    /// at 1e-6 does not see the orientation's factor of at most √3).
    pub fn collapsed(&self, positions: &[Point3<f64>]) -> bool {
        let bound = crate::pass::COLLAPSED * self.rest_box;
        let box_of = |v| crate::selfcontact::regions::box_diagonal_of(v, positions);
        // The sample's box lies in the whole box: at least the bound, so is the whole (a
        // frame without contact read all the shared region's vertices here per fold, 7 % of
        // its pass on the finger).
        if box_of(&self.sized_sample) >= bound {
            return false;
        }
        let size = box_of(&self.sized_vertices);
        // NaN counts as collapsed (no size to resolve a fold at).
        size.is_nan() || size < bound
    }

    /// Whether the shared region (both regions, when separated) is posed larger than
    /// [`crate::pass::STRETCHED`] times its rest size (a broken animation scaling a joint by
    /// 1e20): such a fold is not resolved either (see there). `tree_box`: the box of the
    /// body's detection tree at `positions`, which holds the region's faces: when it is within
    /// the bound, so is the region, and nothing else is read.
    pub fn stretched(&self, positions: &[Point3<f64>], tree_box: Option<&Aabb>) -> bool {
        let bound = crate::pass::STRETCHED * self.rest_box;
        if tree_box.is_some_and(|b| (b.max - b.min).norm() <= bound) {
            return false;
        }
        let size = crate::selfcontact::regions::box_diagonal_of(&self.sized_vertices, positions);
        size > bound
    }

    /// Detection with the rest partition: `None` when the fold does not intersect itself at
    /// `positions` (then nothing else of the fold needs computing, not even normals). The
    /// one-off form of [`FoldPre::detect_on`]: it builds a tree over the mesh at `positions`,
    /// where the self-contact pass refits one tree per body and frame for all its joints.
    pub fn detect(
        &self,
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
    ) -> Result<Option<Detection>, FoldError> {
        let clock = Instant::now();
        let index = MeshIndex::with_faces(positions, triangles, &self.sided_faces())?;
        let sets = self.face_sets(&index);
        self.detect_on(&index.posed_as_built(positions)?, &sets, clock)
    }

    /// The faces of both sides of the rest partition (sorted): what the detection's tree must
    /// hold.
    pub fn sided_faces(&self) -> Vec<u32> {
        (0..self.labels.len() as u32)
            .filter(|&f| self.labels[f as usize] != 0)
            .collect()
    }

    /// The two sides of the rest partition (W1's faces 1, W2's 2) marked in `body`'s tree, for
    /// [`FoldPre::detect_on`]: once per rig.
    pub fn face_sets(&self, body: &MeshIndex) -> FaceSets {
        body.face_sets(|f| self.labels.get(f as usize).copied().unwrap_or(0))
    }

    /// Detection on the fold's body posed with its tree refit (`sets` from
    /// [`FoldPre::face_sets`] on that body's index): the face pairs crossing the other side
    /// and their vertices, `None` when none do. `started`: when the detection began, so that
    /// [`Detection::seconds`] includes the tree's refit where the caller did it.
    pub fn detect_on(
        &self,
        body: &PosedMesh,
        sets: &FaceSets,
        started: Instant,
    ) -> Result<Option<Detection>, FoldError> {
        intersecting_faces(body, sets, started)
    }
}

/// Face labels from `β` at rest: 1 on W1's side, 2 on W2's, 0 outside both.
fn rest_labels(triangles: &[[u32; 3]], r: &PairRegions) -> Vec<u8> {
    triangles
        .iter()
        .map(|t| {
            let in_w = |w: &[bool]| t.iter().all(|&v| w[v as usize]);
            if !(in_w(&r.w1) || in_w(&r.w2)) {
                return 0;
            }
            let b = t.iter().map(|&v| r.beta[v as usize]).sum::<f64>() / 3.0;
            if b >= 0.5 {
                1
            } else {
                2
            }
        })
        .collect()
}

/// Detection with the rest partition: the crossing face pairs and their vertices, or `None`
/// when the fold does not intersect itself.
fn intersecting_faces(
    body: &PosedMesh,
    sets: &FaceSets,
    started: Instant,
) -> Result<Option<Detection>, FoldError> {
    let ints = Intersections::between_sets(body, sets)?;
    if ints.is_empty() {
        return Ok(None);
    }
    let face_pairs: Vec<[u32; 2]> = ints.segments.iter().map(|s| s.faces).collect();
    let triangles = body.triangles();
    let mut vertices: Vec<u32> = face_pairs
        .iter()
        .flatten()
        .flat_map(|&f| triangles[f as usize])
        .collect();
    vertices.sort_unstable();
    vertices.dedup();
    Ok(Some(Detection {
        vertices,
        face_pairs,
        seconds: started.elapsed().as_secs_f64(),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sample holds each axis's lowest and highest vertex of the list (not of the
    /// positions), once each: its box is the list's box.
    #[test]
    fn the_sample_spans_the_box_of_its_list() {
        let p = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(-9.0, 9.0, 9.0), // not listed: lower and higher than all listed
            Point3::new(2.0, -1.0, 0.5),
            Point3::new(1.0, 3.0, -2.0),
            Point3::new(0.5, 0.5, 4.0),
            Point3::new(0.6, 0.6, 0.6),
        ];
        let listed = [0, 2, 3, 4, 5, 42];
        let sample = extremes(&listed, &p);
        assert_eq!(sample, vec![0, 2, 3, 4]);
        let box_of = |v: &[u32]| crate::selfcontact::regions::box_diagonal_of(v, &p);
        assert_eq!(box_of(&sample), box_of(&listed));
        assert!(extremes(&[], &p).is_empty());
    }
}
