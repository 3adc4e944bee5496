//! One joint folding into itself, per frame (2021 Sec. 6): detection, crease partition,
//! contact on the truncated working regions, direction field, deformation of both whole
//! regions, partition-of-unity blend and one volume solve over the blended pair.
//!
//! With `PIPELINE.md`'s conventions: `d̂_12` is W1's outward direction at the fold (from the
//! skeleton or the user); both regions use `d̄ = σ d̂_12`, `σ` harmonic on the shared region
//! `R` with `σ = +1` on `W1 \ R` and on `∂C_1`, `-1` on `W2 \ R` and on `∂C_2` (the paper's
//! `(2β - 1) d̄` can reverse W2's own contact displacement); each region is deformed with both
//! contact zones (the zone found on one side is "reported" onto the part of the other region
//! that was cut away); `p' = β p'_1 + (1 - β) p'_2` with one bulge height `h_v` solved on the
//! blended `P` and `Q` (else the indentation inside `R` is compensated twice).

use super::bulge_guard::{bulge_scales, BulgeStep, TOLERANCE};
use super::crease::{crease_cut, Crease, CreaseInput, CreaseParams, CreaseTopology};
use super::regions::PairRegions;
use super::turn_guard::{displacement_scales, GuardInput, TurnReference};
use crate::contact::{
    inside_from, resolve_self_pair, Contact, ContactSide, DirectionMode, InsideTwice, PairParams,
    SideFrame,
};
use crate::deform::region::{bulge_height, shape_region};
use crate::deform::volume::RootKind;
use crate::deform::{DeformParams, DeformStats, RegionDeformation, RegionFrame, WorkingRegion};
use crate::heat::{Boundary, EdgePoint};
use crate::intersect::{FaceSets, Intersections, MeshIndex, PosedMesh};
use crate::pass::StageTimings;
use crate::report::metrics::WindingNumber;
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

