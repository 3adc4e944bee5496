//! Mapping regions and the farthest-hit mapping (2021 Sec. 4.2; Algorithm 1 lines 6-16).
//!
//! For side `l` of a contact with cast direction `m̂_l` (`PIPELINE.md`: `m̂_l = -d̄_l`, rays for
//! `l`'s vertices go along `m̂_l`, `l` is front-facing where `n·m̂_l ≤ 0`):
//! 1. `B_l`: the front-facing vertices of the intersection region `I_l`;
//! 2. `P_l(B_k)`: the other side's interpolated contours (Hertzmann & Zorin 2000) inside `I_k`
//!    are extruded along the (shared) mapping axis; every front-facing edge of `l` crossing an
//!    extruded quad tags its ends inside or outside, and the inside tags are propagated over
//!    front-facing vertices without crossing a quad. All rays are parallel, so the extrusion
//!    test is exact in the plane orthogonal to the axis;
//! 3. `M_l = B_l ∪ P_l(B_k)`: every vertex of `M_l` is matched with the farthest hit of its ray
//!    on the other surface.
//!
//! Propagation also stops at vertices whose ray finds no hit (a vertex of `M_l` must be
//! mappable); [`MappingStats::misses`] counts them.
//!
//! Two parts of one mesh (a self-contact, 2021 Sec. 6) share the vertices of the crease cut: such
//! a *seam* vertex lies on both surfaces. Where it faces the other part and its ray's farthest
//! hit is the vertex itself (its own incident face of the other part, at distance 0), it is a
//! point of the contact surface at depth 0, and it joins `M_l` whether or not the propagation
//! reaches it (`add_seams`; not in the paper, which does not cut a mesh in two). Before
//! 2026-12-03 only the propagation decided, and whether it leaked round the cut ring from the
//! walls flipped from frame to frame: 20-30 zero-depth samples came and went, Eq. 4's threshold
//! jumped by 0.4-0.5 h, and the output popped (the bending capsule at 76 frames, ratio 5.42 →
//! 3.93 with the seams; measured in `README.md`).

use crate::intersect::{FrontSide, IntersectionRegion, PosedMesh, Ray, RayHit, Silhouette};
use nalgebra::{Point3, Vector2, Vector3};
use std::collections::{HashMap, VecDeque};

/// One side of a contact in the current frame.
#[derive(Clone, Copy, Debug)]
pub struct SideFrame<'m, 'a> {
    /// The surface (positions, triangles, BVH).
    pub mesh: &'m PosedMesh<'a>,
    /// Unit vertex normals.
    pub normals: &'m [Vector3<f64>],
    /// Per face: whether a ray of the other side may land on it (all faces for `None`). The
    /// self-contact pass restricts the rays to the neighbourhood of the side's intersection
    /// region (see `contact::resolve_self_pair`).
    pub hittable: Option<&'m [bool]>,
}

impl SideFrame<'_, '_> {
    /// The farthest hit of `ray` on this side's hittable faces.
    pub fn farthest_hit(&self, ray: &Ray) -> Option<RayHit> {
        crate::intersect::farthest_hit_among(self.mesh, ray, self.hittable)
    }
}

/// Where a point of one surface lands on the other: `p''` of Algorithm 1 line 16.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mapping {
    /// The farthest hit on the other surface.
    pub target: Point3<f64>,
    /// Unit interpolated normal of the other surface at the target.
    pub target_normal: Vector3<f64>,
}

/// A point where an extruded contour quad of the other side crosses an edge of this side: a
/// boundary point of `P_l(B_k)`, mapped onto the contour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallPoint {
    /// Parameter from the edge's first vertex (`edge[0] < edge[1]`).
    pub t: f64,
    /// Its mapping: the contour point of the other side.
    pub mapping: Mapping,
}

