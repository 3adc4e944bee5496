//! Skinning: bind-pose vertices and per-joint matrices in, posed world-space vertices out.
//!
//! Three methods share one signature ([`skin`]):
//! - [`lbs`]: linear blend skinning, the glTF reference (`Σ w_j M_j p`).
//! - [`dqs`]: dual quaternion skinning (Kavan et al. 2008), with the non-rigid part of each
//!   joint matrix (its polar stretch) blended linearly before the rigid part.
//! - [`cor`]: optimized centers of rotation (Le & Hodgins 2016), whose per-vertex centers are
//!   precomputed once per rig ([`cor::CorCenters`]).
//!
//! Every method skins positions and normals; vertices are processed in parallel with rayon,
//! each independently, so results do not depend on the thread count.

pub mod cor;
pub mod dqs;
pub mod lbs;

use crate::rig::{Body, MorphedShape};
use nalgebra::{Matrix3, Matrix4, Point3, Vector3};

/// Which skinning method to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Linear blend skinning.
    Lbs,
    /// Dual quaternion skinning.
    Dqs,
    /// Center-of-rotation skinning (Le & Hodgins 2016).
    Cor,
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Method::Lbs => "lbs",
            Method::Dqs => "dqs",
            Method::Cor => "cor",
        })
    }
}

/// Posed positions and unit normals of one body, in world space, one per file vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skinned {
    /// World-space positions.
    pub positions: Vec<Point3<f64>>,
    /// World-space unit normals (zero where the input normal was zero).
    pub normals: Vec<Vector3<f64>>,
}

/// The shape a skinning reads, one position and normal per file vertex: a body's bind shape,
/// or the bind shape morphed by its morph targets ([`crate::rig::morph`]).
#[derive(Clone, Copy, Debug)]
pub struct BindShape<'a> {
    /// Positions (mesh space).
    pub positions: &'a [Point3<f64>],
    /// Normals (unit or zero).
    pub normals: &'a [Vector3<f64>],
}

impl<'a> BindShape<'a> {
    /// `body`'s own bind shape.
    pub fn of(body: &'a Body) -> Self {
        Self {
            positions: &body.positions,
            normals: &body.normals,
        }
    }

    /// A morphed shape of a body.
    pub fn morphed(shape: &'a MorphedShape) -> Self {
        Self {
            positions: &shape.positions,
            normals: &shape.normals,
        }
    }
}

/// Skins `body` with joint matrices `mats` (`world(joint) · IBM`, one per skin joint).
/// `centers` is required for [`Method::Cor`] (falls back to LBS for vertices without a center).
pub fn skin(
    method: Method,
    body: &Body,
    mats: &[Matrix4<f64>],
    centers: Option<&cor::CorCenters>,
) -> Skinned {
    skin_shape(method, body, BindShape::of(body), mats, centers)
}

/// [`skin`] of `shape`, `body`'s bind shape or a morph of it (the same vertices, skinned
/// with `body`'s weights; CoR's centers stay those of the bind shape).
pub fn skin_shape(
    method: Method,
    body: &Body,
    shape: BindShape,
    mats: &[Matrix4<f64>],
    centers: Option<&cor::CorCenters>,
) -> Skinned {
    match (method, centers) {
        (Method::Lbs, _) => lbs::skin_shape(&body.weights, shape, mats),
        (Method::Dqs, _) => dqs::skin_shape(&body.weights, shape, mats),
        (Method::Cor, Some(c)) => cor::skin_shape(&body.weights, shape, c, mats),
        (Method::Cor, None) => {
            let centers = cor::CorCenters::precompute(body);
            cor::skin_shape(&body.weights, shape, &centers, mats)
        }
    }
}

/// Normal transform of a linear map: the cofactor matrix (`det(A) A^{-T}`), which stays
/// finite for singular maps and has the right orientation for mirrored ones.
pub fn cofactor(a: &Matrix3<f64>) -> Matrix3<f64> {
    let c0 = a.column(1).cross(&a.column(2));
    let c1 = a.column(2).cross(&a.column(0));
    let c2 = a.column(0).cross(&a.column(1));
    Matrix3::from_columns(&[c0, c1, c2])
}

/// Normalizes `n`, returning zero for a zero or non-finite vector.
pub fn unit_or_zero(n: Vector3<f64>) -> Vector3<f64> {
    let len = n.norm();
    if len.is_finite() && len > 1e-300 {
        n / len
    } else {
        Vector3::zeros()
    }
}
