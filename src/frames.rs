//! Evaluation of a rig over time: the per-rig precomputation and the per-frame pure function.
//!
//! [`Precomputed`] holds everything that does not depend on the pose (welded topology, CoR
//! centers). [`evaluate`] maps a time to the posed bodies; frames share nothing, so an animation
//! is evaluated in parallel and the output does not depend on the thread count.

use crate::mesh::WeldedMesh;
use crate::rig::{Pose, Rig};
use crate::skinning::cor::{entry_budget, CorCenters};
use crate::skinning::{self, BindShape, Method, Skinned};
use rayon::prelude::*;

/// Per-rig data computed once, before any frame.
#[derive(Clone, Debug)]
pub struct Precomputed {
    /// Skinning method.
    pub method: Method,
    /// Welded surface of each body.
    pub welded: Vec<WeldedMesh>,
    /// Centers of rotation of each body (only for [`Method::Cor`]).
    pub cor: Vec<Option<CorCenters>>,
}

impl Precomputed {
    /// Precomputes what `method` needs on every body of `rig`.
    pub fn new(rig: &Rig, method: Method) -> Self {
        let welded = rig
            .bodies
            .par_iter()
            .map(|b| WeldedMesh::weld(&b.positions, &b.triangles))
            .collect();
        let cor = rig
            .bodies
            .iter()
            .map(|b| (method == Method::Cor).then(|| CorCenters::precompute(b)))
            .collect();
        Self {
            method,
            welded,
            cor,
        }
    }

    /// One warning per body whose centers of rotation were computed with a lowered
    /// subdivision cap ([`CorCenters::subdivision_cap`]: a broken mesh past the entry budget).
    pub fn warnings(&self, rig: &Rig) -> Vec<String> {
        (self.cor.iter().enumerate())
            .filter_map(|(b, c)| Some((b, c.as_ref()?.subdivision_cap?)))
            .map(|(b, (cap, planned))| {
                let name = rig.bodies.get(b).map_or("?", |body| body.name.as_str());
                format!(
                    "body {b} '{name}': centers of rotation with the subdivision capped at \
                     {cap} ({planned} entries planned, past the budget of {}: triangles \
                     spanning many joints, a broken mesh?)",
                    entry_budget(rig.bodies.get(b).map_or(0, |body| body.triangles.len()))
                )
            })
            .collect()
    }
}

/// One evaluated frame: the posed bodies at one time.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Index of the frame in its sequence.
    pub index: usize,
    /// Animation time in seconds.
    pub time: f64,
    /// Posed positions and normals of every body, in the rig's body order.
    pub bodies: Vec<Skinned>,
}

/// Poses every body of `rig` at time `t` of `animation` (rest pose for `None`).
pub fn evaluate(
    rig: &Rig,
    pre: &Precomputed,
    animation: Option<usize>,
    index: usize,
    t: f64,
) -> Frame {
    evaluate_pose(rig, pre, &rig.pose_at(animation, t), index, t)
}

/// Skins every body of `rig` at `pose`, wherever the pose comes from (an animation, a hand
/// tracker writing joint matrices, a test); `index` and `t` label the frame. A body with
/// morph targets is morphed first, by the pose's weights for its node or else its defaults
/// (glTF 2.0 §3.7.2.2: morphing, then skinning).
pub fn evaluate_pose(rig: &Rig, pre: &Precomputed, pose: &Pose, index: usize, t: f64) -> Frame {
    let bodies = rig
        .bodies
        .iter()
        .zip(&pre.cor)
        .map(|(body, cor)| {
            let mats = pose.skin_matrices(&rig.skins[body.skin]);
            let morphed = body.morphed(pose.morph_weights_of(body.node));
            let shape = morphed
                .as_ref()
                .map_or(BindShape::of(body), BindShape::morphed);
            skinning::skin_shape(pre.method, body, shape, &mats, cor.as_ref())
        })
        .collect();
    Frame {
        index,
        time: t,
        bodies,
    }
}

/// Default number of frames for an animation: 30 per second, both ends included.
pub const DEFAULT_FPS: f64 = 30.0;

/// Most frames one call of [`sample_times`] gives (over nine hours at [`DEFAULT_FPS`]): an
/// animation whose keys span absurd times must not make the default frame count allocate
/// gigabytes (found by fuzzing: keys up to 1e9 s asked for 3e10 frames and aborted).
pub const MAX_FRAMES: usize = 1_000_000;

/// Too many frames asked for, or implied by the animation's length.
#[derive(Debug, thiserror::Error)]
#[error("{frames} frames ({why}) is more than the {MAX_FRAMES} one run samples: give --frames {MAX_FRAMES} or fewer")]
pub struct FrameCountError {
    /// The count asked for or implied (saturated for a non-finite length).
    pub frames: f64,
    /// Where it came from.
    pub why: String,
}

/// The times to sample: `frames` evenly spaced over the animation (both ends included), by
/// default at [`DEFAULT_FPS`]; a single rest-pose frame at t = 0 without an animation. At most
/// [`MAX_FRAMES`].
pub fn sample_times(
    rig: &Rig,
    animation: Option<usize>,
    frames: Option<usize>,
) -> Result<Vec<f64>, FrameCountError> {
    let anim = animation.and_then(|a| rig.animations.get(a));
    let (n, why) = match (frames, anim) {
        (Some(n), _) => (n as f64, "asked for".to_owned()),
        (None, None) => (1.0, String::new()),
        (None, Some(anim)) => (
            (anim.duration() * DEFAULT_FPS).round() + 1.0,
            format!(
                "the animation lasts {} s, at {DEFAULT_FPS} fps",
                anim.duration()
            ),
        ),
    };
    if n.is_nan() || n > MAX_FRAMES as f64 {
        return Err(FrameCountError { frames: n, why });
    }
    let n = (n as usize).max(1);
    Ok(match anim {
        None => vec![0.0; n],
        Some(anim) => anim.frame_times(n),
    })
}

/// Welded positions of every body at time `t` of `animation` (rest pose for `None`): the input
/// of the contact passes, which work on the welded surfaces.
pub fn welded_positions(
    rig: &Rig,
    pre: &Precomputed,
    animation: Option<usize>,
    t: f64,
) -> Vec<Vec<nalgebra::Point3<f64>>> {
    evaluate(rig, pre, animation, 0, t).welded(pre)
}

impl Frame {
    /// Welded positions of every body (each welded vertex takes its representative file
    /// vertex's position).
    pub fn welded(&self, pre: &Precomputed) -> Vec<Vec<nalgebra::Point3<f64>>> {
        self.gather(pre, |b| &b.positions)
    }

    /// Welded skinned normals of every body (the rest normals carried by the skinning, not
    /// recomputed from the posed positions: the reference of [`crate::report::metrics::turned_faces`]).
    pub fn welded_normals(&self, pre: &Precomputed) -> Vec<Vec<nalgebra::Vector3<f64>>> {
        self.gather(pre, |b| &b.normals)
    }

    /// One per-vertex array of every body, gathered to its welded vertices.
    fn gather<T: Copy>(&self, pre: &Precomputed, field: impl Fn(&Skinned) -> &[T]) -> Vec<Vec<T>> {
        self.bodies
            .iter()
            .zip(&pre.welded)
            .map(|(b, w)| w.gather(field(b)))
            .collect()
    }
}
