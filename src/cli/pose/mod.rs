//! `contact-skin pose`: evaluates an animation, runs the contact passes on every frame (the
//! object pass, then the self-contact pass; unless `--no-contact`) and writes the frames (and,
//! with `--diagnostics`, the passes' fields).

use super::contact::{self, median, median_folds, median_stages, ContactRun, FoldMs, SelfRun};
use super::frame_count;
use super::measure::{self, Measured, RunMetrics, Surfaces};
use super::CliResult;
use contact_skin::frames::{self, Frame, Precomputed};
use contact_skin::output::{self, glb, obj, Staged};
use contact_skin::pass::{FailedContact, StageTimings};
use contact_skin::rig::{self, Rig};
use contact_skin::selfcontact::fold::FoldTimings;
use contact_skin::selfcontact::pass::{FailedFold, FoldLayers, UnbalancedCounts};
use contact_skin::skinning::Method;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

mod files;
mod print;

use files::{clear_interrupted_runs, stale_files, write_glb, write_obj_frames, Writes};
use print::print_summary;

/// Output format of `pose`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// One `frame_NNNN.obj` per frame (the comparison contract).
    Obj,
    /// One `<rig>.baked.glb` playing every frame (morph targets + weights animation).
    Glb,
}

/// Skinning method names for the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Skinning {
    /// Linear blend skinning.
    Lbs,
    /// Dual quaternion skinning.
    Dqs,
    /// Center-of-rotation skinning (Le & Hodgins 2016).
    Cor,
}

impl From<Skinning> for Method {
    fn from(s: Skinning) -> Self {
        match s {
            Skinning::Lbs => Method::Lbs,
            Skinning::Dqs => Method::Dqs,
            Skinning::Cor => Method::Cor,
        }
    }
}

/// Arguments of `pose`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The rig (.gltf or .glb).
    rig: PathBuf,
    /// Output folder (created if missing).
    #[arg(long, short)]
    out: PathBuf,
    /// Animation to play, by name or index (default: the first; rest pose if there is none).
    #[arg(long, short)]
    animation: Option<String>,
    /// Number of frames, evenly spaced over the animation, both ends included (at least 1; default: 30 per second).
    #[arg(long, short, value_parser = clap::value_parser!(u64).range(1..))]
    frames: Option<u64>,
    /// Skinning method feeding the contact pass.
    #[arg(long, value_enum, default_value_t = Skinning::Lbs)]
    skinning: Skinning,
    /// Write the plain skinning result, without the contact passes (objects and self-contact).
    #[arg(long, conflicts_with_all = ["config", "passes", "diagnostics", "self_contact"])]
    no_contact: bool,
    /// Leave out the self-contact pass (joints folding into themselves); the contact pass
    /// between objects still runs.
    #[arg(long, conflicts_with = "self_contact")]
    no_self_contact: bool,
    /// Run the self-contact pass (experimental: see the README) even without a
    /// `[self_contact]` table in the configuration.
    #[arg(long)]
    self_contact: bool,
    /// Contact configuration (TOML). Default: `<rig stem>.contact.toml` next to the rig if it
    /// exists, else the default parameters.
    #[arg(long, value_name = "PATH")]
    config: Option<PathBuf>,
    /// Passes per frame of the contact pass between objects (overrides the configuration's
    /// `passes`; default 2, 1 is the paper's). The self-contact pass's sweeps are set by
    /// `[self_contact] passes` in the configuration.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=16))]
    passes: Option<u64>,
    /// Also write `frame_NNNN.diag.json` per frame: per body and file vertex u, zone,
    /// displacement, amplitude, slope, bulge; the contacts and the stage timings.
    #[arg(long)]
    diagnostics: bool,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Obj)]
    format: Format,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    json: bool,
    /// Also measure every frame against its skinned input (MEASURING.md): penetrating
    /// vertices before and after, largest depth, volume error (closed bodies), inverted and
    /// turned faces, non-finite values, and the run's temporal second-difference ratio (the
    /// output's largest second difference over the input's: where the output pops it grows
    /// with the square of
    /// `--frames`, where a vertex enters a contact zone (a kink) in proportion to it, so
    /// compare runs at one frame count) and its displacement-step ratio (the largest change of
    /// the passes' displacement from one frame to the next over the input's fastest vertex's
    /// motion in one frame: it keeps its value over frame counts where the displacement is
    /// continuous, kinks included, and grows in proportion to `--frames` where it pops, so
    /// compare runs at two frame counts); printed and in the JSON summary
    /// (`metrics`). Keeps every frame's welded positions, input and output, in memory (48
    /// bytes per vertex per frame).
    #[arg(long)]
    metrics: bool,
}

