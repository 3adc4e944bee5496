//! A baked glb: one file that plays a posed sequence in any glTF viewer.
//!
//! Each body becomes an unskinned mesh whose base positions are the first frame; every later
//! frame is a morph target holding its displacement from the base, and a `weights` animation
//! switches from one target to the next (LINEAR, so a viewer interpolates between frames).

use super::glb_builder::{GlbBuilder, GlbError, Target};
use crate::frames::Frame;
use crate::rig::Rig;
use gltf_json as json;
use json::validation::Checked::Valid;
use std::collections::BTreeMap;

/// The frames at `times` a glb can key, by position: the first, then each whose key time (from
/// the first, as `f32`) exceeds the last kept one's. A glTF animation's key times must
/// increase, and one key time holds one pose: a rig without animation, a zero-length one, or
/// frames closer than `f32` resolves give repeated times (the Khronos validator rejected such
/// files; found posing the WebXR hands, which have no animation, with `--frames 12`).
pub fn key_times(times: &[f64]) -> Vec<usize> {
    let Some(&first) = times.first() else {
        return Vec::new();
    };
    let mut kept = vec![0];
    let mut last = 0.0f32;
    for (k, &time) in times.iter().enumerate().skip(1) {
        let t = (time - first) as f32;
        if t > last {
            kept.push(k);
            last = t;
        }
    }
    kept
}

/// Why a sequence of frames cannot be baked.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// No frame to bake.
    #[error("no frame to bake")]
    NoFrames,
    /// A frame does not match the rig (bodies or vertices per body).
    #[error("frame {frame}: {what}")]
    Mismatch {
        /// The frame's index.
        frame: usize,
        /// What does not match.
        what: String,
    },
    /// A key time or morph delta that 32-bit floats cannot hold ([`check_bakeable`]).
    #[error("{0}")]
    Unrepresentable(String),
    /// The frames to key are more than a weights animation can index (its output's
    /// `frames × (frames - 1)` elements by 32-bit sparse indices).
    #[error("{frames} frames to key: a baked glb keys at most {MAX_BAKED_FRAMES}")]
    TooManyFrames {
        /// The frames to key.
        frames: usize,
    },
    /// The glb could not be built (serialization, or a file of 4 GiB or more).
    #[error("{0}")]
    Glb(#[from] GlbError),
}

/// Most frames a baked glb keys: its weights animation's output holds `frames × (frames - 1)`
/// elements, indexed by 32-bit sparse indices (viewers expand it dense: at this size 16 GiB).
pub const MAX_BAKED_FRAMES: usize = 65_536;

/// Builds the glb bytes of a sequence of frames (at least one, each with the rig's bodies and
/// vertex counts); only those at its [`key_times`] are baked. Anything else is a
/// [`BakeError`], checked before anything is built.
pub fn bake(rig: &Rig, frames: &[Frame], name: &str) -> Result<Vec<u8>, BakeError> {
    check_frames(rig, frames)?;
    check_bakeable(frames).map_err(BakeError::Unrepresentable)?;
    let times: Vec<f64> = frames.iter().map(|f| f.time).collect();
    let keyed: Vec<&Frame> = key_times(&times).into_iter().map(|k| &frames[k]).collect();
    if keyed.len() > MAX_BAKED_FRAMES {
        return Err(BakeError::TooManyFrames {
            frames: keyed.len(),
        });
    }
    let frames = keyed.as_slice();
    let mut b = GlbBuilder::new();
    let mut nodes = Vec::new();
    for (bi, body) in rig.bodies.iter().enumerate() {
        let mut primitives = Vec::new();
        for prim in &body.primitives {
            primitives.push(bake_primitive(&mut b, frames, bi, body, prim));
        }
        let targets = frames.len().saturating_sub(1);
        let mesh = b.root.push(json::Mesh {
            extensions: None,
            extras: Default::default(),
            name: Some(body.name.clone()),
            primitives,
            weights: (targets > 0).then(|| vec![0.0; targets]),
        });
        nodes.push(b.root.push(json::Node {
            mesh: Some(mesh),
            name: Some(body.name.clone()),
            ..Default::default()
        }));
    }
    if frames.len() > 1 {
        push_weights_animation(&mut b, frames, &nodes, name);
    }
    let scene = b.root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: Some(name.to_string()),
        nodes: nodes.clone(),
    });
    b.root.scene = Some(scene);
    Ok(b.finish()?)
}

/// At least one frame, each with one position set per body of `rig`, each as long as the
/// body's vertex count (what [`bake_primitive`] indexes).
fn check_frames(rig: &Rig, frames: &[Frame]) -> Result<(), BakeError> {
    if frames.is_empty() {
        return Err(BakeError::NoFrames);
    }
    for f in frames {
        let mismatch = |what: String| BakeError::Mismatch {
            frame: f.index,
            what,
        };
        if f.bodies.len() != rig.bodies.len() {
            return Err(mismatch(format!(
                "{} bodies, the rig has {}",
                f.bodies.len(),
                rig.bodies.len()
            )));
        }
        for (b, (posed, body)) in f.bodies.iter().zip(&rig.bodies).enumerate() {
            let needed = body
                .primitives
                .iter()
                .map(|p| p.first_vertex + p.vertex_count)
                .max()
                .unwrap_or(0);
            if posed.positions.len() < needed {
                return Err(mismatch(format!(
                    "body {b}: {} positions, its primitives need {needed}",
                    posed.positions.len()
                )));
            }
        }
    }
    Ok(())
}

