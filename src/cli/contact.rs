//! The contact passes as the command line runs them: configuration discovery, the one
//! [`ContactPass`] (objects) and [`SelfContactPass`] (joints folding into themselves) of a
//! run, per-frame evaluation (skinning → welded → object pass → self-contact pass → file
//! vertices), the `frame_NNNN.diag.json` diagnostics and median stage timings
//! (computed by [`contact_skin::report::timings`]).

use contact_skin::config::{ContactConfig, SelfContactSettings};
use contact_skin::frames::{self, Frame, Precomputed};
use contact_skin::pass::{
    rest_bodies, BodyDiagnostics as PassBodyDiagnostics, ContactPass, ContactSummary, PassOutput,
    RestOverlaps, StageTimings,
};
pub use contact_skin::report::timings::{median, median_folds, median_stages, FoldMs};
use contact_skin::rig::Rig;
use contact_skin::selfcontact::fold::{FoldTimings, Unbalanced};
use contact_skin::selfcontact::pass::{SelfContactPass, SelfPassOutput, UnbalancedCounts};
use nalgebra::Point3;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Boxed error of the command line.
pub type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// The contact passes of one run, shared by every frame.
pub struct ContactRun {
    /// The precomputed object-vs-object pass.
    pub pass: ContactPass,
    /// The configuration file used, if any.
    pub config: Option<PathBuf>,
    /// Passes per frame.
    pub passes: usize,
    /// The self-contact pass (`None`: off, by `--no-self-contact`, `[self_contact] enabled
    /// = false`, or because it could not be built, see `self_contact_skipped`).
    pub self_contact: Option<SelfRun>,
    /// Why the self-contact pass is off although asked for: it could not be built on this rig
    /// (e.g. a joint pair with a degenerate shared region) and the configuration has no
    /// `[self_contact]` table (with one, that is an error).
    pub self_contact_skipped: Option<String>,
}

/// The self-contact pass of one run.
pub struct SelfRun {
    /// The precomputed pass (regions, partition of unity, per-pair analyses).
    pub pass: SelfContactPass,
    /// The settings it was built with.
    pub settings: SelfContactSettings,
    /// Its joint pairs, `(body, name)`, in the order they are resolved.
    pub pairs: Vec<(usize, String)>,
}

impl ContactRun {
    /// Finds the configuration (`config`, else `<rig stem>.contact.toml` next to the rig, else
    /// defaults), resolves it against `rig` and precomputes the passes on the rest pose.
    /// `passes` overrides the configuration's; `self_contact`: `Some(true)` runs the
    /// self-contact pass, `Some(false)` leaves it out, `None` follows the configuration (on
    /// when it has a `[self_contact]` table not disabled: the pass is still experimental,
    /// see the README).
    pub fn new(
        rig_path: &Path,
        rig: &Rig,
        pre: &Precomputed,
        config: Option<&Path>,
        passes: Option<usize>,
        self_contact: Option<bool>,
    ) -> Result<Self, BoxError> {
        let found = ContactConfig::for_rig(rig_path, config)?;
        let used = found.as_ref().map(|c| c.file.clone());
        let cfg = found.unwrap_or_default();
        let (params, overrides, file_passes) = cfg.resolve(rig, &pre.welded)?;
        let rest = frames::welded_positions(rig, pre, None, 0.0);
        let bodies = rest_bodies(&rest, &pre.welded);
        let passes = passes.unwrap_or(file_passes).max(1);
        let pass = ContactPass::new(&bodies, params, overrides)
            .map_err(|e| {
                format!(
                    "{}: contact pass: {e} (--no-contact writes plain skinning)",
                    rig_path.display()
                )
            })?
            .with_passes(passes)
            .with_rest_overlaps(RestOverlaps::LeftOut);
        let wanted = self_contact.unwrap_or_else(|| cfg.self_contact_enabled());
        let (self_contact, self_contact_skipped) = if wanted {
            match SelfRun::new(rig, pre, &cfg, &rest) {
                Ok(s) => (Some(s), None),
                Err(e) if cfg.self_contact.is_none() => (None, Some(e.to_string())),
                Err(e) => {
                    return Err(format!(
                        "{}: self-contact pass: {e} (--no-self-contact leaves it out)",
                        rig_path.display()
                    )
                    .into())
                }
            }
        } else {
            (None, None)
        };
        Ok(Self {
            pass,
            config: used,
            passes,
            self_contact,
            self_contact_skipped,
        })
    }
}

