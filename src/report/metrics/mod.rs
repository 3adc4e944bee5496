//! Per-frame error metrics of `MEASURING.md` ("Error metrics"): residual penetration through the
//! generalized winding number, volume error, inverted faces, temporal smoothness (second
//! differences) and continuity (the displacement's steps), point-to-surface and Hausdorff
//! distances, non-finite values.
//!
//! One file per measure: `penetration.rs` (through the generalized winding number of
//! `winding.rs`, over the small BVH of `bvh.rs`), `frames.rs` (volume error, inverted and turned
//! faces, the temporal ratios), `distances.rs` (point-to-surface, Hausdorff; the closest points
//! of `triangle.rs`); every public item is re-exported here.
//!
//! **Units.** Every length is returned in the absolute units of the positions given. Reports
//! divide them by `h_rest`, the mean edge length of the rest mesh
//! ([`crate::mesh::operators::mean_edge_length`]), so that they compare across scales.
//!
//! **Robustness.** No function here panics or returns NaN, whatever its input:
//! - a point with a non-finite coordinate is *counted and skipped* (the count is returned where
//!   the result type has room for it, see each function);
//! - a triangle with an out-of-range index or a non-finite corner is ignored, as if absent from
//!   the surface (so a surface with such faces has holes, and its winding number is no longer an
//!   integer near them);
//! - where a distance has nothing to be measured to, it is `f64::INFINITY`, never NaN.
//!
//! **Determinism.** Every result is a pure function of the input: parallel loops only map
//! independent items and collect them in input order, and every reduction runs in a fixed order.
//!
//! References:
//! - A. Jacobson, L. Kavan, O. Sorkine-Hornung, *Robust Inside-Outside Segmentation using
//!   Generalized Winding Numbers*, SIGGRAPH 2013 (winding number as a sum of solid angles).
//! - A. van Oosterom, J. Strackee, *The Solid Angle of a Plane Triangle*, IEEE TBME 1983.
//! - G. Barill, N. Dickson, R. Schmidt, D. Levin, A. Jacobson, *Fast Winding Numbers for Soups
//!   and Clouds*, SIGGRAPH 2018 (tree of Taylor expansions, accuracy parameter β).
//! - C. Ericson, *Real-Time Collision Detection*, 2005, Sec. 5.1.5 (closest point on a triangle).

use std::collections::HashMap;
use std::f64::consts::PI;

use nalgebra::{Matrix3, Point3, Vector3};
use rayon::prelude::*;

use crate::mesh::operators::DEGENERATE_AREA;

/// Default accuracy parameter β of [`WindingNumber`] (Barill et al. 2018): a tree node is
/// replaced by its Taylor expansion when the query point is farther than β times the node's
/// radius from the node's center.
pub const WINDING_BETA: f64 = 2.0;

/// Inward nudge of a vertex before its winding number is evaluated, in units of `h`
/// (`MEASURING.md`: "nudged 0.05 h inward").
pub const PENETRATION_NUDGE: f64 = 0.05;

/// Winding number from which a nudged vertex counts as penetrating: inside its own body (1) and
/// inside another body or another part of its own body (2).
pub const PENETRATION_THRESHOLD: f64 = 1.5;

mod bvh;
mod distances;
mod frames;
mod penetration;
mod triangle;
mod winding;

pub use distances::*;
pub use frames::*;
pub use penetration::*;
pub use triangle::*;
pub use winding::*;

// ---------------------------------------------------------------------------------------------
// Small helpers
// ---------------------------------------------------------------------------------------------

/// True when all three coordinates are finite.
#[inline]
fn finite(p: &Point3<f64>) -> bool {
    p.x.is_finite() && p.y.is_finite() && p.z.is_finite()
}

/// The corners of triangle `t`, or `None` when an index is out of range or a corner is not
/// finite.
#[inline]
fn corners(positions: &[Point3<f64>], t: &[u32; 3]) -> Option<[Point3<f64>; 3]> {
    let mut out = [Point3::origin(); 3];
    for (o, &i) in out.iter_mut().zip(t) {
        let p = positions.get(i as usize)?;
        if !finite(p) {
            return None;
        }
        *o = *p;
    }
    Some(out)
}

/// Twice the area vector of a triangle, `(b - a) × (c - a)`.
#[inline]
fn double_area_vector(p: &[Point3<f64>; 3]) -> Vector3<f64> {
    (p[1] - p[0]).cross(&(p[2] - p[0]))
}

/// Whether a triangle is degenerate by the criterion of
/// [`crate::mesh::operators::FaceGeometry`]: twice its area at most `2 DEGENERATE_AREA` times
/// its longest edge squared (also true when the area is not finite).
#[inline]
fn is_degenerate(p: &[Point3<f64>; 3]) -> bool {
    let double_area = double_area_vector(p).norm();
    let longest = [p[1] - p[0], p[2] - p[1], p[0] - p[2]]
        .iter()
        .map(|e| e.norm_squared())
        .fold(0.0, f64::max);
    !(double_area.is_finite() && double_area > 2.0 * DEGENERATE_AREA * longest)
}

/// Number of points with a non-finite coordinate (`MEASURING.md`: "Non-finite values: none,
/// ever").
pub fn non_finite(positions: &[Point3<f64>]) -> usize {
    positions.iter().filter(|p| !finite(p)).count()
}
