//! The per-frame contact pass between separate objects (2021 Appendix B): every pair of bodies
//! whose surfaces intersect gets a contact (Algorithm Part 1), then every body with at least
//! one contact is deformed (Part 2). A frame without intersection costs one BVH refit and
//! one overlap query per pair.
//!
//! Each body is one working region (the whole closed surface). Pairs run in parallel, then
//! regions run in parallel; each unit of work is sequential and its output does not depend on
//! the thread count.

use crate::contact::{
    crossing, resolve_crossing, Contact, ContactError, ContactSide, DirectionMode, PairOutcome,
    PairParams,
};
use crate::deform::{
    deform_region, DeformError, DeformParams, RegionDeformation, RegionFrame, WorkingRegion,
};
use crate::intersect::{Aabb, IntersectError, MeshIndex, PosedMesh};
use crate::mesh::operators::{mean_edge_length, vertex_normals, NormalWeighting};
use crate::mesh::RestVolume;
use crate::solve::SolveError;
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use std::sync::OnceLock;
use std::time::Instant;

/// A body at rest: welded positions and triangles.
pub type RestBody<'a> = (&'a [Point3<f64>], &'a [[u32; 3]]);

/// A rig's bodies as [`ContactPass::new`] takes them: each body's welded rest positions
/// (`rest`, one set per body) with its welded triangles.
pub fn rest_bodies<'a>(
    rest: &'a [Vec<Point3<f64>>],
    welded: &'a [crate::mesh::WeldedMesh],
) -> Vec<RestBody<'a>> {
    rest.iter()
        .zip(welded)
        .map(|(p, w)| (p.as_slice(), w.triangles.as_slice()))
        .collect()
}

/// Default `φ̄` as a fraction of the object's rest size ([`crate::mesh::surface_size`]): one
/// half, as when the size was the diagonal of the object's axis-aligned rest bounding box
/// (until 2026-12-02; a rotation of the rig changed it). On the committed object scenes the
/// two sizes agree to 0.3 % (balls), 2 % (capsules), 7 % (fingertips) and 11 % (the slab), and
/// the scenes' metrics are those of the former default. A diameter-based default, also
/// rotation-invariant, fitted either round or long objects, not both (half a diameter let the
/// sphere on the slab keep 38 penetrating vertices; √3/2 of one made the fingertips 45 %
/// slower).
pub const DEFAULT_EXTENT_FACTOR: f64 = 0.5;

/// Default number of passes per frame (see [`ContactPass::with_passes`]).
pub const DEFAULT_PASSES: usize = 2;

/// Contact parameters of one object (2021 Sec. 4.3, 4.4, 5, 7).
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectParams {
    /// Pseudo-stiffness `k` (`k̄_A = k_A / (k_A + k_B)`); `f64::INFINITY` makes the object rigid.
    pub stiffness: f64,
    /// `τ` (Eq. 4) used when this object is the softer one of a pair.
    pub tau: f64,
    /// `φ̄`, extent of the deformation (scene units); `None`: [`DEFAULT_EXTENT_FACTOR`] times
    /// the object's rest size ([`crate::mesh::surface_size`]).
    pub extent: Option<f64>,
    /// `γ`: 0 no bulge, 1 exact volume, > 1 exaggeration.
    pub gamma: f64,
    /// `ω` of the procedural bulge map.
    pub omega: f64,
    /// Painted bulge map per welded vertex (multiplies `η`; negative values allowed).
    pub painted: Option<Vec<f64>>,
    /// Whether the object takes part in contacts between bodies (`[[object]] contact =
    /// false`: an outline shell, a garment layered on the skin, a duplicate, which the pass
    /// would take for one deep interpenetration and crumple).
    pub contact: bool,
}

impl Default for ObjectParams {
    fn default() -> Self {
        Self {
            stiffness: 1.0,
            tau: 0.0,
            extent: None,
            gamma: 1.0,
            omega: 2.0,
            painted: None,
            contact: true,
        }
    }
}

