//! The per-frame self-contact pass of a rig (2021 Sec. 6): every joint pair whose shared
//! region folds into contact is resolved, one after the other on the same positions (the
//! output of a pair is the input of the next, in a fixed order), each only when it
//! intersects itself; a frame without any fold costs one BVH refit per body and one
//! self-overlap query per pair. A pair runs without the separate pieces of the mesh sunk
//! into its sides at rest (a belt: the smaller of two pieces crossing there) or lying inside
//! a larger piece (teeth, a lining) ([`super::layers`], [`SelfContactPass::layers`]); one whose
//! sides still cross at rest (a layer modeled through the skin in one piece, a broken mesh)
//! is resolved or left as it comes in every frame, as [`SelfContactPass::with_rest_overlaps`]
//! says.

mod build;
mod posed;

use build::{triangles_without, with_detection};
use posed::PosedBodies;

use super::direction::{BoneAxes, DirectionSource, Meeting};
use super::fold::{
    resolve_detected_in, Detection, FoldError, FoldInput, FoldOutcome, FoldOutput, FoldParams,
    FoldPre, FoldTimings,
};
use super::layers::Layer;
use super::regions::{derive_pairs_reporting, PairRegions, RegionOptions};
use super::turn_guard::TurnReference;
use super::SelfContactError;
use crate::intersect::{FaceSets, IntersectError, MeshIndex, TriangleBvh};
use crate::mesh::operators::{mean_edge_length, vertex_normals, NormalWeighting};
use crate::mesh::{RestVolume, WeldedMesh};
use crate::pass::RestOverlaps;
use crate::report::metrics::{penetrating_among, WindingNumber};
use crate::rig::{Pose, Rig};
use crate::skinning::{cofactor, unit_or_zero};
use nalgebra::{Matrix3, Point3, Vector3};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// One joint pair of one body, precomputed.
#[derive(Debug)]
struct Fold {
    body: usize,
    pre: FoldPre,
    /// The index its detection runs on, shared by every fold of the body: over the faces of
    /// all their sides, its tree built at rest and refit per frame ([`PosedBodies`]).
    detection: Arc<MeshIndex>,
    /// The fold's two sides marked in that tree.
    sets: FaceSets,
    axes: BoneAxes,
    direction: DirectionSource,
    /// Its own parameters ([`SelfContactPass::with_pair_params`]); `None`: the pass's.
    params: Option<FoldParams>,
    /// How its two sides meet at the rest positions the pass was built on, when they cross
    /// there ([`SelfContactPass::crossing_at_rest`]).
    at_rest: Option<RestCrossing>,
    /// Whether it runs whatever it does at rest ([`SelfContactPass::with_pair_enabled`]);
    /// `None`: as [`SelfContactPass::with_rest_overlaps`] says.
    enabled: Option<bool>,
    /// The pieces of the body it runs without, when it runs without some ([`super::layers`]).
    without: Option<WithoutLayers>,
    /// Its inside-twice tree's slot in [`PosedBodies`]: the body's index for the body's
    /// tree, shared by its folds; past the bodies for a fold on a surface of its body
    /// ([`FoldPre::on_surface`]: a body of several pieces), shared by the folds on the same.
    winding_slot: usize,
}

/// A fold whose two sides already cross at the rest positions the pass was built on
/// ([`SelfContactPass::crossing_at_rest`]): layers modeled through each other across a joint
/// (a belt sunk into the waist, a collar into the neck), or a broken mesh (a triangle list
/// read as a strip).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RestCrossing {
    /// The body.
    pub body: usize,
    /// The pair's name.
    pub name: String,
    /// Face pairs of its two sides crossing at rest (0 when the detection failed there).
    pub face_pairs: usize,
    /// Why the detection failed at rest (surfaces entangled rather than in contact, ...), when
    /// it did: every frame's would fail alike.
    pub failure: Option<String>,
}

/// A fold the pass leaves out in every frame ([`SelfContactPass::left_out`]).
#[derive(Clone, Debug, PartialEq)]
pub struct LeftOutFold {
    /// The body.
    pub body: usize,
    /// The pair's name.
    pub name: String,
    /// How its sides cross at rest, when they do.
    pub at_rest: Option<RestCrossing>,
    /// Disabled ([`SelfContactPass::with_pair_enabled`] with `false`).
    pub disabled: bool,
}

/// What a fold runs without ([`super::layers`]): pieces of its body sunk into it or lying
/// inside a larger piece at rest.
#[derive(Debug)]
struct WithoutLayers {
    /// The pieces.
    layers: Vec<Layer>,
    /// Their faces (ascending).
    faces: Vec<u32>,
}

/// A fold run without pieces of its body sunk into it or lying inside a larger piece at rest
/// ([`SelfContactPass::layers`], [`super::layers`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FoldLayers {
    /// The body.
    pub body: usize,
    /// The pair's name.
    pub name: String,
    /// The pieces (connected components of the welded mesh) it runs without.
    pub layers: Vec<Layer>,
}

impl RestCrossing {
    /// The face pairs crossing at rest; `None` when the detection failed there.
    pub fn crossing_face_pairs(&self) -> Option<usize> {
        self.failure.is_none().then_some(self.face_pairs)
    }
}

/// What one fold did in a frame.
#[derive(Clone, Debug)]
pub struct FoldReport {
    /// Body.
    pub body: usize,
    /// Pair name.
    pub name: String,
    /// `d̂_12` used.
    pub direction: Vector3<f64>,
    /// The fold's result (positions are those after this fold).
    pub output: FoldOutput,
}

