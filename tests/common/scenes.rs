//! Loading a committed rig and running the contact pass on its frames, with the metrics of
//! `MEASURING.md`.

#![allow(dead_code)]

use contact_skin::frames::{self, Precomputed};
use contact_skin::mesh::operators::{mean_edge_length, vertex_normals, NormalWeighting};
use contact_skin::pass::{ContactPass, ObjectParams, PairOverride, PassOutput};
use contact_skin::report::metrics;
use contact_skin::rig::{self, Rig};
use contact_skin::skinning::Method;
use nalgebra::{Point3, Vector3};
use std::path::Path;

/// A rig with its welded bodies, ready for the contact pass.
pub struct Loaded {
    pub rig: Rig,
    pub pre: Precomputed,
    pub times: Vec<f64>,
    pub triangles: Vec<Vec<[u32; 3]>>,
    pub h_rest: f64,
}

pub fn load(name: &str, frames: usize) -> Loaded {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("rigs")
        .join(format!("{name}.glb"));
    let rig = rig::load(&path).expect("committed rig loads");
    let pre = Precomputed::new(&rig, Method::Lbs);
    let times = frames::sample_times(&rig, Some(0), Some(frames));
    let triangles: Vec<Vec<[u32; 3]>> = pre.welded.iter().map(|w| w.triangles.clone()).collect();
    let rest = welded_positions(&rig, &pre, 0.0, None);
    let (sum, n) = rest
        .iter()
        .zip(&triangles)
        .fold((0.0, 0usize), |(s, n), (p, t)| {
            (s + mean_edge_length(p, t), n + 1)
        });
    Loaded {
        rig,
        pre,
        times,
        triangles,
        h_rest: sum / n as f64,
    }
}

/// Welded positions of every body at time `t` of animation `anim` (rest pose for `None`).
pub fn welded_positions(
    rig: &Rig,
    pre: &Precomputed,
    t: f64,
    anim: Option<usize>,
) -> Vec<Vec<Point3<f64>>> {
    let f = frames::evaluate(rig, pre, anim, 0, t);
    f.bodies
        .iter()
        .zip(&pre.welded)
        .map(|(b, w)| w.gather(&b.positions))
        .collect()
}

impl Loaded {
    pub fn frame(&self, k: usize) -> Vec<Vec<Point3<f64>>> {
        welded_positions(&self.rig, &self.pre, self.times[k], Some(0))
    }

    pub fn pass(&self, params: Vec<ObjectParams>, overrides: Vec<PairOverride>) -> ContactPass {
        let rest = welded_positions(&self.rig, &self.pre, 0.0, None);
        let bodies: Vec<(&[Point3<f64>], &[[u32; 3]])> = rest
            .iter()
            .zip(&self.triangles)
            .map(|(p, t)| (p.as_slice(), t.as_slice()))
            .collect();
        ContactPass::new(&bodies, params, overrides).expect("pass precomputes")
    }

    /// Residual penetration of a frame (all bodies together).
    pub fn penetration(&self, positions: &[Vec<Point3<f64>>]) -> metrics::Penetration {
        let normals: Vec<Vec<Vector3<f64>>> = positions
            .iter()
            .zip(&self.triangles)
            .map(|(p, t)| vertex_normals(p, t, NormalWeighting::Area))
            .collect();
        let bodies: Vec<(&[Point3<f64>], &[[u32; 3]], &[Vector3<f64>])> = positions
            .iter()
            .zip(&self.triangles)
            .zip(&normals)
            .map(|((p, t), n)| (p.as_slice(), t.as_slice(), n.as_slice()))
            .collect();
        metrics::residual_penetration_bodies(&bodies, self.h_rest)
    }

    /// Relative volume error of body `b`.
    pub fn volume_error(&self, b: usize, input: &[Vec<Point3<f64>>], out: &PassOutput) -> f64 {
        let v_in = contact_skin::mesh::signed_volume(&input[b], &self.triangles[b]);
        let v_out = contact_skin::mesh::signed_volume(&out.positions[b], &self.triangles[b]);
        metrics::volume_error(v_in, v_out)
    }
}
