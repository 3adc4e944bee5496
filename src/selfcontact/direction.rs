//! The mapping direction of a self-contact pair, from the skeleton (Brunel et al. 2021, Sec. 6,
//! "Mapping direction"; `PIPELINE.md`, "Skeleton-derived direction").
//!
//! The paper takes "the vector orthogonal to the bisector of the bones lying within their
//! supporting plane". With `J` the child joint's world position, `u1` the unit vector from `J`
//! toward the parent joint and `u2` the unit vector from `J` toward the child bone's other end,
//! `d̂_12 = normalize(u2 - u1)`: it lies in the bones' plane, `(u2 - u1)·(u1 + u2) = 0` makes it
//! orthogonal to the bisector, it is continuous through the straight pose (where it is `u2`,
//! along the bones), and it only degenerates at a full 180° fold (`u1 = u2`). It is `W1`'s
//! outward direction at the fold: it points from the parent bone's side toward the child
//! bone's side (`d̂·u2 ≥ 0 ≥ d̂·u1`).
//!
//! The child bone's other end is the child joint's first child node that is a joint of the
//! body's skin; for a leaf joint it is `J` plus an axis precomputed from the rest vertices of
//! `W2 \ R` ([`BoneAxes`]), carried by the child joint's world transform.

use super::regions::PairRegions;
use crate::mesh::WeldedMesh;
use crate::rig::{Pose, Rig};
use nalgebra::{Matrix3, Matrix4, Point3, SymmetricEigen, Vector3};

/// Below this norm a difference of unit vectors is a degenerate direction (a 180° fold).
pub const DEGENERATE_NORM: f64 = 1e-9;

/// Where the mapping direction of a pair comes from (2021 Sec. 6: from the skeleton, or set by
/// hand, as the paper does for the lips).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DirectionSource {
    /// [`skeleton_direction`] at every frame.
    Skeleton,
    /// A fixed world direction (normalized when used), `W1`'s outward direction.
    Fixed(Vector3<f64>),
}

impl DirectionSource {
    /// The unit direction `d̂_12` of `pair` at `pose` (`None` when degenerate: a 180° fold, a
    /// zero fixed vector, a leaf joint without axis).
    pub fn direction(
        &self,
        rig: &Rig,
        pose: &Pose,
        pair: &super::JointPair,
        axes: &BoneAxes,
    ) -> Option<Vector3<f64>> {
        match self {
            DirectionSource::Skeleton => skeleton_direction(rig, pose, pair, axes.leaf_axis),
            DirectionSource::Fixed(v) => unit(*v),
        }
    }
}

/// How the child bone's far end of a pair is found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LeafAxisSource {
    /// The child joint has a child joint in the skin (this node): no axis needed.
    ChildJoint(usize),
    /// Leaf joint: the principal axis of the rest vertices of `W2 \ R` (`PIPELINE.md`).
    PrincipalAxis,
    /// Leaf joint whose principal axis is ambiguous (two nearly equal largest variances, as on
    /// a short fingertip) or nearly orthogonal to the direction from the joint to the vertices'
    /// centroid (as on a lower lip hinged far behind it): the direction to the centroid.
    Centroid,
    /// Leaf joint without usable vertices: no direction.
    None,
}

/// Rest data of a pair's bones, computed once (see [`skeleton_direction`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoneAxes {
    /// For a leaf child joint: the unit axis toward the child bone's far end, in the child
    /// joint's local frame (after its inverse bind matrix); `None` otherwise.
    pub leaf_axis: Option<Vector3<f64>>,
    /// Where the far end comes from.
    pub source: LeafAxisSource,
    /// Eigenvalues of the covariance of `W2 \ R`'s rest vertices, largest first (zero when
    /// not computed).
    pub variances: [f64; 3],
}

