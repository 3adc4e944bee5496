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
//!
//! This file holds the fold's parameters, precomputation and per-frame sequence; its steps of
//! its own live beside it: `crease_zones.rs` (the zones extended to the crease cut), `sigma.rs`
//! (the sign field `σ`) and `blend.rs` (the blend, the volume solve and the guards' scales).

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

mod blend;
mod crease_zones;
mod sigma;

use blend::blend_and_balance;
use crease_zones::{zones_to_the_crease, CreaseVertices};
use sigma::sigma_field;

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
    /// The vertices whose box [`FoldPre::collapsed`] measures
    /// ([`PairRegions::sized_vertices`]).
    sized_vertices: Vec<u32>,
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
        let sized_vertices = regions.sized_vertices();
        let rest_box = crate::selfcontact::regions::box_diagonal_of(&sized_vertices, rest);
        let region_triangles: Vec<[u32; 3]> =
            faces.iter().map(|&f| triangles[f as usize]).collect();
        let rest_edge = crate::mesh::operators::mean_edge_length(rest, &region_triangles);
        let shared_adjacency = shared.solver.region.adjacency();
        let guarded_faces = faces_touching(triangles, &regions.w1, &regions.w2);
        Ok(Self {
            joint_size,
            rest_box,
            sized_vertices,
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
    /// Whether the shared region (both regions, when separated) is posed smaller than
    /// [`crate::pass::COLLAPSED`] times its rest size (a joint scaled to 0): such a fold is not
    /// resolved (nothing to resolve at that size, and all its faces overlap each other). Sizes here are the diagonals of the
    /// region's bounding box, posed and at rest (cheaper than the joint's size, and a guard
    /// at 1e-6 does not see the orientation's factor of at most √3).
    pub fn collapsed(&self, positions: &[Point3<f64>]) -> bool {
        let size = crate::selfcontact::regions::box_diagonal_of(&self.sized_vertices, positions);
        // NaN counts as collapsed (no size to resolve a fold at).
        size.is_nan() || size < crate::pass::COLLAPSED * self.rest_box
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
    let separated = pre.regions.separated();
    let (crease, truncated) = if separated {
        separated_parts(pre, positions, triangles)?
    } else {
        cut_the_crease(pre, detection, geometry, tree, params)?
    };
    timings.crease = laps.next();
    // Separated regions: their intersection regions are apart, so Eq. 2 applies (Sec. 6
    // replaces it by the skeleton's direction only where the regions overlap).
    let mode = if separated {
        DirectionMode::Automatic
    } else {
        DirectionMode::Fixed(direction)
    };
    let contact = truncated_contact(&truncated, positions, normals, mode, params, tree)?;
    timings.contact = laps.next();
    let Some(mut contact) = contact else {
        return Ok(None);
    };
    // The direction the regions deform along: W1's outward one, the contact's own for
    // separated regions.
    let geometry = &FoldInput {
        direction: if separated {
            contact.sides[0].direction
        } else {
            direction
        },
        ..*geometry
    };
    // Intersecting faces without a contact zone on either side (zero depth: the Quaternius
    // robot's rigid finger pieces, modeled interpenetrating) leave every vertex where it is:
    // the crease can extend zones, not create them, and the rest of the fold only moved
    // vertices by round-off (at most 2.3e-16 on CesiumMan), at 0.6 ms per robot frame.
    if contact.sides.iter().all(|s| s.zone.vertices.is_empty()) {
        return Ok(None);
    }
    if let Some(tree) = tree.filter(|_| !separated) {
        let crease_input = CreaseVertices {
            on_w1: &crease.on_w1,
            positions,
            normals,
            test: tree,
            left_penetrating: geometry.left_penetrating,
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
    /// `d̂_12`, W1's outward direction (not read for separated regions,
    /// [`PairRegions::separated`], which take Eq. 2's from their contact).
    pub direction: Vector3<f64>,
    /// What the turn guard keeps faces from turning against ([`FoldParams::turn_guard`]):
    /// the frame's input and the skinning's normals; `None`: no guard.
    pub turn_reference: Option<TurnReference<'a>>,
    /// Per mesh vertex, whether the frame's previous sweep left it penetrating (set in the
    /// further sweeps of [`crate::selfcontact::pass::SelfContactPass::with_max_passes`],
    /// `None` in a frame's first sweeps): such a vertex of the crease cut does not join a
    /// contact zone at depth 0, where it would be pinned inside again, and is left to Sec. 5's
    /// profile.
    pub left_penetrating: Option<&'a [bool]>,
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

/// Separated regions (no shared region, [`PairRegions::separated`]): no crease to cut; the
/// parts are the two regions as they are (the rest labels), indexed for Sec. 4.2-4.4.
fn separated_parts(
    pre: &FoldPre,
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
) -> Result<(Crease, [MeshIndex; 2]), FoldError> {
    let parts = MeshIndex::self_contact_parts_within(
        Some(&pre.parts_tree),
        positions,
        triangles,
        &pre.labels,
    )?;
    let crease = Crease {
        on_w1: pre.regions.w1.clone(),
        value: 0.0,
        stray: 0,
    };
    Ok((crease, parts))
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
    direction: DirectionMode,
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
        direction,
    };
    Ok(resolve_self_pair(side(0), side(1), &pair, tree)?)
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
