//! The profile curve, the exact volume cubic and the bulge map (2021 Sec. 5.3, Sec. 7, App. B
//! lines 49-60; `PIPELINE.md` "Profile curve", "Exact volume", "Bulge map").

#[path = "common/meshes.rs"]
mod meshes;

use contact_skin::deform::bulge::{apply_painted, procedural_bulge, BulgeParams, ContactSample};
use contact_skin::deform::profile::{basis, basis_derivative, bulge_basis, Profile};
use contact_skin::deform::volume::{moved_faces, RootChoice, RootKind, VolumeCubic, VolumeError};
use contact_skin::mesh::signed_volume;
use meshes::{icosphere, TestMesh};
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;

// ---------------------------------------------------------------- helpers

/// xorshift64*: deterministic pseudo-random numbers in [-1, 1].
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
        2.0 * (bits as f64 / (1u64 << 53) as f64) - 1.0
    }

    fn vector(&mut self) -> Vector3<f64> {
        Vector3::new(self.next(), self.next(), self.next())
    }
}

/// Amplitude/slope pairs, from flat to nearly vertical, including a = 0 and s < 0.
const PROFILES: [(f64, f64); 10] = [
    (1.0, 0.0),
    (1.0, 1.0),
    (0.3, -2.0),
    (0.1, 3.0),
    (0.05, 40.0),
    (0.01, 20.0),
    (2.0, -500.0),
    (1e-3, 1e4),
    (0.0, 0.0),
    (0.0, 3.0),
];

/// Profiles with a well-defined slope at u = 0 (a > 0), with `cos θ ≥ 1e-3`: the first seven.
const SLOPED: &[(f64, f64)] = PROFILES.split_at(7).0;

const BULGES: [f64; 4] = [0.0, 0.7, -0.3, 5.0];

// ---------------------------------------------------------------- profile

#[test]
fn basis_is_a_nonnegative_partition_of_unity() {
    for i in 0..=999 {
        let t = i as f64 / 999.0;
        let n = basis(t);
        assert!(
            (n.iter().sum::<f64>() - 1.0).abs() <= 2e-16 * 4.0,
            "t = {t}"
        );
        assert!(n.iter().all(|&x| x >= 0.0));
        assert!(basis_derivative(t).iter().sum::<f64>().abs() <= 1e-13);
    }
    // Clamping.
    assert_eq!(basis(-1.0), basis(0.0));
    assert_eq!(basis(2.0), basis(1.0));
}

#[test]
fn profile_starts_at_minus_amplitude() {
    for &(a, s) in &PROFILES {
        let p = Profile::new(a, s);
        for &y2 in &BULGES {
            assert_eq!(p.displacement_at(0.0, y2), -a, "a {a} s {s} y2 {y2}");
            assert_eq!(p.control_points(y2)[0], [0.0, -a]);
        }
    }
}

/// dH/du at u = 0 by one-sided finite differences in u through the inverse, with Richardson
/// extrapolation; the step shrinks with cos²θ because the curvature of H(u) grows as 1/cos³θ.
#[test]
fn slope_at_zero_is_s() {
    for &(a, s) in SLOPED {
        let p = Profile::new(a, s);
        let eps = 1e-5 * p.theta().cos().powi(2);
        for &y2 in &BULGES {
            let h0 = p.displacement_at(0.0, y2);
            let d = |e: f64| (p.displacement_at(e, y2) - h0) / e;
            let slope = 2.0 * d(eps / 2.0) - d(eps);
            assert!(
                (slope - s).abs() <= 1e-5 * (1.0 + s.abs()),
                "a {a} s {s} y2 {y2}: {slope}"
            );
        }
        // θ = atan2(s, 2a): the start tangent 9 (v1 - v0) has slope s.
        let v = p.control_points(0.0);
        let tangent = [v[1][0] - v[0][0], v[1][1] - v[0][1]];
        assert!((tangent[1] - s * tangent[0]).abs() <= 1e-14 * (1.0 + s.abs()));
    }
}

/// The printed θ = atan(s/a) would give slope 2s: check that ours is not that.
#[test]
fn printed_theta_doubles_the_slope() {
    let (a, s) = (1.0_f64, 1.0_f64);
    let printed = (s / a).atan();
    let start = [0.2 * printed.cos(), 0.4 * a * printed.sin()];
    assert!((start[1] / start[0] - 2.0 * s).abs() < 1e-14);
    assert!((Profile::new(a, s).theta() - (s / (2.0 * a)).atan()).abs() < 1e-16);
}

#[test]
fn profile_vanishes_flat_at_one() {
    for &(a, s) in &PROFILES {
        let p = Profile::new(a, s);
        for &y2 in &BULGES {
            assert_eq!(p.displacement_at(1.0, y2), 0.0);
            let eps = 1e-4;
            let slope = (p.displacement_at(1.0, y2) - p.displacement_at(1.0 - eps, y2)) / eps;
            // H ∝ (1 - u)³ near u = 1.
            assert!(
                slope.abs() <= 1e-6 * (1.0 + y2.abs()),
                "a {a} s {s}: {slope}"
            );
            assert!(p.ordinate_derivative(1.0, y2).abs() <= 1e-14 * (1.0 + y2.abs()));
        }
    }
}

