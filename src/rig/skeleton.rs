//! The node hierarchy and its pose: local transforms (rest or animated) composed into world
//! matrices, and the per-skin joint matrices `world(joint) · IBM` that skinning consumes.

use super::{Rig, Skin};
use nalgebra::{Matrix3, Matrix4, Quaternion, Rotation3, UnitQuaternion, Vector3};

/// Translation, rotation, scale: the decomposed local transform of a glTF node,
/// applied as `T · R · S`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trs {
    /// Translation.
    pub translation: Vector3<f64>,
    /// Rotation.
    pub rotation: UnitQuaternion<f64>,
    /// Per-axis scale.
    pub scale: Vector3<f64>,
}

impl Default for Trs {
    fn default() -> Self {
        Self {
            translation: Vector3::zeros(),
            rotation: UnitQuaternion::identity(),
            scale: Vector3::repeat(1.0),
        }
    }
}

impl Trs {
    /// The matrix `T · R · S`.
    pub fn matrix(&self) -> Matrix4<f64> {
        let mut m = self.rotation.to_homogeneous();
        for c in 0..3 {
            for r in 0..3 {
                m[(r, c)] *= self.scale[c];
            }
        }
        m[(0, 3)] = self.translation.x;
        m[(1, 3)] = self.translation.y;
        m[(2, 3)] = self.translation.z;
        m
    }

    /// Decomposes an affine matrix without shear into `T · R · S` (a negative determinant is
    /// carried by a negative x scale). Used only when a file animates a node given by `matrix`.
    pub fn from_matrix(m: &Matrix4<f64>) -> Self {
        let translation = Vector3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]);
        let linear: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
        let mut scale = Vector3::new(
            linear.column(0).norm(),
            linear.column(1).norm(),
            linear.column(2).norm(),
        );
        if linear.determinant() < 0.0 {
            scale.x = -scale.x;
        }
        let mut rot = linear;
        for c in 0..3 {
            if scale[c].abs() > 0.0 {
                let s = scale[c];
                rot.column_mut(c).unscale_mut(s);
            }
        }
        let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(rot));
        Self {
            translation,
            rotation,
            scale,
        }
    }
}

/// A node's local transform as written in the file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LocalTransform {
    /// `translation` / `rotation` / `scale` (the only form glTF lets animations target).
    Trs(Trs),
    /// A `matrix`.
    Matrix(Matrix4<f64>),
}

impl LocalTransform {
    /// The local matrix.
    pub fn matrix(&self) -> Matrix4<f64> {
        match self {
            LocalTransform::Trs(t) => t.matrix(),
            LocalTransform::Matrix(m) => *m,
        }
    }

    /// The transform as TRS (decomposing a matrix).
    pub fn trs(&self) -> Trs {
        match self {
            LocalTransform::Trs(t) => *t,
            LocalTransform::Matrix(m) => Trs::from_matrix(m),
        }
    }
}

/// A node of the scene hierarchy.
#[derive(Clone, Debug)]
pub struct Node {
    /// Name from the file.
    pub name: Option<String>,
    /// Parent node (`None` for a root).
    pub parent: Option<usize>,
    /// Children, in file order.
    pub children: Vec<usize>,
    /// Rest (unanimated) local transform.
    pub rest: LocalTransform,
}

/// World matrices of every node for one instant, and the morph weights an animation sets.
#[derive(Clone, Debug)]
pub struct Pose {
    /// `world[n]`: node `n`'s local-to-world matrix.
    pub world: Vec<Matrix4<f64>>,
    /// `morph_weights[n]`: the weights of node `n`'s morph targets where an animation drives
    /// them (missing entries count as 0); `None`, or no entry, for the mesh's defaults
    /// ([`crate::rig::Morphs::default_weights`]).
    pub morph_weights: Vec<Option<Vec<f64>>>,
}

impl Pose {
    /// The pose of the world matrices `world`, with every mesh's default morph weights.
    pub fn new(world: Vec<Matrix4<f64>>) -> Self {
        Self {
            world,
            morph_weights: Vec::new(),
        }
    }

    /// The morph weights of node `node` where an animation drives them.
    pub fn morph_weights_of(&self, node: usize) -> Option<&[f64]> {
        self.morph_weights.get(node)?.as_deref()
    }

    /// Skinning matrices of a skin: `world(joint_j) · IBM_j` for every joint `j`.
    pub fn skin_matrices(&self, skin: &Skin) -> Vec<Matrix4<f64>> {
        skin.joints
            .iter()
            .zip(&skin.inverse_bind)
            .map(|(&node, ibm)| self.world[node] * ibm)
            .collect()
    }
}

impl Rig {
    /// Local transforms of every node at the rest pose (no animation applied).
    pub fn rest_locals(&self) -> Vec<LocalTransform> {
        self.nodes.iter().map(|n| n.rest).collect()
    }

    /// Local transforms with animation `animation` sampled at time `t` (seconds); channels
    /// override the translation, rotation or scale of the nodes they target.
    pub fn animated_locals(&self, animation: usize, t: f64) -> Vec<LocalTransform> {
        let mut locals = self.rest_locals();
        if let Some(anim) = self.animations.get(animation) {
            anim.apply(t, &mut locals);
        }
        locals
    }

    /// Composes local transforms into world matrices, parents first.
    pub fn pose_from_locals(&self, locals: &[LocalTransform]) -> Pose {
        let mut world = vec![Matrix4::identity(); self.nodes.len()];
        for &n in &self.node_order {
            let local = locals[n].matrix();
            world[n] = match self.nodes[n].parent {
                Some(p) => world[p] * local,
                None => local,
            };
        }
        Pose::new(world)
    }

    /// The pose of animation `animation` at time `t` (its transforms and morph weights), or the
    /// rest pose for `None`.
    pub fn pose_at(&self, animation: Option<usize>, t: f64) -> Pose {
        let Some(a) = animation else {
            return self.pose_from_locals(&self.rest_locals());
        };
        let mut pose = self.pose_from_locals(&self.animated_locals(a, t));
        if let Some(anim) = self.animations.get(a) {
            pose.morph_weights = anim.morph_weights(t, self.nodes.len());
        }
        pose
    }
}

/// Normalizes a quaternion given as `[x, y, z, w]`; `None` when it is zero or not finite.
pub fn unit_quaternion(xyzw: [f64; 4]) -> Option<UnitQuaternion<f64>> {
    let q = Quaternion::new(xyzw[3], xyzw[0], xyzw[1], xyzw[2]);
    let n = q.norm();
    (n.is_finite() && n > 1e-12).then(|| UnitQuaternion::new_unchecked(q / n))
}
