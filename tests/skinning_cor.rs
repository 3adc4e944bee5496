//! Center-of-rotation skinning (Le & Hodgins 2016): centers, runtime formula, artifacts that it
//! removes (candy wrapper, elbow volume loss), and the fast precomputation against a brute-force
//! O(V·T) reference.

use contact_skin::rig::{Body, PrimitiveRange, SkinWeights};
use contact_skin::skinning::cor::{self, CorCenters, CorParams};
use contact_skin::skinning::{dqs, lbs, Skinned};
use nalgebra::{Matrix4, Point3, Rotation3, Translation3, Unit, Vector3};
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// Bodies built in code
// ---------------------------------------------------------------------------------------------

/// A body from positions, triangles and weight rows (normals from the triangles).
fn body_from(
    positions: Vec<Point3<f64>>,
    triangles: Vec<[u32; 3]>,
    rows: &[Vec<(u16, f64)>],
) -> Body {
    let mut weights = SkinWeights::with_capacity(rows.len());
    for r in rows {
        weights.push_row(r);
    }
    let mut normals = vec![Vector3::zeros(); positions.len()];
    for t in triangles
        .iter()
        .filter(|t| t.iter().all(|&i| (i as usize) < positions.len()))
    {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(&(c - a));
        for &i in t {
            normals[i as usize] += n;
        }
    }
    for n in &mut normals {
        *n = n.try_normalize(1e-300).unwrap_or_else(Vector3::zeros);
    }
    Body {
        name: "test".into(),
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

/// Normalizes raw weights into a row (positive weights, sorted by joint).
fn row(raw: &[(u16, f64)]) -> Vec<(u16, f64)> {
    let mut r: Vec<(u16, f64)> = raw.iter().copied().filter(|&(_, w)| w > 0.0).collect();
    r.sort_by_key(|&(j, _)| j);
    let s: f64 = r.iter().map(|&(_, w)| w).sum();
    r.iter().map(|&(j, w)| (j, w / s)).collect()
}

/// Geometry of a tube of radius `r` along +y from 0 to `len`: `rings + 1` rings of `segs`
/// vertices, outward-facing side triangles, optional flat caps (center vertices last).
struct Tube {
    r: f64,
    len: f64,
    rings: usize,
    segs: usize,
    caps: bool,
}

impl Tube {
    fn positions(&self) -> Vec<Point3<f64>> {
        let mut p = Vec::new();
        for i in 0..=self.rings {
            let y = self.len * i as f64 / self.rings as f64;
            for k in 0..self.segs {
                let phi = 2.0 * PI * k as f64 / self.segs as f64;
                p.push(Point3::new(self.r * phi.cos(), y, self.r * phi.sin()));
            }
        }
        if self.caps {
            p.push(Point3::new(0.0, 0.0, 0.0));
            p.push(Point3::new(0.0, self.len, 0.0));
        }
        p
    }

    fn triangles(&self) -> Vec<[u32; 3]> {
        let id = |i: usize, k: usize| (i * self.segs + k % self.segs) as u32;
        let mut t = Vec::new();
        for i in 0..self.rings {
            for k in 0..self.segs {
                let (a, b, c, d) = (id(i, k), id(i, k + 1), id(i + 1, k), id(i + 1, k + 1));
                t.push([a, c, b]);
                t.push([b, c, d]);
            }
        }
        if self.caps {
            let (bottom, top) = (
                (self.rings + 1) * self.segs,
                (self.rings + 1) * self.segs + 1,
            );
            for k in 0..self.segs {
                t.push([bottom as u32, id(0, k), id(0, k + 1)]);
                t.push([top as u32, id(self.rings, k + 1), id(self.rings, k)]);
            }
        }
        t
    }
}

/// Two bones along y with the joint at `len / 2`; weights blend smoothly (smoothstep) over
/// `[len/2 - h, len/2 + h]`, single-bone elsewhere.
fn two_bone_tube(tube: &Tube, h: f64) -> Body {
    let positions = tube.positions();
    let joint = tube.len / 2.0;
    let rows: Vec<Vec<(u16, f64)>> = positions
        .iter()
        .map(|p| {
            let t = ((p.y - (joint - h)) / (2.0 * h)).clamp(0.0, 1.0);
            let w1 = t * t * (3.0 - 2.0 * t);
            row(&[(0, 1.0 - w1), (1, w1)])
        })
        .collect();
    body_from(positions, tube.triangles(), &rows)
}

/// The standard test capsule: radius 1, length 8, blend band ±1 around y = 4.
fn standard_tube(caps: bool) -> (Tube, Body) {
    let tube = Tube {
        r: 1.0,
        len: 8.0,
        rings: 64,
        segs: 32,
        caps,
    };
    let body = two_bone_tube(&tube, 1.0);
    (tube, body)
}

/// `T(pivot) R T(-pivot)` for a rotation of `angle` about `axis` through `pivot`.
fn rotation_about(pivot: Point3<f64>, axis: Vector3<f64>, angle: f64) -> Matrix4<f64> {
    let r = Rotation3::from_axis_angle(&Unit::new_normalize(axis), angle).to_homogeneous();
    Translation3::from(pivot.coords).to_homogeneous()
        * r
        * Translation3::from(-pivot.coords).to_homogeneous()
}

/// Child bone bent by `angle` about z through the joint.
fn bend(len: f64, angle: f64) -> Vec<Matrix4<f64>> {
    vec![
        Matrix4::identity(),
        rotation_about(Point3::new(0.0, len / 2.0, 0.0), Vector3::z(), angle),
    ]
}

/// Child bone twisted by `angle` about the tube axis.
fn twist(angle: f64) -> Vec<Matrix4<f64>> {
    vec![
        Matrix4::identity(),
        rotation_about(Point3::origin(), Vector3::y(), angle),
    ]
}

fn signed_volume(p: &[Point3<f64>], tris: &[[u32; 3]]) -> f64 {
    tris.iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| p[i as usize].coords);
            a.dot(&b.cross(&c)) / 6.0
        })
        .sum()
}

