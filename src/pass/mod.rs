//! The per-frame contact pass between separate objects (2021 Appendix B): every pair of bodies
//! whose surfaces intersect gets a contact (Algorithm Part 1), then every body with at least
//! one contact is deformed (Part 2). A frame without intersection costs one BVH refit and
//! one overlap query per pair.
//!
//! Each body is one working region (the whole closed surface). Pairs run in parallel, then
//! regions run in parallel; each unit of work is sequential and its output does not depend on
//! the thread count.

use crate::contact::{
    crossing, resolve_crossing, ContactError, ContactSide, DirectionMode, PairOutcome, PairParams,
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

mod output;
mod params;

pub use output::{BodyDiagnostics, ContactSummary, FailedContact, PassOutput, StageTimings};
pub use params::{DirectionTrack, ObjectParams, PairOverride, RestOverlaps, DEFAULT_EXTENT_FACTOR};

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

/// Default number of passes per frame (see [`ContactPass::with_passes`]).
pub const DEFAULT_PASSES: usize = 2;

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
