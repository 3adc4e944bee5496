//! Tests of the per-frame error metrics (`src/report/metrics/`, `MEASURING.md` "Error
//! metrics"): fast winding numbers against the brute-force sum, residual penetration against
//! analytic spheres, inverted faces, temporal second differences, exact point-triangle and
//! Hausdorff distances, and non-finite inputs. Every mesh is generated here.
//!
//! `cargo test --release --test metrics -- --nocapture` prints the measured accuracy and speed
//! of the fast winding number.

use std::time::Instant;

use contact_skin::mesh::operators::{mean_edge_length, vertex_normals, NormalWeighting};
use contact_skin::mesh::signed_volume;
use contact_skin::report::metrics::{
    closest_point_on_triangle, displacement_step_ratio, hausdorff, inverted_faces, non_finite,
    penetrating_among, penetrating_count, point_triangle_distance, residual_penetration,
    residual_penetration_bodies, second_difference_ratio, solid_angle, surface_distance,
    turned_faces, volume_error, winding_number, zone_distance, Body, InvertedFaces, Penetration,
    TurnedFaces, WindingNumber,
};
use nalgebra::{Point3, Rotation3, Vector3};
use parry3d_f64::math::Vector as PVec;
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::Triangle as PTriangle;
use rayon::prelude::*;

#[path = "common/meshes.rs"]
mod meshes;
#[path = "common/rng.rs"]
mod rng;
use rng::Rng;

type Mesh = (Vec<Point3<f64>>, Vec<[u32; 3]>);

// ---------------------------------------------------------------------------------------------
// Generators
// ---------------------------------------------------------------------------------------------

/// Icosphere: `level` midpoint subdivisions of an icosahedron (20·4^level faces), outward CCW,
/// scaled to `radius` about `center` (the shared generator of `tests/common/meshes.rs`).
fn icosphere(level: u32, radius: f64, center: Point3<f64>) -> Mesh {
    let m = meshes::icosphere(level as usize);
    let pos = m
        .positions
        .iter()
        .map(|p| center + p.coords * radius)
        .collect();
    (pos, m.triangles)
}

/// Capsule along z: a cylinder of half-length `half` capped by hemispheres of `radius`;
/// `seg` vertices per ring, `cap` rings per hemisphere (pole excluded), `body` cylinder spans.
fn capsule(radius: f64, half: f64, seg: u32, cap: u32, body: u32) -> Mesh {
    let mut rings: Vec<(f64, f64)> = Vec::new(); // (z, ring radius)
    for i in 1..=cap {
        let phi = -std::f64::consts::FRAC_PI_2 * (1.0 - i as f64 / cap as f64);
        rings.push((-half + radius * phi.sin(), radius * phi.cos()));
    }
    for i in 1..body {
        rings.push((-half + 2.0 * half * i as f64 / body as f64, radius));
    }
    for i in 0..cap {
        let phi = std::f64::consts::FRAC_PI_2 * (i as f64 / cap as f64);
        rings.push((half + radius * phi.sin(), radius * phi.cos()));
    }
    let mut pos = vec![Point3::new(0.0, 0.0, -half - radius)];
    for &(z, r) in &rings {
        for k in 0..seg {
            let a = 2.0 * std::f64::consts::PI * k as f64 / seg as f64;
            pos.push(Point3::new(r * a.cos(), r * a.sin(), z));
        }
    }
    pos.push(Point3::new(0.0, 0.0, half + radius));
    let top = pos.len() as u32 - 1;
    let ring = |i: u32, k: u32| 1 + i * seg + k % seg;
    let mut tris = Vec::new();
    for k in 0..seg {
        tris.push([0, ring(0, k + 1), ring(0, k)]);
    }
    for i in 0..rings.len() as u32 - 1 {
        for k in 0..seg {
            let (a, b, c, d) = (
                ring(i, k),
                ring(i, k + 1),
                ring(i + 1, k),
                ring(i + 1, k + 1),
            );
            tris.push([a, b, d]);
            tris.push([a, d, c]);
        }
    }
    let last = rings.len() as u32 - 1;
    for k in 0..seg {
        tris.push([top, ring(last, k), ring(last, k + 1)]);
    }
    (pos, tris)
}

/// Torus around z (major radius `big`, tube radius `small`), `nu × nv` quads, outward CCW.
fn torus(big: f64, small: f64, nu: u32, nv: u32) -> Mesh {
    let mut pos = Vec::new();
    for i in 0..nu {
        let u = 2.0 * std::f64::consts::PI * i as f64 / nu as f64;
        for j in 0..nv {
            let v = 2.0 * std::f64::consts::PI * j as f64 / nv as f64;
            let r = big + small * v.cos();
            pos.push(Point3::new(r * u.cos(), r * u.sin(), small * v.sin()));
        }
    }
    let id = |i: u32, j: u32| (i % nu) * nv + j % nv;
    let mut tris = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i, j + 1), id(i + 1, j + 1));
            tris.push([a, b, d]);
            tris.push([a, d, c]);
        }
    }
    (pos, tris)
}

fn concat(a: &Mesh, b: &Mesh) -> Mesh {
    let mut pos = a.0.clone();
    pos.extend_from_slice(&b.0);
    let off = a.0.len() as u32;
    let mut tris = a.1.clone();
    tris.extend(b.1.iter().map(|t| t.map(|i| i + off)));
    (pos, tris)
}

/// Brute-force distance from `p` to the mesh (all faces).
fn brute_distance(p: &Point3<f64>, m: &Mesh) -> f64 {
    m.1.iter()
        .map(|t| point_triangle_distance(p, &t.map(|i| m.0[i as usize])))
        .fold(f64::INFINITY, f64::min)
}

// ---------------------------------------------------------------------------------------------
// Winding number
// ---------------------------------------------------------------------------------------------