#[derive(Serialize)]
struct Summary {
    rig: String,
    animation: Option<String>,
    skinning: String,
    /// Whether the contact pass ran.
    contact: bool,
    /// The contact configuration file used (`None`: defaults, or no contact).
    config: Option<String>,
    /// Contact passes per frame (`None` without contact).
    passes: Option<usize>,
    frames: usize,
    /// Frames where the pass found at least one contact.
    contact_frames: usize,
    /// Pairs of bodies found intersecting with no direction to resolve them along (Eq. 2's
    /// normals cancel out: a symmetric crossing; a `[[pair]] direction` resolves them), left
    /// as they were, summed over the frames (a warning).
    contacts_without_direction: usize,
    /// Contacts between bodies and deformations of bodies that failed (a factorization,
    /// entangled surfaces, …), each leaving what it would have moved as it came in while the
    /// pass went on, summed over the frames (a warning naming the first).
    contacts_failed: usize,
    /// The first of them: `frame N: error`.
    first_contact_failure: Option<String>,
    /// Bodies turned inside out by their pose (a joint scaled by a negative factor), left out
    /// of the passes in that frame, summed over the frames (a warning naming the first).
    bodies_inside_out: usize,
    /// The first of them: `frame N: body 'NAME'`.
    first_inside_out: Option<String>,
    /// Pairs of bodies whose surfaces cross at rest (modeled overlaps, as a robot's pieces at
    /// their hinges), left out of the contact pass (`[[pair]] enabled = true` resolves one).
    pairs_left_out_at_rest: Vec<[String; 2]>,
    vertices: usize,
    files: Vec<String>,
    /// Number of `frame_NNNN.diag.json` written.
    diagnostics: usize,
    /// Poses the baked glb holds (`--format glb`; frames sharing a key time are baked once).
    baked_poses: Option<usize>,
    /// Frame files in the output folder that this run did not write (`frame_NNNN.obj` of an
    /// OBJ run, `frame_NNNN.diag.json`): an earlier run's, left in place (a warning).
    stale_files: Vec<String>,
    precompute_ms: f64,
    total_ms: f64,
    median_frame_ms: f64,
    /// Median per-stage time of the contact pass (ms), over all frames.
    stage_ms: Option<StageTimings>,
    /// Whether the self-contact pass ran.
    self_contact: bool,
    /// Why it did not although asked for (it cannot be built on this rig; a warning).
    self_contact_skipped: Option<String>,
    /// Joint pairs of the self-contact pass (`body/parent-child`), in the order they run.
    self_contact_pairs: Vec<String>,
    /// Parent/child pairs the pass left out, one reason each (e.g. no partition of unity).
    self_contact_pairs_skipped: Vec<String>,
    /// Joint pairs of the pass left as they come in every frame: their two sides cross at
    /// rest (modeled overlaps), or the configuration disables them.
    self_contact_pairs_left_out: Vec<LeftOutFold>,
    /// Joint pairs run without separate pieces of their mesh sunk into them or lying inside a
    /// larger piece at rest (a belt, a collar, teeth: those follow the skinning), with the
    /// pieces.
    self_contact_layers: Vec<FoldLayers>,
    /// Frames where the self-contact pass resolved at least one fold.
    fold_frames: usize,
    /// The pairs found folding into contact in some frame, in the pass's order.
    folds: Vec<String>,
    /// Joint pairs skipped for want of a direction (bones folded 180°, no common relative
    /// motion where the parts meet, or separated regions whose normals cancel out in Eq. 2),
    /// summed over the frames.
    folds_without_direction: usize,
    /// Folds left unresolved because no bulge could keep the volume without a spike or a face
    /// turned over, summed over the frames.
    folds_unbalanced: usize,
    /// The same by reason: no exact root of the volume cubic (no band for a bulge, or inward
    /// displacement directions), a bulge steeper than its band allows, every balanced blend
    /// turning a face over.
    folds_unbalanced_by_reason: UnbalancedCounts,
    /// Folds that failed (a factorization, the intersection, …) and were left as they were
    /// while the pass went on, summed over the frames (a warning naming the first).
    folds_failed: usize,
    /// The first fold that failed: `frame N: fold NAME: error`.
    first_fold_failure: Option<String>,
    /// Vertices whose displacement the turn guard scaled back so that no face turns over,
    /// summed over the folds and frames.
    vertices_guarded: usize,
    /// Vertices whose bulge the bulge guard scaled back so that it does not enter the other
    /// part of the fold, summed over the folds and frames.
    bulges_guarded: usize,
    /// The crossing face pairs the folds' crease cuts should separate, summed over the folds
    /// and frames (separated regions have no cut and count none).
    crease_pairs: usize,
    /// Of those, the pairs a cut left with both faces on one side (`PIPELINE.md`'s check of
    /// the cut: every crossing pair straddles it); such an intersection lies within one
    /// truncated part, which the fold does not resolve.
    crease_pairs_unseparated: usize,
    /// The most sweeps over the folds a frame took (`[self_contact] passes`, and more up to
    /// `max_passes` while a fold's shared region still penetrates); 0 without the pass.
    sweeps_max: usize,
    /// The sweeps every frame gets (`[self_contact] passes`); 0 without the pass.
    sweeps_planned: usize,
    /// Median time of the self-contact pass per frame (ms), over all frames.
    self_contact_ms: Option<f64>,
    /// Median fold step times (ms) over the frames with a fold (each step summed over the
    /// frame's folds; `wall`: the whole self-contact pass).
    fold_ms: Option<FoldMs>,
    /// `--metrics`: every frame measured against its skinned input, and the run's worst.
    metrics: Option<RunMetrics>,
}

