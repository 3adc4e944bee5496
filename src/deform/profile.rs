//! The profile curve `H` of the deformation (2021 Sec. 5.3, Algorithm Part 2 lines 49-60,
//! with the corrections of `PIPELINE.md`, paragraph "Profile curve").
//!
//! `H` is a planar cubic B-spline `(f1(t), f2(t)) = Σ_k N_k³(t) v_k`, `t ∈ [0, 1]`, on the
//! clamped uniform knots `[0, 0, 0, 0, 1/3, 2/3, 1, 1, 1, 1]`, with six control points
//!
//! ```text
//! v0 = (0, -a)   v1 = (0.2 cos θ, a (0.4 sin θ - 1))   v2 = (0.4, y2)
//! v3 = (0.6, 0)  v4 = (0.8, 0)                          v5 = (1, 0)
//! ```
//!
//! `a` is the amplitude (depth at `u = 0`), `s` the slope and `y2 = γ η h_v` the bulge ordinate.
//! The paper prints `θ = atan(s / a)`; the start tangent is `9 (v1 - v0)`, whose slope is
//! `2 a tan θ`, so the printed θ gives `dH/du(0) = 2 s`. We use **`θ = atan2(s, 2a)`**, which
//! gives `dH/du(0) = s` exactly for `a > 0` and keeps the paper's ellipse of semi-axes
//! `0.2` and `0.4 a` around `v0`. A vertex with parameter `u` is displaced by
//! `H(u) = f2(f1⁻¹(u))` along its direction `d`.
//!
//! Properties (tested): `H(0) = -a`, `dH/du(0) = s` (for `a > 0`), `H(1) = dH/du(1) = 0`, `H` is
//! C¹ in `u` (C² in `t`), `f1` is strictly increasing on `(0, 1]` for every θ (its control
//! abscissae are non-decreasing because `cos θ ≥ 0`), and `f2 = A(t) + N_2(t) y2` is affine in
//! the bulge ordinate.

use std::sync::LazyLock;

/// Clamped uniform knot vector of the cubic B-spline (2021 App. B line 50).
const KNOTS: [f64; 10] = [0.0, 0.0, 0.0, 0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0, 1.0, 1.0, 1.0];

/// Span boundaries of the curve parameter (the distinct knots).
const BREAKS: [f64; 4] = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0];

/// Index of the control point whose ordinate carries the bulge (`v2`, App. B line 59).
pub const BULGE_INDEX: usize = 2;

/// Relative tolerance of [`Profile::parameter_at`]: it stops when `|f1(t) - u| ≤ 4 ε u`
/// (`ε` the machine epsilon), i.e. below `1e-15` absolute on `[0, 1]`.
pub const INVERSE_TOLERANCE: f64 = 4.0 * f64::EPSILON;

/// Maximum number of safeguarded Newton iterations of [`Profile::parameter_at`].
const MAX_INVERSE_ITERATIONS: u32 = 100;

/// Clamps `x` to `[0, 1]`; NaN maps to `nan_value`.
fn clamp_unit(x: f64, nan_value: f64) -> f64 {
    if x.is_nan() {
        nan_value
    } else {
        x.clamp(0.0, 1.0)
    }
}

/// `num / den`, with `0` when `den = 0` (the Cox–de Boor convention `0/0 = 0`).
fn ratio(num: f64, den: f64) -> f64 {
    if den == 0.0 {
        0.0
    } else {
        num / den
    }
}

/// Index `i` of the non-empty knot interval `[KNOTS[i], KNOTS[i+1])` holding `t`
/// (`t = 1` belongs to the last one).
fn knot_span(t: f64) -> usize {
    (3..6).find(|&i| t < KNOTS[i + 1]).unwrap_or(5)
}

/// Degree-2 and degree-3 B-spline basis values at `t ∈ [0, 1]` (Cox–de Boor recursion).
fn basis_degrees_2_3(t: f64) -> ([f64; 7], [f64; 6]) {
    let mut n = [0.0; 9];
    n[knot_span(t)] = 1.0;
    let mut quadratic = [0.0; 7];
    for p in 1..=3 {
        for i in 0..(9 - p) {
            let left = ratio(t - KNOTS[i], KNOTS[i + p] - KNOTS[i]);
            let right = ratio(KNOTS[i + p + 1] - t, KNOTS[i + p + 1] - KNOTS[i + 1]);
            n[i] = left * n[i] + right * n[i + 1];
        }
        if p == 2 {
            quadratic.copy_from_slice(&n[..7]);
        }
    }
    let mut cubic = [0.0; 6];
    cubic.copy_from_slice(&n[..6]);
    (quadratic, cubic)
}