/// Checks the fast winding number against the brute force at random points in a box around the
/// mesh and in a thin shell around its vertices; returns the largest error.
fn check_fast_winding(name: &str, m: &Mesh, inside: impl Fn(&Point3<f64>) -> Option<bool>) -> f64 {
    let h = mean_edge_length(&m.0, &m.1);
    let fast = WindingNumber::new(&m.0, &m.1);
    assert_eq!(fast.skipped_faces(), 0);
    let (lo, hi) =
        m.0.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.x.min(p.y).min(p.z)), hi.max(p.x.max(p.y).max(p.z)))
            });
    let pad = 0.3 * (hi - lo);
    let mut rng = Rng(0x5eed ^ m.1.len() as u64);
    let mut qs: Vec<Point3<f64>> = (0..1500)
        .map(|_| rng.point_in_box(lo - pad, hi + pad))
        .collect();
    // Near the surface: vertices displaced by up to 0.5 h, and the vertices themselves.
    for k in 0..1500 {
        let v = m.0[(rng.next_u64() % m.0.len() as u64) as usize];
        let s = if k % 10 == 0 {
            0.0
        } else {
            rng.range(0.0, 0.5 * h)
        };
        qs.push(v + rng.unit() * s);
    }
    let w_fast = fast.query_many(&qs);
    let results: Vec<(f64, f64, f64)> = qs
        .par_iter()
        .zip(&w_fast)
        .map(|(q, &wf)| (winding_number(&m.0, &m.1, q), wf, brute_distance(q, m)))
        .collect();
    let mut max_err: f64 = 0.0;
    let mut classified = 0;
    for (q, &(wb, wf, d)) in qs.iter().zip(&results) {
        assert!(wf.is_finite() && wb.is_finite());
        let err = (wf - wb).abs();
        max_err = max_err.max(err);
        assert!(err < 1e-2, "{name}: fast {wf} vs brute {wb} at {q:?}");
        if d > 0.1 * h {
            // Off the surface the brute force is an integer, and the fast one rounds to it.
            let truth = wb.round();
            assert!((wb - truth).abs() < 1e-6, "{name}: brute {wb} at {q:?}");
            assert!(truth == 0.0 || truth == 1.0);
            assert_eq!((wf > 0.5), (truth == 1.0), "{name}: fast {wf} at {q:?}");
            if let Some(inside) = inside(q) {
                assert_eq!(inside, truth == 1.0, "{name}: analytic at {q:?}");
            }
            classified += 1;
        }
    }
    assert!(classified > 2000);
    println!(
        "{name}: {} faces, {} queries ({classified} off the surface): max |fast - brute| = {max_err:.2e}",
        m.1.len(),
        qs.len()
    );
    max_err
}

#[test]
fn fast_winding_number_matches_the_brute_force_sum() {
    let sphere = icosphere(3, 1.0, Point3::new(0.1, -0.2, 0.3));
    let h = mean_edge_length(&sphere.0, &sphere.1);
    let c = Point3::new(0.1, -0.2, 0.3);
    // The polyhedron lies between radius 1 - sagitta and 1: decide only clear cases.
    check_fast_winding("icosphere", &sphere, |q| {
        let r = (q - c).norm();
        (r < 1.0 - 0.1 * h || r > 1.0 + 0.01 * h).then_some(r < 1.0)
    });
    let cap = capsule(0.5, 1.0, 32, 8, 12);
    assert!(signed_volume(&cap.0, &cap.1) > 0.0);
    check_fast_winding("capsule", &cap, |_| None);
    let tor = torus(1.0, 0.35, 48, 16);
    assert!(signed_volume(&tor.0, &tor.1) > 0.0);
    check_fast_winding("torus", &tor, |_| None);
}

#[test]
fn winding_number_is_one_inside_zero_outside_and_counts_overlaps() {
    let (pos, tris) = icosphere(2, 1.0, Point3::origin());
    assert!((winding_number(&pos, &tris, &Point3::origin()) - 1.0).abs() < 1e-12);
    assert!(winding_number(&pos, &tris, &Point3::new(3.0, 0.2, 0.1)).abs() < 1e-12);
    // Reversed orientation: -1.
    let rev: Vec<[u32; 3]> = tris.iter().map(|t| [t[0], t[2], t[1]]).collect();
    assert!((winding_number(&pos, &rev, &Point3::origin()) + 1.0).abs() < 1e-12);
    // Two overlapping spheres: 2 in the lens.
    let two = concat(
        &icosphere(2, 1.0, Point3::origin()),
        &icosphere(2, 1.0, Point3::new(1.0, 0.0, 0.0)),
    );
    let q = Point3::new(0.5, 0.0, 0.0);
    assert!((winding_number(&two.0, &two.1, &q) - 2.0).abs() < 1e-12);
    assert!((WindingNumber::new(&two.0, &two.1).query(&q) - 2.0).abs() < 1e-2);
    // Solid angle of one octant triangle from the origin: 4π / 8.
    let oct = [
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(0.0, 1.0, 0.0),
        Point3::new(0.0, 0.0, 1.0),
    ];
    let octant = solid_angle(&oct, &Point3::origin());
    assert!(
        (octant - std::f64::consts::FRAC_PI_2).abs() < 1e-14,
        "{octant}"
    );
    let behind = solid_angle(&[oct[0], oct[2], oct[1]], &Point3::origin());
    assert!((behind + octant).abs() < 1e-14);
    // On a corner: 0, no NaN.
    assert_eq!(solid_angle(&oct, &oct[0]), 0.0);
}

#[test]
fn fast_winding_number_is_deterministic() {
    let m = capsule(0.4, 0.8, 24, 6, 10);
    let fast = WindingNumber::new(&m.0, &m.1);
    let mut rng = Rng(7);
    let qs: Vec<Point3<f64>> = (0..3000).map(|_| rng.point_in_box(-1.5, 1.5)).collect();
    let a = fast.query_many(&qs);
    let b = WindingNumber::new(&m.0, &m.1).query_many(&qs);
    let c: Vec<f64> = qs.iter().map(|q| fast.query(q)).collect();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(bits(&a), bits(&c));
    // Brute force for β = ∞.
    let exact = WindingNumber::with_beta(&m.0, &m.1, f64::INFINITY);
    for q in qs.iter().take(200) {
        assert!((exact.query(q) - winding_number(&m.0, &m.1, q)).abs() < 1e-12);
    }
}