#[test]
fn abscissa_is_strictly_increasing_for_all_theta() {
    for k in -100..=100 {
        let theta = k as f64 / 100.5 * std::f64::consts::FRAC_PI_2;
        let p = Profile::new(1.0, 2.0 * theta.tan());
        assert!((p.theta() - theta).abs() < 1e-12);
        let mut last = p.abscissa(0.0);
        assert_eq!(last, 0.0);
        for i in 1..=2000 {
            let x = p.abscissa(i as f64 / 2000.0);
            assert!(x > last, "θ {theta} i {i}");
            last = x;
        }
        assert_eq!(last, 1.0);
    }
}

#[test]
fn parameter_at_inverts_abscissa() {
    let (mut worst_u, mut worst_t) = (0.0_f64, 0.0_f64);
    for &(a, s) in &PROFILES {
        let p = Profile::new(a, s);
        for i in 0..=1000 {
            let x = i as f64 / 1000.0;
            let t = p.parameter_at(x);
            worst_u = worst_u.max((p.abscissa(t) - x).abs());
            if p.theta().cos() > 1e-3 {
                worst_t = worst_t.max((p.parameter_at(p.abscissa(x)) - x).abs());
            }
        }
        // u outside [0, 1] is clamped.
        assert_eq!(p.parameter_at(-0.5), 0.0);
        assert_eq!(p.parameter_at(1.5), 1.0);
    }
    eprintln!("inverse: |f1(f1⁻¹(u)) - u| ≤ {worst_u:e}, |f1⁻¹(f1(t)) - t| ≤ {worst_t:e}");
    let (mut total, mut count, mut worst_iterations) = (0u64, 0u64, 0u32);
    for &(a, s) in &PROFILES {
        let p = Profile::new(a, s);
        for i in 0..=1000 {
            let iterations = p.invert_abscissa(i as f64 / 1000.0).1;
            (total, count) = (total + u64::from(iterations), count + 1);
            worst_iterations = worst_iterations.max(iterations);
        }
    }
    eprintln!(
        "inverse iterations: mean {:.2}, worst {worst_iterations}",
        total as f64 / count as f64
    );
    assert!(worst_iterations <= 12);
    assert!(worst_u <= 1e-15, "|f1(f1⁻¹(u)) - u| up to {worst_u:e}");
    assert!(worst_t <= 1e-12, "|f1⁻¹(f1(t)) - t| up to {worst_t:e}");
}

#[test]
fn inverse_is_robust_in_degenerate_profiles() {
    for &(a, s) in &[(0.0, 1.0), (1e-300, 1e300), (1.0, -1e300), (1e300, 1e-300)] {
        let p = Profile::new(a, s);
        for i in 0..=100 {
            let u = (i as f64 / 100.0).powi(8);
            let (t, iterations) = p.invert_abscissa(u);
            assert!((0.0..=1.0).contains(&t));
            assert!((p.abscissa(t) - u).abs() <= 1e-15, "a {a} s {s} u {u}");
            assert!(iterations <= 12);
            assert!(p.displacement_at(u, 1.0).is_finite());
        }
    }
}

/// Largest jump between consecutive finite-difference slopes of `H(u)` (evaluated through
/// the inverse) on the points `u_i = f1(i / n)`: uniform in t, so the layer near u = 0 where
/// the slope turns quickly (width ~ cos²θ) is resolved.
fn largest_slope_jump(p: &Profile, y2: f64, n: usize) -> f64 {
    let u: Vec<f64> = (0..=n).map(|i| p.abscissa(i as f64 / n as f64)).collect();
    let h: Vec<f64> = u.iter().map(|&x| p.displacement_at(x, y2)).collect();
    let slopes: Vec<f64> = (0..n)
        .map(|i| (h[i + 1] - h[i]) / (u[i + 1] - u[i]))
        .collect();
    slopes
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max)
}

/// Finite-difference slopes on both sides of the span boundaries t = 1/3, 2/3 agree up to
/// O(ε), and the largest jump between consecutive finite-difference slopes halves with the
/// step (a kink anywhere would keep it constant).
#[test]
fn profile_is_c1_in_u() {
    for &(a, s) in SLOPED {
        let p = Profile::new(a, s);
        for &y2 in &BULGES {
            let h = |u: f64| p.displacement_at(u, y2);
            let scale = 1.0 + a.abs() + s.abs() + y2.abs();
            for t_break in [1.0 / 3.0, 2.0 / 3.0] {
                let u = p.abscissa(t_break);
                let kink = |e: f64| ((h(u + e) - h(u)) / e - (h(u) - h(u - e)) / e).abs();
                let (coarse, fine) = (kink(1e-5), kink(1e-6));
                assert!(coarse <= 1e-2 * scale, "a {a} s {s} y2 {y2}: {coarse}");
                assert!(fine <= 0.2 * coarse + 1e-8 * scale, "a {a} s {s} y2 {y2}");
            }
            let (coarse, fine) = (
                largest_slope_jump(&p, y2, 50_000),
                largest_slope_jump(&p, y2, 100_000),
            );
            assert!(
                fine <= 0.6 * coarse,
                "a {a} s {s} y2 {y2}: {coarse} -> {fine}"
            );
        }
    }
}