/// Output of one frame.
#[derive(Clone, Debug, Default)]
pub struct SelfPassOutput {
    /// Folds that were in contact.
    pub folds: Vec<FoldReport>,
    /// Summed timings.
    pub timings: FoldTimings,
    /// Folds that intersect themselves but were skipped for want of a direction (a full 180°
    /// fold for the skeleton's, no common relative motion where the parts meet for the
    /// motion's, normals cancelling out in Eq. 2 for separated regions:
    /// [`FoldOutcome::NoDirection`]; until 2026-12-05 the last were not counted).
    pub no_direction: usize,
    /// Folds left unresolved because no bulge could keep the volume without a spike
    /// ([`crate::selfcontact::fold::FoldOutput::unbalanced`]).
    pub unbalanced: usize,
    /// Vertices whose displacement the turn guard scaled back, summed over the folds
    /// ([`crate::selfcontact::fold::FoldOutput::guarded`]).
    pub guarded: usize,
    /// Vertices whose bulge the bulge guard scaled back, summed over the folds
    /// ([`crate::selfcontact::fold::FoldOutput::bulge_guarded`]).
    pub bulge_guarded: usize,
    /// Sweeps over the folds run this frame (see [`SelfContactPass::with_max_passes`]).
    pub sweeps: usize,
    /// Folds that failed this frame (a [`FoldError`]: a factorization that found its matrix
    /// not positive definite, an intersection the exact predicates could not place, …), each
    /// left as it was, as a refused fold is, while the pass went on with the others. Until
    /// 2026-12-05 one such fold stopped the whole run; the inputs found to make one fail are
    /// broken meshes (a triangle list read as a strip) and rigs scaled to `1e-30`.
    pub failed: Vec<FailedFold>,
    /// Closed bodies that the frame turned inside out (signed volume of the other sign than at
    /// rest: a joint scaled by a negative factor in the animation), each once: their folds
    /// found intersecting are left as they are, as [`crate::pass::PassOutput::inside_out`]
    /// leaves such a body out of the contacts between bodies. A fold reads the winding as
    /// outward (its zones, its direction, its bulge): on the bending capsule with its root
    /// scaled by -1 from mid-animation the pass resolved none of the mirrored frames, silently
    /// (measured 2026-12-05); now they are reported.
    pub inside_out: Vec<usize>,
}

/// A fold that failed in a frame ([`SelfPassOutput::failed`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FailedFold {
    /// The pair.
    pub name: String,
    /// What failed.
    pub error: String,
}

/// Self-contact of every joint pair of a rig, precomputed once.
#[derive(Debug)]
pub struct SelfContactPass {
    folds: Vec<Fold>,
    params: FoldParams,
    triangles: Vec<Vec<[u32; 3]>>,
    /// Welded rest positions per body, and the rest pose ([`DirectionSource::Motion`]).
    rest: Vec<Vec<Point3<f64>>>,
    /// Per body: the welded rest normals and each welded vertex's file vertex (its weights),
    /// for the turn guard's reference ([`SelfContactPass::skinned_normals`]).
    rest_normals: Vec<Vec<Vector3<f64>>>,
    representative: Vec<Vec<u32>>,
    rest_pose: Pose,
    /// Each closed body's rest signed volume ([`SelfPassOutput::inside_out`]).
    rest_volumes: Vec<Option<RestVolume>>,
    passes: usize,
    max_passes: usize,
    /// Joint pairs left out when deriving, one reason each ([`derive_pairs_reporting`]).
    skipped: Vec<String>,
    /// What the pass does with the folds of [`SelfContactPass::crossing_at_rest`].
    rest_overlaps: RestOverlaps,
    /// The body of each inside-twice tree a frame keeps ([`Fold::winding_slot`]: one per
    /// body, then one per surface of a body that folds run on) and its surface's mean rest
    /// edge length: further sweeps look for penetrating vertices tree by tree, in that unit.
    slots: Vec<(usize, f64)>,
    /// Detection trees of finished frames, one set per body, each refit in place by a later
    /// frame ([`MeshIndex::refit_nodes_in`]) instead of copied from the index: as many sets as
    /// frames ran at once. Only their allocations are reused: every box is rewritten before a
    /// query reads it, so a frame's output does not depend on which set it got.
    spare_trees: Mutex<Vec<Vec<Option<TriangleBvh>>>>,
}

/// Default number of sweeps over the folds per frame (see [`SelfContactPass::with_passes`]).
pub const DEFAULT_FOLD_PASSES: usize = 2;

/// Default bound of [`SelfContactPass::with_max_passes`]: after [`DEFAULT_FOLD_PASSES`] sweeps,
/// up to four further ones while the folds' shared regions still hold penetrating vertices
/// (two until 2026-12-03, twenty-fourth session).
pub const DEFAULT_MAX_FOLD_PASSES: usize = 6;

/// Why the self-contact pass failed.
#[derive(Debug, thiserror::Error)]
pub enum SelfPassError {
    /// Precomputation.
    #[error(transparent)]
    Regions(#[from] SelfContactError),
    /// A non-finite input position (checked before anything moves).
    #[error("body {body}: position of welded vertex {vertex} is not finite")]
    NonFinite {
        /// The body.
        body: usize,
        /// Its welded vertex.
        vertex: usize,
    },
    /// A fold's precomputation (in a frame, a failed fold is reported in
    /// [`SelfPassOutput::failed`] instead).
    #[error("fold {name}: {source}")]
    Fold {
        /// The pair.
        name: String,
        /// Cause.
        source: FoldError,
    },
    /// A body's detection index could not be built (invalid rest positions or faces).
    #[error("body {body}: {source}")]
    Detection {
        /// The body.
        body: usize,
        /// Cause.
        source: IntersectError,
    },
    /// Inputs do not match the rig.
    #[error("{0}")]
    Mismatch(String),
}

impl SelfContactPass {
    /// Derives the joint pairs of every body from the skin weights and precomputes them
    /// (`rest`: welded rest positions per body, at the rig's rest pose). `directions`: where
    /// each named pair's direction comes from (a fixed direction is W1's outward side at the
    /// fold, e.g. vertical for the lips); other pairs use the skeleton's. The parent/child
    /// pairs only: `pose` also gives the pass the skeleton's separated regions
    /// ([`SelfContactPass::with_separated`], [`crate::selfcontact::separated_from_skeleton`]).
    pub fn new(
        rig: &Rig,
        welded: &[WeldedMesh],
        rest: &[Vec<Point3<f64>>],
        options: &RegionOptions,
        params: FoldParams,
        directions: &[(String, DirectionSource)],
    ) -> Result<Self, SelfPassError> {
        Self::with_separated(rig, welded, rest, options, params, directions, Vec::new())
    }