/// Per-pair overrides ([`PairOverride::new`]: none).
#[derive(Clone, Debug, PartialEq)]
pub struct PairOverride {
    /// The two bodies (indices).
    pub bodies: [usize; 2],
    /// `τ` of this pair.
    pub tau: Option<f64>,
    /// The safeguard angle of this pair in degrees ([`PairParams::safeguard_angle`]).
    pub safeguard_angle: Option<f64>,
    /// Mapping direction, outward for `bodies[0]` (constant or keyframed).
    pub direction: Option<DirectionTrack>,
    /// Whether the pair is resolved: `Some(false)` (`[[pair]] enabled = false`) leaves the
    /// two bodies as they come where they meet; `Some(true)` resolves the pair even when the
    /// two surfaces cross at rest and the pass leaves such pairs out
    /// ([`RestOverlaps::LeftOut`]); `None`, the default, follows the pass.
    pub enabled: Option<bool>,
}

/// What [`ContactPass`] does with the pairs of bodies whose surfaces already cross at rest
/// ([`ContactPass::crossing_at_rest`]; [`ContactPass::with_rest_overlaps`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RestOverlaps {
    /// Resolves them like any other (the library's default: a caller may build the pass on
    /// any positions, such as a frame's, where every contact crosses).
    #[default]
    Resolved,
    /// Leaves them out unless an override enables the pair: on a rig's true rest pose (what
    /// `contact-skin pose` does), such an overlap is modeled on purpose, as a robot's rigid
    /// pieces at their hinges or a head sunk into a torso, and resolving it in every frame
    /// works against the model (until 2026-12-05 the CLI did: the Quaternius robot's 11
    /// hinges, with zones of 1-9 vertices, faces turned over and its open pieces' volumes
    /// changed).
    LeftOut,
}

impl PairOverride {
    /// No override of the pair `bodies`: the objects' parameters, the automatic direction,
    /// resolved.
    pub fn new(bodies: [usize; 2]) -> Self {
        Self {
            bodies,
            tau: None,
            safeguard_angle: None,
            direction: None,
            enabled: None,
        }
    }
}

/// A user mapping direction over time (2021 Sec. 4.1: "specify it manually and even key-frame
/// it"): keys `(time, direction)`, normalized linear interpolation between them, held
/// constant before the first and after the last.
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionTrack {
    keys: Vec<(f64, Vector3<f64>)>,
}

impl DirectionTrack {
    /// A constant direction.
    pub fn constant(direction: Vector3<f64>) -> Self {
        Self {
            keys: vec![(0.0, direction)],
        }
    }

    /// Keyframes; `None` when empty, when a time or direction is not finite or a direction is
    /// zero. Keys are sorted by time.
    pub fn keyed(mut keys: Vec<(f64, Vector3<f64>)>) -> Option<Self> {
        let valid = |(t, d): &(f64, Vector3<f64>)| {
            t.is_finite() && d.iter().all(|x| x.is_finite()) && d.norm() > 0.0
        };
        if keys.is_empty() || !keys.iter().all(valid) {
            return None;
        }
        keys.sort_by(|a, b| a.0.total_cmp(&b.0));
        Some(Self { keys })
    }

    /// The direction at time `t` (unit unless two consecutive keys are opposite, where the
    /// earlier key is used).
    pub fn at(&self, t: f64) -> Vector3<f64> {
        let k = &self.keys;
        let first = k[0].1.normalize();
        if k.len() == 1 || t <= k[0].0 {
            return first;
        }
        for w in k.windows(2) {
            let ((t0, d0), (t1, d1)) = (w[0], w[1]);
            if t <= t1 {
                let s = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
                let (d0, d1) = (d0.normalize(), d1.normalize());
                return (d0 * (1.0 - s) + d1 * s).try_normalize(1e-12).unwrap_or(d0);
            }
        }
        k[k.len() - 1].1.normalize()
    }
}

/// Why the pass could not run.
#[derive(Debug, thiserror::Error)]
pub enum PassError {
    /// A mesh is unusable for intersection queries.
    #[error("body {body}: {source}")]
    Intersect {
        /// Body index.
        body: usize,
        /// Cause.
        source: IntersectError,
    },
    /// A region could not be analysed.
    #[error("body {body}: {source}")]
    Solve {
        /// Body index.
        body: usize,
        /// Cause.
        source: SolveError,
    },
    /// A contact failed.
    #[error("contact between bodies {a} and {b}: {source}")]
    Contact {
        /// First body.
        a: usize,
        /// Second body.
        b: usize,
        /// Cause.
        source: ContactError,
    },
    /// A deformation failed.
    #[error("deformation of body {body}: {source}")]
    Deform {
        /// Body.
        body: usize,
        /// Cause.
        source: DeformError,
    },
    /// Inputs do not match the bodies.
    #[error("{0}")]
    Mismatch(String),
}

