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
//!
//! **Past a full fold, for a leaf joint's proxy bone.** The paper's "orthogonal to the
//! bisector" has two senses; `u2 - u1` picks the one that holds while the fold angle stays below
//! 180° (`PIPELINE.md`: the direction "degenerates only at a full 180° fold"), and turns over
//! when the bones pass each other. For a leaf child joint, `u2` is no bone but the direction of
//! its vertices ([`BoneAxes`]), which need not continue the parent bone: the mouth's (from the
//! jaw joint toward the head joint, and toward the lower lip) are 9° apart at rest, and closing
//! the jaw sweeps the lip's past the head's, which reversed `d̂` (into the lips) in the closed
//! frames. The paper sets the lips' direction by hand ("the mouth which is not an
//! articulation", Sec. 6). So, for a leaf joint whose rest pose folds them past 90° only
//! ([`RestFold`]), the rest fold's sense is kept past a full fold: where the fold angle `ψ`,
//! measured about the rest sense carried by the parent joint, is below `ψ_rest - π`,
//! `d̂ = -normalize(u2 - u1)`. This choice is ours (the design note does not make it) and has
//! its own cut: opening the pair by more than `π - ψ_rest` past straight (9° for the mouth's
//! jaw, which would have to open 180° from rest) reverses `d̂` there instead. It is only decided
//! while the proxy bone `u2` lies within 20° of the carried rest plane (else `u2 - u1` as is,
//! whose own sense swings there anyway): the proxy's angle to that plane is well defined even
//! where the bones nearly line up, which the tilt of their plane is not (a 3.5° sideways tilt
//! 2° past the full fold switched a test on that tilt). A real bone (a child joint with a
//! child joint) keeps `normalize(u2 - u1)` in every pose: a joint that opens the other way
//! folds the other way.

use super::regions::PairRegions;
use crate::mesh::WeldedMesh;
use crate::rig::{Pose, Rig};
use nalgebra::{Matrix3, Matrix4, Point3, SymmetricEigen, Vector3};

/// Below this norm a difference of unit vectors is a degenerate direction (a 180° fold).
pub const DEGENERATE_NORM: f64 = 1e-9;

/// Where the mapping direction of a pair comes from (2021 Sec. 6: from the skeleton, set by
/// hand as the paper does for the lips, or estimated from the relative motion of the parts).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DirectionSource {
    /// [`skeleton_direction`] at every frame.
    Skeleton,
    /// A fixed world direction (normalized when used), `W1`'s outward direction.
    Fixed(Vector3<f64>),
    /// [`motion_direction`] at every frame, where the parts meet in that frame.
    Motion,
}

/// Where the two parts of a pair meet in a frame, for [`DirectionSource::Motion`].
#[derive(Clone, Copy, Debug)]
pub struct Meeting<'a> {
    /// The rest pose (the pose of the rest positions).
    pub rest_pose: &'a Pose,
    /// Rest positions of the vertices where the parts meet (e.g. those of the faces crossing
    /// the other part).
    pub points: &'a [Point3<f64>],
}

impl DirectionSource {
    /// The unit direction `d̂_12` of `pair` at `pose` (`None` when degenerate: a 180° fold, a
    /// zero fixed vector, a leaf joint without axis, no relative motion where the parts meet,
    /// or `Motion` without `meeting`).
    pub fn direction(
        &self,
        pose: &Pose,
        pair: &super::JointPair,
        axes: &BoneAxes,
        meeting: Option<&Meeting>,
    ) -> Option<Vector3<f64>> {
        match self {
            DirectionSource::Skeleton => skeleton_direction(pose, pair, axes),
            DirectionSource::Fixed(v) => unit(*v),
            DirectionSource::Motion => {
                meeting.and_then(|m| motion_direction(pose, m.rest_pose, pair, m.points))
            }
        }
    }

    /// The fixed vector, for [`DirectionSource::Fixed`] (for reports).
    pub fn fixed(&self) -> Option<[f64; 3]> {
        match self {
            DirectionSource::Fixed(d) => Some([d.x, d.y, d.z]),
            _ => None,
        }
    }

