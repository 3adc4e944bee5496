//! Exact volume preservation: the volume change as a cubic in the bulge height `h` and its
//! root (2021 Sec. 5.3 "Volume preservation"; `PIPELINE.md` "Exact volume").
//!
//! Displaced vertices are `P_i + h Q_i`: `P_i = p_i + A_i d_i` is the position with zero bulge
//! and `Q_i = N_2(t_i) η_i d_i` the bulge direction scaled by its basis weight and the bulge map
//! (no γ during the solve); unmoved vertices have `P_i = p_i`, `Q_i = 0`. By the divergence
//! theorem `6 V = Σ_faces [a, b, c]` with `[x, y, z] = x·(y × z)`, so per face the change is
//! trilinear in `P + hQ`:
//!
//! ```text
//! 6 ΔV(h) = Σ ([P] - [p]) + h Σ ([Q,P,P] + [P,Q,P] + [P,P,Q])
//!                         + h² Σ ([P,Q,Q] + [Q,P,Q] + [Q,Q,P]) + h³ Σ [Q,Q,Q]
//! ```
//!
//! summed over the faces with a moved vertex only: the other faces do not change, and the
//! boundary of the moved patch is fixed, so the sum does not depend on the origin.

use nalgebra::{Point3, Vector3};

/// Errors of [`VolumeCubic::assemble`] and [`VolumeCubic::solve`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum VolumeError {
    /// `rest`, `base` and `bulge` do not have the same length.
    #[error("rest ({rest}), base ({base}) and bulge ({bulge}) lengths differ")]
    LengthMismatch {
        /// Length of `rest`.
        rest: usize,
        /// Length of `base`.
        base: usize,
        /// Length of `bulge`.
        bulge: usize,
    },
    /// A face index is not a triangle of `triangles`.
    #[error("face {0} is out of range")]
    FaceOutOfRange(u32),
    /// A triangle references a vertex that does not exist.
    #[error("vertex {0} is out of range")]
    VertexOutOfRange(u32),
    /// A position or bulge vector of an involved vertex is not finite.
    #[error("vertex {0} has a non-finite position or bulge vector")]
    NonFinite(u32),
    /// The cubic's coefficients are not finite (overflow).
    #[error("the volume cubic has non-finite coefficients")]
    NonFiniteCoefficients,
}

/// How [`VolumeCubic::solve`] picks among several real roots of the sign of `h_lin`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RootChoice {
    /// The root nearest the linear estimate `h_lin = -c0/c1` (`PIPELINE.md`). It jumps
    /// between two roots when they become equidistant from `h_lin` (roots `0.8 h_lin` and
    /// `1.2 h_lin`: a coefficient change of ~1e-4 moves `h` by 50 %).
    #[default]
    NearestLinear,
    /// The root of smallest magnitude, i.e. the first zero crossing from `h = 0` in the
    /// direction of `h_lin` (the paper's "smallest positive root" when `h_lin > 0`): the
    /// smallest bulge that restores the volume; continuous except where a new pair of roots
    /// appears below it.
    FirstCrossing,
}

/// What kind of value [`VolumeRoot::h`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RootKind {
    /// A real root of `ΔV(h) = 0` (including `h = 0` when `c0 = 0`).
    Exact,
    /// No real root has the sign of `h_lin`: `h` is the first stationary point of `ΔV` in that
    /// direction, the bulge that brings the volume closest to the rest volume.
    ClosestApproach,
    /// `c1` vanishes against its own magnitude (no bulge compensates to first order, e.g.
    /// `Q = 0`): `h = 0`.
    NoBulge,
}

/// The bulge height that preserves the volume (2021 Sec. 5.3), with how it was obtained.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeRoot {
    /// The bulge height `h_v`.
    pub h: f64,
    /// Exact root or documented fallback.
    pub kind: RootKind,
    /// The linear estimate `h_lin = -c0/c1` (0 when `kind` is [`RootKind::NoBulge`] or
    /// `c0 = 0`).
    pub linear: f64,
    /// `ΔV(h)`, the volume error left.
    pub residual: f64,
}