#[test]
fn fast_winding_number_speedup_on_a_20k_triangle_sphere() {
    let (pos, tris) = icosphere(5, 1.0, Point3::origin());
    assert_eq!(tris.len(), 20480);
    let mut rng = Rng(42);
    let qs: Vec<Point3<f64>> = (0..10_000).map(|_| rng.point_in_box(-1.3, 1.3)).collect();

    let t0 = Instant::now();
    let fast = WindingNumber::new(&pos, &tris);
    let build = t0.elapsed();
    let t0 = Instant::now();
    let w_fast_seq: Vec<f64> = qs.iter().map(|q| fast.query(q)).collect();
    let fast_seq = t0.elapsed();
    let t0 = Instant::now();
    let w_fast = fast.query_many(&qs);
    let fast_par = t0.elapsed();
    assert_eq!(w_fast, w_fast_seq);

    // Brute force: all 10k queries, in parallel (each query is a sequential sum).
    let t0 = Instant::now();
    let w_brute: Vec<f64> = qs
        .par_iter()
        .map(|q| winding_number(&pos, &tris, q))
        .collect();
    let brute_par = t0.elapsed();
    // Single thread on a tenth of the queries, extrapolated.
    let t0 = Instant::now();
    let sub: Vec<f64> = qs[..1000]
        .iter()
        .map(|q| winding_number(&pos, &tris, q))
        .collect();
    let brute_seq = t0.elapsed() * 10;
    assert_eq!(sub[..], w_brute[..1000]);

    let max_err = w_fast
        .iter()
        .zip(&w_brute)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(max_err < 1e-2, "max error {max_err}");
    println!(
        "fast winding number, {} faces, {} queries, {} threads: build {:.1} ms; \
         single thread: fast {:.1} ms vs brute {:.0} ms (x{:.0}); \
         query_many {:.1} ms vs parallel brute {:.0} ms (x{:.0}); max |error| {max_err:.1e}",
        tris.len(),
        qs.len(),
        rayon::current_num_threads(),
        build.as_secs_f64() * 1e3,
        fast_seq.as_secs_f64() * 1e3,
        brute_seq.as_secs_f64() * 1e3,
        brute_seq.as_secs_f64() / fast_seq.as_secs_f64(),
        fast_par.as_secs_f64() * 1e3,
        brute_par.as_secs_f64() * 1e3,
        brute_par.as_secs_f64() / fast_par.as_secs_f64(),
    );
}

// ---------------------------------------------------------------------------------------------
// Residual penetration
// ---------------------------------------------------------------------------------------------

fn normals(m: &Mesh) -> Vec<Vector3<f64>> {
    vertex_normals(&m.0, &m.1, NormalWeighting::Angle)
}

/// Two overlapping spheres (different resolutions, B rotated so the meshes are not aligned).
fn overlapping_spheres() -> (Mesh, Mesh, [(Point3<f64>, f64); 2]) {
    let ca = Point3::origin();
    let cb = Point3::new(1.4, 0.1, -0.05);
    let a = icosphere(4, 1.0, ca);
    let rot = Rotation3::from_euler_angles(0.3, 0.7, -0.2);
    let (pb, tb) = icosphere(3, 0.9, Point3::origin());
    let pb = pb.iter().map(|p| cb + rot * p.coords).collect();
    (a, (pb, tb), [(ca, 1.0), (cb, 0.9)])
}

/// Analytic check of the flags and depths of a scene of two spheres, whose vertices `0..na` lie
/// on sphere 0 and the rest on sphere 1; vertices in `skip` are not checked. Each flagged
/// vertex's depth is checked against its analytic depth within `depth_tol`. Returns
/// (checked vertices, analytic max depth).
fn check_against_spheres(
    scene: &Mesh,
    na: usize,
    spheres: &[(Point3<f64>, f64); 2],
    h: f64,
    pen: &Penetration,
    skip: &[u32],
    depth_tol: f64,
) -> (usize, f64) {
    let mut checked = 0;
    let mut analytic_max: f64 = 0.0;
    for (v, p) in scene.0.iter().enumerate() {
        let (c, r) = spheres[if v < na { 1 } else { 0 }];
        let dist = (p - c).norm();
        let inside = dist < r;
        if skip.contains(&(v as u32)) {
            continue;
        }
        if inside {
            analytic_max = analytic_max.max(r - dist);
        }
        let pos = pen.flagged.binary_search(&(v as u32));
        if (dist - r).abs() > 0.1 * h {
            assert_eq!(
                pos.is_ok(),
                inside,
                "vertex {v} at {dist} from the other center"
            );
            checked += 1;
        }
        if let Ok(i) = pos {
            if inside {
                let err = (pen.depths[i] - (r - dist)).abs();
                assert!(
                    err < depth_tol,
                    "vertex {v}: depth {} vs analytic {}",
                    pen.depths[i],
                    r - dist
                );
            }
        }
    }
    (checked, analytic_max)
}

#[test]
fn overlapping_spheres_flag_exactly_the_vertices_inside_the_other_sphere() {
    let (a, b, spheres) = overlapping_spheres();
    let scene = concat(&a, &b);
    let n = [normals(&a), normals(&b)].concat();
    let h = mean_edge_length(&scene.0, &scene.1);
    let pen = residual_penetration(&scene.0, &scene.1, &n, h);
    assert_eq!(pen.skipped, 0);
    assert_eq!(pen.vertices, pen.flagged.len());
    assert_eq!(pen.depths.len(), pen.flagged.len());
    assert!(pen.flagged.windows(2).all(|w| w[0] < w[1]));
    // The polyhedra lie inside their spheres by at most a sagitta (< 0.01 h here).
    let (checked, analytic_max) =
        check_against_spheres(&scene, a.0.len(), &spheres, h, &pen, &[], 0.05 * h);
    assert!(pen.vertices > 100, "{} flagged", pen.vertices);
    assert!(checked > scene.0.len() * 9 / 10);
    let rel = (pen.max_depth - analytic_max).abs() / analytic_max;
    println!(
        "overlapping spheres: {} of {} vertices flagged, max depth {:.4} vs analytic {:.4} ({:.2} %), h = {h:.4}",
        pen.vertices,
        scene.0.len(),
        pen.max_depth,
        analytic_max,
        100.0 * rel
    );
    assert!(rel < 0.02);

    // The list-of-bodies form gives the same answer.
    let (na, nb) = (normals(&a), normals(&b));
    let bodies: [Body; 2] = [(&a.0, &a.1, &na), (&b.0, &b.1, &nb)];
    assert_eq!(residual_penetration_bodies(&bodies, h), pen);
    // The count without depths flags the same vertices, with `h` given or from the scene's
    // own edges.
    assert_eq!(penetrating_count(&scene.0, &scene.1, &n, h), pen.vertices);
    let fallback = residual_penetration(&scene.0, &scene.1, &n, f64::NAN).vertices;
    assert_eq!(
        penetrating_count(&scene.0, &scene.1, &n, f64::NAN),
        fallback
    );
    assert_eq!(penetrating_count(&a.0, &a.1, &na, h), 0, "one sphere alone");
    // Restricted to some vertices, on a tree of either accuracy (the further sweeps' form,
    // with the folds' β = 1.5): the flagged vertices among them, and all of them among all.
    let even: Vec<bool> = (0..scene.0.len()).map(|v| v % 2 == 0).collect();
    let flagged_even: Vec<u32> = pen.flagged.iter().copied().filter(|v| v % 2 == 0).collect();
    assert!(!flagged_even.is_empty() && flagged_even.len() < pen.vertices);
    for beta in [2.0, 1.5] {
        let tree = WindingNumber::with_beta(&scene.0, &scene.1, beta);
        let among = |flags: &[bool]| penetrating_among(&tree, &scene.0, &scene.1, &n, h, flags);
        assert_eq!(among(&even), flagged_even, "beta {beta}");
        assert_eq!(
            among(&vec![true; scene.0.len()]),
            pen.flagged,
            "beta {beta}"
        );
        assert!(among(&[]).is_empty(), "no vertex asked");
    }
}