#[test]
fn ordinate_is_affine_in_the_bulge() {
    for &(a, s) in &PROFILES {
        let p = Profile::new(a, s);
        for i in 0..=100 {
            let t = i as f64 / 100.0;
            let (y1, y2) = (0.37, -2.5);
            let direct = p.ordinate(t, y1);
            let affine = p.base_ordinate(t) + bulge_basis(t) * y1;
            assert!((direct - affine).abs() <= 1e-15 * (1.0 + a.abs()));
            let mix = p.ordinate(t, 0.25 * y1 + 0.75 * y2);
            let mixed = 0.25 * p.ordinate(t, y1) + 0.75 * p.ordinate(t, y2);
            assert!((mix - mixed).abs() <= 1e-14 * (1.0 + a.abs()));
            assert_eq!(p.ordinate(t, 0.0), p.base_ordinate(t));
        }
    }
}

// ---------------------------------------------------------------- volume

/// A cube [-1, 1]³ with an n × n grid per face, shared vertices, outward CCW.
fn cube(n: i64) -> TestMesh {
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut vertex = |g: [i64; 3]| {
        *index.entry(g).or_insert_with(|| {
            positions.push(Point3::from(Vector3::from(
                g.map(|c| 2.0 * c as f64 / n as f64 - 1.0),
            )));
            (positions.len() - 1) as u32
        })
    };
    let mut triangles = Vec::new();
    for axis in 0..3 {
        for side in [0, n] {
            for i in 0..n {
                for j in 0..n {
                    let corner = |di: i64, dj: i64| {
                        let mut g = [0; 3];
                        g[axis] = side;
                        g[(axis + 1) % 3] = i + di;
                        g[(axis + 2) % 3] = j + dj;
                        g
                    };
                    let q =
                        [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)].map(&mut vertex);
                    let (t1, t2) = ([q[0], q[1], q[2]], [q[0], q[2], q[3]]);
                    if side == n {
                        triangles.extend([t1, t2]);
                    } else {
                        triangles.extend([[t1[0], t1[2], t1[1]], [t2[0], t2[2], t2[1]]]);
                    }
                }
            }
        }
    }
    TestMesh {
        positions,
        triangles,
    }
}

/// Outward vertex normals, area-weighted.
fn normals(m: &TestMesh) -> Vec<Vector3<f64>> {
    let mut n = vec![Vector3::zeros(); m.positions.len()];
    for t in &m.triangles {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        let fnorm = (b - a).cross(&(c - a));
        for &i in t {
            n[i as usize] += fnorm;
        }
    }
    n.into_iter().map(|v| v.normalize()).collect()
}

/// Radius of the deformed patch around vertex 0.
const PATCH_RADIUS: f64 = 1.2;

/// A contact-like deformation of a patch around vertex 0: P pushed inward (plus noise),
/// Q outward (plus noise).
fn patch_deformation(m: &TestMesh, seed: u64) -> (Vec<Point3<f64>>, Vec<Vector3<f64>>) {
    let mut rng = Rng(seed);
    let n = normals(m);
    let center = m.positions[0];
    let (mut base, mut bulge) = (
        m.positions.clone(),
        vec![Vector3::zeros(); m.positions.len()],
    );
    for (i, p) in m.positions.iter().enumerate() {
        let dist = (p - center).norm();
        if dist < 0.5 * PATCH_RADIUS {
            base[i] = p - n[i] * 0.15 * (1.0 - 2.0 * dist / PATCH_RADIUS) + rng.vector() * 0.02;
        } else if dist < PATCH_RADIUS {
            bulge[i] = n[i] * (1.0 + 0.3 * rng.next()) + rng.vector() * 0.2;
            base[i] = p + rng.vector() * 0.01;
        }
    }
    (base, bulge)
}

fn displaced(base: &[Point3<f64>], bulge: &[Vector3<f64>], h: f64) -> Vec<Point3<f64>> {
    base.iter().zip(bulge).map(|(p, q)| p + q * h).collect()
}

fn assemble(m: &TestMesh, base: &[Point3<f64>], bulge: &[Vector3<f64>]) -> VolumeCubic {
    let faces = moved_faces(&m.triangles, &m.positions, base, bulge);
    assert!(faces.len() < m.triangles.len());
    VolumeCubic::assemble(&m.triangles, &faces, &m.positions, base, bulge).unwrap()
}