/// Counters of a mapping-region computation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MappingStats {
    /// Vertices of `B_l`.
    pub front_inside: usize,
    /// Vertices added by the projected region `P_l(B_k)`.
    pub projected: usize,
    /// Contour segments of the other side extruded.
    pub contour_segments: usize,
    /// Edge-quad crossings, those of one edge closer than 1e-9 of its length merged.
    pub wall_crossings: usize,
    /// Rays cast.
    pub rays: usize,
    /// Candidate vertices whose ray found no hit (left out of `M_l`).
    pub misses: usize,
    /// Seam vertices of a self-contact added to `M_l` beyond the propagation's
    /// (see the module's doc).
    pub seams: usize,
}

/// The mapping region `M_l` of one side and the mapping of its vertices.
#[derive(Clone, Debug, Default)]
pub struct MappingRegion {
    /// Per vertex of the mesh: its mapping when it belongs to `M_l`.
    pub mapped: Vec<Option<Mapping>>,
    /// The vertices of `M_l`, sorted.
    pub members: Vec<u32>,
    /// Quad crossings per edge `[a, b]` (`a < b`), sorted by `t`.
    pub walls: HashMap<[u32; 2], Vec<WallPoint>>,
    /// Counters.
    pub stats: MappingStats,
}

/// Computes `M_l` for side `own` (cast direction `cast`, intersection region flags
/// `own_inside`) against `other` (its intersection region `other_region`). `reach` bounds ray
/// lengths (a length larger than both surfaces). `seams`: the two sides are parts of one mesh
/// (vertex ids shared), whose seam vertices join `M_l` (see the module's doc).
pub fn mapping_region(
    own: SideFrame,
    other: SideFrame,
    own_inside: &[bool],
    other_region: &IntersectionRegion,
    cast: &Vector3<f64>,
    reach: f64,
    seams: bool,
) -> MappingRegion {
    let index = own.mesh.index();
    let n = own.mesh.positions().len();
    let front: Vec<bool> = (0..n)
        .map(|v| index.uses_vertex(v as u32) && own.normals[v].dot(cast) <= 0.0)
        .collect();
    let mut region = MappingRegion {
        mapped: vec![None; n],
        ..Default::default()
    };
    let seeds: Vec<u32> = (0..n as u32)
        .filter(|&v| front[v as usize] && own_inside.get(v as usize) == Some(&true))
        .collect();
    let hits = cast_from(own, other, &seeds, cast, reach);
    region.stats.rays += seeds.len();
    for (&v, hit) in seeds.iter().zip(hits) {
        match hit {
            Some(h) => {
                region.mapped[v as usize] = Some(mapping_of(other, &h));
                region.stats.front_inside += 1;
            }
            None => region.stats.misses += 1,
        }
    }
    let walls = Walls::new(other, other_region, cast);
    region.stats.contour_segments = walls.segments.len();
    if !walls.segments.is_empty() {
        let tags = walls.crossings(own, &mut region);
        propagate(own, other, &front, &tags, cast, reach, &mut region);
    }
    if seams {
        add_seams(own, other, &front, cast, reach, &mut region);
    }
    region.members = (0..n as u32)
        .filter(|&v| region.mapped[v as usize].is_some())
        .collect();
    region
}

/// The farthest hits on `other` of the rays of `vertices` along `cast` (in parallel).
fn cast_from(
    own: SideFrame,
    other: SideFrame,
    vertices: &[u32],
    cast: &Vector3<f64>,
    reach: f64,
) -> Vec<Option<RayHit>> {
    let rays: Vec<Ray> = vertices
        .iter()
        .map(|&v| ray_from(own, v, cast, reach))
        .collect();
    crate::intersect::farthest_hits_among(other.mesh, &rays, other.hittable)
}

/// The ray of vertex `v` along `cast`.
fn ray_from(own: SideFrame, v: u32, cast: &Vector3<f64>, reach: f64) -> Ray {
    Ray::new(own.mesh.positions()[v as usize], *cast, reach)
}

/// The mapping given by a ray hit on `other`.
pub fn mapping_of(other: SideFrame, hit: &RayHit) -> Mapping {
    Mapping {
        target: hit.point,
        target_normal: interpolated_normal(other, hit.face, hit.bary),
    }
}

