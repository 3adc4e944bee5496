//! The clipped polygons of a face triangulated into sub-triangles (ear clipping; a signed fan,
//! its clockwise triangles holes, where no ear is found), so that integrals over `I_l` of
//! piecewise-linear data are exact (Sec. 4.1).

use super::clip::Node;
use super::{CutFace, RegionStats, SubTriangle};

fn cross2(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

pub(super) fn signed_area(poly: &[Node]) -> f64 {
    let n = poly.len();
    (0..n)
        .map(|i| {
            let (a, b) = (poly[i].uv(), poly[(i + 1) % n].uv());
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
        * 0.5
}

fn sub_triangle(poly: &[Node], [a, b, c]: [usize; 3]) -> SubTriangle {
    SubTriangle {
        bary: [poly[a].bary, poly[b].bary, poly[c].bary],
        points: [poly[a].point, poly[b].point, poly[c].point],
    }
}

/// Ear clipping of a counter-clockwise polygon (in barycentric coordinates of the face); falls
/// back to a signed fan (negative triangles become holes), which keeps integrals exact.
pub(super) fn triangulate_into(poly: &[Node], cut: &mut CutFace, stats: &mut RegionStats) {
    let uv: Vec<[f64; 2]> = poly.iter().map(Node::uv).collect();
    let mut ring: Vec<usize> = (0..poly.len()).collect();
    while ring.len() > 3 {
        match find_ear(&uv, &ring) {
            Some((i, true)) => {
                let m = ring.len();
                let tri = [ring[(i + m - 1) % m], ring[i], ring[(i + 1) % m]];
                cut.sub_triangles.push(sub_triangle(poly, tri));
                ring.remove(i);
            }
            Some((i, false)) => {
                // Exactly collinear vertex: removing it keeps the region.
                ring.remove(i);
            }
            None => {
                stats.fan_fallbacks += 1;
                fan_into(poly, &uv, &ring, cut);
                return;
            }
        }
    }
    if ring.len() == 3 {
        fan_into(poly, &uv, &ring, cut);
    }
}

/// An ear of the ring (`(position, true)`) or an exactly collinear vertex (`(position, false)`).
fn find_ear(uv: &[[f64; 2]], ring: &[usize]) -> Option<(usize, bool)> {
    let m = ring.len();
    for i in 0..m {
        let (a, b, c) = (ring[(i + m - 1) % m], ring[i], ring[(i + 1) % m]);
        let cr = cross2(uv[a], uv[b], uv[c]);
        if cr == 0.0 {
            return Some((i, false));
        }
        if cr < 0.0 {
            continue;
        }
        let blocked = ring.iter().any(|&v| {
            let p = uv[v];
            v != a
                && v != b
                && v != c
                && p != uv[a]
                && p != uv[b]
                && p != uv[c]
                && cross2(uv[a], uv[b], p) >= 0.0
                && cross2(uv[b], uv[c], p) >= 0.0
                && cross2(uv[c], uv[a], p) >= 0.0
        });
        if !blocked {
            return Some((i, true));
        }
    }
    None
}

/// Fan from the ring's first vertex; clockwise triangles go to the holes (reversed).
fn fan_into(poly: &[Node], uv: &[[f64; 2]], ring: &[usize], cut: &mut CutFace) {
    let o = ring[0];
    for w in ring[1..].windows(2) {
        let (b, c) = (w[0], w[1]);
        let cr = cross2(uv[o], uv[b], uv[c]);
        if cr > 0.0 {
            cut.sub_triangles.push(sub_triangle(poly, [o, b, c]));
        } else if cr < 0.0 {
            cut.holes.push(sub_triangle(poly, [o, c, b]));
        }
    }
}
