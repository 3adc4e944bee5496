//! Exact orientation predicates and the symbolic perturbation that resolves their zeros.
//!
//! Signs are computed in floating point behind the error bounds of Shewchuk ("Adaptive
//! Precision Floating-Point Arithmetic and Fast Robust Geometric Predicates", 1997); when the
//! bound does not certify the sign, `orient3d` falls back to the `robust` crate (Shewchuk's
//! adaptive stages, exact, no allocation) and the 2x2 cross-product sign to expansion
//! arithmetic (two-sum / two-product, products via `f64::mul_add`). Inputs are assumed finite
//! and far from the underflow range (mesh coordinates are).
//!
//! The fallback matters where two surfaces coincide: on the second sweep of a fold the two
//! sides touch along `S` and most face pairs there are near-coplanar (bending capsule, two
//! sweeps: 18 % of the frame in the former allocating exact `orient3d`).
//!
//! **Simulation of simplicity.** For a pair of surfaces `A`, `B`, the points of `B` are translated
//! by `τ = ε e_x + ε² e_y + ε³ e_z` with `ε → 0⁺`. Every predicate mixing points of both
//! surfaces is affine in `τ`, so its perturbed sign is the first non-zero of its exact value and
//! the three components of its linear term. Exact ties (a vertex on a face plane, a line through
//! a triangle edge, coplanar triangles) are thereby resolved as in one consistent, generic
//! configuration: intersection curves stay closed and every face pair has 0 or 2 hits.

use nalgebra::Point3;

/// Unit roundoff of `f64` (2⁻⁵³).
const EPS: f64 = f64::EPSILON * 0.5;
/// Shewchuk's `o3derrboundA`.
const O3D_BOUND: f64 = (7.0 + 56.0 * EPS) * EPS;
/// Shewchuk's `ccwerrboundA`, valid for any 2x2 determinant of four coordinate differences.
const CCW_BOUND: f64 = (3.0 + 16.0 * EPS) * EPS;

/// A predicate sign with the information whether it needed the perturbation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct SoSSign {
    /// -1 or +1 (0 only when the perturbation cannot decide: degenerate simplex).
    pub sign: i8,
    /// The unperturbed determinant was exactly zero.
    pub tie: bool,
}

/// Sign of `(b - a) × (c - a) · (d - a)` (positive when `d` is on the side of the normal of the
/// counter-clockwise triangle `abc`), exact.
pub(crate) fn orient3d(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>, d: &Point3<f64>) -> i8 {
    orient3d_filtered(a, b, c, d).unwrap_or_else(|| -orient3d_exact(a, b, c, d))
}

/// [`orient3d`] in floating point when Shewchuk's error bound certifies its sign, else `None`.
fn orient3d_filtered(
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
    d: &Point3<f64>,
) -> Option<i8> {
    // Shewchuk's orient3d evaluates det[a-d, b-d, c-d], which is minus ours.
    let (adx, bdx, cdx) = (a.x - d.x, b.x - d.x, c.x - d.x);
    let (ady, bdy, cdy) = (a.y - d.y, b.y - d.y, c.y - d.y);
    let (adz, bdz, cdz) = (a.z - d.z, b.z - d.z, c.z - d.z);
    let (bdxcdy, cdxbdy) = (bdx * cdy, cdx * bdy);
    let (cdxady, adxcdy) = (cdx * ady, adx * cdy);
    let (adxbdy, bdxady) = (adx * bdy, bdx * ady);
    let det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
    let permanent = (bdxcdy.abs() + cdxbdy.abs()) * adz.abs()
        + (cdxady.abs() + adxcdy.abs()) * bdz.abs()
        + (adxbdy.abs() + bdxady.abs()) * cdz.abs();
    let bound = O3D_BOUND * permanent;
    if det > bound {
        Some(-1)
    } else if -det > bound {
        Some(1)
    } else {
        None
    }
}

/// Sign of component `axis` of `(u1 - u0) × (v1 - v0)`, exact.
pub(crate) fn cross_sign(
    u0: &Point3<f64>,
    u1: &Point3<f64>,
    v0: &Point3<f64>,
    v1: &Point3<f64>,
    axis: usize,
) -> i8 {
    let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
    let (ui, uj) = (u1[i] - u0[i], u1[j] - u0[j]);
    let (vi, vj) = (v1[i] - v0[i], v1[j] - v0[j]);
    let (left, right) = (ui * vj, uj * vi);
    let det = left - right;
    let bound = CCW_BOUND * (left.abs() + right.abs());
    if det > bound {
        return 1;
    }
    if -det > bound {
        return -1;
    }
    let e = diff_product(u1[i], u0[i], v1[j], v0[j]);
    let f = diff_product(u1[j], u0[j], v1[i], v0[i]);
    expansion_sign(&sum(&e, &negate(&f)))
}

