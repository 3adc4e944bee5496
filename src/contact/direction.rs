//! Mapping direction of a contact (2021 Sec. 4.1, Eq. 2; Algorithm 1 lines 4-5).
//!
//! With the conventions of `PIPELINE.md`, the direction of side `l` in its contact with `k` is
//! oriented *outward* for `l`: `d̂_{l,k} = normalize(n̄_l Var(n_k) - n̄_k Var(n_l))`, so that the
//! object whose normals vary least over its intersection region dictates the direction, and
//! `d̂_{k,l} = -d̂_{l,k}`. Means and total variations are exact integrals of the piecewise-linear
//! (unnormalized) normal field over the intersection regions `I_l`, cut exactly along the
//! intersection curves, so the direction moves continuously in time.

use crate::intersect::{IntersectionRegion, PosedMesh, QuadratureRule};
use nalgebra::Vector3;

/// Area-weighted statistics of the interpolated normal field over one intersection region.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalStats {
    /// Area of the region.
    pub area: f64,
    /// `m_l = ∫ n dA` (Sec. 4.1).
    pub integral: Vector3<f64>,
    /// Total variation: trace of the covariance, `∫|n|² dA / A - |∫n dA / A|²` (degree-2
    /// quadrature, exact for the interpolated field).
    pub variation: f64,
}

impl NormalStats {
    /// Statistics of `normals` (per vertex of `mesh`) over `region`. `None` when the region
    /// has no area.
    pub fn over(
        region: &IntersectionRegion,
        mesh: &PosedMesh,
        normals: &[Vector3<f64>],
    ) -> Option<Self> {
        let tris = mesh.triangles();
        let mut area = 0.0;
        let mut integral = Vector3::zeros();
        let mut square = 0.0;
        for q in region.quadrature(mesh, QuadratureRule::Degree2) {
            let n = q.interpolate(tris, normals);
            area += q.weight;
            integral += n * q.weight;
            square += n.norm_squared() * q.weight;
        }
        if !(area > 0.0 && area.is_finite()) {
            return None;
        }
        let mean = integral / area;
        let variation = (square / area - mean.norm_squared()).max(0.0);
        Some(Self {
            area,
            integral,
            variation,
        })
    }

    /// The unit mean normal `n̄_l` (`None` if the normals cancel out).
    pub fn mean_normal(&self) -> Option<Vector3<f64>> {
        self.integral.try_normalize(1e-12 * self.area.max(1e-300))
    }
}

/// Eq. 2: the direction of side `l`, outward for `l`, from the statistics of both sides.
/// Falls back to `normalize(n̄_l - n̄_k)` when both variations vanish (two planes), and to the
/// one available side when the other has no intersection area. `None` when neither side
/// gives a usable normal.
pub fn automatic_direction(
    own: Option<&NormalStats>,
    other: Option<&NormalStats>,
) -> Option<Vector3<f64>> {
    let own_mean = own.and_then(NormalStats::mean_normal);
    let other_mean = other.and_then(NormalStats::mean_normal);
    match (own, own_mean, other, other_mean) {
        (Some(o), Some(no), Some(k), Some(nk)) => {
            let weighted = no * k.variation - nk * o.variation;
            let scale = k.variation + o.variation;
            if scale > 1e-12 {
                if let Some(d) = weighted.try_normalize(1e-9 * scale) {
                    return Some(d);
                }
            }
            (no - nk).try_normalize(1e-9)
        }
        (_, Some(no), _, None) => Some(no),
        (_, None, _, Some(nk)) => Some(-nk),
        _ => None,
    }
}