    /// [`SelfContactPass::new`] with, after the derived pairs, the `separated` pairs of
    /// regions a rig config names or the skeleton gives
    /// ([`crate::selfcontact::separated_regions`],
    /// [`crate::selfcontact::separated_from_skeleton`]: two working
    /// regions of one body that share no vertex, resolved by Sec. 4-5 alone with Eq. 2's
    /// direction, in the same sweeps as the folds).
    pub fn with_separated(
        rig: &Rig,
        welded: &[WeldedMesh],
        rest: &[Vec<Point3<f64>>],
        options: &RegionOptions,
        params: FoldParams,
        directions: &[(String, DirectionSource)],
        separated: Vec<PairRegions>,
    ) -> Result<Self, SelfPassError> {
        if rest.len() != welded.len() {
            return Err(SelfPassError::Mismatch(format!(
                "{} bodies, {} position sets",
                welded.len(),
                rest.len()
            )));
        }
        let mut built = Vec::new();
        // One winding-number tree per body, shared by its folds.
        let mut windings: Vec<Option<Arc<WindingNumber>>> = vec![None; welded.len()];
        let (mut pairs, skipped) = derive_pairs_reporting(rig, welded, options)?;
        pairs.extend(separated);
        for regions in pairs {
            let body = regions.pair.body;
            let (rest, triangles) = (&rest[body], &welded[body].triangles);
            let winding = windings[body]
                .get_or_insert_with(|| Arc::new(FoldPre::body_winding(rest, triangles)));
            let winding = Arc::clone(winding);
            let name = regions.pair.name.clone();
            let axes = BoneAxes::new(rig, &welded[body], &regions);
            let direction = directions
                .iter()
                .find(|(n, _)| *n == name)
                .map_or(DirectionSource::Skeleton, |(_, d)| *d);
            let pre = FoldPre::with_winding(rest, triangles, regions, winding)
                .map_err(|source| SelfPassError::Fold { name, source })?;
            built.push((body, pre, axes, direction));
        }
        let (folds, surfaces) = with_detection(rig, built, rest, welded)?;
        let mut slots: Vec<(usize, f64)> = (rest.iter().zip(welded).enumerate())
            .map(|(b, (r, w))| (b, mean_edge_length(r, &w.triangles)))
            .collect();
        slots.extend(surfaces);
        let triangles = welded.iter().map(|w| w.triangles.clone()).collect();
        Ok(Self {
            folds,
            params,
            triangles,
            rest: rest.to_vec(),
            rest_normals: rest
                .iter()
                .zip(welded)
                .map(|(p, w)| vertex_normals(p, &w.triangles, NormalWeighting::Area))
                .collect(),
            representative: welded.iter().map(|w| w.representative.clone()).collect(),
            rest_pose: rig.pose_at(None, 0.0),
            rest_volumes: rest
                .iter()
                .zip(welded)
                .map(|(r, w)| RestVolume::of(r, &w.triangles))
                .collect(),
            passes: DEFAULT_FOLD_PASSES,
            max_passes: DEFAULT_MAX_FOLD_PASSES,
            skipped,
            rest_overlaps: RestOverlaps::default(),
            slots,
            spare_trees: Mutex::default(),
        })
    }

    /// The folds whose two sides already cross at the positions the pass was built on (by
    /// the detection that opens a fold in a frame; a detection that fails there counts too,
    /// with its reason), in fold order. What the pass does with them:
    /// [`SelfContactPass::with_rest_overlaps`].
    pub fn crossing_at_rest(&self) -> Vec<&RestCrossing> {
        self.folds
            .iter()
            .filter_map(|f| f.at_rest.as_ref())
            .collect()
    }

    /// Sets what the pass does with the folds of [`SelfContactPass::crossing_at_rest`]
    /// (default [`RestOverlaps::Resolved`], as [`crate::pass::ContactPass::with_rest_overlaps`]:
    /// a caller may build the pass on any positions). With [`RestOverlaps::LeftOut`] (what
    /// `contact-skin pose` does on the rig's rest pose) they are left as they come in every
    /// frame unless [`SelfContactPass::with_pair_enabled`] enables them: their sides overlap
    /// as modeled, and resolving that overlap in every frame works against the model.
    pub fn with_rest_overlaps(mut self, rest_overlaps: RestOverlaps) -> Self {
        self.rest_overlaps = rest_overlaps;
        self
    }

    /// Enables (`true`: resolved even when crossing at rest) or disables (`false`: left as
    /// it comes in every frame) the named joint pairs, every fold of that name (the
    /// configuration's `[[self_contact.pair]] enabled`). A name that is not one of
    /// [`SelfContactPass::pairs`] is [`SelfPassError::Mismatch`].
    pub fn with_pair_enabled(mut self, enabled: &[(String, bool)]) -> Result<Self, SelfPassError> {
        for (name, on) in enabled {
            self.set_on_folds_named(name, |fold| fold.enabled = Some(*on))?;
        }
        Ok(self)
    }

    /// The folds the pass leaves out in every frame, with why: those disabled, and those
    /// crossing at rest that it leaves out ([`SelfContactPass::with_rest_overlaps`]) and no
    /// [`SelfContactPass::with_pair_enabled`] enables; in fold order.
    pub fn left_out(&self) -> Vec<LeftOutFold> {
        (self.folds.iter())
            .filter(|f| !self.runs(f))
            .map(|f| LeftOutFold {
                body: f.body,
                name: f.pre.regions.pair.name.clone(),
                at_rest: f.at_rest.clone(),
                disabled: f.enabled == Some(false),
            })
            .collect()
    }

    /// The folds run without separate pieces of the mesh ([`super::layers`]): pieces sunk
    /// into their sides at rest (a belt, a collar: the smaller of two pieces crossing there)
    /// or lying inside a larger piece (teeth, a lining), which follow the skinning; in fold
    /// order.
    pub fn layers(&self) -> Vec<FoldLayers> {
        (self.folds.iter())
            .filter_map(|f| {
                Some(FoldLayers {
                    body: f.body,
                    name: f.pre.regions.pair.name.clone(),
                    layers: f.without.as_ref()?.layers.clone(),
                })
            })
            .collect()
    }

    /// Per body, its welded triangles without the layers its folds run without
    /// ([`SelfContactPass::layers`]: pieces sunk into it as modeled, whose overlap with the
    /// skin no fold resolves), `None` for a body without any: the surface on which what the
    /// pass leaves is measured.
    pub fn triangles_without_layers(&self) -> Vec<Option<Vec<[u32; 3]>>> {
        let mut left: Vec<Vec<bool>> = vec![Vec::new(); self.triangles.len()];
        for fold in &self.folds {
            let Some(without) = &fold.without else {
                continue;
            };
            let flags = &mut left[fold.body];
            flags.resize(self.triangles[fold.body].len(), false);
            for &f in &without.faces {
                flags[f as usize] = true;
            }
        }
        (left.iter().zip(&self.triangles))
            .map(|(flags, tris)| (!flags.is_empty()).then(|| triangles_without(tris, flags)))
            .collect()
    }

    /// Whether `fold` runs in the frames ([`SelfContactPass::left_out`]).
    fn runs(&self, fold: &Fold) -> bool {
        let left_at_rest = self.rest_overlaps == RestOverlaps::LeftOut && fold.at_rest.is_some();
        fold.enabled.unwrap_or(!left_at_rest)
    }

