//! `contact-skin pose`: evaluates an animation, runs the contact passes on every frame (the
//! object pass, then the self-contact pass; unless `--no-contact`) and writes the frames (and,
//! with `--diagnostics`, the passes' fields).

use super::contact::{
    self, median, median_folds, median_stages, BoxError, ContactRun, FoldMs, SelfRun,
};
use super::frame_count;
use super::measure::{self, Measured, RunMetrics, Surfaces};
use super::CliResult;
use contact_skin::frames::{self, Frame, Precomputed};
use contact_skin::output::{self, glb, obj, Staged};
use contact_skin::pass::{FailedContact, StageTimings};
use contact_skin::rig::{self, Rig};
use contact_skin::selfcontact::fold::FoldTimings;
use contact_skin::selfcontact::pass::{FailedFold, FoldLayers};
use contact_skin::skinning::Method;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::{Arc, PoisonError, RwLock, RwLockReadGuard};
use std::time::Instant;

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
    /// Folds left unresolved because no bulge could keep the volume without a spike, summed
    /// over the frames.
    folds_unbalanced: usize,
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
    folds_unbalanced: usize,
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
        folds_unbalanced: stats.iter().map(|s| s.folds_unbalanced).sum(),
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

fn print_summary(s: &Summary, a: &Args) -> CliResult {
    warn_stale(s, a);
    if let Some(first) = &s.first_fold_failure {
        eprintln!(
            "warning: {} self-contact fold(s) failed and were left as skinned, the others \
             resolved (first: {first})",
            s.folds_failed
        );
    }
    if let Some(first) = &s.first_contact_failure {
        eprintln!(
            "warning: {} contact(s) or deformation(s) between bodies failed and were left as \
             skinned, the others resolved (first: {first}); `[[pair]] enabled = false` or \
             `[[object]] contact = false` in the configuration leaves a pair or a body out",
            s.contacts_failed
        );
    }
    if let Some(first) = &s.first_inside_out {
        eprintln!(
            "warning: {} time(s) a pose turned a closed body inside out (a joint scaled by a \
             negative factor: its signed volume changed sign), left out of the passes in that \
             frame (first: {first})",
            s.bodies_inside_out
        );
    }
    if s.contacts_without_direction > 0 {
        eprintln!(
            "warning: {} time(s) two bodies intersected with no direction to resolve them \
             along (their normals cancel out, as in a symmetric crossing): left as they were; \
             a `[[pair]] direction` in the configuration resolves them",
            s.contacts_without_direction
        );
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(s)?);
        return Ok(());
    }
    println!(
        "posed {} ({} vertices) with {}: {} frames in {:.1} ms (precompute {:.1} ms, median {:.3} ms per frame), wrote {} file(s) to {}",
        s.rig,
        s.vertices,
        s.skinning,
        s.frames,
        s.total_ms,
        s.precompute_ms,
        s.median_frame_ms,
        s.files.len() + s.diagnostics,
        a.out.display()
    );
    print_contact(s);
    print_self_contact(s);
    if let Some(m) = &s.metrics {
        print_metrics(m);
    }
    Ok(())
}

/// Clears what an interrupted `pose` left in the output folder (its hidden temporaries and
/// backups, [`output::clear_interrupted`]) and says so.
fn clear_interrupted_runs(a: &Args) {
    let cleared = output::clear_interrupted(&a.out, written_by_pose);
    if !(cleared.removed.is_empty() && cleared.restored.is_empty()) {
        eprintln!(
            "warning: {}: an interrupted run's leftovers cleared ({} temporary file(s) removed, \
             {} earlier version(s) put back)",
            a.out.display(),
            cleared.removed.len(),
            cleared.restored.len()
        );
    }
}

/// The names `pose` writes in its output folder (frames, diagnostics, the baked glb).
fn written_by_pose(name: &str) -> bool {
    name.starts_with("frame_") || name.ends_with(".baked.glb")
}