#[test]
fn self_contact_in_one_component_uses_the_facing_side_for_depth() {
    // The two overlapping spheres joined into one connected component: a vertex of B is moved
    // exactly onto a vertex of A near the intersection circle (a pinch), so the depth of a
    // flagged vertex must come from its own component's faces that face it (the other sphere's).
    let (a, mut b, spheres) = overlapping_spheres();
    // The closest pair of vertices of the two meshes (on the intersection curve): the move is
    // a small fraction of an edge.
    let (ia, ib) = (0..a.0.len())
        .flat_map(|i| (0..b.0.len()).map(move |j| (i, j)))
        .min_by(|&(i, j), &(k, l)| {
            (a.0[i] - b.0[j])
                .norm()
                .total_cmp(&(a.0[k] - b.0[l]).norm())
        })
        .unwrap_or((0, 0));
    let moved = (a.0[ia] - b.0[ib]).norm();
    b.0[ib] = a.0[ia];
    let scene = concat(&a, &b);
    let n = [normals(&a), normals(&b)].concat();
    let h = mean_edge_length(&scene.0, &scene.1);
    let pen = residual_penetration(&scene.0, &scene.1, &n, h);
    // Do not check the vertices near the pinch (B's faces there moved by up to half an edge).
    let pinch = a.0[ia];
    let hb = mean_edge_length(&b.0, &b.1);
    let skip: Vec<u32> = (0..scene.0.len() as u32)
        .filter(|&v| (scene.0[v as usize] - pinch).norm() < 2.0 * hb)
        .collect();
    let (checked, analytic_max) =
        check_against_spheres(&scene, a.0.len(), &spheres, h, &pen, &skip, 0.05 * h);
    assert!(checked > scene.0.len() * 9 / 10);
    let rel = (pen.max_depth - analytic_max).abs() / analytic_max;
    println!(
        "pinched spheres (one component, pinch moved {moved:.4}): {} flagged, max depth {:.4} vs analytic {:.4} ({:.2} %)",
        pen.vertices,
        pen.max_depth,
        analytic_max,
        100.0 * rel
    );
    assert!(rel < 0.02);
}

#[test]
fn separate_spheres_and_a_single_body_have_no_penetration() {
    let a = icosphere(3, 1.0, Point3::origin());
    let h = mean_edge_length(&a.0, &a.1);
    // Gap of half an edge between the spheres.
    let b = icosphere(3, 0.8, Point3::new(1.8 + 0.5 * h, 0.0, 0.0));
    let scene = concat(&a, &b);
    let n = [normals(&a), normals(&b)].concat();
    let pen = residual_penetration(&scene.0, &scene.1, &n, h);
    assert_eq!(pen.vertices, 0);
    assert_eq!(pen.max_depth, 0.0);
    assert!(pen.flagged.is_empty());

    // One body alone: every nudged vertex has winding number 1.
    let cap = capsule(0.5, 1.0, 32, 8, 12);
    let hc = mean_edge_length(&cap.0, &cap.1);
    let nc = normals(&cap);
    let pen = residual_penetration(&cap.0, &cap.1, &nc, hc);
    assert_eq!(pen, Default::default());
    let fast = WindingNumber::new(&cap.0, &cap.1);
    let nudged: Vec<Point3<f64>> = cap
        .0
        .iter()
        .zip(&nc)
        .map(|(p, n)| p - n * (0.05 * hc))
        .collect();
    for (q, w) in nudged.iter().zip(fast.query_many(&nudged)) {
        assert!((w - 1.0).abs() < 1e-2, "{w}");
        assert!((winding_number(&cap.0, &cap.1, q) - 1.0).abs() < 1e-6);
    }
}

#[test]
fn penetration_skips_non_finite_vertices_and_normals() {
    let (a, b, _) = overlapping_spheres();
    let mut scene = concat(&a, &b);
    let mut n = [normals(&a), normals(&b)].concat();
    let h = mean_edge_length(&scene.0, &scene.1);
    let clean = residual_penetration(&scene.0, &scene.1, &n, h);
    scene.0[5] = Point3::new(f64::NAN, 0.0, 0.0);
    n[7] = Vector3::new(f64::INFINITY, 0.0, 0.0);
    n[9] = Vector3::zeros();
    n.truncate(n.len() - 1); // the last vertex has no normal
    let pen = residual_penetration(&scene.0, &scene.1, &n, h);
    assert_eq!(pen.skipped, 4);
    assert!(pen.max_depth.is_finite());
    assert!(pen.depths.iter().all(|d| d.is_finite()));
    // Holes of a few faces on A's far side change nothing in the overlap.
    assert!(pen.vertices.abs_diff(clean.vertices) <= 4);
    assert!((pen.max_depth - clean.max_depth).abs() < 1e-9);
    // Invalid h falls back to the scene's edge length; garbage triangles are ignored.
    let mut tris = scene.1.clone();
    tris.push([0, 1, u32::MAX]);
    let pen2 = residual_penetration(&scene.0, &tris, &n, f64::NAN);
    assert!(pen2.max_depth.is_finite());
    let all_nan = vec![Point3::new(f64::NAN, f64::NAN, f64::NAN); 3];
    let pen3 = residual_penetration(&all_nan, &[[0, 1, 2]], &[], 1.0);
    assert_eq!(pen3.skipped, 3);
    assert_eq!(pen3.vertices, 0);
    assert_eq!(residual_penetration(&[], &[], &[], 0.0), Default::default());
}

// ---------------------------------------------------------------------------------------------
// Volume, inverted faces, smoothness
// ---------------------------------------------------------------------------------------------

#[test]
fn volume_error_is_relative_and_guarded() {
    let (pos, tris) = icosphere(3, 1.0, Point3::origin());
    let v0 = signed_volume(&pos, &tris);
    let scaled: Vec<Point3<f64>> = pos.iter().map(|p| p * 1.001).collect();
    let v1 = signed_volume(&scaled, &tris);
    assert!((volume_error(v0, v1) - (1.001f64.powi(3) - 1.0)).abs() < 1e-12);
    assert_eq!(volume_error(v0, v0), 0.0);
    assert_eq!(volume_error(-2.0, -1.0), 0.5);
    assert_eq!(volume_error(0.0, 0.0), 0.0);
    assert_eq!(volume_error(0.0, 1.0), f64::INFINITY);
    assert_eq!(volume_error(f64::NAN, 1.0), f64::INFINITY);
    assert_eq!(volume_error(1.0, f64::INFINITY), f64::INFINITY);
}