/// The volume change `ΔV(h) = Σ_k coefficients[k] h^k` (2021 Sec. 5.3; `PIPELINE.md` "Exact
/// volume"). The coefficients are those of `ΔV`, i.e. the triple-product sums divided by 6.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeCubic {
    /// `[c0, c1, c2, c3]` of `ΔV` (not `6 ΔV`).
    pub coefficients: [f64; 4],
    /// Sums of the absolute values of the terms of each coefficient (same factor 1/6): the
    /// scale against which cancellation is judged.
    pub magnitudes: [f64; 4],
}

/// `x·(y × z)`.
fn triple(x: &Vector3<f64>, y: &Vector3<f64>, z: &Vector3<f64>) -> f64 {
    x.dot(&y.cross(z))
}

/// The vertex triples `(p, P, Q)` of one face, relative to `origin`.
type Corners = [(Vector3<f64>, Vector3<f64>, Vector3<f64>); 3];

/// The 4 coefficients (times 6) of one face and the absolute values of their terms.
/// `c0 = [P] - [p]` is written `(Pa - pa)·(Pb×Pc) + pa·((Pb - pb)×Pc + pb×(Pc - pc))` so that
/// its error scales with the displacement, not with the size of the mesh.
fn face_terms(c: &Corners) -> ([f64; 4], [f64; 4]) {
    let [(pa, ba, qa), (pb, bb, qb), (pc, bc, qc)] = c;
    let (bb_bc, qb_qc) = (bb.cross(bc), qb.cross(qc));
    let mixed = bb.cross(qc) + qb.cross(bc);
    let t0 = [
        (ba - pa).dot(&bb_bc),
        triple(pa, &(bb - pb), bc),
        triple(pa, pb, &(bc - pc)),
    ];
    let t1 = [qa.dot(&bb_bc), ba.dot(&mixed)];
    let t2 = [ba.dot(&qb_qc), qa.dot(&mixed)];
    let t3 = qa.dot(&qb_qc);
    let sum = [t0.iter().sum(), t1[0] + t1[1], t2[0] + t2[1], t3];
    let abs = [
        t0.iter().map(|x| x.abs()).sum(),
        t1[0].abs() + t1[1].abs(),
        t2[0].abs() + t2[1].abs(),
        t3.abs(),
    ];
    (sum, abs)
}

impl VolumeCubic {
    /// A cubic from its coefficients `[c0, c1, c2, c3]` (magnitudes `|c_k|`).
    pub fn from_coefficients(coefficients: [f64; 4]) -> VolumeCubic {
        VolumeCubic {
            coefficients,
            magnitudes: coefficients.map(f64::abs),
        }
    }

    /// Assembles `ΔV(h)` over `faces` (indices into `triangles`) in one pass (2021 Sec. 5.3;
    /// `PIPELINE.md` "Exact volume"). `rest` = `p`, `base` = `P`, `bulge` = `Q`, all indexed by
    /// vertex. `faces` must contain every face with a moved vertex ([`moved_faces`] builds
    /// it), otherwise the result depends on the origin. The origin is the centroid of the
    /// involved rest vertices, which limits cancellation far from the world origin.
    pub fn assemble(
        triangles: &[[u32; 3]],
        faces: &[u32],
        rest: &[Point3<f64>],
        base: &[Point3<f64>],
        bulge: &[Vector3<f64>],
    ) -> Result<VolumeCubic, VolumeError> {
        if rest.len() != base.len() || rest.len() != bulge.len() {
            return Err(VolumeError::LengthMismatch {
                rest: rest.len(),
                base: base.len(),
                bulge: bulge.len(),
            });
        }
        let tris = checked_faces(triangles, faces, rest, base, bulge)?;
        let origin = centroid(&tris, rest);
        let corner = |i: u32| {
            let i = i as usize;
            (rest[i] - origin, base[i] - origin, bulge[i])
        };
        let (mut sum, mut abs) = ([0.0; 4], [0.0; 4]);
        for tri in &tris {
            let (s, a) = face_terms(&tri.map(corner));
            for k in 0..4 {
                sum[k] += s[k];
                abs[k] += a[k];
            }
        }
        Ok(VolumeCubic {
            coefficients: sum.map(|c| c / 6.0),
            magnitudes: abs.map(|c| c / 6.0),
        })
    }

