//! Intersection benchmarks (2021 Sec. 4.1-4.2 building blocks) on two overlapping 10k-triangle
//! UV spheres: mesh-mesh detection (hits + curves), intersection regions, BVH build vs refit
//! (ours, and parry's `Bvh` for comparison), 10k farthest-hit rays, silhouette extraction, and
//! the fast winding number (Barill et al. 2018) that the self-contact pass's inside tests and
//! `pose --metrics`' penetration test query: its refit and 5k queries, one thread.
//!
//! Run with `cargo bench --bench intersect`.

use contact_skin::intersect::{
    farthest_hits, FrontSide, IntersectionRegion, Intersections, MeshIndex, Ray, Side, Silhouette,
    TriangleBvh,
};
use contact_skin::report::metrics::WindingNumber;
use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Point3, Vector3};
use parry3d_f64::bounding_volume::{Aabb as ParryAabb, BoundingVolume};
use parry3d_f64::math::Vector as ParryVector;
use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy, BvhWorkspace};
use std::hint::black_box;
use std::time::Duration;

type Mesh = (Vec<Point3<f64>>, Vec<[u32; 3]>);

/// UV sphere with `n_lat` rings of `n_lon` vertices plus poles: `2 n_lon n_lat` triangles.
fn uv_sphere(radius: f64, center: Point3<f64>, n_lat: usize, n_lon: usize) -> Mesh {
    let mut pos = vec![center + Vector3::z() * radius];
    for j in 1..=n_lat {
        let th = std::f64::consts::PI * j as f64 / (n_lat + 1) as f64;
        for k in 0..n_lon {
            let ph = std::f64::consts::TAU * k as f64 / n_lon as f64 + 0.05 * j as f64;
            pos.push(
                center + Vector3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()) * radius,
            );
        }
    }
    pos.push(center - Vector3::z() * radius);
    let south = pos.len() as u32 - 1;
    let v = |j: usize, k: usize| (1 + j * n_lon + k % n_lon) as u32;
    let mut tris = Vec::new();
    for k in 0..n_lon {
        tris.push([0, v(0, k), v(0, k + 1)]);
        tris.push([south, v(n_lat - 1, k + 1), v(n_lat - 1, k)]);
    }
    for j in 0..n_lat - 1 {
        for k in 0..n_lon {
            tris.push([v(j, k), v(j + 1, k), v(j + 1, k + 1)]);
            tris.push([v(j, k), v(j + 1, k + 1), v(j, k + 1)]);
        }
    }
    (pos, tris)
}

/// A deformed copy (a smooth wave), as a new frame of the same topology.
fn deformed(m: &Mesh) -> Vec<Point3<f64>> {
    m.0.iter()
        .map(|p| p + Vector3::new(0.0, 0.0, 0.1 * (3.0 * p.x).sin()))
        .collect()
}

struct Scene {
    a: Mesh,
    b: Mesh,
    index_a: MeshIndex,
    index_b: MeshIndex,
}

fn scene() -> Scene {
    let a = uv_sphere(1.0, Point3::new(0.01, -0.02, 0.0), 50, 100);
    let b = uv_sphere(0.8, Point3::new(0.3, 0.2, 1.1), 50, 100);
    assert_eq!(a.1.len(), 10_000);
    let index_a = MeshIndex::new(&a.0, &a.1).expect("sphere a");
    let index_b = MeshIndex::new(&b.0, &b.1).expect("sphere b");
    Scene {
        a,
        b,
        index_a,
        index_b,
    }
}

fn detection(c: &mut Criterion) {
    let s = scene();
    let (pa, pb) = (
        s.index_a.pose(&s.a.0).expect("pose"),
        s.index_b.pose(&s.b.0).expect("pose"),
    );
    let ints = Intersections::between(&pa, &pb).expect("the scene intersects");
    println!(
        "two 10k spheres: {} hits, {} segments, {} curves, {} candidate pairs",
        ints.hits.len(),
        ints.segments.len(),
        ints.curves.len(),
        ints.stats.candidate_pairs
    );
    let mut g = c.benchmark_group("detect");
    g.bench_function("hits_and_curves_10k_x_10k", |bch| {
        bch.iter(|| black_box(Intersections::between(&pa, &pb)))
    });
    g.bench_function("regions_both_sides", |bch| {
        bch.iter(|| {
            black_box(IntersectionRegion::inside(&ints, Side::A, &pa).expect("region"));
            black_box(IntersectionRegion::inside(&ints, Side::B, &pb).expect("region"))
        })
    });
    g.bench_function("pose_refit_and_detect", |bch| {
        bch.iter(|| {
            let pa = s.index_a.pose(&s.a.0).expect("pose");
            let pb = s.index_b.pose(&s.b.0).expect("pose");
            black_box(Intersections::between(&pa, &pb))
        })
    });
    g.finish();
}

fn parry_boxes(m: &Mesh, positions: &[Point3<f64>]) -> Vec<ParryAabb> {
    let v = |p: &Point3<f64>| ParryVector::new(p.x, p.y, p.z);
    m.1.iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| &positions[i as usize]);
            ParryAabb::new(v(&a.inf(&b.inf(c))), v(&a.sup(&b.sup(c))))
        })
        .collect()
}

