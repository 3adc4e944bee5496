//! A fold's parameters (2021 Sec. 4-6: `k̄`, `τ`, the safeguard angle, `φ̄` per joint, `γ`,
//! `ω`, the crease's weights) and the thresholds that refuse a fold.

use super::FoldPre;
use crate::deform::DeformParams;
use crate::selfcontact::crease::CreaseParams;

/// Relative volume change above which a fold that no bulge balances is left unresolved (see
/// [`super::FoldOutput::unbalanced`]).
pub const UNBALANCED_VOLUME: f64 = 1e-6;

/// Largest bulge, as a multiple of the band it rises from: the largest blended bulge
/// displacement `γ h_v |Q|` over a region's vertices above `STEEPEST_BULGE ×` its effective extent `φ_max,eff` makes
/// the fold unbalanced (see [`super::FoldOutput::unbalanced`]). Such a bulge is steeper than
/// 45° on average: it happens when a zone of a few vertices sits on its region's border, where the
/// extent is capped to almost nothing and the whole lost volume must rise from a sliver.
/// Measured (largest ratio per fold): below 0.1 over the committed rigs' animations. Before
/// the amplitude faded across the crease (`deform::region`), CesiumMan with the object pass's
/// extent floor (`κ = 3`) had four folds at 1.4, 1.6, 1.9 and 12 (bulges of 14 to 42 edge
/// lengths in frame 5, which took that frame from 17 to 116 penetrating vertices); now none
/// there with either floor, and the rule stays a safeguard, exercised by the bending capsule
/// with `φ̄` = 0.084 × the joint's size (ratios 1.5 to 35, every fold refused).
pub const STEEPEST_BULGE: f64 = 1.0;

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
    /// The safeguard angle of Sec. 4.4 in degrees
    /// ([`crate::contact::PairParams::safeguard_angle`]; default 80°, the paper's). It governs the zones of Eq. 3; the crease vertices that
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
    /// input normal and the skinning's; [`crate::selfcontact::turn_guard`]; needs
    /// [`super::FoldInput::turn_reference`]). Not in the paper. Default on. Measured (31-frame
    /// bends, worst frame; CesiumMan summed over 21 frames), without → with: CoR bend 15 → 0 turned
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
    /// of the other, the volume solved again ([`crate::selfcontact::bulge_guard`]). Not in the
    /// paper. Default on. Measured (two sweeps, penetrating vertices summed over the frames, without
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
