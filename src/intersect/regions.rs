//! Intersection regions `I_l` (2021 Sec. 4, Algorithm 1 line 3): the part of surface `l` inside
//! the other body, bounded exactly by the intersection curves, and area integrals over it
//! (Sec. 4.1, Eq. 2: area-weighted mean normals and total variation).
//!
//! Vertices are classified from the crossing signs at cut edges, then flood-filled across uncut
//! edges. Faces crossed by a curve are clipped along it: the inside part is traced as polygons
//! (curve chains inside the face, closed by arcs of the face boundary, the inside always on the
//! left of the oriented curve) and triangulated, so integrals of piecewise-linear data over
//! `I_l` are exact.

use super::index::{MeshIndex, PosedMesh};
use super::mesh_mesh::{EdgeHit, Intersections, Side};
use super::IntersectError;
use nalgebra::{Point3, Vector3};

/// A triangle inside one face, given by barycentric coordinates on that face and 3D corners.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubTriangle {
    /// Barycentric coordinates (on the parent face) of the three corners, counter-clockwise.
    pub bary: [[f64; 3]; 3],
    /// 3D corners.
    pub points: [Point3<f64>; 3],
}

impl SubTriangle {
    /// Area.
    pub fn area(&self) -> f64 {
        let [a, b, c] = &self.points;
        0.5 * (b - a).cross(&(c - a)).norm()
    }
}

/// The part of a face crossed by an intersection curve that lies in the region: the union of
/// `sub_triangles` minus the union of `holes` (holes only occur when a curve loop lies entirely
/// inside one face and encloses a part outside the region).
#[derive(Clone, Debug, PartialEq)]
pub struct CutFace {
    /// The face.
    pub face: u32,
    /// Triangles of the region part.
    pub sub_triangles: Vec<SubTriangle>,
    /// Triangles to subtract.
    pub holes: Vec<SubTriangle>,
}

/// Counters of inconsistencies met while building a region. All zero for two closed,
/// non-self-intersecting surfaces; open surfaces (working regions cut out of a mesh) and
/// self-contact parts can leave curves ending inside a face.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RegionStats {
    /// Flood-fill components that received both inside and outside votes (majority wins,
    /// ties go outside).
    pub conflicting_components: usize,
    /// Curve pieces inside a face that do not reach the face boundary nor close (ignored).
    pub dangling_chains: usize,
    /// Faces without a curve whose corners disagree (majority wins).
    pub mixed_uncut_faces: usize,
    /// Boundary walks that found the curve exits and entries out of order (polygon closed early).
    pub boundary_mismatches: usize,
    /// Polygons triangulated by a signed fan because ear clipping failed (integrals stay exact).
    pub fan_fallbacks: usize,
}

/// The part `I_l` of one surface inside the other body (or its complement).
#[derive(Clone, Debug, PartialEq)]
pub struct IntersectionRegion {
    /// Which surface.
    pub side: Side,
    /// Per vertex of the mesh: inside the region (false for vertices of no face of the side).
    pub inside: Vec<bool>,
    /// Faces entirely in the region, sorted.
    pub whole_faces: Vec<u32>,
    /// Faces crossed by a curve, with their part in the region, sorted by face.
    pub cut_faces: Vec<CutFace>,
    /// Inconsistencies met.
    pub stats: RegionStats,
}

/// Quadrature rules on triangles (both exact for linear data).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QuadratureRule {
    /// One point at the centroid: exact for degree 1.
    Centroid,
    /// Three points at barycentric `(2/3, 1/6, 1/6)` and permutations: exact for degree 2
    /// (the "degree two Gauss quadrature" of Sec. 4.1 for the total variation of normals).
    Degree2,
}

/// A quadrature point: a location on a face and its weight (area share; negative inside holes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadraturePoint {
    /// The face.
    pub face: u32,
    /// Barycentric coordinates on the face.
    pub bary: [f64; 3],
    /// Weight (area units).
    pub weight: f64,
}

impl QuadraturePoint {
    /// Linear interpolation of per-vertex values at this point.
    pub fn interpolate(&self, triangles: &[[u32; 3]], values: &[Vector3<f64>]) -> Vector3<f64> {
        let t = &triangles[self.face as usize];
        (0..3).fold(Vector3::zeros(), |acc, k| {
            acc + values[t[k] as usize] * self.bary[k]
        })
    }
}

