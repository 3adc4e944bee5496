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
//!
//! Built here, with the folds as built once per rig in `build`; run in a frame by `run`, on the
//! frame's bodies as `posed` keeps them; what it reports is in `output`.

mod build;
mod output;
mod posed;
mod run;

pub use output::{
    FailedFold, FoldLayers, FoldReport, LeftOutFold, RestCrossing, SelfPassOutput, UnbalancedCounts,
};

use build::{triangles_without, with_detection};

use super::direction::{BoneAxes, DirectionSource};
use super::fold::{FoldError, FoldParams, FoldPre};
use super::layers::Layer;
use super::regions::{derive_pairs_reporting, PairRegions, RegionOptions};
use super::SelfContactError;
use crate::intersect::{FaceSets, IntersectError, MeshIndex, TriangleBvh};
use crate::mesh::operators::{mean_edge_length, vertex_normals, NormalWeighting};
use crate::mesh::{RestVolume, WeldedMesh};
use crate::pass::RestOverlaps;
use crate::report::metrics::WindingNumber;
use crate::rig::{Pose, Rig};
use nalgebra::{Point3, Vector3};
use std::sync::{Arc, Mutex};

/// One joint pair of one body, precomputed.
#[derive(Debug)]
struct Fold {
    body: usize,
    pre: FoldPre,
    /// The index its detection runs on, shared by every fold of the body: over the faces of
    /// all their sides, its tree built at rest and refit per frame ([`posed::PosedBodies`]).
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
    /// Its inside-twice tree's slot in [`posed::PosedBodies`]: the body's index for the body's
    /// tree, shared by its folds; past the bodies for a fold on a surface of its body
    /// ([`FoldPre::on_surface`]: a body of several pieces), shared by the folds on the same.
    winding_slot: usize,
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
    /// pass leaves is measured. A face some fold runs on stays, though others run without it:
    /// two fingers modeled as two tubes of one mesh, each fold of a knuckle runs without the
    /// other finger's tube, and both tubes are measured (until 2026-12-06 every face some fold
    /// ran without was left out: on `two_fingers.glb` the whole mesh, and `pose --metrics`
    /// measured nothing, its mean edge length 0 and its depths NaN).
    pub fn triangles_without_layers(&self) -> Vec<Option<Vec<[u32; 3]>>> {
        let mut left: Vec<Vec<bool>> = vec![Vec::new(); self.triangles.len()];
        let mut run_on: Vec<Vec<bool>> = (self.triangles.iter())
            .map(|t| vec![false; t.len()])
            .collect();
        for fold in &self.folds {
            let r = &fold.pre.regions;
            for &f in r.w1_faces.iter().chain(&r.w2_faces) {
                run_on[fold.body][f as usize] = true;
            }
            let Some(without) = &fold.without else {
                continue;
            };
            let flags = &mut left[fold.body];
            flags.resize(self.triangles[fold.body].len(), false);
            for &f in &without.faces {
                flags[f as usize] = true;
            }
        }
        for (flags, on) in left.iter_mut().zip(&run_on) {
            flags.iter_mut().zip(on).for_each(|(l, &on)| *l &= !on);
            if !flags.contains(&true) {
                flags.clear();
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
}

#[cfg(test)]
mod tests {
    use super::posed::PosedBodies;
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