    /// Sets how many sweeps over the folds a frame gets (at least 1; default
    /// [`DEFAULT_FOLD_PASSES`]). The paper resolves each fold once; a second sweep resolves what
    /// the first left (vertices outside the contact zones still inside the other side, and
    /// what a neighbouring joint's fold pushed back in): at the deepest frame, 3 penetrating
    /// vertices on the bending capsule and 191 on the finger drop to 0 (86 on the capsule with
    /// `τ = 0`). Those are touching, not interpenetrating: all lie within 0.25 h of the
    /// surface on the other side of the crease cut (two triangulations of one curved contact
    /// surface cross each other by more than `MEASURING.md`'s 0.05 h nudge), so one sweep
    /// resolves the folds at half the cost. A sweep that moves nothing ends the frame. This
    /// sets the count exactly (no further sweep: [`SelfContactPass::with_max_passes`] after it
    /// allows more).
    pub fn with_passes(mut self, passes: usize) -> Self {
        self.passes = passes.max(1);
        self.max_passes = self.passes;
        self
    }

    /// Allows sweeps beyond [`SelfContactPass::with_passes`]'s, up to `max_passes` in all
    /// (default [`DEFAULT_MAX_FOLD_PASSES`]; none beyond after [`SelfContactPass::with_passes`]
    /// until this is called), while the shared regions of the folds that moved this frame
    /// keep penetrating vertices by `MEASURING.md`'s test (the winding number at `p - 0.05 h n`
    /// at least 1.5, `h` the body's mean rest edge length; queried on the body's tree that the
    /// folds keep, refit to the body; a fold that first moves in a further sweep adds its
    /// shared region to the vertices counted). Each body is counted and stopped on its own, so
    /// that a body gets what it gets alone whatever else the rig holds (until 2026-12-03 the
    /// counts were summed over the bodies: the bending capsule next to the finger, CoR input,
    /// took a fourth sweep at frame 13 of 31 that it does not take alone; a body that the last
    /// sweep did not move stops too). A further sweep runs only the folds whose working
    /// regions hold one of those vertices: what no fold reaches (an arm against the torso)
    /// costs one test, and a fold left out reports nothing for that sweep
    /// ([`SelfPassOutput`]'s counts). Where the
    /// mapping direction is not square to the contact (a direction 3° off the bending
    /// capsule's skeleton's leaves 82 penetrating vertices over 31 frames after 2 sweeps, 2
    /// with the default), on CoR or DQS input, or where a neighbouring joint's fold pushed back
    /// in, each sweep resolves part of what the last left. Measured with 2 sweeps then up to 4
    /// (`pose --metrics`, bulge guard on, against exactly 2;
    /// penetrating vertices summed over 31 frames): DQS capsule 17 → 9, CoR 19 → 10; the
    /// finger with DQS 321 → 65, with CoR 366 → 45; Fox over 41 frames: run 79 → 69, walk 53
    /// → 40; CesiumMan 21 → 21 (its arms against its torso); frames clear after 2 sweeps
    /// unchanged; temporal ratios within 5 %, but for CesiumMan over 61 frames (64 → 61
    /// penetrating; its hip pop at frame 17, where a third sweep takes 6 to 2, 6.29 → 7.22).
    /// Cost (one thread, alternated runs, medians of three, whole runs): finger 2.04 → 2.19 s
    /// (no further sweep needed: the test alone), `finger_long` 2.09 → 2.18 s, CesiumMan (21
    /// frames) 0.69 → 0.82 s, CoR capsule 1.33 → 1.68 s, the finger with DQS 2.15 → 3.70 s.
    /// Testing every vertex of the moved bodies on a tree built for the test, and sweeping
    /// every fold again, took 2.49, 2.75, 1.02, 2.18 and 4.65 s, with the same outputs on the
    /// scenes compared (measured, not implied: a fold that touches without a penetrating
    /// vertex no longer runs again).
    ///
    /// Until the twenty-fourth session (2026-12-03) a body also stopped when its last further
    /// sweep did not lower its count, and the default bound was 4. A sweep that leaves as many
    /// can prepare one that leaves fewer, and the bound of 6 lets them: measured against that
    /// rule (`pose --metrics`, penetrating vertices summed over 31 frames, 41 for Fox, 21 and 61
    /// for CesiumMan): CoR capsule 9 → 4, the finger with CoR 43 → 29 and with DQS 59 → 37,
    /// Fox's walk 39 → 33 and run 64 → 63 (138 → 134 over 81 frames), CesiumMan 19 → 19 and 59
    /// → 57, the DQS capsule 11 → 11; the LBS capsule, finger, `finger_long` and mouth take no
    /// further sweep and are the same to the byte; displacement-step ratios within 1 % but for
    /// Fox's walk (1.52 → 1.65). The rule alone (bound 4) gained 0-4 vertices a scene, the bound
    /// alone (6, with the rule) 1 on the CoR capsule and 11 on the finger with CoR. Cost (one
    /// thread, whole runs, alternated, medians of three): CoR capsule 1.86 → 2.43 s, the finger
    /// with DQS 3.80 → 4.58 s, with CoR 4.09 → 5.45 s. Values below the sweep count are raised
    /// to it.
    pub fn with_max_passes(mut self, max_passes: usize) -> Self {
        self.max_passes = max_passes.max(self.passes);
        self
    }

    /// Gives the named joint pairs their own fold parameters (a studio's per-joint `τ`, `γ`,
    /// `ω`: the shoulders' bulge can push an arm into the torso, which no joint pair covers;
    /// see the README); the other pairs keep the pass's. A name that is not one of
    /// [`SelfContactPass::pairs`] is [`SelfPassError::Mismatch`]; every fold of that name takes
    /// the parameters (as directions do).
    pub fn with_pair_params(
        mut self,
        params: &[(String, FoldParams)],
    ) -> Result<Self, SelfPassError> {
        for (name, p) in params {
            self.set_on_folds_named(name, |fold| fold.params = Some(*p))?;
        }
        Ok(self)
    }

    /// Calls `set` on every fold named `name`; [`SelfPassError::Mismatch`] when none is.
    fn set_on_folds_named(
        &mut self,
        name: &str,
        mut set: impl FnMut(&mut Fold),
    ) -> Result<(), SelfPassError> {
        let mut found = false;
        for fold in (self.folds.iter_mut()).filter(|f| f.pre.regions.pair.name == name) {
            set(fold);
            found = true;
        }
        match found {
            true => Ok(()),
            false => Err(SelfPassError::Mismatch(format!(
                "no joint pair named '{name}'"
            ))),
        }
    }