fn max_distance(a: &[Point3<f64>], b: &[Point3<f64>]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm())
        .fold(0.0, f64::max)
}

fn is_finite(s: &Skinned) -> bool {
    s.positions
        .iter()
        .all(|p| p.coords.iter().all(|c| c.is_finite()))
        && s.normals.iter().all(|n| n.iter().all(|c| c.is_finite()))
}

// ---------------------------------------------------------------------------------------------
// (1)-(3) runtime formula
// ---------------------------------------------------------------------------------------------

#[test]
fn rest_pose_reproduces_bind_positions() {
    let (_, body) = standard_tube(true);
    let centers = CorCenters::precompute(&body);
    let out = cor::skin(&body, &centers, &[Matrix4::identity(); 2]);
    let err = max_distance(&out.positions, &body.positions);
    assert!(err < 1e-13, "rest pose moved vertices by {err}");
    let nerr = out
        .normals
        .iter()
        .zip(&body.normals)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(nerr < 1e-13, "rest pose changed normals by {nerr}");
}

/// A common rigid motion is that motion; so is a common similarity (joints that also scale:
/// an armature node scaled from centimetres to metres, or 100× the other way), and a bend under
/// a scaled root is the bend scaled. Until 2026-12-05 the offset from a vertex to its center
/// kept its bind size, and the blended vertices of the tube scaled by 0.01 lay up to 0.99 of
/// that offset away.
#[test]
fn common_similarity_is_that_similarity() {
    let (tube, body) = standard_tube(true);
    let centers = CorCenters::precompute(&body);
    let rest_size = body
        .positions
        .iter()
        .map(|p| p.coords.norm())
        .fold(0.0, f64::max);
    // Both joints moved by `m` (its largest stretch `reach`): every vertex goes where `m`
    // takes it, its normal by `m`'s cofactor.
    let follows = |m: Matrix4<f64>, reach: f64| {
        let out = cor::skin(&body, &centers, &[m, m]);
        let expected: Vec<Point3<f64>> = body
            .positions
            .iter()
            .map(|p| m.transform_point(p))
            .collect();
        let err = max_distance(&out.positions, &expected) / (reach * rest_size);
        assert!(err < 1e-12, "{m}: motion error {err:e} of the size");
        let a = m.fixed_view::<3, 3>(0, 0).into_owned();
        let cof = a.try_inverse().expect("invertible").transpose() * a.determinant();
        for (n, n0) in out.normals.iter().zip(&body.normals) {
            assert!((n - (cof * n0).normalize()).norm() < 1e-12);
        }
    };
    let rigid = Translation3::new(0.3, -2.0, 5.0).to_homogeneous()
        * rotation_about(
            Point3::new(1.0, 2.0, 3.0),
            Vector3::new(1.0, 2.0, -0.5),
            2.2,
        );
    for scale in [1.0, 0.01, 100.0] {
        let root = Matrix4::new_scaling(scale);
        follows(root * rigid, scale);
        let bent = bend(tube.len, 1.2);
        let plain = cor::skin(&body, &centers, &bent);
        let scaled = cor::skin(
            &body,
            &centers,
            &bent.iter().map(|m| root * m).collect::<Vec<_>>(),
        );
        let expected: Vec<Point3<f64>> = plain.positions.iter().map(|p| p * scale).collect();
        let err = max_distance(&scaled.positions, &expected) / (scale * rest_size);
        assert!(err < 1e-12, "× {scale}: bend error {err:e} of the size");
    }
    // A common stretch that is not a similarity: the blended stretch is the joints' own.
    follows(
        rigid * Matrix4::new_nonuniform_scaling(&Vector3::new(2.0, 1.0, 0.5)),
        2.0,
    );
}

