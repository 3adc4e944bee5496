//! The partition of unity `β` over a shared region (Brunel et al. 2021, Sec. 6, "Shared
//! region & Partition of unity"), precomputed once on the rest pose.
//!
//! `R` is the set of vertices in both working regions `W1` and `W2`. `β` is harmonic on `R`
//! (cotangent stiffness on the faces of `R`, assembled at the rest positions and solved with
//! the machinery of [`crate::heat`]), with Dirichlet data on `R`'s border:
//! - `β = 1` on border vertices next to a vertex of `W1 \ R` (the paper's "boundary vertices of
//!   `R` belonging only to the boundary of `W2`": where `W2` ends, on `W1`'s side);
//! - `β = 0` on border vertices next to a vertex of `W2 \ R`;
//! - natural Neumann on the other border vertices (next to both, or to neither, e.g. an open
//!   mesh border).
//!
//! Outside `R`, `β = 1` on `W1 \ R` and `β = 0` on `W2 \ R`; vertices in neither region get 0
//! (they belong to neither deformation). The result is clamped to `[0, 1]`.

use super::{BorderSide, SelfContactError, UNNAMED_PAIR};
use crate::heat::{Boundary, RegionSolver};
use crate::mesh::Region;
use nalgebra::Point3;

/// What the partition of unity found on its way (for diagnostics and tests).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PartitionStats {
    /// Vertices of `R`.
    pub shared: usize,
    /// Faces of `R` (all three corners in `R`).
    pub faces: usize,
    /// Dirichlet vertices with `β = 1` (next to `W1 \ R` only).
    pub dirichlet_one: usize,
    /// Dirichlet vertices with `β = 0` (next to `W2 \ R` only).
    pub dirichlet_zero: usize,
    /// Vertices of `R` next to both `W1 \ R` and `W2 \ R` (natural Neumann).
    pub touching_both: usize,
    /// Vertices of `R` on no face of `R` (given the mean of their neighbors' `β`).
    pub orphans: usize,
    /// Connected parts of `R` (over the faces of `R`).
    pub components: usize,
    /// Parts of `R` whose border carries a single Dirichlet value (`β` constant on them).
    pub one_sided_components: usize,
    /// Smallest harmonic value before clamping (the discrete maximum principle keeps it `≥ 0`
    /// when no cotangent weight is negative).
    pub raw_min: f64,
    /// Largest harmonic value before clamping.
    pub raw_max: f64,
}

/// `β` per vertex of the mesh (see the module doc; 2021 Sec. 6).
///
/// - `positions_rest`: `#V` rest positions (welded vertices);
/// - `triangles`: `#F` triangles in vertex indices;
/// - `w1`, `w2`: `#V` flags, membership of each vertex in `W1` and `W2`.
///
/// Errors: inconsistent lengths or indices, a shared region whose border lacks the `β = 1` or
/// the `β = 0` side ([`SelfContactError::DegenerateSharedRegion`]), a part of `R` that touches
/// no Dirichlet border, or a failed solve. The pair is reported as [`UNNAMED_PAIR`]; callers
/// that know it rename it with [`SelfContactError::for_pair`].
pub fn partition_of_unity(
    positions_rest: &[Point3<f64>],
    triangles: &[[u32; 3]],
    w1: &[bool],
    w2: &[bool],
) -> Result<Vec<f64>, SelfContactError> {
    partition_of_unity_with_stats(positions_rest, triangles, w1, w2).map(|(beta, _)| beta)
}

/// [`partition_of_unity`] with its [`PartitionStats`].
pub fn partition_of_unity_with_stats(
    positions_rest: &[Point3<f64>],
    triangles: &[[u32; 3]],
    w1: &[bool],
    w2: &[bool],
) -> Result<(Vec<f64>, PartitionStats), SelfContactError> {
    let adjacency = vertex_adjacency(positions_rest.len(), triangles)?;
    partition_with_adjacency(positions_rest, triangles, &adjacency, w1, w2)
}

/// The faces whose three corners are all `inside` (ascending ids): with `inside` the vertices
/// of both working regions, the faces of the shared region `R`.
pub(super) fn faces_within(triangles: &[[u32; 3]], inside: &[bool]) -> Vec<u32> {
    triangles
        .iter()
        .enumerate()
        .filter(|(_, t)| t.iter().all(|&v| inside[v as usize]))
        .map(|(f, _)| f as u32)
        .collect()
}