/// Resolves `--animation` against the rig.
pub fn pick_animation(rig: &Rig, key: Option<&str>) -> Result<Option<usize>, String> {
    match key {
        Some(k) => rig.find_animation(k).map(Some).ok_or_else(|| {
            format!(
                "no animation '{k}' in {} ({} animations)",
                rig.source.display(),
                rig.animations.len()
            )
        }),
        None => Ok((!rig.animations.is_empty()).then_some(0)),
    }
}

/// Refuses to write over the input file.
fn guard_input(input: &Path, output: &Path) -> Result<(), String> {
    let same = match (input.canonicalize(), output.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if same {
        Err(format!(
            "refusing to overwrite the input {}",
            input.display()
        ))
    } else {
        Ok(())
    }
}

fn progress(len: usize, json: bool) -> ProgressBar {
    if json {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len as u64);
    if let Ok(style) =
        ProgressStyle::with_template("{spinner} {msg} [{bar:30}] {pos}/{len} frames ({eta})")
    {
        pb.set_style(style.progress_chars("=> "));
    }
    pb
}

/// Everything a frame needs, shared by all frames of a run.
struct Job<'a> {
    args: &'a Args,
    rig: &'a Rig,
    pre: &'a Precomputed,
    contact: Option<&'a ContactRun>,
    animation: Option<usize>,
    header: String,
    /// The OBJ frames' objects and faces, the same in every frame.
    faces: obj::ObjFaces,
    pb: ProgressBar,
    /// `--metrics`: the rest mean edge length `h`, the measures' length unit.
    h: Option<f64>,
    /// `--metrics`: the surfaces measured (without the layers the folds run without).
    surfaces: Option<Surfaces>,
    /// The run's file writes, stopped by an interrupt.
    writes: Arc<Writes>,
}