impl IntersectionRegion {
    /// `I_l`: the part of surface `side` inside the other body. `mesh` is the surface `side`
    /// of the query that produced `ints`.
    pub fn inside(
        ints: &Intersections,
        side: Side,
        mesh: &PosedMesh,
    ) -> Result<Self, IntersectError> {
        check_belongs(ints, side, mesh)?;
        Ok(build(ints, side, mesh, false))
    }

    /// The complement of `I_l` on the faces of surface `side` (the part outside the other
    /// body). With [`IntersectionRegion::inside`] it tiles the surface exactly.
    pub fn outside(
        ints: &Intersections,
        side: Side,
        mesh: &PosedMesh,
    ) -> Result<Self, IntersectError> {
        check_belongs(ints, side, mesh)?;
        Ok(build(ints, side, mesh, true))
    }

    /// True when the region has no face.
    pub fn is_empty(&self) -> bool {
        self.whole_faces.is_empty() && self.cut_faces.is_empty()
    }

    /// Quadrature points covering the region (whole faces and clipped parts).
    pub fn quadrature(&self, mesh: &PosedMesh, rule: QuadratureRule) -> Vec<QuadraturePoint> {
        let mut out = Vec::new();
        for &f in &self.whole_faces {
            let unit = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            push_rule(&mut out, f, &unit, mesh.face_area(f), rule);
        }
        for c in &self.cut_faces {
            for (tris, sign) in [(&c.sub_triangles, 1.0), (&c.holes, -1.0)] {
                for st in tris {
                    push_rule(&mut out, c.face, &st.bary, sign * st.area(), rule);
                }
            }
        }
        out
    }

    /// Area of the region.
    pub fn area(&self, mesh: &PosedMesh) -> f64 {
        let whole: f64 = self.whole_faces.iter().map(|&f| mesh.face_area(f)).sum();
        let cut: f64 = self
            .cut_faces
            .iter()
            .map(|c| {
                c.sub_triangles.iter().map(SubTriangle::area).sum::<f64>()
                    - c.holes.iter().map(SubTriangle::area).sum::<f64>()
            })
            .sum();
        whole + cut
    }

    /// Integral over the region of the linear interpolation of per-vertex `values` (exact):
    /// with vertex normals this is `m_l` of Eq. 2.
    pub fn integrate_linear(
        &self,
        mesh: &PosedMesh,
        values: &[Vector3<f64>],
    ) -> Result<Vector3<f64>, IntersectError> {
        if values.len() != mesh.positions().len() {
            return Err(IntersectError::ValueCount {
                expected: mesh.positions().len(),
                got: values.len(),
            });
        }
        let tris = mesh.triangles();
        Ok(self
            .quadrature(mesh, QuadratureRule::Centroid)
            .iter()
            .fold(Vector3::zeros(), |acc, q| {
                acc + q.interpolate(tris, values) * q.weight
            }))
    }

    /// Integral of `f(face, bary)` over the region with `rule`.
    pub fn integrate(
        &self,
        mesh: &PosedMesh,
        rule: QuadratureRule,
        f: impl Fn(u32, [f64; 3]) -> f64,
    ) -> f64 {
        self.quadrature(mesh, rule)
            .iter()
            .map(|q| q.weight * f(q.face, q.bary))
            .sum()
    }
}

fn push_rule(
    out: &mut Vec<QuadraturePoint>,
    face: u32,
    corners: &[[f64; 3]; 3],
    area: f64,
    rule: QuadratureRule,
) {
    let at = |w: [f64; 3]| -> [f64; 3] {
        std::array::from_fn(|k| (0..3).map(|c| w[c] * corners[c][k]).sum())
    };
    match rule {
        QuadratureRule::Centroid => out.push(QuadraturePoint {
            face,
            bary: at([1.0 / 3.0; 3]),
            weight: area,
        }),
        QuadratureRule::Degree2 => {
            let (a, b) = (2.0 / 3.0, 1.0 / 6.0);
            for w in [[a, b, b], [b, a, b], [b, b, a]] {
                out.push(QuadraturePoint {
                    face,
                    bary: at(w),
                    weight: area / 3.0,
                });
            }
        }
    }
}

