//! Assembly of a scene description (joints, skinned bodies, animation clips) into a GLB with
//! [`GlbBuilder`].
//!
//! Node layout: node 0 is the `rig` root, parent of the joint hierarchy (joints are nodes
//! `1..=joints`); the skinned mesh nodes follow, at the scene root with no transform, as the
//! glTF rules for skinned meshes ask. Inverse bind matrices are the inverses of the joints'
//! rest world transforms (computed from the same `f32` values the file stores), and mesh
//! vertices are given in world space at rest, so the rest pose reproduces the mesh.

use super::shapes::MeshData;
use crate::output::glb_builder::{GlbBuilder, GlbError, Target};
use gltf_json as json;
use json::validation::Checked::Valid;
use nalgebra::{Isometry3, Matrix4, Quaternion, Translation3, UnitQuaternion, Vector3};
use std::collections::BTreeMap;

/// A joint (bone) node of the rig.
#[derive(Clone, Debug)]
pub(crate) struct Joint {
    /// Node name.
    pub name: &'static str,
    /// Parent joint (index into the joint list), `None` for a child of the `rig` root.
    pub parent: Option<usize>,
    /// Rest translation relative to the parent.
    pub translation: Vector3<f64>,
    /// Rest rotation relative to the parent.
    pub rotation: UnitQuaternion<f64>,
}

impl Joint {
    /// A joint with no rest rotation.
    pub fn at(name: &'static str, parent: Option<usize>, translation: Vector3<f64>) -> Self {
        Self {
            name,
            parent,
            translation,
            rotation: UnitQuaternion::identity(),
        }
    }
}

/// Skin influences of one vertex (indices into the body's skin joints), weights summing to 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Influence {
    /// JOINTS_0 entry.
    pub joints: [u16; 4],
    /// WEIGHTS_0 entry.
    pub weights: [f32; 4],
}

impl Influence {
    /// Fully bound to skin joint `j`.
    pub fn rigid(j: u16) -> Self {
        Self {
            joints: [j, 0, 0, 0],
            weights: [1.0, 0.0, 0.0, 0.0],
        }
    }

    /// Blend of skin joints `j0` (weight `1 - t`) and `j1` (weight `t`), rigid at the ends.
    pub fn blend(j0: u16, j1: u16, t: f64) -> Self {
        if t <= 0.0 {
            return Self::rigid(j0);
        }
        if t >= 1.0 {
            return Self::rigid(j1);
        }
        let w1 = t as f32;
        Self {
            joints: [j0, j1, 0, 0],
            weights: [1.0 - w1, w1, 0.0, 0.0],
        }
    }
}

/// A skinned mesh: its node, its skin (the joints it uses) and its weights.
#[derive(Clone, Debug)]
pub(crate) struct SkinnedBody {
    /// Node, mesh and skin name.
    pub name: &'static str,
    /// Geometry in world space at rest.
    pub mesh: MeshData,
    /// The skin's joints (indices into the joint list), in JOINTS_0 order.
    pub skin: Vec<usize>,
    /// One influence per vertex.
    pub influences: Vec<Influence>,
    /// Volume of the smooth primitive the mesh approximates.
    pub analytic_volume: f64,
}

/// Keyframe values of one animation channel.
#[derive(Clone, Debug)]
pub(crate) enum Keys {
    /// Local rotations.
    Rotation(Vec<UnitQuaternion<f64>>),
    /// Local translations.
    Translation(Vec<Vector3<f64>>),
}

/// One LINEAR channel.
#[derive(Clone, Debug)]
pub(crate) struct Track {
    /// Target joint (index into the joint list).
    pub joint: usize,
    /// Strictly increasing key times, seconds.
    pub times: Vec<f64>,
    /// One value per key time.
    pub keys: Keys,
}

/// A named animation.
#[derive(Clone, Debug)]
pub(crate) struct Clip {
    /// Animation name.
    pub name: &'static str,
    /// Its channels.
    pub tracks: Vec<Track>,
}

/// Everything a scene file holds.
#[derive(Clone, Debug)]
pub(crate) struct SceneSpec {
    /// Scene name.
    pub name: &'static str,
    /// The joint hierarchy (parents before children).
    pub joints: Vec<Joint>,
    /// The skinned bodies.
    pub bodies: Vec<SkinnedBody>,
    /// The animations.
    pub clips: Vec<Clip>,
}

fn f32x3(v: &Vector3<f64>) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

fn f32x4(q: &UnitQuaternion<f64>) -> [f32; 4] {
    let c = q.as_ref().coords;
    [c.x as f32, c.y as f32, c.z as f32, c.w as f32]
}

/// The rest local transform as the file stores it (rounded to `f32`).
fn stored_local(j: &Joint) -> Isometry3<f64> {
    let t = f32x3(&j.translation).map(f64::from);
    let [x, y, z, w] = f32x4(&j.rotation).map(f64::from);
    Isometry3::from_parts(
        Translation3::new(t[0], t[1], t[2]),
        UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)),
    )
}

/// Rest world transform of every joint.
fn rest_world(joints: &[Joint]) -> Vec<Isometry3<f64>> {
    let mut world: Vec<Isometry3<f64>> = Vec::with_capacity(joints.len());
    for j in joints {
        let local = stored_local(j);
        let w = match j.parent {
            Some(p) => world[p] * local,
            None => local,
        };
        world.push(w);
    }
    world
}

fn matrix_f32(m: &Matrix4<f64>) -> [f32; 16] {
    let mut out = [0.0f32; 16];
    for (o, x) in out.iter_mut().zip(m.as_slice()) {
        *o = *x as f32;
    }
    out
}