    /// The parameters `fold` runs with.
    fn params_of<'s>(&'s self, fold: &'s Fold) -> &'s FoldParams {
        fold.params.as_ref().unwrap_or(&self.params)
    }

    /// Whether some fold runs the turn guard.
    fn guards_any(&self) -> bool {
        self.params.turn_guard
            || self
                .folds
                .iter()
                .any(|f| f.params.is_some_and(|p| p.turn_guard))
    }

    /// Sweeps every frame gets ([`SelfContactPass::with_passes`]); frames whose folds still
    /// penetrate may take more, up to [`SelfContactPass::max_passes`].
    pub fn passes(&self) -> usize {
        self.passes
    }

    /// Most sweeps a frame may take ([`SelfContactPass::with_max_passes`]).
    pub fn max_passes(&self) -> usize {
        self.max_passes
    }

    /// Why parent/child pairs were left out (e.g. a shared region without a border toward
    /// one side: no partition of unity), one message each.
    pub fn skipped(&self) -> &[String] {
        &self.skipped
    }

    /// Names of the joint pairs, with their body.
    pub fn pairs(&self) -> Vec<(usize, String)> {
        self.folds
            .iter()
            .map(|f| (f.body, f.pre.regions.pair.name.clone()))
            .collect()
    }

    /// Resolves every fold of a frame in place (`positions`: welded positions per body, `pose`
    /// the frame's skeleton pose, one world matrix per node of `rig`; a mismatch in either is
    /// [`SelfPassError::Mismatch`], a non-finite position [`SelfPassError::NonFinite`], before
    /// anything moves). A fold that fails is left as it was and reported
    /// ([`SelfPassOutput::failed`]); the others go on. The turn guard's second reference is
    /// linear blend skinning's normals in `pose`; [`SelfContactPass::run_with_normals`] takes
    /// the normals of the skinning that made `positions` instead.
    pub fn run(
        &self,
        rig: &Rig,
        pose: &Pose,
        positions: &mut [Vec<Point3<f64>>],
    ) -> Result<SelfPassOutput, SelfPassError> {
        self.run_referenced(rig, pose, positions, None)
    }

    /// [`SelfContactPass::run`] with the turn guard's second reference given: `normals`, the
    /// welded unit vertex normals per body of the skinning that made `positions` (DQS and CoR
    /// carry normals by their own rotations), the reference of the turned-face metric
    /// (`MEASURING.md`), so that what the guard lets through is what the metric counts. With
    /// linear blend skinning's, the guard stopped faces 85° short of LBS's normals and the
    /// metric, on CoR input, still counted a face of the bending capsule (frame 27 of 31, the
    /// seam samples of [`crate::contact::mapping`] on): the rotations differ by more than the
    /// margin there.
    pub fn run_with_normals(
        &self,
        rig: &Rig,
        pose: &Pose,
        positions: &mut [Vec<Point3<f64>>],
        normals: &[Vec<Vector3<f64>>],
    ) -> Result<SelfPassOutput, SelfPassError> {
        self.run_referenced(rig, pose, positions, Some(normals))
    }

    fn run_referenced(
        &self,
        rig: &Rig,
        pose: &Pose,
        positions: &mut [Vec<Point3<f64>>],
        normals: Option<&[Vec<Vector3<f64>>]>,
    ) -> Result<SelfPassOutput, SelfPassError> {
        self.check_frame(rig, pose, positions)?;
        if let Some(normals) = normals {
            check_normals(positions, normals)?;
        }
        let trees = self
            .spare_trees
            .lock()
            .ok()
            .and_then(|mut spare| spare.pop());
        let mut bodies = PosedBodies::new(positions, trees, self.slots.len());
        let out = self.sweeps(rig, pose, normals, &mut bodies);
        if let Ok(mut spare) = self.spare_trees.lock() {
            spare.push(bodies.into_trees());
        }
        Ok(out)
    }

    /// The frame's sweeps over the folds ([`SelfContactPass::with_passes`],
    /// [`SelfContactPass::with_max_passes`]).
    fn sweeps(
        &self,
        rig: &Rig,
        pose: &Pose,
        normals: Option<&[Vec<Vector3<f64>>]>,
        bodies: &mut PosedBodies,
    ) -> SelfPassOutput {
        let mut out = SelfPassOutput::default();
        // The positions before any fold, copied when the first fold is detected: the turn
        // guard's reference.
        let mut frame_input = None;
        let mut further = FurtherSweeps::new(self.slots.len());
        // Per fold, whether it runs in this sweep: all in the first sweeps, in further ones
        // those whose working regions hold a penetrating vertex. A fold that still touches
        // without one is left as it is (before 2026-12-03 every fold ran again: the same
        // outputs to the byte on the 13 scenes compared, a choice rather than an identity).
        let mut active: Vec<bool> = self.folds.iter().map(|f| self.runs(f)).collect();
        for sweep in 1..=self.max_passes {
            let mut changed = false;
            further.moved.fill(false);
            for (fold, _) in self.folds.iter().zip(&active).filter(|(_, &a)| a) {
                let frame = Frame {
                    rig,
                    pose,
                    normals,
                    bodies,
                    left_penetrating: &further.left,
                };
                let moved_now = match self.sweep_fold(fold, frame, &mut frame_input, &mut out) {
                    Ok(moved) => moved,
                    Err(failed) => {
                        out.failed.push(failed);
                        false
                    }
                };
                if moved_now && self.max_passes > self.passes {
                    add_shared_region(&mut further.reach[fold.winding_slot], &fold.pre.regions);
                    further.moved[fold.winding_slot] = true;
                }
                changed |= moved_now;
            }
            out.sweeps = sweep;
            // Nothing moved: a further sweep would find the same.
            if !changed || sweep == self.max_passes {
                break;
            }
            if sweep >= self.passes {
                match further.next(self, bodies) {
                    Some(folds) => active = folds,
                    None => break,
                }
            }
        }
        out
    }