impl SelfRun {
    /// Resolves `[self_contact]` and precomputes the pass on `rest` (welded rest positions).
    fn new(
        rig: &Rig,
        pre: &Precomputed,
        cfg: &ContactConfig,
        rest: &[Vec<Point3<f64>>],
    ) -> Result<Self, BoxError> {
        let settings = cfg.resolve_self_contact(rig, &pre.welded)?;
        let pass = settings.pass(rig, &pre.welded, rest)?;
        let pairs = pass.pairs();
        Ok(Self {
            pass,
            settings,
            pairs,
        })
    }
}

/// One frame through the contact passes.
pub struct ContactFrame {
    /// The frame with the passes' positions on every file vertex.
    pub frame: Frame,
    /// The skinned positions (file vertices), before the passes.
    pub input: Frame,
    /// The object pass's output (welded vertices).
    pub output: PassOutput,
    /// The self-contact pass's output (`None` when it is off).
    pub self_output: Option<SelfPassOutput>,
    /// Wall time of the self-contact pass (s; 0 when it is off).
    pub self_wall: f64,
    /// Final welded positions per body: the object pass's output, then the self-contact
    /// pass's.
    pub positions: Vec<Vec<Point3<f64>>>,
}

impl ContactFrame {
    /// Folds resolved in this frame.
    pub fn fold_count(&self) -> usize {
        self.self_output.as_ref().map_or(0, |s| s.folds.len())
    }

    /// The bodies this frame turned inside out that a pass left out (the object pass's, then
    /// the self-contact pass's), each once, ascending.
    pub fn inside_out(&self) -> Vec<usize> {
        let folds = self.self_output.as_ref().map(|s| s.inside_out.as_slice());
        let mut bodies: Vec<usize> = (self.output.inside_out.iter())
            .chain(folds.unwrap_or_default())
            .copied()
            .collect();
        bodies.sort_unstable();
        bodies.dedup();
        bodies
    }
}

/// Skins frame `index` at time `t` and runs the passes on it: the object pass, then the
/// self-contact pass (when on) on its result. Every file copy of a welded vertex the passes
/// moved gets their position; the others keep their skinned position, so a frame without
/// contact is exactly the skinning result.
pub fn run_frame(
    rig: &Rig,
    pre: &Precomputed,
    run: &ContactRun,
    animation: Option<usize>,
    index: usize,
    t: f64,
) -> Result<ContactFrame, String> {
    // One pose for the skinning and the self-contact pass's skeleton directions.
    let pose = rig.pose_at(animation, t);
    let input = frames::evaluate_pose(rig, pre, &pose, index, t);
    let before = input.welded(pre);
    let output = run
        .pass
        .run_at(&before, t)
        .map_err(|e| format!("frame {index} (t = {t}): contact pass: {e}"))?;
    let mut positions = output.positions.clone();
    let (mut self_output, mut self_wall) = (None, 0.0);
    if let Some(s) = &run.self_contact {
        let clock = Instant::now();
        let normals = input.welded_normals(pre);
        let out = s
            .pass
            .run_with_normals(rig, &pose, &mut positions, &normals)
            .map_err(|e| format!("frame {index} (t = {t}): self-contact pass: {e}"))?;
        self_wall = clock.elapsed().as_secs_f64();
        self_output = Some(out);
    }
    let mut frame = input.clone();
    for (b, body) in frame.bodies.iter_mut().enumerate() {
        let w = &pre.welded[b];
        let (old, new) = (&before[b], &positions[b]);
        for (f, p) in body.positions.iter_mut().enumerate() {
            let v = w.to_welded[f] as usize;
            if new[v] != old[v] {
                *p = new[v];
            }
        }
    }
    Ok(ContactFrame {
        frame,
        input,
        output,
        self_output,
        self_wall,
        positions,
    })
}

// ---------------------------------------------------------------------------------------------
// Diagnostics