/// [`partition_of_unity_with_stats`] with the mesh's [`vertex_adjacency`] already built.
pub(super) fn partition_with_adjacency(
    positions_rest: &[Point3<f64>],
    triangles: &[[u32; 3]],
    adjacency: &[Vec<u32>],
    w1: &[bool],
    w2: &[bool],
) -> Result<(Vec<f64>, PartitionStats), SelfContactError> {
    let n = positions_rest.len();
    if w1.len() != n || w2.len() != n || adjacency.len() != n {
        return Err(SelfContactError::InconsistentInput(format!(
            "{n} positions, {} W1 flags, {} W2 flags, {} adjacency rows",
            w1.len(),
            w2.len(),
            adjacency.len()
        )));
    }
    let in_r: Vec<bool> = w1.iter().zip(w2).map(|(&a, &b)| a && b).collect();
    let mut stats = PartitionStats {
        shared: in_r.iter().filter(|&&x| x).count(),
        raw_min: f64::INFINITY,
        raw_max: f64::NEG_INFINITY,
        ..Default::default()
    };

    let fixed = dirichlet_sides(adjacency, w1, w2, &mut stats)?;
    let mut beta: Vec<Option<f64>> = (0..n)
        .map(|v| match (w1[v], w2[v]) {
            (true, false) => Some(1.0),
            (false, true) | (false, false) => Some(0.0),
            (true, true) => fixed[v],
        })
        .collect();

    let r_faces = faces_within(triangles, &in_r);
    stats.faces = r_faces.len();
    if !r_faces.is_empty() {
        let region = Region::from_faces(triangles, r_faces);
        let (components, one_sided) = component_counts(&region, &fixed);
        stats.components = components;
        stats.one_sided_components = one_sided;
        let values = solve_harmonic(region, positions_rest, &fixed, &mut stats)?;
        for (v, x) in values {
            beta[v as usize] = Some(x);
        }
    }

    stats.orphans = fill_orphans(adjacency, &mut beta);
    let beta = beta
        .into_iter()
        .map(|b| b.unwrap_or(0.5).clamp(0.0, 1.0))
        .collect();
    Ok((beta, stats))
}

/// The Dirichlet side of each vertex of `R` from its neighbours outside `R`: 1 next to
/// `W1 \ R` only, 0 next to `W2 \ R` only, free otherwise. A shared region without a border
/// toward one side has no partition of unity.
fn dirichlet_sides(
    adjacency: &[Vec<u32>],
    w1: &[bool],
    w2: &[bool],
    stats: &mut PartitionStats,
) -> Result<Vec<Option<f64>>, SelfContactError> {
    let n = adjacency.len();
    let mut fixed: Vec<Option<f64>> = vec![None; n];
    for v in (0..n).filter(|&v| w1[v] && w2[v]) {
        let near = |a: &[bool], b: &[bool]| {
            adjacency[v]
                .iter()
                .any(|&u| a[u as usize] && !b[u as usize])
        };
        match (near(w1, w2), near(w2, w1)) {
            (true, false) => {
                fixed[v] = Some(1.0);
                stats.dirichlet_one += 1;
            }
            (false, true) => {
                fixed[v] = Some(0.0);
                stats.dirichlet_zero += 1;
            }
            (true, true) => stats.touching_both += 1,
            (false, false) => {}
        }
    }
    for (count, missing) in [
        (stats.dirichlet_one, BorderSide::W1),
        (stats.dirichlet_zero, BorderSide::W2),
    ] {
        if count == 0 {
            return Err(SelfContactError::DegenerateSharedRegion {
                pair: UNNAMED_PAIR.to_owned(),
                shared: stats.shared,
                missing,
            });
        }
    }
    Ok(fixed)
}

/// Orphans (vertices of `R` on no face of `R`) take the mean of their assigned neighbours,
/// ring by ring; those cut off from every assigned vertex take 0.5. Returns their number.
fn fill_orphans(adjacency: &[Vec<u32>], beta: &mut [Option<f64>]) -> usize {
    let mut pending: Vec<usize> = (0..beta.len()).filter(|&v| beta[v].is_none()).collect();
    let orphans = pending.len();
    while !pending.is_empty() {
        let before = pending.len();
        let mut still = Vec::new();
        for v in pending {
            let known: Vec<f64> = adjacency[v]
                .iter()
                .filter_map(|&u| beta[u as usize])
                .collect();
            if known.is_empty() {
                still.push(v);
            } else {
                beta[v] = Some(known.iter().sum::<f64>() / known.len() as f64);
            }
        }
        if still.len() == before {
            // Isolated from every assigned vertex: no information, take the midpoint.
            for &v in &still {
                beta[v] = Some(0.5);
            }
            break;
        }
        pending = still;
    }
    orphans
}

/// Harmonic interpolation of the Dirichlet values over `region` (cotangent stiffness at the
/// rest positions, natural Neumann elsewhere): `(mesh vertex, clamped β)` per local vertex.
fn solve_harmonic(
    region: Region,
    positions_rest: &[Point3<f64>],
    fixed: &[Option<f64>],
    stats: &mut PartitionStats,
) -> Result<Vec<(u32, f64)>, SelfContactError> {
    let local_positions = region.gather(positions_rest);
    let mut dirichlet = Vec::new();
    let mut values = Vec::new();
    for (local, &v) in region.vertices.iter().enumerate() {
        if let Some(x) = fixed[v as usize] {
            dirichlet.push(local as u32);
            values.push(x);
        }
    }
    let boundary = Boundary::vertices(region.vertex_count(), dirichlet);
    let solver = RegionSolver::new(region).map_err(|source| SelfContactError::Solve {
        pair: UNNAMED_PAIR.to_owned(),
        source,
    })?;
    let heat = |source| SelfContactError::Heat {
        pair: UNNAMED_PAIR.to_owned(),
        source,
    };
    let mut problem = solver.problem(&local_positions, &boundary).map_err(heat)?;
    let unreached = problem.unreached().iter().filter(|&&u| u).count();
    if unreached > 0 {
        return Err(SelfContactError::UnreachedSharedRegion {
            pair: UNNAMED_PAIR.to_owned(),
            vertices: unreached,
        });
    }
    let x = problem.harmonic(&values).map_err(heat)?;
    let mut out = Vec::with_capacity(x.len());
    for (local, &value) in x.iter().enumerate() {
        if !value.is_finite() {
            return Err(SelfContactError::Heat {
                pair: UNNAMED_PAIR.to_owned(),
                source: crate::heat::HeatError::Internal("non-finite harmonic value"),
            });
        }
        stats.raw_min = stats.raw_min.min(value);
        stats.raw_max = stats.raw_max.max(value);
        out.push((solver.region.vertices[local], value.clamp(0.0, 1.0)));
    }
    Ok(out)
}