/// What is kept of a frame once written.
struct FrameStats {
    ms: f64,
    contacts: usize,
    contacts_without_direction: usize,
    contacts_failed: Vec<FailedContact>,
    /// Bodies turned inside out, left out of the passes.
    inside_out: Vec<usize>,
    timings: Option<StageTimings>,
    diagnostics: bool,
    /// Names of the folds resolved.
    folds: Vec<String>,
    /// Summed fold timings and the self-contact pass's wall time (s), when it ran.
    fold_timings: Option<(FoldTimings, f64)>,
    folds_without_direction: usize,
    folds_unbalanced: UnbalancedCounts,
    folds_failed: Vec<FailedFold>,
    vertices_guarded: usize,
    bulges_guarded: usize,
    /// Crossing face pairs of the folds' cuts, and those a cut left on one side.
    crease_pairs: [usize; 2],
    sweeps: usize,
    /// `--metrics`: the frame measured, with its positions.
    measured: Option<Measured>,
}

/// Runs `pose`.
pub fn run(a: &Args) -> CliResult {
    let start = Instant::now();
    let rig = rig::load(&a.rig)?;
    for w in &rig.warnings {
        eprintln!("warning: {w}");
    }
    if rig.bodies.is_empty() {
        return Err(format!("{}: no skinned mesh to pose", a.rig.display()).into());
    }
    let animation = pick_animation(&rig, a.animation.as_deref())?;
    let times = frames::sample_times(&rig, animation, a.frames.map(frame_count))?;
    let method = Method::from(a.skinning);
    let t_pre = Instant::now();
    let pre = Precomputed::new(&rig, method);
    for w in pre.warnings(&rig) {
        eprintln!("warning: {w}");
    }
    let contact = if a.no_contact {
        None
    } else {
        let passes = a.passes.map(|p| p as usize);
        Some(ContactRun::new(
            &a.rig,
            &rig,
            &pre,
            a.config.as_deref(),
            passes,
            if a.no_self_contact {
                Some(false)
            } else if a.self_contact {
                Some(true)
            } else {
                None
            },
        )?)
    };
    let precompute_ms = t_pre.elapsed().as_secs_f64() * 1e3;
    if let Some(why) = contact
        .as_ref()
        .and_then(|c| c.self_contact_skipped.as_ref())
    {
        eprintln!(
            "warning: {}: self-contact pass off: {why} (with a [self_contact] table in the \
             configuration this is an error; --no-self-contact leaves the pass out)",
            a.rig.display()
        );
    }
    super::create_folder(&a.out)?;
    clear_interrupted_runs(a);
    let surfaces = a.metrics.then(|| {
        let self_run = contact.as_ref().and_then(|c| c.self_contact.as_ref());
        let layers = self_run.map_or(Vec::new(), |s| s.pass.triangles_without_layers());
        Surfaces::new(&pre, layers)
    });
    let job = Job {
        args: a,
        rig: &rig,
        pre: &pre,
        contact: contact.as_ref(),
        animation,
        header: header(a, &rig, animation, method, contact.as_ref()),
        faces: obj::ObjFaces::of(&rig),
        pb: progress(times.len(), a.json),
        h: surfaces.as_ref().map(|s| s.rest_edge_length(&rig, &pre)),
        surfaces,
        writes: Writes::stopped_on_interrupt(&a.out),
    };
    job.pb.set_message(format!("posing {}", a.rig.display()));
    let (files, mut stats) = match a.format {
        Format::Obj => write_obj_frames(&job, &times)?,
        Format::Glb => write_glb(&job, &times)?,
    };
    job.pb.finish_and_clear();
    let metrics = job.h.map(|h| take_metrics(h, &mut stats));
    let mut summary = summarize(&job, method, &times, files, &stats, precompute_ms, start);
    summary.metrics = metrics;
    print_summary(&summary, a)
}