/// Σ_k m_k |h|^k: the rounding scale of ΔV(h).
fn scale(c: &VolumeCubic, h: f64) -> f64 {
    (0..4)
        .map(|k| c.magnitudes[k] * h.abs().powi(k as i32))
        .sum()
}

fn meshes() -> Vec<(&'static str, TestMesh)> {
    vec![("icosphere", icosphere(3)), ("cube", cube(12))]
}

/// The faces with a vertex within the deformation radius of `patch_deformation`, found from
/// the geometry (not from `moved_faces`).
fn patch_faces(m: &TestMesh) -> Vec<[u32; 3]> {
    let center = m.positions[0];
    let near = |i: u32| (m.positions[i as usize] - center).norm() < PATCH_RADIUS;
    m.triangles
        .iter()
        .filter(|t| t.iter().any(|&i| near(i)))
        .copied()
        .collect()
}

/// An independent ΔV: `signed_volume` of the closed surface made of the new patch and the
/// reversed old patch (their common border is fixed), with its origin at the patch center.
fn patch_volume_change(m: &TestMesh, new: &[Point3<f64>]) -> f64 {
    let n = new.len() as u32;
    let faces = patch_faces(m);
    let mut positions = new.to_vec();
    positions.extend_from_slice(&m.positions);
    let mut triangles = faces.clone();
    triangles.extend(faces.iter().map(|&[a, b, c]| [a + n, c + n, b + n]));
    signed_volume(&positions, &triangles)
}

/// The cubic against `signed_volume`: to 1e-12 relative against the closed-patch reference,
/// and to 1e-12 of the mesh volume against the whole-mesh difference, whose own rounding
/// (sequential sum over every face) is of the order of N ε V0.
#[test]
fn cubic_matches_the_signed_volume() {
    let (mut worst_patch, mut worst_mesh) = (0.0_f64, 0.0_f64);
    for (name, m) in meshes() {
        let v0 = signed_volume(&m.positions, &m.triangles);
        assert!(v0 > 0.0, "{name} must be outward");
        for seed in 1..=4 {
            let (base, bulge) = patch_deformation(&m, seed);
            let cubic = assemble(&m, &base, &bulge);
            let moved = moved_faces(&m.triangles, &m.positions, &base, &bulge);
            assert_eq!(moved.len(), patch_faces(&m).len());
            for h in [-1.5, -0.3, 0.0, 0.05, 0.4, 2.0] {
                let new = displaced(&base, &bulge, h);
                let patch = patch_volume_change(&m, &new);
                let err = (cubic.evaluate(h) - patch).abs() / patch.abs().max(scale(&cubic, h));
                worst_patch = worst_patch.max(err);
                assert!(err <= 1e-12, "{name} seed {seed} h {h}: {err:e}");
                let whole = signed_volume(&new, &m.triangles) - v0;
                let err = (cubic.evaluate(h) - whole).abs() / v0;
                worst_mesh = worst_mesh.max(err);
                assert!(err <= 1e-12, "{name} seed {seed} h {h}: {err:e}");
            }
        }
    }
    eprintln!("cubic vs closed patch: {worst_patch:e}; vs whole mesh / V0: {worst_mesh:e}");
}

#[test]
fn solved_root_preserves_the_volume() {
    for (name, m) in meshes() {
        let v0 = signed_volume(&m.positions, &m.triangles);
        for seed in 1..=4 {
            let (base, bulge) = patch_deformation(&m, seed);
            let cubic = assemble(&m, &base, &bulge);
            let c0 = cubic.coefficients[0];
            assert!(c0 < 0.0, "the push loses volume");
            let root = cubic.solve().unwrap();
            assert_eq!(root.kind, RootKind::Exact);
            assert!(root.h > 0.0 && root.linear > 0.0);
            assert!(root.residual.abs() <= 1e-12 * c0.abs(), "{name}: {root:?}");
            let new = displaced(&base, &bulge, root.h);
            let patch = patch_volume_change(&m, &new);
            assert!(
                patch.abs() <= 1e-12 * c0.abs(),
                "{name} seed {seed}: {patch:e}"
            );
            let whole = signed_volume(&new, &m.triangles) - v0;
            assert!(whole.abs() <= 1e-12 * v0, "{name} seed {seed}: {whole:e}");
            eprintln!(
                "{name} seed {seed}: h_lin {:.6} h {:.6} ΔV(h)/c0: cubic {:e} patch {:e} mesh {:e}",
                root.linear,
                root.h,
                root.residual / c0,
                patch / c0,
                whole / c0
            );
        }
    }
}

