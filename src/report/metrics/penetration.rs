//! Residual penetration (`MEASURING.md`): vertices nudged inward whose winding number says they
//! are inside another body or another part of their own.

use super::*;

/// Residual penetration of a scene of closed bodies (`MEASURING.md`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Penetration {
    /// Number of penetrating vertices (`flagged.len()`), counted per vertex of the array (split
    /// seam copies count separately).
    pub vertices: usize,
    /// Largest depth among them (absolute units; 0 when none).
    pub max_depth: f64,
    /// The penetrating vertices, ascending.
    pub flagged: Vec<u32>,
    /// Depth of each flagged vertex (same order as `flagged`).
    pub depths: Vec<f64>,
    /// Surface vertices that could not be evaluated: non-finite position, or missing, non-finite
    /// or zero normal. They are not counted as penetrating.
    pub skipped: usize,
}

/// Residual penetration of a scene: `scene_positions` and `scene_triangles` hold the union of
/// all closed, outward-oriented bodies (several bodies are several connected components of the
/// one array, or one body may fold onto itself); `normals` are the vertex normals (normalized
/// here); `h` is the length unit of the nudge (the rest mesh's mean edge length; when it is not
/// finite and positive, the mean edge length of the given scene is used).
///
/// **Flag.** A vertex `p` with unit normal `n` is penetrating when the generalized winding
/// number of the whole scene at `p - 0.05 h n` is at least 1.5: the nudged point lies inside
/// its own body and inside another body or another part of its own body.
///
/// **Depth.** The distance from `p` to the nearest point of the scene surface among the faces
/// that can be the penetrated surface:
/// - every face of another connected component (topology welded by exactly equal positions,
///   so split seams do not separate a body);
/// - a face of the vertex's own component that is not one of the vertex's own faces and faces
///   the vertex: its unit normal has a negative dot product with the vertex normal, as the two
///   sides of a self-contact do, and as a face folded over the vertex does; without such a
///   face, the facing condition is dropped. (Excluding the faces within 3 rings of the vertex
///   instead, as this did until the thirteenth session, made a vertex under a neighbour's face
///   folded over it, a skinning's local fold on a coarse mesh, read about the rings' radius
///   deep: CesiumMan 3.0-6.1 h for vertices 0.07-0.3 h under a face one or two rings away.)
///
/// So depths against other bodies are exact, and self-contact depths are those of the
/// opposing side of the fold; 0 when no face qualifies. On a closed mesh the depth is at most
/// the distance from the vertex, inward along its normal, to where it stops being inside
/// twice (that exit is through a face of this kind: `tests/selfcontact_samples.rs`). Where a
/// thin part's two sides lie closer than a vertex is deep (a plate a fraction of the depth
/// thick), the part's own far side is the nearer facing face and the depth is understated.
/// Only vertices used by a triangle with in-range indices are evaluated; faces with an
/// invalid corner are ignored.
pub fn residual_penetration(
    scene_positions: &[Point3<f64>],
    scene_triangles: &[[u32; 3]],
    normals: &[Vector3<f64>],
    h: f64,
) -> Penetration {
    penetration_labeled(scene_positions, scene_triangles, normals, h, None)
}

/// How many vertices of the scene are penetrating by [`residual_penetration`]'s flag (the
/// winding number at `p - 0.05 h n` at least 1.5), without their depths; `h` as there.
pub fn penetrating_count(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    normals: &[Vector3<f64>],
    h: f64,
) -> usize {
    let valid = valid_faces(positions, triangles);
    flag_penetrating(positions, triangles, normals, h, &valid)
        .flagged
        .len()
}

/// The vertices flagged in `among` (one flag per vertex; the others are not tested) that are
/// penetrating by [`penetrating_count`]'s test, queried on `winding`, a tree of the surface
/// at `positions` (any β: [`WindingNumber::with_beta`]), ascending. For a caller that keeps a
/// tree and can act on some vertices only (the self-contact pass's further sweeps).
pub fn penetrating_among(
    winding: &WindingNumber,
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    normals: &[Vector3<f64>],
    h: f64,
    among: &[bool],
) -> Vec<u32> {
    let h = given_or(h, || {
        valid_mean_edge_length(positions, triangles, &valid_faces(positions, triangles))
    });
    let (mut evaluated, _) = surface_vertices(positions, triangles, normals);
    evaluated.retain(|(v, _)| among.get(*v as usize).copied().unwrap_or(false));
    inside_when_nudged(winding, positions, &evaluated, h)
        .iter()
        .map(|(v, _)| *v)
        .collect()
}

