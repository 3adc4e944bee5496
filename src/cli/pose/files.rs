//! The files a run writes: OBJ frames or one glb, all or none (written beside, then renamed),
//! and the leftovers of interrupted or earlier runs.

use super::{compute, guard_input, Args, Format, FrameStats, Job};
use crate::cli::contact::{self, BoxError};
use contact_skin::output::{self, glb, obj, Staged};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::{Arc, PoisonError, RwLock, RwLockReadGuard};

/// Clears what an interrupted `pose` left in the output folder (its hidden temporaries and
/// backups, [`output::clear_interrupted`]) and says so.
pub(super) fn clear_interrupted_runs(a: &Args) {
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
pub(super) struct Writes {
    stopped: RwLock<bool>,
}

impl Writes {
    /// The writes of a run into `folder`, stopped on an interrupt. A process has one handler:
    /// where one is already set, it stays.
    pub(super) fn stopped_on_interrupt(folder: &Path) -> Arc<Self> {
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
    pub(super) fn stage(&self, path: &Path, bytes: &[u8]) -> Result<Staged, String> {
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
pub(super) fn stale_files(a: &Args, frames: usize) -> Vec<String> {
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
pub(super) fn write_obj_frames(job: &Job, times: &[f64]) -> Result<Written, BoxError> {
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

/// One glb, `<rig stem>.baked.glb`, that plays the frames (morph targets switched by a
/// `weights` animation: [`glb::bake`]), staged with the diagnostics files, committed with them.
pub(super) fn write_glb(job: &Job, times: &[f64]) -> Result<Written, BoxError> {
    let a = job.args;
    let stem = a
        .rig
        .file_stem()
        .map_or("rig".into(), |s| s.to_string_lossy().to_string());
    let path = a.out.join(format!("{stem}.baked.glb"));
    guard_input(&a.rig, &path)?;
    // Before any frame is computed (and held: a baked glb keeps them all).
    let keys = glb::key_times(times).len();
    if keys > glb::MAX_BAKED_FRAMES {
        let refused = glb::BakeError::TooManyFrames { frames: keys };
        let remedy = "use --format obj, or fewer --frames; nothing written";
        return Err(format!("{refused} ({remedy})").into());
    }
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