/// Unit linear interpolation of vertex normals inside a face (zero if they cancel).
pub fn interpolated_normal(side: SideFrame, face: u32, bary: [f64; 3]) -> Vector3<f64> {
    let t = side.mesh.triangles()[face as usize];
    let n = (0..3).fold(Vector3::zeros(), |acc, k| {
        acc + side.normals[t[k] as usize] * bary[k]
    });
    n.try_normalize(1e-12).unwrap_or_else(Vector3::zeros)
}

/// Maps an arbitrary point of `own` (e.g. a point on an edge) by casting its ray, which lands
/// only on `other`'s hittable faces, as the vertices' rays do.
pub fn map_point(
    other: SideFrame,
    point: &Point3<f64>,
    cast: &Vector3<f64>,
    reach: f64,
) -> Option<Mapping> {
    other
        .farthest_hit(&Ray::new(*point, *cast, reach))
        .map(|h| mapping_of(other, &h))
}

/// One extruded contour segment of the other side, projected on the plane orthogonal to the
/// mapping axis.
struct WallSegment {
    ends: [Vector2<f64>; 2],
    /// Sign of `cross(end - start, x - start)` for points `x` on the inside (front) side.
    inside_sign: f64,
    points: [Point3<f64>; 2],
    normals: [Vector3<f64>; 2],
}

/// The extruded contour quads of the other side (Algorithm 1 lines 8-10).
struct Walls {
    basis: [Vector3<f64>; 2],
    segments: Vec<WallSegment>,
    lo: Vector2<f64>,
    hi: Vector2<f64>,
}

impl Walls {
    fn new(other: SideFrame, other_region: &IntersectionRegion, cast: &Vector3<f64>) -> Self {
        let basis = orthonormal_basis(cast);
        let mut faces: Vec<u32> = other_region.whole_faces.clone();
        faces.extend(other_region.cut_faces.iter().map(|c| c.face));
        let positions = other.mesh.positions();
        let tris = other.mesh.triangles();
        // The other side is cast along -cast: its front is n·(-cast) ≤ 0.
        let sil = Silhouette::compute_on_faces(
            positions,
            tris,
            other.normals,
            &(-cast),
            FrontSide::NonPositive,
            &faces,
        )
        .unwrap_or_default();
        let project =
            |p: &Point3<f64>| Vector2::new(p.coords.dot(&basis[0]), p.coords.dot(&basis[1]));
        let mut segments = Vec::new();
        for s in &sil.segments {
            let [c0, c1] = s.points.map(|k| sil.points[k as usize]);
            let ends = [project(&c0.point), project(&c1.point)];
            let dir = ends[1] - ends[0];
            let t = tris[s.face as usize];
            let front_corner = t
                .iter()
                .find(|&&v| other.normals[v as usize].dot(cast) >= 0.0)
                .map(|&v| project(&positions[v as usize]));
            let Some(corner) = front_corner else { continue };
            let side = cross2(&dir, &(corner - ends[0]));
            if side == 0.0 || dir.norm_squared() == 0.0 {
                continue;
            }
            let normal_at = |c: &crate::intersect::ContourPoint| {
                let (a, b) = (c.edge[0] as usize, c.edge[1] as usize);
                (other.normals[a] * (1.0 - c.t) + other.normals[b] * c.t)
                    .try_normalize(1e-12)
                    .unwrap_or_else(Vector3::zeros)
            };
            segments.push(WallSegment {
                ends,
                inside_sign: side.signum(),
                points: [c0.point, c1.point],
                normals: [normal_at(&c0), normal_at(&c1)],
            });
        }
        let (mut lo, mut hi) = (
            Vector2::repeat(f64::INFINITY),
            Vector2::repeat(f64::NEG_INFINITY),
        );
        for s in &segments {
            for e in &s.ends {
                lo = lo.inf(e);
                hi = hi.sup(e);
            }
        }
        Self {
            basis,
            segments,
            lo,
            hi,
        }
    }

    fn project(&self, p: &Point3<f64>) -> Vector2<f64> {
        Vector2::new(p.coords.dot(&self.basis[0]), p.coords.dot(&self.basis[1]))
    }

