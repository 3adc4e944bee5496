//! Skinning benchmarks on a synthetic ~30k-vertex, 20-bone character built in code: LBS, DQS
//! and center-of-rotation (Le & Hodgins 2016) per-frame times, LBS after morph targets (52
//! targets of 2k vertices each, as a face's blend shapes, 10 of them weighted), and the CoR
//! center precomputation.
//!
//! The character is a set of open tubes (torso + neck + head chain, two 4-bone arms, two 3-bone
//! legs) whose weights blend over bands around every joint. The bands are oblique (their
//! position depends on the angle around the tube), so weight rows are not repeated around a
//! ring, as in painted weights: the deduplication of identical rows gains little here (13.7k
//! blended vertices, 12.5k distinct rows). Band
//! vertices have three influences (the two bones of the joint and a small spill onto the next
//! bone), limb roots also blend with their parent bone. A second, "dense" variant widens the
//! bands until nearly every vertex is blended, as a worst case for the precomputation.
//!
//! Run with `cargo bench --bench skinning`.

use contact_skin::rig::{Body, MorphTarget, Morphs, PrimitiveRange, SkinWeights};
use contact_skin::skinning::cor::{self, CorCenters, CorParams};
use contact_skin::skinning::{dqs, lbs, BindShape};
use criterion::{criterion_group, criterion_main, Criterion, SamplingMode};
use nalgebra::{Matrix4, Point3, Rotation3, Translation3, Unit, Vector3};
use std::f64::consts::PI;
use std::hint::black_box;
use std::time::Duration;

/// One tube of the character: a straight chain of equal bones.
struct Limb {
    start: Point3<f64>,
    dir: Vector3<f64>,
    length: f64,
    radius: f64,
    segs: usize,
    rings: usize,
    bones: Vec<u16>,
    parent: Option<u16>,
}

/// Bones (`(parent, head position)`, bind rotation identity) and the tubes they drive.
struct Character {
    bones: Vec<(Option<usize>, Point3<f64>)>,
    limbs: Vec<Limb>,
}