#[test]
fn cubic_is_translation_invariant() {
    for (name, m) in meshes() {
        let (base, bulge) = patch_deformation(&m, 7);
        let cubic = assemble(&m, &base, &bulge);
        let offset = Vector3::new(1e3, -2e3, 5e2);
        let moved = TestMesh {
            positions: m.positions.iter().map(|p| p + offset).collect(),
            triangles: m.triangles.clone(),
        };
        let base_moved: Vec<_> = base.iter().map(|p| p + offset).collect();
        let shifted = assemble(&moved, &base_moved, &bulge);
        for k in 0..4 {
            let diff = (cubic.coefficients[k] - shifted.coefficients[k]).abs();
            eprintln!(
                "{name} c{k}: change / magnitude {:e}",
                diff / cubic.magnitudes[k]
            );
            assert!(diff <= 1e-10 * cubic.magnitudes[k], "{name} c{k}: {diff:e}");
        }
        let (h, h_moved) = (cubic.solve().unwrap().h, shifted.solve().unwrap().h);
        assert!(
            (h - h_moved).abs() <= 1e-10 * h.abs(),
            "{name}: {h} vs {h_moved}"
        );
    }
}

#[test]
fn zero_bulge_and_zero_change_fallbacks() {
    let m = icosphere(2);
    let (base, bulge) = patch_deformation(&m, 3);
    let none = vec![Vector3::zeros(); bulge.len()];
    let root = assemble(&m, &base, &none).solve().unwrap();
    assert_eq!((root.h, root.kind), (0.0, RootKind::NoBulge));
    let unchanged = assemble(&m, &m.positions, &bulge);
    assert_eq!(unchanged.coefficients[0], 0.0);
    let root = unchanged.solve().unwrap();
    assert_eq!((root.h, root.kind), (0.0, RootKind::Exact));
    // Q tangent to a sphere everywhere (rotation field): c1 cancels to rounding.
    let axis = Vector3::new(0.3, -0.2, 0.9).normalize();
    let tangent: Vec<_> = m.positions.iter().map(|p| axis.cross(&p.coords)).collect();
    let faces: Vec<u32> = (0..m.triangles.len() as u32).collect();
    let pushed: Vec<_> = m.positions.iter().map(|p| p * 0.99).collect();
    let cubic =
        VolumeCubic::assemble(&m.triangles, &faces, &m.positions, &pushed, &tangent).unwrap();
    assert_eq!(cubic.solve().unwrap().kind, RootKind::NoBulge, "{cubic:?}");
}

/// `c0 Π (1 - h / (h_lin r_i))`, whose roots are `h_lin r_i` (needs `Σ 1/r_i = 1`).
fn cubic_with_roots(c0: f64, h_lin: f64, r: [f64; 3]) -> VolumeCubic {
    let s = r.map(|x| 1.0 / (h_lin * x));
    let e1 = s[0] + s[1] + s[2];
    let e2 = s[0] * s[1] + s[0] * s[2] + s[1] * s[2];
    let e3 = s[0] * s[1] * s[2];
    VolumeCubic::from_coefficients([c0, -c0 * e1, c0 * e2, -c0 * e3])
}

#[test]
fn three_real_roots_pick_the_nearest_of_the_linear_sign() {
    // Σ 1/r = 1 pins the third root.
    let third = |a: f64, b: f64| 1.0 / (1.0 - 1.0 / a - 1.0 / b);
    for (c0, h_lin) in [(-2.0, 0.3), (5.0, -0.01), (1e-9, 4e3)] {
        // Two roots of h_lin's sign around h_lin: the nearest is 1.1 h_lin, the first 0.8 h_lin.
        let cubic = cubic_with_roots(c0, h_lin, [0.8, 1.1, third(0.8, 1.1)]);
        let root = cubic.solve().unwrap();
        assert!((root.linear - h_lin).abs() <= 1e-14 * h_lin.abs());
        assert!(
            (root.h - 1.1 * h_lin).abs() <= 1e-13 * h_lin.abs(),
            "{root:?}"
        );
        let first = cubic.solve_with(RootChoice::FirstCrossing).unwrap();
        assert!(
            (first.h - 0.8 * h_lin).abs() <= 1e-13 * h_lin.abs(),
            "{first:?}"
        );
        // Both below h_lin: 0.9 is nearer than 0.5.
        let cubic = cubic_with_roots(c0, h_lin, [0.5, 0.9, third(0.5, 0.9)]);
        assert!((cubic.solve().unwrap().h - 0.9 * h_lin).abs() <= 1e-13 * h_lin.abs());
        // Three roots of the same sign (2, 3, 6): the nearest is also the first.
        let cubic = cubic_with_roots(c0, h_lin, [2.0, 3.0, 6.0]);
        assert!((cubic.solve().unwrap().h - 2.0 * h_lin).abs() <= 1e-13 * h_lin.abs());
        // One root of h_lin's sign (4/7), two of the other sign: never a wrong-sign root.
        let cubic = cubic_with_roots(c0, h_lin, [third(-2.0, -4.0), -2.0, -4.0]);
        let root = cubic.solve().unwrap();
        assert!(
            (root.h - h_lin * 4.0 / 7.0).abs() <= 1e-13 * h_lin.abs(),
            "{root:?}"
        );
        assert_eq!(root.kind, RootKind::Exact);
    }
}