    /// Lines 11-12: tags the ends of front-facing edges crossing a quad; records the crossings.
    /// Returns per vertex: `Some(true)` inside, `Some(false)` outside (outside wins).
    fn crossings(&self, own: SideFrame, region: &mut MappingRegion) -> Vec<Option<bool>> {
        let positions = own.mesh.positions();
        let axis = self.normal_axis();
        let mut tags: Vec<Option<bool>> = vec![None; positions.len()];
        for &[a, b] in own.mesh.index().edges() {
            let (pa, pb) = (
                self.project(&positions[a as usize]),
                self.project(&positions[b as usize]),
            );
            if pa.sup(&pb).x < self.lo.x
                || pa.sup(&pb).y < self.lo.y
                || pa.inf(&pb).x > self.hi.x
                || pa.inf(&pb).y > self.hi.y
            {
                continue;
            }
            // Only front-facing edges: g(t) = n(t)·m̂ ≤ 0 at the crossing.
            let (ga, gb) = (
                own.normals[a as usize].dot(&axis),
                own.normals[b as usize].dot(&axis),
            );
            for seg in &self.segments {
                let Some((t, s)) = segment_crossing(&pa, &pb, &seg.ends[0], &seg.ends[1]) else {
                    continue;
                };
                if ga * (1.0 - t) + gb * t > FRONT_TOLERANCE {
                    continue;
                }
                let dir = seg.ends[1] - seg.ends[0];
                for (v, p) in [(a, pa), (b, pb)] {
                    let inside = cross2(&dir, &(p - seg.ends[0])) * seg.inside_sign > 0.0;
                    let tag = &mut tags[v as usize];
                    *tag = Some(tag.unwrap_or(true) && inside);
                }
                let target = seg.points[0] + (seg.points[1] - seg.points[0]) * s;
                let normal = (seg.normals[0] * (1.0 - s) + seg.normals[1] * s)
                    .try_normalize(1e-12)
                    .unwrap_or_else(Vector3::zeros);
                region.walls.entry([a, b]).or_default().push(WallPoint {
                    t,
                    mapping: Mapping {
                        target,
                        target_normal: normal,
                    },
                });
            }
        }
        for w in region.walls.values_mut() {
            w.sort_by(|x, y| x.t.total_cmp(&y.t));
            w.dedup_by(|later, kept| later.t - kept.t <= PARAMETER_TOLERANCE);
            region.stats.wall_crossings += w.len();
        }
        tags
    }

    /// The mapping axis (unit, the cast direction of the own side), from the basis.
    fn normal_axis(&self) -> Vector3<f64> {
        self.basis[0].cross(&self.basis[1])
    }
}

/// Line 13: propagates the inside tags over front-facing vertices, across edges that cross no
/// quad, mapping every vertex reached.
fn propagate(
    own: SideFrame,
    other: SideFrame,
    front: &[bool],
    tags: &[Option<bool>],
    cast: &Vector3<f64>,
    reach: f64,
    region: &mut MappingRegion,
) {
    let index = own.mesh.index();
    let mut visited = vec![false; tags.len()];
    let mut queue: VecDeque<u32> = (0..tags.len() as u32)
        .filter(|&v| tags[v as usize] == Some(true) && front[v as usize])
        .collect();
    for &v in &queue {
        visited[v as usize] = true;
    }
    while let Some(v) = queue.pop_front() {
        if region.mapped[v as usize].is_none() {
            region.stats.rays += 1;
            match other.farthest_hit(&ray_from(own, v, cast, reach)) {
                Some(h) => {
                    region.mapped[v as usize] = Some(mapping_of(other, &h));
                    region.stats.projected += 1;
                }
                None => {
                    region.stats.misses += 1;
                    continue;
                }
            }
        }
        for &e in index.vertex_edges(v) {
            let edge = index.edges()[e as usize];
            let w = if edge[0] == v { edge[1] } else { edge[0] };
            let wi = w as usize;
            if visited[wi]
                || !front[wi]
                || tags[wi] == Some(false)
                || region.walls.contains_key(&edge)
            {
                continue;
            }
            visited[wi] = true;
            queue.push_back(w);
        }
    }
}

