//! The displacement of a region (Algorithm lines 49-56): the profile curves and the bulge map
//! (Sec. 7, Eq. 7) give the positions without bulge `P` and the bulge vectors `Q`; the exact
//! volume root and `p' = P + γ h_v Q` (lines 57-60) follow in the parent module.

use super::{
    DeformError, DeformParams, DeformStats, DeformTimings, RegionDeformation, RegionFrame,
    WorkingRegion,
};
use crate::contact::{ContactSide, SurfaceSample};
use crate::deform::bulge::{apply_painted, procedural_bulge, BulgeParams, ContactSample};
use crate::deform::profile::{bulge_basis, Profile};
use crate::mesh::Region;
use nalgebra::{Point3, Vector3};

/// The per-vertex fields the displacement needs (local indices).
pub(super) struct Shape<'a> {
    /// Region positions (local indices) and mean edge length of this frame.
    pub(super) positions: &'a [Point3<f64>],
    pub(super) edge_length: f64,
    pub(super) u: &'a [f64],
    pub(super) a: &'a [f64],
    pub(super) s: &'a [f64],
    pub(super) d: &'a [Vector3<f64>],
    pub(super) zone: &'a [bool],
}

/// Lines 49-56: profiles and bulge map, `P` and `Q` (the volume root is the caller's).
pub(super) fn displace(
    wr: &WorkingRegion,
    frame: &RegionFrame,
    params: &DeformParams,
    shape: &Shape,
    stats: &mut DeformStats,
) -> Result<RegionDeformation, DeformError> {
    let region = wr.region();
    let rest = frame.positions;
    let mut base = rest.to_vec();
    let mut bulge_dir = vec![Vector3::zeros(); rest.len()];
    let mut deformable: Vec<(usize, f64)> = Vec::new();
    let mut direction = vec![Vector3::zeros(); rest.len()];
    for (l, &v) in region.vertices.iter().enumerate() {
        let v = v as usize;
        if shape.zone[l] {
            if let Some(s) = zone_sample(frame.contacts, v) {
                base[v] = s.surface_point;
            }
            continue;
        }
        let u = shape.u[l];
        if u.is_nan() || u >= 1.0 {
            continue;
        }
        let profile = Profile::new(shape.a[l].max(0.0), shape.s[l]);
        let t = profile.parameter_at(u);
        base[v] = rest[v] + shape.d[l] * profile.base_ordinate(t);
        bulge_dir[v] = shape.d[l] * bulge_basis(t);
        direction[v] = shape.d[l];
        deformable.push((l, t));
    }
    stats.deformed_vertices = deformable.len();
    let eta = bulge_map(wr, frame, params, shape, &deformable);
    for (&(l, _), e) in deformable.iter().zip(&eta) {
        let v = region.vertices[l] as usize;
        bulge_dir[v] *= *e;
    }
    Ok(RegionDeformation {
        positions: base.clone(),
        base,
        bulge_unit: bulge_dir,
        bulge: vec![Vector3::zeros(); rest.len()],
        u: Vec::new(),
        zone: Vec::new(),
        direction,
        amplitude: Vec::new(),
        slope: Vec::new(),
        stats: DeformStats::default(),
        timings: DeformTimings::default(),
    })
}

/// The sample on `S` of a zone vertex (the deepest when several contacts claim it).
fn zone_sample(contacts: &[&ContactSide], v: usize) -> Option<SurfaceSample> {
    contacts
        .iter()
        .filter(|c| c.zone.inside[v])
        .filter_map(|c| c.samples.get(v))
        .max_by(|x, y| x.depth.total_cmp(&y.depth))
        .copied()
}

/// `A_j`: a third of the area of the faces around each zone vertex (local indices; 0 for
/// other vertices, which are not needed).
fn zone_areas(
    region: &Region,
    local_pos: &[Point3<f64>],
    contacts: &[&ContactSide],
    local_of: &[u32],
) -> Vec<f64> {
    let mut in_zone = vec![false; region.vertex_count()];
    for c in contacts {
        for &v in &c.zone.vertices {
            if let Some(&l) = local_of.get(v as usize).filter(|&&l| l != u32::MAX) {
                in_zone[l as usize] = true;
            }
        }
    }
    let mut area = vec![0.0; region.vertex_count()];
    for t in &region.triangles {
        if !t.iter().any(|&v| in_zone[v as usize]) {
            continue;
        }
        let [a, b, c] = t.map(|v| local_pos[v as usize]);
        let third = (b - a).cross(&(c - a)).norm() / 6.0;
        for &v in t {
            area[v as usize] += third;
        }
    }
    area
}

/// Eq. 7 at the deformable vertices, from every zone vertex of every contact.
fn bulge_map(
    wr: &WorkingRegion,
    frame: &RegionFrame,
    params: &DeformParams,
    shape: &Shape,
    deformable: &[(usize, f64)],
) -> Vec<f64> {
    let region = wr.region();
    let local_pos = shape.positions;
    let area = zone_areas(region, local_pos, frame.contacts, &wr.local_of);
    let mut samples = Vec::new();
    for c in frame.contacts {
        for &v in &c.zone.vertices {
            let (Some(s), l) = (c.samples.get(v as usize), wr.local_of[v as usize]) else {
                continue;
            };
            if l == u32::MAX {
                continue;
            }
            samples.push(ContactSample {
                position: s.point,
                area: area[l as usize],
                depth: (s.surface_point - s.point).norm(),
                push: c.cast,
            });
        }
    }
    let points: Vec<Point3<f64>> = deformable.iter().map(|&(l, _)| local_pos[l]).collect();
    let h = shape.edge_length;
    let bp = BulgeParams {
        omega: params.omega,
        floor: params.bulge_floor,
        ..BulgeParams::for_edge_length(h)
    };
    let mut eta = procedural_bulge(&points, &samples, &bp);
    if let Some(painted) = frame.painted {
        let per_point: Vec<f64> = deformable
            .iter()
            .map(|&(l, _)| {
                painted
                    .get(region.vertices[l] as usize)
                    .copied()
                    .unwrap_or(1.0)
            })
            .collect();
        apply_painted(&mut eta, &per_point);
    }
    eta
}
