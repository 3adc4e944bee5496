//! The rig: a glTF scene reduced to what posing needs.
//!
//! [`load()`] reads a `.gltf` (embedded data URIs or sibling `.bin` files) or `.glb` into a [`Rig`]:
//! the node hierarchy with rest transforms, the skins, the skinned mesh instances ([`Body`]) and
//! the animations. Every accessor is read through [`accessor`], which checks bounds, counts and
//! component types before touching a byte, so malformed files give a typed [`RigError`].

pub mod accessor;
pub mod animation;
mod error;
mod load;
pub mod morph;
mod orientation;
pub mod skeleton;
mod weights;

pub use animation::{Animation, Channel, Interpolation, Property};
pub use error::RigError;
pub(crate) use load::{confined_path, read_whole, Confinement, Unreadable};
pub use load::{
    load, load_from_bytes, MAX_FILE_VERTICES, MAX_MORPH_DISPLACEMENTS, MAX_MORPH_READS,
};
pub use morph::{MorphTarget, MorphedShape, Morphs};
pub use skeleton::{LocalTransform, Node, Pose, Trs};
pub use weights::SkinWeights;

use nalgebra::{Matrix4, Point3, Vector3};
use std::path::PathBuf;

/// A skin: an ordered list of joint nodes and their inverse bind matrices (glTF `skins[i]`).
#[derive(Clone, Debug)]
pub struct Skin {
    /// Name from the file, if any.
    pub name: Option<String>,
    /// Node index of each joint, in the skin's joint order (JOINTS_n refer to this order).
    pub joints: Vec<usize>,
    /// Inverse bind matrix of each joint (identity when the file gives none).
    pub inverse_bind: Vec<Matrix4<f64>>,
}

/// Where the vertices and triangles of one glTF primitive sit inside a [`Body`].
#[derive(Clone, Debug)]
pub struct PrimitiveRange {
    /// Index of the glTF mesh.
    pub mesh: usize,
    /// Index of the primitive inside that mesh.
    pub primitive: usize,
    /// First vertex of this primitive in the body's arrays.
    pub first_vertex: usize,
    /// Number of vertices (exactly the primitive's POSITION count, in file order).
    pub vertex_count: usize,
    /// First triangle of this primitive in [`Body::triangles`].
    pub first_triangle: usize,
    /// Number of triangles.
    pub triangle_count: usize,
}

/// One skinned mesh instance: a node that carries both a mesh and a skin.
///
/// The arrays concatenate the mesh's triangle primitives in file order, so vertex `i` of
/// primitive `p` is body vertex `primitives[p].first_vertex + i`. Following the glTF rule, the
/// node's own transform is ignored: skinned positions are `Σ w_j · world(joint_j) · IBM_j · p`.
#[derive(Clone, Debug)]
pub struct Body {
    /// Display name: the node's name, else the mesh's, else `body<i>`.
    pub name: String,
    /// Node index that instantiates the mesh.
    pub node: usize,
    /// glTF mesh index.
    pub mesh: usize,
    /// Index into [`Rig::skins`].
    pub skin: usize,
    /// A mesh without a skin in the file, posed rigidly by its node: `skin` is its own, with
    /// the node as its one joint.
    pub rigid: bool,
    /// Bind-pose positions (mesh space), one per file vertex.
    pub positions: Vec<Point3<f64>>,
    /// Bind-pose normals; computed from the triangles when the file has none.
    pub normals: Vec<Vector3<f64>>,
    /// Renormalized skin weights, one row per file vertex (joint indices into the skin).
    pub weights: SkinWeights,
    /// Triangles in body vertex indices (strips and fans converted, in file order).
    pub triangles: Vec<[u32; 3]>,
    /// The glTF primitives the arrays are made of.
    pub primitives: Vec<PrimitiveRange>,
    /// Morph targets (none for most rigs), applied before skinning ([`morph`]).
    pub morphs: Morphs,
}

impl Body {
    /// Number of (file) vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// The shape to skin with the morph `weights` (one per target; `None`: the defaults): the
    /// morphed shape, or `None` when no target has a non-zero weight (the bind shape).
    pub fn morphed(&self, weights: Option<&[f64]>) -> Option<MorphedShape> {
        let weights = weights.unwrap_or(&self.morphs.default_weights);
        self.morphs
            .apply(weights, &self.positions, &self.normals, &self.triangles)
    }

    /// Negates the bind normals and, with them, every morph target's normal displacements:
    /// the morphed normal `normalize(-n - Σ w Δn)` is then the negated file's
    /// `normalize(n + Σ w Δn)` (glTF 2.0 §3.7.2.2 adds the displacements to the file's
    /// normal), where negating the bind normals alone would turn a displaced normal away from
    /// both.
    pub(crate) fn negate_normals(&mut self) {
        for n in &mut self.normals {
            *n = -*n;
        }
        for target in &mut self.morphs.targets {
            for (_, d) in &mut target.normals {
                *d = -*d;
            }
        }
    }
}

/// A loaded rig: everything posing needs, read once.
#[derive(Clone, Debug)]
pub struct Rig {
    /// The file it was read from (or a label for in-memory input).
    pub source: PathBuf,
    /// Every node of the file, with its parent and rest transform.
    pub nodes: Vec<Node>,
    /// Nodes in parent-before-child order (every node appears once).
    pub node_order: Vec<usize>,
    /// Skins.
    pub skins: Vec<Skin>,
    /// Skinned mesh instances, in node order, then the unskinned ones (rigid bodies posed by
    /// their node, each with a skin of its own at the end of `skins`), in node order.
    pub bodies: Vec<Body>,
    /// Animations.
    pub animations: Vec<Animation>,
    /// Custom scalar vertex attributes of each body (same order as [`Rig::bodies`]): glTF
    /// attributes whose name starts with `_` (kept with the underscore, e.g. `_BULGE`), SCALAR
    /// float or normalized integer, one value per file vertex, present on every triangle
    /// primitive of the body. Other custom attributes are skipped with a warning.
    pub extra_attributes: Vec<Vec<(String, Vec<f64>)>>,
    /// Documented fallbacks taken while reading (renormalized weights, ignored primitives...).
    pub warnings: Vec<String>,
}

impl Rig {
    /// Finds an animation by name, or by index when `key` parses as a number.
    pub fn find_animation(&self, key: &str) -> Option<usize> {
        if let Some(i) = self
            .animations
            .iter()
            .position(|a| a.name.as_deref() == Some(key))
        {
            return Some(i);
        }
        key.parse::<usize>()
            .ok()
            .filter(|&i| i < self.animations.len())
    }

    /// The custom vertex attribute `name` (underscore included) of body `body`, one value per
    /// file vertex.
    pub fn extra_attribute(&self, body: usize, name: &str) -> Option<&[f64]> {
        self.extra_attributes
            .get(body)?
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    /// Total number of file vertices over all bodies.
    pub fn vertex_count(&self) -> usize {
        self.bodies.iter().map(Body::vertex_count).sum()
    }
}