fn bvh(c: &mut Criterion) {
    let s = scene();
    let faces: Vec<u32> = (0..s.a.1.len() as u32).collect();
    let frames = [s.a.0.clone(), deformed(&s.a)];
    let mut g = c.benchmark_group("bvh_10k");
    g.bench_function("build", |bch| {
        bch.iter(|| black_box(TriangleBvh::build(&s.a.0, &s.a.1, &faces)))
    });
    let mut tree = TriangleBvh::build(&s.a.0, &s.a.1, &faces);
    let mut k = 0;
    g.bench_function("refit", |bch| {
        bch.iter(|| {
            k ^= 1;
            tree.refit(&frames[k], &s.a.1);
            black_box(tree.root_box())
        })
    });
    // Both spheres have 10k faces: `faces` indexes either.
    let tb = TriangleBvh::build(&s.b.0, &s.b.1, &faces);
    let ta = TriangleBvh::build(&s.a.0, &s.a.1, &faces);
    g.bench_function("candidate_pairs", |bch| {
        bch.iter(|| black_box(ta.candidate_pairs(&tb).len()))
    });

    // parry's Bvh on the same boxes, for comparison.
    let boxes = [parry_boxes(&s.a, &frames[0]), parry_boxes(&s.a, &frames[1])];
    g.bench_function("parry_build", |bch| {
        bch.iter(|| black_box(Bvh::from_leaves(BvhBuildStrategy::Binned, &boxes[0])))
    });
    let mut ptree = Bvh::from_leaves(BvhBuildStrategy::Binned, &boxes[0]);
    let mut ws = BvhWorkspace::default();
    let mut k = 0;
    g.bench_function("parry_refit", |bch| {
        bch.iter(|| {
            k ^= 1;
            for (i, bx) in boxes[k].iter().enumerate() {
                ptree.insert_or_update_partially(*bx, i as u32, 0.0);
            }
            ptree.refit(&mut ws);
            black_box(ptree.root_aabb())
        })
    });
    let pa = Bvh::from_leaves(BvhBuildStrategy::Binned, &boxes[0]);
    let pb = Bvh::from_leaves(BvhBuildStrategy::Binned, &parry_boxes(&s.b, &s.b.0));
    g.bench_function("parry_candidate_pairs", |bch| {
        bch.iter(|| {
            black_box(
                pa.leaf_pairs(&pb, |x, y| x.aabb().intersects(&y.aabb()))
                    .count(),
            )
        })
    });
    g.finish();
}

fn rays(c: &mut Criterion) {
    let s = scene();
    let pa = s.index_a.pose(&s.a.0).expect("pose");
    // 10k rays from the vertices of B toward -z (the mapping rays of Sec. 4.2), 3 units long.
    let rays: Vec<Ray> = (0..10_000)
        .map(|i| {
            let p = s.b.0[i % s.b.0.len()];
            let jitter = Vector3::new((i as f64 * 0.37).sin(), (i as f64 * 0.61).cos(), 0.0) * 0.01;
            Ray::new(p + jitter, -Vector3::z(), 3.0)
        })
        .collect();
    let hit = farthest_hits(&pa, &rays).iter().flatten().count();
    println!("farthest-hit rays: {hit} of {} hit", rays.len());
    let mut g = c.benchmark_group("rays");
    g.bench_function("farthest_hit_10k_rays_10k_tris", |bch| {
        bch.iter(|| black_box(farthest_hits(&pa, &rays)))
    });
    let normals: Vec<Vector3<f64>> =
        s.a.0
            .iter()
            .map(|p| (p - Point3::new(0.01, -0.02, 0.0)).normalize())
            .collect();
    let d = Vector3::new(0.3, -0.4, 0.866).normalize();
    g.bench_function("silhouette_10k", |bch| {
        bch.iter(|| {
            black_box(
                Silhouette::compute(&s.a.0, &s.a.1, &normals, &d, FrontSide::NonPositive)
                    .expect("silhouette"),
            )
        })
    });
    g.finish();
}

fn winding(c: &mut Criterion) {
    let s = scene();
    let mut tree = WindingNumber::new(&s.a.0, &s.a.1);
    // Queries at B's vertices, nudged inward as the penetration test nudges them: about a
    // quarter inside A, some near its surface, the rest up to a diameter away.
    let center_b = Point3::new(0.3, 0.2, 1.1);
    let queries: Vec<Point3<f64>> =
        s.b.0
            .iter()
            .map(|p| p - (p - center_b).normalize() * 0.005)
            .collect();
    let inside = queries.iter().filter(|q| tree.query(q) > 0.5).count();
    println!(
        "winding number: {inside} of {} queries inside",
        queries.len()
    );
    let moved: Vec<Point3<f64>> = s.a.0.iter().map(|p| p + Vector3::x() * 1e-3).collect();
    let mut g = c.benchmark_group("winding");
    g.bench_function("winding_5k_queries_10k_tris", |bch| {
        bch.iter(|| black_box(queries.iter().map(|q| tree.query(q)).sum::<f64>()))
    });
    let mut k = 0;
    g.bench_function("winding_refit_10k_tris", |bch| {
        bch.iter(|| {
            k ^= 1;
            let at = if k == 1 { &moved } else { &s.a.0 };
            black_box(tree.refit(at, &s.a.1))
        })
    });
    g.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1))
}

criterion_group! {
    name = benches;
    config = config();
    targets = detection, bvh, rays, winding
}
criterion_main!(benches);
