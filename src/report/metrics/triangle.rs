//! Point-triangle distance (Ericson 2005, Sec. 5.1.5).

use super::*;

/// Closest point to `p` on the segment `[a, b]` (on `a` when the segment has zero length).
#[inline]
fn closest_on_segment(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>) -> Point3<f64> {
    let ab = b - a;
    let len2 = ab.norm_squared();
    if len2.is_nan() || len2 <= 0.0 {
        return *a;
    }
    let t = ((p - a).dot(&ab) / len2).clamp(0.0, 1.0);
    a + ab * t
}

/// Closest point on the three edges (used for degenerate triangles).
fn closest_on_edges(p: &Point3<f64>, t: &[Point3<f64>; 3]) -> Point3<f64> {
    let mut best = t[0];
    let mut best_d = (p - t[0]).norm_squared();
    for k in 0..3 {
        let c = closest_on_segment(p, &t[k], &t[(k + 1) % 3]);
        let d = (p - c).norm_squared();
        if d < best_d {
            best = c;
            best_d = d;
        }
    }
    best
}

/// Closest point to `p` on the (solid) triangle `t`, exactly (Ericson 2005, Sec. 5.1.5: Voronoi
/// regions of the corners, edges and interior). A degenerate triangle (collinear or repeated
/// corners, see [`crate::mesh::operators::DEGENERATE_AREA`]) is treated as its three edges.
/// `None` when an input coordinate is not finite.
pub fn closest_point_on_triangle(p: &Point3<f64>, t: &[Point3<f64>; 3]) -> Option<Point3<f64>> {
    if !finite(p) || !t.iter().all(finite) {
        return None;
    }
    if is_degenerate(t) {
        return Some(closest_on_edges(p, t));
    }
    let c = ericson(p, t);
    Some(if finite(&c) {
        c
    } else {
        closest_on_edges(p, t)
    })
}

/// Ericson's region test; the divisions are by positive quantities for a non-degenerate triangle.
fn ericson(p: &Point3<f64>, t: &[Point3<f64>; 3]) -> Point3<f64> {
    let [a, b, c] = t;
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Unsigned distance from `p` to the (solid) triangle `t` (see [`closest_point_on_triangle`]);
/// `f64::INFINITY` when an input coordinate is not finite.
pub fn point_triangle_distance(p: &Point3<f64>, t: &[Point3<f64>; 3]) -> f64 {
    closest_point_on_triangle(p, t).map_or(f64::INFINITY, |c| (p - c).norm())
}

/// Squared distance for the trees (inputs already known finite).
#[inline]
pub(super) fn distance2(p: &Point3<f64>, t: &[Point3<f64>; 3]) -> f64 {
    let c = if is_degenerate(t) {
        closest_on_edges(p, t)
    } else {
        let c = ericson(p, t);
        if finite(&c) {
            c
        } else {
            closest_on_edges(p, t)
        }
    };
    let d = (p - c).norm_squared();
    if d.is_nan() {
        f64::INFINITY
    } else {
        d
    }
}