#[test]
fn single_bone_vertices_are_lbs() {
    let (_, body) = standard_tube(true);
    let centers = CorCenters::precompute(&body);
    let mats = bend(8.0, 1.3);
    let (c, l) = (cor::skin(&body, &centers, &mats), lbs::skin(&body, &mats));
    let mut single = 0;
    for v in 0..body.vertex_count() {
        if body.weights.row_slices(v).0.len() == 1 {
            single += 1;
            assert!(
                centers.centers[v].is_none(),
                "single-bone vertex {v} got a center"
            );
            assert_eq!(c.positions[v], l.positions[v]);
            assert_eq!(c.normals[v], l.normals[v]);
        } else {
            assert!(
                centers.centers[v].is_some(),
                "blended vertex {v} has no center"
            );
        }
    }
    assert!(single > body.vertex_count() / 2);
}

// ---------------------------------------------------------------------------------------------
// (4)-(6) geometry
// ---------------------------------------------------------------------------------------------

#[test]
fn centers_of_a_symmetric_cylinder_lie_on_the_axis_in_the_band() {
    let (tube, body) = standard_tube(false);
    let centers = CorCenters::precompute(&body);
    let (mut worst_axis, mut count) = (0.0f64, 0);
    for (v, c) in centers.centers.iter().enumerate() {
        let Some(c) = c else { continue };
        count += 1;
        worst_axis = worst_axis.max(c.x.hypot(c.z));
        assert!(
            (3.0..=5.0).contains(&c.y),
            "center of vertex {v} at height {} outside the blend band",
            c.y
        );
    }
    println!(
        "{count} centers, max distance to the axis {worst_axis:.3e} (radius {})",
        tube.r
    );
    assert!(count > 0);
    assert!(
        worst_axis < 1e-9 * tube.r,
        "center {worst_axis} away from the axis"
    );
}

