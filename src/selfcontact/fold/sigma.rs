//! The sign field `σ` of the mapping direction over the shared region (`PIPELINE.md`,
//! "Consistent directions"; 2021 Sec. 6, "Consistent mapping direction").

use super::*;

/// `σ`: +1 on `W1 \ R` and `C_1`, -1 on `W2 \ R` and `C_2`, harmonic on the rest of `R`
/// (Dirichlet on the zones' exact boundary points and on `R`'s borders toward each side).
pub(super) fn sigma_field(
    pre: &FoldPre,
    positions: &[Point3<f64>],
    contact: &Contact,
) -> Result<Vec<f64>, FoldError> {
    let r = &pre.regions;
    let mut sigma: Vec<f64> = (0..positions.len())
        .map(|v| match (r.w1[v], r.w2[v]) {
            (true, false) => 1.0,
            (false, true) => -1.0,
            _ => 0.0,
        })
        .collect();
    // A vertex of `R` on no face of `R` (all of `R` where it has no face; `PartitionStats::
    // orphans`) has no harmonic value: in a zone it takes the zone's sign, else 0 (the
    // normals take over, as where the blend vanishes). Until 2026-12-05 a zone's vertex there
    // kept 0 too, against the +1 / -1 of this doc.
    for (v, s) in sigma.iter_mut().enumerate() {
        if r.w1[v] && r.w2[v] && pre.shared.local_of[v] == u32::MAX {
            *s = zone_sign(contact, v).unwrap_or(0.0);
        }
    }
    let region = &pre.shared.solver.region;
    if region.vertex_count() == 0 {
        return Ok(sigma);
    }
    let (boundary, values) = sigma_boundary(pre, contact);
    let local = region.gather(positions);
    let mut problem = pre.shared.solver.problem(&local, &boundary)?;
    let solved = problem.harmonic(&values)?;
    for (l, &v) in region.vertices.iter().enumerate() {
        let v = v as usize;
        sigma[v] = match zone_sign(contact, v) {
            Some(s) => s,
            None if problem.unreached()[l] => 0.0,
            None => solved[l].clamp(-1.0, 1.0),
        };
    }
    Ok(sigma)
}

/// `σ`'s Dirichlet value at `v`, if it is a vertex of a contact zone: +1 in `C_1`, -1 in `C_2`.
fn zone_sign(contact: &Contact, v: usize) -> Option<f64> {
    let zones = &contact.sides;
    if zones[0].zone.inside[v] {
        Some(1.0)
    } else if zones[1].zone.inside[v] {
        Some(-1.0)
    } else {
        None
    }
}

/// `σ`'s boundary on the shared region and its values (points first, then vertices): the
/// zones' exact points on `R`'s edges (every edge leaving a zone gets one, at the zone vertex
/// if the contact has none on it) and `R`'s vertices bordering one side only.
fn sigma_boundary(pre: &FoldPre, contact: &Contact) -> (Boundary, Vec<f64>) {
    let region = &pre.shared.solver.region;
    let inside: Vec<bool> = region
        .vertices
        .iter()
        .map(|&v| zone_sign(contact, v as usize).is_some())
        .collect();
    let exact = zone_exact_points(pre, contact);
    let mut points = Vec::new();
    let mut values = Vec::new();
    for (e, &[a, b]) in region.edges.iter().enumerate() {
        if inside[a as usize] == inside[b as usize] {
            continue;
        }
        let zone_vertex = if inside[a as usize] { a } else { b };
        let (alpha, sign) = exact.get(&(e as u32)).copied().unwrap_or_else(|| {
            let s = zone_sign(contact, region.vertices[zone_vertex as usize] as usize);
            (if zone_vertex == a { 0.0 } else { 1.0 }, s.unwrap_or(0.0))
        });
        points.push(EdgePoint {
            edge: e as u32,
            alpha,
        });
        values.push(sign);
    }
    let mut fixed = Vec::new();
    for (l, &v) in region.vertices.iter().enumerate() {
        let side = match pre.topology.borders()[v as usize] {
            (true, false) => 1.0,
            (false, true) => -1.0,
            _ => continue,
        };
        if !inside[l] {
            fixed.push(l as u32);
            values.push(side);
        }
    }
    let boundary = Boundary {
        inside,
        points,
        vertices: fixed,
    };
    (boundary, values)
}

/// The zones' exact boundary points on the shared region's edges: per local edge, the
/// position along it from its first end and the sign of the zone.
fn zone_exact_points(pre: &FoldPre, contact: &Contact) -> HashMap<u32, (f64, f64)> {
    let region = &pre.shared.solver.region;
    let mut exact = HashMap::new();
    for (side, sign) in contact.sides.iter().zip([1.0, -1.0]) {
        for bp in &side.zone.boundary {
            let (li, lj) = (
                pre.shared.local_of[bp.inside as usize],
                pre.shared.local_of[bp.outside as usize],
            );
            if li == u32::MAX || lj == u32::MAX {
                continue;
            }
            if let Some(e) = region.edge(li, lj) {
                let alpha_first = if region.edges[e as usize][0] == li {
                    bp.alpha
                } else {
                    1.0 - bp.alpha
                };
                // A vertex in both zones counts as C_1's ([`zone_sign`]): so does its edge.
                exact.entry(e).or_insert((alpha_first, sign));
            }
        }
    }
    exact
}