/// Adds to `M_l` the seam vertices of two parts of one mesh: front-facing vertices of `own`
/// that `other` uses too (the crease cut's), whose ray's farthest hit on `other` is at the
/// vertex itself (at most [`SEAM_DISTANCE`] of `reach` away). A seam vertex whose ray goes on
/// through the other part is inside it: the intersection region's seeds and the propagation
/// decide for it, as for any vertex.
fn add_seams(
    own: SideFrame,
    other: SideFrame,
    front: &[bool],
    cast: &Vector3<f64>,
    reach: f64,
    region: &mut MappingRegion,
) {
    let shared = other.mesh.index();
    let candidates: Vec<u32> = (0..front.len() as u32)
        .filter(|&v| {
            front[v as usize] && region.mapped[v as usize].is_none() && shared.uses_vertex(v)
        })
        .collect();
    region.stats.rays += candidates.len();
    for (&v, hit) in candidates
        .iter()
        .zip(cast_from(own, other, &candidates, cast, reach))
    {
        if let Some(hit) = hit.filter(|h| h.t <= SEAM_DISTANCE * reach) {
            region.mapped[v as usize] = Some(mapping_of(other, &hit));
            region.stats.seams += 1;
        }
    }
}

/// How far (a fraction of the ray reach) a seam vertex's farthest hit may lie from the vertex:
/// round-off of a hit at distance 0 on a face the vertex is a corner of.
const SEAM_DISTANCE: f64 = 1e-12;

/// Two unit vectors completing `axis` to a right-handed orthonormal frame.
pub fn orthonormal_basis(axis: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let a = axis.normalize();
    let helper = if a.x.abs() < 0.6 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = (helper - a * a.dot(&helper)).normalize();
    let e2 = a.cross(&e1);
    [e1, e2]
}