#[test]
fn inverted_faces_counts_flipped_degenerate_and_invalid_faces_separately() {
    let (pos, tris) = icosphere(2, 1.0, Point3::origin());
    // A soup: every face has its own corners, so faces can be changed one by one.
    let soup_pos: Vec<Point3<f64>> = tris
        .iter()
        .flat_map(|t| t.map(|i| pos[i as usize]))
        .collect();
    let soup_tris: Vec<[u32; 3]> = (0..tris.len() as u32)
        .map(|f| [3 * f, 3 * f + 1, 3 * f + 2])
        .collect();
    let mut out = soup_pos.clone();
    let (mut flipped, mut collapsed, mut broken) = (0, 0, 0);
    for f in 0..soup_tris.len() {
        let b = 3 * f;
        match f % 11 {
            0 => {
                out.swap(b + 1, b + 2); // reversed orientation
                flipped += 1;
            }
            3 => {
                out[b + 2] = out[b]; // collapsed corner
                collapsed += 1;
            }
            5 => {
                out[b] = Point3::new(0.0, f64::NAN, 0.0);
                broken += 1;
            }
            _ => {}
        }
    }
    let r = inverted_faces(&soup_tris, &soup_pos, &out);
    assert_eq!(
        r,
        InvertedFaces {
            inverted: flipped,
            degenerate: collapsed,
            invalid: broken
        }
    );
    // A rotation by less than 90° inverts nothing; a reflection through z = 0 inverts exactly the faces whose
    // normal is closer to ±z than to the xy plane.
    let axis = nalgebra::Unit::new_normalize(Vector3::new(0.3, -1.0, 0.5));
    let rot = Rotation3::from_axis_angle(&axis, 1.5);
    let moved: Vec<Point3<f64>> = pos.iter().map(|p| rot * p).collect();
    assert_eq!(
        inverted_faces(&tris, &pos, &moved),
        InvertedFaces::default()
    );
    let mirrored: Vec<Point3<f64>> = pos.iter().map(|p| Point3::new(p.x, p.y, -p.z)).collect();
    let expected = tris
        .iter()
        .filter(|t| {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            let n = (b - a).cross(&(c - a));
            // The mirrored normal is (-n_x, -n_y, n_z).
            n.z * n.z - n.x * n.x - n.y * n.y < 0.0
        })
        .count();
    assert!(expected > 0);
    assert_eq!(inverted_faces(&tris, &pos, &mirrored).inverted, expected);
    // Out-of-range indices and short position arrays are invalid, not a panic.
    let r = inverted_faces(&[[0, 1, 99]], &pos, &pos[..2]);
    assert_eq!(r.invalid, 1);
}

/// A smooth animation of a sphere: breathing and drifting.
fn smooth_frames(pos: &[Point3<f64>], count: usize) -> Vec<Vec<Point3<f64>>> {
    (0..count)
        .map(|t| {
            let t = t as f64;
            let s = 1.0 + 0.1 * (0.2 * t).sin();
            let shift = Vector3::new(0.01 * t, 0.002 * t * t, 0.0);
            pos.iter()
                .map(|p| Point3::from(p.coords * s + shift))
                .collect()
        })
        .collect()
}

#[test]
fn second_difference_ratio_is_one_on_identical_input_and_finds_a_pop() {
    let (pos, _) = icosphere(2, 1.0, Point3::origin());
    let input = smooth_frames(&pos, 20);
    let same = second_difference_ratio(&input, &input);
    assert_eq!(same.ratio, 1.0);
    assert!(same.input_max > 0.0);
    assert_eq!(same.skipped, 0);

    let mut popped = input.clone();
    popped[7][42] += Vector3::new(0.0, 0.05, 0.0);
    let r = second_difference_ratio(&popped, &input);
    assert!(r.ratio > 2.0, "{r:?}");
    assert_eq!((r.frame, r.vertex), (Some(7), Some(42)));
    assert!(r.output_max > 0.09 && r.output_max < 0.1 + 2.0 * r.input_max);

    // A still input: identical output gives 1, a pop gives a huge ratio.
    let still = vec![pos.clone(); 6];
    assert_eq!(second_difference_ratio(&still, &still).ratio, 1.0);
    let mut jump = still.clone();
    jump[3][0].x += 1e-3;
    let r = second_difference_ratio(&jump, &still);
    assert!(r.ratio > 1e5 && r.ratio.is_finite());
    assert_eq!((r.frame, r.vertex), (Some(3), Some(0)));

    // Non-finite positions are skipped and counted; too few frames give no triple.
    let mut bad = input.clone();
    bad[4][3] = Point3::new(f64::NAN, 0.0, 0.0);
    let r = second_difference_ratio(&bad, &input);
    assert_eq!(r.skipped, 3);
    assert!((r.ratio - 1.0).abs() < 1e-12);
    let r = second_difference_ratio(&input[..2], &input[..2]);
    assert_eq!((r.ratio, r.frame), (1.0, None));
}