    /// `"skeleton"`, `"fixed"` or `"motion"` (for reports).
    pub fn label(&self) -> &'static str {
        match self {
            DirectionSource::Skeleton => "skeleton",
            DirectionSource::Fixed(_) => "fixed",
            DirectionSource::Motion => "motion",
        }
    }
}

/// `d̂_12` from the relative motion of the parts (2021 Sec. 6: "it is usually possible to
/// estimate d̂ from the relative motion between the two parts"). Each part follows its joint
/// rigidly since the rest pose, `A_j = world_j(pose) world_j(rest)^-1`; at a rest point `x`
/// where the parts meet, part 2 has moved by `(A_2 - A_1) x` relative to part 1. `W1`'s
/// outward direction faces the approaching part 2: `d̂_12 = -normalize(Σ (A_2 - A_1) x)` over
/// `points` (rest positions). Time-independent: the pose and the rest pose only. `None` when a
/// joint is missing or singular, or when the motions cancel (their sum below `1e-6` of the sum
/// of their lengths: no common approach direction, e.g. a twist about the points).
pub fn motion_direction(
    pose: &Pose,
    rest_pose: &Pose,
    pair: &super::JointPair,
    points: &[Point3<f64>],
) -> Option<Vector3<f64>> {
    let rigid = |joint: usize| -> Option<Matrix4<f64>> {
        Some(pose.world.get(joint)? * rest_pose.world.get(joint)?.try_inverse()?)
    };
    let relative = rigid(pair.child_joint)? - rigid(pair.parent_joint)?;
    let (mut sum, mut length) = (Vector3::zeros(), 0.0);
    for x in points {
        // The difference of two affine maps is not a point transform (its last row is 0).
        let m = (relative * x.to_homogeneous()).xyz();
        sum += m;
        length += m.norm();
    }
    let norm = sum.norm();
    (norm.is_finite() && length > 0.0 && norm > 1e-6 * length).then(|| -sum / norm)
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
    /// For a leaf child joint, the rest pose's fold when it folds the bones past 90° (see the
    /// module doc); `None` otherwise.
    pub rest_fold: Option<RestFold>,
}

/// A leaf joint pair's fold at rest, for rest poses folded past 90° (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestFold {
    /// The sense of the fold: the unit normal `(-u1) × u2` of the bones' plane at rest, in the
    /// parent joint's frame (carried by its world transform in a pose).
    pub sense: Vector3<f64>,
    /// The fold angle at rest, `ψ_rest` in radians (above π/2, below π): the angle from the
    /// parent bone's continuation `-u1` to `u2` about `sense`.
    pub angle: f64,
}

/// Sine of the largest angle between the proxy bone `u2` and the carried rest plane at which
/// [`RestFold`] still decides the sense (20°).
const REST_PLANE_SIN: f64 = 0.342_020_143_325_668_7;

/// The fold angle of `(u1, u2)` about the unit `axis`: from `-u1` to `u2`, in `(-π, π]`.
fn fold_angle(u1: &Vector3<f64>, u2: &Vector3<f64>, axis: &Vector3<f64>) -> f64 {
    (-u1).cross(u2).dot(axis).atan2(-u1.dot(u2))
}

impl RestFold {
    /// The rest fold of a leaf joint `pair` at `rest` (the rest pose), when it lies strictly
    /// between 90° and 180° (at 180° the bones' plane is undefined); `None` for a real bone.
    fn at(rest: &Pose, pair: &super::JointPair, leaf_axis: Option<Vector3<f64>>) -> Option<Self> {
        if pair.bone_end.is_some() {
            return None;
        }
        let (u1, u2) = bone_directions(rest, pair, leaf_axis)?;
        let normal = unit((-u1).cross(&u2))?;
        let angle = fold_angle(&u1, &u2, &normal);
        if angle <= std::f64::consts::FRAC_PI_2 {
            return None;
        }
        let to_parent = rest.world.get(pair.parent_joint)?.try_inverse()?;
        let sense = unit(to_parent.transform_vector(&normal))?;
        Some(Self { sense, angle })
    }

