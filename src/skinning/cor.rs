//! Center-of-rotation skinning (placeholder, being written).
use super::Skinned;
use crate::rig::Body;
use nalgebra::{Matrix4, Point3};

/// Per-vertex centers of rotation.
#[derive(Clone, Debug, Default)]
pub struct CorCenters {
    /// Center of each file vertex; `None` for single-bone vertices (plain LBS).
    pub centers: Vec<Option<Point3<f64>>>,
}

impl CorCenters {
    /// Precomputes the centers.
    pub fn precompute(body: &Body) -> Self {
        Self { centers: vec![None; body.vertex_count()] }
    }
}

/// Skins with centers of rotation.
pub fn skin(body: &Body, _centers: &CorCenters, mats: &[Matrix4<f64>]) -> Skinned {
    super::lbs::skin(body, mats)
}