/// The six cubic B-spline basis functions `N_k³(t)` on the clamped uniform knots
/// `[0,0,0,0,1/3,2/3,1,1,1,1]` (2021 App. B line 50). `t` is clamped to `[0, 1]` (NaN → 1).
/// They are non-negative and sum to 1.
pub fn basis(t: f64) -> [f64; 6] {
    basis_degrees_2_3(clamp_unit(t, 1.0)).1
}

/// Derivatives `dN_k³/dt` of the six basis functions of [`basis`] (2021 App. B line 50), from
/// the degree-2 basis: `N'_{k,3} = 3 (N_{k,2} / (τ_{k+3} - τ_k) - N_{k+1,2} / (τ_{k+4} - τ_{k+1}))`.
/// `t` is clamped to `[0, 1]` (NaN → 1). They sum to 0.
pub fn basis_derivative(t: f64) -> [f64; 6] {
    let (quadratic, _) = basis_degrees_2_3(clamp_unit(t, 1.0));
    derivative_from_quadratic(&quadratic)
}

/// [`basis_derivative`] from the degree-2 basis at the same `t`.
fn derivative_from_quadratic(quadratic: &[f64; 7]) -> [f64; 6] {
    std::array::from_fn(|k| {
        3.0 * (ratio(quadratic[k], KNOTS[k + 3] - KNOTS[k])
            - ratio(quadratic[k + 1], KNOTS[k + 4] - KNOTS[k + 1]))
    })
}

/// [`basis`] at the span breaks [`BREAKS`], the same for every profile: computed once.
static BREAK_BASIS: LazyLock<[[f64; 6]; 4]> = LazyLock::new(|| BREAKS.map(basis));

/// `N_2³(t)`, the basis function of the bulge control point `v2`: the factor of the bulge
/// ordinate in `f2` (2021 Sec. 5.3 and App. B line 59; `PIPELINE.md` "Exact volume":
/// `Q_i = N_2(t_i) η_i d_i`). `t` is clamped to `[0, 1]` (NaN → 1, where it is 0).
pub fn bulge_basis(t: f64) -> f64 {
    basis(t)[BULGE_INDEX]
}

/// Σ_k w_k c_k over the six control coordinates.
fn combine(weights: &[f64; 6], coords: &[f64; 6]) -> f64 {
    weights.iter().zip(coords).map(|(w, c)| w * c).sum()
}

/// One profile curve `H_{a,s}` (2021 Sec. 5.3, App. B lines 50-55; `PIPELINE.md`
/// "Profile curve"), with the bulge ordinate `y2` left free: every ordinate query takes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    amplitude: f64,
    slope: f64,
    theta: f64,
    abscissae: [f64; 6],
    base_ordinates: [f64; 6],
}

impl Profile {
    /// The profile of amplitude `a` (`H(0) = -a`) and slope `s` (`dH/du(0) = s`), with
    /// `θ = atan2(s, 2a)` (2021 App. B lines 52-54 as corrected in `PIPELINE.md`).
    ///
    /// Fallbacks: a non-finite `amplitude` or `slope` is treated as 0. A negative amplitude
    /// is accepted (the curve starts above the axis) with `θ = atan2(s sgn a, 2|a|)`, which
    /// keeps `cos θ ≥ 0` (so `f1` stays monotone) and `dH/du(0) = s`. With `a = 0` and
    /// `s ≠ 0`, `θ = ±π/2` and `v1 = v0 = (0, 0)`: the start tangent vanishes and the slope
    /// at `u = 0` is that of the bulge alone (0 for `y2 = 0`): no slope without amplitude.
    pub fn new(amplitude: f64, slope: f64) -> Profile {
        let a = if amplitude.is_finite() {
            amplitude
        } else {
            0.0
        };
        let s = if slope.is_finite() { slope } else { 0.0 };
        let sign = if a < 0.0 { -1.0 } else { 1.0 };
        let theta = (sign * s).atan2(2.0 * a.abs());
        let (sin, cos) = theta.sin_cos();
        Profile {
            amplitude: a,
            slope: s,
            theta,
            abscissae: [0.0, 0.2 * cos, 0.4, 0.6, 0.8, 1.0],
            base_ordinates: [-a, a * (0.4 * sin - 1.0), 0.0, 0.0, 0.0, 0.0],
        }
    }

    /// The amplitude `a` after the fallbacks of [`Profile::new`].
    pub fn amplitude(&self) -> f64 {
        self.amplitude
    }

    /// The slope `s` after the fallbacks of [`Profile::new`].
    pub fn slope(&self) -> f64 {
        self.slope
    }

    /// The angle `θ = atan2(s, 2a)` placing `v1` on its ellipse (2021 Sec. 5.3, Fig. 8 right).
    pub fn theta(&self) -> f64 {
        self.theta
    }

