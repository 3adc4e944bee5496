//! The anisotropic bulge map `η` (2021 Sec. 7, Eq. 7; `PIPELINE.md` "Bulge map").
//!
//! Every contact-zone vertex `p_j` (area `A_j`, depth `δ_j = |p'_j - p_j|`, unit push direction
//! `m̂` of its contact) emits the field
//!
//! ```text
//! P_j(x) = (1/r) max(0, m̂·(x - p_j) / r)^ω,   r = max(|x - p_j|, r_min)
//! ```
//!
//! (`ω = 0`: `P_j = 1/r`, no half-space cut), and a deformable vertex gets
//! `η_aniso(x_i) = Σ_j A_j δ_j P_j(x_i)` over all contact zones of the region (Eq. 7), then
//! `η_i = λ + (1 - λ) η_aniso_i / max_i η_aniso_i` so flat neighbourhoods keep some bulge.
//! The paper orients the field with the mapping direction `d̂`; `PIPELINE.md` uses the push
//! direction `m̂` (the direction of `p'_j - p_j`), otherwise a ball pressed from above gets
//! `η ≈ 0` where it should bulge. A painted map multiplies `η` ([`apply_painted`]).

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

/// Below this many point-sample pairs the map is computed sequentially.
const PARALLEL_THRESHOLD: usize = 1 << 15;

/// One contact-zone vertex emitting a bulge field (2021 Sec. 7, Eq. 7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactSample {
    /// Its position `p_j` (before displacement).
    pub position: Point3<f64>,
    /// `A_j`, one third of the areas of its adjacent triangles.
    pub area: f64,
    /// Its penetration depth `δ_j = |p'_j - p_j|`.
    pub depth: f64,
    /// The push direction `m̂` of its contact (normalized internally).
    pub push: Vector3<f64>,
}

/// Parameters of the procedural bulge map (2021 Sec. 7; `PIPELINE.md` "Bulge map").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BulgeParams {
    /// Exponent `ω` of the directional term (2 in the paper's tests; 0: isotropic `1/r`).
    /// Negative or non-finite values are treated as 0.
    pub omega: f64,
    /// The floor `λ` of the normalized map (0.05 by default); clamped to `[0, 1]`
    /// (non-finite: 0.05).
    pub floor: f64,
    /// `r_min`, the smallest distance used in `P_j` (`h/2` for a mesh of edge length `h`).
    /// Non-finite or negative values are treated as 0; with 0, a point that coincides with a
    /// sample gets no contribution from it.
    pub min_radius: f64,
}

impl Default for BulgeParams {
    /// `ω = 2`, `λ = 0.05`, `r_min = 0` (set it with [`BulgeParams::for_edge_length`]).
    fn default() -> Self {
        Self {
            omega: 2.0,
            floor: 0.05,
            min_radius: 0.0,
        }
    }
}

impl BulgeParams {
    /// The defaults with `r_min = h/2` for a mesh of (mean) edge length `h`
    /// (`PIPELINE.md` "Bulge map").
    pub fn for_edge_length(edge_length: f64) -> Self {
        Self {
            min_radius: 0.5 * edge_length,
            ..Self::default()
        }
    }

    /// `(ω, λ, r_min)` after the documented fallbacks.
    fn sanitized(&self) -> (f64, f64, f64) {
        let omega = if self.omega.is_finite() && self.omega > 0.0 {
            self.omega
        } else {
            0.0
        };
        let floor = if self.floor.is_finite() {
            self.floor.clamp(0.0, 1.0)
        } else {
            0.05
        };
        let r_min = if self.min_radius.is_finite() && self.min_radius > 0.0 {
            self.min_radius
        } else {
            0.0
        };
        (omega, floor, r_min)
    }
}

/// Four emitters side by side (structure of arrays), so that the sum over them vectorizes.
#[derive(Clone, Copy, Debug, Default)]
struct Block {
    position: [[f64; 4]; 3],
    push: [[f64; 4]; 3],
    /// Relative weight `A δ`; 0 in the padding of the last block.
    weight: [f64; 4],
}

/// The validated samples, four per block: positions, weights `A δ` relative to the largest,
/// unit pushes.
#[derive(Clone, Debug, Default)]
struct Emitters {
    blocks: Vec<Block>,
    count: usize,
}

