//! Sparse solver and heat-method timings on working regions of 2k, 10k and 50k vertices
//! (planar grids of 45², 100² and 224² vertices): symbolic analysis (once per region), numeric Cholesky (per frame and matrix),
//! solves with 1 and 3 right-hand sides, and the whole heat-method distance from a circle on
//! the cut mesh (cut + assembly + 2 factorizations + 2 solves).
//!
//! Run with `cargo bench --bench solve`. For scale: the 2021 paper's whole frame of the skinned
//! finger (1967 + 2951 vertices) took 13.6 ms on one 2014 core (Table 1).

#[path = "../tests/common/meshes.rs"]
mod meshes;

use contact_skin::heat::{Boundary, HeatParams, RegionSolver};
use contact_skin::mesh::operators::{face_geometry, lumped_mass};
use contact_skin::mesh::Region;
use contact_skin::solve::SpdPattern;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use std::time::Duration;

/// Slot values of `M + t K` on the whole region (no cut).
fn heat_slots(region: &Region, pos: &[nalgebra::Point3<f64>]) -> Vec<f64> {
    let n = region.vertex_count();
    let geo = face_geometry(pos, &region.triangles);
    let mass = lumped_mass(n, &region.triangles, &geo);
    let mut s = vec![0.0; n + region.edges.len()];
    s[..n].copy_from_slice(&mass);
    let t = 1e-3;
    for ((tri, g), fe) in region.triangles.iter().zip(&geo).zip(&region.face_edges) {
        for k in 0..3 {
            let (i, j) = ((k + 1) % 3, (k + 2) % 3);
            let w = t * g.stiffness(i, j);
            s[n + fe[k] as usize] += w;
            s[tri[i] as usize] -= w;
            s[tri[j] as usize] -= w;
        }
    }
    s
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("solve");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(300));
    for (label, cells) in [("2k", 44), ("10k", 99), ("50k", 223)] {
        let mesh = meshes::grid(cells);
        let region = Region::whole(&mesh.triangles);
        let pos = region.gather(&mesh.positions);
        group.bench_function(BenchmarkId::new("symbolic", label), |b| {
            b.iter(|| {
                SpdPattern::new(region.vertex_count(), black_box(&region.edges)).expect("symbolic")
            })
        });
        let pattern = SpdPattern::new(region.vertex_count(), &region.edges).expect("symbolic");
        let slots = heat_slots(&region, &pos);
        group.bench_function(BenchmarkId::new("numeric", label), |b| {
            b.iter(|| pattern.factor(black_box(&slots), "heat").expect("numeric"))
        });
        let factor = pattern.factor(&slots, "heat").expect("numeric");
        group.bench_function(BenchmarkId::new("solve_1", label), |b| {
            b.iter(|| {
                let mut rhs = vec![1.0; region.vertex_count()];
                factor.solve(&mut rhs);
                rhs
            })
        });
        group.bench_function(BenchmarkId::new("solve_3", label), |b| {
            b.iter(|| {
                let mut rhs = vec![[1.0, 2.0, 3.0]; region.vertex_count()];
                factor.solve_many(&mut rhs);
                rhs
            })
        });
        let solver = RegionSolver::new(region.clone()).expect("symbolic");
        let f: Vec<f64> = pos.iter().map(|p| p.coords.norm() - 0.3).collect();
        let boundary = Boundary::from_level_set(&solver.region, &f);
        group.bench_function(BenchmarkId::new("heat_distance", label), |b| {
            b.iter(|| {
                let mut problem = solver.problem(black_box(&pos), &boundary).expect("cut");
                problem.distance(HeatParams::default()).expect("distance")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