    /// The six control points `v0..v5` with bulge ordinate `y2 = γ η h_v` (2021 App. B lines
    /// 53-54 and 59). A non-finite `bulge_ordinate` is treated as 0.
    pub fn control_points(&self, bulge_ordinate: f64) -> [[f64; 2]; 6] {
        let y2 = finite_or_zero(bulge_ordinate);
        std::array::from_fn(|k| {
            let bulge = if k == BULGE_INDEX { y2 } else { 0.0 };
            [self.abscissae[k], self.base_ordinates[k] + bulge]
        })
    }

    /// The abscissa `f1(t)` (2021 App. B line 50); `t` clamped to `[0, 1]` (NaN → 1).
    pub fn abscissa(&self, t: f64) -> f64 {
        combine(&basis(t), &self.abscissae)
    }

    /// `df1/dt` at `t` (clamped to `[0, 1]`, NaN → 1). Non-negative, zero only at `t = 0`
    /// when `cos θ = 0`.
    pub fn abscissa_derivative(&self, t: f64) -> f64 {
        combine(&basis_derivative(t), &self.abscissae)
    }

    /// `t = f1⁻¹(u)` (2021 App. B line 55), `u` clamped to `[0, 1]` (NaN → 1, i.e. no
    /// displacement). Per-span bisection plus safeguarded Newton, to
    /// `|f1(t) - u| ≤` [`INVERSE_TOLERANCE`]` · u` (or adjacent floats in `t`). `f1` is
    /// strictly increasing but `f1'(0) = 1.8 cos θ → 0` as `|θ| → π/2`, where `t ~ √u` near 0:
    /// the bracket keeps Newton safe there.
    pub fn parameter_at(&self, u: f64) -> f64 {
        self.invert_abscissa(u).0
    }

    /// [`Profile::parameter_at`] together with the number of Newton/bisection iterations.
    pub fn invert_abscissa(&self, u: f64) -> (f64, u32) {
        let u = clamp_unit(u, 1.0);
        let ends = BREAK_BASIS.map(|b| combine(&b, &self.abscissae));
        if u <= ends[0] {
            return (0.0, 0);
        }
        if u >= ends[3] {
            return (1.0, 0);
        }
        let k = (0..3).find(|&k| u <= ends[k + 1]).unwrap_or(2);
        self.newton_in_span(u, [BREAKS[k], BREAKS[k + 1]], [ends[k], ends[k + 1]])
    }

    /// Safeguarded Newton for `f1(t) = u` in the bracket `span` where `f1` goes from
    /// `values[0] ≤ u` to `values[1] ≥ u`; bisects when Newton leaves the bracket.
    fn newton_in_span(&self, u: f64, span: [f64; 2], values: [f64; 2]) -> (f64, u32) {
        let [mut lo, mut hi] = span;
        let mut t = self.initial_guess(u, span, values);
        for iteration in 1..=MAX_INVERSE_ITERATIONS {
            // `f1(t)` and `f1'(t)` from one evaluation of the basis (as `abscissa` and
            // `abscissa_derivative` each make it).
            let (quadratic, cubic) = basis_degrees_2_3(clamp_unit(t, 1.0));
            let residual = combine(&cubic, &self.abscissae) - u;
            if residual.abs() <= INVERSE_TOLERANCE * u {
                return (t, iteration);
            }
            if residual < 0.0 {
                lo = t;
            } else {
                hi = t;
            }
            let slope = combine(&derivative_from_quadratic(&quadratic), &self.abscissae);
            let step = t - residual / slope;
            t = if step > lo && step < hi {
                step
            } else {
                0.5 * (lo + hi)
            };
            if hi - lo <= 2.0 * f64::EPSILON * hi.max(f64::MIN_POSITIVE) {
                return (t, iteration);
            }
        }
        (t, MAX_INVERSE_ITERATIONS)
    }

    /// Start of [`Profile::newton_in_span`]: on the first span the quadratic Taylor model of
    /// `f1` at 0 (`f1'(0) = 9 x1`, `f1''(0) = 10.8 - 81 x1`, `x1 = 0.2 cos θ`), which stays
    /// accurate for tiny `u` when `f1'(0) → 0`; elsewhere linear interpolation of the span.
    fn initial_guess(&self, u: f64, span: [f64; 2], values: [f64; 2]) -> f64 {
        let [lo, hi] = span;
        let width = values[1] - values[0];
        let linear = if width > 0.0 {
            lo + (hi - lo) * (u - values[0]) / width
        } else {
            0.5 * (lo + hi)
        };
        if lo > 0.0 {
            return linear;
        }
        let x1 = self.abscissae[1];
        let (b, c) = (9.0 * x1, 10.8 - 81.0 * x1);
        let denominator = b + (b * b + 2.0 * c * u).max(0.0).sqrt();
        let quadratic = 2.0 * u / denominator;
        if quadratic > lo && quadratic < hi {
            quadratic
        } else {
            linear
        }
    }