    /// `ΔV(h)` (Horner).
    pub fn evaluate(&self, h: f64) -> f64 {
        let [c0, c1, c2, c3] = self.coefficients;
        ((c3 * h + c2) * h + c1) * h + c0
    }

    /// `dΔV/dh`.
    pub fn derivative(&self, h: f64) -> f64 {
        let [_, c1, c2, c3] = self.coefficients;
        (3.0 * c3 * h + 2.0 * c2) * h + c1
    }

    /// The bulge height `h` with `ΔV(h) = 0`, with [`RootChoice::NearestLinear`]: the real root
    /// nearest `h_lin = -c0/c1` among those of its sign (`PIPELINE.md`). See
    /// [`VolumeCubic::solve_with`].
    pub fn solve(&self) -> Result<VolumeRoot, VolumeError> {
        self.solve_with(RootChoice::NearestLinear)
    }

    /// The bulge height `h` with `ΔV(h) = 0` (2021 Sec. 5.3 "Volume preservation").
    ///
    /// In `x = h / h_lin` the cubic reads `ΔV = c0 (1 - x + β x² + α x³)` with
    /// `β = -c2 h_lin / c1`, `α = -c3 h_lin² / c1`; it equals `c0` at `x = 0` with slope
    /// `-c0`, and its roots satisfy `Σ 1/x_i = 1`. Its positive roots are bracketed between
    /// the critical points (each monotone piece holds at most one root, so quadratic and
    /// linear degenerations need no special case) and found by safeguarded Newton to adjacent
    /// floats. `choice` picks among them: the paper's "smallest positive root" is
    /// [`RootChoice::FirstCrossing`] when `h_lin > 0`; the two choices differ exactly when
    /// the smallest root is `x < 1` and another positive root is nearer 1 (e.g. roots
    /// `x = 0.8, 1.1, -0.863`). For `h_lin < 0` the paper's rule would take a root of the wrong
    /// sign. Fallbacks (never a panic): `c0 = 0` → `h = 0` ([`RootKind::Exact`]);
    /// `|c1| ≤ 1e-12 ×` its term magnitude or non-finite ratios → `h = 0`
    /// ([`RootKind::NoBulge`]); no root of the sign of `h_lin` → the first stationary point
    /// ([`RootKind::ClosestApproach`]). Errors only for non-finite coefficients.
    pub fn solve_with(&self, choice: RootChoice) -> Result<VolumeRoot, VolumeError> {
        if self.coefficients.iter().any(|c| !c.is_finite()) {
            return Err(VolumeError::NonFiniteCoefficients);
        }
        let [c0, c1, c2, c3] = self.coefficients;
        let root = |h: f64, kind: RootKind, linear: f64| VolumeRoot {
            h,
            kind,
            linear,
            residual: self.evaluate(h),
        };
        if c0 == 0.0 {
            return Ok(root(0.0, RootKind::Exact, 0.0));
        }
        let h_lin = -c0 / c1;
        let (beta, alpha) = (-c2 * h_lin / c1, -c3 * h_lin * h_lin / c1);
        let negligible = c1.abs() <= 1e-12 * self.magnitudes[1];
        if negligible || ![h_lin, beta, alpha].iter().all(|v| v.is_finite()) {
            return Ok(root(0.0, RootKind::NoBulge, 0.0));
        }
        let reduced = Reduced { alpha, beta };
        let (x, kind) = match reduced.pick_root(choice) {
            Some(x) => (x, RootKind::Exact),
            None => (reduced.first_stationary(), RootKind::ClosestApproach),
        };
        let h = self.polish(h_lin * x, kind);
        Ok(root(h, kind, h_lin))
    }

    /// One Newton step on the original coefficients, kept only if it lowers `|ΔV|`.
    fn polish(&self, h: f64, kind: RootKind) -> f64 {
        if kind != RootKind::Exact {
            return h;
        }
        let step = h - self.evaluate(h) / self.derivative(h);
        if step.is_finite() && self.evaluate(step).abs() < self.evaluate(h).abs() {
            step
        } else {
            h
        }
    }
}

