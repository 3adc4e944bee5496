//! `contact-skin pose`: evaluates an animation and writes its frames.

use super::CliResult;
use contact_skin::frames::{self, Frame, Precomputed};
use contact_skin::output::{self, glb, obj};
use contact_skin::rig::{self, Rig};
use contact_skin::skinning::Method;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};
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
    /// Number of frames, evenly spaced over the animation, both ends included (default: 30 per second).
    #[arg(long, short)]
    frames: Option<usize>,
    /// Skinning method feeding the contact pass.
    #[arg(long, value_enum, default_value_t = Skinning::Lbs)]
    skinning: Skinning,
    /// Write the plain skinning result (the contact pass is not built yet: currently always the case).
    #[arg(long)]
    no_contact: bool,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Obj)]
    format: Format,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Summary {
    rig: String,
    animation: Option<String>,
    skinning: String,
    contact: bool,
    frames: usize,
    vertices: usize,
    files: Vec<String>,
    precompute_ms: f64,
    total_ms: f64,
    median_frame_ms: f64,
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
    let times = frames::sample_times(&rig, animation, a.frames);
    let method = Method::from(a.skinning);
    let t_pre = Instant::now();
    let pre = Precomputed::new(&rig, method);
    let precompute_ms = t_pre.elapsed().as_secs_f64() * 1e3;
    std::fs::create_dir_all(&a.out)?;
    let pb = progress(times.len(), a.json);
    pb.set_message(format!("posing {}", a.rig.display()));
    let header = format!(
        "rig {} animation {:?} skinning {} contact off",
        a.rig.display(),
        animation.and_then(|i| rig.animations[i].name.clone()),
        method
    );
    let (files, frame_ms) = match a.format {
        Format::Obj => write_obj_frames(a, &rig, &pre, animation, &times, &header, &pb)?,
        Format::Glb => write_glb(a, &rig, &pre, animation, &times, &pb)?,
    };
    pb.finish_and_clear();
    let summary = Summary {
        rig: a.rig.display().to_string(),
        animation: animation.map(|i| {
            rig.animations[i]
                .name
                .clone()
                .unwrap_or_else(|| i.to_string())
        }),
        skinning: method.to_string(),
        contact: false,
        frames: times.len(),
        vertices: rig.vertex_count(),
        files: files.iter().map(|p| p.display().to_string()).collect(),
        precompute_ms,
        total_ms: start.elapsed().as_secs_f64() * 1e3,
        median_frame_ms: median(frame_ms),
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        println!(
            "posed {} ({} vertices) with {}: {} frames in {:.1} ms (precompute {:.1} ms, median {:.3} ms per frame), wrote {} file(s) to {}",
            summary.rig,
            summary.vertices,
            summary.skinning,
            summary.frames,
            summary.total_ms,
            summary.precompute_ms,
            summary.median_frame_ms,
            summary.files.len(),
            a.out.display()
        );
    }
    Ok(())
}

type Written = (Vec<PathBuf>, Vec<f64>);

fn write_obj_frames(
    a: &Args,
    rig: &Rig,
    pre: &Precomputed,
    animation: Option<usize>,
    times: &[f64],
    header: &str,
    pb: &ProgressBar,
) -> Result<Written, Box<dyn std::error::Error + Send + Sync>> {
    for i in 0..times.len() {
        guard_input(&a.rig, &a.out.join(obj::frame_file_name(i)))?;
    }
    let results: Vec<(PathBuf, f64)> = times
        .par_iter()
        .enumerate()
        .map(|(i, &t)| {
            let path = a.out.join(obj::frame_file_name(i));
            let t0 = Instant::now();
            let frame = frames::evaluate(rig, pre, animation, i, t);
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            output::write_atomic(&path, obj::frame_to_obj(rig, &frame, header).as_bytes())
                .map_err(|e| format!("{}: {e}", path.display()))?;
            pb.inc(1);
            Ok((path, ms))
        })
        .collect::<Result<_, String>>()?;
    Ok(results.into_iter().unzip())
}

fn write_glb(
    a: &Args,
    rig: &Rig,
    pre: &Precomputed,
    animation: Option<usize>,
    times: &[f64],
    pb: &ProgressBar,
) -> Result<Written, Box<dyn std::error::Error + Send + Sync>> {
    let stem = a
        .rig
        .file_stem()
        .map_or("rig".into(), |s| s.to_string_lossy().to_string());
    let path = a.out.join(format!("{stem}.baked.glb"));
    guard_input(&a.rig, &path)?;
    let timed: Vec<(Frame, f64)> = times
        .par_iter()
        .enumerate()
        .map(|(i, &t)| {
            let t0 = Instant::now();
            let f = frames::evaluate(rig, pre, animation, i, t);
            pb.inc(1);
            (f, t0.elapsed().as_secs_f64() * 1e3)
        })
        .collect();
    let (frames, ms): (Vec<Frame>, Vec<f64>) = timed.into_iter().unzip();
    let bytes = glb::bake(rig, &frames, &stem)?;
    output::write_atomic(&path, &bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok((vec![path], ms))
}

/// Median of a list (0 for an empty one).
pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}