/// Which pass of a frame runs ([`ContactPass::run_at`]): the first sees the skinned input, a
/// later one the contact surfaces of the passes before
/// ([`crate::contact::PairParams::refuse_coincident`]) and leaves out the pairs that failed
/// in them (a pair refused as coincident would be resolved there).
#[derive(Clone, Copy, Debug)]
enum Pass<'a> {
    First,
    Later { failed: &'a [FailedContact] },
}

impl Pass<'_> {
    /// Whether the pair `(a, b)` is tried in this pass.
    fn tries(&self, a: usize, b: usize) -> bool {
        match self {
            Pass::First => true,
            Pass::Later { failed } => !failed.iter().any(|f| f.bodies == [a.min(b), a.max(b)]),
        }
    }
}

/// The contacts of one pass over the candidate pairs ([`ContactPass::contacts`]).
#[derive(Default)]
struct FoundContacts {
    contacts: Vec<ContactSummary>,
    /// Pairs that intersect with no direction ([`PairOutcome::NoDirection`]).
    without_direction: usize,
    failed: Vec<FailedContact>,
}

/// What a pass makes of each body only when one of its pairs crosses (nothing in a frame
/// without contact): its area-weighted vertex normals, and whether the frame turned it inside
/// out ([`PassOutput::inside_out`]).
struct AtFirstCrossing {
    normals: Vec<OnceLock<Vec<Vector3<f64>>>>,
    turned: Vec<OnceLock<bool>>,
}

impl AtFirstCrossing {
    fn new(bodies: usize) -> Self {
        Self {
            normals: (0..bodies).map(|_| OnceLock::new()).collect(),
            turned: (0..bodies).map(|_| OnceLock::new()).collect(),
        }
    }

    /// The normals made (empty where none was) and the bodies found inside out, ascending.
    fn into_parts(self) -> (Vec<Vec<Vector3<f64>>>, Vec<usize>) {
        let inside_out = (0..self.turned.len())
            .filter(|&b| self.turned[b].get() == Some(&true))
            .collect();
        let normals = (self.normals.into_iter())
            .map(|n| n.into_inner().unwrap_or_default())
            .collect();
        (normals, inside_out)
    }
}

/// Precomputed per body.
#[derive(Clone, Debug)]
struct PassBody {
    /// Its tree and working region; `None` for a body that takes part in no contact
    /// ([`ObjectParams::contact`]): nothing of it is precomputed (a layered shell left out
    /// need not even suit a working region).
    geometry: Option<BodyGeometry>,
    vertex_count: usize,
    triangles: Vec<[u32; 3]>,
    deform: DeformParams,
    /// The rest bounding-box diagonal ([`COLLAPSED`]).
    rest_diagonal: f64,
    /// Its rest signed volume when closed ([`PassOutput::inside_out`]).
    rest_volume: Option<RestVolume>,
}

/// The intersection index and the working region of a body in contacts.
#[derive(Clone, Debug)]
struct BodyGeometry {
    index: MeshIndex,
    region: WorkingRegion,
}

impl BodyGeometry {
    fn new(body: usize, (pos, tris): RestBody) -> Result<Self, PassError> {
        Ok(Self {
            index: MeshIndex::new(pos, tris)
                .map_err(|source| PassError::Intersect { body, source })?,
            region: WorkingRegion::whole(tris, pos.len())
                .map_err(|source| PassError::Solve { body, source })?,
        })
    }
}