/// `h` when finite and positive, else `mean_edge()` (computed only then).
fn given_or(h: f64, mean_edge: impl FnOnce() -> f64) -> f64 {
    if h.is_finite() && h > 0.0 {
        h
    } else {
        mean_edge()
    }
}

/// Per face: all its corners in range and finite.
fn valid_faces(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> Vec<bool> {
    triangles
        .iter()
        .map(|t| corners(positions, t).is_some())
        .collect()
}

/// The flag of [`residual_penetration`] and what its depths reuse.
struct Flags {
    winding: WindingNumber,
    /// The penetrating vertices with their unit normals.
    flagged: Vec<(u32, Vector3<f64>)>,
    /// Surface vertices not evaluated (non-finite position or normal).
    skipped: usize,
}

/// [`residual_penetration`]'s flag (`h` not finite and positive: the mean edge length of the
/// `valid` faces).
fn flag_penetrating(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    normals: &[Vector3<f64>],
    h: f64,
    valid: &[bool],
) -> Flags {
    let h = given_or(h, || valid_mean_edge_length(positions, triangles, valid));
    let (evaluated, skipped) = surface_vertices(positions, triangles, normals);
    let winding = WindingNumber::new(positions, triangles);
    let flagged = inside_when_nudged(&winding, positions, &evaluated, h);
    Flags {
        winding,
        flagged,
        skipped,
    }
}

/// [`residual_penetration`] with optional body labels per vertex (bodies are never joined).
fn penetration_labeled(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    normals: &[Vector3<f64>],
    h: f64,
    labels: Option<&[u32]>,
) -> Penetration {
    let valid = valid_faces(positions, triangles);
    let Flags {
        winding,
        flagged,
        skipped,
    } = flag_penetrating(positions, triangles, normals, h, &valid);
    if flagged.is_empty() {
        return Penetration {
            skipped,
            ..Penetration::default()
        };
    }
    let topo = Topology::new(positions, triangles, &valid, labels);
    let depths = flagged_depths(&winding, &topo, positions, triangles, &flagged);
    let max_depth = depths
        .iter()
        .copied()
        .filter(|d| d.is_finite())
        .fold(0.0, f64::max);
    Penetration {
        vertices: flagged.len(),
        max_depth,
        flagged: flagged.iter().map(|(v, _)| *v).collect(),
        depths,
        skipped,
    }
}

/// The vertices of `triangles` with a finite position and normal, with their unit normal, and
/// how many surface vertices were skipped for want of one.
fn surface_vertices(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    normals: &[Vector3<f64>],
) -> (Vec<(u32, Vector3<f64>)>, usize) {
    let nv = positions.len();
    let mut used = vec![false; nv];
    for t in triangles {
        if t.iter().all(|&i| (i as usize) < nv) {
            for &i in t {
                used[i as usize] = true;
            }
        }
    }
    let mut skipped = 0;
    let mut evaluated: Vec<(u32, Vector3<f64>)> = Vec::new();
    for (v, p) in positions.iter().enumerate() {
        if !used[v] {
            continue;
        }
        let n = normals
            .get(v)
            .filter(|n| n.iter().all(|x| x.is_finite()))
            .and_then(|n| n.try_normalize(1e-300));
        match n {
            Some(n) if finite(p) => evaluated.push((v as u32, n)),
            _ => skipped += 1,
        }
    }
    (evaluated, skipped)
}

/// The `evaluated` vertices whose point nudged inward by [`PENETRATION_NUDGE`] `h` has a
/// winding number of at least [`PENETRATION_THRESHOLD`] (inside twice).
fn inside_when_nudged(
    winding: &WindingNumber,
    positions: &[Point3<f64>],
    evaluated: &[(u32, Vector3<f64>)],
    h: f64,
) -> Vec<(u32, Vector3<f64>)> {
    let nudged: Vec<Point3<f64>> = evaluated
        .iter()
        .map(|(v, n)| positions[*v as usize] - n * (PENETRATION_NUDGE * h))
        .collect();
    let w = winding.query_many(&nudged);
    evaluated
        .iter()
        .zip(&w)
        .filter(|(_, &w)| w >= PENETRATION_THRESHOLD)
        .map(|(e, _)| *e)
        .collect()
}

/// Depth of each `flagged` vertex: its distance to the nearest face of another component, or of
/// its own component, not incident to it, that faces its normal (else any such face).
fn flagged_depths(
    winding: &WindingNumber,
    topo: &Topology,
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    flagged: &[(u32, Vector3<f64>)],
) -> Vec<f64> {
    let face_normals: Vec<Vector3<f64>> = triangles
        .iter()
        .map(|t| {
            corners(positions, t)
                .and_then(|c| double_area_vector(&c).try_normalize(0.0))
                .unwrap_or_else(Vector3::zeros)
        })
        .collect();
    flagged
        .par_iter()
        .map(|&(v, n)| {
            let wv = topo.welded[v as usize];
            let comp = topo.component[wv as usize];
            let near = |f: u32| topo.face_welded[f as usize].contains(&wv);
            let other = |f: u32| topo.face_component(f) != comp;
            let p = &positions[v as usize];
            winding
                .bvh
                .nearest(p, |f| {
                    other(f) || (!near(f) && face_normals[f as usize].dot(&n) < 0.0)
                })
                .or_else(|| winding.bvh.nearest(p, |f| other(f) || !near(f)))
                .map_or(0.0, |(d2, _)| d2.sqrt())
        })
        .collect()
}

/// One closed body for [`residual_penetration_bodies`]: positions, triangles, vertex normals.
pub type Body<'a> = (&'a [Point3<f64>], &'a [[u32; 3]], &'a [Vector3<f64>]);