    /// Whether `(u1, u2)` at `pose` lie past the full fold from the rest fold: their fold
    /// angle about the carried sense below `ψ_rest - π`, `u2` within 20° of the carried rest
    /// plane.
    fn passed(
        &self,
        pose: &Pose,
        pair: &super::JointPair,
        u1: &Vector3<f64>,
        u2: &Vector3<f64>,
    ) -> bool {
        let Some(sense) = pose
            .world
            .get(pair.parent_joint)
            .and_then(|m| unit(m.transform_vector(&self.sense)))
        else {
            return false;
        };
        let in_plane = u2.dot(&sense).abs() <= REST_PLANE_SIN;
        in_plane && fold_angle(u1, u2, &sense) < self.angle - std::f64::consts::PI
    }
}

impl BoneAxes {
    /// Precomputes the axes of `regions` on its body (`welded` is that body's welded mesh).
    pub fn new(rig: &Rig, welded: &WeldedMesh, regions: &PairRegions) -> Self {
        let pair = &regions.pair;
        let none = Self {
            leaf_axis: None,
            source: LeafAxisSource::None,
            variances: [0.0; 3],
            rest_fold: None,
        };
        let Some(body) = rig.bodies.get(pair.body) else {
            return none;
        };
        let Some(skin) = rig.skins.get(body.skin) else {
            return none;
        };
        if let Some(end) = pair.bone_end {
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
        let Some(axes) = leaf_axis(&local) else {
            return none;
        };
        Self {
            rest_fold: RestFold::at(&rig.pose_at(None, 0.0), pair, axes.leaf_axis),
            ..axes
        }
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
            rest_fold: None,
        });
    }
    to_centroid.map(|c| BoneAxes {
        leaf_axis: Some(c),
        source: LeafAxisSource::Centroid,
        variances,
        rest_fold: None,
    })
}

/// `d̂_12 = normalize(u2 - u1)` at `pose` (see the module doc; 2021 Sec. 6, "Mapping
/// direction"), reversed past a full fold from a leaf joint's rest pose folded past 90°
/// ([`BoneAxes::rest_fold`]).
///
/// `axes.leaf_axis` is the far end of a leaf child joint's bone, in that joint's local frame;
/// it is ignored when the child joint has a child joint. `None` when the bones fold onto each
/// other (180°), when a bone has zero length, when a leaf joint has no axis, or when a node is
/// missing from the pose.
pub fn skeleton_direction(
    pose: &Pose,
    pair: &super::JointPair,
    axes: &BoneAxes,
) -> Option<Vector3<f64>> {
    let (u1, u2) = bone_directions(pose, pair, axes.leaf_axis)?;
    let d = u2 - u1;
    let norm = d.norm();
    if !(norm > DEGENERATE_NORM && norm.is_finite()) {
        return None;
    }
    let passed = axes
        .rest_fold
        .is_some_and(|f| f.passed(pose, pair, &u1, &u2));
    Some(if passed { -d / norm } else { d / norm })
}

/// `(u1, u2)` at `pose`: the unit vectors from the child joint toward the parent joint and
/// toward the child bone's far end (`leaf_axis` in the child joint's frame for a leaf joint).
fn bone_directions(
    pose: &Pose,
    pair: &super::JointPair,
    leaf_axis: Option<Vector3<f64>>,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let world = |node: usize| pose.world.get(node);
    let position = |m: &Matrix4<f64>| m.transform_point(&Point3::origin());
    let child_world = world(pair.child_joint)?;
    let joint = position(child_world);
    let u1 = unit(position(world(pair.parent_joint)?) - joint)?;
    let toward_end = match pair.bone_end {
        Some(end) => position(world(end)?) - joint,
        None => child_world.transform_vector(&leaf_axis?),
    };
    Some((u1, unit(toward_end)?))
}