/// The faces to sum over, validated: in range, finite data.
fn checked_faces(
    triangles: &[[u32; 3]],
    faces: &[u32],
    rest: &[Point3<f64>],
    base: &[Point3<f64>],
    bulge: &[Vector3<f64>],
) -> Result<Vec<[u32; 3]>, VolumeError> {
    faces
        .iter()
        .map(|&f| {
            let tri = *triangles
                .get(f as usize)
                .ok_or(VolumeError::FaceOutOfRange(f))?;
            for v in tri {
                let i = v as usize;
                if i >= rest.len() {
                    return Err(VolumeError::VertexOutOfRange(v));
                }
                let finite = rest[i].coords.iter().chain(base[i].coords.iter());
                if !finite.chain(bulge[i].iter()).all(|x| x.is_finite()) {
                    return Err(VolumeError::NonFinite(v));
                }
            }
            Ok(tri)
        })
        .collect()
}

/// Centroid of the rest positions of the corners (repeated corners counted repeatedly).
fn centroid(tris: &[[u32; 3]], rest: &[Point3<f64>]) -> Point3<f64> {
    let n = (3 * tris.len()).max(1) as f64;
    let sum: Vector3<f64> = tris
        .iter()
        .flatten()
        .map(|&i| rest[i as usize].coords)
        .sum();
    Point3::from(sum / n)
}

/// The faces of `triangles` with at least one moved vertex (`base ≠ rest` or `bulge ≠ 0`):
/// the faces [`VolumeCubic::assemble`] must sum over. Out-of-range vertices count as unmoved
/// (`assemble` reports them if listed).
pub fn moved_faces(
    triangles: &[[u32; 3]],
    rest: &[Point3<f64>],
    base: &[Point3<f64>],
    bulge: &[Vector3<f64>],
) -> Vec<u32> {
    let moved = |i: u32| {
        let i = i as usize;
        match (rest.get(i), base.get(i), bulge.get(i)) {
            (Some(p), Some(b), Some(q)) => p != b || *q != Vector3::zeros(),
            _ => false,
        }
    };
    (0..triangles.len())
        .filter(|&f| triangles[f].iter().any(|&v| moved(v)))
        .map(|f| f as u32)
        .collect()
}

/// The reduced cubic `g(x) = α x³ + β x² - x + 1` (`ΔV / c0` at `h = h_lin x`).
#[derive(Clone, Copy, Debug)]
struct Reduced {
    alpha: f64,
    beta: f64,
}

/// Maximum number of safeguarded Newton / bisection iterations per bracket.
const MAX_ROOT_ITERATIONS: u32 = 300;

impl Reduced {
    fn value(&self, x: f64) -> f64 {
        ((self.alpha * x + self.beta) * x - 1.0) * x + 1.0
    }

    fn slope(&self, x: f64) -> f64 {
        (3.0 * self.alpha * x + 2.0 * self.beta) * x - 1.0
    }

    /// Positive roots of `g' = 3α x² + 2β x - 1`, ascending (stable quadratic formula).
    fn positive_critical_points(&self) -> Vec<f64> {
        let (qa, qb) = (3.0 * self.alpha, 2.0 * self.beta);
        let mut points = if qa == 0.0 {
            vec![1.0 / qb]
        } else {
            let disc = qb * qb + 4.0 * qa;
            if disc < 0.0 {
                vec![]
            } else {
                // q ≠ 0: qb = 0 and disc > 0 give q = -sqrt(qa) (qa > 0 when disc ≥ 0).
                let q = -0.5 * (qb + qb.signum() * disc.sqrt());
                vec![q / qa, -1.0 / q]
            }
        };
        points.retain(|x| x.is_finite() && *x > 0.0);
        points.sort_by(f64::total_cmp);
        points
    }

    /// The positive roots of `g`, one per monotone piece with a sign change.
    fn positive_roots(&self) -> Vec<f64> {
        let mut ends = vec![0.0];
        ends.extend(self.positive_critical_points());
        let mut roots = Vec::new();
        for w in ends.windows(2) {
            if self.value(w[0]).signum() != self.value(w[1]).signum() || self.value(w[1]) == 0.0 {
                roots.push(self.bisect_newton(w[0], w[1]));
            }
        }
        let last = *ends.last().unwrap_or(&0.0);
        if let Some(hi) = self.unbounded_bracket(last) {
            roots.push(self.bisect_newton(last, hi));
        }
        roots
    }