/// The plane of a triangle with what the orientation filter needs, shared by several points.
pub(crate) struct FacePlane<'a> {
    corners: [&'a Point3<f64>; 3],
    /// `(f1 - f0) × (f2 - f0)` in floating point.
    normal: [f64; 3],
    /// Per component, the sum of the magnitudes of the two products of the cross product.
    permanent: [f64; 3],
}

impl<'a> FacePlane<'a> {
    pub(crate) fn new(corners: [&'a Point3<f64>; 3]) -> Self {
        let u = corners[1] - corners[0];
        let v = corners[2] - corners[0];
        let mut normal = [0.0; 3];
        let mut permanent = [0.0; 3];
        for k in 0..3 {
            let (i, j) = ((k + 1) % 3, (k + 2) % 3);
            let (l, r) = (u[i] * v[j], u[j] * v[i]);
            normal[k] = l - r;
            permanent[k] = l.abs() + r.abs();
        }
        Self {
            corners,
            normal,
            permanent,
        }
    }

    /// Perturbed sign of `orient3d(f0, f1, f2, p)` (see [`point_face`]). The floating-point
    /// evaluation `(p - f0)·n` has the structure of Shewchuk's orient3d (one difference times a
    /// 2x2 minor of differences, three terms), so the same error bound certifies its sign;
    /// otherwise the exact path decides.
    pub(crate) fn side(&self, p: &Point3<f64>, point_in_b: bool) -> SoSSign {
        let w = p - self.corners[0];
        let det = w.x * self.normal[0] + w.y * self.normal[1] + w.z * self.normal[2];
        let permanent = w.x.abs() * self.permanent[0]
            + w.y.abs() * self.permanent[1]
            + w.z.abs() * self.permanent[2];
        let bound = O3D_BOUND * permanent;
        if det > bound || -det > bound {
            return SoSSign {
                sign: if det > 0.0 { 1 } else { -1 },
                tie: false,
            };
        }
        point_face(self.corners, p, point_in_b)
    }
}

/// Perturbed sign of `orient3d(f0, f1, f2, p)` for a face and a point of different surfaces.
/// `point_in_b`: the point belongs to `B` (translated by `τ`), else the face does.
pub(crate) fn point_face(f: [&Point3<f64>; 3], p: &Point3<f64>, point_in_b: bool) -> SoSSign {
    let s = orient3d(f[0], f[1], f[2], p);
    if s != 0 {
        return SoSSign {
            sign: s,
            tie: false,
        };
    }
    // Linear term: +n·τ when the point moves, -n·τ when the face moves.
    let flip = if point_in_b { 1 } else { -1 };
    let sign = (0..3)
        .map(|k| cross_sign(f[0], f[1], f[0], f[2], k))
        .find(|&s| s != 0)
        .map_or(0, |s| s * flip);
    SoSSign { sign, tie: true }
}

/// Perturbed sign of `orient3d(p, q, a, b)` for an edge `pq` of `A` and an edge `ab` of `B`.
/// Callers always pass both edges in canonical vertex order, so every use of one edge pair sees
/// the same value.
pub(crate) fn edge_edge(
    p: &Point3<f64>,
    q: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
) -> SoSSign {
    let s = orient3d(p, q, a, b);
    if s != 0 {
        return SoSSign {
            sign: s,
            tie: false,
        };
    }
    // d/dτ det(q - p, a - p, b - p) with a, b moving = τ · ((b - a) × (q - p)).
    let sign = (0..3)
        .map(|k| cross_sign(a, b, p, q, k))
        .find(|&s| s != 0)
        .unwrap_or(0);
    SoSSign { sign, tie: true }
}

/// Shewchuk's `orient3d` (`det[a - d, b - d, c - d]`, minus ours), exact, by `robust`'s
/// adaptive stages.
fn orient3d_exact(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>, d: &Point3<f64>) -> i8 {
    let coord = |p: &Point3<f64>| robust::Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    };
    let det = robust::orient3d(coord(a), coord(b), coord(c), coord(d));
    if det > 0.0 {
        1
    } else if det < 0.0 {
        -1
    } else {
        0
    }
}

/// Exact `(a1 - a0) (b1 - b0)` as an expansion.
fn diff_product(a1: f64, a0: f64, b1: f64, b0: f64) -> Vec<f64> {
    let (x, ex) = two_sum(a1, -a0);
    let (y, ey) = two_sum(b1, -b0);
    product(&[ex, x], &[ey, y])
}

fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bv = s - a;
    let av = s - bv;
    (s, (a - av) + (b - bv))
}

fn two_product(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

/// Shewchuk's `grow_expansion_zeroelim`.
fn grow(e: &[f64], b: f64) -> Vec<f64> {
    let mut h = Vec::with_capacity(e.len() + 1);
    let mut q = b;
    for &x in e {
        let (s, err) = two_sum(q, x);
        if err != 0.0 {
            h.push(err);
        }
        q = s;
    }
    if q != 0.0 || h.is_empty() {
        h.push(q);
    }
    h
}

/// Sum of two non-overlapping expansions (repeated growth).
fn sum(e: &[f64], f: &[f64]) -> Vec<f64> {
    f.iter().fold(e.to_vec(), |h, &x| grow(&h, x))
}

/// Shewchuk's `scale_expansion_zeroelim`.
fn scale(e: &[f64], b: f64) -> Vec<f64> {
    let mut h = Vec::with_capacity(2 * e.len());
    let Some((&first, rest)) = e.split_first() else {
        return vec![0.0];
    };
    let (mut q, err) = two_product(first, b);
    if err != 0.0 {
        h.push(err);
    }
    for &x in rest {
        let (p1, p0) = two_product(x, b);
        let (s, err) = two_sum(q, p0);
        if err != 0.0 {
            h.push(err);
        }
        let (qn, err) = two_sum(p1, s);
        if err != 0.0 {
            h.push(err);
        }
        q = qn;
    }
    if q != 0.0 || h.is_empty() {
        h.push(q);
    }
    h
}

fn product(e: &[f64], f: &[f64]) -> Vec<f64> {
    f.iter().fold(vec![0.0], |acc, &x| sum(&acc, &scale(e, x)))
}

fn negate(e: &[f64]) -> Vec<f64> {
    e.iter().map(|x| -x).collect()
}

/// Sign of a non-overlapping expansion: the sign of its largest (last non-zero) component.
fn expansion_sign(e: &[f64]) -> i8 {
    match e.iter().rev().find(|x| **x != 0.0) {
        Some(x) if *x > 0.0 => 1,
        Some(_) => -1,
        None => 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64, z: f64) -> Point3<f64> {
        Point3::new(x, y, z)
    }

    #[test]
    fn orient3d_sign_convention() {
        let (a, b, c) = (p(0., 0., 0.), p(1., 0., 0.), p(0., 1., 0.));
        assert_eq!(orient3d(&a, &b, &c, &p(0.2, 0.2, 1.0)), 1);
        assert_eq!(orient3d(&a, &b, &c, &p(0.2, 0.2, -1.0)), -1);
        assert_eq!(orient3d(&a, &b, &c, &p(5.0, -3.0, 0.0)), 0);
    }

    #[test]
    fn exact_path_decides_near_degenerate_cases() {
        // d is on the plane up to one ulp: the filter fails, the expansion decides.
        let (a, b, c) = (p(0.1, 0.2, 0.3), p(1.3, 0.7, 0.3), p(0.4, 1.9, 0.3));
        let up = p(0.5, 0.5, f64::from_bits(0.3f64.to_bits() + 1));
        let down = p(0.5, 0.5, f64::from_bits(0.3f64.to_bits() - 1));
        assert_eq!(orient3d(&a, &b, &c, &up), 1);
        assert_eq!(orient3d(&a, &b, &c, &down), -1);
        assert_eq!(orient3d(&a, &b, &c, &p(0.5, 0.5, 0.3)), 0);
        assert_eq!(orient3d_exact(&a, &b, &c, &up), -1);
    }

    /// On lattice points (integers scaled by 2^-20: exact in `f64`) the sign agrees with the
    /// determinant in integer arithmetic, for exactly coplanar points (zero: the exact path
    /// must confirm it) and for points one lattice step off the plane.
    #[test]
    fn orient3d_agrees_with_integer_arithmetic() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = |range: i64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % (2 * range as u64 + 1)) as i64 - range
        };
        let scale = (-20f64).exp2();
        let point = |v: [i64; 3]| {
            p(
                v[0] as f64 * scale,
                v[1] as f64 * scale,
                v[2] as f64 * scale,
            )
        };
        let det = |a: [i64; 3], b: [i64; 3], c: [i64; 3], d: [i64; 3]| {
            let u = [0, 1, 2].map(|k| (b[k] - a[k]) as i128);
            let v = [0, 1, 2].map(|k| (c[k] - a[k]) as i128);
            let w = [0, 1, 2].map(|k| (d[k] - a[k]) as i128);
            (u[1] * v[2] - u[2] * v[1]) * w[0]
                + (u[2] * v[0] - u[0] * v[2]) * w[1]
                + (u[0] * v[1] - u[1] * v[0]) * w[2]
        };
        let (mut zeros, mut off) = (0, 0);
        for _ in 0..2000 {
            let a = [0; 3].map(|_| next(1 << 19));
            let b = [0, 1, 2].map(|k| a[k] + next(1 << 18));
            let c = [0, 1, 2].map(|k| a[k] + next(1 << 18));
            let (s, t) = (next(4), next(4));
            let mut d = [0, 1, 2].map(|k| a[k] + s * (b[k] - a[k]) + t * (c[k] - a[k]));
            let axis = next(1) + 1;
            d[axis as usize] += next(1);
            let exact = det(a, b, c, d).signum() as i8;
            zeros += usize::from(exact == 0);
            off += usize::from(exact != 0);
            assert_eq!(orient3d(&point(a), &point(b), &point(c), &point(d)), exact);
        }
        assert!(
            zeros > 100 && off > 100,
            "both cases drawn: {zeros} coplanar, {off} off"
        );
    }

    /// Shewchuk's `orient3d` written out with this module's expansion arithmetic (the exact
    /// path before `robust`): an independent exact reference.
    fn expansion_orient3d(
        a: &Point3<f64>,
        b: &Point3<f64>,
        c: &Point3<f64>,
        d: &Point3<f64>,
    ) -> i8 {
        let diff = |p: &Point3<f64>, k: usize| {
            let (x, e) = two_sum(p[k], -d[k]);
            vec![e, x]
        };
        let (ad, bd, cd) = (
            [diff(a, 0), diff(a, 1), diff(a, 2)],
            [diff(b, 0), diff(b, 1), diff(b, 2)],
            [diff(c, 0), diff(c, 1), diff(c, 2)],
        );
        let minor = |u: &[Vec<f64>; 3], v: &[Vec<f64>; 3]| {
            sum(&product(&u[0], &v[1]), &negate(&product(&v[0], &u[1])))
        };
        let t1 = product(&ad[2], &minor(&bd, &cd));
        let t2 = product(&bd[2], &minor(&cd, &ad));
        let t3 = product(&cd[2], &minor(&ad, &bd));
        -expansion_sign(&sum(&sum(&t1, &t2), &t3))
    }

    /// Points a few ulps off planes in general position, where the filter cannot decide: the
    /// adaptive path agrees with the expansion arithmetic.
    #[test]
    fn near_coplanar_signs_agree_with_expansion_arithmetic() {
        let mut x = 0.377f64;
        let mut next = || {
            x = (x * 9.73 + 0.113).fract();
            x
        };
        let mut undecided = 0;
        for _ in 0..3000 {
            let a = p(next(), next(), next());
            let b = p(next(), next(), next());
            let c = p(next(), next(), next());
            let (s, t) = (next() - 0.3, next() - 0.3);
            let on = a + (b - a) * s + (c - a) * t;
            let k = (next() * 3.0) as usize;
            let steps = (next() * 7.0) as i64 - 3;
            let mut d = on;
            d[k] = f64::from_bits((d[k].to_bits() as i64 + steps) as u64);
            let expected = expansion_orient3d(&a, &b, &c, &d);
            assert_eq!(orient3d(&a, &b, &c, &d), expected, "{a} {b} {c} {d}");
            undecided += usize::from(orient3d_filtered(&a, &b, &c, &d).is_none());
        }
        assert!(
            undecided > 1000,
            "the exact path was exercised {undecided} times"
        );
    }

    #[test]
    fn face_plane_filter_agrees_with_orient3d() {
        let (a, b, c) = (p(0.1, 0.2, 0.3), p(1.3, 0.7, 0.35), p(0.4, 1.9, 0.25));
        let plane = FacePlane::new([&a, &b, &c]);
        let mut x = 0.123f64;
        for _ in 0..1000 {
            x = (x * 3.7 + 0.31).fract();
            let q = p(
                x * 2.0 - 0.5,
                (x * 7.0).fract() * 2.0,
                0.3 + (x - 0.5) * 1e-15,
            );
            let s = plane.side(&q, true);
            let exact = orient3d(&a, &b, &c, &q);
            if exact != 0 {
                assert_eq!(s.sign, exact);
                assert!(!s.tie);
            }
        }
    }

    #[test]
    fn collinear_cross_component_is_zero() {
        let (a, b) = (p(0.1, 0.1, 0.1), p(0.3, 0.3, 0.3));
        for k in 0..3 {
            assert_eq!(cross_sign(&a, &b, &a, &p(0.7, 0.7, 0.7), k), 0);
        }
    }
}