/// Smallest distance to the y axis over the side vertices.
fn min_radius(s: &Skinned) -> f64 {
    s.positions
        .iter()
        .map(|p| p.x.hypot(p.z))
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn candy_wrapper_twist_keeps_the_radius() {
    let (tube, body) = standard_tube(false);
    let centers = CorCenters::precompute(&body);
    let mats = twist(150f64.to_radians());
    let r_lbs = min_radius(&lbs::skin(&body, &mats));
    let r_dqs = min_radius(&dqs::skin(&body, &mats));
    let r_cor = min_radius(&cor::skin(&body, &centers, &mats));
    println!(
        "twist 150°: min radius / r: LBS {:.4}, DQS {:.4}, CoR {:.4}",
        r_lbs, r_dqs, r_cor
    );
    assert!(r_lbs < 0.5 * tube.r, "LBS should collapse, got {r_lbs}");
    assert!(r_cor > 0.9 * tube.r, "CoR collapsed to {r_cor}");
    assert!(
        (r_cor - tube.r).abs() < 1e-9,
        "CoR radius {r_cor} should be exactly r here"
    );
}

#[test]
fn bent_capsule_volume_cor_and_dqs_beat_lbs() {
    let (_, body) = standard_tube(true);
    let centers = CorCenters::precompute(&body);
    let v0 = signed_volume(&body.positions, &body.triangles);
    assert!(v0 > 0.0);
    for deg in [90.0f64, 120.0, 150.0] {
        let mats = bend(8.0, deg.to_radians());
        let change = |s: Skinned| (signed_volume(&s.positions, &body.triangles) - v0) / v0;
        let d_lbs = change(lbs::skin(&body, &mats));
        let d_dqs = change(dqs::skin(&body, &mats));
        let d_cor = change(cor::skin(&body, &centers, &mats));
        println!(
            "bend {deg}°: (V-V0)/V0 LBS {:+.3}%, DQS {:+.3}%, CoR {:+.3}%",
            100.0 * d_lbs,
            100.0 * d_dqs,
            100.0 * d_cor
        );
        let (e_lbs, e_dqs, e_cor) = (d_lbs.abs(), d_dqs.abs(), d_cor.abs());
        assert!(
            e_cor < 0.5 * e_lbs,
            "CoR volume error {e_cor} vs LBS {e_lbs}"
        );
        assert!(
            e_dqs < 0.5 * e_lbs,
            "DQS volume error {e_dqs} vs LBS {e_lbs}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// (7) fast precomputation = brute-force O(V·T) reference
// ---------------------------------------------------------------------------------------------

/// A small three-bone tube whose weights vary around the ring, with 1-3 influences, a few
/// abrupt weight changes (forcing deep subdivision) and one vertex off every triangle.
fn irregular_body() -> Body {
    let tube = Tube {
        r: 0.7,
        len: 3.0,
        rings: 9,
        segs: 7,
        caps: true,
    };
    let mut positions = tube.positions();
    let mut rows: Vec<Vec<(u16, f64)>> = positions
        .iter()
        .enumerate()
        .map(|(v, p)| {
            let phi = p.z.atan2(p.x);
            let raw: Vec<(u16, f64)> = (0..3u16)
                .map(|i| {
                    let c = 0.5 + f64::from(i);
                    let g = (-((p.y - c) / 0.55).powi(2)).exp()
                        * (1.0 + 0.3 * (phi + f64::from(i)).cos());
                    (
                        i,
                        if g < 0.03 {
                            0.0
                        } else {
                            g + 0.001 * (v % 5) as f64
                        },
                    )
                })
                .collect();
            row(&raw)
        })
        .collect();
    rows[30] = vec![(2, 1.0)];
    rows[45] = vec![(0, 0.5), (2, 0.5)];
    positions.push(Point3::new(5.0, 5.0, 5.0));
    rows.push(row(&[(0, 0.4), (1, 0.6)]));
    body_from(positions, tube.triangles(), &rows)
}

/// Brute-force centers, independent of the library's code: dense weights, explicit pieces of
/// the `n × n` subdivision with corner-mean weights, centroids and cross-product areas, and the
/// similarity summed over every (vertex, piece) pair.
fn brute_force_centers(body: &Body, joints: usize, params: &CorParams) -> Vec<Option<Point3<f64>>> {
    let dense = |v: usize| {
        let mut w = vec![0.0; joints];
        for (j, x) in body.weights.row(v) {
            w[j] += x;
        }
        w
    };
    let mut pieces: Vec<(Vec<f64>, Point3<f64>, f64)> = Vec::new();
    for t in &body.triangles {
        let p = t.map(|i| body.positions[i as usize].coords);
        let w = t.map(|i| dense(i as usize));
        let dist = |a: &Vec<f64>, b: &Vec<f64>| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let d = dist(&w[0], &w[1])
            .max(dist(&w[1], &w[2]))
            .max(dist(&w[2], &w[0]));
        let n = ((d / params.epsilon).ceil() as usize).clamp(1, params.max_subdivision as usize);
        let at = |i: usize, j: usize| {
            let (b0, b1) = (i as f64 / n as f64, j as f64 / n as f64);
            let b2 = 1.0 - b0 - b1;
            let pos = p[0] * b0 + p[1] * b1 + p[2] * b2;
            let wt: Vec<f64> = (0..joints)
                .map(|k| w[0][k] * b0 + w[1][k] * b1 + w[2][k] * b2)
                .collect();
            (pos, wt)
        };
        let mut push = |c: [(Vector3<f64>, Vec<f64>); 3]| {
            let area = 0.5 * (c[1].0 - c[0].0).cross(&(c[2].0 - c[0].0)).norm();
            let centroid = Point3::from((c[0].0 + c[1].0 + c[2].0) / 3.0);
            let wt = (0..joints)
                .map(|k| (c[0].1[k] + c[1].1[k] + c[2].1[k]) / 3.0)
                .collect();
            pieces.push((wt, centroid, area));
        };
        for i in 0..n {
            for j in 0..n - i {
                push([at(i, j), at(i + 1, j), at(i, j + 1)]);
                if i + j + 2 <= n {
                    push([at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]);
                }
            }
        }
    }
    let s2 = params.sigma * params.sigma;
    (0..body.vertex_count())
        .map(|v| {
            let wv = dense(v);
            let (mut num, mut den) = (Vector3::zeros(), 0.0);
            for (wt, c, a) in &pieces {
                let mut s = 0.0;
                for j in 0..joints {
                    for k in j + 1..joints {
                        let d = wv[j] * wt[k] - wv[k] * wt[j];
                        s += wv[j] * wv[k] * wt[j] * wt[k] * (-d * d / s2).exp();
                    }
                }
                num += c.coords * (s * a);
                den += s * a;
            }
            (den > 0.0).then(|| Point3::from(num / den))
        })
        .collect()
}

#[test]
fn fast_precomputation_matches_brute_force() {
    let body = irregular_body();
    for params in [
        CorParams::default(),
        CorParams {
            sigma: 0.25,
            epsilon: 0.05,
            max_subdivision: 8,
            entry_budget: None,
        },
    ] {
        let (fast, stats) = CorCenters::precompute_with_stats(&body, &params);
        let reference = brute_force_centers(&body, 3, &params);
        println!("{params:?}: {stats:?}");
        assert!(
            stats.subtriangles > 4 * body.triangles.len(),
            "expected deep subdivision"
        );
        let (mut compared, mut worst) = (0, 0.0f64);
        for (v, (f, r)) in fast.centers.iter().zip(&reference).enumerate() {
            match (f, r) {
                (Some(f), Some(r)) => {
                    compared += 1;
                    let err = (f - r).norm() / r.coords.norm().max(1.0);
                    worst = worst.max(err);
                    assert!(
                        err < 1e-12,
                        "vertex {v}: fast {f} vs reference {r} ({err:e})"
                    );
                }
                (None, None) => {}
                _ => panic!("vertex {v}: fast {f:?} vs reference {r:?}"),
            }
        }
        println!("{compared} centers, max relative deviation from brute force {worst:.2e}");
        assert!(
            compared > body.vertex_count() / 2,
            "only {compared} centers"
        );
        // A vertex on no triangle still has similar triangles elsewhere.
        assert!(
            fast.centers.last().is_some_and(Option::is_some),
            "isolated vertex"
        );
    }
}

#[test]
fn similarity_matches_the_dense_formula() {
    let p: (&[u16], &[f64]) = (&[1, 4, 7], &[0.2, 0.5, 0.3]);
    let v: (&[u16], &[f64]) = (&[0, 4, 7, 1], &[0.1, 0.3, 0.4, 0.2]);
    let wp: [f64; 8] = [0.0, 0.2, 0.0, 0.0, 0.5, 0.0, 0.0, 0.3];
    let wv: [f64; 8] = [0.1, 0.2, 0.0, 0.0, 0.3, 0.0, 0.0, 0.4];
    let mut s = 0.0;
    for j in 0..8 {
        for k in j + 1..8 {
            let d = wp[j] * wv[k] - wp[k] * wv[j];
            s += wp[j] * wp[k] * wv[j] * wv[k] * (-d * d / 0.01).exp();
        }
    }
    let fast = cor::similarity(p, v, 0.1);
    assert!((fast - s).abs() < 1e-15 * s, "{fast} vs {s}");
    assert_eq!(cor::similarity(p, (&[4], &[1.0]), 0.1), 0.0);
}

#[test]
fn precomputation_does_not_depend_on_the_thread_count() {
    let body = irregular_body();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("pool");
    let a = one.install(|| CorCenters::precompute(&body));
    let b = two.install(|| CorCenters::precompute(&body));
    assert_eq!(a.centers, b.centers);
}

#[test]
fn seam_copies_get_the_same_center() {
    // Duplicate every vertex of ring 5 (a UV seam): same weights, different ids.
    let (_, mut body) = standard_tube(false);
    let base = body.vertex_count();
    let ring: Vec<usize> = (5 * 32..6 * 32).collect();
    let (mut positions, mut normals) = (body.positions.clone(), body.normals.clone());
    let mut rows: Vec<Vec<(u16, f64)>> = (0..base)
        .map(|v| body.weights.row(v).map(|(j, w)| (j as u16, w)).collect())
        .collect();
    for &v in &ring {
        positions.push(body.positions[v]);
        normals.push(body.normals[v]);
        rows.push(rows[v].clone());
    }
    body = body_from(positions, body.triangles.clone(), &rows);
    let (centers, stats) = CorCenters::precompute_with_stats(&body, &CorParams::default());
    assert!(stats.unique_rows < stats.blended_vertices);
    for (i, &v) in ring.iter().enumerate() {
        assert_eq!(centers.centers[v], centers.centers[base + i]);
    }
}

// ---------------------------------------------------------------------------------------------
// (8) degenerate input
// ---------------------------------------------------------------------------------------------

#[test]
fn empty_body() {
    let body = body_from(Vec::new(), Vec::new(), &[]);
    let centers = CorCenters::precompute(&body);
    assert!(centers.centers.is_empty());
    let out = cor::skin(&body, &centers, &[Matrix4::identity()]);
    assert!(out.positions.is_empty() && out.normals.is_empty());
}

#[test]
fn single_joint_body_is_lbs() {
    let tube = Tube {
        r: 1.0,
        len: 2.0,
        rings: 4,
        segs: 6,
        caps: true,
    };
    let positions = tube.positions();
    let rows = vec![vec![(0u16, 1.0)]; positions.len()];
    let body = body_from(positions, tube.triangles(), &rows);
    let centers = CorCenters::precompute(&body);
    assert!(centers.centers.iter().all(Option::is_none));
    let mats = [rotation_about(
        Point3::new(0.0, 1.0, 0.0),
        Vector3::x(),
        0.7,
    )];
    assert_eq!(cor::skin(&body, &centers, &mats), lbs::skin(&body, &mats));
}

#[test]
fn degenerate_triangles_and_isolated_vertices_stay_finite() {
    let positions = vec![
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(2.0, 0.0, 0.0), // collinear with 0 and 1
        Point3::new(0.0, 1.0, 0.0),
        Point3::new(0.0, 0.0, 1.0), // on no triangle
        Point3::new(3.0, 3.0, 3.0),
    ];
    let triangles = vec![
        [0, 1, 2],  // zero area
        [3, 3, 1],  // repeated corner
        [5, 5, 5],  // a point
        [0, 1, 99], // out-of-range index: skipped
    ];
    let rows = vec![
        vec![(0u16, 0.5), (1, 0.5)],
        vec![(0, 0.2), (1, 0.8)],
        vec![(1, 1.0)],
        vec![(0, 0.3), (1, 0.3), (2, 0.4)],
        vec![(0, 0.6), (2, 0.4)],
        vec![(0, 1.0)],
    ];
    let body = body_from(positions, triangles, &rows);
    let centers = CorCenters::precompute(&body);
    assert_eq!(centers.centers.len(), 6);
    assert!(
        centers.centers.iter().all(Option::is_none),
        "{:?}",
        centers.centers
    );
    let mats = [
        Matrix4::identity(),
        rotation_about(Point3::origin(), Vector3::z(), 1.0),
        rotation_about(Point3::origin(), Vector3::x(), -2.0),
    ];
    let out = cor::skin(&body, &centers, &mats);
    assert!(is_finite(&out));
    assert_eq!(out, lbs::skin(&body, &mats));
    // A center list of the wrong length falls back to LBS instead of panicking.
    let out = cor::skin(&body, &CorCenters::default(), &mats);
    assert!(is_finite(&out));
}

#[test]
fn opposite_rotations_do_not_produce_nan() {
    // Joint quaternions q and -q (same rotation) and a 180° pair whose blend may vanish.
    let (_, body) = standard_tube(true);
    let centers = CorCenters::precompute(&body);
    for mats in [twist(PI), twist(-PI), bend(8.0, PI), twist(2.0 * PI - 1e-9)] {
        let out = cor::skin(&body, &centers, &mats);
        assert!(is_finite(&out));
    }
}

/// A body whose planned subdivision passes the entry budget gets its cap halved until the plan
/// fits, and says so: its centers are then those of the uncapped precomputation at that cap
/// (an independent run), finite, and as many as without the budget.
#[test]
fn the_subdivision_is_capped_past_the_entry_budget() {
    let body = irregular_body();
    let fine = CorParams {
        epsilon: 0.01,
        ..CorParams::default()
    };
    let (free, free_stats) = CorCenters::precompute_with_stats(&body, &fine);
    assert_eq!(
        (free.subdivision_cap, free_stats.subdivision_cap),
        (None, 32)
    );
    let budget = free_stats.bucket_entries / 10;
    let bounded = CorParams {
        entry_budget: Some(budget),
        ..fine
    };
    let (capped, stats) = CorCenters::precompute_with_stats(&body, &bounded);
    let (cap, planned) = capped.subdivision_cap.expect("capped");
    println!("{free_stats:?}\n{stats:?}\ncap {cap}, planned {planned}, budget {budget}");
    assert!(cap < 32 && cap == stats.subdivision_cap && planned >= free_stats.bucket_entries);
    assert!(
        stats.bucket_entries <= budget,
        "{} entries",
        stats.bucket_entries
    );
    let at_cap = CorParams {
        max_subdivision: cap,
        ..fine
    };
    let reference = CorCenters::precompute_with(&body, &at_cap);
    assert_eq!(capped.centers, reference.centers);
    assert_eq!(reference.subdivision_cap, None);
    let count = |c: &CorCenters| c.centers.iter().flatten().count();
    assert_eq!(count(&capped), count(&free));
    assert!(capped
        .centers
        .iter()
        .flatten()
        .all(|p| p.coords.iter().all(|x| x.is_finite())));
}