/// The displacement-step ratio tells a pop from a kink across frame rates: sampled twice as
/// finely, a displacement continuous in time (a ramp that starts at a kink) keeps its ratio,
/// a jump of the displacement doubles it; the second-difference ratio grows with both.
#[test]
fn displacement_step_ratio_keeps_a_kink_and_grows_with_a_pop() {
    let (pos, _) = icosphere(1, 1.0, Point3::origin());
    // The input translates at unit speed over the animation's unit time; vertex 5 is also
    // displaced by `d(s)` along y.
    let sample = |count: usize, d: &dyn Fn(f64) -> f64| -> [Vec<Vec<Point3<f64>>>; 2] {
        let times = (0..count).map(|k| k as f64 / (count - 1) as f64);
        let input: Vec<Vec<Point3<f64>>> = times
            .clone()
            .map(|s| pos.iter().map(|p| p + Vector3::new(s, 0.0, 0.0)).collect())
            .collect();
        let mut output = input.clone();
        for (frame, s) in output.iter_mut().zip(times) {
            frame[5].y += d(s);
        }
        [output, input]
    };
    let kink = |s: f64| 0.3 * (s - 0.4).max(0.0);
    let pop = |s: f64| if s > 0.4 { 0.05 } else { 0.0 };
    let ratio = |count: usize, d: &dyn Fn(f64) -> f64| {
        let [output, input] = sample(count, d);
        let r = displacement_step_ratio(&output, &input);
        assert_eq!(r.vertex, Some(5), "{r:?}");
        assert_eq!(r.skipped, 0);
        (r, second_difference_ratio(&output, &input).ratio)
    };
    let [(k1, sk1), (k2, sk2)] = [11, 21].map(|n| ratio(n, &kink));
    // The ramp's slope over the input's speed, at both rates.
    assert!(
        (k1.ratio - 0.3).abs() < 1e-9 && (k2.ratio - 0.3).abs() < 1e-9,
        "{k1:?} {k2:?}"
    );
    let [(p1, sp1), (p2, sp2)] = [11, 21].map(|n| ratio(n, &pop));
    // The jump over the input's step: 0.05 / 0.1, then 0.05 / 0.05.
    assert!(
        (p1.ratio - 0.5).abs() < 1e-9 && (p2.ratio - 1.0).abs() < 1e-9,
        "{p1:?} {p2:?}"
    );
    assert_eq!((p1.frame, p2.frame), (Some(4), Some(8)));
    // A translating input has no second difference: both kinds of event give huge
    // second-difference ratios, which do not tell them apart.
    assert!(sk1 > 1e5 && sk2 > 1e5 && sp1 > 1e5 && sp2 > 1e5);

    // Identical sequences: no step, ratio 0; a still input: 1 without a step, huge with one.
    let [output, input] = sample(6, &|_| 0.0);
    let r = displacement_step_ratio(&output, &input);
    assert_eq!((r.ratio, r.output_max), (0.0, 0.0));
    let still = vec![pos.clone(); 4];
    assert_eq!(displacement_step_ratio(&still, &still).ratio, 1.0);
    let mut moved = still.clone();
    moved[2][0].x += 1e-3;
    let r = displacement_step_ratio(&moved, &still);
    assert!(r.ratio > 1e5 && r.ratio.is_finite(), "{r:?}");
    assert_eq!((r.frame, r.vertex), (Some(1), Some(0)));

    // Non-finite positions are skipped and counted (the two pairs the frame belongs to);
    // a single frame has no pair.
    let mut bad = output.clone();
    bad[3][7] = Point3::new(f64::NAN, 0.0, 0.0);
    let r = displacement_step_ratio(&bad, &input);
    assert_eq!((r.skipped, r.ratio), (2, 0.0));
    let r = displacement_step_ratio(&output[..1], &input[..1]);
    assert_eq!((r.ratio, r.frame), (1.0, None));
}

// ---------------------------------------------------------------------------------------------
// Distances
// ---------------------------------------------------------------------------------------------

#[test]
fn point_triangle_distance_matches_the_analytic_cases_and_parry() {
    let t = [
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(0.0, 1.0, 0.0),
    ];
    let d = |x: f64, y: f64, z: f64| point_triangle_distance(&Point3::new(x, y, z), &t);
    // Above the face.
    assert!((d(0.2, 0.3, 0.7) - 0.7).abs() < 1e-15);
    assert!((d(0.2, 0.3, -0.4) - 0.4).abs() < 1e-15);
    // Near an edge (y = 0, and the hypotenuse).
    assert!((d(0.5, -0.3, 0.4) - 0.5).abs() < 1e-15);
    assert!((d(1.0, 1.0, 0.0) - 0.5f64.sqrt()).abs() < 1e-15);
    // Near a vertex.
    assert!((d(-0.3, -0.4, 0.0) - 0.5).abs() < 1e-15);
    assert!((d(1.3, -0.1, 0.2) - (0.09f64 + 0.01 + 0.04).sqrt()).abs() < 1e-15);
    // In the plane, inside: 0.
    assert_eq!(d(0.25, 0.25, 0.0), 0.0);
    // Degenerate (collinear) triangle: the segment.
    let line = [
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(2.0, 0.0, 0.0),
    ];
    assert!((point_triangle_distance(&Point3::new(1.5, 2.0, 0.0), &line) - 2.0).abs() < 1e-15);
    assert!((point_triangle_distance(&Point3::new(3.0, 0.0, 0.0), &line) - 1.0).abs() < 1e-15);
    let dot = [Point3::new(1.0, 1.0, 1.0); 3];
    assert!((point_triangle_distance(&Point3::new(1.0, 1.0, 3.0), &dot) - 2.0).abs() < 1e-15);
    // Non-finite: infinity, no NaN.
    assert_eq!(d(f64::NAN, 0.0, 0.0), f64::INFINITY);
    assert!(closest_point_on_triangle(&Point3::new(0.0, f64::INFINITY, 0.0), &t).is_none());

    // Random triangles and points against parry.
    let mut rng = Rng(99);
    let pv = |p: &Point3<f64>| PVec::new(p.x, p.y, p.z);
    for _ in 0..20_000 {
        let tri = [0; 3].map(|_| rng.point_in_box(-1.0, 1.0));
        let p = rng.point_in_box(-2.0, 2.0);
        let ours = point_triangle_distance(&p, &tri);
        let reference = PTriangle::new(pv(&tri[0]), pv(&tri[1]), pv(&tri[2]))
            .distance_to_local_point(pv(&p), true);
        assert!((ours - reference).abs() < 1e-9, "{ours} vs {reference}");
        let c = closest_point_on_triangle(&p, &tri).unwrap_or(Point3::origin());
        assert!(((p - c).norm() - ours).abs() < 1e-15);
    }
}

#[test]
fn surface_distance_is_the_exact_minimum_over_the_given_faces() {
    let m = icosphere(3, 1.0, Point3::origin());
    // The faces of the upper hemisphere only.
    let faces: Vec<u32> = (0..m.1.len() as u32)
        .filter(|&f| m.1[f as usize].iter().all(|&i| m.0[i as usize].z > 0.0))
        .collect();
    let mut rng = Rng(3);
    let mut points: Vec<Point3<f64>> = (0..500).map(|_| rng.point_in_box(-2.0, 2.0)).collect();
    points.push(Point3::new(f64::NAN, 0.0, 0.0));
    let d = surface_distance(&points, &m.0, &m.1, &faces);
    for (p, &dist) in points.iter().zip(&d).take(500) {
        let brute = faces
            .iter()
            .map(|&f| point_triangle_distance(p, &m.1[f as usize].map(|i| m.0[i as usize])))
            .fold(f64::INFINITY, f64::min);
        assert_eq!(dist, brute);
    }
    assert_eq!(d[500], f64::INFINITY);
    // Point below the south pole: the nearest faces are at the rim of the hemisphere.
    let south = surface_distance(&[Point3::new(0.0, 0.0, -2.0)], &m.0, &m.1, &faces)[0];
    assert!(south > 5f64.sqrt() - 1e-9 && south < 2.5, "{south}");
    // No face (or only invalid ids): infinity.
    assert_eq!(
        surface_distance(&[Point3::origin()], &m.0, &m.1, &[]),
        vec![f64::INFINITY]
    );
    assert_eq!(
        surface_distance(&[Point3::origin()], &m.0, &m.1, &[u32::MAX]),
        vec![f64::INFINITY]
    );
}

