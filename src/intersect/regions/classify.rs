//! The inside/outside status of the vertices of a surface against the other body (2021 Sec. 4,
//! Algorithm 1 line 3): from the crossing signs at the edges the intersection curves cut, then
//! flood-filled across the uncut edges.

use super::RegionStats;
use crate::intersect::index::{MeshIndex, PosedMesh};
use crate::intersect::mesh_mesh::{EdgeHit, Intersections, Side};

/// Inside flags per vertex: crossing signs at the cut edges vote (and the corners of faces
/// crossed only by closed loops, see `FaceClip::corner_vote`), uncut edges propagate. Only
/// components holding an inside vote are walked (cost in the size of the region).
pub(super) fn classify_vertices(
    ints: &Intersections,
    side: Side,
    mesh: &PosedMesh,
    loop_votes: &[(u32, bool)],
    complement: bool,
    stats: &mut RegionStats,
) -> Vec<bool> {
    let index = mesh.index();
    let n = index.vertex_count();
    let mut votes = vec![[0u32; 2]; n]; // [outside, inside]
    let mut cut = vec![false; index.edges().len()];
    let mut seeds = Vec::new();
    let hits: Vec<&EdgeHit> = ints.hits.iter().filter(|h| h.side == side).collect();
    for group in hits.chunk_by(|x, y| x.edge == y.edge) {
        let edge = group[0].edge;
        if let Some(e) = index.edge_id(edge[0], edge[1]) {
            cut[e as usize] = true;
        }
        let status = endpoint_status(group);
        for (v, inside) in edge.into_iter().zip(status) {
            votes[v as usize][inside as usize] += 1;
            if inside {
                seeds.push(v);
            }
        }
    }
    // Faces crossed only by closed loops: the outermost loop's orientation tells their corners.
    for &(f, is_in) in loop_votes {
        for v in mesh.triangles()[f as usize] {
            votes[v as usize][is_in as usize] += 1;
            if is_in {
                seeds.push(v);
            }
        }
    }
    let mut inside = vec![false; n];
    let mut seen = vec![false; n];
    for seed in seeds {
        if seen[seed as usize] {
            continue;
        }
        let component = flood(index, seed, &cut, &mut seen);
        let total = component.iter().fold([0u32; 2], |acc, &v| {
            let c = votes[v as usize];
            [acc[0] + c[0], acc[1] + c[1]]
        });
        if total[0] > 0 && total[1] > 0 {
            stats.conflicting_components += 1;
        }
        if total[1] > total[0] {
            for v in component {
                inside[v as usize] = true;
            }
        }
    }
    if complement {
        for (v, x) in inside.iter_mut().enumerate() {
            *x = !*x && index.uses_vertex(v as u32);
        }
    }
    inside
}

/// The vertices reachable from `seed` across uncut edges (marking them seen).
fn flood(index: &MeshIndex, seed: u32, cut: &[bool], seen: &mut [bool]) -> Vec<u32> {
    let mut component = vec![seed];
    seen[seed as usize] = true;
    let mut next = 0;
    while let Some(&v) = component.get(next) {
        next += 1;
        for &e in index.vertex_edges(v) {
            if cut[e as usize] {
                continue;
            }
            let [a, b] = index.edges()[e as usize];
            let w = if a == v { b } else { a };
            if !seen[w as usize] {
                seen[w as usize] = true;
                component.push(w);
            }
        }
    }
    component
}

/// Inside status of `[edge[0], edge[1]]` from the hits of one edge (all of the same edge): the
/// net count of entering minus leaving crossings decides when it is ±1 (crossings alternate
/// along an edge), else the first and last hits along the edge.
fn endpoint_status(group: &[&EdgeHit]) -> [bool; 2] {
    let net: i64 = group.iter().map(|h| if h.entering { 1 } else { -1 }).sum();
    match net {
        1 => [false, true],
        -1 => [true, false],
        _ => {
            let by_t = |x: &&&EdgeHit, y: &&&EdgeHit| x.t.total_cmp(&y.t);
            let first = group.iter().min_by(by_t).is_none_or(|h| h.entering);
            let last = group.iter().max_by(by_t).is_some_and(|h| h.entering);
            [!first, last]
        }
    }
}