fn cross2(a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

/// How far past its ends a segment still counts as crossed, as a fraction of its length. A
/// contour point of the other side may lie on an edge of this side (in a self-contact the two
/// truncated parts share the cut's vertices, and near the cut the contour runs along shared
/// edges), and an edge through a contour point crosses both segments that meet there, at their
/// ends: without a tolerance, round-off decided whether that crossing counted once, twice or
/// not at all, so the mirror image of a fold had other walls (the crossing at a segment's start
/// is at its end once the winding is reversed). With it, both segments count and the crossings
/// of one edge closer than this are merged (one wall point per place: the boundary samples take
/// the nearest, the propagation only asks whether the edge is a wall).
const PARAMETER_TOLERANCE: f64 = 1e-9;

/// How far above 0 a crossing's `n·m̂` still counts as front-facing: on a contour `n·m̂` is 0,
/// and its sign at a crossing there was round-off (the same case as [`PARAMETER_TOLERANCE`]).
const FRONT_TOLERANCE: f64 = 1e-9;

/// Crossing of segments `p0 p1` and `q0 q1`, ends included up to [`PARAMETER_TOLERANCE`]:
/// parameters `(t, s)` along each, clamped to `[0, 1]`.
fn segment_crossing(
    p0: &Vector2<f64>,
    p1: &Vector2<f64>,
    q0: &Vector2<f64>,
    q1: &Vector2<f64>,
) -> Option<(f64, f64)> {
    let (r, s) = (p1 - p0, q1 - q0);
    let denom = cross2(&r, &s);
    if denom == 0.0 {
        return None;
    }
    let qp = q0 - p0;
    let t = cross2(&qp, &s) / denom;
    let u = cross2(&qp, &r) / denom;
    let range = -PARAMETER_TOLERANCE..=1.0 + PARAMETER_TOLERANCE;
    (range.contains(&t) && range.contains(&u)).then_some((t.clamp(0.0, 1.0), u.clamp(0.0, 1.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An edge through the point where two contour segments meet crosses both, whichever way
    /// the segments run and on whichever side of the point round-off puts it; a miss by more
    /// than the tolerance stays a miss.
    #[test]
    fn a_crossing_at_a_contour_point_counts_for_both_segments() {
        let v = Vector2::new;
        let (a, b, c) = (v(0.0, 0.0), v(1.0, 0.0), v(2.0, 1.0));
        for x in [1.0, 1.0 + 1e-13, 1.0 - 1e-13] {
            let (p0, p1) = (v(x, -1.0), v(x, 1.0));
            for (q0, q1, end) in [(a, b, 1.0), (b, a, 0.0), (b, c, 0.0), (c, b, 1.0)] {
                let (t, s) = segment_crossing(&p0, &p1, &q0, &q1).expect("crossing");
                assert!(
                    (t - 0.5).abs() < 1e-9 && (s - end).abs() < 1e-9,
                    "{x}: {t} {s}"
                );
            }
        }
        let (p0, p1) = (v(1.0 + 1e-6, -1.0), v(1.0 + 1e-6, 1.0));
        assert!(segment_crossing(&p0, &p1, &a, &b).is_none());
    }

    /// Two parts of one mesh meeting at a seam (the edge `x = z = 0`): part A in the plane
    /// `z = 0` facing `+z` and cast along `-z`, part B leaning away below it (the plane
    /// `x = z`, `x ≤ 0`). A's seam vertices are on B, the rest of A above nothing: with no
    /// intersection region and no wall, only the seam rule maps them, onto themselves (depth
    /// 0), and A's other vertices stay out; two separate surfaces have no seam.
    #[test]
    fn seam_vertices_of_one_mesh_join_the_mapping_region_at_depth_zero() {
        use crate::intersect::{IntersectionRegion, MeshIndex, RegionStats, Side};
        let (positions, triangles) = crate::contact::fixtures::folded_square();
        let [a, b] =
            MeshIndex::self_contact_parts(&positions, &triangles, &[1, 1, 2, 2]).expect("parts");
        let (a, b) = (
            a.pose(&positions).expect("A"),
            b.pose(&positions).expect("B"),
        );
        let normals = vec![Vector3::z(); positions.len()];
        let side = |mesh| SideFrame {
            mesh,
            normals: &normals,
            hittable: None,
        };
        let none = IntersectionRegion {
            side: Side::B,
            inside: vec![false; positions.len()],
            whole_faces: Vec::new(),
            cut_faces: Vec::new(),
            stats: RegionStats::default(),
        };
        let cast = -Vector3::z();
        let inside = vec![false; positions.len()];
        let m = mapping_region(side(&a), side(&b), &inside, &none, &cast, 10.0, true);
        assert_eq!(m.members, vec![0, 1]);
        assert_eq!(m.stats.seams, 2);
        for v in [0, 1] {
            let target = m.mapped[v].expect("mapped").target;
            assert!((target - positions[v]).norm() <= 1e-12, "{v}: {target}");
        }
        let apart = mapping_region(side(&a), side(&b), &inside, &none, &cast, 10.0, false);
        assert!(apart.members.is_empty());
        assert_eq!(apart.stats.seams, 0);
    }

    /// A point of an edge is mapped like a vertex: its ray lands only on the faces the other
    /// side lets it hit (the self-contact pass restricts them to the neighbourhood of the other
    /// part's intersection region), so the farthest hit is the farthest hittable one.
    #[test]
    fn points_of_edges_land_on_hittable_faces_only() {
        use crate::intersect::MeshIndex;
        // Two parallel squares, at z = 1 (faces 0, 1) and z = 3 (faces 2, 3).
        let mut positions = Vec::new();
        for z in [1.0, 3.0] {
            for (x, y) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                positions.push(Point3::new(x, y, z));
            }
        }
        let triangles = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
        let index = MeshIndex::new(&positions, &triangles).expect("index");
        let mesh = index.pose(&positions).expect("posed");
        let normals = vec![Vector3::z(); positions.len()];
        let near_only = [true, true, false, false];
        let (point, cast) = (Point3::new(0.1, 0.2, 0.0), Vector3::z());
        let target_z = |hittable: Option<&[bool]>| {
            let other = SideFrame {
                mesh: &mesh,
                normals: &normals,
                hittable,
            };
            map_point(other, &point, &cast, 10.0).map(|m| m.target.z)
        };
        assert_eq!(target_z(None), Some(3.0));
        assert_eq!(target_z(Some(&near_only)), Some(1.0));
        assert_eq!(target_z(Some(&[false; 4])), None);
    }
}