#[test]
fn hausdorff_of_a_sphere_and_a_scaled_sphere_is_the_radius_difference() {
    let a = icosphere(4, 1.0, Point3::origin());
    let b: Mesh = (a.0.iter().map(|p| p * 1.1).collect(), a.1.clone());
    let h = hausdorff(&a.0, &a.1, &b.0, &b.1);
    assert!((h - 0.1).abs() < 2e-3, "{h}");
    assert_eq!(h, hausdorff(&b.0, &b.1, &a.0, &a.1));
    assert_eq!(hausdorff(&a.0, &a.1, &a.0, &a.1), 0.0);
    // Another tessellation and orientation: the radius difference up to the sagittas.
    let rot = Rotation3::from_euler_angles(0.1, 0.2, 0.3);
    let c = icosphere(3, 1.05, Point3::origin());
    let c: Mesh = (c.0.iter().map(|p| rot * p).collect(), c.1);
    let hc = hausdorff(&a.0, &a.1, &c.0, &c.1);
    assert!((hc - 0.05).abs() < 0.01, "{hc}");
    // A contact zone against itself: 0; against its offset copy: the offset.
    let faces: Vec<u32> = (0..40).collect();
    assert_eq!(zone_distance(&a.0, &a.1, &faces, &a.0, &a.1, &faces), 0.0);
    let up: Vec<Point3<f64>> =
        a.0.iter()
            .map(|p| p + Vector3::new(0.0, 0.0, 1e-3))
            .collect();
    let z = zone_distance(&a.0, &a.1, &faces, &up, &a.1, &faces);
    assert!(z > 0.0 && z <= 1e-3 + 1e-12);
    assert_eq!(
        zone_distance(&a.0, &a.1, &faces, &up, &a.1, &[]),
        f64::INFINITY
    );
    assert_eq!(zone_distance(&a.0, &a.1, &[], &up, &a.1, &[]), 0.0);
    // Non-finite vertices are skipped.
    let mut bad = b.clone();
    bad.0[0] = Point3::new(f64::NAN, 1.0, 1.0);
    // (its faces are dropped: the hole's rim is within an edge length of the vertex)
    let hb = hausdorff(&a.0, &a.1, &bad.0, &bad.1);
    let edge = mean_edge_length(&b.0, &b.1);
    assert!(hb.is_finite() && hb >= h - 1e-12 && hb < 0.1 + edge, "{hb}");
    assert_eq!(hausdorff(&a.0, &a.1, &[], &[]), f64::INFINITY);
    assert_eq!(hausdorff(&[], &[], &[], &[]), 0.0);
}

#[test]
fn non_finite_inputs_are_counted_and_never_produce_nan() {
    let (mut pos, tris) = icosphere(2, 1.0, Point3::origin());
    assert_eq!(non_finite(&pos), 0);
    pos[3] = Point3::new(f64::NAN, 0.0, 0.0);
    pos[8] = Point3::new(0.0, f64::INFINITY, 0.0);
    pos[9] = Point3::new(0.0, 0.0, f64::NEG_INFINITY);
    assert_eq!(non_finite(&pos), 3);
    let fast = WindingNumber::new(&pos, &tris);
    assert_eq!(
        fast.skipped_faces(),
        tris.iter()
            .filter(|t| t.iter().any(|&i| [3, 8, 9].contains(&i)))
            .count()
    );
    let mut rng = Rng(11);
    let mut qs: Vec<Point3<f64>> = (0..500).map(|_| rng.point_in_box(-1.5, 1.5)).collect();
    qs.extend(pos.iter().copied());
    qs.push(Point3::new(f64::NAN, f64::NAN, f64::NAN));
    for (q, w) in qs.iter().zip(fast.query_many(&qs)) {
        assert!(w.is_finite());
        assert!(winding_number(&pos, &tris, q).is_finite());
    }
    assert_eq!(fast.query(&Point3::new(f64::NAN, 0.0, 0.0)), 0.0);
    // Huge but finite coordinates: no NaN either.
    let huge: Vec<Point3<f64>> = pos
        .iter()
        .map(|p| if p.x.is_finite() { p * 1e200 } else { *p })
        .collect();
    let far = WindingNumber::new(&huge, &tris);
    for q in &qs {
        assert!(far.query(q).is_finite());
    }
    let d = surface_distance(
        &qs,
        &huge,
        &tris,
        &(0..tris.len() as u32).collect::<Vec<_>>(),
    );
    assert!(d.iter().all(|x| !x.is_nan()));
    assert!(!hausdorff(&pos, &tris, &huge, &tris).is_nan());
    // Empty surfaces.
    assert_eq!(WindingNumber::new(&[], &[]).query(&Point3::origin()), 0.0);
    assert_eq!(winding_number(&[], &[[0, 1, 2]], &Point3::origin()), 0.0);
}

/// `WindingNumber::refit` after a deformation agrees with a tree built from scratch on the new
/// positions (both within the fast method's accuracy of the exact sum).
#[test]
fn refitted_winding_tree_matches_a_rebuilt_one() {
    let s = icosphere(4, 1.0, nalgebra::Point3::origin());
    let mut tree = contact_skin::report::metrics::WindingNumber::new(&s.0, &s.1);
    let moved: Vec<nalgebra::Point3<f64>> =
        s.0.iter()
            .map(|p| nalgebra::Point3::new(p.x * 1.3 + 0.2 * p.y * p.y, p.y * 0.8, p.z + 0.1 * p.x))
            .collect();
    assert!(tree.refit(&moved, &s.1));
    let fresh = contact_skin::report::metrics::WindingNumber::new(&moved, &s.1);
    let mut worst: f64 = 0.0;
    for i in 0..2000 {
        let t = i as f64 * 0.618_033_988_75;
        let q = nalgebra::Point3::new(
            1.6 * (t.sin()),
            1.2 * ((2.0 * t).cos()),
            1.4 * ((3.0 * t).sin()),
        );
        let exact = contact_skin::report::metrics::winding_number(&moved, &s.1, &q);
        worst = worst.max((tree.query(&q) - exact).abs());
        assert!((fresh.query(&q) - exact).abs() < 1e-2);
    }
    println!("refit: worst error against the exact sum {worst:.2e}");
    assert!(worst < 1e-2);
    let mut bad = moved.clone();
    bad[0].x = f64::NAN;
    assert!(!tree.refit(&bad, &s.1), "a NaN corner is refused");
}