/// The run's measures, taken out of the frames' statistics (in frame order).
fn take_metrics(h: f64, stats: &mut [FrameStats]) -> RunMetrics {
    let measured = stats.iter_mut().filter_map(|s| s.measured.take()).collect();
    measure::run_metrics(h, measured)
}

fn header(
    a: &Args,
    rig: &Rig,
    animation: Option<usize>,
    method: Method,
    contact: Option<&ContactRun>,
) -> String {
    let contact = match contact {
        None => "contact off".to_string(),
        Some(c) => format!(
            "contact on (passes {}, config {}), self-contact {}",
            c.passes,
            c.config
                .as_ref()
                .map_or("none".into(), |p| p.display().to_string()),
            if c.self_contact.is_some() {
                "on"
            } else {
                "off"
            }
        ),
    };
    // The animation by name, by index when it has none, `none` for the rest pose (until
    // 2026-12-05 Rust's debug text: `Some("flex")`, `None`).
    let animation = match animation {
        Some(i) => match &rig.animations[i].name {
            Some(name) => format!("{name:?}"),
            None => i.to_string(),
        },
        None => "none".to_owned(),
    };
    format!(
        "rig {} animation {animation} skinning {} {contact}",
        a.rig.display(),
        method
    )
}

fn summarize(
    job: &Job,
    method: Method,
    times: &[f64],
    files: Vec<PathBuf>,
    stats: &[FrameStats],
    precompute_ms: f64,
    start: Instant,
) -> Summary {
    let (rig, animation) = (job.rig, job.animation);
    let timings: Vec<StageTimings> = stats.iter().filter_map(|s| s.timings).collect();
    let self_run = job.contact.and_then(|c| c.self_contact.as_ref());
    let pairs: Vec<String> = self_run.map_or(Vec::new(), |s| {
        s.pairs.iter().map(|(_, n)| n.clone()).collect()
    });
    let folds: Vec<String> = pairs
        .iter()
        .filter(|p| stats.iter().any(|s| s.folds.contains(p)))
        .cloned()
        .collect();
    let with_fold: Vec<(FoldTimings, f64)> = stats
        .iter()
        .filter(|s| !s.folds.is_empty())
        .filter_map(|s| s.fold_timings)
        .collect();
    let self_walls: Vec<f64> = stats
        .iter()
        .filter_map(|s| s.fold_timings.map(|t| t.1 * 1e3))
        .collect();
    Summary {
        rig: job.args.rig.display().to_string(),
        animation: animation.map(|i| {
            rig.animations[i]
                .name
                .clone()
                .unwrap_or_else(|| i.to_string())
        }),
        skinning: method.to_string(),
        contact: job.contact.is_some(),
        config: job
            .contact
            .and_then(|c| c.config.as_ref())
            .map(|p| p.display().to_string()),
        passes: job.contact.map(|c| c.passes),
        frames: times.len(),
        contact_frames: stats.iter().filter(|s| s.contacts > 0).count(),
        contacts_without_direction: stats.iter().map(|s| s.contacts_without_direction).sum(),
        contacts_failed: stats.iter().map(|s| s.contacts_failed.len()).sum(),
        first_contact_failure: first_failure(stats, |s| {
            s.contacts_failed.first().map(|f| f.error.clone())
        }),
        bodies_inside_out: stats.iter().map(|s| s.inside_out.len()).sum(),
        first_inside_out: first_failure(stats, |s| {
            let b = *s.inside_out.first()?;
            Some(format!("body '{}'", rig.bodies[b].name))
        }),
        pairs_left_out_at_rest: job.contact.map_or(Vec::new(), |c| {
            let name = |b: usize| rig.bodies[b].name.clone();
            let left_out = c.pass.left_out_at_rest();
            left_out.into_iter().map(|p| p.map(name)).collect()
        }),
        vertices: rig.vertex_count(),
        files: files.iter().map(|p| p.display().to_string()).collect(),
        diagnostics: stats.iter().filter(|s| s.diagnostics).count(),
        stale_files: stale_files(job.args, times.len()),
        baked_poses: matches!(job.args.format, Format::Glb).then(|| glb::key_times(times).len()),
        precompute_ms,
        total_ms: start.elapsed().as_secs_f64() * 1e3,
        median_frame_ms: median(stats.iter().map(|s| s.ms).collect()),
        stage_ms: job.contact.map(|_| median_stages(&timings)),
        self_contact: self_run.is_some(),
        self_contact_skipped: job.contact.and_then(|c| c.self_contact_skipped.clone()),
        self_contact_pairs: pairs,
        self_contact_pairs_skipped: self_run.map_or(Vec::new(), |s| s.pass.skipped().to_vec()),
        self_contact_pairs_left_out: self_run.map_or(Vec::new(), left_out_folds),
        self_contact_layers: self_run.map_or(Vec::new(), |s| s.pass.layers()),
        fold_frames: stats.iter().filter(|s| !s.folds.is_empty()).count(),
        folds,
        folds_without_direction: stats.iter().map(|s| s.folds_without_direction).sum(),
        folds_unbalanced: stats.iter().map(|s| s.folds_unbalanced.total()).sum(),
        folds_unbalanced_by_reason: stats.iter().map(|s| s.folds_unbalanced).sum(),
        folds_failed: stats.iter().map(|s| s.folds_failed.len()).sum(),
        first_fold_failure: first_failure(stats, |s| {
            let f = s.folds_failed.first()?;
            Some(format!("fold {}: {}", f.name, f.error))
        }),
        vertices_guarded: stats.iter().map(|s| s.vertices_guarded).sum(),
        bulges_guarded: stats.iter().map(|s| s.bulges_guarded).sum(),
        crease_pairs: stats.iter().map(|s| s.crease_pairs[0]).sum(),
        crease_pairs_unseparated: stats.iter().map(|s| s.crease_pairs[1]).sum(),
        sweeps_max: stats.iter().map(|s| s.sweeps).max().unwrap_or(0),
        sweeps_planned: self_run.map_or(0, |s| s.pass.passes()),
        self_contact_ms: self_run.map(|_| median(self_walls)),
        fold_ms: self_run.map(|_| median_folds(&with_fold)),
        metrics: None,
    }
}

