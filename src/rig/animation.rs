//! glTF animations and their sampling at any time: LINEAR (spherical for rotations), STEP and
//! CUBICSPLINE interpolation, as the glTF 2.0 specification (Appendix C) defines them, of a
//! node's translation, rotation, scale and morph target weights.

use super::skeleton::{unit_quaternion, LocalTransform};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// Which part of a node's TRS a channel drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Property {
    /// `translation` (3 components).
    Translation,
    /// `rotation` (4 components, `[x, y, z, w]`).
    Rotation,
    /// `scale` (3 components).
    Scale,
    /// `weights` of the node's morph targets (one component per target).
    Weights,
}

impl Property {
    /// Number of components of one value; for [`Property::Weights`], the node's number of
    /// morph targets `targets`.
    pub fn components(self, targets: usize) -> usize {
        match self {
            Property::Rotation => 4,
            Property::Weights => targets,
            _ => 3,
        }
    }
}

/// A sampler's interpolation mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// Piecewise linear; spherical linear for rotations.
    Linear,
    /// Piecewise constant.
    Step,
    /// Cubic Hermite with in- and out-tangents stored beside each value.
    CubicSpline,
}

/// One animated property of one node.
#[derive(Clone, Debug)]
pub struct Channel {
    /// Target node.
    pub node: usize,
    /// Target property.
    pub property: Property,
    /// Components of one value ([`Property::components`]).
    pub width: usize,
    /// Interpolation.
    pub interpolation: Interpolation,
    /// Key times in seconds, strictly increasing and finite.
    pub times: Vec<f64>,
    /// Key values, flattened: `width` per value, and for CUBICSPLINE the triples
    /// `[in-tangent, value, out-tangent]` per key.
    pub values: Vec<f64>,
}

/// A named set of channels.
#[derive(Clone, Debug)]
pub struct Animation {
    /// Name from the file.
    pub name: Option<String>,
    /// Channels.
    pub channels: Vec<Channel>,
    /// Earliest key time over all channels.
    pub start: f64,
    /// Latest key time over all channels.
    pub end: f64,
}

impl Animation {
    /// Builds an animation and its time range from its channels.
    pub fn new(name: Option<String>, channels: Vec<Channel>) -> Self {
        let start = channels
            .iter()
            .filter_map(|c| c.times.first().copied())
            .fold(f64::INFINITY, f64::min);
        let end = channels
            .iter()
            .filter_map(|c| c.times.last().copied())
            .fold(f64::NEG_INFINITY, f64::max);
        let (start, end) = if start.is_finite() {
            (start, end)
        } else {
            (0.0, 0.0)
        };
        Self {
            name,
            channels,
            start,
            end,
        }
    }

    /// Duration `end - start` in seconds.
    pub fn duration(&self) -> f64 {
        self.end - self.start
    }

    /// `n` times evenly spaced over `[start, end]`, both included (`start` alone for `n = 1`).
    pub fn frame_times(&self, n: usize) -> Vec<f64> {
        match n {
            0 => Vec::new(),
            1 => vec![self.start],
            _ => (0..n)
                .map(|i| self.start + self.duration() * i as f64 / (n - 1) as f64)
                .collect(),
        }
    }

    /// Overrides the targeted properties of `locals` with their values at time `t` (the
    /// morph weights are [`Animation::morph_weights`]).
    pub fn apply(&self, t: f64, locals: &mut [LocalTransform]) {
        for ch in &self.channels {
            let Some(local) = locals.get_mut(ch.node) else {
                continue;
            };
            let mut trs = local.trs();
            let vector = |v: [f64; 4]| Vector3::new(v[0], v[1], v[2]);
            match ch.property {
                Property::Translation => trs.translation = vector(ch.sample(t)),
                Property::Scale => trs.scale = vector(ch.sample(t)),
                Property::Rotation => {
                    if let Some(q) = unit_quaternion(ch.sample(t)) {
                        trs.rotation = q;
                    }
                }
                Property::Weights => continue,
            }
            *local = LocalTransform::Trs(trs);
        }
    }

    /// The morph weights its `weights` channels give at time `t`, per node of a scene of
    /// `nodes` nodes (`None` for a node no channel drives).
    pub fn morph_weights(&self, t: f64, nodes: usize) -> Vec<Option<Vec<f64>>> {
        let mut out = vec![None; nodes];
        for ch in self.channels.iter() {
            if let (Property::Weights, Some(slot)) = (ch.property, out.get_mut(ch.node)) {
                let mut w = vec![0.0; ch.width];
                ch.sample_into(t, &mut w);
                *slot = Some(w);
            }
        }
        out
    }
}

