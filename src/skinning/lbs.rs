//! Linear blend skinning: `p' = (Σ_j w_j M_j) p`, normals by the cofactor of the blended matrix.

use super::{cofactor, unit_or_zero, BindShape, Skinned};
use crate::rig::{Body, SkinWeights};
use nalgebra::{Matrix3, Matrix4, Point3, Vector3};
use rayon::prelude::*;

/// The weighted sum of joint matrices at vertex `v`.
pub fn blended_matrix(weights: &SkinWeights, v: usize, mats: &[Matrix4<f64>]) -> Matrix4<f64> {
    let mut m = Matrix4::zeros();
    for (j, w) in weights.row(v) {
        m += mats[j] * w;
    }
    m
}

/// Skins one vertex.
pub fn skin_vertex(
    weights: &SkinWeights,
    v: usize,
    p: &Point3<f64>,
    n: &Vector3<f64>,
    mats: &[Matrix4<f64>],
) -> (Point3<f64>, Vector3<f64>) {
    let m = blended_matrix(weights, v, mats);
    let p2 = m.transform_point(p);
    let lin: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
    (p2, unit_or_zero(cofactor(&lin) * n))
}

/// Linear blend skinning of a whole body.
pub fn skin(body: &Body, mats: &[Matrix4<f64>]) -> Skinned {
    skin_shape(&body.weights, BindShape::of(body), mats)
}

/// Linear blend skinning of `shape` (a body's bind shape or a morph of it) with its `weights`.
pub fn skin_shape(weights: &SkinWeights, shape: BindShape, mats: &[Matrix4<f64>]) -> Skinned {
    let (positions, normals) = (shape.positions.par_iter().zip(shape.normals))
        .with_min_len(1024)
        .enumerate()
        .map(|(v, (p, n))| skin_vertex(weights, v, p, n, mats))
        .unzip();
    Skinned { positions, normals }
}
