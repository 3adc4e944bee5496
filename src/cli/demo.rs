//! `contact-skin demo`: the built-in scenes end to end. Each scene is generated in memory
//! (the same bytes as `rigs/`), posed through every animation with LBS, DQS and CoR, baked to a
//! glb per method, the LBS frames of the first animation written as OBJ, and a table of timings
//! and volume changes printed (and saved as `summary.json`).

use super::contact::median;
use super::CliResult;
use contact_skin::frames::{self, Frame, Precomputed};
use contact_skin::mesh::signed_volume;
use contact_skin::output::{self, glb, obj};
use contact_skin::rig::{self, Rig};
use contact_skin::scenes::{self, Scene};
use contact_skin::skinning::Method;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output folder.
    #[arg(long, short, default_value = "demo-out")]
    out: PathBuf,
    /// Frames per animation (default: 30 per second).
    #[arg(long, short)]
    frames: Option<usize>,
    /// Print the summary as JSON on stdout instead of a table.
    #[arg(long)]
    json: bool,
}

/// One row of the demo table.
#[derive(Serialize)]
struct Row {
    scene: String,
    animation: String,
    method: String,
    vertices: usize,
    frames: usize,
    precompute_ms: f64,
    median_frame_ms: f64,
    /// Largest `|V(t) - V(0)| / V(0)` over frames and closed bodies.
    max_volume_change: f64,
    glb: String,
}

/// Runs `demo`.
pub fn run(a: &Args) -> CliResult {
    std::fs::create_dir_all(a.out.join("rigs"))?;
    let pb = if a.json {
        ProgressBar::hidden()
    } else {
        ProgressBar::new((Scene::ALL.len() * 3) as u64)
    };
    if let Ok(style) = ProgressStyle::with_template("{spinner} demo [{bar:30}] {pos}/{len} {msg}") {
        pb.set_style(style.progress_chars("=> "));
    }
    let mut rows = Vec::new();
    for scene in Scene::ALL {
        let bytes = scenes::build_glb(scene, scenes::DEFAULT_RESOLUTION)?;
        let rig_path = a.out.join("rigs").join(format!("{}.glb", scene.name()));
        output::write_atomic(&rig_path, &bytes)?;
        let rig = rig::load_from_bytes(&rig_path, &bytes)?;
        for method in [Method::Lbs, Method::Dqs, Method::Cor] {
            pb.set_message(format!("{} ({method})", scene.name()));
            rows.extend(run_scene(a, scene, &rig, method)?);
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    let json = serde_json::to_string_pretty(&rows)?;
    output::write_atomic(&a.out.join("summary.json"), json.as_bytes())?;
    if a.json {
        println!("{json}");
    } else {
        print_table(&rows, &a.out);
    }
    Ok(())
}

fn run_scene(
    a: &Args,
    scene: Scene,
    rig: &Rig,
    method: Method,
) -> Result<Vec<Row>, Box<dyn std::error::Error + Send + Sync>> {
    let dir = a.out.join(scene.name());
    std::fs::create_dir_all(&dir)?;
    let t0 = Instant::now();
    let pre = Precomputed::new(rig, method);
    let precompute_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut rows = Vec::new();
    for (ai, anim) in rig.animations.iter().enumerate() {
        let anim_name = anim.name.clone().unwrap_or_else(|| ai.to_string());
        let times = frames::sample_times(rig, Some(ai), a.frames);
        let timed: Vec<(Frame, f64)> = times
            .par_iter()
            .enumerate()
            .map(|(i, &t)| {
                let s = Instant::now();
                let f = frames::evaluate(rig, &pre, Some(ai), i, t);
                (f, s.elapsed().as_secs_f64() * 1e3)
            })
            .collect();
        let (frames, ms): (Vec<Frame>, Vec<f64>) = timed.into_iter().unzip();
        let glb_path = dir.join(format!("{anim_name}.{method}.glb"));
        output::write_atomic(
            &glb_path,
            &glb::bake(
                rig,
                &frames,
                &format!("{} {anim_name} {method}", scene.name()),
            )?,
        )?;
        if method == Method::Lbs && ai == 0 {
            write_obj(&dir.join("obj"), rig, &frames)?;
        }
        rows.push(Row {
            scene: scene.name().to_string(),
            animation: anim_name,
            method: method.to_string(),
            vertices: rig.vertex_count(),
            frames: frames.len(),
            precompute_ms,
            median_frame_ms: median(ms),
            max_volume_change: max_volume_change(rig, &pre, &frames),
            glb: glb_path.display().to_string(),
        });
    }
    Ok(rows)
}

fn write_obj(dir: &Path, rig: &Rig, frames: &[Frame]) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    frames.par_iter().try_for_each(|f| {
        output::write_atomic(
            &dir.join(obj::frame_file_name(f.index)),
            obj::frame_to_obj(rig, f, "demo, lbs").as_bytes(),
        )
    })
}

/// Largest relative volume change against the first frame over the closed bodies.
pub fn max_volume_change(rig: &Rig, pre: &Precomputed, frames: &[Frame]) -> f64 {
    let mut worst: f64 = 0.0;
    for (b, welded) in pre.welded.iter().enumerate().take(rig.bodies.len()) {
        if !welded.report.is_closed_manifold() {
            continue;
        }
        let volume =
            |f: &Frame| signed_volume(&welded.gather(&f.bodies[b].positions), &welded.triangles);
        let v0 = volume(&frames[0]);
        if v0.abs() < 1e-300 {
            continue;
        }
        for f in frames {
            worst = worst.max(((volume(f) - v0) / v0).abs());
        }
    }
    worst
}

fn print_table(rows: &[Row], out: &Path) {
    println!(
        "{:<16} {:<8} {:<6} {:>8} {:>7} {:>11} {:>11} {:>12}",
        "scene", "anim", "skin", "vertices", "frames", "precomp ms", "ms/frame", "max |dV|/V"
    );
    for r in rows {
        println!(
            "{:<16} {:<8} {:<6} {:>8} {:>7} {:>11.2} {:>11.3} {:>11.3}%",
            r.scene,
            r.animation,
            r.method,
            r.vertices,
            r.frames,
            r.precompute_ms,
            r.median_frame_ms,
            100.0 * r.max_volume_change
        );
    }
    println!(
        "wrote rigs, baked glb per scene/animation/method, LBS OBJ frames and summary.json to {}",
        out.display()
    );
    println!(
        "(contact resolution is not built yet: these are the skinning inputs of the contact pass)"
    );
}