    /// `A(t)`, the ordinate `f2(t)` with zero bulge (2021 App. B line 50; `PIPELINE.md`
    /// "Exact volume": `A_i = f2(t_i)` at `h = 0`). `t` clamped to `[0, 1]` (NaN → 1).
    pub fn base_ordinate(&self, t: f64) -> f64 {
        combine(&basis(t), &self.base_ordinates)
    }

    /// The ordinate `f2(t) = A(t) + N_2(t) y2` for the bulge ordinate `y2 = γ η h_v`
    /// (2021 App. B lines 59-60). Non-finite `bulge_ordinate` → 0; `t` as in [`basis`].
    pub fn ordinate(&self, t: f64, bulge_ordinate: f64) -> f64 {
        let n = basis(t);
        combine(&n, &self.base_ordinates) + n[BULGE_INDEX] * finite_or_zero(bulge_ordinate)
    }

    /// `df2/dt` for the bulge ordinate `y2` (non-finite → 0); `t` as in [`basis`].
    pub fn ordinate_derivative(&self, t: f64, bulge_ordinate: f64) -> f64 {
        let n = basis_derivative(t);
        combine(&n, &self.base_ordinates) + n[BULGE_INDEX] * finite_or_zero(bulge_ordinate)
    }

    /// The displacement magnitude `H(u) = f2(f1⁻¹(u))` along `d` (2021 Sec. 5, App. B line
    /// 60), for `u` as in [`Profile::parameter_at`] and `y2` as in [`Profile::ordinate`].
    pub fn displacement_at(&self, u: f64, bulge_ordinate: f64) -> f64 {
        self.ordinate(self.parameter_at(u), bulge_ordinate)
    }
}

/// `x` if finite, else 0.
fn finite_or_zero(x: f64) -> f64 {
    if x.is_finite() {
        x
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CASES: [(f64, f64); 9] = [
        (1.0, 0.0),
        (1.0, 1.0),
        (0.3, -2.0),
        (0.05, 40.0),
        (2.0, -500.0),
        (1e-3, 1e4),
        (0.5, 1e-9),
        (0.0, 0.0),
        (0.0, 3.0),
    ];

    #[test]
    fn basis_is_a_partition_of_unity() {
        for i in 0..=300 {
            let t = i as f64 / 300.0;
            let n = basis(t);
            assert!((n.iter().sum::<f64>() - 1.0).abs() < 1e-15);
            assert!(n.iter().all(|&x| x >= 0.0));
            assert!(basis_derivative(t).iter().sum::<f64>().abs() < 1e-12);
        }
        assert_eq!(basis(0.0)[0], 1.0);
        assert_eq!(basis(1.0)[5], 1.0);
    }

    #[test]
    fn basis_derivative_matches_finite_differences() {
        for i in 1..300 {
            let t = i as f64 / 300.0;
            let (n_p, n_m, d) = (basis(t + 1e-6), basis(t - 1e-6), basis_derivative(t));
            for k in 0..6 {
                assert!(
                    ((n_p[k] - n_m[k]) / 2e-6 - d[k]).abs() < 1e-6,
                    "t {t} k {k}"
                );
            }
        }
    }

    #[test]
    fn inverse_converges_fast_and_accurately() {
        let mut worst = 0u32;
        for &(a, s) in &CASES {
            let profile = Profile::new(a, s);
            for i in 0..=1000 {
                let u = i as f64 / 1000.0;
                let (t, iterations) = profile.invert_abscissa(u);
                worst = worst.max(iterations);
                assert!(
                    (profile.abscissa(t) - u).abs() <= 1e-14,
                    "a {a} s {s} u {u}"
                );
            }
        }
        assert!(worst <= 12, "worst iteration count {worst}");
    }

    #[test]
    fn non_finite_inputs_fall_back() {
        let p = Profile::new(f64::NAN, f64::INFINITY);
        assert_eq!((p.amplitude(), p.slope()), (0.0, 0.0));
        assert_eq!(p.parameter_at(f64::NAN), 1.0);
        assert_eq!(p.displacement_at(f64::NAN, 1.0), 0.0);
        assert_eq!(Profile::new(1.0, 1.0).ordinate(0.5, f64::NAN), {
            Profile::new(1.0, 1.0).ordinate(0.5, 0.0)
        });
        assert_eq!(basis(f64::NAN), basis(1.0));
    }
}