/// [`residual_penetration`] on a list of bodies `(positions, triangles, normals)`, concatenated
/// in order: the flagged vertex ids index the concatenation (body `b`'s vertices start at the
/// sum of the vertex counts of the bodies before it). A triangle index outside its own body is
/// treated as invalid (the face is ignored).
pub fn residual_penetration_bodies(bodies: &[Body<'_>], h: f64) -> Penetration {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut normals = Vec::new();
    let mut labels: Vec<u32> = Vec::new();
    for (b, (p, t, n)) in bodies.iter().enumerate() {
        let offset = positions.len();
        let count = p.len();
        positions.extend_from_slice(p);
        labels.extend(std::iter::repeat_n(b as u32, count));
        normals.extend((0..count).map(|i| {
            n.get(i)
                .copied()
                .unwrap_or_else(|| Vector3::repeat(f64::NAN))
        }));
        triangles.extend(t.iter().map(|t| {
            t.map(|i| {
                if (i as usize) < count {
                    u32::try_from(offset + i as usize).unwrap_or(u32::MAX)
                } else {
                    u32::MAX
                }
            })
        }));
    }
    penetration_labeled(&positions, &triangles, &normals, h, Some(&labels))
}

/// Mean edge length over the valid faces (0 without any).
fn valid_mean_edge_length(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    valid: &[bool],
) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (t, _) in triangles.iter().zip(valid).filter(|(_, &v)| v) {
        for k in 0..3 {
            sum += (positions[t[k] as usize] - positions[t[(k + 1) % 3] as usize]).norm();
            n += 1;
        }
    }
    if n == 0 || !sum.is_finite() {
        0.0
    } else {
        sum / n as f64
    }
}

/// Welded connectivity of a scene (vertices merged when their positions are bitwise equal,
/// `-0.0 == 0.0`; non-finite positions are never merged).
struct Topology {
    /// Welded id of each array vertex.
    welded: Vec<u32>,
    /// Welded corners of each face.
    face_welded: Vec<[u32; 3]>,
    /// Connected component of each welded vertex (over the valid faces).
    component: Vec<u32>,
}