impl Emitters {
    /// The usable samples: finite, `A δ > 0`, and (when `ω > 0`) a non-zero finite push.
    /// Weights are divided by the largest one (normalization removes the scale anyway),
    /// which keeps the sums finite. The last block is padded with zero weights.
    fn new(samples: &[ContactSample], directional: bool) -> Self {
        let mut usable: Vec<(Point3<f64>, Vector3<f64>, f64)> = Vec::new();
        for s in samples {
            let weight = s.area * s.depth;
            let push = s.push.try_normalize(0.0).unwrap_or_else(Vector3::zeros);
            let usable_push =
                !directional || (push.iter().all(|x| x.is_finite()) && push != Vector3::zeros());
            let finite = s.position.iter().all(|x| x.is_finite()) && weight.is_finite();
            if finite && weight > 0.0 && usable_push {
                usable.push((s.position, push, weight));
            }
        }
        let largest = usable.iter().map(|u| u.2).fold(0.0, f64::max);
        let blocks = usable
            .chunks(4)
            .map(|chunk| {
                let mut b = Block::default();
                for (lane, (p, m, w)) in chunk.iter().enumerate() {
                    for k in 0..3 {
                        b.position[k][lane] = p[k];
                        b.push[k][lane] = m[k];
                    }
                    b.weight[lane] = w / largest;
                }
                b
            })
            .collect();
        Self {
            blocks,
            count: usable.len(),
        }
    }

    fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// `Σ_j A_j δ_j P_j(x)`, `term` the directional factor, summed in four lanes (one per
    /// slot of a block: a fixed order, so the result does not depend on the machine or the
    /// thread count). A sample at `r = 0` contributes 0.
    fn sum(&self, x: &[f64; 3], r_min: f64, term: impl Fn(f64) -> f64) -> f64 {
        let mut lanes = [0.0; 4];
        for b in &self.blocks {
            for (lane, acc) in lanes.iter_mut().enumerate() {
                let v = [
                    x[0] - b.position[0][lane],
                    x[1] - b.position[1][lane],
                    x[2] - b.position[2][lane],
                ];
                let r = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(r_min);
                let along =
                    b.push[0][lane] * v[0] + b.push[1][lane] * v[1] + b.push[2][lane] * v[2];
                let value = b.weight[lane] * term(along / r) / r;
                *acc += if r == 0.0 { 0.0 } else { value };
            }
        }
        (lanes[0] + lanes[1]) + (lanes[2] + lanes[3])
    }
}

/// `max(0, c)^ω` with the cheap integer cases.
fn directional_term(cosine: f64, omega: f64) -> f64 {
    let c = cosine.max(0.0);
    if omega == 2.0 {
        c * c
    } else if omega == 1.0 {
        c
    } else {
        c.powf(omega)
    }
}

/// `η_aniso(x) = Σ_j A_j δ_j P_j(x)` (2021 Eq. 7, relative weights); 0 for a non-finite `x`.
/// The common exponents get their own loop (no branch or `powf` per emitter).
fn anisotropic(x: &Point3<f64>, emitters: &Emitters, omega: f64, r_min: f64) -> f64 {
    if !x.iter().all(|c| c.is_finite()) {
        return 0.0;
    }
    let x = [x.x, x.y, x.z];
    if omega == 0.0 {
        emitters.sum(&x, r_min, |_| 1.0)
    } else if omega == 2.0 {
        emitters.sum(&x, r_min, |c: f64| {
            let c = c.max(0.0);
            c * c
        })
    } else {
        emitters.sum(&x, r_min, |c| directional_term(c, omega))
    }
}

/// `λ + (1 - λ) v / max`, with `+∞` entries mapped to 1 (and the rest to λ) if the sums
/// overflowed.
fn normalize(raw: Vec<f64>, floor: f64) -> Vec<f64> {
    let max = raw.iter().copied().fold(0.0, f64::max);
    raw.into_iter()
        .map(|v| {
            let fraction = match (max.is_finite(), max > 0.0) {
                (true, true) => v / max,
                (false, _) => f64::from(u8::from(v == f64::INFINITY)),
                (true, false) => 0.0,
            };
            floor + (1.0 - floor) * fraction
        })
        .collect()
}