impl Channel {
    /// Value `slot` (0, or for CUBICSPLINE 0 in-tangent, 1 value, 2 out-tangent) of key `key`.
    fn value(&self, key: usize, slot: usize) -> &[f64] {
        let stride = if self.interpolation == Interpolation::CubicSpline {
            3
        } else {
            1
        };
        let base = (key * stride + slot) * self.width;
        &self.values[base..base + self.width]
    }

    /// The value at time `t` of a translation, rotation or scale channel (`[x, y, z, w]` for
    /// rotations; the entries past [`Channel::width`] are 0). Before the first key and after
    /// the last, the end values hold.
    pub fn sample(&self, t: f64) -> [f64; 4] {
        let mut out = [0.0; 4];
        let width = self.width.min(4);
        self.sample_into(t, &mut out[..width]);
        out
    }

    /// Writes the value at time `t` into `out` (its first [`Channel::width`] entries).
    pub fn sample_into(&self, t: f64, out: &mut [f64]) {
        let n = self.times.len();
        let value_slot = if self.interpolation == Interpolation::CubicSpline {
            1
        } else {
            0
        };
        let copy = |out: &mut [f64], v: &[f64]| {
            for (o, x) in out.iter_mut().zip(v) {
                *o = *x;
            }
        };
        if n == 1 || t <= self.times[0] || t.is_nan() {
            return copy(out, self.value(0, value_slot));
        }
        if t >= self.times[n - 1] {
            return copy(out, self.value(n - 1, value_slot));
        }
        // Largest k with times[k] <= t; k < n - 1 here.
        let k = self.times.partition_point(|&x| x <= t) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let dt = t1 - t0;
        let s = (t - t0) / dt;
        match self.interpolation {
            Interpolation::Step => copy(out, self.value(k, 0)),
            Interpolation::Linear if self.property == Property::Rotation => {
                let quaternion =
                    |v: &[f64]| std::array::from_fn(|i| v.get(i).copied().unwrap_or(0.0));
                let (a, b) = (
                    quaternion(self.value(k, 0)),
                    quaternion(self.value(k + 1, 0)),
                );
                copy(out, &slerp(a, b, s));
            }
            Interpolation::Linear => {
                let (a, b) = (self.value(k, 0), self.value(k + 1, 0));
                for (o, (a, b)) in out.iter_mut().zip(a.iter().zip(b)) {
                    *o = a + (b - a) * s;
                }
            }
            Interpolation::CubicSpline => {
                let (v0, b0) = (self.value(k, 1), self.value(k, 2));
                let (a1, v1) = (self.value(k + 1, 0), self.value(k + 1, 1));
                let (s2, s3) = (s * s, s * s * s);
                let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
                let h10 = s3 - 2.0 * s2 + s;
                let h01 = -2.0 * s3 + 3.0 * s2;
                let h11 = s3 - s2;
                for (i, o) in out.iter_mut().enumerate().take(self.width) {
                    *o = h00 * v0[i] + h10 * dt * b0[i] + h01 * v1[i] + h11 * dt * a1[i];
                }
            }
        }
    }
}

/// Spherical linear interpolation of `[x, y, z, w]` quaternions along the shorter arc
/// (glTF 2.0 Appendix C); falls back to normalized linear interpolation only for keys within
/// ~1e-6 rad, where both agree to rounding.
pub fn slerp(a: [f64; 4], b: [f64; 4], s: f64) -> [f64; 4] {
    let qa = unit_quaternion(a).unwrap_or_else(UnitQuaternion::identity);
    let qb = unit_quaternion(b).unwrap_or_else(UnitQuaternion::identity);
    let mut d = qa.coords.dot(&qb.coords);
    let mut qb: Quaternion<f64> = qb.into_inner();
    if d < 0.0 {
        qb = -qb;
        d = -d;
    }
    let qa = qa.into_inner();
    let q = if d > 1.0 - 1e-12 {
        qa * (1.0 - s) + qb * s
    } else {
        let theta0 = d.clamp(-1.0, 1.0).acos();
        let theta = theta0 * s;
        let sin0 = theta0.sin();
        qa * ((theta0 - theta).sin() / sin0) + qb * (theta.sin() / sin0)
    };
    let q = q.normalize();
    [q.i, q.j, q.k, q.w]
}