impl Topology {
    /// `labels` (one per vertex) keeps vertices of different bodies apart even where their
    /// positions coincide exactly (two surfaces touching at a vertex).
    fn new(
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        valid: &[bool],
        labels: Option<&[u32]>,
    ) -> Self {
        let mut map: HashMap<([u64; 3], u32), u32> = HashMap::with_capacity(positions.len());
        let mut count = 0u32;
        let welded: Vec<u32> = positions
            .iter()
            .enumerate()
            .map(|(i, p)| {
                if !finite(p) {
                    count += 1;
                    return count - 1;
                }
                let label = labels.and_then(|l| l.get(i).copied()).unwrap_or(0);
                let key = ([p.x, p.y, p.z].map(|x| (x + 0.0).to_bits()), label);
                *map.entry(key).or_insert_with(|| {
                    count += 1;
                    count - 1
                })
            })
            .collect();
        let face_welded: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| welded.get(i as usize).copied().unwrap_or(u32::MAX)))
            .collect();
        // Union-find for the components.
        let mut parent: Vec<u32> = (0..count).collect();
        fn find(parent: &mut [u32], mut x: u32) -> u32 {
            while parent[x as usize] != x {
                let up = parent[parent[x as usize] as usize];
                parent[x as usize] = up;
                x = up;
            }
            x
        }
        for (t, _) in face_welded.iter().zip(valid).filter(|(_, &v)| v) {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if a != b {
                    let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                    if ra != rb {
                        parent[ra.max(rb) as usize] = ra.min(rb);
                    }
                }
            }
        }
        let component: Vec<u32> = (0..count).map(|x| find(&mut parent, x)).collect();
        Self {
            welded,
            face_welded,
            component,
        }
    }

    /// Component of a face (of its first welded corner; faces in the tree are valid).
    fn face_component(&self, f: u32) -> u32 {
        let w = self.face_welded[f as usize][0];
        self.component.get(w as usize).copied().unwrap_or(u32::MAX)
    }
}

/// The length unit of the reports (`h_rest`, `MEASURING.md`): the rest pose's mean edge length
/// ([`crate::mesh::operators::mean_edge_length`]) averaged over the bodies (`rest` their
/// positions, `triangles` their surfaces); 1 (scene units) when that is not a positive finite
/// length (every rest edge collapsed, no triangle, non-finite rest positions): depths of 0 over
/// an `h` of 0 read NaN otherwise.
pub fn h_rest(rest: &[Vec<Point3<f64>>], triangles: &[&[[u32; 3]]]) -> f64 {
    let sum: f64 = (rest.iter().zip(triangles))
        .map(|(p, t)| crate::mesh::operators::mean_edge_length(p, t))
        .sum();
    let h = sum / rest.len().max(1) as f64;
    if h > 0.0 && h.is_finite() {
        h
    } else {
        1.0
    }
}

/// [`residual_penetration_bodies`] of a frame's posed bodies (`positions`, `triangles` per
/// body), their vertex normals made here: a vertex is flagged inside another body or inside
/// another part of its own body (a fold). A closed body whose positions enclose a negative
/// signed volume (turned inside out by its pose: a joint scaled by -1 in the animation) is
/// measured with its winding reversed, so that its inside is inside: read as it winds, its
/// winding number is -1 there and nothing in it counted as penetrating (the capsule pair
/// mirrored from mid-animation: 0 penetrating vertices in the frames where the capsules are
/// pressed deepest).
pub fn residual_penetration_posed(
    positions: &[Vec<Point3<f64>>],
    triangles: &[&[[u32; 3]]],
    h: f64,
) -> Penetration {
    use crate::mesh::operators::{vertex_normals, NormalWeighting};
    let outward: Vec<std::borrow::Cow<[[u32; 3]]>> = (positions.iter().zip(triangles))
        .map(|(p, &t)| outward_winding(p, t))
        .collect();
    let normals: Vec<Vec<Vector3<f64>>> = (positions.iter().zip(&outward))
        .map(|(p, t)| vertex_normals(p, t, NormalWeighting::Area))
        .collect();
    let bodies: Vec<Body> = (positions.iter().zip(&outward).zip(&normals))
        .map(|((p, t), n)| (p.as_slice(), t.as_ref(), n.as_slice()))
        .collect();
    residual_penetration_bodies(&bodies, h)
}

/// `triangles` reversed when they close a surface that `positions` turn inside out (a negative
/// signed volume), else as they are.
fn outward_winding<'t>(
    positions: &[Point3<f64>],
    triangles: &'t [[u32; 3]],
) -> std::borrow::Cow<'t, [[u32; 3]]> {
    let indexed = triangles
        .iter()
        .flatten()
        .all(|&v| (v as usize) < positions.len());
    // The sign first: the closedness test sorts the edges, and only a negative volume asks it.
    let inside_out = indexed
        && crate::mesh::signed_volume(positions, triangles) < 0.0
        && crate::mesh::closed_and_oriented(triangles);
    if inside_out {
        std::borrow::Cow::Owned(triangles.iter().map(|&[a, b, c]| [a, c, b]).collect())
    } else {
        std::borrow::Cow::Borrowed(triangles)
    }
}