fn smoothstep(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl Character {
    /// The 20-bone character.
    fn new() -> Self {
        let mut bones = Vec::new();
        let mut limbs = Vec::new();
        let mut chain = |bones: &mut Vec<(Option<usize>, Point3<f64>)>,
                         start: Point3<f64>,
                         dir: Vector3<f64>,
                         length: f64,
                         n: usize,
                         parent: Option<usize>,
                         (radius, segs, rings): (f64, usize, usize)| {
            let first = bones.len();
            for i in 0..n {
                let head = start + dir * (length * i as f64 / n as f64);
                let p = if i == 0 {
                    parent
                } else {
                    Some(bones.len() - 1)
                };
                bones.push((p, head));
            }
            limbs.push(Limb {
                start,
                dir,
                length,
                radius,
                segs,
                rings,
                bones: (first..first + n).map(|b| b as u16).collect(),
                parent: parent.map(|p| p as u16),
            });
        };
        let base = Point3::new(0.0, 0.9, 0.0);
        chain(
            &mut bones,
            base,
            Vector3::y(),
            0.9,
            6,
            None,
            (0.15, 48, 181),
        );
        let chest = Point3::new(0.0, 1.35, 0.0);
        chain(
            &mut bones,
            chest,
            -Vector3::x(),
            0.75,
            4,
            Some(3),
            (0.05, 32, 161),
        );
        chain(
            &mut bones,
            chest,
            Vector3::x(),
            0.75,
            4,
            Some(3),
            (0.05, 32, 161),
        );
        let hip = |x: f64| Point3::new(x, 0.9, 0.0);
        chain(
            &mut bones,
            hip(-0.09),
            -Vector3::y(),
            0.9,
            3,
            Some(0),
            (0.07, 40, 141),
        );
        chain(
            &mut bones,
            hip(0.09),
            -Vector3::y(),
            0.9,
            3,
            Some(0),
            (0.07, 40, 141),
        );
        Self { bones, limbs }
    }

    /// The skinned body with blend half-width `band` (fraction of a bone length).
    fn body(&self, band: f64) -> Body {
        let (mut positions, mut normals, mut triangles) = (Vec::new(), Vec::new(), Vec::new());
        let mut weights = SkinWeights::with_capacity(32_000);
        for limb in &self.limbs {
            let first = positions.len() as u32;
            let (u, w) = frame(&limb.dir);
            for i in 0..=limb.rings {
                let s = limb.length * i as f64 / limb.rings as f64;
                for k in 0..limb.segs {
                    let phi = 2.0 * PI * k as f64 / limb.segs as f64;
                    let radial = u * phi.cos() + w * phi.sin();
                    positions.push(limb.start + limb.dir * s + radial * limb.radius);
                    normals.push(radial);
                    weights.push_row(&limb_weights(limb, s, phi, band));
                }
            }
            let id = |i: usize, k: usize| first + (i * limb.segs + k % limb.segs) as u32;
            for i in 0..limb.rings {
                for k in 0..limb.segs {
                    let (a, b, c, d) = (id(i, k), id(i, k + 1), id(i + 1, k), id(i + 1, k + 1));
                    triangles.push([a, c, b]);
                    triangles.push([b, c, d]);
                }
            }
        }
        Body {
            name: "character".into(),
            node: 0,
            mesh: 0,
            skin: 0,
            rigid: false,
            primitives: vec![PrimitiveRange {
                mesh: 0,
                primitive: 0,
                first_vertex: 0,
                vertex_count: positions.len(),
                first_triangle: 0,
                triangle_count: triangles.len(),
            }],
            positions,
            normals,
            weights,
            triangles,
            morphs: Default::default(),
        }
    }

    /// Joint matrices `world(bone) · IBM` of a pose bending every bone by up to ~60°.
    fn pose(&self, phase: f64) -> Vec<Matrix4<f64>> {
        let mut world: Vec<Matrix4<f64>> = Vec::with_capacity(self.bones.len());
        for (b, &(parent, head)) in self.bones.iter().enumerate() {
            let angle = 1.0 * (phase + 0.7 * b as f64).sin();
            let axis = Unit::new_normalize(Vector3::new(1.0, 0.3 * b as f64, 0.5).normalize());
            let local = Rotation3::from_axis_angle(&axis, angle).to_homogeneous();
            let (parent_world, parent_head) = match parent {
                Some(p) => (world[p], self.bones[p].1),
                None => (Matrix4::identity(), Point3::origin()),
            };
            let offset = Translation3::from(head - parent_head).to_homogeneous();
            world.push(parent_world * offset * local);
        }
        world
            .iter()
            .zip(&self.bones)
            .map(|(m, &(_, head))| m * Translation3::from(-head.coords).to_homogeneous())
            .collect()
    }
}

/// Two unit vectors orthogonal to `d` and to each other.
fn frame(d: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if d.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = d.cross(&helper).normalize();
    (u, d.cross(&u))
}

/// Weights at axial coordinate `s` and angle `phi` of a limb: oblique smoothstep bands at the
/// joints, a small spill onto the next bone inside each band, and a blend with the parent bone
/// at the root. Rows are positive, sorted by joint and normalized.
fn limb_weights(limb: &Limb, s: f64, phi: f64, band: f64) -> Vec<(u16, f64)> {
    let n = limb.bones.len();
    let lb = limb.length / n as f64;
    let h = band * lb;
    let shift = 0.3 * h * phi.cos() + 0.1 * h * (3.0 * phi).sin();
    // b[i] = how far past joint i (between bones i-1 and i) the point is, b[0] = 1, b[n] = 0.
    let past = |i: usize| -> f64 {
        match i {
            0 => 1.0,
            i if i >= n => 0.0,
            i => smoothstep((s - i as f64 * lb - shift + h) / (2.0 * h)),
        }
    };
    let mut raw: Vec<(u16, f64)> = (0..n)
        .map(|i| (limb.bones[i], past(i) - past(i + 1)))
        .collect();
    for i in 1..n {
        let t = past(i);
        if i + 1 < n && t > 0.0 && t < 1.0 {
            raw[i + 1].1 += 0.15 * 4.0 * t * (1.0 - t);
        }
    }
    if let Some(parent) = limb.parent {
        let r = 0.5 * (1.0 - smoothstep(s / (1.5 * h))) * (1.0 + 0.3 * (2.0 * phi).sin()) / 1.3;
        raw.iter_mut().for_each(|e| e.1 *= 1.0 - r);
        raw.push((parent, r));
    }
    let mut row: Vec<(u16, f64)> = raw.into_iter().filter(|e| e.1 > 1e-9).collect();
    row.sort_by_key(|e| e.0);
    let sum: f64 = row.iter().map(|e| e.1).sum();
    row.iter().map(|&(j, w)| (j, w / sum)).collect()
}

fn report(name: &str, body: &Body) {
    let t = std::time::Instant::now();
    let (_, stats) = CorCenters::precompute_with_stats(body, &CorParams::default());
    let influences = body.weights.joints.len() as f64 / body.vertex_count() as f64;
    println!(
        "{name}: {} vertices, {} triangles, {:.2} influences/vertex, precompute {:.1} ms\n  \
         {stats:?}\n  naive O(V·T) would evaluate the similarity {:.2e} times",
        body.vertex_count(),
        body.triangles.len(),
        influences,
        t.elapsed().as_secs_f64() * 1e3,
        stats.vertices as f64 * stats.subtriangles as f64,
    );
}

/// `body` with 52 morph targets, target `k` displacing the 2000 vertices from `300 k` on (as a
/// face's blend shapes each move a part of the head), and 10 of them weighted.
fn with_blend_shapes(body: &Body) -> (Body, Vec<f64>) {
    let n = body.vertex_count() as u32;
    let targets = (0..52u32)
        .map(|k| MorphTarget {
            positions: (300 * k..(300 * k + 2000).min(n))
                .map(|v| (v, Vector3::new(1e-3, 2e-3 * f64::from(k % 3), -1e-3)))
                .collect(),
            normals: Vec::new(),
        })
        .collect();
    let mut morphed = body.clone();
    morphed.morphs = Morphs {
        targets,
        default_weights: vec![0.0; 52],
        normals_from_triangles: false,
    };
    let weights = (0..52)
        .map(|k| if k % 5 == 0 { 0.5 } else { 0.0 })
        .collect();
    (morphed, weights)
}

fn skinning(c: &mut Criterion) {
    let character = Character::new();
    let body = character.body(0.25);
    let dense = character.body(0.45);
    report("character (bands ±25% of a bone)", &body);
    report("dense (bands ±45% of a bone)", &dense);
    let mats = character.pose(0.4);
    let centers = CorCenters::precompute(&body);

    let mut g = c.benchmark_group("frame");
    g.measurement_time(Duration::from_secs(2));
    g.bench_function("lbs_30k", |b| {
        b.iter(|| lbs::skin(black_box(&body), black_box(&mats)))
    });
    g.bench_function("dqs_30k", |b| {
        b.iter(|| dqs::skin(black_box(&body), black_box(&mats)))
    });
    g.bench_function("cor_30k", |b| {
        b.iter(|| cor::skin(black_box(&body), black_box(&centers), black_box(&mats)))
    });
    let (shaped, weights) = with_blend_shapes(&body);
    g.bench_function("morph_then_lbs_30k", |b| {
        b.iter(|| {
            let shape = shaped.morphed(Some(black_box(&weights))).expect("weighted");
            lbs::skin_shape(
                &shaped.weights,
                BindShape::morphed(&shape),
                black_box(&mats),
            )
        })
    });
    g.finish();

    let mut g = c.benchmark_group("cor_precompute");
    g.sampling_mode(SamplingMode::Flat);
    g.measurement_time(Duration::from_secs(6));
    g.bench_function("character_30k", |b| {
        b.iter(|| CorCenters::precompute(black_box(&body)))
    });
    g.bench_function("dense_30k", |b| {
        b.iter(|| CorCenters::precompute(black_box(&dense)))
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500));
    targets = skinning
}
criterion_main!(benches);
