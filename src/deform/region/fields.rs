//! The direction field (Sec. 5.2, Eq. 6) and the slope estimates at the cut points (Sec. 5.3,
//! lines 44-48), with the amplitude faded where the mapping field fades.

use super::{CutPoint, DeformStats};
use nalgebra::{Point3, Vector3};

/// The amplitude where the mapping field fades: `a |d̄|` (`|d̄| ≤ 1`), so the displacement
/// fades where the directions cancel, as the direction itself does ([`blend_direction`]):
/// self-contact's `d̄ = σ d̂` across the crease (`σ → 0`), several contacts pulling apart
/// (their harmonic blend). With a single contact `|d̄| = 1` and nothing changes. Not in the
/// paper, whose Sec. 6 only turns the direction back to the normal there: the profile then
/// pushed the band along the crease along its normals by the whole amplitude diffused from the
/// zones. Measured against that (31-frame animations, worst frame): faces turned 1 → 0 on the
/// LBS capsule, 2 → 0 on the finger, 0 → 0 on the mouth, penetration unchanged there (0),
/// temporal ratios 1.78, 1.00, 1.03 → 1.02; CoR capsule 17 → 15 turned faces, 2 → 5
/// penetrating vertices, ratio 24.9 → 22.1; DQS 19 → 9, 3 → 4, 23.1 → 20.8; CesiumMan (21
/// frames, summed) 260 → 225 turned faces, 49 → 54 penetrating vertices. Object contact (the
/// fingertips on the ball, several contacts per body): temporal ratio 1.78 → 1.35, still no
/// vertex deeper than the chords (0.142 h) on the `k̄ × τ` grid, those at chord depth up to
/// 46 instead of 30 (`τ = 0.6`). The slopes at `∂C` are estimated before the fade (from the
/// zone's own amplitude).
pub(super) fn fade_with_the_direction(a: &mut [f64], dbar: &[Vector3<f64>]) {
    for (x, d) in a.iter_mut().zip(dbar) {
        *x *= d.norm().min(1.0);
    }
}

/// Eq. 6 with `w(u) = (1 - u²)^6`, generalized to a mapping field `d̄` shorter than 1:
/// `d = normalize(w d̄ + (1 - w |d̄|) n)`. With a unit `d̄` (one contact) this is Eq. 6 exactly;
/// where `d̄` fades (self-contact's `σ d̂` across the crease, `σ → 0`; several contacts pulling
/// apart) the normal takes over continuously, as Sec. 6 intends ("gently fall back to the
/// normal field"), instead of `normalize(σ d̂)` flipping between `±d̂` at `u ≈ 0`, which turned
/// faces over along the crease. `w` fades where `d̄` opposes the normal (see the body); the
/// normal where the blend vanishes.
pub(super) fn blend_direction(
    dbar: &Vector3<f64>,
    n: &Vector3<f64>,
    u: f64,
    stats: &mut DeformStats,
) -> Vector3<f64> {
    let w = (1.0 - u * u).powi(6);
    let strength = dbar.norm().min(1.0);
    // Where the mapping direction points into the surface (the far side of a limb, the
    // underside of a lip), `w d̄ + (1 - w) n` passes through zero as `w` falls: the normalized
    // direction swings by 180° over a few edges and the bulge raises ridges (measured on the
    // bending capsule's outer side at 150°: dihedral angles up to 47°, against 10° in the
    // input). Not in the paper: `w` is scaled by how much `d̄` faces along the normal,
    // `1 + d̂·n` clamped to [0, 1], so that the normal takes over smoothly there.
    let facing = dbar
        .try_normalize(1e-12)
        .map_or(1.0, |d| (1.0 + d.dot(n)).clamp(0.0, 1.0));
    let w = w * facing;
    let v = dbar * w + n * (1.0 - w * strength);
    match v.try_normalize(1e-6) {
        Some(d) => d,
        None => {
            stats.direction_fallbacks += 1;
            *n
        }
    }
}

/// Weight of the global slope in each point's estimate, relative to the mean denominator
/// (see the slope estimation in this module).
pub const SLOPE_REGULARIZATION: f64 = 0.25;

/// Slope estimates at the cut points (Sec. 5.3 with the corrected anchor of `PIPELINE.md`):
/// the least-squares slope of one edge is `s_ij = num / den` with
/// `num = (d·n')((b - p_j)·n' + a_j d·n') + a_j (d·m)²` and
/// `den = u_j ((d·n')² + (d·m)²)`.
///
/// `den → 0` as the boundary point nears its outside vertex (`u_j → 0`), where `num / den`
/// becomes noise that changes quickly as `∂C` slides, a pop in time. Instead of dropping those
/// edges (which also pops), each estimate is regularized toward the least-squares slope of
/// the whole boundary, `s̄ = Σ num / Σ den`:
/// `s_ij = (num + w s̄) / (den + w)`, `w = SLOPE_REGULARIZATION × mean(den)`. This is
/// continuous in every input. Estimates with `den < w` are counted in
/// [`DeformStats::dropped_slopes`].
pub(super) fn slope_estimates(
    points: &[CutPoint],
    pos: &[Point3<f64>],
    u: &[f64],
    d: &[Vector3<f64>],
    a: &[f64],
    stats: &mut DeformStats,
) -> Vec<f64> {
    let terms: Vec<(f64, f64)> = points
        .iter()
        .map(|p| {
            let (i, j) = (p.inside as usize, p.outside as usize);
            let n = p.sample.surface_normal;
            let Some(e) = (pos[j] - pos[i]).try_normalize(1e-300) else {
                return (0.0, 0.0);
            };
            let dij = d[i];
            let m = (e - dij * e.dot(&dij))
                .try_normalize(1e-12)
                .unwrap_or_else(Vector3::zeros);
            let (dn, dm) = (d[j].dot(&n), d[j].dot(&m));
            let den = u[j] * (dn * dn + dm * dm);
            let num = dn * ((p.sample.surface_point - pos[j]).dot(&n) + a[j] * dn) + a[j] * dm * dm;
            if num.is_finite() && den.is_finite() && den >= 0.0 {
                (num, den)
            } else {
                (0.0, 0.0)
            }
        })
        .collect();
    let (sum_num, sum_den) = terms
        .iter()
        .fold((0.0, 0.0), |(a, b), (n, d)| (a + n, b + d));
    let global = if sum_den > 0.0 {
        sum_num / sum_den
    } else {
        0.0
    };
    let w = SLOPE_REGULARIZATION * sum_den / terms.len().max(1) as f64;
    stats.dropped_slopes = terms.iter().filter(|(_, den)| *den < w).count();
    terms
        .iter()
        .map(|&(num, den)| {
            if den + w > 0.0 {
                (num + w * global) / (den + w)
            } else {
                global
            }
        })
        .collect()
}
