//! The pass in a frame: its sweeps over the folds (the first over every fold, further ones
//! over those still holding a penetrating vertex), each fold's gates (detection, direction)
//! and resolution, and the skinned normals the turn guard compares with.

use super::posed::PosedBodies;
use super::{FailedFold, Fold, SelfContactPass, SelfPassError, SelfPassOutput};
use crate::report::metrics::penetrating_among;
use crate::rig::{Pose, Rig};
use crate::selfcontact::direction::{DirectionSource, Meeting};
use crate::selfcontact::fold::{resolve_detected_in, Detection, FoldError, FoldInput, FoldOutcome};
use crate::selfcontact::regions::PairRegions;
use crate::selfcontact::turn_guard::TurnReference;
use crate::skinning::{cofactor, unit_or_zero};
use nalgebra::{Matrix3, Point3, Vector3};
use std::time::Instant;

impl SelfContactPass {
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
        // Checked finite above (`check_frame`).
        let mut bodies = PosedBodies::new(positions, trees, self.slots.len()).checked_finite();
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
    /// without a skin): the `given` normals of the body, else linear blend skinning's of its
    /// bind normals, morphed by the pose's weights where it has morph targets.
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
        let bind = match body.morphed(pose.morph_weights_of(body.node)) {
            Some(shape) => std::borrow::Cow::Owned(shape.normals),
            None => std::borrow::Cow::Borrowed(&body.normals[..]),
        };
        Some(SkinnedNormals::Linear(LinearNormals {
            body,
            bind,
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
    /// The body's bind normals, morphed where the pose weights its morph targets.
    bind: std::borrow::Cow<'s, [Vector3<f64>]>,
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
            .bind
            .get(rep)
            .filter(|n| n.norm_squared() > 0.0)
            .or_else(|| self.rest.get(v))
            .copied()
            .unwrap_or_else(Vector3::zeros);
        unit_or_zero(cofactor(&linear) * n)
    }
}