/// `v / |v|`, or `None` for a zero or non-finite vector.
fn unit(v: Vector3<f64>) -> Option<Vector3<f64>> {
    let n = v.norm();
    (n > 0.0 && n.is_finite()).then(|| v / n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::selfcontact::JointPair;
    use nalgebra::{Rotation3, Translation3};

    fn pair() -> JointPair {
        JointPair {
            body: 0,
            parent_joint: 0,
            child_joint: 1,
            bone_end: None,
            name: "a/b".into(),
        }
    }

    fn pose(parent: Matrix4<f64>, child: Matrix4<f64>) -> Pose {
        Pose::new(vec![parent, child])
    }

    #[test]
    fn a_translated_part_approaches_against_its_motion() {
        let rest = pose(Matrix4::identity(), Matrix4::new_translation(&Vector3::x()));
        // The whole skeleton moved, and the child moved 0.3 up relative to the parent.
        let lift = Translation3::new(2.0, 0.0, 0.0).to_homogeneous();
        let now = pose(
            lift,
            lift * Matrix4::new_translation(&Vector3::new(1.0, 0.3, 0.0)),
        );
        let points = [Point3::new(0.5, 0.0, 0.0), Point3::new(1.5, 1.0, -1.0)];
        let d = motion_direction(&now, &rest, &pair(), &points).expect("a direction");
        assert!((d + Vector3::y()).norm() < 1e-12, "{d:?}");
    }

    #[test]
    fn a_hinge_closing_gives_the_side_it_closes_on() {
        // The child part turns 60° about +z round the joint at the origin; where the parts
        // meet, W1's outward direction is opposite the child's displacement there.
        let rest = pose(Matrix4::identity(), Matrix4::identity());
        let turn = Rotation3::from_axis_angle(&Vector3::z_axis(), 60f64.to_radians());
        let now = pose(Matrix4::identity(), turn.to_homogeneous());
        let points = [Point3::new(0.2, 0.1, 0.0), Point3::new(0.4, 0.1, 0.0)];
        let d = motion_direction(&now, &rest, &pair(), &points).expect("a direction");
        let expected: Vector3<f64> = points
            .iter()
            .map(|p| -(turn * p - p))
            .sum::<Vector3<f64>>()
            .normalize();
        assert!((d - expected).norm() < 1e-12, "{d:?} against {expected:?}");
    }

    /// A hinge at the child joint `(1, 0, 0)`, the parent joint at the origin: the child
    /// joint turned by `turn` degrees about +z, the whole skeleton then carried by `carry`.
    fn hinge(turn: f64, carry: Matrix4<f64>) -> Pose {
        let rotation = Rotation3::from_axis_angle(&Vector3::z_axis(), turn.to_radians());
        let child = Matrix4::<f64>::new_translation(&Vector3::x()) * rotation.to_homogeneous();
        pose(carry, carry * child)
    }

    /// The axes of a leaf child joint whose bone leaves at `rest_degrees` about +z from the
    /// parent bone's continuation `+x` in the rest pose (`hinge(0)`).
    fn axes_at(rest_degrees: f64) -> BoneAxes {
        let axis = planar(rest_degrees);
        BoneAxes {
            leaf_axis: Some(axis),
            source: LeafAxisSource::PrincipalAxis,
            variances: [0.0; 3],
            rest_fold: RestFold::at(&hinge(0.0, Matrix4::identity()), &pair(), Some(axis)),
        }
    }

    /// `(cos a, sin a, 0)` for `a` in degrees.
    fn planar(degrees: f64) -> Vector3<f64> {
        let a = degrees.to_radians();
        Vector3::new(a.cos(), a.sin(), 0.0)
    }

    #[test]
    fn a_rest_pose_folded_past_90_degrees_keeps_its_sense_past_a_full_fold() {
        // The mouth's case: the bones 9° apart at rest (ψ = 171°), the fold closing on to 200°.
        let axes = axes_at(171.0);
        let fold = axes.rest_fold.expect("folded past 90° at rest");
        assert!((fold.angle - 171f64.to_radians()).abs() < 1e-12);
        assert!((fold.sense - Vector3::z()).norm() < 1e-12);
        // A turn of the whole skeleton turns the direction with it.
        let carry = Rotation3::from_axis_angle(&Vector3::x_axis(), 0.7).to_homogeneous();
        for psi in [171.0, 175.0, 179.0, 181.0, 185.0, 200.0, 340.0] {
            for c in [Matrix4::identity(), carry] {
                let d = skeleton_direction(&hinge(psi - 171.0, c), &pair(), &axes)
                    .expect("a direction");
                // `-u1` turned by ψ/2 about the sense: continuous through 180°.
                let expected = c.transform_vector(&planar(psi / 2.0));
                assert!((d - expected).norm() < 1e-9, "ψ = {psi}: {d:?}");
            }
        }
        // The full fold itself stays degenerate.
        assert_eq!(
            skeleton_direction(&hinge(9.0, Matrix4::identity()), &pair(), &axes),
            None
        );
        // Opening the fold is unchanged: straight, then bent back less than 180° from rest;
        // the rule's own cut lies beyond, 9° past straight (the module doc).
        for psi in [90.0, 0.0, -8.0, -10.0] {
            let d = skeleton_direction(&hinge(psi - 171.0, Matrix4::identity()), &pair(), &axes)
                .expect("a direction");
            let expected = if psi < -9.0 { -1.0 } else { 1.0 } * planar(psi / 2.0);
            assert!((d - expected).norm() < 1e-9, "ψ = {psi}: {d:?}");
        }
        // The sense is the parent's: a twist of the child about its own bone leaves `u2`, hence
        // the direction, as it is; a uniformly scaled skeleton too.
        let twist = Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(axes.leaf_axis.expect("axis")),
            1.2,
        )
        .to_homogeneous();
        let scaled = Matrix4::new_scaling(3.0);
        for psi in [185.0, -8.0] {
            let plain =
                skeleton_direction(&hinge(psi - 171.0, Matrix4::identity()), &pair(), &axes);
            let mut twisted = hinge(psi - 171.0, Matrix4::identity());
            twisted.world[1] *= twist;
            let twisted = skeleton_direction(&twisted, &pair(), &axes);
            let big = skeleton_direction(&hinge(psi - 171.0, scaled), &pair(), &axes);
            let plain = plain.expect("a direction");
            for d in [twisted, big] {
                assert!((d.expect("a direction") - plain).norm() < 1e-9, "ψ = {psi}");
            }
        }
    }

    /// Out of the rest plane the rule stands aside: the child's proxy bone swung 30° out of it
    /// (beyond the rule's 20°) across the parent's plane (azimuth 180°, where the fold angle
    /// about the rest sense jumps by 2π) keeps `normalize(u2 - u1)`, continuous there.
    #[test]
    fn a_proxy_bone_out_of_the_rest_plane_keeps_the_plain_direction() {
        let axes = axes_at(171.0);
        let axis = axes.leaf_axis.expect("axis");
        let toward = |azimuth: f64| {
            let (a, e) = (azimuth.to_radians(), 30f64.to_radians());
            let target = Vector3::new(e.cos() * a.cos(), e.cos() * a.sin(), e.sin());
            let turn = Rotation3::rotation_between(&axis, &target).expect("a rotation");
            let child = Matrix4::<f64>::new_translation(&Vector3::x()) * turn.to_homogeneous();
            (pose(Matrix4::identity(), child), target)
        };
        let mut directions = Vec::new();
        for azimuth in [179.9, 180.1] {
            let (p, u2) = toward(azimuth);
            let d = skeleton_direction(&p, &pair(), &axes).expect("a direction");
            let plain = (u2 + Vector3::x()).normalize();
            assert!((d - plain).norm() < 1e-9, "azimuth {azimuth}: {d:?}");
            directions.push(d);
        }
        assert!((directions[0] - directions[1]).norm() < 0.01);
    }

    /// Just past the full fold, a proxy bone tilted a few degrees out of the rest plane keeps
    /// the rest sense as in the plane (a test on the tilt of the bones' plane, ill-defined
    /// where they line up, turned it back into the lips at 3.6°).
    #[test]
    fn a_small_tilt_past_the_full_fold_keeps_the_sense() {
        let axes = axes_at(171.0);
        let axis = axes.leaf_axis.expect("axis");
        for tilt in [0.0f64, 1.0, 3.4, 3.6, 10.0, 19.0] {
            let (a, e) = (182f64.to_radians(), tilt.to_radians());
            let target = Vector3::new(e.cos() * a.cos(), e.cos() * a.sin(), e.sin());
            let turn = Rotation3::rotation_between(&axis, &target).expect("a rotation");
            let child = Matrix4::<f64>::new_translation(&Vector3::x()) * turn.to_homogeneous();
            let d = skeleton_direction(&pose(Matrix4::identity(), child), &pair(), &axes)
                .expect("a direction");
            // The rest sense's side: `d̂` points like `-u1` turned by 91° about +z, i.e. +y.
            assert!(d.y > 0.0, "tilt {tilt}°: {d:?}");
        }
    }

    /// A real bone (a child joint with a child joint) is an articulation: no rest fold, so
    /// `normalize(u2 - u1)` past 180° too (a joint that opens the other way folds the other
    /// way), even folded 132° at rest as Fox's hips are.
    #[test]
    fn a_real_bone_keeps_the_plain_direction() {
        let mut p = pair();
        p.bone_end = Some(2);
        let end_at = |degrees: f64| Matrix4::new_translation(&(Vector3::x() + planar(degrees)));
        let bones = |degrees: f64| {
            Pose::new(vec![
                Matrix4::identity(),
                Matrix4::new_translation(&Vector3::x()),
                end_at(degrees),
            ])
        };
        assert_eq!(RestFold::at(&bones(132.0), &p, None), None);
        let axes = BoneAxes {
            leaf_axis: None,
            source: LeafAxisSource::ChildJoint(2),
            variances: [0.0; 3],
            rest_fold: None,
        };
        for psi in [132.0, 200.0, -60.0] {
            let d = skeleton_direction(&bones(psi), &p, &axes).expect("a direction");
            assert!(
                (d - (planar(psi) + Vector3::x()).normalize()).norm() < 1e-9,
                "ψ = {psi}"
            );
        }
    }

    #[test]
    fn a_rest_pose_folded_90_degrees_or_less_sets_no_sense() {
        for rest in [0.0, 10.0, -30.0, 90.0] {
            let axes = axes_at(rest);
            assert_eq!(axes.rest_fold, None, "rest fold {rest}°");
            // `normalize(u2 - u1)` in every pose: past 180° it turns over.
            for psi in [45.0, 179.0, 181.0, 250.0] {
                let d = skeleton_direction(&hinge(psi - rest, Matrix4::identity()), &pair(), &axes)
                    .expect("a direction");
                let expected = (planar(psi) + Vector3::x()).normalize();
                assert!(
                    (d - expected).norm() < 1e-9,
                    "rest {rest}°, ψ = {psi}: {d:?}"
                );
            }
        }
    }

    #[test]
    fn no_relative_motion_has_no_direction() {
        let rest = pose(Matrix4::identity(), Matrix4::identity());
        let moved = Matrix4::new_translation(&Vector3::new(0.0, 5.0, 0.0));
        let together = pose(moved, moved);
        let points = [Point3::new(0.1, 0.2, 0.3)];
        assert_eq!(motion_direction(&together, &rest, &pair(), &points), None);
        assert_eq!(motion_direction(&together, &rest, &pair(), &[]), None);
        // A twist about the points: the motions cancel.
        let twist = Rotation3::from_axis_angle(&Vector3::x_axis(), 0.5).to_homogeneous();
        let around = [Point3::new(1.0, 0.2, 0.0), Point3::new(1.0, -0.2, 0.0)];
        let twisted = pose(Matrix4::identity(), twist);
        assert_eq!(motion_direction(&twisted, &rest, &pair(), &around), None);
        // A singular rest joint.
        let flat = pose(Matrix4::zeros(), Matrix4::identity());
        assert_eq!(motion_direction(&twisted, &flat, &pair(), &points), None);
    }
}