/// Connected parts of `region` and how many of them carry a single Dirichlet value.
fn component_counts(region: &Region, fixed: &[Option<f64>]) -> (usize, usize) {
    let m = region.vertex_count();
    let adjacency = region.adjacency();
    let mut seen = vec![false; m];
    let (mut components, mut one_sided) = (0, 0);
    for start in 0..m {
        if seen[start] {
            continue;
        }
        components += 1;
        let (mut has_one, mut has_zero) = (false, false);
        let mut stack = vec![start as u32];
        seen[start] = true;
        while let Some(v) = stack.pop() {
            match fixed[region.vertices[v as usize] as usize] {
                Some(x) if x > 0.5 => has_one = true,
                Some(_) => has_zero = true,
                None => {}
            }
            for &u in &adjacency[v as usize] {
                if !std::mem::replace(&mut seen[u as usize], true) {
                    stack.push(u);
                }
            }
        }
        if has_one != has_zero {
            one_sided += 1;
        }
    }
    (components, one_sided)
}

/// Sorted, deduplicated neighbors of every vertex over the edges of `triangles`.
pub(crate) fn vertex_adjacency(
    n: usize,
    triangles: &[[u32; 3]],
) -> Result<Vec<Vec<u32>>, SelfContactError> {
    let mut adjacency: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (f, t) in triangles.iter().enumerate() {
        if let Some(&bad) = t.iter().find(|&&v| v as usize >= n) {
            return Err(SelfContactError::InconsistentInput(format!(
                "triangle {f} uses vertex {bad} of {n}"
            )));
        }
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if a != b {
                adjacency[a as usize].push(b);
                adjacency[b as usize].push(a);
            }
        }
    }
    for list in &mut adjacency {
        list.sort_unstable();
        list.dedup();
    }
    Ok(adjacency)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat strip of `cols × rows` quads along x, unit spacing.
    fn strip(cols: usize, rows: usize) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for j in 0..=rows {
            for i in 0..=cols {
                p.push(Point3::new(i as f64, j as f64, 0.0));
            }
        }
        let id = |i: usize, j: usize| (j * (cols + 1) + i) as u32;
        let mut t = Vec::new();
        for j in 0..rows {
            for i in 0..cols {
                t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        (p, t)
    }

    #[test]
    fn linear_ramp_across_a_flat_strip() {
        // W1: x ≤ 6, W2: x ≥ 2: R = 2 ≤ x ≤ 6, β = (6 - x) / 4 exactly (linear is harmonic,
        // Neumann on the strip's open long sides).
        let (p, t) = strip(8, 3);
        let w1: Vec<bool> = p.iter().map(|q| q.x <= 6.0).collect();
        let w2: Vec<bool> = p.iter().map(|q| q.x >= 2.0).collect();
        let (beta, stats) =
            partition_of_unity_with_stats(&p, &t, &w1, &w2).expect("non-degenerate");
        for (q, b) in p.iter().zip(&beta) {
            let expected = ((6.0 - q.x) / 4.0).clamp(0.0, 1.0);
            assert!(
                (b - expected).abs() < 1e-9,
                "x = {}: {b} vs {expected}",
                q.x
            );
        }
        assert_eq!(stats.dirichlet_one, 4);
        assert_eq!(stats.dirichlet_zero, 4);
        assert_eq!(stats.components, 1);
    }

    #[test]
    fn one_sided_region_is_a_typed_error() {
        // W2 covers everything: no vertex of W1 \ R, so no β = 1 border.
        let (p, t) = strip(4, 2);
        let w1: Vec<bool> = p.iter().map(|q| q.x <= 2.0).collect();
        let w2 = vec![true; p.len()];
        match partition_of_unity(&p, &t, &w1, &w2) {
            Err(SelfContactError::DegenerateSharedRegion { missing, .. }) => {
                assert_eq!(missing, BorderSide::W1)
            }
            other => panic!("expected a degenerate region, got {other:?}"),
        }
        assert!(matches!(
            partition_of_unity(&p, &t, &w1[..3], &w2),
            Err(SelfContactError::InconsistentInput(_))
        ));
    }
}