/// `frame N: what` of the first frame where `what` says something failed.
fn first_failure(
    stats: &[FrameStats],
    what: impl Fn(&FrameStats) -> Option<String>,
) -> Option<String> {
    stats
        .iter()
        .enumerate()
        .find_map(|(i, s)| Some(format!("frame {i}: {}", what(s)?)))
}

/// A joint pair the self-contact pass leaves as it comes in every frame
/// ([`contact_skin::selfcontact::pass::SelfContactPass::left_out`]).
#[derive(Debug, Serialize)]
struct LeftOutFold {
    name: String,
    /// Face pairs of its two sides crossing at rest, when they do.
    crossing_at_rest: Option<usize>,
    /// Why its detection failed at rest (every frame's would fail alike), when it did.
    failure_at_rest: Option<String>,
    /// `[[self_contact.pair]] enabled = false`.
    disabled: bool,
}

/// The pairs `run` leaves out in every frame, with why.
fn left_out_folds(run: &SelfRun) -> Vec<LeftOutFold> {
    (run.pass.left_out().into_iter())
        .map(|f| LeftOutFold {
            crossing_at_rest: f.at_rest.as_ref().and_then(|c| c.crossing_face_pairs()),
            failure_at_rest: f.at_rest.and_then(|c| c.failure),
            disabled: f.disabled,
            name: f.name,
        })
        .collect()
}

/// One frame posed: the frame, its statistics and its diagnostics file staged (if asked).
type Computed = (Frame, FrameStats, Option<Staged>);