/// The ids in `ints` that refer to surface `side` are valid for `mesh`.
fn check_belongs(ints: &Intersections, side: Side, mesh: &PosedMesh) -> Result<(), IntersectError> {
    let (nv, nf, nh) = (
        mesh.index().vertex_count(),
        mesh.triangles().len(),
        ints.hits.len(),
    );
    let hits_ok = ints.hits.iter().all(|h| {
        if h.side == side {
            h.edge.iter().all(|&v| (v as usize) < nv)
        } else {
            (h.face as usize) < nf
        }
    });
    let k = if side == Side::A { 0 } else { 1 };
    let segments_ok = ints
        .segments
        .iter()
        .all(|s| (s.faces[k] as usize) < nf && s.hits.iter().all(|&h| (h as usize) < nh));
    if hits_ok && segments_ok {
        Ok(())
    } else {
        Err(IntersectError::Mismatch)
    }
}

fn build(
    ints: &Intersections,
    side: Side,
    mesh: &PosedMesh,
    complement: bool,
) -> IntersectionRegion {
    let mut stats = RegionStats::default();
    let clipper = |face| FaceClip {
        ints,
        side,
        mesh,
        face,
    };
    let by_face = segments_by_face(ints, side);
    let curves: Vec<FaceCurves> = by_face
        .chunk_by(|x, y| x.0 == y.0)
        .map(|g| {
            let segs: Vec<[u32; 2]> = g.iter().map(|x| x.1).collect();
            clipper(g[0].0).curves(&segs, &mut stats)
        })
        .collect();
    let loop_votes: Vec<(u32, bool)> = curves
        .iter()
        .filter_map(|c| clipper(c.face).corner_vote(c).map(|v| (c.face, v)))
        .collect();
    let inside = classify_vertices(ints, side, mesh, &loop_votes, complement, &mut stats);
    let mut whole_faces = Vec::new();
    let mut cut_faces = Vec::new();
    let mut pending = curves.into_iter().peekable();
    for &f in mesh.index().faces() {
        while pending.next_if(|c| c.face < f).is_some() {}
        let corners_in = mesh.triangles()[f as usize].map(|v| inside[v as usize]);
        if let Some(c) = pending.next_if(|c| c.face == f) {
            let c = if complement { c.reversed() } else { c };
            cut_faces.push(clipper(f).clip(c, corners_in, &mut stats));
            continue;
        }
        let n_in = corners_in.iter().filter(|&&x| x).count();
        if n_in == 1 || n_in == 2 {
            stats.mixed_uncut_faces += 1;
        }
        if n_in >= 2 {
            whole_faces.push(f);
        }
    }
    IntersectionRegion {
        side,
        inside,
        whole_faces,
        cut_faces,
        stats,
    }
}

/// Segments lying in faces of `side`, oriented with `I_l` on their left (seen from outside the
/// surface), as `(face, [from, to])`, sorted by face.
fn segments_by_face(ints: &Intersections, side: Side) -> Vec<(u32, [u32; 2])> {
    // Segments run along n_A × n_B: A's inside part is on their left, B's on their right.
    let reverse = side == Side::B;
    let mut v: Vec<(u32, [u32; 2])> = ints
        .segments
        .iter()
        .map(|s| {
            let face = if side == Side::A {
                s.faces[0]
            } else {
                s.faces[1]
            };
            let [h0, h1] = s.hits;
            (face, if reverse { [h1, h0] } else { [h0, h1] })
        })
        .collect();
    v.sort_unstable();
    v
}