/// The procedural bulge map `η` at `points` (2021 Sec. 7, Eq. 7, normalized as in
/// `PIPELINE.md` "Bulge map"): in `[λ, 1]`, maximum 1 (when some point sees a sample).
///
/// Samples with a non-finite field, `A δ ≤ 0`, or (for `ω > 0`) a zero push are skipped. With
/// no usable sample the map is isotropic: `η = 1` everywhere. A non-finite point gets `λ`.
/// Parallel over points (rayon) when large; every point sums its samples in a fixed order (four
/// lanes, see `Emitters::sum`), so the result does not depend on the thread count.
pub fn procedural_bulge(
    points: &[Point3<f64>],
    samples: &[ContactSample],
    params: &BulgeParams,
) -> Vec<f64> {
    let (omega, floor, r_min) = params.sanitized();
    let emitters = Emitters::new(samples, omega > 0.0);
    if emitters.is_empty() {
        return vec![1.0; points.len()];
    }
    let eval = |x: &Point3<f64>| anisotropic(x, &emitters, omega, r_min);
    let raw: Vec<f64> = if points.len().saturating_mul(emitters.count) < PARALLEL_THRESHOLD {
        points.iter().map(eval).collect()
    } else {
        points.par_iter().map(eval).collect()
    };
    normalize(raw, floor)
}

/// Multiplies `η` by a painted per-vertex map (2021 Sec. 7: negative values allowed).
/// Vertices beyond `painted.len()` and non-finite painted values keep a factor 1; extra
/// painted values are ignored.
pub fn apply_painted(eta: &mut [f64], painted: &[f64]) {
    for (e, &w) in eta.iter_mut().zip(painted) {
        if w.is_finite() {
            *e *= w;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> ContactSample {
        ContactSample {
            position: Point3::origin(),
            area: 0.1,
            depth: 0.2,
            push: Vector3::new(0.0, 0.0, -3.0),
        }
    }

    #[test]
    fn behind_the_plane_gets_the_floor() {
        let params = BulgeParams::for_edge_length(0.1);
        let points = [
            Point3::new(0.0, 0.0, -1.0),
            Point3::new(0.3, 0.0, 1.0),
            Point3::new(1.0, 0.0, 0.0),
        ];
        let eta = procedural_bulge(&points, &[sample()], &params);
        assert_eq!(eta, vec![1.0, 0.05, 0.05]);
    }

    /// Eq. 7 written out per sample (no blocks, no lanes), normalized as documented.
    fn reference(points: &[Point3<f64>], samples: &[ContactSample], p: &BulgeParams) -> Vec<f64> {
        let raw: Vec<f64> = points
            .iter()
            .map(|x| {
                samples
                    .iter()
                    .map(|s| {
                        let v = x - s.position;
                        let r = v.norm().max(p.min_radius);
                        let c = (s.push.normalize().dot(&v) / r).max(0.0);
                        let field = if p.omega == 0.0 { 1.0 } else { c.powf(p.omega) };
                        s.area * s.depth * field / r
                    })
                    .sum::<f64>()
            })
            .collect();
        let max = raw.iter().copied().fold(0.0, f64::max);
        raw.iter()
            .map(|v| p.floor + (1.0 - p.floor) * v / max)
            .collect()
    }

    #[test]
    fn blocked_sums_match_eq_7() {
        // 11 samples: two full blocks of four and a padded one; scattered points, some on a
        // sample (r = r_min).
        let mut next = crate::test_support::uniform(7);
        let samples: Vec<ContactSample> = (0..11)
            .map(|_| ContactSample {
                position: Point3::new(next(), next(), next()),
                area: 0.01 + next(),
                depth: 0.01 + next(),
                push: Vector3::new(next() - 0.5, next() - 0.5, 1.0),
            })
            .collect();
        let mut points: Vec<Point3<f64>> = (0..50)
            .map(|_| Point3::new(next(), next(), 2.0 * next()))
            .collect();
        points.push(samples[3].position);
        for omega in [0.0, 1.0, 1.5, 2.0, 3.0] {
            let params = BulgeParams {
                omega,
                ..BulgeParams::for_edge_length(0.05)
            };
            let eta = procedural_bulge(&points, &samples, &params);
            for (a, b) in eta.iter().zip(reference(&points, &samples, &params)) {
                assert!((a - b).abs() < 1e-12, "ω = {omega}: {a} against {b}");
            }
        }
    }

    #[test]
    fn no_samples_is_isotropic() {
        let eta = procedural_bulge(&[Point3::origin()], &[], &BulgeParams::default());
        assert_eq!(eta, vec![1.0]);
    }
}