/// Where two roots of h_lin's sign are equidistant from h_lin (0.8 and 1.2), a tiny change of
/// the coefficients flips `NearestLinear` between them (a 50 % jump of the bulge between two
/// frames), while `FirstCrossing` moves continuously.
#[test]
fn nearest_linear_jumps_where_first_crossing_does_not() {
    let third = |a: f64, b: f64| 1.0 / (1.0 - 1.0 / a - 1.0 / b);
    let family = |d: f64| cubic_with_roots(-1.0, 1.0, [0.8 + d, 1.2 + d, third(0.8 + d, 1.2 + d)]);
    let (before, after) = (family(-1e-4), family(1e-4));
    for k in 0..4 {
        let change = (before.coefficients[k] - after.coefficients[k]).abs();
        assert!(change < 1e-2, "c{k} changes by {change}");
    }
    let nearest = |c: &VolumeCubic| c.solve().unwrap().h;
    let first = |c: &VolumeCubic| c.solve_with(RootChoice::FirstCrossing).unwrap().h;
    assert!((nearest(&before) - 1.1999).abs() < 1e-12);
    assert!((nearest(&after) - 0.8001).abs() < 1e-12);
    assert!((first(&before) - first(&after)).abs() < 3e-4);
}

#[test]
fn degenerate_cubics() {
    // Linear.
    let r = VolumeCubic::from_coefficients([3.0, 2.0, 0.0, 0.0])
        .solve()
        .unwrap();
    assert_eq!((r.h, r.kind), (-1.5, RootKind::Exact));
    // Nearly quadratic: 1 - h + 0.24 h² (+ 1e-30 h³): root (1 - 0.2) / 0.48.
    for c3 in [0.0, 1e-30, -1e-30] {
        let r = VolumeCubic::from_coefficients([1.0, -1.0, 0.24, c3])
            .solve()
            .unwrap();
        assert!((r.h - 0.8 / 0.48).abs() <= 1e-14, "{r:?}");
    }
    // No real root of the linear sign: 1 - h + h² > 0; closest approach at h = 1/2.
    let r = VolumeCubic::from_coefficients([1.0, -1.0, 1.0, 0.0])
        .solve()
        .unwrap();
    assert_eq!(r.kind, RootKind::ClosestApproach);
    assert!((r.h - 0.5).abs() <= 1e-15 && (r.residual - 0.75).abs() <= 1e-15);
    // A positive cubic term far away: roots only for h < 0 beyond... none of the sign of h_lin.
    let r = VolumeCubic::from_coefficients([1.0, -1.0, 1.0, 1e-3])
        .solve()
        .unwrap();
    assert_eq!(r.kind, RootKind::ClosestApproach);
    assert!(r.h > 0.0 && r.residual > 0.0 && r.residual < 1.0);
    // Huge and tiny scales give the same reduced answer.
    for k in [-200, -20, 0, 20, 200] {
        let s = 10f64.powi(k);
        let r = VolumeCubic::from_coefficients([-2.0 * s, 4.0 * s, 0.5 * s, 0.1 * s])
            .solve()
            .unwrap();
        let unit = VolumeCubic::from_coefficients([-2.0, 4.0, 0.5, 0.1])
            .solve()
            .unwrap();
        assert!((r.h - unit.h).abs() <= 1e-15, "scale {s}: {r:?}");
    }
    // c1 = 0: nothing compensates at first order.
    let r = VolumeCubic::from_coefficients([1.0, 0.0, 1.0, 1.0])
        .solve()
        .unwrap();
    assert_eq!((r.h, r.kind), (0.0, RootKind::NoBulge));
    // Non-finite coefficients: an error, not a panic.
    for bad in [f64::NAN, f64::INFINITY] {
        let e = VolumeCubic::from_coefficients([1.0, bad, 0.0, 0.0]).solve();
        assert_eq!(e, Err(VolumeError::NonFiniteCoefficients));
    }
}

#[test]
fn assemble_rejects_bad_input() {
    let m = cube(2);
    let n = m.positions.len();
    let (p, q) = (m.positions.clone(), vec![Vector3::zeros(); n]);
    let tris = &m.triangles;
    assert!(matches!(
        VolumeCubic::assemble(tris, &[0], &p, &p[..n - 1], &q),
        Err(VolumeError::LengthMismatch { .. })
    ));
    let far = tris.len() as u32;
    assert_eq!(
        VolumeCubic::assemble(tris, &[far], &p, &p, &q),
        Err(VolumeError::FaceOutOfRange(far))
    );
    let broken = vec![[0, 1, n as u32]];
    assert_eq!(
        VolumeCubic::assemble(&broken, &[0], &p, &p, &q),
        Err(VolumeError::VertexOutOfRange(n as u32))
    );
    let mut nan = p.clone();
    nan[tris[0][1] as usize].x = f64::NAN;
    assert_eq!(
        VolumeCubic::assemble(tris, &[0], &p, &nan, &q),
        Err(VolumeError::NonFinite(tris[0][1]))
    );
    let empty = VolumeCubic::assemble(tris, &[], &p, &p, &q).unwrap();
    assert_eq!(empty.coefficients, [0.0; 4]);
    assert_eq!(empty.solve().unwrap().h, 0.0);
}