/// Inside flags per vertex: crossing signs at the cut edges vote (and the corners of faces
/// crossed only by closed loops, see `FaceClip::corner_vote`), uncut edges propagate. Only
/// components holding an inside vote are walked (cost in the size of the region).
fn classify_vertices(
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

/// A polygon vertex inside a face.
#[derive(Clone, Copy, Debug)]
struct Node {
    bary: [f64; 3],
    point: Point3<f64>,
}

impl Node {
    fn uv(&self) -> [f64; 2] {
        [self.bary[1], self.bary[2]]
    }
}

/// A curve piece crossing a face from boundary to boundary.
struct Chain {
    hits: Vec<u32>,
    /// Boundary positions (see `FaceClip::boundary_position`) of entry and exit.
    entry: f64,
    exit: f64,
}

/// The curve pieces inside one face.
struct FaceCurves {
    face: u32,
    chains: Vec<Chain>,
    loops: Vec<Vec<u32>>,
}

impl FaceCurves {
    /// The same curves run backwards (the complement region on their left).
    fn reversed(mut self) -> Self {
        for c in &mut self.chains {
            c.hits.reverse();
            std::mem::swap(&mut c.entry, &mut c.exit);
        }
        for l in &mut self.loops {
            l.reverse();
        }
        self
    }
}

/// Clipping of one face of `side` along the curve segments in it.
struct FaceClip<'a, 'm> {
    ints: &'a Intersections,
    side: Side,
    mesh: &'a PosedMesh<'m>,
    face: u32,
}

impl FaceClip<'_, '_> {
    fn clip(&self, curves: FaceCurves, corners_in: [bool; 3], stats: &mut RegionStats) -> CutFace {
        let FaceCurves { chains, loops, .. } = curves;
        let mut polygons: Vec<Vec<Node>> = Vec::new();
        if chains.is_empty() {
            if corners_in.iter().filter(|&&x| x).count() >= 2 {
                polygons.push((0..3).map(|k| self.corner(k)).collect());
            }
        } else {
            polygons.extend(self.boundary_polygons(&chains, stats));
        }
        let mut cut = CutFace {
            face: self.face,
            sub_triangles: Vec::new(),
            holes: Vec::new(),
        };
        for poly in polygons {
            triangulate_into(&poly, &mut cut, stats);
        }
        for lp in loops {
            let mut poly: Vec<Node> = lp.iter().map(|&h| self.hit_node(h)).collect();
            if signed_area(&poly) < 0.0 {
                poly.reverse();
                let mut hole = CutFace {
                    face: self.face,
                    sub_triangles: Vec::new(),
                    holes: Vec::new(),
                };
                triangulate_into(&poly, &mut hole, stats);
                cut.holes.extend(hole.sub_triangles);
                cut.sub_triangles.extend(hole.holes);
            } else {
                triangulate_into(&poly, &mut cut, stats);
            }
        }
        cut
    }

    fn hit(&self, h: u32) -> &EdgeHit {
        &self.ints.hits[h as usize]
    }

    /// A hit on this face's boundary (an edge of this surface), rather than inside it.
    fn on_boundary(&self, h: u32) -> bool {
        self.hit(h).side == self.side
    }

    fn corner(&self, k: usize) -> Node {
        let mut bary = [0.0; 3];
        bary[k] = 1.0;
        Node {
            bary,
            point: *self.mesh.corners(self.face)[k],
        }
    }

    /// Local edge `k` of a boundary hit and its parameter along that edge, counter-clockwise.
    fn boundary_location(&self, h: u32) -> (usize, f64) {
        let hit = self.hit(h);
        let t = self.mesh.triangles()[self.face as usize];
        for k in 0..3 {
            let (u, v) = (t[k], t[(k + 1) % 3]);
            if [u.min(v), u.max(v)] == hit.edge {
                let along = if u == hit.edge[0] { hit.t } else { 1.0 - hit.t };
                return (k, along);
            }
        }
        (0, 0.0)
    }

    /// Position of a boundary hit along the face boundary, in `(0, 3)`: local edge `k` maps to
    /// `[k + η, k + 1 - η]` and corner `j` sits at `j`, so a hit at a corner (t = 0 or 1, from
    /// an exact tie) stays on its own edge's side of the corner.
    fn boundary_position(&self, h: u32) -> f64 {
        const ETA: f64 = 1.0 / (1u64 << 20) as f64;
        let (k, along) = self.boundary_location(h);
        k as f64 + ETA + along * (1.0 - 2.0 * ETA)
    }

    fn hit_node(&self, h: u32) -> Node {
        let hit = self.hit(h);
        if !self.on_boundary(h) {
            return Node {
                bary: hit.bary,
                point: hit.point,
            };
        }
        let (k, along) = self.boundary_location(h);
        let mut bary = [0.0; 3];
        bary[k] = 1.0 - along;
        bary[(k + 1) % 3] = along;
        Node {
            bary,
            point: hit.point,
        }
    }

    /// Whether the corners are in the region, when the face is crossed only by closed loops:
    /// the region is on the left of every loop, so the corners are in it iff the outermost
    /// (largest) loop runs clockwise.
    fn corner_vote(&self, curves: &FaceCurves) -> Option<bool> {
        if !curves.chains.is_empty() {
            return None;
        }
        curves
            .loops
            .iter()
            .map(|l| signed_area(&l.iter().map(|&h| self.hit_node(h)).collect::<Vec<_>>()))
            .max_by(|x, y| x.abs().total_cmp(&y.abs()))
            .map(|a| a < 0.0)
    }

    /// Splits the face's segments into boundary-to-boundary chains and closed interior loops.
    fn curves(&self, segs: &[[u32; 2]], stats: &mut RegionStats) -> FaceCurves {
        let mut used = vec![false; segs.len()];
        let next_from =
            |h: u32, used: &[bool]| (0..segs.len()).find(|&i| !used[i] && segs[i][0] == h);
        let mut chains = Vec::new();
        for start in 0..segs.len() {
            if used[start] || !self.on_boundary(segs[start][0]) {
                continue;
            }
            let mut hits = vec![segs[start][0]];
            let mut cur = start;
            let complete = loop {
                used[cur] = true;
                let to = segs[cur][1];
                hits.push(to);
                if self.on_boundary(to) {
                    break true;
                }
                match next_from(to, &used) {
                    Some(n) => cur = n,
                    None => break false,
                }
            };
            if complete {
                let entry = self.boundary_position(hits[0]);
                let exit = self.boundary_position(hits[hits.len() - 1]);
                chains.push(Chain { hits, entry, exit });
            } else {
                stats.dangling_chains += 1;
            }
        }
        let loops = self.loops(segs, &mut used, stats);
        FaceCurves {
            face: self.face,
            chains,
            loops,
        }
    }

    fn loops(
        &self,
        segs: &[[u32; 2]],
        used: &mut [bool],
        stats: &mut RegionStats,
    ) -> Vec<Vec<u32>> {
        let mut loops = Vec::new();
        for start in 0..segs.len() {
            if used[start] {
                continue;
            }
            let mut hits = vec![segs[start][0]];
            let mut cur = start;
            let closed = loop {
                used[cur] = true;
                let to = segs[cur][1];
                if to == segs[start][0] {
                    break true;
                }
                hits.push(to);
                match (0..segs.len()).find(|&i| !used[i] && segs[i][0] == to) {
                    Some(n) => cur = n,
                    None => break false,
                }
            };
            if closed && hits.len() >= 3 {
                loops.push(hits);
            } else if !closed {
                stats.dangling_chains += 1;
            }
        }
        loops
    }

    /// Polygons made of chains joined by counter-clockwise arcs of the face boundary.
    fn boundary_polygons(&self, chains: &[Chain], stats: &mut RegionStats) -> Vec<Vec<Node>> {
        let mut used = vec![false; chains.len()];
        let mut polygons = Vec::new();
        for first in 0..chains.len() {
            if used[first] {
                continue;
            }
            let mut poly = Vec::new();
            let mut cur = first;
            loop {
                used[cur] = true;
                poly.extend(chains[cur].hits.iter().map(|&h| self.hit_node(h)));
                let exit = chains[cur].exit;
                let next = next_entry(chains, exit);
                let gap = (chains[next].entry - exit).rem_euclid(3.0);
                poly.extend(corners_between(exit, gap).map(|k| self.corner(k)));
                if next == first {
                    break;
                }
                if used[next] {
                    stats.boundary_mismatches += 1;
                    break;
                }
                cur = next;
            }
            polygons.push(poly);
        }
        polygons
    }
}

/// The chain whose entry comes first counter-clockwise after boundary position `exit`.
fn next_entry(chains: &[Chain], exit: f64) -> usize {
    let mut best = (f64::INFINITY, 0);
    for (i, c) in chains.iter().enumerate() {
        let gap = (c.entry - exit).rem_euclid(3.0);
        if gap < best.0 {
            best = (gap, i);
        }
    }
    best.1
}

/// Local corners strictly between boundary position `from` and `from + gap`, in order.
fn corners_between(from: f64, gap: f64) -> impl Iterator<Item = usize> {
    let mut ks: Vec<(f64, usize)> = (0..3)
        .map(|k| ((k as f64 - from).rem_euclid(3.0), k))
        .filter(|&(d, _)| d > 0.0 && d < gap)
        .collect();
    ks.sort_by(|x, y| x.0.total_cmp(&y.0));
    ks.into_iter().map(|(_, k)| k)
}

fn cross2(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

fn signed_area(poly: &[Node]) -> f64 {
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
fn triangulate_into(poly: &[Node], cut: &mut CutFace, stats: &mut RegionStats) {
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
