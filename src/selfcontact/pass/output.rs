//! What the pass reports: per frame its folds, failures, sweeps and timings; per rig the pairs
//! left out, crossing at rest, and the layers they run without.

use super::Fold;
use crate::selfcontact::fold::{FoldOutput, FoldTimings, Unbalanced};
use crate::selfcontact::layers::Layer;
use nalgebra::Vector3;

/// A fold whose two sides already cross at the rest positions the pass was built on
/// ([`super::SelfContactPass::crossing_at_rest`]): layers modeled through each other across a joint
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

/// A fold the pass leaves out in every frame ([`super::SelfContactPass::left_out`]).
#[derive(Clone, Debug, PartialEq)]
pub struct LeftOutFold {
    /// The body.
    pub body: usize,
    /// The pair's name.
    pub name: String,
    /// How its sides cross at rest, when they do.
    pub at_rest: Option<RestCrossing>,
    /// Disabled ([`super::SelfContactPass::with_pair_enabled`] with `false`).
    pub disabled: bool,
}

/// A fold run without pieces of its body sunk into it or lying inside a larger piece at rest
/// ([`super::SelfContactPass::layers`], [`crate::selfcontact::layers`]).
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
    /// [`crate::selfcontact::fold::FoldOutcome::NoDirection`]; until 2026-12-05 the last were
    /// not counted).
    pub no_direction: usize,
    /// Folds left unresolved because no bulge could keep the volume without a spike or a face
    /// turned over ([`crate::selfcontact::fold::FoldOutput::unbalanced`]), by reason.
    pub unbalanced: UnbalancedCounts,
    /// Vertices whose displacement the turn guard scaled back, summed over the folds
    /// ([`crate::selfcontact::fold::FoldOutput::guarded`]).
    pub guarded: usize,
    /// Vertices whose bulge the bulge guard scaled back, summed over the folds
    /// ([`crate::selfcontact::fold::FoldOutput::bulge_guarded`]).
    pub bulge_guarded: usize,
    /// Sweeps over the folds run this frame (see [`super::SelfContactPass::with_max_passes`]).
    pub sweeps: usize,
    /// Folds that failed this frame (a [`crate::selfcontact::fold::FoldError`]: a
    /// factorization that found its matrix not positive definite, an intersection the exact
    /// predicates could not place, …), each
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

/// Folds left unresolved, by reason ([`crate::selfcontact::fold::Unbalanced`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct UnbalancedCounts {
    /// No exact root of the volume cubic ([`Unbalanced::NoVolumeRoot`]).
    pub no_volume_root: usize,
    /// A bulge steeper than its band allows ([`Unbalanced::SteepBulge`]).
    pub steep_bulge: usize,
    /// Every balanced blend turns a face over ([`Unbalanced::TurnedFace`]).
    pub turned_face: usize,
}

impl UnbalancedCounts {
    /// All the folds left unresolved.
    pub fn total(&self) -> usize {
        self.no_volume_root + self.steep_bulge + self.turned_face
    }

    /// Counts one fold's outcome (nothing when it was resolved).
    pub fn count(&mut self, reason: Option<Unbalanced>) {
        match reason {
            Some(Unbalanced::NoVolumeRoot) => self.no_volume_root += 1,
            Some(Unbalanced::SteepBulge) => self.steep_bulge += 1,
            Some(Unbalanced::TurnedFace) => self.turned_face += 1,
            None => {}
        }
    }
}

impl std::ops::AddAssign for UnbalancedCounts {
    fn add_assign(&mut self, other: Self) {
        self.no_volume_root += other.no_volume_root;
        self.steep_bulge += other.steep_bulge;
        self.turned_face += other.turned_face;
    }
}

impl std::iter::Sum for UnbalancedCounts {
    fn sum<I: Iterator<Item = Self>>(counts: I) -> Self {
        counts.fold(Self::default(), |mut all, c| {
            all += c;
            all
        })
    }
}

/// A fold that failed in a frame ([`SelfPassOutput::failed`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FailedFold {
    /// The pair.
    pub name: String,
    /// What failed.
    pub error: String,
}

impl SelfPassOutput {
    /// Adds `fold`'s output `o` (resolved along `direction`, unless its regions are separated)
    /// to the frame's report; whether it moved the body (not when it was left unbalanced).
    pub(super) fn record(&mut self, fold: &Fold, direction: Vector3<f64>, o: FoldOutput) -> bool {
        self.unbalanced.count(o.unbalanced);
        if o.unbalanced.is_none() {
            self.guarded += o.guarded;
            self.bulge_guarded += o.bulge_guarded;
        }
        self.timings += o.timings;
        let moved = o.unbalanced.is_none();
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