impl BoneAxes {
    /// Precomputes the axes of `regions` on its body (`welded` is that body's welded mesh).
    pub fn new(rig: &Rig, welded: &WeldedMesh, regions: &PairRegions) -> Self {
        let pair = &regions.pair;
        let none = Self {
            leaf_axis: None,
            source: LeafAxisSource::None,
            variances: [0.0; 3],
        };
        let Some(body) = rig.bodies.get(pair.body) else {
            return none;
        };
        let Some(skin) = rig.skins.get(body.skin) else {
            return none;
        };
        if let Some(end) = child_end(rig, pair) {
            return Self {
                source: LeafAxisSource::ChildJoint(end),
                ..none
            };
        }
        let Some(ibm) = skin
            .joints
            .iter()
            .position(|&j| j == pair.child_joint)
            .and_then(|k| skin.inverse_bind.get(k))
        else {
            return none;
        };
        // W2-only rest vertices in the child joint's local frame, where the joint is the origin.
        let local: Vec<Vector3<f64>> = (0..welded.vertex_count())
            .filter(|&v| {
                regions.w2.get(v).copied().unwrap_or(false)
                    && !regions.w1.get(v).copied().unwrap_or(false)
            })
            .filter_map(|v| {
                let rep = *welded.representative.get(v)? as usize;
                body.positions.get(rep)
            })
            .map(|p| ibm.transform_point(p).coords)
            .collect();
        leaf_axis(&local).unwrap_or(none)
    }
}

/// Principal axis of `points` (joint-local, joint at the origin), oriented away from the
/// joint; the centroid direction when that axis is ambiguous or across the centroid.
fn leaf_axis(points: &[Vector3<f64>]) -> Option<BoneAxes> {
    if points.is_empty() {
        return None;
    }
    let centroid = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let mut cov = Matrix3::zeros();
    for p in points {
        let d = p - centroid;
        cov += d * d.transpose();
    }
    cov /= points.len() as f64;
    let eig = SymmetricEigen::new(cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let variances = order.map(|k| eig.eigenvalues[k]);
    let mut axis: Vector3<f64> = eig.eigenvectors.column(order[0]).into_owned();
    let to_centroid = unit(centroid);
    if let Some(c) = to_centroid {
        if axis.dot(&c) < 0.0 {
            axis = -axis;
        }
    }
    let distinct = variances[0] > 1.5 * variances[1];
    let aligned = to_centroid.is_none_or(|c| axis.dot(&c) >= 0.5);
    if distinct && aligned {
        return unit(axis).map(|a| BoneAxes {
            leaf_axis: Some(a),
            source: LeafAxisSource::PrincipalAxis,
            variances,
        });
    }
    to_centroid.map(|c| BoneAxes {
        leaf_axis: Some(c),
        source: LeafAxisSource::Centroid,
        variances,
    })
}

/// The first child node of the pair's child joint that is a joint of the body's skin.
pub fn child_end(rig: &Rig, pair: &super::JointPair) -> Option<usize> {
    let skin = rig.skins.get(rig.bodies.get(pair.body)?.skin)?;
    rig.nodes
        .get(pair.child_joint)?
        .children
        .iter()
        .copied()
        .find(|c| skin.joints.contains(c))
}

/// `d̂_12 = normalize(u2 - u1)` at `pose` (see the module doc; 2021 Sec. 6, "Mapping
/// direction").
///
/// `leaf_axis` is [`BoneAxes::leaf_axis`]: the far end of a leaf child joint's bone, in that
/// joint's local frame; it is ignored when the child joint has a child joint. `None` when the
/// bones fold onto each other (180°), when a bone has zero length, when a leaf joint has no
/// axis, or when a node is missing from the pose.
pub fn skeleton_direction(
    rig: &Rig,
    pose: &Pose,
    pair: &super::JointPair,
    leaf_axis: Option<Vector3<f64>>,
) -> Option<Vector3<f64>> {
    let world = |node: usize| pose.world.get(node);
    let position = |m: &Matrix4<f64>| m.transform_point(&Point3::origin());
    let child_world = world(pair.child_joint)?;
    let joint = position(child_world);
    let u1 = unit(position(world(pair.parent_joint)?) - joint)?;
    let toward_end = match child_end(rig, pair) {
        Some(end) => position(world(end)?) - joint,
        None => child_world.transform_vector(&leaf_axis?),
    };
    let u2 = unit(toward_end)?;
    let d = u2 - u1;
    let norm = d.norm();
    (norm > DEGENERATE_NORM && norm.is_finite()).then(|| d / norm)
}

/// `v / |v|`, or `None` for a zero or non-finite vector.
fn unit(v: Vector3<f64>) -> Option<Vector3<f64>> {
    let n = v.norm();
    (n > 0.0 && n.is_finite()).then(|| v / n)
}