/// Builds the GLB bytes of `spec`.
pub(crate) fn assemble(spec: &SceneSpec) -> Result<Vec<u8>, GlbError> {
    let mut b = GlbBuilder::new();
    let joint_node = |j: usize| json::Index::<json::Node>::new(1 + j as u32);
    let roots: Vec<_> = (0..spec.joints.len())
        .filter(|&j| spec.joints[j].parent.is_none())
        .map(joint_node)
        .collect();
    let rig = b.root.push(json::Node {
        name: Some("rig".into()),
        children: Some(roots),
        ..Default::default()
    });
    push_joints(&mut b, &spec.joints, joint_node);
    let world = rest_world(&spec.joints);
    let mut scene_nodes = vec![rig];
    for body in &spec.bodies {
        scene_nodes.push(push_body(&mut b, body, &world, rig, joint_node));
    }
    for clip in &spec.clips {
        push_clip(&mut b, clip, joint_node);
    }
    let scene = b.root.push(json::Scene {
        name: Some(spec.name.into()),
        nodes: scene_nodes,
        extensions: None,
        extras: Default::default(),
    });
    b.root.scene = Some(scene);
    b.finish()
}

fn push_joints(
    b: &mut GlbBuilder,
    joints: &[Joint],
    node: impl Fn(usize) -> json::Index<json::Node>,
) {
    for (i, j) in joints.iter().enumerate() {
        let children: Vec<_> = (0..joints.len())
            .filter(|&c| joints[c].parent == Some(i))
            .map(&node)
            .collect();
        let translation = (j.translation != Vector3::zeros()).then(|| f32x3(&j.translation));
        let rotation = (j.rotation != UnitQuaternion::identity())
            .then(|| json::scene::UnitQuaternion(f32x4(&j.rotation)));
        b.root.push(json::Node {
            name: Some(j.name.into()),
            children: (!children.is_empty()).then_some(children),
            translation,
            rotation,
            ..Default::default()
        });
    }
}

fn push_body(
    b: &mut GlbBuilder,
    body: &SkinnedBody,
    world: &[Isometry3<f64>],
    rig: json::Index<json::Node>,
    node: impl Fn(usize) -> json::Index<json::Node>,
) -> json::Index<json::Node> {
    let m = &body.mesh;
    let positions: Vec<[f32; 3]> = m.positions.iter().map(|p| f32x3(&p.coords)).collect();
    let normals: Vec<[f32; 3]> = m.normals.iter().map(f32x3).collect();
    let joints: Vec<[u16; 4]> = body.influences.iter().map(|i| i.joints).collect();
    let weights: Vec<[f32; 4]> = body.influences.iter().map(|i| i.weights).collect();
    let mut attributes = BTreeMap::new();
    attributes.insert(
        Valid(json::mesh::Semantic::Positions),
        b.push_f32(&positions, Target::Vertex, true),
    );
    attributes.insert(
        Valid(json::mesh::Semantic::Normals),
        b.push_f32(&normals, Target::Vertex, false),
    );
    attributes.insert(
        Valid(json::mesh::Semantic::Joints(0)),
        b.push_joints(&joints),
    );
    attributes.insert(
        Valid(json::mesh::Semantic::Weights(0)),
        b.push_f32(&weights, Target::Vertex, false),
    );
    let indices = b.push_indices(&m.triangles);
    let mesh = b.root.push(json::Mesh {
        name: Some(body.name.into()),
        primitives: vec![json::mesh::Primitive {
            attributes,
            indices: Some(indices),
            material: None,
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
            extensions: None,
            extras: Default::default(),
        }],
        weights: None,
        extensions: None,
        extras: Default::default(),
    });
    let ibm: Vec<[f32; 16]> = body
        .skin
        .iter()
        .map(|&j| matrix_f32(&world[j].inverse().to_homogeneous()))
        .collect();
    let ibm = b.push_f32(&ibm, Target::None, false);
    let skin = b.root.push(json::Skin {
        name: Some(format!("{}_skin", body.name)),
        inverse_bind_matrices: Some(ibm),
        joints: body.skin.iter().map(|&j| node(j)).collect(),
        skeleton: Some(rig),
        extensions: None,
        extras: Default::default(),
    });
    b.root.push(json::Node {
        name: Some(body.name.into()),
        mesh: Some(mesh),
        skin: Some(skin),
        ..Default::default()
    })
}

fn push_clip(b: &mut GlbBuilder, clip: &Clip, node: impl Fn(usize) -> json::Index<json::Node>) {
    let mut channels = Vec::new();
    let mut samplers = Vec::new();
    for track in &clip.tracks {
        let times: Vec<[f32; 1]> = track.times.iter().map(|&t| [t as f32]).collect();
        let input = b.push_f32(&times, Target::None, true);
        let (output, path) = match &track.keys {
            Keys::Rotation(q) => {
                let v: Vec<[f32; 4]> = q.iter().map(f32x4).collect();
                (
                    b.push_f32(&v, Target::None, false),
                    json::animation::Property::Rotation,
                )
            }
            Keys::Translation(t) => {
                let v: Vec<[f32; 3]> = t.iter().map(f32x3).collect();
                (
                    b.push_f32(&v, Target::None, false),
                    json::animation::Property::Translation,
                )
            }
        };
        channels.push(json::animation::Channel {
            sampler: json::Index::new(samplers.len() as u32),
            target: json::animation::Target {
                node: node(track.joint),
                path: Valid(path),
                extensions: None,
                extras: Default::default(),
            },
            extensions: None,
            extras: Default::default(),
        });
        samplers.push(json::animation::Sampler {
            input,
            interpolation: Valid(json::animation::Interpolation::Linear),
            output,
            extensions: None,
            extras: Default::default(),
        });
    }
    b.root.push(json::Animation {
        name: Some(clip.name.into()),
        channels,
        samplers,
        extensions: None,
        extras: Default::default(),
    });
}