    /// An end `hi > lo` with a sign change of `g` on `[lo, hi]`, trying `max(lo, 1)` then doubling;
    /// `None` if the last piece keeps the sign of `g(lo)` (or `g(lo) = 0`).
    fn unbounded_bracket(&self, lo: f64) -> Option<f64> {
        let start = self.value(lo);
        if start == 0.0 {
            return None;
        }
        let mut hi = lo.max(1.0);
        while hi.is_finite() {
            if hi > lo && self.value(hi).signum() != start.signum() {
                return Some(hi);
            }
            hi *= 2.0;
        }
        None
    }

    /// The root of `g` in `[lo, hi]`, where `g` is monotone and changes sign.
    fn bisect_newton(&self, mut lo: f64, mut hi: f64) -> f64 {
        let lo_sign = self.value(lo).signum();
        let mut x = 0.5 * (lo + hi);
        for _ in 0..MAX_ROOT_ITERATIONS {
            let g = self.value(x);
            if g == 0.0 {
                return x;
            }
            if g.signum() == lo_sign {
                lo = x;
            } else {
                hi = x;
            }
            let step = x - g / self.slope(x);
            x = if step > lo && step < hi {
                step
            } else {
                0.5 * (lo + hi)
            };
            if hi - lo <= 2.0 * f64::EPSILON * hi.abs() {
                break;
            }
        }
        x
    }

    /// The positive root chosen by `choice`, if any.
    fn pick_root(&self, choice: RootChoice) -> Option<f64> {
        let roots = self.positive_roots();
        match choice {
            RootChoice::FirstCrossing => roots.into_iter().min_by(f64::total_cmp),
            RootChoice::NearestLinear => roots
                .into_iter()
                .min_by(|a, b| (a - 1.0).abs().total_cmp(&(b - 1.0).abs())),
        }
    }

    /// The first positive critical point (exists whenever `g` has no positive root, since
    /// `g(0) = 1` and `g'(0) = -1`); 1 as a last resort.
    fn first_stationary(&self) -> f64 {
        self.positive_critical_points()
            .first()
            .copied()
            .unwrap_or(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `c0 (1 - x/r1)(1 - x/r2)(1 - x/r3)` in `x = h / h_lin`, with `Σ 1/r = 1`, as a cubic in h.
    fn cubic_with_roots(c0: f64, h_lin: f64, r: [f64; 3]) -> VolumeCubic {
        let s = [h_lin * r[0], h_lin * r[1], h_lin * r[2]];
        let e1 = 1.0 / s[0] + 1.0 / s[1] + 1.0 / s[2];
        let e2 = 1.0 / (s[0] * s[1]) + 1.0 / (s[0] * s[2]) + 1.0 / (s[1] * s[2]);
        let e3 = 1.0 / (s[0] * s[1] * s[2]);
        VolumeCubic::from_coefficients([c0, -c0 * e1, c0 * e2, -c0 * e3])
    }

    #[test]
    fn linear_and_quadratic_degenerations() {
        let lin = VolumeCubic::from_coefficients([2.0, -4.0, 0.0, 0.0])
            .solve()
            .unwrap();
        assert_eq!((lin.h, lin.kind), (0.5, RootKind::Exact));
        // 1 - x + 0.24 x²: roots 1.6667 and 2.5.
        let quad = VolumeCubic::from_coefficients([1.0, -1.0, 0.24, 0.0])
            .solve()
            .unwrap();
        assert!((quad.h - 1.0 / 0.6).abs() < 1e-14, "{quad:?}");
    }

    #[test]
    fn choices_differ_when_the_smallest_root_is_below_h_lin() {
        let r3 = 1.0 / (1.0 - 1.0 / 0.8 - 1.0 / 1.1);
        let cubic = cubic_with_roots(-3.0, 0.25, [0.8, 1.1, r3]);
        let nearest = cubic.solve().unwrap();
        let first = cubic.solve_with(RootChoice::FirstCrossing).unwrap();
        assert!((nearest.h - 0.25 * 1.1).abs() < 1e-14, "{nearest:?}");
        assert!((first.h - 0.25 * 0.8).abs() < 1e-14, "{first:?}");
    }
}