/// Whether a contact pass with `overrides` resolves the pair `bodies` where its bodies meet
/// (`crossing_at_rest`: their surfaces cross at rest and the pass leaves such pairs out,
/// [`RestOverlaps::LeftOut`]): not when an override disables it (the configuration allows one
/// per pair; any that does), else when one enables it or the pair is not such a pair.
fn resolves_pair(overrides: &[PairOverride], bodies: [usize; 2], crossing_at_rest: bool) -> bool {
    let [a, b] = bodies;
    let set = (overrides.iter())
        .filter(|o| o.bodies == [a, b] || o.bodies == [b, a])
        .filter_map(|o| o.enabled);
    let (mut on, mut off) = (false, false);
    for e in set {
        on |= e;
        off |= !e;
    }
    !off && (on || !crossing_at_rest)
}

/// The pairs of `bodies` in contacts whose boxes overlap at their `rest` positions and whose
/// surfaces cross there ([`ContactPass::crossing_at_rest`]). A pair whose test fails
/// (surfaces lying on each other, entangled ones) is not counted: the frames refuse it as they
/// would.
fn crossing_at_rest(rest: &[RestBody], bodies: &[PassBody]) -> Result<Vec<[usize; 2]>, PassError> {
    let posed: Vec<Option<(PosedMesh, Aabb)>> = (bodies.iter().zip(rest).enumerate())
        .map(|(body, (b, &(pos, _)))| {
            let Some(g) = &b.geometry else {
                return Ok(None);
            };
            let intersect = |source| PassError::Intersect { body, source };
            let aabb = g.index.bounding_box(pos).map_err(intersect)?;
            let mesh = g.index.pose(pos).map_err(intersect)?;
            Ok(aabb.map(|aabb| (mesh, aabb)))
        })
        .collect::<Result<_, PassError>>()?;
    let overlapping: Vec<[usize; 2]> = (0..posed.len())
        .flat_map(|a| (a + 1..posed.len()).map(move |b| [a, b]))
        .filter(|&[a, b]| match (&posed[a], &posed[b]) {
            (Some((_, x)), Some((_, y))) => x.overlaps(y),
            _ => false,
        })
        .collect();
    Ok(overlapping
        .into_par_iter()
        .filter(|&[a, b]| match (&posed[a], &posed[b]) {
            (Some((x, _)), Some((y, _))) => {
                let found = crossing([x, y], &PairParams::default());
                found.is_ok_and(|c| c.is_some())
            }
            _ => false,
        })
        .collect())
}

/// A body posed smaller than this fraction of its rest bounding-box diagonal (a bone or the
/// whole rig scaled to 0, a common way to hide a part) takes no part in contacts that frame:
/// there is nothing to
/// resolve at that size, and every face of it overlaps every other (measured: two collapsed
/// 3322-vertex capsules took over three minutes per frame).
pub const COLLAPSED: f64 = 1e-6;

/// A body posed larger than this multiple of its rest bounding-box diagonal (a broken
/// animation scaling a joint by 1e20) takes no part in contacts that frame either: its faces
/// stretch across the scene, where the exact predicates fall to their slowest arithmetic
/// (measured: a self-contact frame of CesiumMan with one scale key of 1e20 took 2.4 s). Far
/// above any pose: a sphere sheared a billion-fold still takes part (and its deformation
/// fails, as `tests/contact.rs` needs).
pub const STRETCHED: f64 = 1e10;