// ---------------------------------------------------------------- bulge

fn sample_at(position: Point3<f64>, push: Vector3<f64>) -> ContactSample {
    ContactSample {
        position,
        area: 0.02,
        depth: 0.1,
        push,
    }
}

/// Eq. 7 written out, unnormalized.
fn reference(x: &Point3<f64>, samples: &[ContactSample], omega: f64, r_min: f64) -> f64 {
    samples
        .iter()
        .map(|s| {
            let v = x - s.position;
            let r = v.norm().max(r_min);
            let cut = if omega == 0.0 {
                1.0
            } else {
                (s.push.normalize().dot(&v) / r).max(0.0).powf(omega)
            };
            s.area * s.depth * cut / r
        })
        .sum()
}

#[test]
fn single_sample_front_behind_and_on_the_plane() {
    let params = BulgeParams::for_edge_length(0.1);
    assert_eq!(
        (params.omega, params.floor, params.min_radius),
        (2.0, 0.05, 0.05)
    );
    let s = sample_at(Point3::new(0.1, 0.2, 0.3), Vector3::new(0.0, 2.0, 0.0));
    let points: Vec<Point3<f64>> = [
        [0.0, 1.0, 0.0],  // in front, on axis
        [0.5, 0.5, 0.0],  // in front, oblique
        [0.0, -1.0, 0.0], // behind
        [1.0, 0.0, -0.4], // on the plane
        [0.0, 0.05, 0.0], // in front, within r_min
    ]
    .iter()
    .map(|d| s.position + Vector3::from(*d))
    .collect();
    let eta = procedural_bulge(&points, &[s], &params);
    assert_eq!(eta[2], 0.05, "behind: exactly λ");
    assert_eq!(eta[3], 0.05, "on the plane: exactly λ");
    let raw: Vec<f64> = points
        .iter()
        .map(|x| reference(x, &[s], 2.0, 0.05))
        .collect();
    let max = raw.iter().copied().fold(0.0, f64::max);
    for (e, r) in eta.iter().zip(&raw) {
        assert!((e - (0.05 + 0.95 * r / max)).abs() <= 1e-15);
    }
    assert_eq!(eta[4], 1.0, "the nearest point in front is the maximum");
    assert!(eta[0] > eta[1] && eta[1] > eta[2]);
}

#[test]
fn symmetric_about_the_push_axis() {
    let axis = Vector3::new(0.0, 0.0, 1.0);
    // A ring of 8 samples around the axis (8-fold symmetric).
    let samples: Vec<ContactSample> = (0..8)
        .map(|k| {
            let a = k as f64 * std::f64::consts::FRAC_PI_4;
            sample_at(Point3::new(0.2 * a.cos(), 0.2 * a.sin(), 0.0), axis)
        })
        .collect();
    let params = BulgeParams::for_edge_length(0.04);
    for (rho, z) in [(0.3, 0.5), (0.8, 0.2), (0.1, 1.0), (0.5, -0.1)] {
        let ring: Vec<Point3<f64>> = (0..8)
            .map(|k| {
                let a = 0.3 + k as f64 * std::f64::consts::FRAC_PI_4;
                Point3::new(rho * a.cos(), rho * a.sin(), z)
            })
            .collect();
        let eta = procedural_bulge(&ring, &samples, &params);
        let (lo, hi) = eta
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), &e| (l.min(e), h.max(e)));
        assert!(hi - lo <= 1e-14, "ρ {rho} z {z}: {eta:?}");
    }
}

#[test]
fn omega_zero_is_isotropic_one_over_r() {
    let s = sample_at(Point3::origin(), Vector3::new(1.0, 0.0, 0.0));
    let params = BulgeParams {
        omega: 0.0,
        ..BulgeParams::for_edge_length(0.2)
    };
    let points = [
        Point3::new(0.5, 0.0, 0.0),
        Point3::new(-1.0, 0.0, 0.0),
        Point3::new(0.0, 2.0, 0.0),
        Point3::new(0.0, 0.0, -4.0),
        Point3::new(0.05, 0.0, 0.0), // inside r_min = 0.1
    ];
    let eta = procedural_bulge(&points, &[s], &params);
    let frac: Vec<f64> = eta.iter().map(|e| (e - 0.05) / 0.95).collect();
    assert_eq!(eta[4], 1.0);
    for (i, r) in [0.5, 1.0, 2.0, 4.0].iter().enumerate() {
        assert!((frac[i] - 0.1 / r).abs() <= 1e-15, "r {r}: {}", frac[i]);
    }
}