/// `frame_NNNN.diag.json`.
#[derive(Serialize)]
pub struct FrameDiagnostics {
    /// Frame index.
    pub frame: usize,
    /// Animation time (s).
    pub time: f64,
    /// Per body, per file vertex.
    pub bodies: Vec<BodyDiagnostics>,
    /// Contacts of the first pass.
    pub contacts: Vec<ContactDiagnostics>,
    /// Contacts resolved by later passes.
    pub later_contacts: usize,
    /// Pairs of bodies intersecting with no direction (Eq. 2's normals cancel out), left as
    /// they were ([`contact_skin::pass::PassOutput::pairs_without_direction`]).
    pub contacts_without_direction: usize,
    /// Contacts and deformations that failed and were left as they came in, with what failed
    /// ([`contact_skin::pass::PassOutput::failed`]).
    pub contacts_failed: Vec<contact_skin::pass::FailedContact>,
    /// Bodies the frame turned inside out, left out of the passes
    /// ([`contact_skin::pass::PassOutput::inside_out`]).
    pub inside_out: Vec<usize>,
    /// Stage timings in seconds.
    pub timings_s: StageTimings,
    /// Folds resolved by the self-contact pass, in the order they ran (empty when it is off).
    pub folds: Vec<FoldDiagnostics>,
    /// Joint pairs skipped by the self-contact pass for want of a direction (bones folded 180°,
    /// no common relative motion where the parts meet, or separated regions crossing
    /// symmetrically).
    pub folds_without_direction: usize,
    /// Folds left unresolved because no bulge could keep the volume without a spike or a face
    /// turned over.
    pub folds_unbalanced: usize,
    /// The same by reason.
    pub folds_unbalanced_by_reason: UnbalancedCounts,
    /// Folds that failed and were left as they were, with what failed.
    pub folds_failed: Vec<contact_skin::selfcontact::pass::FailedFold>,
    /// Wall time of the self-contact pass (s; 0 when it is off).
    pub self_contact_s: f64,
}

/// One fold (a joint pair of one body in self-contact) in one frame.
#[derive(Serialize)]
pub struct FoldDiagnostics {
    /// Body index.
    pub body: usize,
    /// Pair name (`body/parent-child`).
    pub name: String,
    /// Sweep over the folds (0 first; `[self_contact] passes`).
    pub sweep: usize,
    /// `d̂_12` used: W1's (the parent side's) outward direction.
    pub direction: [f64; 3],
    /// Welded vertices in the contact zone of each side (W1's first).
    pub zone_sizes: [usize; 2],
    /// `ε_c` of the fold's contact.
    pub threshold: f64,
    /// Value of the crease min-cut.
    pub crease_cut: f64,
    /// Vertices of the shared region that switched side in the crease cut.
    pub crease_stray: usize,
    /// Crossing face pairs left on one side of the crease cut (`PIPELINE.md`: every one
    /// should straddle it; `FoldOutput::unseparated`).
    pub crease_unseparated: usize,
    /// The crossing face pairs the cut should separate (`FoldOutput::crossing`).
    pub crease_pairs: usize,
    /// The common bulge height (0 on an open mesh).
    pub bulge_height: f64,
    /// The largest bulge displacement over its band's width (`FoldOutput::bulge_steepness`;
    /// `null` for a bulge on a zero-width band).
    pub bulge_steepness: f64,
    /// Left unresolved: no bulge could keep the volume without a spike or a face turned over
    /// (the output is the fold's input).
    pub unbalanced: bool,
    /// Why (`null` when resolved): `"no_volume_root"`, `"steep_bulge"` or `"turned_face"`.
    pub unbalanced_reason: Option<Unbalanced>,
    /// Vertices whose displacement the turn guard scaled back (`FoldOutput::guarded`).
    pub guarded: usize,
    /// Vertices whose bulge the bulge guard scaled back (`FoldOutput::bulge_guarded`).
    pub bulge_guarded: usize,
    /// Step timings of the fold in seconds.
    pub timings_s: FoldTimings,
}

/// Diagnostics of one body, one entry per file vertex (scattered from welded vertices).
#[derive(Serialize)]
pub struct BodyDiagnostics {
    /// Body index.
    pub index: usize,
    /// Body name.
    pub name: String,
    /// File vertices.
    pub vertices: usize,
    /// The body was deformed.
    pub deformed: bool,
    /// `u` (1 where undeformed).
    pub u: Vec<f64>,
    /// 1 in a contact zone, else 0.
    pub zone: Vec<u8>,
    /// Output − input position.
    pub displacement: Vec<[f64; 3]>,
    /// Amplitude field `a`.
    pub amplitude: Vec<f64>,
    /// Slope field `s`.
    pub slope: Vec<f64>,
    /// Bulge part of the displacement at `γ = 1`.
    pub bulge: Vec<[f64; 3]>,
}

/// One contact between two bodies.
#[derive(Serialize)]
pub struct ContactDiagnostics {
    /// The two bodies (the first is side A).
    pub bodies: [usize; 2],
    /// Their names.
    pub names: [String; 2],
    /// `ε_c` (Eq. 4).
    pub threshold: f64,
    /// `m_S`.
    pub mean_depth: f64,
    /// `σ_S`.
    pub depth_deviation: f64,
    /// Welded vertices in each side's contact zone.
    pub zone_sizes: [usize; 2],
    /// Mapping direction of the first body (outward for it).
    pub direction: [f64; 3],
}