/// The contact pass of a set of bodies, precomputed once (indices, regions, symbolic
/// factorizations).
#[derive(Clone, Debug)]
pub struct ContactPass {
    bodies: Vec<PassBody>,
    params: Vec<ObjectParams>,
    overrides: Vec<PairOverride>,
    passes: usize,
    /// [`ContactPass::crossing_at_rest`].
    crossing_at_rest: Vec<[usize; 2]>,
    rest_overlaps: RestOverlaps,
}

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
    /// left as they were ([`PairOutcome::NoDirection`]); summed over the passes.
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
    fn new(bodies: &[usize], error: &PassError) -> Self {
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
    fn push_body(&mut self, deformed: Option<RegionDeformation>, input: &[Point3<f64>]) {
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

impl ContactPass {
    /// Precomputes the pass for bodies given by rest positions and triangles (welded).
    pub fn new(
        rest: &[RestBody<'_>],
        params: Vec<ObjectParams>,
        overrides: Vec<PairOverride>,
    ) -> Result<Self, PassError> {
        if params.len() != rest.len() {
            return Err(PassError::Mismatch(format!(
                "{} bodies, {} parameter sets",
                rest.len(),
                params.len()
            )));
        }
        let bodies = rest
            .iter()
            .zip(&params)
            .enumerate()
            .map(|(body, (&(pos, tris), p))| {
                let geometry = match p.contact {
                    true => Some(BodyGeometry::new(body, (pos, tris))?),
                    false => None,
                };
                let extent = p.extent.unwrap_or_else(|| {
                    DEFAULT_EXTENT_FACTOR * crate::mesh::surface_size(pos, tris)
                });
                let deform = DeformParams {
                    extent,
                    gamma: p.gamma,
                    omega: p.omega,
                    ..DeformParams::default()
                };
                Ok(PassBody {
                    geometry,
                    vertex_count: pos.len(),
                    triangles: tris.to_vec(),
                    deform,
                    rest_diagonal: crate::mesh::bbox_diagonal(pos),
                    rest_volume: p.contact.then(|| RestVolume::of(pos, tris)).flatten(),
                })
            })
            .collect::<Result<Vec<_>, PassError>>()?;
        let crossing_at_rest = crossing_at_rest(rest, &bodies)?;
        Ok(Self {
            bodies,
            params,
            overrides,
            passes: DEFAULT_PASSES,
            crossing_at_rest,
            rest_overlaps: RestOverlaps::default(),
        })
    }

    /// The pairs of bodies in contacts whose surfaces already cross at the positions the pass
    /// was built on (`[a, b]`, `a < b`; beyond a touch, by the test that opens a contact in a
    /// frame, [`crate::contact::crossing`]). What the pass does with them:
    /// [`ContactPass::with_rest_overlaps`].
    pub fn crossing_at_rest(&self) -> &[[usize; 2]] {
        &self.crossing_at_rest
    }

    /// Sets what the pass does with the pairs of [`ContactPass::crossing_at_rest`] (default
    /// [`RestOverlaps::Resolved`]).
    pub fn with_rest_overlaps(mut self, rest_overlaps: RestOverlaps) -> Self {
        self.rest_overlaps = rest_overlaps;
        self
    }

    /// The pairs of [`ContactPass::crossing_at_rest`] that the pass leaves out: none with
    /// [`RestOverlaps::Resolved`], else those no override enables.
    pub fn left_out_at_rest(&self) -> Vec<[usize; 2]> {
        (self.crossing_at_rest.iter().copied())
            .filter(|&[a, b]| !self.resolves(a, b))
            .collect()
    }

    /// Whether the pass resolves pair `(a, b)` where it meets ([`resolves_pair`]).
    fn resolves(&self, a: usize, b: usize) -> bool {
        let crossing = self.rest_overlaps == RestOverlaps::LeftOut
            && self.crossing_at_rest.contains(&[a.min(b), a.max(b)]);
        resolves_pair(&self.overrides, [a, b], crossing)
    }

    /// Number of bodies.
    pub fn body_count(&self) -> usize {
        self.bodies.len()
    }

    /// The parameters of pair `(a, b)` at animation time `time`.
    pub fn pair_params(&self, a: usize, b: usize, time: f64) -> PairParams {
        let (pa, pb) = (&self.params[a], &self.params[b]);
        let (ka, kb) = (pa.stiffness, pb.stiffness);
        let stiffness_a = if ka.is_infinite() && kb.is_infinite() {
            0.5
        } else if ka.is_infinite() {
            1.0
        } else if kb.is_infinite() {
            0.0
        } else if ka + kb > 0.0 {
            ka / (ka + kb)
        } else {
            0.5
        };
        let tau = if ka < kb {
            pa.tau
        } else if kb < ka {
            pb.tau
        } else {
            0.5 * (pa.tau + pb.tau)
        };
        let mut pp = PairParams {
            stiffness_a,
            tau,
            direction: DirectionMode::Automatic,
            ..PairParams::default()
        };
        for o in &self.overrides {
            let swapped = o.bodies == [b, a];
            if o.bodies == [a, b] || swapped {
                if let Some(t) = o.tau {
                    pp.tau = t;
                }
                if let Some(angle) = o.safeguard_angle {
                    pp.safeguard_angle = angle;
                }
                if let Some(track) = &o.direction {
                    let d = track.at(time);
                    pp.direction = DirectionMode::Fixed(if swapped { -d } else { d });
                }
            }
        }
        pp
    }

    /// Sets how many times the pass is applied per frame (at least 1; default
    /// [`DEFAULT_PASSES`]). The paper applies it once (`1` reproduces it exactly); a second pass resolves intersections created by the first one's bulges (next to a
    /// stiffer object with a small contact zone). Every pass preserves the volume exactly.
    pub fn with_passes(mut self, passes: usize) -> Self {
        self.passes = passes.max(1);
        self
    }

    /// Runs the pass on one frame (welded positions per body), [`ContactPass::with_passes`]
    /// times (stopping early when nothing intersects any more). Diagnostics and contacts are
    /// those of the first pass; timings are summed.
    pub fn run(&self, positions: &[Vec<Point3<f64>>]) -> Result<PassOutput, PassError> {
        self.run_at(positions, 0.0)
    }

    /// [`ContactPass::run`] at animation time `time` (for keyframed directions).
    pub fn run_at(
        &self,
        positions: &[Vec<Point3<f64>>],
        time: f64,
    ) -> Result<PassOutput, PassError> {
        let mut out = self.run_once(positions, time, Pass::First)?;
        // A first pass without contact moved nothing: a later one would try the same pairs
        // less the failed ones on the same positions and find nothing either (a frame without
        // contact ran both; `cargo bench --bench contact -- "no-contact frame/2 passes"`).
        if out.contacts.is_empty() {
            return Ok(out);
        }
        for _ in 1..self.passes {
            let pass = Pass::Later {
                failed: &out.failed,
            };
            let next = self.run_once(&out.positions, time, pass)?;
            // Failures first: a later pass whose only contact failed moves nothing, but its
            // failure is the frame's.
            for f in next.failed {
                if !out.failed.iter().any(|g| g.bodies == f.bodies) {
                    out.failed.push(f);
                }
            }
            for b in next.inside_out {
                if !out.inside_out.contains(&b) {
                    out.inside_out.push(b);
                }
            }
            if next.contacts.is_empty() {
                break;
            }
            out.timings += next.timings;
            out.positions = next.positions;
            out.later_contacts += next.contacts.len();
            out.pairs_without_direction += next.pairs_without_direction;
        }
        Ok(out)
    }

    fn run_once(
        &self,
        positions: &[Vec<Point3<f64>>],
        time: f64,
        pass: Pass,
    ) -> Result<PassOutput, PassError> {
        let wall = Instant::now();
        self.check_counts(positions)?;
        let boxes = self.boxes(positions)?;
        let mut pairs = self.candidate_pairs(&boxes);
        pairs.retain(|&(a, b)| pass.tries(a, b));
        let posed = self.posed(positions, &pairs)?;
        let mut timings = StageTimings {
            setup: wall.elapsed().as_secs_f64(),
            ..Default::default()
        };
        let lazy = AtFirstCrossing::new(positions.len());
        let found = self.contacts(positions, &lazy, &posed, &pairs, time, pass);
        let (normals, inside_out) = lazy.into_parts();
        for c in &found.contacts {
            timings.intersection += c.contact.timings.intersection;
            timings.mapping += c.contact.timings.mapping;
            timings.zones += c.contact.timings.zones;
        }
        let results: Vec<_> = (0..self.bodies.len())
            .into_par_iter()
            .map(|body| self.deform_body(body, positions, &normals, &found.contacts))
            .collect();
        let mut out = PassOutput {
            positions: Vec::new(),
            diagnostics: Vec::new(),
            contacts: found.contacts,
            timings,
            later_contacts: 0,
            pairs_without_direction: found.without_direction,
            failed: found.failed,
            inside_out,
        };
        for (body, r) in results.into_iter().enumerate() {
            let deformed = r.unwrap_or_else(|e| {
                out.failed.push(FailedContact::new(&[body], &e));
                None
            });
            out.push_body(deformed, &positions[body]);
        }
        out.timings.wall = wall.elapsed().as_secs_f64();
        Ok(out)
    }

    /// Whether body `b`, its box `posed` at its positions, is between [`COLLAPSED`] and
    /// [`STRETCHED`] times its rest bounding-box diagonal.
    fn in_size(&self, b: usize, posed: Option<&Aabb>) -> bool {
        let Some(rest) = self.bodies.get(b).map(|body| body.rest_diagonal) else {
            return false;
        };
        posed.is_some_and(|x| {
            let size = (x.max - x.min).norm();
            size >= COLLAPSED * rest && size <= STRETCHED * rest
        })
    }

    /// One position set per body, each with the body's vertex count.
    fn check_counts(&self, positions: &[Vec<Point3<f64>>]) -> Result<(), PassError> {
        if positions.len() != self.bodies.len() {
            return Err(PassError::Mismatch(format!(
                "{} bodies, {} position sets",
                self.bodies.len(),
                positions.len()
            )));
        }
        for (body, (p, b)) in positions.iter().zip(&self.bodies).enumerate() {
            if p.len() != b.vertex_count {
                return Err(PassError::Intersect {
                    body,
                    source: IntersectError::PositionCount {
                        expected: b.vertex_count,
                        got: p.len(),
                    },
                });
            }
        }
        Ok(())
    }

    /// Every body's box at its positions (checked as a refit checks them), or none when there
    /// are fewer than two bodies: no pair to find, the positions only checked (a single-body
    /// rig's frame paid a tree and the normals here for nothing, four times its skinning).
    fn boxes(&self, positions: &[Vec<Point3<f64>>]) -> Result<Vec<Option<Aabb>>, PassError> {
        let bodies = positions.iter().zip(&self.bodies).enumerate();
        if self.bodies.len() < 2 {
            for (body, (p, b)) in bodies {
                if let Some(g) = &b.geometry {
                    (g.index.check_frame(p))
                        .map_err(|source| PassError::Intersect { body, source })?;
                }
            }
            return Ok(Vec::new());
        }
        bodies
            .map(|(body, (p, b))| match &b.geometry {
                Some(g) => (g.index.bounding_box(p))
                    .map_err(|source| PassError::Intersect { body, source }),
                None => Ok(None),
            })
            .collect()
    }

    /// The bodies of the candidate `pairs` posed (their trees refit at their positions), the
    /// others not (`None`): a frame whose bodies' boxes do not meet refits no tree.
    fn posed<'a>(
        &'a self,
        positions: &'a [Vec<Point3<f64>>],
        pairs: &[(usize, usize)],
    ) -> Result<Vec<Option<PosedMesh<'a>>>, PassError> {
        let paired = |b: usize| pairs.iter().any(|&(x, y)| x == b || y == b);
        positions
            .iter()
            .zip(&self.bodies)
            .enumerate()
            .map(|(body, (p, b))| match (&b.geometry, paired(body)) {
                (Some(g), true) => (g.index.pose(p).map(Some))
                    .map_err(|source| PassError::Intersect { body, source }),
                _ => Ok(None),
            })
            .collect()
    }

    /// The body pairs to resolve: both in size and taking part in contacts, the pair resolved
    /// ([`ContactPass::resolves`]), their boxes overlapping.
    fn candidate_pairs(&self, boxes: &[Option<Aabb>]) -> Vec<(usize, usize)> {
        let sized: Vec<bool> = (0..boxes.len())
            .map(|b| self.params[b].contact && self.in_size(b, boxes[b].as_ref()))
            .collect();
        let overlap = |a: usize, b: usize| match (&boxes[a], &boxes[b]) {
            (Some(x), Some(y)) => x.overlaps(y),
            _ => false,
        };
        (0..boxes.len())
            .flat_map(|a| (a + 1..boxes.len()).map(move |b| (a, b)))
            .filter(|&(a, b)| sized[a] && sized[b] && self.resolves(a, b))
            .filter(|&(a, b)| overlap(a, b))
            .collect()
    }

    /// The contacts (Sec. 4) of the candidate `pairs` of bodies, in parallel; what each body
    /// needs once a pair crosses made in `lazy` (a body turned inside out leaves its pairs
    /// apart).
    fn contacts(
        &self,
        positions: &[Vec<Point3<f64>>],
        lazy: &AtFirstCrossing,
        posed: &[Option<PosedMesh>],
        pairs: &[(usize, usize)],
        time: f64,
        pass: Pass,
    ) -> FoundContacts {
        // Area-weighted vertex normals of body `k`, made once, when a contact first needs them.
        let normals_of = |k: usize| -> &[Vector3<f64>] {
            lazy.normals[k].get_or_init(|| {
                vertex_normals(
                    &positions[k],
                    &self.bodies[k].triangles,
                    NormalWeighting::Area,
                )
            })
        };
        let found = pairs
            .par_iter()
            .map(|&(a, b)| {
                // Geometric order, not body order: the same two surfaces give the same bits
                // whichever body comes first (the exact predicates break ties by perturbing
                // the second surface).
                let (a, b) = if canonical_key(&positions[b]) < canonical_key(&positions[a]) {
                    (b, a)
                } else {
                    (a, b)
                };
                let (Some(pa), Some(pb)) = (&posed[a], &posed[b]) else {
                    // Not a candidate pair (every pair's bodies are posed).
                    return Ok(([a, b], PairOutcome::Apart));
                };
                let bodies = [a, b];
                let params = PairParams {
                    refuse_coincident: matches!(pass, Pass::First),
                    ..self.pair_params(a, b, time)
                };
                let fail =
                    move |source| FailedContact::new(&bodies, &PassError::Contact { a, b, source });
                let Some(found) = crossing([pa, pb], &params).map_err(fail)? else {
                    return Ok((bodies, PairOutcome::Apart));
                };
                let inside_out = |k: usize| {
                    let body = &self.bodies[k];
                    *lazy.turned[k].get_or_init(|| {
                        (body.rest_volume)
                            .is_some_and(|v| v.inside_out(&positions[k], &body.triangles))
                    })
                };
                if inside_out(a) | inside_out(b) {
                    return Ok((bodies, PairOutcome::Apart));
                }
                resolve_crossing([pa, pb], found, |k| normals_of(bodies[k]), &params)
                    .map(|outcome| (bodies, outcome))
                    .map_err(fail)
            })
            .collect::<Vec<_>>();
        let mut out = FoundContacts::default();
        for r in found {
            match r {
                Ok((_, PairOutcome::NoDirection)) => out.without_direction += 1,
                Ok((bodies, o)) => out.contacts.extend(
                    o.into_contact()
                        .map(|contact| ContactSummary { bodies, contact }),
                ),
                Err(failed) => out.failed.push(failed),
            }
        }
        out
    }

    fn deform_body(
        &self,
        body: usize,
        positions: &[Vec<Point3<f64>>],
        normals: &[Vec<Vector3<f64>>],
        contacts: &[ContactSummary],
    ) -> Result<Option<RegionDeformation>, PassError> {
        let sides: Vec<&ContactSide> = contacts
            .iter()
            .flat_map(|c| {
                c.bodies
                    .iter()
                    .enumerate()
                    .filter(move |(_, &b)| b == body)
                    .map(move |(k, _)| &c.contact.sides[k])
            })
            .filter(|s| s.stiffness < 1.0 && !s.zone.vertices.is_empty())
            .collect();
        let b = &self.bodies[body];
        let Some(geometry) = b.geometry.as_ref().filter(|_| !sides.is_empty()) else {
            return Ok(None);
        };
        let frame = RegionFrame {
            positions: &positions[body],
            normals: &normals[body],
            triangles: &b.triangles,
            contacts: &sides,
            painted: self.params[body].painted.as_deref(),
            direction_field: None,
            free_border: None,
        };
        deform_region(&geometry.region, &frame, &b.deform)
            .map(Some)
            .map_err(|source| PassError::Deform { body, source })
    }

    /// The rest mean edge length of each body (`h_rest` of `MEASURING.md`).
    pub fn rest_edge_lengths(&self, rest: &[Vec<Point3<f64>>]) -> Vec<f64> {
        rest.iter()
            .zip(&self.bodies)
            .map(|(p, b)| mean_edge_length(p, &b.triangles))
            .collect()
    }
}

/// An order on surfaces that does not depend on their index: vertex count, then the bits of
/// the first positions.
fn canonical_key(positions: &[Point3<f64>]) -> (usize, Vec<[u64; 3]>) {
    let head = positions
        .iter()
        .take(16)
        .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
        .collect();
    (positions.len(), head)
}