/// Why a fold could not be resolved in a frame.
#[derive(Debug, thiserror::Error)]
pub enum FoldError {
    /// Intersection queries on the parts.
    #[error(transparent)]
    Intersect(#[from] crate::intersect::IntersectError),
    /// The crease min-cut.
    #[error(transparent)]
    MinCut(#[from] crate::mincut::MinCutError),
    /// The contact between the truncated regions.
    #[error(transparent)]
    Contact(#[from] crate::contact::ContactError),
    /// A region's deformation.
    #[error(transparent)]
    Deform(#[from] crate::deform::DeformError),
    /// A harmonic solve (`σ`).
    #[error(transparent)]
    Heat(#[from] crate::heat::HeatError),
    /// A region's analysis.
    #[error(transparent)]
    Solve(#[from] crate::solve::SolveError),
}

/// Relative volume change above which a fold that no bulge balances is left unresolved (see
/// [`FoldOutput::unbalanced`]).
pub const UNBALANCED_VOLUME: f64 = 1e-6;

/// Largest bulge, as a multiple of the band it rises from: a region's largest bulge
/// displacement `γ h_v |Q|` above `STEEPEST_BULGE ×` its effective extent `φ_max,eff` makes
/// the fold unbalanced (see [`FoldOutput::unbalanced`]). Such a bulge is steeper than 45° on
/// average: it happens when a zone of a few vertices sits on its region's border, where the
/// extent is capped to almost nothing and the whole lost volume must rise from a sliver.
/// Measured (largest ratio per fold): below 0.1 over the committed rigs' animations. Before
/// the amplitude faded across the crease (`deform::region`), CesiumMan with the object pass's
/// extent floor (`κ = 3`) had four folds at 1.4, 1.6, 1.9 and 12 (bulges of 14 to 42 edge
/// lengths in frame 5, which took that frame from 17 to 116 penetrating vertices); now none
/// there with either floor, and the rule stays a safeguard, exercised by the bending capsule
/// with `φ̄` = 0.1 × the joint's size (ratios 1.3 to 9, every fold refused).
pub const STEEPEST_BULGE: f64 = 1.0;

/// β of the fold's winding-number tree. Its queries only decide "inside twice" (a winding
/// number of at least 1.5 between 1 and 2): at β = 1.5 the error stays below 0.03 (measured
/// against the brute force near the surfaces of the bent finger and capsule; 0.39 at β = 1),
/// and the contact step of the finger takes 9.8 ms instead of 11.2 at the metrics' β = 2.
const INSIDE_BETA: f64 = 1.5;

/// Default [`FoldParams::tau`].
pub const DEFAULT_FOLD_TAU: f64 = -1.0;

/// The extent floor factor `κ` of a fold's regions ([`DeformParams`]'s
/// `intersection_extent_factor`): 0, the paper's fixed `φ̄` (already scaled to the joint by
/// [`FoldParams::joint_extent`]). The object pass's floor (`κ = 3`: the extent reaches three
/// times the distance from the zone to the intersection curve) let a fold whose intersection
/// runs far along the body spread its deformation over it: on CesiumMan a 3-vertex zone's
/// region got an extent of 3 scene units (the figure is 1.5 tall) and turned 277 faces.
/// Measured against `κ = 3` (21 frames, summed): CesiumMan 88 → 54 penetrating vertices, 688 →
/// 225 turned faces, largest displacement 9.8 → 5.3 edge lengths (before the amplitude faded
/// across the crease: 67 → 49, 590 → 260, 2 → 0 folds refused, 9.1 → 4.1, and the committed
/// rigs unchanged: the floor set a fold's extent in 3 of 496 region deformations, all on the
/// CoR capsule, with the same metrics).
pub const FOLD_EXTENT_FLOOR: f64 = 0.0;

/// Default [`FoldParams::joint_extent`].
pub const DEFAULT_JOINT_EXTENT: f64 = 1.5;

/// Parameters of one fold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FoldParams {
    /// `k̄` of W1 (W1 moves `1 - k̄` of the way; 0.5 for one material, the paper's setting
    /// for its skinned folds). Asymmetric values leave folds unresolved: `S` (Sec. 4.3) nears
    /// the stiff side's own skinned surface, tilted the other way near the crease, so the soft
    /// side's faces turn over as they conform to it, or stay inside where the turn guard
    /// scales them back (README, "Self-contact"). Measured on the LBS capsule (worst frame of
    /// 31, two sweeps; penetrating vertices / turned faces): `k̄ = 0.25` 40 / 0 with the turn
    /// guard, 1 / 37 without; `k̄ = 0` 307 / 0, and 2 / 97 without; 0.5 gives 0 / 0.
    pub stiffness_1: f64,
    /// `τ` of Eq. 4. Default -1, the paper's setting for both its skinned folds (Fig. 13, the
    /// bending capsule with LBS and CoR input; Fig. 15, the finger): a wider contact zone
    /// (`ε_c` one standard deviation below the mean depth) reaches further into the crease.
    /// Measured against `τ = 0` on the 31-frame animations (worst frame): CoR capsule 5 → 2
    /// penetrating vertices and 30 → 18 turned faces, DQS 2 → 3 and 22 → 18, finger 1 → 0,
    /// LBS capsule and mouth unchanged (0 and 0; temporal ratios 1.82 → 1.78, 1.03 → 1.03).
    pub tau: f64,
    /// The safeguard angle of Sec. 4.4 in degrees ([`PairParams::safeguard_angle`]; default
    /// 80°, the paper's). It governs the zones of Eq. 3; the crease vertices that
    /// `zones_to_the_crease` adds to a zone are not subject to it (they sit where the two parts
    /// meet, their normals anywhere: up to 132° from the direction on the CoR capsule).
    /// Measured with 75° against 80° (`pose --metrics`, two sweeps, summed penetrating
    /// vertices): CesiumMan's walk ratio 7.05 → 4.04 over 61 frames and 2 → 0 turned faces,
    /// but 58 → 80 penetrating vertices over 21 frames; CoR and DQS capsules 23 → 49 and
    /// 21 → 44 over 31 frames (CoR ratio 22.47 → 22.90); LBS capsule, finger and mouth
    /// unchanged.
    pub safeguard_angle: f64,
    /// Deformation parameters of both regions.
    pub deform: DeformParams,
    /// Crease graph weights.
    pub crease: CreaseParams,
    /// `φ̄` as a multiple of the joint's size ([`FoldPre::joint_size`], a second moment of its
    /// shared region at rest); when set it replaces `deform.extent` (scene units). Default 1.5:
    /// scale-free, and on the committed rigs the extents of the former default, 1.75 × the
    /// diagonal of the region's axis-aligned rest box (the second moment is 1.16-1.19 of it on
    /// the finger's and the capsule's joints, 1.11 on the mouth's), without the box's
    /// dependence on the rig's orientation. Measured against the former default (`pose
    /// --metrics`, two sweeps): LBS capsule ratios 1.70 and 5.42 at 31 and 76 frames (1.69,
    /// 5.39), CoR 22.47 and 140.8 (22.45, 137.7), DQS, finger and mouth the same, CesiumMan
    /// 53 penetrating vertices over 21 frames (49) and a walk ratio of 7.05 (7.31). With box
    /// diagonals, 1.0 and 1.5 let the object pass's extent floor take over on the capsule's
    /// last frames (a pop, ratio 7.9 and 4.5; the fold's floor is now 0) and 2.0 left up to 9
    /// penetrating vertices on the finger; 1 scene unit, the first default (5 capsule radii,
    /// 11 finger radii), spread the bulge over whole limbs and left the finger 17.
    pub joint_extent: Option<f64>,
    /// Scale the blended displacement back where it would turn a face over (against both its
    /// input normal and the skinning's; [`super::turn_guard`]; needs
    /// [`FoldInput::turn_reference`]). Not in the paper. Default on. Measured (31-frame bends,
    /// worst frame; CesiumMan summed over 21 frames), without → with: CoR bend 15 → 0 turned
    /// faces, 5 → 5 penetrating vertices (per frame -3 to +3), temporal ratio 22.1 → 22.4;
    /// DQS 9 → 0, 4 → 5, 20.8 → 21.2; CesiumMan 225 → 2 turned, 54 → 53 penetrating, largest
    /// displacement 5.3 → 4.2 h. The LBS capsule, finger, mouth and curled hand never trigger
    /// it (outputs identical to the bit) and pay one pass over the moving faces per fold
    /// (≤ 2 % of a finger frame, alternated runs). Where it acts it costs its rounds and more
    /// volume solves (`GUARD_SOLVES`): CoR bend, 31 frames, two sweeps, one thread, 46 folds, the
    /// blend-and-volume step 28 → 80 ms in all (1.1 ms per fold), 4-12 % of the whole in
    /// alternated runs; `cargo bench --bench selfcontact -- "turn guard"` 794 → 924 ms.
    pub turn_guard: bool,
    /// Scale the bulge back where it would carry a face of one truncated part through a face
    /// of the other, the volume solved again ([`super::bulge_guard`]). Not in the paper.
    /// Default on. Measured (two sweeps, penetrating vertices summed over the frames, without
    /// → with): CesiumMan 58 → 21 over 21 frames (0.67 → 0.39 h deep), the volume exact;
    /// Fox's run 102 → 79 and walk 64 → 53 over 41 frames (temporal ratios 3.14 → 1.77, 2.37
    /// → 2.13); `finger_long` 1 → 0 over 61; CoR capsule 23 → 19, DQS 21 → 17 over 31; the
    /// LBS capsule, finger and mouth 0 either way. Cost (one thread, alternated runs): a
    /// median CesiumMan frame 13.5 → 18.9 ms, `finger_long` 75 → 77 ms, the CoR capsule's 31
    /// frames 1.03 → 1.3 s. The guard's checks share the turn guard's volume solves (at most
    /// 4).
    pub bulge_guard: bool,
    /// Leave out of the contact zones the crease vertices that the fold would add to a zone
    /// (inside the other part, `zones_to_the_crease`) but that do not connect to it: only
    /// those next to one of its vertices, or to a crease vertex joining it, over the shared
    /// region's edges, join. The isolated ones keep the profile's displacement and a harmonic
    /// `σ` (the name is the former rule's, which left only `σ` free; kept for the
    /// configuration files). Not in the paper; default off.
    /// Such a vertex joins or leaves its zone from one frame to the next, pinned on `S` and
    /// given its zone's sign at once: next to a vertex where `σ` was about 0, the amplitude,
    /// faded by `|σ|`, came back in one frame, and the mouth's corners popped by 0.15-0.3 h
    /// (temporal ratio 3.14 at 91 frames with the vertical direction, 2.93 with the
    /// skeleton's). Measured with the setting (`pose --metrics`, 2026-12-03; summed
    /// penetrating vertices, default → setting): the mouth 1.02 and 1.00 at 91 frames, its
    /// faces inverted against the input 7 → 0, no penetrating vertex either way; the LBS
    /// capsule, finger and `finger_long` unchanged (0; the finger's ratio at 91 frames 1.84);
    /// the finger with DQS and CoR input 65 → 36 and 45 → 32 over 31 frames; but the
    /// capsule with CoR 10 → 17 (up to 5 in a frame, 0.30 h deep) and DQS 9 → 12, at 76
    /// frames 29 → 54 and 34 → 48, Fox's run 69 → 78 (a face turned), CesiumMan 21 → 21. For
    /// a pair like the lips, not for an articulation squashed into a wall. (Until 2026-12-03
    /// the setting left such vertices in their zone with `σ` free there: the same mouth
    /// ratios, with 9 to 13 inverted faces, the finger with DQS 59, the capsule with CoR 21.)
    pub free_isolated_crease: bool,
}

impl FoldParams {
    /// The deformation parameters of a fold: `φ̄ = joint_extent × joint size` when set.
    pub fn deform_at(&self, pre: &FoldPre) -> DeformParams {
        let mut deform = self.deform;
        if let Some(k) = self.joint_extent {
            deform.extent = k * pre.joint_size;
        }
        deform
    }
}

impl Default for FoldParams {
    fn default() -> Self {
        Self {
            stiffness_1: 0.5,
            tau: DEFAULT_FOLD_TAU,
            safeguard_angle: crate::contact::zones::DEFAULT_SAFEGUARD_ANGLE,
            deform: DeformParams {
                intersection_extent_factor: FOLD_EXTENT_FLOOR,
                ..DeformParams::default()
            },
            crease: CreaseParams::default(),
            joint_extent: Some(DEFAULT_JOINT_EXTENT),
            turn_guard: true,
            bulge_guard: true,
            free_isolated_crease: false,
        }
    }
}

/// What is precomputed once per joint pair.
#[derive(Debug)]
pub struct FoldPre {
    /// The regions, `R` and `β`.
    pub regions: PairRegions,
    w1: WorkingRegion,
    w2: WorkingRegion,
    shared: WorkingRegion,
    /// Faces at rest: 1 on W1's side, 2 on W2's, 0 elsewhere ([`rest_labels`]).
    labels: Vec<u8>,
    faces: Vec<u32>,
    /// BVH over `faces` (at rest), restricted to each truncated part per frame.
    parts_tree: crate::intersect::bvh::TriangleBvh,
    closed: bool,
    /// The body's winding-number tree at rest ([`FoldPre::body_winding`]), shared by the
    /// body's folds.
    winding: Arc<WindingNumber>,
    topology: CreaseTopology,
    /// Neighbours of each local vertex of `shared` (local ids).
    shared_adjacency: Vec<Vec<u32>>,
    /// The joint's size at rest ([`PairRegions::joint_size`]).
    pub joint_size: f64,
    /// The diagonal of the shared region's bounding box at rest ([`FoldPre::collapsed`]).
    rest_box: f64,
    /// The mean edge length of the working regions' faces at rest (the bulge guard's unit).
    rest_edge: f64,
    /// The faces the turn guard checks: every face with a corner in `W1 ∪ W2`, those beyond
    /// the working regions' border included, since the bulge moves the border's vertices too
    /// (until 2026-12-03 only `W1 ∪ W2`'s faces: with the seam samples of
    /// [`crate::contact::mapping`] a fold of Fox's hip turned face 33, next to the border, and
    /// no guard saw it).
    guarded_faces: Vec<u32>,
}

/// Time per step of one fold, in seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct FoldTimings {
    /// Detection with the rest partition.
    pub detection: f64,
    /// Crease cut and truncated parts.
    pub crease: f64,
    /// Contact surface and zones (Sec. 4.2-4.4).
    pub contact: f64,
    /// The zones' extension to the crease and the direction field `σ`.
    pub directions: f64,
    /// Both regions' deformation (Sec. 5).
    pub deformation: f64,
    /// Blend and volume.
    pub volume: f64,
    /// The same time in the columns of the paper's Table 1: i. the detection, the crease cut
    /// and the truncated parts' intersection; m. and c. the contact's mapping and zones; di.
    /// the zones' extension to the crease, `σ` and both regions' direction fields; p., g. and
    /// s. both regions' parametrization, diffusions and numeric factorizations; de. both
    /// regions' profiles and bulge map, the blend and the volume solve.
    pub stages: StageTimings,
}

add_assign_fields!(
    "Times of several folds, summed step by step.",
    FoldTimings {
        detection,
        crease,
        contact,
        directions,
        deformation,
        volume,
        stages,
    }
);

impl FoldTimings {
    /// The fold's whole time: the sum of its steps.
    pub fn total(&self) -> f64 {
        self.detection
            + self.crease
            + self.contact
            + self.directions
            + self.deformation
            + self.volume
    }
}

/// The result of one fold in one frame.
#[derive(Clone, Debug)]
pub struct FoldOutput {
    /// Output positions of the whole mesh.
    pub positions: Vec<Point3<f64>>,
    /// The crease partition.
    pub crease: Crease,
    /// The contact between the truncated regions.
    pub contact: Contact,
    /// `σ` per mesh vertex (0 outside `W1 ∪ W2`).
    pub sigma: Vec<f64>,
    /// Statistics of W1's and W2's deformations.
    pub stats: [DeformStats; 2],
    /// The common bulge height.
    pub bulge_height: f64,
    /// How it was found (`None` for an open mesh: no volume to keep).
    pub root: Option<RootKind>,
    /// The largest bulge displacement `γ h_v |Q|` of either region over that region's
    /// effective extent `φ_max,eff` (0 without bulge; `+∞` for a bulge on a zero extent).
    pub bulge_steepness: f64,
    /// No plausible bulge could keep the volume: either no exact root of the cubic (e.g. a
    /// zone whose region's extent is capped to nothing by its border) while the deformation
    /// changed the volume by more than [`UNBALANCED_VOLUME`], or the root gives a bulge
    /// higher than [`STEEPEST_BULGE`] × the band it rises from. `positions` is then the input:
    /// the fold is left unresolved rather than resolved with a volume error (measured on
    /// CesiumMan: 7e-3) or a spike.
    pub unbalanced: bool,
    /// Vertices whose displacement the turn guard scaled back ([`FoldParams::turn_guard`]).
    pub guarded: usize,
    /// Vertices whose bulge the bulge guard scaled back ([`FoldParams::bulge_guard`]).
    pub bulge_guarded: usize,
    /// Each region's own deformation with the common bulge height, before the blend (`p'_1`,
    /// `p'_2`; whole mesh, unchanged outside the region).
    pub region_positions: [Vec<Point3<f64>>; 2],
    /// Timings.
    pub timings: FoldTimings,
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

    /// A copy of the body's tree at rest, for [`resolve_detected_in`].
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
        // The indices are the regions' own (derived from `triangles`); the positions are
        // checked before a tree is built on them.
        crate::intersect::check_positions(rest)?;
        let parts_tree = crate::intersect::bvh::TriangleBvh::build(rest, triangles, &faces);
        // Only the topology is needed here (no factorization of the whole mesh).
        let closed = crate::mesh::Region::whole(triangles).is_closed();
        let topology = CreaseTopology::new(triangles, &faces, &regions.w1, &regions.w2);
        let joint_size = regions.joint_size(rest, triangles);
        let rest_box = regions.box_diagonal(rest);
        let region_triangles: Vec<[u32; 3]> =
            faces.iter().map(|&f| triangles[f as usize]).collect();
        let rest_edge = crate::mesh::operators::mean_edge_length(rest, &region_triangles);
        let shared_adjacency = shared.solver.region.adjacency();
        let guarded_faces = faces_touching(triangles, &regions.w1, &regions.w2);
        Ok(Self {
            joint_size,
            rest_box,
            rest_edge,
            regions,
            w1,
            w2,
            shared,
            labels,
            faces,
            parts_tree,
            closed,
            winding,
            topology,
            shared_adjacency,
            guarded_faces,
        })
    }
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
    /// Seconds, with the refit of the body's tree when this detection did it (in the
    /// self-contact pass: the first fold of a body in a frame, or the first after a fold moved
    /// the body; the others reuse that tree).
    pub seconds: f64,
}

impl FoldPre {
    /// Whether the shared region is posed smaller than [`crate::pass::COLLAPSED`] times its
    /// rest size (a joint scaled to 0): such a fold is not resolved (nothing to resolve at that
    /// size, and all its faces overlap each other). Sizes here are the diagonals of the
    /// region's bounding box, posed and at rest (cheaper than the joint's size, and a guard
    /// at 1e-6 does not see the orientation's factor of at most √3).
    pub fn collapsed(&self, positions: &[Point3<f64>]) -> bool {
        let size = self.regions.box_diagonal(positions);
        // NaN counts as collapsed (no size to resolve a fold at).
        self.regions.shared.is_empty()
            || size.is_nan()
            || size < crate::pass::COLLAPSED * self.rest_box
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
    /// [`FoldPre::face_sets`] on that body's index): the vertices of the faces crossing the
    /// other side, `None` when none do. `started`: when the detection began, so that
    /// [`Detection::seconds`] includes the tree's refit where the caller did it.
    pub fn detect_on(
        &self,
        body: &PosedMesh,
        sets: &FaceSets,
        started: Instant,
    ) -> Result<Option<Detection>, FoldError> {
        Ok(
            intersecting_vertices(body, sets)?.map(|vertices| Detection {
                vertices,
                seconds: started.elapsed().as_secs_f64(),
            }),
        )
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

/// The fold in one frame, once [`FoldPre::detect`] found it intersecting itself: `None` when
/// the truncated parts turn out not to be in contact, or when neither side has a contact zone
/// (the time spent finding that out is then not reported in any fold's timings).
pub fn resolve_detected(
    pre: &FoldPre,
    detection: &Detection,
    geometry: &FoldInput,
    params: &FoldParams,
) -> Result<Option<FoldOutput>, FoldError> {
    let mut winding = pre.body_tree();
    resolve_detected_in(pre, detection, geometry, params, &mut winding)
}

/// [`resolve_detected`] with the body's winding-number tree `winding` kept by the caller
/// between the folds of a frame: [`FoldPre::body_tree`], or that tree as an earlier fold of the
/// same body in the same frame left it. It is refit whole at the first fold, then only at its
/// leaves with a moved corner ([`WindingNumber::refit_changed`]), to the same bits as a copy
/// of the rest tree refit whole: the folds of a body each move one joint's regions.
pub fn resolve_detected_in(
    pre: &FoldPre,
    detection: &Detection,
    geometry: &FoldInput,
    params: &FoldParams,
    winding: &mut WindingNumber,
) -> Result<Option<FoldOutput>, FoldError> {
    let FoldInput {
        positions,
        normals,
        triangles,
        direction,
        ..
    } = *geometry;
    let mut timings = FoldTimings {
        detection: detection.seconds,
        ..FoldTimings::default()
    };
    let mut laps = Laps::start();
    let inside = winding
        .refit_changed(positions, triangles)
        .then(|| InsideTwice::new(std::borrow::Cow::Borrowed(&*winding), positions, triangles));
    let tree = inside.as_ref();
    let (crease, truncated) = cut_the_crease(pre, detection, geometry, tree, params)?;
    timings.crease = laps.next();
    let contact = truncated_contact(&truncated, positions, normals, direction, params, tree)?;
    timings.contact = laps.next();
    let Some(mut contact) = contact else {
        return Ok(None);
    };
    // Intersecting faces without a contact zone on either side (zero depth: the Quaternius
    // robot's rigid finger pieces, modeled interpenetrating) leave every vertex where it is:
    // the crease can extend zones, not create them, and the rest of the fold only moved
    // vertices by round-off (at most 2.3e-16 on CesiumMan), at 0.6 ms per robot frame.
    if contact.sides.iter().all(|s| s.zone.vertices.is_empty()) {
        return Ok(None);
    }
    if let Some(tree) = tree {
        let crease_input = CreaseVertices {
            on_w1: &crease.on_w1,
            positions,
            normals,
            test: tree,
        };
        zones_to_the_crease(
            pre,
            &crease_input,
            &mut contact,
            params.free_isolated_crease,
        );
    }
    let sigma = sigma_field(pre, positions, &contact)?;
    timings.directions = laps.next();
    let [s1, s2] = deform_both(pre, geometry, &contact, &sigma, params)?;
    timings.deformation = laps.next();
    let blended = blend_and_balance(pre, geometry, [&s1, &s2], params, &truncated)?;
    timings.volume = laps.next();
    let gamma_h = params.deform.gamma * blended.h;
    timings.stages = table1_stages(&timings, &contact.timings, [&s1.timings, &s2.timings]);
    Ok(Some(FoldOutput {
        region_positions: [own_positions(&s1, gamma_h), own_positions(&s2, gamma_h)],
        positions: blended.positions,
        crease,
        contact,
        sigma,
        stats: [s1.stats, s2.stats],
        bulge_height: blended.h,
        root: blended.root,
        bulge_steepness: blended.steepness,
        unbalanced: blended.unbalanced,
        guarded: blended.guarded,
        bulge_guarded: blended.bulge_guarded,
        timings,
    }))
}

/// The posed body of one frame, as a fold reads it.
#[derive(Clone, Copy)]
pub struct FoldInput<'a> {
    /// Positions of the whole mesh.
    pub positions: &'a [Point3<f64>],
    /// Unit vertex normals of `positions`.
    pub normals: &'a [Vector3<f64>],
    /// Mesh triangles.
    pub triangles: &'a [[u32; 3]],
    /// `d̂_12`, W1's outward direction.
    pub direction: Vector3<f64>,
    /// What the turn guard keeps faces from turning against ([`FoldParams::turn_guard`]):
    /// the frame's input and the skinning's normals; `None`: no guard.
    pub turn_reference: Option<TurnReference<'a>>,
}

/// Seconds between successive calls of [`Laps::next`].
struct Laps {
    clock: Instant,
    mark: f64,
}

impl Laps {
    fn start() -> Self {
        Self {
            clock: Instant::now(),
            mark: 0.0,
        }
    }

    /// Seconds since the previous lap (or the start).
    fn next(&mut self) -> f64 {
        let now = self.clock.elapsed().as_secs_f64();
        let step = now - self.mark;
        self.mark = now;
        step
    }
}

/// Sec. 6 "Crease detection & Partitioning": the min-cut of `R` (intersection terms on the
/// intersecting vertices and, when the body is closed, those of `R` buried in the other
/// part), and the two truncated parts it leaves, indexed for Sec. 4.2-4.4.
fn cut_the_crease(
    pre: &FoldPre,
    detection: &Detection,
    g: &FoldInput,
    tree: Option<&InsideTwice>,
    params: &FoldParams,
) -> Result<(Crease, [MeshIndex; 2]), FoldError> {
    let r = &pre.regions;
    let intersecting = match tree {
        Some(tree) => with_buried(pre, g.positions, g.normals, tree, &detection.vertices),
        None => detection.vertices.clone(),
    };
    let crease = crease_cut(
        &CreaseInput {
            positions: g.positions,
            normals: g.normals,
            triangles: g.triangles,
            faces: &pre.faces,
            w1: &r.w1,
            w2: &r.w2,
            beta: &r.beta,
            direction: g.direction,
            intersecting: &intersecting,
            topology: Some(&pre.topology),
        },
        &params.crease,
    )?;
    let labels = cut_labels(g.triangles, &pre.faces, &crease.on_w1);
    let truncated = MeshIndex::self_contact_parts_within(
        Some(&pre.parts_tree),
        g.positions,
        g.triangles,
        &labels,
    )?;
    Ok((crease, truncated))
}

/// Sec. 5 on both working regions with the mapping field `σ d̂` (Sec. 6 "Consistent mapping
/// direction"), `R`'s vertices free to move: the two are independent until the blend.
fn deform_both(
    pre: &FoldPre,
    g: &FoldInput,
    contact: &Contact,
    sigma: &[f64],
    params: &FoldParams,
) -> Result<[RegionDeformation; 2], FoldError> {
    let r = &pre.regions;
    let field: Vec<Vector3<f64>> = sigma.iter().map(|s| g.direction * *s).collect();
    let sides: Vec<&ContactSide> = contact.sides.iter().collect();
    let shared: Vec<bool> = r.w1.iter().zip(&r.w2).map(|(a, b)| *a && *b).collect();
    let frame = RegionFrame {
        positions: g.positions,
        normals: g.normals,
        triangles: g.triangles,
        contacts: &sides,
        painted: None,
        direction_field: Some(&field),
        free_border: Some(&shared),
    };
    let deform = params.deform_at(pre);
    let (s1, s2) = rayon::join(
        || shape_region(&pre.w1, &frame, &deform),
        || shape_region(&pre.w2, &frame, &deform),
    );
    Ok([s1?, s2?])
}

/// One region's own result before the blend: `P + γ h_v Q`.
fn own_positions(region: &RegionDeformation, gamma_h: f64) -> Vec<Point3<f64>> {
    region
        .base
        .iter()
        .zip(&region.bulge_unit)
        .map(|(p, q)| p + q * gamma_h)
        .collect()
}

/// A fold's time in the columns of the paper's Table 1 ([`FoldTimings::stages`] says what each
/// holds: the paper does not say where Sec. 6's own steps go in its skinned finger row).
/// `wall` is the fold's whole time ([`FoldTimings::total`]).
fn table1_stages(
    fold: &FoldTimings,
    contact: &crate::contact::ContactTimings,
    regions: [&crate::deform::DeformTimings; 2],
) -> StageTimings {
    let sum = |f: fn(&crate::deform::DeformTimings) -> f64| regions.iter().map(|r| f(r)).sum();
    StageTimings {
        setup: 0.0,
        intersection: fold.detection + fold.crease + contact.intersection,
        mapping: contact.mapping,
        zones: contact.zones,
        parametrization: sum(|r| r.parametrization),
        directions: fold.directions + sum(|r| r.directions),
        fields: sum(|r| r.fields),
        deformation: sum(|r| r.deformation) + fold.volume,
        factorization: sum(|r| r.factorization),
        wall: fold.total(),
    }
}

/// The vertices that get the crease's intersection terms: those of the crossing faces
/// (`crossing`, sorted) and the vertices of `R` inside the other part
/// ([`crate::contact::inside_twice`]) reached from them across `R`'s edges through such
/// vertices (as `I_l` is found). A scan of the whole of `R` finds 0 to 5 more per 31-frame
/// animation (isolated vertices, CoR and DQS) for 4 times the winding queries.
///
/// Not in `PIPELINE.md`, which gives the intersection terms to the crossing faces only. With
/// DQS or CoR input the joint's inner side bulges into the other part: between the crease and
/// the bulge's top (up to 8 h deep at 150° on the bending capsule) lies a band whose normals
/// face the other part's direction (`n·d̂` of W1's sign on W2's side). Far from the
/// intersection curve, the band got the `β` terms, stayed on W2's side, could not be mapped
/// (back-facing, Sec. 4.2) and the zone ended 8 h deep: the profile then carried its
/// amplitude (4 h) onto the band and folded it. With the intersection terms the band goes to
/// the side its normals face. Measured on the bending capsule, 31 frames, worst frame:
/// CoR 19 → 5 penetrating vertices, 57 → 30 faces turned; DQS 22 → 2, 61 → 22; LBS, finger and
/// mouth unchanged. The temporal ratio does not improve (CoR 12 → 23, DQS 17 → 23: the
/// crease's bottom still jumps, see the issue note).
fn with_buried(
    pre: &FoldPre,
    positions: &[Point3<f64>],
    normals: &[Vector3<f64>],
    inside: &InsideTwice,
    crossing: &[u32],
) -> Vec<u32> {
    let region = &pre.shared.solver.region;
    let local = |v: u32| {
        pre.shared
            .local_of
            .get(v as usize)
            .copied()
            .filter(|&l| l != u32::MAX)
    };
    let buried = inside_from(
        region.vertex_count(),
        crossing.iter().filter_map(|&v| local(v)),
        |l, out| out.extend(&pre.shared_adjacency[l as usize]),
        |l| {
            let v = region.vertices[l as usize] as usize;
            inside.at(v, &positions[v], &normals[v])
        },
    );
    let mut out = crossing.to_vec();
    out.extend(
        region
            .vertices
            .iter()
            .zip(&buried)
            .filter(|(_, &b)| b)
            .map(|(&v, _)| v),
    );
    out.sort_unstable();
    out.dedup();
    out
}

/// Detection with the rest partition: the vertices of the faces crossing the other side, or
/// `None` when the fold does not intersect itself.
fn intersecting_vertices(body: &PosedMesh, sets: &FaceSets) -> Result<Option<Vec<u32>>, FoldError> {
    let ints = Intersections::between_sets(body, sets)?;
    if ints.is_empty() {
        return Ok(None);
    }
    let triangles = body.triangles();
    let mut vertices: Vec<u32> = ints
        .segments
        .iter()
        .flat_map(|s| {
            triangles[s.faces[0] as usize]
                .into_iter()
                .chain(triangles[s.faces[1] as usize])
        })
        .collect();
    vertices.sort_unstable();
    vertices.dedup();
    Ok(Some(vertices))
}

/// Sec. 4.2-4.4 between the truncated parts, with the skeleton's (or the user's) direction.
fn truncated_contact(
    truncated: &[MeshIndex; 2],
    positions: &[Point3<f64>],
    normals: &[Vector3<f64>],
    direction: Vector3<f64>,
    params: &FoldParams,
    tree: Option<&InsideTwice>,
) -> Result<Option<Contact>, FoldError> {
    // The parts were indexed at these positions (`cut_the_crease`): no second refit.
    let posed = [
        truncated[0].posed_as_built(positions)?,
        truncated[1].posed_as_built(positions)?,
    ];
    let side = |k: usize| SideFrame {
        mesh: &posed[k],
        normals,
        hittable: None,
    };
    let pair = PairParams {
        stiffness_a: params.stiffness_1,
        tau: params.tau,
        safeguard_angle: params.safeguard_angle,
        direction: DirectionMode::Fixed(direction),
    };
    Ok(resolve_self_pair(side(0), side(1), &pair, tree)?)
}

/// The blended pair and its one volume solve.
struct Blended {
    positions: Vec<Point3<f64>>,
    h: f64,
    root: Option<RootKind>,
    steepness: f64,
    unbalanced: bool,
    guarded: usize,
    bulge_guarded: usize,
}

/// Sec. 6: `P = β P_1 + (1 - β) P_2`, `Q` likewise, one bulge height `h_v` on the blended pair
/// (closed meshes), `p' = P + γ h_v Q`, the turn guard's scales applied to `P - p` and `Q`
/// before `h_v` is solved again; the input when no bulge can keep the volume
/// ([`FoldOutput::unbalanced`]).
fn blend_and_balance(
    pre: &FoldPre,
    g: &FoldInput,
    regions: [&RegionDeformation; 2],
    params: &FoldParams,
    parts: &[MeshIndex; 2],
) -> Result<Blended, FoldError> {
    let (positions, triangles) = (g.positions, g.triangles);
    let gamma = params.deform.gamma;
    let (mut base, mut bulge) = blend(pre, positions, regions);
    let (mut h, mut root) = balance(pre, g, &base, &bulge)?;
    let mut out = displaced(&base, &bulge, gamma * h);
    let mut scaled = vec![false; positions.len()];
    let mut lowered = vec![false; positions.len()];
    let turn_guard = g
        .turn_reference
        .filter(|_| params.turn_guard)
        .map(|reference| GuardInput {
            triangles,
            faces: &pre.guarded_faces,
            input: positions,
            reference,
        });
    // Check, scale, solve the volume again, until the checks find nothing (or the cap).
    for _ in 0..GUARD_SOLVES {
        let turn = turn_guard
            .as_ref()
            .and_then(|guard| displacement_scales(guard, &out));
        let lower = if params.bulge_guard {
            lowered_bulge(
                parts,
                pre.rest_edge,
                triangles,
                &base,
                &bulge,
                gamma * h,
                &out,
            )?
        } else {
            None
        };
        if turn.is_none() && lower.is_none() {
            break;
        }
        for (v, &s) in turn.iter().flatten().enumerate().filter(|(_, &s)| s < 1.0) {
            base[v] = positions[v] + (base[v] - positions[v]) * s;
            bulge[v] *= s;
            scaled[v] = true;
        }
        for (v, &s) in lower.iter().flatten().enumerate().filter(|(_, &s)| s < 1.0) {
            bulge[v] *= s;
            lowered[v] = true;
        }
        (h, root) = balance(pre, g, &base, &bulge)?;
        out = displaced(&base, &bulge, gamma * h);
    }
    let guarded = scaled.iter().filter(|&&s| s).count();
    let bulge_guarded = lowered.iter().filter(|&&s| s).count();
    let no_root = gamma != 0.0
        && root.is_some_and(|k| k != RootKind::Exact)
        && crate::report::metrics::volume_error(
            crate::mesh::signed_volume(positions, triangles),
            crate::mesh::signed_volume(&out, triangles),
        ) > UNBALANCED_VOLUME;
    let highest = if guarded + bulge_guarded > 0 {
        // The bulge as scaled back, not the regions' own (the re-solved `h_v` is higher).
        scaled_highest(pre, &bulge)
    } else {
        regions.map(|r| r.bulge_unit.iter().map(|q| q.norm()).fold(0.0, f64::max))
    };
    let steepness = steepness(regions, highest, gamma * h);
    let unbalanced = no_root || steepness > STEEPEST_BULGE;
    if unbalanced {
        out.copy_from_slice(positions);
    }
    Ok(Blended {
        positions: out,
        h,
        root,
        steepness,
        unbalanced,
        guarded,
        bulge_guarded,
    })
}

/// The bulge guard's scales ([`super::bulge_guard`]) for the bulge `bulge` times `scale`
/// (`γ h_v`) on `base`, whose sum is `out`.
fn lowered_bulge(
    parts: &[MeshIndex; 2],
    edge: f64,
    triangles: &[[u32; 3]],
    base: &[Point3<f64>],
    bulge: &[Vector3<f64>],
    scale: f64,
    out: &[Point3<f64>],
) -> Result<Option<Vec<f64>>, FoldError> {
    if scale == 0.0 {
        return Ok(None);
    }
    let step: Vec<Vector3<f64>> = bulge.iter().map(|q| q * scale).collect();
    let input = BulgeStep {
        triangles,
        base,
        step: &step,
        output: out,
        tolerance: TOLERANCE * edge,
    };
    Ok(bulge_scales(parts, &input)?)
}

/// Most volume solves after the guards' scalings (the turn guard's and, when on, the bulge
/// guard's, checked together): the turn guard scales the displacement back,
/// the volume solve raises the bulge again, which may turn a face the guard then catches at
/// the next check. The volume comes first: what a fold returns has its volume solved, and is
/// checked unless the cap was reached (faces the last solve pushed past the guard's 85° then
/// stay). Measured after the cap: faces past 85° in 3 of 138 folds of the CoR/DQS bends and 31
/// of 266 folds of CesiumMan (with and without the object pass's extent floor), none of the
/// bends' past 90°. Scaling once more without a last solve instead lost 2.2e-3 of CesiumMan's
/// volume with the extent floor `κ = 3`. The bulge guard's scalings converge the same way (the
/// raised bulge meets the other part again, a little further): 8 solves instead of 4 changed
/// CesiumMan's and Fox's residuals by 0-2 vertices.
const GUARD_SOLVES: usize = 4;

/// Per region, the highest blended bulge (per unit `h_v`) over its vertices, as the turn
/// guard scaled it back.
fn scaled_highest(pre: &FoldPre, bulge: &[Vector3<f64>]) -> [f64; 2] {
    let r = &pre.regions;
    [&r.w1, &r.w2].map(|inside| {
        bulge
            .iter()
            .zip(inside.iter())
            .filter(|(_, &i)| i)
            .map(|(q, _)| q.norm())
            .fold(0.0, f64::max)
    })
}

/// `P` and `Q` blended over `W1 ∪ W2` with `β` (the input and 0 elsewhere).
fn blend(
    pre: &FoldPre,
    positions: &[Point3<f64>],
    regions: [&RegionDeformation; 2],
) -> (Vec<Point3<f64>>, Vec<Vector3<f64>>) {
    let r = &pre.regions;
    let (mut base, mut bulge) = (positions.to_vec(), vec![Vector3::zeros(); positions.len()]);
    for v in 0..positions.len() {
        let b = match (r.w1[v], r.w2[v]) {
            (false, false) => continue,
            (true, true) => r.beta[v].clamp(0.0, 1.0),
            (true, false) => 1.0,
            (false, true) => 0.0,
        };
        base[v] =
            Point3::from(regions[0].base[v].coords * b + regions[1].base[v].coords * (1.0 - b));
        bulge[v] = regions[0].bulge_unit[v] * b + regions[1].bulge_unit[v] * (1.0 - b);
    }
    (base, bulge)
}

/// The bulge height `h_v` that keeps the closed body's volume (Sec. 5.3 on the blended pair);
/// 0 for an open one.
fn balance(
    pre: &FoldPre,
    g: &FoldInput,
    base: &[Point3<f64>],
    bulge: &[Vector3<f64>],
) -> Result<(f64, Option<RootKind>), FoldError> {
    if !pre.closed {
        return Ok((0.0, None));
    }
    let (h, kind) = bulge_height(g.triangles, g.positions, base, bulge)?;
    Ok((h, Some(kind)))
}

/// `P + scale Q`.
fn displaced(base: &[Point3<f64>], bulge: &[Vector3<f64>], scale: f64) -> Vec<Point3<f64>> {
    base.iter().zip(bulge).map(|(p, q)| p + q * scale).collect()
}

/// [`FoldOutput::bulge_steepness`]: per region, its highest bulge per unit `h_v` (`highest`)
/// times `scale = γ h_v`, over its band's width; the larger of the two.
fn steepness(regions: [&RegionDeformation; 2], highest: [f64; 2], scale: f64) -> f64 {
    regions
        .iter()
        .zip(highest)
        .map(|(r, highest)| {
            let rise = (scale * highest).abs();
            if rise == 0.0 {
                0.0
            } else {
                rise / r.stats.extent
            }
        })
        .fold(0.0, f64::max)
}

/// Face labels after the cut: a face of `W1 ∪ W2` goes to the side of at least two of its
/// corners.
fn cut_labels(triangles: &[[u32; 3]], faces: &[u32], on_w1: &[bool]) -> Vec<u8> {
    let mut labels = vec![0u8; triangles.len()];
    for &f in faces {
        let t = triangles[f as usize];
        let ones = t.iter().filter(|&&v| on_w1[v as usize]).count();
        labels[f as usize] = if ones >= 2 { 1 } else { 2 };
    }
    labels
}

/// Extends the contact zones to the vertices of the crease cut (next to the other side) that
/// lie inside the other part ([`crate::contact::inside_twice`], as for `I_l`): each joins the zone of its own side,
/// else of the other side (a cut vertex belongs to faces of both parts), whose sample is
/// [`conditioned`]; only a side that already has a zone is extended.
///
/// Not in the paper. The threshold of Eq. 4 leaves out the shallow end of the intersection,
/// which in a fold is its bottom: the two sides meet at the crease, where the depth goes to 0.
/// Left to Sec. 5's profile, that band gets the amplitude diffused from the zone (about 0.7 h
/// on the bending capsule) along a direction that `σ` turns through the normals between the
/// two zones; LBS's loop has turned those normals over, and the band folded (40 to 100 faces
/// per frame turned against both the input and the skinning on the capsule and the finger).
/// As zone vertices, the crease vertices go to their own point on `S` (about where they are)
/// and keep their side's sign, whichever side the cut gives them from frame to frame. The cut
/// also runs round the outside of the joint, where nothing is inside the other part: those
/// vertices stay out (else the zones would jump there as the cut moves). With `connected_only`
/// ([`FoldParams::free_isolated_crease`]) a crease vertex joins only where it connects to the
/// zone it would join (next to one of its vertices, or to a crease vertex joining it).
fn zones_to_the_crease(
    pre: &FoldPre,
    input: &CreaseVertices,
    contact: &mut Contact,
    connected_only: bool,
) {
    let candidates = crease_candidates(pre, input, contact);
    let inside = |v: usize| input.test.at(v, &input.positions[v], &input.normals[v]);
    let joining: Vec<(usize, usize)> = if connected_only {
        connected_candidates(pre, &candidates, contact, inside)
    } else {
        candidates.into_iter().filter(|&(v, _)| inside(v)).collect()
    };
    for (v, k) in joining {
        let side = &mut contact.sides[k];
        side.zone.inside[v] = true;
        side.zone.vertices.push(v as u32);
    }
    for side in &mut contact.sides {
        side.zone.vertices.sort_unstable();
    }
}

/// What [`zones_to_the_crease`] reads of the frame: the cut, the posed body and the
/// inside-twice test.
struct CreaseVertices<'a> {
    on_w1: &'a [bool],
    positions: &'a [Point3<f64>],
    normals: &'a [Vector3<f64>],
    test: &'a InsideTwice<'a>,
}

/// The crease vertices (on an edge of `R` across the cut) outside the zones, each with the
/// zone it would join (its own side's, else the other's, whose sample is [`conditioned`]), in
/// the order of `R`'s edges. Zones are extended, not created: a zone made of crease vertices
/// alone can sit on the working region's border, where the extent is capped to nothing and no
/// bulge can compensate (measured on CesiumMan: a one-vertex zone, volume error 7e-3).
fn crease_candidates(
    pre: &FoldPre,
    input: &CreaseVertices,
    contact: &Contact,
) -> Vec<(usize, usize)> {
    let region = &pre.shared.solver.region;
    // The body's mean edge length in this frame (computed once, with the test).
    let length = input.test.h;
    let extendable = contact
        .sides
        .each_ref()
        .map(|c| !c.zone.vertices.is_empty());
    let mut seen = vec![false; input.positions.len()];
    let mut candidates = Vec::new();
    for &[a, b] in &region.edges {
        let (va, vb) = (
            region.vertices[a as usize] as usize,
            region.vertices[b as usize] as usize,
        );
        if input.on_w1[va] == input.on_w1[vb] {
            continue;
        }
        for v in [va, vb] {
            if std::mem::replace(&mut seen[v], true)
                || contact.sides.iter().any(|c| c.zone.inside[v])
            {
                continue;
            }
            let own = usize::from(!input.on_w1[v]);
            let joins = [own, 1 - own]
                .into_iter()
                .find(|&k| extendable[k] && conditioned(&contact.sides[k], v, length));
            if let Some(k) = joins {
                candidates.push((v, k));
            }
        }
    }
    candidates
}

/// [`FoldParams::free_isolated_crease`]: of the `candidates`, those inside the other part and
/// connected to the zone they would join, next to one of its vertices or to a candidate that
/// joins it (a flood over `R`'s edges, [`FoldPre`]'s adjacency of `R`, from the zones); the
/// isolated ones stay out.
fn connected_candidates(
    pre: &FoldPre,
    candidates: &[(usize, usize)],
    contact: &Contact,
    inside: impl Fn(usize) -> bool,
) -> Vec<(usize, usize)> {
    let region = &pre.shared.solver.region;
    let neighbours = &pre.shared_adjacency;
    // Per local vertex: the zone it would join, while it has not been tried.
    let mut open: Vec<Option<usize>> = vec![None; region.vertices.len()];
    for &(v, k) in candidates {
        if let Some(&l) = pre.shared.local_of.get(v).filter(|&&l| l != u32::MAX) {
            open[l as usize] = Some(k);
        }
    }
    let next_to_zone = |l: usize, k: usize| {
        neighbours[l]
            .iter()
            .any(|&m| contact.sides[k].zone.inside[region.vertices[m as usize] as usize])
    };
    let mut queue: std::collections::VecDeque<usize> = (0..open.len())
        .filter(|&l| open[l].is_some_and(|k| next_to_zone(l, k)))
        .collect();
    let mut joining = Vec::new();
    while let Some(l) = queue.pop_front() {
        let Some(k) = open[l].take() else {
            continue;
        };
        let v = region.vertices[l] as usize;
        if !inside(v) {
            continue;
        }
        joining.push((v, k));
        let next = neighbours[l].iter().map(|&m| m as usize);
        queue.extend(next.filter(|&m| open[m] == Some(k)));
    }
    joining
}

/// Whether `side`'s sample of `v` places it on `S` by a displacement that agrees with its
/// depth (Eq. 3): the angle between the displacement and the normal of `S` is below 60°, or
/// the displacement is below 0.05 `length`. At the bottom of a fold `S` can turn parallel to
/// the mapping axis, where a vertex on `S` (depth 0) is sent along it by a whole edge length
/// (measured on the bending capsule with CoR input): such a sample is left to the profile.
fn conditioned(side: &ContactSide, v: usize, length: f64) -> bool {
    side.samples.get(v).is_some_and(|s| {
        let moved = (s.surface_point - s.point).norm();
        moved <= 0.05 * length || s.depth * (1.0 - side.stiffness) >= 0.5 * moved
    })
}

/// `σ`: +1 on `W1 \ R` and `C_1`, -1 on `W2 \ R` and `C_2`, harmonic on the rest of `R`
/// (Dirichlet on the zones' exact boundary points and on `R`'s borders toward each side).
fn sigma_field(
    pre: &FoldPre,
    positions: &[Point3<f64>],
    contact: &Contact,
) -> Result<Vec<f64>, FoldError> {
    let r = &pre.regions;
    let mut sigma: Vec<f64> = (0..positions.len())
        .map(|v| match (r.w1[v], r.w2[v]) {
            (true, false) => 1.0,
            (false, true) => -1.0,
            _ => 0.0,
        })
        .collect();
    let region = &pre.shared.solver.region;
    if region.vertex_count() == 0 {
        return Ok(sigma);
    }
    let (boundary, values) = sigma_boundary(pre, contact);
    let local = region.gather(positions);
    let mut problem = pre.shared.solver.problem(&local, &boundary)?;
    let solved = problem.harmonic(&values)?;
    for (l, &v) in region.vertices.iter().enumerate() {
        let v = v as usize;
        sigma[v] = match zone_sign(contact, v) {
            Some(s) => s,
            None if problem.unreached()[l] => 0.0,
            None => solved[l].clamp(-1.0, 1.0),
        };
    }
    Ok(sigma)
}

/// `σ`'s Dirichlet value at `v`, if it is a vertex of a contact zone: +1 in `C_1`, -1 in `C_2`.
fn zone_sign(contact: &Contact, v: usize) -> Option<f64> {
    let zones = &contact.sides;
    if zones[0].zone.inside[v] {
        Some(1.0)
    } else if zones[1].zone.inside[v] {
        Some(-1.0)
    } else {
        None
    }
}

/// `σ`'s boundary on the shared region and its values (points first, then vertices): the
/// zones' exact points on `R`'s edges (every edge leaving a zone gets one, at the zone vertex
/// if the contact has none on it) and `R`'s vertices bordering one side only.
fn sigma_boundary(pre: &FoldPre, contact: &Contact) -> (Boundary, Vec<f64>) {
    let region = &pre.shared.solver.region;
    let inside: Vec<bool> = region
        .vertices
        .iter()
        .map(|&v| zone_sign(contact, v as usize).is_some())
        .collect();
    let exact = zone_exact_points(pre, contact);
    let mut points = Vec::new();
    let mut values = Vec::new();
    for (e, &[a, b]) in region.edges.iter().enumerate() {
        if inside[a as usize] == inside[b as usize] {
            continue;
        }
        let zone_vertex = if inside[a as usize] { a } else { b };
        let (alpha, sign) = exact.get(&(e as u32)).copied().unwrap_or_else(|| {
            let s = zone_sign(contact, region.vertices[zone_vertex as usize] as usize);
            (if zone_vertex == a { 0.0 } else { 1.0 }, s.unwrap_or(0.0))
        });
        points.push(EdgePoint {
            edge: e as u32,
            alpha,
        });
        values.push(sign);
    }
    let mut fixed = Vec::new();
    for (l, &v) in region.vertices.iter().enumerate() {
        let side = match pre.topology.borders()[v as usize] {
            (true, false) => 1.0,
            (false, true) => -1.0,
            _ => continue,
        };
        if !inside[l] {
            fixed.push(l as u32);
            values.push(side);
        }
    }
    let boundary = Boundary {
        inside,
        points,
        vertices: fixed,
    };
    (boundary, values)
}

/// The zones' exact boundary points on the shared region's edges: per local edge, the
/// position along it from its first end and the sign of the zone.
fn zone_exact_points(pre: &FoldPre, contact: &Contact) -> HashMap<u32, (f64, f64)> {
    let region = &pre.shared.solver.region;
    let mut exact = HashMap::new();
    for (side, sign) in contact.sides.iter().zip([1.0, -1.0]) {
        for bp in &side.zone.boundary {
            let (li, lj) = (
                pre.shared.local_of[bp.inside as usize],
                pre.shared.local_of[bp.outside as usize],
            );
            if li == u32::MAX || lj == u32::MAX {
                continue;
            }
            if let Some(e) = region.edge(li, lj) {
                let alpha_first = if region.edges[e as usize][0] == li {
                    bp.alpha
                } else {
                    1.0 - bp.alpha
                };
                exact.insert(e, (alpha_first, sign));
            }
        }
    }
    exact
}
