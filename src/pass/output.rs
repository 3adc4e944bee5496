//! What the contact pass gives: the positions, each body's diagnostics, the contacts and
//! failures, and the per-stage timings of the paper's Table 1.

use super::PassError;
use crate::contact::Contact;
use crate::deform::RegionDeformation;
use nalgebra::{Point3, Vector3};

/// Time per stage in seconds, summed over pairs and regions (the paper's Table 1 columns).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct StageTimings {
    /// Normals and BVH refits.
    pub setup: f64,
    /// i.: intersection detection and regions.
    pub intersection: f64,
    /// m.: direction and mapping.
    pub mapping: f64,
    /// c.: potential surface and contact zones.
    pub zones: f64,
    /// p.: parametrization (heat method).
    pub parametrization: f64,
    /// di.: direction field.
    pub directions: f64,
    /// g.: amplitude and slope diffusion.
    pub fields: f64,
    /// de.: profiles, bulge, volume, displacement.
    pub deformation: f64,
    /// s.: numeric factorizations (part of p., di. and g.).
    pub factorization: f64,
    /// Wall-clock time of the whole pass.
    pub wall: f64,
}

/// Per-body diagnostics of one frame.
#[derive(Clone, Debug, Default)]
pub struct BodyDiagnostics {
    /// `u` per welded vertex (1 where undeformed).
    pub u: Vec<f64>,
    /// Contact-zone flag per welded vertex.
    pub zone: Vec<bool>,
    /// Displacement direction `d` per welded vertex (zero where undeformed).
    pub direction: Vec<Vector3<f64>>,
    /// Bulge part of the displacement at `γ = 1` per welded vertex.
    pub bulge: Vec<Vector3<f64>>,
    /// Amplitude field `a` per welded vertex.
    pub amplitude: Vec<f64>,
    /// Slope field `s` per welded vertex.
    pub slope: Vec<f64>,
    /// The region's statistics (when deformed).
    pub stats: Option<crate::deform::DeformStats>,
}

impl BodyDiagnostics {
    /// Those of a body of `n` welded vertices that the pass left as it was.
    pub fn unchanged(n: usize) -> Self {
        Self {
            u: vec![1.0; n],
            zone: vec![false; n],
            direction: vec![Vector3::zeros(); n],
            bulge: vec![Vector3::zeros(); n],
            amplitude: vec![0.0; n],
            slope: vec![0.0; n],
            stats: None,
        }
    }
}

/// Summary of one contact.
#[derive(Clone, Debug)]
pub struct ContactSummary {
    /// The two bodies.
    pub bodies: [usize; 2],
    /// The contact.
    pub contact: Contact,
}

/// Output of one frame.
#[derive(Clone, Debug)]
pub struct PassOutput {
    /// Output positions per body (welded vertices).
    pub positions: Vec<Vec<Point3<f64>>>,
    /// Diagnostics per body, `None` for a body the pass left as it was
    /// ([`PassOutput::diagnostics_of`] gives its [`BodyDiagnostics::unchanged`]): not made in
    /// every frame for `--diagnostics` alone (six arrays per body, a fifth of a single-body
    /// frame's skinning time).
    pub diagnostics: Vec<Option<BodyDiagnostics>>,
    /// Contacts found.
    pub contacts: Vec<ContactSummary>,
    /// Stage timings.
    pub timings: StageTimings,
    /// Contacts resolved by passes after the first.
    pub later_contacts: usize,
    /// Pairs of bodies found intersecting with no direction to resolve them along (Eq. 2's
    /// normals cancel out: two bodies crossing symmetrically) and no direction configured,
    /// left as they were ([`crate::contact::PairOutcome::NoDirection`]); summed over the passes.
    pub pairs_without_direction: usize,
    /// Contacts and deformations that failed this frame (a factorization that found its
    /// matrix not positive definite, entangled surfaces, …), each leaving what it would have
    /// moved as it came in while the pass went on with the others: a pair whose contact
    /// failed moves neither body for it, a body whose deformation failed keeps its input
    /// positions (the other side of its contacts is still deformed onto the shared contact
    /// surface). Until 2026-12-05 one such failure stopped the whole run; the input found to
    /// make one fail is a broken rig (a body sheared a billion-fold by a fuzzed inverse bind
    /// matrix). Each pair or body once per frame (its first error), however many passes met it;
    /// a body whose deformation failed in a later pass keeps the earlier passes' output. The
    /// contacts of a body whose deformation failed still count in [`PassOutput::contacts`]
    /// (their other sides were deformed).
    pub failed: Vec<FailedContact>,
    /// Closed bodies that the frame turned inside out (their signed volume of the other sign
    /// than at rest: a joint scaled by a negative factor in the animation), judged when one of
    /// their pairs crosses and then left out of the contacts and as they came, each once. The passes take a body's winding for outward
    /// (the rest pose's mirror is undone at load); on one turned inside out they resolved the
    /// wrong way (the capsule pair with one capsule mirrored from mid-animation: 634 faces
    /// turned over by the pass in a frame, found 2026-12-05).
    pub inside_out: Vec<usize>,
}

/// A contact or a deformation that failed in a frame ([`PassOutput::failed`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FailedContact {
    /// The two bodies of a contact (in increasing order), or the one body of a deformation.
    pub bodies: Vec<usize>,
    /// What failed.
    pub error: String,
}

impl FailedContact {
    pub(super) fn new(bodies: &[usize], error: &PassError) -> Self {
        let mut bodies = bodies.to_vec();
        bodies.sort_unstable();
        Self {
            bodies,
            error: error.to_string(),
        }
    }
}

impl PassOutput {
    /// Appends one body's result: its deformation, or its input unchanged (`None`: no
    /// contact zone on it), with the diagnostics of either.
    pub(super) fn push_body(&mut self, deformed: Option<RegionDeformation>, input: &[Point3<f64>]) {
        let Some(d) = deformed else {
            self.positions.push(input.to_vec());
            self.diagnostics.push(None);
            return;
        };
        self.timings.parametrization += d.timings.parametrization;
        self.timings.directions += d.timings.directions;
        self.timings.fields += d.timings.fields;
        self.timings.deformation += d.timings.deformation;
        self.timings.factorization += d.timings.factorization;
        self.positions.push(d.positions);
        self.diagnostics.push(Some(BodyDiagnostics {
            u: d.u,
            zone: d.zone,
            direction: d.direction,
            bulge: d.bulge,
            amplitude: d.amplitude,
            slope: d.slope,
            stats: Some(d.stats),
        }));
    }

    /// The diagnostics of `body` (`None` beyond the bodies).
    pub fn diagnostics_of(&self, body: usize) -> Option<std::borrow::Cow<'_, BodyDiagnostics>> {
        use std::borrow::Cow;
        match self.diagnostics.get(body)? {
            Some(d) => Some(Cow::Borrowed(d)),
            None => Some(Cow::Owned(BodyDiagnostics::unchanged(
                self.positions.get(body)?.len(),
            ))),
        }
    }
}

add_assign_fields!(
    "Times of several passes or folds, summed stage by stage.",
    StageTimings {
        setup,
        intersection,
        mapping,
        zones,
        parametrization,
        directions,
        fields,
        deformation,
        factorization,
        wall,
    }
);