    /// [`SelfContactPass::run`]'s input matches the rig: one position set per body, each of
    /// its welded vertex count, and one world matrix per node.
    fn check_frame(
        &self,
        rig: &Rig,
        pose: &Pose,
        positions: &[Vec<Point3<f64>>],
    ) -> Result<(), SelfPassError> {
        if positions.len() != self.triangles.len() {
            return Err(SelfPassError::Mismatch(format!(
                "{} bodies, {} position sets",
                self.triangles.len(),
                positions.len()
            )));
        }
        if pose.world.len() != rig.nodes.len() {
            return Err(SelfPassError::Mismatch(format!(
                "a pose of {} nodes for a rig of {}",
                pose.world.len(),
                rig.nodes.len()
            )));
        }
        for (b, (p, rest)) in positions.iter().zip(&self.rest).enumerate() {
            let n = rest.len();
            if p.len() != n {
                return Err(SelfPassError::Mismatch(format!(
                    "body {b}: {} positions, the rig has {n} welded vertices",
                    p.len()
                )));
            }
            if let Some(vertex) = crate::mesh::first_non_finite(p) {
                return Err(SelfPassError::NonFinite { body: b, vertex });
            }
        }
        Ok(())
    }

    /// Per fold, whether it runs and its working regions hold one of the `flagged` vertices
    /// of its tree ([`Fold::winding_slot`]).
    fn folds_holding(&self, flagged: &[Vec<u32>]) -> Vec<bool> {
        let holds = |fold: &Fold| {
            let regions = &fold.pre.regions;
            self.runs(fold)
                && (flagged[fold.winding_slot].iter())
                    .any(|&v| regions.w1[v as usize] || regions.w2[v as usize])
        };
        self.folds.iter().map(holds).collect()
    }

    /// Per inside-twice tree ([`Fold::winding_slot`]: one per body, one per fold run without
    /// layers), its body's penetrating vertices among those its folds can `reach` (the shared
    /// regions of the folds that moved this frame; see [`SelfContactPass::with_max_passes`]),
    /// queried on that tree, refit to the body's positions.
    fn penetrating(&self, bodies: &mut PosedBodies, reach: &[Vec<bool>]) -> Vec<Vec<u32>> {
        (0..reach.len())
            .map(|slot| {
                if reach[slot].is_empty() {
                    return Vec::new();
                }
                let (b, edge) = self.slots[slot];
                let t = &self.triangles[b];
                let (p, normals, tree) = bodies.refit_winding(slot, b, t);
                penetrating_among(&tree, p, t, normals, edge, &reach[slot])
            })
            .collect()
    }

    /// `d̂_12` of `fold` at `pose` from its [`DirectionSource`]; the parts meet at the
    /// `crossing` vertices (those of the faces crossing the other part).
    fn direction(&self, fold: &Fold, pose: &Pose, crossing: &[u32]) -> Option<Vector3<f64>> {
        let rest = &self.rest[fold.body];
        let points: Vec<Point3<f64>> = match fold.direction {
            DirectionSource::Motion => crossing
                .iter()
                .filter_map(|&v| rest.get(v as usize).copied())
                .collect(),
            _ => Vec::new(),
        };
        let meeting = Meeting {
            rest_pose: &self.rest_pose,
            points: &points,
        };
        let pair = &fold.pre.regions.pair;
        fold.direction
            .direction(pose, pair, &fold.axes, Some(&meeting))
    }

    /// The turn guard's reference normals of `fold`'s body in this pose (`None` for a body
    /// without a skin): the `given` normals of the body, else linear blend skinning's.
    fn skinned_normals<'s>(
        &'s self,
        rig: &'s Rig,
        pose: &Pose,
        fold: &Fold,
        given: Option<&'s [Vec<Vector3<f64>>]>,
    ) -> Option<SkinnedNormals<'s>> {
        let body = rig.bodies.get(fold.body)?;
        let skin = rig.skins.get(body.skin)?;
        if let Some(normals) = given.and_then(|n| n.get(fold.body)) {
            return Some(SkinnedNormals::Given(normals));
        }
        Some(SkinnedNormals::Linear(LinearNormals {
            body,
            mats: pose.skin_matrices(skin),
            rest: self.rest_normals.get(fold.body)?,
            representative: self.representative.get(fold.body)?,
        }))
    }

    /// One fold in one sweep; whether it moved the body, or how it failed (the body then as it
    /// was).
    fn sweep_fold(
        &self,
        fold: &Fold,
        frame: Frame,
        frame_input: &mut Option<Vec<Vec<Point3<f64>>>>,
        out: &mut SelfPassOutput,
    ) -> Result<bool, FailedFold> {
        let Frame {
            rig,
            pose,
            normals: given,
            bodies,
            left_penetrating,
        } = frame;
        let fail = |source: FoldError| FailedFold {
            name: fold.pre.regions.pair.name.clone(),
            error: source.to_string(),
        };
        let Some((detection, direction)) = self.gates(fold, pose, bodies, out).map_err(fail)?
        else {
            return Ok(false);
        };
        // The turn guard's references: the frame's input (copied at the frame's first fold
        // whenever some fold guards, so that a guarded fold after an unguarded one compares
        // with the frame's input too) and the skinning's normals.
        if self.guards_any() {
            frame_input.get_or_insert_with(|| bodies.all().to_vec());
        }
        let params = self.params_of(fold);
        let skinned = params
            .turn_guard
            .then(|| self.skinned_normals(rig, pose, fold, given))
            .flatten();
        let first = skinned
            .is_some()
            .then_some(frame_input.as_deref())
            .flatten();
        let tris = &self.triangles[fold.body];
        let (pos, normals, winding) =
            bodies.for_fold(fold.winding_slot, fold.body, tris, || fold.pre.body_tree());
        let normal = |v: usize| skinned.as_ref().map_or_else(Vector3::zeros, |s| s.at(v));
        let input = FoldInput {
            positions: pos,
            normals,
            triangles: tris,
            direction,
            turn_reference: first.map(|first| TurnReference {
                positions: &first[fold.body],
                normal: &normal,
            }),
            left_penetrating: left_penetrating
                .get(fold.winding_slot)
                .filter(|left| !left.is_empty())
                .map(Vec::as_slice),
        };
        let resolved = resolve_detected_in(&fold.pre, &detection, &input, params, winding);
        let o = match resolved.map_err(fail)? {
            FoldOutcome::Resolved(o) => o,
            FoldOutcome::NoDirection => {
                out.no_direction += 1;
                return Ok(false);
            }
            FoldOutcome::Apart => return Ok(false),
        };
        bodies.replace(fold.body, &o.positions);
        Ok(out.record(fold, direction, *o))
    }

    /// What a fold passes, cheapest first, before it is resolved in a sweep: not collapsed nor
    /// stretched, intersecting itself (its detection, with the body's tree refit), its body
    /// not inside out (reported in `out`), a mapping direction (its lack counted in `out`).
    /// The detection and `d̂_12` (zero for separated regions, which take Eq. 2's from their
    /// contact inside the fold), `None` when the fold does not run.
    fn gates(
        &self,
        fold: &Fold,
        pose: &Pose,
        bodies: &mut PosedBodies,
        out: &mut SelfPassOutput,
    ) -> Result<Option<(Detection, Vector3<f64>)>, FoldError> {
        if fold.pre.collapsed(bodies.positions(fold.body)) {
            return Ok(None);
        }
        // Detection first: a joint that does not fold into itself costs its detection only.
        let clock = Instant::now();
        let posed = bodies.posed(fold.body, &fold.detection)?;
        if fold
            .pre
            .stretched(posed.positions(), posed.bvh().root_box().as_ref())
        {
            return Ok(None);
        }
        let Some(detection) = fold.pre.detect_on(&posed, &fold.sets, clock)? else {
            return Ok(None);
        };
        let (positions, tris) = (bodies.positions(fold.body), &self.triangles[fold.body]);
        if (self.rest_volumes[fold.body]).is_some_and(|v| v.inside_out(positions, tris)) {
            if !out.inside_out.contains(&fold.body) {
                out.inside_out.push(fold.body);
            }
            return Ok(None);
        }
        let direction = if fold.pre.regions.separated() {
            Some(Vector3::zeros())
        } else {
            self.direction(fold, pose, &detection.vertices)
        };
        if direction.is_none() {
            out.no_direction += 1;
        }
        Ok(direction.map(|d| (detection, d)))
    }
}

