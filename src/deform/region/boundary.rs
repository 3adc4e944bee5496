//! The cut boundary `∂C` of the contact zones (Algorithm lines 32-37; Sec. 5.1) and what is read
//! on it: the effective extent `φ_max,eff`, the intersection distance `φ_I`, the Dirichlet
//! directions of the cut points.

use super::{CutPoint, DeformStats, WorkingRegion};
use crate::contact::{ContactSide, SurfaceSample};
use crate::heat::{Boundary, EdgePoint};
use crate::mesh::Region;
use nalgebra::{Point3, Vector3};

/// The union of the contact zones as a cut boundary (local indices), with one exact point per
/// edge leaving it. Where two zones' points share an edge, the one farther from the zone
/// vertex is kept; edges leaving the union without a point get one next to the zone vertex.
pub(super) fn cut_boundary(
    wr: &WorkingRegion,
    contacts: &[&ContactSide],
    stats: &mut DeformStats,
) -> (Boundary, Vec<CutPoint>) {
    let region = wr.region();
    let n = region.vertex_count();
    let mut inside = vec![false; n];
    for (l, &v) in region.vertices.iter().enumerate() {
        inside[l] = contacts.iter().any(|c| c.zone.inside[v as usize]);
    }
    // The kept point of each edge, as an index into `kept` (`u32::MAX`: none). A point per
    // edge (200 bytes each) would make ~2 MB per region and fold on the finger, fresh pages
    // zeroed and faulted in each time, for the few hundred edges that get one.
    let mut per_edge = vec![u32::MAX; region.edges.len()];
    let mut kept: Vec<(f64, CutPoint)> = Vec::new();
    for (k, c) in contacts.iter().enumerate() {
        for bp in &c.zone.boundary {
            let (li, lj) = (
                wr.local_of[bp.inside as usize],
                wr.local_of[bp.outside as usize],
            );
            if li == u32::MAX || lj == u32::MAX || inside[lj as usize] {
                continue;
            }
            let Some(e) = region.edge(li, lj) else {
                continue;
            };
            let point = (
                bp.alpha,
                CutPoint {
                    contact: k,
                    inside: li,
                    outside: lj,
                    sample: bp.sample,
                },
            );
            let slot = &mut per_edge[e as usize];
            match kept.get_mut(*slot as usize) {
                Some(old) if bp.alpha > old.0 => *old = point,
                Some(_) => {}
                None => {
                    *slot = kept.len() as u32;
                    kept.push(point);
                }
            }
        }
    }
    let mut points = Vec::new();
    let mut edge_points = Vec::new();
    for (e, &[a, b]) in region.edges.iter().enumerate() {
        if inside[a as usize] == inside[b as usize] {
            continue;
        }
        let (li, lj) = if inside[a as usize] { (a, b) } else { (b, a) };
        let (alpha, cp) = match kept.get(per_edge[e] as usize) {
            Some(&x) => x,
            None => {
                stats.filled_boundary_points += 1;
                (0.0, filled_point(wr, contacts, li, lj))
            }
        };
        let alpha_first = if li == a { alpha } else { 1.0 - alpha };
        edge_points.push(EdgePoint {
            edge: e as u32,
            alpha: alpha_first,
        });
        points.push(cp);
    }
    let boundary = Boundary {
        inside,
        points: edge_points,
        vertices: Vec::new(),
    };
    (boundary, points)
}

/// A boundary point at the zone vertex itself, carrying its sample.
fn filled_point(wr: &WorkingRegion, contacts: &[&ContactSide], li: u32, lj: u32) -> CutPoint {
    let v = wr.region().vertices[li as usize] as usize;
    let (contact, sample) = contacts
        .iter()
        .enumerate()
        .find_map(|(k, c)| {
            c.zone.inside[v]
                .then(|| c.samples.get(v).map(|s| (k, *s)))
                .flatten()
        })
        .unwrap_or((
            0,
            SurfaceSample {
                point: Point3::origin(),
                own_normal: Vector3::zeros(),
                mapping: crate::contact::Mapping {
                    target: Point3::origin(),
                    target_normal: Vector3::zeros(),
                },
                surface_point: Point3::origin(),
                surface_normal: Vector3::zeros(),
                depth: 0.0,
                safeguard: 0.0,
            },
        ));
    CutPoint {
        contact,
        inside: li,
        outside: lj,
        sample,
    }
}

/// `φ_max,eff = min(φ̄, min φ over the region's open border)` (`PIPELINE.md`).
pub(super) fn effective_extent(
    region: &Region,
    boundary: &Boundary,
    phi: &[f64],
    extent: f64,
    free_border: Option<&[bool]>,
    stats: &mut DeformStats,
) -> f64 {
    let free =
        |l: usize| free_border.is_some_and(|f| f.get(region.vertices[l] as usize) == Some(&true));
    let border_min = (0..region.vertex_count())
        .filter(|&l| region.border[l] && !boundary.inside[l] && !free(l))
        .map(|l| phi[l])
        .fold(f64::INFINITY, f64::min);
    let ext = if extent.is_finite() && extent > 0.0 {
        extent
    } else {
        f64::INFINITY
    };
    let eff = ext.min(border_min);
    stats.extent_bound = border_min < ext;
    let eff = if eff.is_finite() && eff > 0.0 {
        eff
    } else {
        1e-12_f64.max(ext.min(1.0))
    };
    stats.extent = eff;
    eff
}

/// `φ_I`: the largest distance from `∂C` to the intersection curve (interpolated at the
/// edge-face intersection points, so it moves continuously).
pub(super) fn intersection_distance(
    wr: &WorkingRegion,
    contacts: &[&ContactSide],
    phi: &[f64],
) -> f64 {
    let mut best: f64 = 0.0;
    for c in contacts {
        for &([a, b], t) in &c.crossings {
            let (la, lb) = (wr.local_of[a as usize], wr.local_of[b as usize]);
            if la == u32::MAX || lb == u32::MAX {
                continue;
            }
            let v = phi[la as usize] * (1.0 - t) + phi[lb as usize] * t;
            if v.is_finite() {
                best = best.max(v);
            }
        }
    }
    best
}

/// The Dirichlet direction of each cut point: its contact's `d̄`.
pub(super) fn contact_directions(
    contacts: &[&ContactSide],
    points: &[CutPoint],
) -> Vec<Vector3<f64>> {
    if contacts.len() == 1 {
        return vec![contacts[0].direction];
    }
    points
        .iter()
        .map(|p| contacts[p.contact].direction)
        .collect()
}
