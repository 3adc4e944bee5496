//! A small deterministic generator (SplitMix64) for the tests' random cases.

#![allow(dead_code)]

use nalgebra::{Point3, Rotation3, Unit, Vector3};

/// SplitMix64; the seed is the state.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in the cube `[lo, hi)³`.
    pub fn point_in_box(&mut self, lo: f64, hi: f64) -> Point3<f64> {
        Point3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }

    /// A uniformly distributed unit vector (rejection sampling in the unit ball).
    pub fn unit(&mut self) -> Vector3<f64> {
        loop {
            let v = Vector3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let n = v.norm();
            if n > 0.1 && n <= 1.0 {
                return v / n;
            }
        }
    }

    /// A rotation about a random axis by a random angle.
    pub fn rotation(&mut self) -> Rotation3<f64> {
        let axis = Unit::new_normalize(self.unit());
        Rotation3::from_axis_angle(&axis, self.range(0.0, std::f64::consts::TAU))
    }
}
