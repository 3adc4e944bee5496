//! Dual quaternion skinning (Kavan, Collins, Žára, O'Sullivan 2008).
//!
//! Each joint matrix `M = [A | t]` is split into a rigid part and a stretch by the polar
//! decomposition `A = R S`. Per vertex, the stretches are blended linearly
//! (`S̄ = Σ w_j S_j`, identity for rigid rigs), then the unit dual quaternions of `(R_j, t_j)`
//! are blended with signs aligned to the heaviest influence and normalized:
//! `p' = DQ(Σ w_j σ_j q̂_j) (S̄ p)`. Normals use the rotation and the cofactor of `S̄`.

use super::{cofactor, unit_or_zero, BindShape, Skinned};
use crate::rig::{Body, SkinWeights};
use nalgebra::{Matrix3, Matrix4, Quaternion, Rotation3, UnitQuaternion};
use rayon::prelude::*;

/// A joint transform split for dual quaternion blending.
#[derive(Clone, Copy, Debug)]
pub struct JointDq {
    /// Real part (rotation).
    pub real: Quaternion<f64>,
    /// Dual part `½ t r`.
    pub dual: Quaternion<f64>,
    /// Stretch `S` of the polar decomposition (identity when rigid).
    pub stretch: Matrix3<f64>,
    /// Whether `S` differs from the identity.
    pub stretched: bool,
}

/// Polar decomposition `A = R S` of a 3x3 matrix (`R` a rotation when `det A > 0`).
pub fn polar(a: &Matrix3<f64>) -> (UnitQuaternion<f64>, Matrix3<f64>, bool) {
    let ata = a.transpose() * a;
    if (ata - Matrix3::identity()).abs().max() < 1e-9 && a.determinant() > 0.0 {
        let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*a));
        return (q, Matrix3::identity(), false);
    }
    let svd = a.svd(true, true);
    match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => {
            let mut r = u * v_t;
            if r.determinant() < 0.0 {
                // Mirrored joint: keep a proper rotation, the reflection goes into the stretch.
                r = -r;
            }
            let s = r.transpose() * a;
            let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
            (q, s, true)
        }
        _ => (UnitQuaternion::identity(), *a, true),
    }
}

/// Splits every joint matrix for blending.
pub fn joint_dqs(mats: &[Matrix4<f64>]) -> Vec<JointDq> {
    mats.iter()
        .map(|m| {
            let a: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
            let (r, stretch, stretched) = polar(&a);
            let t = Quaternion::new(0.0, m[(0, 3)], m[(1, 3)], m[(2, 3)]);
            let real = r.into_inner();
            JointDq {
                real,
                dual: t * real * 0.5,
                stretch,
                stretched,
            }
        })
        .collect()
}

/// The blended stretch `S̄ = Σ_j w_j S_j` of one vertex's influences, `None` when every joint
/// is rigid (DQS's, and CoR's for joints that scale).
pub fn blended_stretch(joints: &[u16], weights: &[f64], split: &[JointDq]) -> Option<Matrix3<f64>> {
    let mut stretch = Matrix3::zeros();
    let mut stretched = false;
    for (&j, &w) in joints.iter().zip(weights) {
        if let Some(d) = split.get(j as usize) {
            stretch += d.stretch * w;
            stretched |= d.stretched;
        }
    }
    stretched.then_some(stretch)
}

/// Skins a whole body with dual quaternions.
pub fn skin(body: &Body, mats: &[Matrix4<f64>]) -> Skinned {
    skin_shape(&body.weights, BindShape::of(body), mats)
}

/// Dual quaternion skinning of `shape` (a body's bind shape or a morph of it) with its
/// `skin_weights`.
pub fn skin_shape(skin_weights: &SkinWeights, shape: BindShape, mats: &[Matrix4<f64>]) -> Skinned {
    let dqs = joint_dqs(mats);
    let (positions, normals) = (0..shape.positions.len())
        .into_par_iter()
        .with_min_len(1024)
        .map(|v| {
            let (joints, weights) = skin_weights.row_slices(v);
            let pivot = joints
                .iter()
                .zip(weights)
                .max_by(|a, b| a.1.total_cmp(b.1))
                .map_or(0, |(&j, _)| j as usize);
            let q0 = dqs[pivot].real;
            let mut real = Quaternion::new(0.0, 0.0, 0.0, 0.0);
            let mut dual = real;
            for (&j, &w) in joints.iter().zip(weights) {
                let d = &dqs[j as usize];
                let sign = if d.real.dot(&q0) < 0.0 { -w } else { w };
                real += d.real * sign;
                dual += d.dual * sign;
            }
            let len = real.norm();
            let (real, dual) = if len > 1e-12 {
                (real / len, dual / len)
            } else {
                (Quaternion::identity(), Quaternion::new(0.0, 0.0, 0.0, 0.0))
            };
            let rot = UnitQuaternion::new_unchecked(real);
            let t = (dual * real.conjugate() * 2.0).imag();
            let p = &shape.positions[v].coords;
            let n = &shape.normals[v];
            let (ps, ns) = match blended_stretch(joints, weights, &dqs) {
                Some(stretch) => (stretch * p, cofactor(&stretch) * n),
                None => (*p, *n),
            };
            let p2 = rot * ps + t;
            (nalgebra::Point3::from(p2), unit_or_zero(rot * ns))
        })
        .unzip();
    Skinned { positions, normals }
}