/// The diagnostics of a frame, per file vertex.
pub fn diagnostics(rig: &Rig, pre: &Precomputed, c: &ContactFrame) -> FrameDiagnostics {
    let so = c.self_output.as_ref();
    FrameDiagnostics {
        frame: c.frame.index,
        time: c.frame.time,
        bodies: (0..rig.bodies.len())
            .map(|b| body_diagnostics(rig, pre, c, b))
            .collect(),
        contacts: c
            .output
            .contacts
            .iter()
            .map(|s| contact_diagnostics(rig, s))
            .collect(),
        later_contacts: c.output.later_contacts,
        contacts_without_direction: c.output.pairs_without_direction,
        contacts_failed: c.output.failed.clone(),
        inside_out: c.inside_out(),
        timings_s: c.output.timings,
        folds: so.map_or(Vec::new(), fold_diagnostics),
        folds_without_direction: so.map_or(0, |s| s.no_direction),
        folds_unbalanced: so.map_or(0, |s| s.unbalanced.total()),
        folds_unbalanced_by_reason: so.map_or(UnbalancedCounts::default(), |s| s.unbalanced),
        folds_failed: so.map_or(Vec::new(), |s| s.failed.clone()),
        self_contact_s: c.self_wall,
    }
}

/// Body `b`'s fields of the contact pass and its displacement over both passes, per file
/// vertex.
fn body_diagnostics(rig: &Rig, pre: &Precomputed, c: &ContactFrame, b: usize) -> BodyDiagnostics {
    let w = &pre.welded[b];
    let d = c.output.diagnostics_of(b).unwrap_or_else(|| {
        std::borrow::Cow::Owned(PassBodyDiagnostics::unchanged(w.representative.len()))
    });
    let v3 = |v: &nalgebra::Vector3<f64>| [v.x, v.y, v.z];
    BodyDiagnostics {
        index: b,
        name: rig.bodies[b].name.clone(),
        vertices: rig.bodies[b].vertex_count(),
        deformed: d.stats.is_some(),
        u: w.scatter(&d.u),
        zone: w.scatter(&d.zone).into_iter().map(u8::from).collect(),
        displacement: c.frame.bodies[b]
            .positions
            .iter()
            .zip(&c.input.bodies[b].positions)
            .map(|(o, i)| v3(&(o - i)))
            .collect(),
        amplitude: w.scatter(&d.amplitude),
        slope: w.scatter(&d.slope),
        bulge: w.scatter(&d.bulge).iter().map(v3).collect(),
    }
}

/// One contact between bodies.
fn contact_diagnostics(rig: &Rig, s: &ContactSummary) -> ContactDiagnostics {
    let k = &s.contact;
    let d = k.sides[0].direction;
    ContactDiagnostics {
        bodies: s.bodies,
        names: s.bodies.map(|b| rig.bodies[b].name.clone()),
        threshold: k.threshold,
        mean_depth: k.mean_depth,
        depth_deviation: k.depth_deviation,
        zone_sizes: k.sides.each_ref().map(|side| side.zone.vertices.len()),
        direction: [d.x, d.y, d.z],
    }
}

/// The folds of the self-contact pass, in the order they ran, each with its sweep (how many
/// times the same fold ran before it this frame).
fn fold_diagnostics(s: &SelfPassOutput) -> Vec<FoldDiagnostics> {
    s.folds
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let o = &f.output;
            let sweep = s.folds[..k]
                .iter()
                .filter(|g| g.body == f.body && g.name == f.name)
                .count();
            FoldDiagnostics {
                body: f.body,
                name: f.name.clone(),
                sweep,
                direction: [f.direction.x, f.direction.y, f.direction.z],
                zone_sizes: o
                    .contact
                    .sides
                    .each_ref()
                    .map(|side| side.zone.vertices.len()),
                threshold: o.contact.threshold,
                crease_cut: o.crease.value,
                crease_stray: o.crease.stray,
                crease_unseparated: o.unseparated,
                crease_pairs: o.crossing,
                bulge_height: o.bulge_height,
                bulge_steepness: o.bulge_steepness,
                unbalanced: o.unbalanced.is_some(),
                unbalanced_reason: o.unbalanced,
                guarded: o.guarded,
                bulge_guarded: o.bulge_guarded,
                timings_s: o.timings,
            }
        })
        .collect()
}

/// The diagnostics file name of frame `index`: `frame_NNNN.diag.json`.
pub fn diagnostics_file_name(index: usize) -> String {
    format!("frame_{index:04}.diag.json")
}