impl SelfPassOutput {
    /// Adds `fold`'s output `o` (resolved along `direction`, unless its regions are separated)
    /// to the frame's report; whether it moved the body (not when it was left unbalanced).
    fn record(&mut self, fold: &Fold, direction: Vector3<f64>, o: FoldOutput) -> bool {
        self.unbalanced += usize::from(o.unbalanced);
        if !o.unbalanced {
            self.guarded += o.guarded;
            self.bulge_guarded += o.bulge_guarded;
        }
        self.timings += o.timings;
        let moved = !o.unbalanced;
        self.folds.push(FoldReport {
            body: fold.body,
            name: fold.pre.regions.pair.name.clone(),
            direction: if fold.pre.regions.separated() {
                o.contact.sides[0].direction
            } else {
                direction
            },
            output: o,
        });
        moved
    }
}

/// One frame of the pass as a fold sweeps it: the pose and the bodies.
struct Frame<'f, 'p> {
    rig: &'f Rig,
    pose: &'f Pose,
    /// The skinning's normals per body ([`SelfContactPass::run_with_normals`]).
    normals: Option<&'f [Vec<Vector3<f64>>]>,
    bodies: &'f mut PosedBodies<'p>,
    /// Per body, the vertices the sweep before left penetrating ([`FurtherSweeps::left`]).
    left_penetrating: &'f [Vec<bool>],
}

/// One normal per position, per body.
fn check_normals(
    positions: &[Vec<Point3<f64>>],
    normals: &[Vec<Vector3<f64>>],
) -> Result<(), SelfPassError> {
    let counts =
        |p: usize, n: usize| SelfPassError::Mismatch(format!("{p} positions, {n} normals"));
    if normals.len() != positions.len() {
        return Err(counts(positions.len(), normals.len()));
    }
    for (p, n) in positions.iter().zip(normals) {
        if p.len() != n.len() {
            return Err(counts(p.len(), n.len()));
        }
    }
    Ok(())
}

/// What decides the further sweeps of a frame ([`SelfContactPass::with_max_passes`]), per
/// inside-twice tree ([`Fold::winding_slot`]: per body, and per fold run without layers) so
/// that what a body gets does not depend on the others.
struct FurtherSweeps {
    /// Per tree: the vertices of the shared regions of its folds that moved this frame (empty
    /// until one does, and again once the tree is done), where further sweeps act.
    reach: Vec<Vec<bool>>,
    /// Per tree, whether one of its folds moved its body in the sweep just run.
    moved: Vec<bool>,
    /// Per tree, per vertex: whether the last sweep left it penetrating (empty before the
    /// first further sweep and for a tree done): a further sweep does not pin these crease
    /// vertices again ([`FoldInput::left_penetrating`]).
    left: Vec<Vec<bool>>,
}

impl FurtherSweeps {
    fn new(slots: usize) -> Self {
        Self {
            reach: vec![Vec::new(); slots],
            moved: vec![false; slots],
            left: vec![Vec::new(); slots],
        }
    }

    /// After a sweep at or past the sweep count: per fold, whether it runs in a further
    /// sweep, `None` when no fold does. A body goes on only while the sweep just run moved it
    /// (else another would find the same, as for the whole frame) and penetrating vertices are
    /// left in its reach, whether or not its last sweep left fewer than the one before (a sweep
    /// that does not lower the count can prepare one that does); a body done is neither tested
    /// nor swept again. The vertices found are kept in [`FurtherSweeps::left`] for the sweep.
    fn next(&mut self, pass: &SelfContactPass, bodies: &mut PosedBodies) -> Option<Vec<bool>> {
        for (reach, &moved) in self.reach.iter_mut().zip(&self.moved) {
            if !moved {
                reach.clear();
            }
        }
        let mut flagged = pass.penetrating(bodies, &self.reach);
        for (flags, reach) in flagged.iter_mut().zip(&mut self.reach) {
            if flags.is_empty() {
                reach.clear();
            }
        }
        for ((left, flags), reach) in self.left.iter_mut().zip(&flagged).zip(&self.reach) {
            left.clear();
            if !flags.is_empty() {
                left.resize(reach.len(), false);
                for &v in flags {
                    if let Some(l) = left.get_mut(v as usize) {
                        *l = true;
                    }
                }
            }
        }
        (!flagged.iter().all(Vec::is_empty)).then(|| pass.folds_holding(&flagged))
    }
}

/// Flags the vertices of `regions`' shared region in `reach` (sized on first use); both regions'
/// for separated ones.
fn add_shared_region(reach: &mut Vec<bool>, regions: &PairRegions) {
    if reach.is_empty() {
        reach.resize(regions.w1.len(), false);
    }
    for &v in &regions.shared {
        if let Some(r) = reach.get_mut(v as usize) {
            *r = true;
        }
    }
    // Separated regions have no shared region: their contact may lie anywhere in them.
    if regions.separated() {
        for (r, (&a, &b)) in reach.iter_mut().zip(regions.w1.iter().zip(&regions.w2)) {
            *r |= a || b;
        }
    }
}