#[test]
fn normalization_and_multiple_contacts() {
    let mut rng = Rng(11);
    let samples: Vec<ContactSample> = (0..30)
        .map(|k| {
            let push = if k % 2 == 0 {
                Vector3::z()
            } else {
                -Vector3::x() * 3.0
            };
            ContactSample {
                position: Point3::from(rng.vector() * 0.3),
                area: 0.01 * (1.5 + rng.next()),
                depth: 0.05 * (1.5 + rng.next()),
                push,
            }
        })
        .collect();
    let points: Vec<Point3<f64>> = (0..500).map(|_| Point3::from(rng.vector() * 2.0)).collect();
    let params = BulgeParams::for_edge_length(0.05);
    let eta = procedural_bulge(&points, &samples, &params);
    let max = eta.iter().copied().fold(f64::MIN, f64::max);
    assert_eq!(max, 1.0);
    assert!(eta.iter().all(|&e| (0.05..=1.0).contains(&e)));
    let raw: Vec<f64> = points
        .iter()
        .map(|x| reference(x, &samples, 2.0, 0.025))
        .collect();
    let raw_max = raw.iter().copied().fold(0.0, f64::max);
    for (e, r) in eta.iter().zip(&raw) {
        assert!((e - (0.05 + 0.95 * r / raw_max)).abs() <= 1e-13);
    }
}

#[test]
fn degenerate_input_stays_finite() {
    let good = sample_at(Point3::origin(), Vector3::z());
    let bad = [
        ContactSample {
            position: Point3::new(f64::NAN, 0.0, 0.0),
            ..good
        },
        ContactSample {
            area: f64::INFINITY,
            ..good
        },
        ContactSample {
            depth: -1.0,
            ..good
        },
        ContactSample {
            push: Vector3::zeros(),
            ..good
        },
        ContactSample {
            push: Vector3::new(f64::NAN, 0.0, 1.0),
            ..good
        },
    ];
    let points = [
        Point3::origin(),
        Point3::new(0.0, 0.0, 1.0),
        Point3::new(f64::INFINITY, 0.0, 0.0),
        Point3::new(f64::NAN, 1.0, 0.0),
    ];
    // Only invalid samples: isotropic.
    assert_eq!(
        procedural_bulge(&points, &bad, &BulgeParams::default()),
        vec![1.0; 4]
    );
    let weird = [
        BulgeParams::default(),
        BulgeParams {
            omega: f64::NAN,
            floor: f64::NAN,
            min_radius: -1.0,
        },
        BulgeParams {
            omega: -3.0,
            floor: 7.0,
            min_radius: f64::INFINITY,
        },
        BulgeParams {
            omega: f64::INFINITY,
            floor: -1.0,
            min_radius: 1e-320,
        },
    ];
    let mut all = bad.to_vec();
    all.push(good);
    for params in &weird {
        let eta = procedural_bulge(&points, &all, params);
        assert!(eta.iter().all(|e| e.is_finite()), "{params:?}: {eta:?}");
        assert!(eta.iter().all(|&e| (0.0..=1.0).contains(&e)));
    }
    let eta = procedural_bulge(&points, &all, &BulgeParams::default());
    assert_eq!(
        eta[0], 0.05,
        "coincident point with r_min = 0: no contribution"
    );
    assert_eq!(eta[1], 1.0);
    assert_eq!(&eta[2..], &[0.05, 0.05], "non-finite points get λ");
    assert!(procedural_bulge(&[], &all, &BulgeParams::default()).is_empty());
}

#[test]
fn deterministic_and_thread_independent() {
    let mut rng = Rng(5);
    let samples: Vec<ContactSample> = (0..200)
        .map(|_| {
            sample_at(
                Point3::from(rng.vector() * 0.2),
                Vector3::new(0.1, 0.2, 1.0),
            )
        })
        .collect();
    let points: Vec<Point3<f64>> = (0..5000).map(|_| Point3::from(rng.vector())).collect();
    let params = BulgeParams::for_edge_length(0.02);
    let a = procedural_bulge(&points, &samples, &params);
    let b = procedural_bulge(&points, &samples, &params);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let c = pool.install(|| procedural_bulge(&points, &samples, &params));
    assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
    assert!(a.iter().zip(&c).all(|(x, y)| x.to_bits() == y.to_bits()));
}

#[test]
fn painted_map_multiplies() {
    let mut eta = vec![1.0, 0.5, 0.2, 0.8];
    apply_painted(&mut eta, &[2.0, -0.5, f64::NAN]);
    assert_eq!(eta, vec![2.0, -0.25, 0.2, 0.8]);
    let mut eta = vec![1.0];
    apply_painted(&mut eta, &[0.5, 3.0]);
    assert_eq!(eta, vec![0.5]);
}