/// Poses frame `i` (with the contact pass when on), checks that it can be written and stages
/// its diagnostics if asked (committed with the rest of the run).
fn compute(job: &Job, i: usize, t: f64) -> Result<Computed, String> {
    let (frame, stats, diagnostics) = compute_unchecked(job, i, t)?;
    output::check_representable(&frame).map_err(|e| format!("frame {i} (t = {t}): {e}"))?;
    let staged = match diagnostics {
        Some(bytes) => {
            let path = job.args.out.join(contact::diagnostics_file_name(i));
            Some(job.writes.stage(&path, &bytes)?)
        }
        None => None,
    };
    Ok((frame, stats, staged))
}

/// `--metrics`: frame `i` measured against its skinned `input` (`output`: the passes' welded
/// positions; `None`: the input itself, no pass ran).
fn measured(
    job: &Job,
    i: usize,
    input: &Frame,
    output: Option<&[Vec<nalgebra::Point3<f64>>]>,
) -> Option<Measured> {
    let h = job.h?;
    let welded = input.welded(job.pre);
    let normals = input.welded_normals(job.pre);
    let output = output.unwrap_or(&welded);
    let surfaces = job.surfaces.as_ref()?;
    Some(Measured::new(surfaces, h, i, &welded, &normals, output))
}

/// [`compute`] before the check that its positions can be written: the frame, its
/// statistics and its diagnostics' bytes (if asked).
fn compute_unchecked(
    job: &Job,
    i: usize,
    t: f64,
) -> Result<(Frame, FrameStats, Option<Vec<u8>>), String> {
    let t0 = Instant::now();
    let Some(c) = job.contact else {
        let frame = frames::evaluate(job.rig, job.pre, job.animation, i, t);
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let stats = FrameStats {
            ms,
            contacts: 0,
            contacts_without_direction: 0,
            contacts_failed: Vec::new(),
            inside_out: Vec::new(),
            timings: None,
            diagnostics: false,
            folds: Vec::new(),
            fold_timings: None,
            folds_without_direction: 0,
            folds_unbalanced: UnbalancedCounts::default(),
            folds_failed: Vec::new(),
            vertices_guarded: 0,
            bulges_guarded: 0,
            crease_pairs: [0, 0],
            sweeps: 0,
            measured: measured(job, i, &frame, None),
        };
        return Ok((frame, stats, None));
    };
    let cf = contact::run_frame(job.rig, job.pre, c, job.animation, i, t)?;
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    let diagnostics = if job.args.diagnostics {
        let d = contact::diagnostics(job.rig, job.pre, &cf);
        Some(serde_json::to_vec(&d).map_err(|e| format!("frame {i} diagnostics: {e}"))?)
    } else {
        None
    };
    let so = cf.self_output.as_ref();
    let stats = FrameStats {
        ms,
        contacts: cf.output.contacts.len(),
        contacts_without_direction: cf.output.pairs_without_direction,
        contacts_failed: cf.output.failed.clone(),
        inside_out: cf.inside_out(),
        timings: Some(cf.output.timings),
        diagnostics: job.args.diagnostics,
        folds: so.map_or(Vec::new(), |s| {
            s.folds.iter().map(|f| f.name.clone()).collect()
        }),
        fold_timings: so.map(|s| (s.timings, cf.self_wall)),
        folds_without_direction: so.map_or(0, |s| s.no_direction),
        folds_unbalanced: so.map_or(UnbalancedCounts::default(), |s| s.unbalanced),
        folds_failed: so.map_or(Vec::new(), |s| s.failed.clone()),
        vertices_guarded: so.map_or(0, |s| s.guarded),
        bulges_guarded: so.map_or(0, |s| s.bulge_guarded),
        crease_pairs: so.map_or([0, 0], |s| {
            s.folds.iter().fold([0, 0], |[c, u], f| {
                [c + f.output.crossing, u + f.output.unseparated]
            })
        }),
        sweeps: so.map_or(0, |s| s.sweeps),
        measured: measured(job, i, &cf.input, Some(&cf.positions)),
    };
    Ok((cf.frame, stats, diagnostics))
}