/// The turn guard's reference of one body in one pose (a sign reference per face only).
enum SkinnedNormals<'s> {
    /// The welded normals of the skinning that made the input
    /// ([`SelfContactPass::run_with_normals`]).
    Given(&'s [Vector3<f64>]),
    /// Linear blend skinning's, computed from the pose ([`SelfContactPass::run`]).
    Linear(LinearNormals<'s>),
}

impl SkinnedNormals<'_> {
    /// The reference normal of welded vertex `v` (zero if it has none or a non-finite one).
    fn at(&self, v: usize) -> Vector3<f64> {
        match self {
            Self::Given(normals) => normals
                .get(v)
                .copied()
                .map_or_else(Vector3::zeros, unit_or_zero),
            Self::Linear(linear) => linear.at(v),
        }
    }
}

/// Each welded vertex's rest normal (the file's where it has one, what the skinning carries;
/// else the rest surface's) carried by its blended joint matrix as linear blend skinning
/// carries it (the cofactor), whatever skinning made the input.
struct LinearNormals<'s> {
    body: &'s crate::rig::Body,
    mats: Vec<nalgebra::Matrix4<f64>>,
    rest: &'s [Vector3<f64>],
    representative: &'s [u32],
}

impl LinearNormals<'_> {
    fn at(&self, v: usize) -> Vector3<f64> {
        let Some(&rep) = self.representative.get(v) else {
            return Vector3::zeros();
        };
        let rep = rep as usize;
        let mut linear = Matrix3::zeros();
        for (j, w) in self.body.weights.row(rep) {
            if let Some(m) = self.mats.get(j) {
                linear += m.fixed_view::<3, 3>(0, 0) * w;
            }
        }
        let n = self
            .body
            .normals
            .get(rep)
            .filter(|n| n.norm_squared() > 0.0)
            .or_else(|| self.rest.get(v))
            .copied()
            .unwrap_or_else(Vector3::zeros);
        unit_or_zero(cofactor(&linear) * n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two ellipsoids crossing at right angles, rigid on sibling joints: the
    /// skeleton's separated pair (the siblings' subtrees) crosses itself at rest. Centered, the
    /// normals over both intersection regions cancel out (Eq. 2 has no direction): the pass
    /// leaves the mesh as it was and counts the fold as one without a direction (until
    /// 2026-12-05 it was dropped as if the parts only touched). Shifted off center, the same
    /// pair is resolved.
    #[test]
    fn separated_regions_crossing_symmetrically_count_as_without_direction() {
        use crate::frames::{welded_positions, Precomputed};
        use crate::selfcontact::separated_from_skeleton;
        use crate::skinning::Method;
        let run = |offset: f64| {
            let bytes = crate::scenes::crossing_ellipsoids_glb(offset);
            let rig = crate::rig::load_from_bytes(std::path::Path::new("crossing"), &bytes)
                .expect("the test rig loads");
            let pre = Precomputed::new(&rig, Method::Lbs);
            let rest = welded_positions(&rig, &pre, None, 0.0);
            let options = RegionOptions::default();
            let separated = separated_from_skeleton(&rig, &pre.welded, &options).expect("pairs");
            assert_eq!(separated.len(), 1, "long_x against long_z");
            let pass = SelfContactPass::with_separated(
                &rig,
                &pre.welded,
                &rest,
                &options,
                FoldParams::default(),
                &[],
                separated,
            )
            .expect("pass");
            let mut positions = rest.clone();
            let pose = rig.pose_at(None, 0.0);
            let out = pass.run(&rig, &pose, &mut positions).expect("runs");
            (out, positions == rest)
        };
        let (out, unchanged) = run(0.0);
        assert_eq!((out.no_direction, out.folds.len()), (1, 0));
        assert!(unchanged);
        let (out, unchanged) = run(0.05);
        assert_eq!(out.no_direction, 0);
        assert!(!out.folds.is_empty() && !unchanged);
    }

    /// A body's detection tree follows its positions: after [`PosedBodies::replace`] the next
    /// detection refits it (a stale tree would miss the pairs the move created), and so does
    /// the first detection of a frame handed an earlier frame's trees.
    #[test]
    fn replaced_positions_refit_the_tree() {
        let tris = vec![[0u32, 1, 2]];
        let at = |x: f64| {
            vec![
                Point3::new(x, 0.0, 0.0),
                Point3::new(x + 1.0, 0.0, 0.0),
                Point3::new(x, 1.0, 0.0),
            ]
        };
        let index = MeshIndex::new(&at(0.0), &tris).expect("index");
        let mut positions = vec![at(0.0)];
        let mut bodies = PosedBodies::new(&mut positions, None, 1);
        let low_x = |b: &mut PosedBodies| {
            let posed = b.posed(0, &index).expect("finite positions");
            posed.bvh().root_box().expect("a face").min.x
        };
        assert_eq!(low_x(&mut bodies), 0.0);
        bodies.replace(0, &at(5.0));
        assert_eq!(bodies.positions(0)[0].x, 5.0);
        assert_eq!(low_x(&mut bodies), 5.0);
        let trees = bodies.into_trees();
        let mut next_frame = vec![at(-3.0)];
        let mut bodies = PosedBodies::new(&mut next_frame, Some(trees), 1);
        assert_eq!(low_x(&mut bodies), -3.0);
        // A non-finite position is refused, and the tree is refit once it is finite again.
        bodies.replace(0, &at(f64::NAN));
        assert!(bodies.posed(0, &index).is_err());
        bodies.replace(0, &at(2.0));
        assert_eq!(low_x(&mut bodies), 2.0);
    }

    /// The normals a fold reads follow the positions: kept while they do not change, made
    /// again after [`PosedBodies::replace`] (stale ones would face the old surface).
    #[test]
    fn replaced_positions_drop_the_normals() {
        let tris = vec![[0u32, 1, 2]];
        let flat = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ];
        // The same triangle turned to face +x.
        let turned: Vec<Point3<f64>> = flat.iter().map(|p| Point3::new(0.0, p.x, p.y)).collect();
        let mut positions = vec![flat];
        let mut bodies = PosedBodies::new(&mut positions, None, 1);
        let rest = || WindingNumber::new(&[], &[]);
        let normal = |b: &mut PosedBodies| b.for_fold(0, 0, &tris, rest).1[0];
        assert_eq!(normal(&mut bodies), Vector3::z());
        assert_eq!(normal(&mut bodies), Vector3::z());
        bodies.replace(0, &turned);
        assert_eq!(normal(&mut bodies), Vector3::x());
    }
}