/// A run's file writes, stopped by an interrupt (Ctrl-C, `SIGTERM`, `SIGHUP`): each write and
/// the commit hold the lock to read, the interrupt handler takes it to write, so that it
/// waits for the writes under way and none starts after; it then clears the run's temporaries
/// from the output folder ([`output::clear_own`]) and ends the process with exit code 130.
/// (The next run clears what a run killed outright left: [`clear_interrupted_runs`].)
#[derive(Default)]
struct Writes {
    stopped: RwLock<bool>,
}

impl Writes {
    /// The writes of a run into `folder`, stopped on an interrupt. A process has one handler:
    /// where one is already set, it stays.
    fn stopped_on_interrupt(folder: &Path) -> Arc<Self> {
        let writes = Arc::new(Self::default());
        let (stop, folder) = (Arc::clone(&writes), folder.to_path_buf());
        let _ = ctrlc::set_handler(move || {
            let mut stopped = stop.stopped.write().unwrap_or_else(PoisonError::into_inner);
            *stopped = true;
            output::clear_own(&folder, written_by_pose);
            eprintln!(
                "interrupted: {}: this run's temporaries removed",
                folder.display()
            );
            std::process::exit(130);
        });
        writes
    }

    /// The lock to write under, while the run is not stopped.
    fn open(&self) -> Result<RwLockReadGuard<'_, bool>, String> {
        let stopped = self.stopped.read().unwrap_or_else(PoisonError::into_inner);
        match *stopped {
            true => Err("interrupted".into()),
            false => Ok(stopped),
        }
    }

    /// Stages `bytes` for `path` ([`Staged::write`]).
    fn stage(&self, path: &Path, bytes: &[u8]) -> Result<Staged, String> {
        let _open = self.open()?;
        Staged::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Commits staged files all or none ([`output::commit_all`]; a destination taken by a
    /// folder is refused before anything is moved).
    fn commit(&self, staged: Vec<Staged>) -> Result<(), String> {
        let _open = self.open()?;
        output::commit_all(staged).map_err(|e| e.to_string())
    }
}

/// The warning about an earlier run's frame files left in the output folder.
fn warn_stale(s: &Summary, a: &Args) {
    if let (Some(first), Some(last)) = (s.stale_files.first(), s.stale_files.last()) {
        eprintln!(
            "warning: {}: {} frame file(s) of an earlier run left in place ({first}{}), not part \
             of this run's {} frame(s)",
            a.out.display(),
            s.stale_files.len(),
            if first == last {
                String::new()
            } else {
                format!(" … {last}")
            },
            s.frames
        );
    }
}

/// The contact pass's line: frames in contact and median stage times.
fn print_contact(s: &Summary) {
    if let (Some(passes), Some(t)) = (s.passes, &s.stage_ms) {
        println!(
            "contact ({} pass(es), config {}): {} of {} frames in contact; median ms: intersection {:.3}, mapping {:.3}, zones {:.3}, parametrization {:.3}, directions {:.3}, fields {:.3}, deformation {:.3}, wall {:.3}",
            passes,
            s.config.as_deref().unwrap_or("none (defaults)"),
            s.contact_frames,
            s.frames,
            t.intersection,
            t.mapping,
            t.zones,
            t.parametrization,
            t.directions,
            t.fields,
            t.deformation,
            t.wall
        );
    }
    if !s.pairs_left_out_at_rest.is_empty() {
        let pairs: Vec<String> = (s.pairs_left_out_at_rest.iter())
            .map(|[a, b]| format!("'{a}' / '{b}'"))
            .collect();
        println!(
            "contact: {} pair(s) of bodies cross at rest (modeled overlaps) and are left out: {} ([[pair]] enabled = true resolves one)",
            pairs.len(),
            pairs.join(", ")
        );
    }
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

/// The line on the pairs left out in every frame, if any.
fn print_left_out_folds(folds: &[LeftOutFold]) {
    if folds.is_empty() {
        return;
    }
    let why = |f: &LeftOutFold| match (f.disabled, f.crossing_at_rest, &f.failure_at_rest) {
        (true, ..) => format!("{} (disabled)", f.name),
        (false, Some(n), _) => format!("{} ({n} face pairs cross at rest)", f.name),
        (false, None, Some(e)) => format!("{} (at rest: {e})", f.name),
        (false, None, None) => f.name.clone(),
    };
    println!(
        "self-contact: {} joint pair(s) left as they come in every frame: {} ([[self_contact.pair]] enabled = true resolves one whose sides cross at rest)",
        folds.len(),
        first_eight(folds, why)
    );
}

/// The first eight of `items` shown, then how many more: `a, b and 3 more`.
fn first_eight<T>(items: &[T], show: impl Fn(&T) -> String) -> String {
    let listed: Vec<String> = items.iter().take(8).map(show).collect();
    match items.len() - listed.len() {
        0 => listed.join(", "),
        more => format!("{} and {more} more", listed.join(", ")),
    }
}

/// The line on the pairs run without layers, if any.
fn print_layers(folds: &[FoldLayers]) {
    if folds.is_empty() {
        return;
    }
    let show = |f: &FoldLayers| {
        let faces: Vec<String> = f.layers.iter().map(|l| l.faces.to_string()).collect();
        format!("{} (pieces of {} faces)", f.name, faces.join(", "))
    };
    println!(
        "self-contact: {} joint pair(s) run without the separate pieces of the mesh sunk into them or lying inside others at rest, which follow the skinning: {}",
        folds.len(),
        first_eight(folds, show)
    );
}

/// The self-contact pass's lines: frames with a fold, median step times, Table 1's columns,
/// and what was skipped, left out, left unresolved or guarded.
fn print_self_contact(s: &Summary) {
    if let (Some(wall), Some(t)) = (s.self_contact_ms, &s.fold_ms) {
        let folds = if s.folds.is_empty() {
            "none".to_string()
        } else {
            s.folds.join(", ")
        };
        println!(
            "self-contact ({} joint pair(s)): {} of {} frames with a fold ({folds}); median ms per frame {wall:.3}; with a fold: detection {:.3}, crease {:.3}, contact {:.3}, directions {:.3}, deformation {:.3}, volume {:.3}, wall {:.3}",
            s.self_contact_pairs.len(),
            s.fold_frames,
            s.frames,
            t.steps.detection,
            t.steps.crease,
            t.steps.contact,
            t.steps.directions,
            t.steps.deformation,
            t.steps.volume,
            t.wall
        );
        let q = &t.steps.stages;
        println!(
            "self-contact in Table 1's columns (ms): i. {:.3}, m. {:.3}, c. {:.3}, p. {:.3}, di. {:.3}, g. {:.3}, de. {:.3}, s. {:.3}",
            q.intersection,
            q.mapping,
            q.zones,
            q.parametrization,
            q.directions,
            q.fields,
            q.deformation,
            q.factorization
        );
        for reason in &s.self_contact_pairs_skipped {
            println!("self-contact: skipped {reason}");
        }
        print_left_out_folds(&s.self_contact_pairs_left_out);
        print_layers(&s.self_contact_layers);
        if s.folds_without_direction > 0 {
            println!(
                "self-contact: {} fold(s) skipped without a direction (bones folded 180°, no common relative motion, or separated regions crossing symmetrically)",
                s.folds_without_direction
            );
        }
        if s.folds_unbalanced > 0 {
            println!(
                "self-contact: {} fold(s) left unresolved: no bulge could keep the volume without a spike",
                s.folds_unbalanced
            );
        }
        if s.vertices_guarded > 0 {
            println!(
                "self-contact: the turn guard scaled back {} vertex displacement(s) (summed over the folds) so that no face turns over",
                s.vertices_guarded
            );
        }
        if s.bulges_guarded > 0 {
            println!(
                "self-contact: the bulge guard scaled back {} vertex bulge(s) (summed over the folds) so that no bulge enters the other part",
                s.bulges_guarded
            );
        }
        if s.crease_pairs_unseparated > 0 {
            println!(
                "self-contact: {} of the {} crossing face pair(s) of the crease cuts left on one side of their cut (summed over the folds), where the fold does not resolve them",
                s.crease_pairs_unseparated, s.crease_pairs
            );
        }
        if s.sweeps_max > s.sweeps_planned {
            println!(
                "self-contact: up to {} sweeps over the folds in a frame ({} planned, more while a fold still penetrated)",
                s.sweeps_max, s.sweeps_planned
            );
        }
    }
}

/// `--metrics` in words: each measure's worst frame.
fn print_metrics(m: &RunMetrics) {
    let at = |x: Option<usize>| x.map_or("-".into(), |x| x.to_string());
    let temporal = m.temporal.map_or("fewer than 3 frames".to_string(), |t| {
        format!(
            "{:.2} (frame {}, vertex {}); displacement-step ratio {:.3} ({:.3} h from frame {} to the next, vertex {}; the input's fastest vertex {:.3} h per frame)",
            t.ratio,
            at(t.frame),
            at(t.vertex),
            t.step_ratio,
            t.step_max_h,
            at(t.step_frame),
            at(t.step_vertex),
            t.input_step_max_h,
        )
    });
    println!(
        "metrics (worst frame; h = {:.4}): penetrating vertices {} (frame {}) in the input, {} (frame {}) in the output, deepest {:.2} h (frame {}); volume error of the closed bodies {:.1e} (frame {}); inverted faces {} (frame {}), of which turned by the deformer {} (frame {}); non-finite values {}; temporal second-difference ratio {temporal}",
        m.h,
        m.penetrating_before.value,
        m.penetrating_before.frame,
        m.penetrating_after.value,
        m.penetrating_after.frame,
        m.max_depth_after_h.value,
        m.max_depth_after_h.frame,
        m.volume_error.value,
        m.volume_error.frame,
        m.inverted_faces.value,
        m.inverted_faces.frame,
        m.turned_faces.value,
        m.turned_faces.frame,
        m.non_finite
    );
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
            folds_unbalanced: 0,
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
        folds_unbalanced: so.map_or(0, |s| s.unbalanced),
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

type Written = (Vec<PathBuf>, Vec<FrameStats>);

fn guard_outputs(job: &Job, times: &[f64]) -> Result<(), String> {
    for i in 0..times.len() {
        guard_input(&job.args.rig, &job.args.out.join(obj::frame_file_name(i)))?;
        if job.args.diagnostics {
            let diag = job.args.out.join(contact::diagnostics_file_name(i));
            guard_input(&job.args.rig, &diag)?;
        }
    }
    Ok(())
}

/// The frame files of the output folder that a run of `frames` frames did not write, in frame
/// order: files named like this program's `frame_NNNN.obj` (OBJ runs only) or
/// `frame_NNNN.diag.json` that are not among the names this run wrote. Names are compared as
/// spelled (on a case-insensitive file system a stale `frame_0009.OBJ` goes unreported).
fn stale_files(a: &Args, frames: usize) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(&a.out) else {
        return Vec::new();
    };
    let mut written = std::collections::HashSet::new();
    for i in 0..frames {
        if matches!(a.format, Format::Obj) {
            written.insert(obj::frame_file_name(i));
        }
        if a.diagnostics {
            written.insert(contact::diagnostics_file_name(i));
        }
    }
    let index = |name: &str| -> Option<usize> {
        let rest = name.strip_prefix("frame_")?;
        let digits = match a.format {
            Format::Obj => rest.strip_suffix(".obj"),
            Format::Glb => None,
        }
        .or_else(|| rest.strip_suffix(".diag.json"))?;
        let all_digits = digits.len() >= 4 && digits.bytes().all(|b| b.is_ascii_digit());
        all_digits.then(|| digits.parse().ok()).flatten()
    };
    let mut stale: Vec<(usize, String)> = entries
        .filter_map(|e| {
            let e = e.ok()?;
            e.file_type().ok()?.is_file().then_some(())?;
            let name = e.file_name().into_string().ok()?;
            let i = index(&name)?;
            (!written.contains(&name)).then_some((i, name))
        })
        .collect();
    stale.sort();
    stale.into_iter().map(|(_, name)| name).collect()
}

/// Computes every frame in parallel (`each`): the results in frame order, or an error once
/// the frames under way have finished (rayon stops at a failure); what the others staged is
/// then dropped, which removes it.
fn all_frames<T: Send>(
    times: &[f64],
    each: impl Fn(usize, f64) -> Result<T, String> + Sync,
) -> Result<Vec<T>, String> {
    times
        .par_iter()
        .enumerate()
        .map(|(i, &t)| each(i, t))
        .collect()
}

/// One OBJ per frame. Every file (and diagnostics file) is staged and the set committed only
/// when every frame was written: a failed run leaves the output folder as it was, with no
/// partial or mixed sequence (found by fuzzing: a run failing at its last frame left 75 of 76).
fn write_obj_frames(job: &Job, times: &[f64]) -> Result<Written, BoxError> {
    guard_outputs(job, times)?;
    let frames = all_frames(times, |i, t| {
        let (frame, stats, diagnostics) = compute(job, i, t)?;
        let path = job.args.out.join(obj::frame_file_name(i));
        let text = obj::frame_to_obj_with(&job.faces, &frame, &job.header);
        let obj = job.writes.stage(&path, text.as_bytes())?;
        job.pb.inc(1);
        Ok((obj, diagnostics, stats))
    })
    .map_err(|e| format!("{e} (nothing written)"))?;
    let mut staged = Vec::new();
    let mut stats = Vec::new();
    let mut paths = Vec::new();
    for (obj, diagnostics, s) in frames {
        paths.push(obj.path().to_path_buf());
        staged.push(obj);
        staged.extend(diagnostics);
        stats.push(s);
    }
    job.writes.commit(staged)?;
    Ok((paths, stats))
}

fn write_glb(job: &Job, times: &[f64]) -> Result<Written, BoxError> {
    let a = job.args;
    let stem = a
        .rig
        .file_stem()
        .map_or("rig".into(), |s| s.to_string_lossy().to_string());
    let path = a.out.join(format!("{stem}.baked.glb"));
    guard_input(&a.rig, &path)?;
    if a.diagnostics {
        guard_outputs(job, times)?;
    }
    let computed = all_frames(times, |i, t| {
        let r = compute(job, i, t);
        job.pb.inc(1);
        r
    })
    .map_err(|e| format!("{e} (nothing written)"))?;
    let mut frames = Vec::with_capacity(computed.len());
    let mut stats = Vec::with_capacity(computed.len());
    let mut staged = Vec::new();
    for (frame, s, diagnostics) in computed {
        frames.push(frame);
        stats.push(s);
        staged.extend(diagnostics);
    }
    let bytes = glb::bake(job.rig, &frames, &stem).map_err(|e| format!("{e} (nothing written)"))?;
    let keyed = glb::key_times(times).len();
    if keyed < frames.len() {
        eprintln!(
            "warning: {}: {} of {} frames share their key time with an earlier one (no animation, \
             a zero-length one, or times closer than 32-bit floats tell apart): the glb holds \
             {keyed} pose(s)",
            path.display(),
            frames.len() - keyed,
            frames.len()
        );
    }
    staged.push(job.writes.stage(&path, &bytes)?);
    job.writes.commit(staged)?;
    Ok((vec![path], stats))
}
