//! The contact pass between separate objects, per frame, with the per-stage breakdown of the
//! 2021 paper's Table 1 (i. intersection, m. mapping, c. contact zones, p. parametrization,
//! di. directions, g. guiding-field diffusion, de. deformation).
//!
//! Scenes: the committed `rigs/fingertips_ball.glb` (ball 1514 + three fingertips 3 × 402
//! vertices; the paper's Fingers-Ball has 1064 + 1561), `capsule_pair` (2282 + 2282) and
//! `sphere_plane` (4002 + 762), LBS input. Timings on one thread (a one-thread rayon pool:
//! the paper's "one core") and with every core.
//!
//! Run with `cargo bench --bench contact`. Before criterion's measurements, the bench prints a
//! table of per-stage medians over every frame with contact of each animation.

use contact_skin::frames::{self, Precomputed};
use contact_skin::pass::{ContactPass, PassOutput, StageTimings};
use contact_skin::report::timings::{median, median_stages};
use contact_skin::rig::Rig;
use contact_skin::skinning::Method;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::{Duration, Instant};

mod common;

struct Scene {
    rig: Rig,
    pre: Precomputed,
    pass: ContactPass,
    times: Vec<f64>,
}

fn scene(name: &str, passes: usize) -> Scene {
    let rig = common::committed_rig(name);
    let pre = Precomputed::new(&rig, Method::Lbs);
    let pass = common::object_pass(&rig, &pre).with_passes(passes);
    let times = frames::sample_times(&rig, Some(0), Some(61)).expect("frames");
    Scene {
        rig,
        pre,
        pass,
        times,
    }
}

/// Per-stage medians (ms) over the frames with contact, on the current rayon pool.
fn breakdown(s: &Scene) -> (Vec<(&'static str, f64)>, usize, f64) {
    let mut rows: Vec<StageTimings> = Vec::new();
    let mut skin = Vec::new();
    for &t in &s.times {
        let start = Instant::now();
        let input = frames::welded_positions(&s.rig, &s.pre, Some(0), t);
        skin.push(start.elapsed().as_secs_f64());
        let out: PassOutput = s.pass.run_at(&input, t).expect("pass");
        if !out.contacts.is_empty() {
            rows.push(out.timings);
        }
    }
    let m = median_stages(&rows);
    let table = vec![
        ("i. intersection", m.intersection),
        ("m. mapping", m.mapping),
        ("c. contact zones", m.zones),
        ("p. parametrization", m.parametrization),
        ("di. directions", m.directions),
        ("g. diffusion", m.fields),
        ("de. deformation", m.deformation),
        ("s. factorizations", m.factorization),
        ("setup (normals, refit)", m.setup),
        ("wall", m.wall),
    ];
    (table, rows.len(), 1e3 * median(skin))
}

fn print_breakdowns() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    for passes in [1, 2] {
        for name in ["fingertips_ball", "capsule_pair", "sphere_plane"] {
            let s = scene(name, passes);
            let (table, n, skin) = pool.install(|| breakdown(&s));
            let wall = table.last().map_or(0.0, |r| r.1);
            println!("{name}, {passes} pass(es), one thread, median over {n} frames with contact (skinning + weld {skin:.3} ms):");
            for (label, ms) in &table {
                println!(
                    "  {label:<24} {ms:>8.3} ms {:>5.1} %",
                    100.0 * ms / wall.max(1e-12)
                );
            }
        }
    }
}

fn bench(c: &mut Criterion) {
    print_breakdowns();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let mut g = c.benchmark_group("contact");
    g.measurement_time(Duration::from_secs(4)).sample_size(20);
    for name in ["fingertips_ball", "capsule_pair", "sphere_plane"] {
        let s = scene(name, 1);
        let last = *s.times.last().unwrap_or(&0.0);
        let deep = frames::welded_positions(&s.rig, &s.pre, Some(0), last);
        let rest = frames::welded_positions(&s.rig, &s.pre, Some(0), 0.0);
        g.bench_function(format!("{name}/deepest frame/1 pass/1 thread"), |b| {
            common::on_one_thread(&one, b, || black_box(s.pass.run(&deep).expect("pass")))
        });
        g.bench_function(format!("{name}/deepest frame/1 pass/all threads"), |b| {
            b.iter(|| black_box(s.pass.run(&deep).expect("pass")))
        });
        // At `pose`'s default two passes, of which a frame without contact runs the first only
        // (the same time as at one pass: one entry measures both).
        let two = scene(name, 2);
        g.bench_function(format!("{name}/no-contact frame/2 passes/1 thread"), |b| {
            common::on_one_thread(&one, b, || black_box(two.pass.run(&rest).expect("pass")))
        });
        g.bench_function(format!("{name}/skinning + weld/1 thread"), |b| {
            common::on_one_thread(&one, b, || {
                black_box(frames::welded_positions(&s.rig, &s.pre, Some(0), last))
            })
        });
    }
    g.finish();
    batch(c);
}

/// Batch evaluation of an animation (skinning + contact pass for 31 frames, frames in
/// parallel as `pose` does): one thread against every core.
fn batch(c: &mut Criterion) {
    use rayon::prelude::*;
    let mut g = c.benchmark_group("batch");
    g.measurement_time(Duration::from_secs(6)).sample_size(10);
    let s = scene("fingertips_ball", 1);
    let times: Vec<f64> = frames::sample_times(&s.rig, Some(0), Some(31)).expect("frames");
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        g.bench_function(
            format!("fingertips_ball/31 frames/{threads} thread(s)"),
            |b| {
                b.iter(|| {
                    pool.install(|| {
                        times
                            .par_iter()
                            .map(|&t| {
                                s.pass
                                    .run_at(
                                        &frames::welded_positions(&s.rig, &s.pre, Some(0), t),
                                        t,
                                    )
                                    .expect("pass")
                                    .positions
                                    .len()
                            })
                            .sum::<usize>()
                    })
                })
            },
        );
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