/// Whether `frames` (each already [`super::check_representable`]) can be baked: every morph
/// delta, the `f32` difference from the first frame, and every key time, from the first
/// frame's, finite (positions near `±f32::MAX` of opposite signs, or key times spanning more
/// than `f32`'s range, overflow; found by fuzzing).
pub fn check_bakeable(frames: &[Frame]) -> Result<(), String> {
    let Some(first) = frames.first() else {
        return Ok(());
    };
    for f in frames {
        let dt = (f.time - first.time) as f32;
        if !dt.is_finite() {
            return Err(format!(
                "frame {}: its time {} cannot be a glb key time",
                f.index, f.time
            ));
        }
        for (b, (body, base)) in f.bodies.iter().zip(&first.bodies).enumerate() {
            for (v, (p, q)) in body.positions.iter().zip(&base.positions).enumerate() {
                let finite = (0..3).all(|k| (p[k] as f32 - q[k] as f32).is_finite());
                if !finite {
                    return Err(format!(
                        "frame {} body {b} vertex {v}: its displacement from the first frame \
                         overflows 32-bit floats",
                        f.index
                    ));
                }
            }
        }
    }
    Ok(())
}

fn bake_primitive(
    b: &mut GlbBuilder,
    frames: &[&Frame],
    body: usize,
    source: &crate::rig::Body,
    prim: &crate::rig::PrimitiveRange,
) -> json::mesh::Primitive {
    let range = prim.first_vertex..prim.first_vertex + prim.vertex_count;
    let base: Vec<[f32; 3]> = frames[0].bodies[body].positions[range.clone()]
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    let position = b.push_f32(&base, Target::Vertex, true);
    let targets: Vec<json::mesh::MorphTarget> = frames[1..]
        .iter()
        .map(|f| {
            let delta: Vec<[f32; 3]> = f.bodies[body].positions[range.clone()]
                .iter()
                .zip(&base)
                .map(|(p, q)| [p.x as f32 - q[0], p.y as f32 - q[1], p.z as f32 - q[2]])
                .collect();
            json::mesh::MorphTarget {
                positions: Some(b.push_f32(&delta, Target::Vertex, true)),
                normals: None,
                tangents: None,
            }
        })
        .collect();
    // Indices local to the primitive.
    let first = prim.first_vertex as u32;
    let tris: Vec<[u32; 3]> = source.triangles
        [prim.first_triangle..prim.first_triangle + prim.triangle_count]
        .iter()
        .map(|t| t.map(|i| i - first))
        .collect();
    let indices = b.push_indices(&tris);
    let mut attributes = BTreeMap::new();
    attributes.insert(Valid(json::mesh::Semantic::Positions), position);
    json::mesh::Primitive {
        attributes,
        extensions: None,
        extras: Default::default(),
        indices: Some(indices),
        material: None,
        mode: Valid(json::mesh::Mode::Triangles),
        targets: (!targets.is_empty()).then_some(targets),
    }
}

fn push_weights_animation(
    b: &mut GlbBuilder,
    frames: &[&Frame],
    nodes: &[json::Index<json::Node>],
    name: &str,
) {
    let t0 = frames[0].time;
    let times: Vec<[f32; 1]> = frames.iter().map(|f| [(f.time - t0) as f32]).collect();
    let targets = frames.len() - 1;
    // Key k weighs target k - 1 (frame k) by 1 and the others by 0: one non-zero per key
    // from the second on, stored sparse (the dense output holds `frames × targets` values:
    // 16 MB at 2 000 frames).
    let ones: Vec<(u32, f32)> = (1..frames.len())
        .map(|k| ((k * targets + k - 1) as u32, 1.0))
        .collect();
    let input = b.push_f32(&times, Target::None, true);
    let output = b.push_sparse_scalar(frames.len() * targets, &ones);
    let sampler = json::animation::Sampler {
        extensions: None,
        extras: Default::default(),
        input,
        interpolation: Valid(json::animation::Interpolation::Linear),
        output,
    };
    let channels = nodes
        .iter()
        .map(|&node| json::animation::Channel {
            sampler: json::Index::new(0),
            target: json::animation::Target {
                extensions: None,
                extras: Default::default(),
                node,
                path: Valid(json::animation::Property::MorphTargetWeights),
            },
            extensions: None,
            extras: Default::default(),
        })
        .collect();
    b.root.push(json::Animation {
        extensions: None,
        extras: Default::default(),
        channels,
        name: Some(name.to_string()),
        samplers: vec![sampler],
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_times_keep_increasing_times_only() {
        assert_eq!(key_times(&[]), Vec::<usize>::new());
        assert_eq!(key_times(&[0.0, 0.5, 1.0]), vec![0, 1, 2]);
        // No animation: every frame at t = 0.
        assert_eq!(key_times(&[0.0; 4]), vec![0]);
        // Closer than f32 resolves (its spacing is 0.0625 at 1e6 s), or going back.
        assert_eq!(key_times(&[0.0, 1e6, 1e6 + 1e-3, 5e5, 2e6]), vec![0, 1, 4]);
    }
}
