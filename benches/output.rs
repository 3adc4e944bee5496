//! Writing a posed frame as OBJ text (`pose`'s default output): the whole frame with the rig's
//! faces written for each frame (`frame_to_obj`) against the faces written once per run
//! (`frame_to_obj_with`, as `pose` and the demo do), beside the skinning of the same frame.
//! Scene: the committed `finger_long.glb` (4562 vertices, 9120 faces), one thread.
//!
//! Run with `cargo bench --bench output`.

use contact_skin::frames::{self, Precomputed};
use contact_skin::output::obj;
use contact_skin::skinning::Method;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;

mod common;

fn bench(c: &mut Criterion) {
    let rig = common::committed_rig("finger_long");
    let pre = Precomputed::new(&rig, Method::Lbs);
    let frame = frames::evaluate(&rig, &pre, Some(0), 3, 0.5);
    let faces = obj::ObjFaces::of(&rig);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let mut g = c.benchmark_group("output");
    g.measurement_time(Duration::from_secs(4)).sample_size(30);
    g.bench_function("finger_long/obj frame, faces per frame", |b| {
        b.iter(|| black_box(obj::frame_to_obj(&rig, &frame, "header")))
    });
    g.bench_function("finger_long/obj frame, faces once", |b| {
        b.iter(|| black_box(obj::frame_to_obj_with(&faces, &frame, "header")))
    });
    g.bench_function("finger_long/skinning", |b| {
        common::on_one_thread(&one, b, || {
            black_box(frames::evaluate(&rig, &pre, Some(0), 3, 0.5))
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