/// `WindingNumber::refit_changed` (only the leaves with a moved corner) gives the bits of a full
/// `refit` at the same positions, over successive moves of parts of the surface (as the folds of
/// one body move one joint's regions after another), from a tree as built (whose inner moments
/// come from their faces, not from merges: its first call refits it whole) and from one refit
/// at rest; and it refuses a NaN corner, keeping its fit (the moves after it found against
/// that fit).
#[test]
fn partial_refit_gives_the_bits_of_a_full_refit() {
    use contact_skin::report::metrics::WindingNumber;
    use nalgebra::Point3;
    let s = icosphere(4, 1.0, Point3::origin());
    let mut partial = WindingNumber::new(&s.0, &s.1);
    let mut refit_at_rest = WindingNumber::new(&s.0, &s.1);
    assert!(refit_at_rest.refit(&s.0, &s.1));
    // Three moves: the cap above y = 0.3 bulges, then the band |z| < 0.2 shifts, then nothing.
    let cap: Vec<Point3<f64>> =
        s.0.iter()
            .map(|p| {
                if p.y > 0.3 {
                    Point3::new(p.x * 1.2, p.y + 0.1, p.z)
                } else {
                    *p
                }
            })
            .collect();
    let band: Vec<Point3<f64>> = cap
        .iter()
        .map(|p| {
            if p.z.abs() < 0.2 {
                Point3::new(p.x + 0.05, p.y, p.z * 0.9)
            } else {
                *p
            }
        })
        .collect();
    let queries: Vec<Point3<f64>> = (0..500)
        .map(|i| {
            let t = i as f64 * 0.618_033_988_75;
            Point3::new(0.8 * t.sin(), 0.8 * (2.0 * t).cos(), 0.8 * (3.0 * t).sin())
        })
        .collect();
    for moved in [&cap, &band, &band] {
        assert!(partial.refit_changed(moved, &s.1));
        assert!(refit_at_rest.refit_changed(moved, &s.1));
        let mut full = WindingNumber::new(&s.0, &s.1);
        assert!(full.refit(moved, &s.1));
        for q in &queries {
            let bits = full.query(q).to_bits();
            assert_eq!(partial.query(q).to_bits(), bits, "at {q}");
            assert_eq!(refit_at_rest.query(q).to_bits(), bits, "at {q}");
        }
    }
    // Some queries land inside, some outside: the comparison is not between zeros.
    let inside = queries.iter().filter(|q| partial.query(q) > 0.5).count();
    assert!(inside > 50 && inside < 450, "{inside} inside");
    let mut bad = band.clone();
    bad[0].x = f64::NAN;
    assert!(
        !partial.refit_changed(&bad, &s.1),
        "a NaN corner is refused"
    );
    let q = Point3::new(0.1, 0.2, 0.3);
    let mut full = WindingNumber::new(&s.0, &s.1);
    assert!(full.refit(&band, &s.1));
    assert_eq!(partial.query(&q).to_bits(), full.query(&q).to_bits());
    // After the refusal the moves are still found against the last fit (the band's): back to
    // the cap alone, the same bits as a full refit there.
    assert!(partial.refit_changed(&cap, &s.1));
    assert!(full.refit(&cap, &s.1));
    for q in &queries {
        assert_eq!(
            partial.query(q).to_bits(),
            full.query(q).to_bits(),
            "at {q}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Turned faces
// ---------------------------------------------------------------------------------------------

/// Unit normal of face `t`.
fn face_normal(p: &[Point3<f64>], t: &[u32; 3]) -> Vector3<f64> {
    let [a, b, c] = t.map(|v| p[v as usize]);
    (b - a).cross(&(c - a)).normalize()
}

/// The mirror `z -> -z` of a face centred on the sphere's centre turns its normal against the
/// input exactly where `n_z² < n_x² + n_y²` (the reflected, reversed normal is
/// `(-n_x, -n_y, n_z)`): the count `turned_faces` must give, and none buried on a single
/// sphere. A sphere whose skinned normals all point inward is turned in the input only.
#[test]
fn turned_faces_against_input_and_skinning() {
    let (p, t) = icosphere(3, 1.0, Point3::origin());
    let h = mean_edge_length(&p, &t);
    let outward = vertex_normals(&p, &t, NormalWeighting::Area);
    assert_eq!(
        turned_faces(&t, &p, &p, &outward, h),
        TurnedFaces::default(),
        "nothing moved"
    );
    let inward: Vec<Vector3<f64>> = outward.iter().map(|n| -n).collect();
    let r = turned_faces(&t, &p, &p, &inward, h);
    assert_eq!(r.input_against_skinning, t.len());
    assert_eq!(
        (r.against_input, r.turned),
        (0, 0),
        "the input itself is not a fault"
    );
    let mirrored: Vec<Point3<f64>> = p.iter().map(|q| Point3::new(q.x, q.y, -q.z)).collect();
    let expected = t
        .iter()
        .filter(|f| {
            let n = face_normal(&p, f);
            n.z * n.z < n.x * n.x + n.y * n.y
        })
        .count();
    assert!(expected > t.len() / 4, "a band round the equator");
    let r = turned_faces(&t, &p, &mirrored, &outward, h);
    assert_eq!(r.against_input, expected);
    assert_eq!(r.turned, expected);
    assert_eq!(r.buried, 0, "a lone sphere has material on one side only");
    assert_eq!(r.exposed(), expected);
}

/// A hollow ball (outer sphere outward, inner sphere inward: a cavity) whose inner sphere is
/// mirrored `z -> -z`: the inner sphere now faces outward inside the outer one, so each of
/// its turned faces has material on both sides (winding 1 in front, 2 behind): all buried.
#[test]
fn turned_faces_inside_material_are_buried() {
    let (outer, to) = icosphere(3, 1.0, Point3::origin());
    let (inner, ti) = icosphere(2, 0.5, Point3::origin());
    let n = outer.len() as u32;
    let mut p = outer.clone();
    p.extend(&inner);
    let mut t = to.clone();
    t.extend(ti.iter().map(|f| [f[0] + n, f[2] + n, f[1] + n]));
    let h = mean_edge_length(&p, &t);
    let skinned = vertex_normals(&p, &t, NormalWeighting::Area);
    let out: Vec<Point3<f64>> = p
        .iter()
        .enumerate()
        .map(|(v, q)| {
            if v < n as usize {
                *q
            } else {
                Point3::new(q.x, q.y, -q.z)
            }
        })
        .collect();
    let expected = t[to.len()..]
        .iter()
        .filter(|f| {
            let m = face_normal(&p, f);
            m.z * m.z < m.x * m.x + m.y * m.y
        })
        .count();
    let r = turned_faces(&t, &p, &out, &skinned, h);
    assert_eq!(r.turned, expected);
    assert_eq!(r.buried, expected);
    assert_eq!(r.exposed(), 0);
}
