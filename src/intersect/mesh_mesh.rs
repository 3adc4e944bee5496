//! Edge–face intersections between two surfaces and the intersection curves they delimit
//! (2021 Sec. 4, Algorithm 1 line 3: "compute and store edge-face intersection points").

use super::bvh::FaceSets;
use super::curves::{chain, Curve};
use super::index::{canonical, MeshIndex, PosedMesh};
use super::predicates::{edge_edge, FacePlane, SoSSign};
use super::IntersectError;
use nalgebra::{Point3, Vector3};
use std::sync::atomic::{AtomicUsize, Ordering};

/// One of the two surfaces of an intersection query. In a self-contact, `A` is part 1 and `B`
/// part 2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Side {
    /// The first surface.
    A,
    /// The second surface.
    B,
}

impl Side {
    /// The other surface.
    pub fn other(self) -> Side {
        match self {
            Side::A => Side::B,
            Side::B => Side::A,
        }
    }
}

/// An edge of one surface crossing a face of the other.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeHit {
    /// The surface the edge belongs to (the face belongs to the other one).
    pub side: Side,
    /// The edge's vertex ids, `edge[0] < edge[1]`.
    pub edge: [u32; 2],
    /// Parameter along the edge: `point = (1 - t) p[edge[0]] + t p[edge[1]]`, in `[0, 1]`.
    pub t: f64,
    /// The crossed face of the other surface.
    pub face: u32,
    /// Barycentric coordinates of the point on `face`, in the order of its corners.
    pub bary: [f64; 3],
    /// The intersection point.
    pub point: Point3<f64>,
    /// The edge, run from `edge[0]` to `edge[1]`, enters the other body here (its direction has
    /// a negative dot product with the face's outward normal): `edge[1]` is on the inner side.
    pub entering: bool,
}

impl EdgeHit {
    fn key(&self) -> (Side, [u32; 2], u32) {
        (self.side, self.edge, self.face)
    }
}

/// The intersection of a face of `A` with a face of `B`: a segment between two hits, oriented
/// along `n_A × n_B` (so the part of `A` inside `B` is on its left seen from outside `A`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntersectionSegment {
    /// `[face of A, face of B]`.
    pub faces: [u32; 2],
    /// `[start, end]` hit indices.
    pub hits: [u32; 2],
}

/// Counters of one intersection query.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IntersectionStats {
    /// Face pairs whose bounding boxes overlap.
    pub candidate_pairs: usize,
    /// Face pairs that intersect (one segment each).
    pub intersecting_pairs: usize,
    /// Self-contact face pairs skipped because they share a vertex.
    pub adjacent_pairs_skipped: usize,
    /// Face pairs found exactly coplanar (they never intersect under the perturbation).
    pub coplanar_pairs: usize,
    /// Distinct faces of each side in such a pair: every face of a surface and its duplicate,
    /// the few faces of one flat side resting on another.
    pub coplanar_faces: [usize; 2],
    /// Predicate evaluations that were exactly zero and decided by the symbolic perturbation
    /// (touching configurations).
    pub symbolic_ties: usize,
    /// Candidate pairs in which a face has an exactly zero normal (collinear corners): such a
    /// face is never crossed, its edges still are (so curves stay closed).
    pub degenerate_pairs: usize,
    /// Faces left out because they repeat a vertex index (both sides).
    pub index_degenerate_faces: usize,
    /// Intersecting face pairs with other than two hits or two equally oriented hits. Zero for
    /// any input: the exact predicates make this impossible; counted as a safeguard.
    pub anomalous_pairs: usize,
}

/// All edge–face hits between two surfaces, the segments joining them and the curves chained
/// from the segments (closed loops for closed surfaces).
///
/// Exact and deterministic: crossing decisions use exact predicates with a symbolic
/// perturbation (see the module `predicates`), outputs are sorted (hits by side, edge, face;
/// segments by face pair), whatever the BVH or the number of threads.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Intersections {
    /// Hits sorted by `(side, edge, face)`.
    pub hits: Vec<EdgeHit>,
    /// Segments sorted by face pair.
    pub segments: Vec<IntersectionSegment>,
    /// Chains of segments; their nodes are indices into `hits`.
    pub curves: Vec<Curve>,
    /// Counters.
    pub stats: IntersectionStats,
}

impl Intersections {
    /// Intersections between two separate surfaces; surfaces entangled rather than in contact
    /// are [`IntersectError::Entangled`] ([`crate::intersect::bvh::PAIRS_PER_FACE`]: two
    /// capsules with their vertices shuffled, a broken rig, took 11.6 s per frame unbounded).
    pub fn between(a: &PosedMesh, b: &PosedMesh) -> Result<Self, IntersectError> {
        compute(a, b, false)
    }

    /// Intersections between the two parts of one mesh (2021 Sec. 6): only pairs across the
    /// parts count, and face pairs sharing a vertex are skipped. Both parts must be posed with
    /// the same positions. Parts entangled rather than in contact are
    /// [`IntersectError::Entangled`] ([`crate::intersect::bvh::PAIRS_PER_FACE`]).
    pub fn self_contact(part1: &PosedMesh, part2: &PosedMesh) -> Result<Self, IntersectError> {
        let same = std::ptr::eq(part1.positions(), part2.positions())
            && part1.triangles() == part2.triangles();
        if !same {
            return Err(IntersectError::SelfContactMismatch);
        }
        compute(part1, part2, true)
    }

    /// [`Intersections::self_contact`] between two disjoint sets of one surface's faces,
    /// marked in its BVH ([`crate::intersect::MeshIndex::face_sets`]): the same segments, hits
    /// and curves as between two indices over each set, with one refit of one tree for both
    /// (the statistics' index-degenerate faces are the whole surface's).
    pub fn between_sets(mesh: &PosedMesh, sets: &FaceSets) -> Result<Self, IntersectError> {
        let counters = Counters::default();
        // The pairs sharing a vertex are dropped in the traversal (counted as skipped).
        let (pairs, adjacent) = mesh.bvh().apart_pairs_between_sets(
            sets,
            mesh.positions(),
            mesh.index().triangles(),
            |fa, fb| pair_segment(mesh, fa, mesh, fb, true, &counters),
        )?;
        Counters::add(&counters.candidates, adjacent);
        Counters::add(&counters.adjacent, adjacent);
        let degenerate = mesh.index().index_degenerate_faces();
        Ok(assemble(pairs, degenerate, &counters))
    }

    /// True when nothing intersects.
    pub fn is_empty(&self) -> bool {
        self.hits.is_empty()
    }

    /// Index of the hit of edge `{a, b}` of `side` with face `face` of the other side.
    pub fn find_hit(&self, side: Side, a: u32, b: u32, face: u32) -> Option<u32> {
        let key = (side, canonical(a, b), face);
        self.hits
            .binary_search_by(|h| h.key().cmp(&key))
            .ok()
            .map(|i| i as u32)
    }
}

/// One-call form of [`Intersections::between`] (builds the indices on the given positions).
pub fn intersect_meshes(
    positions_a: &[Point3<f64>],
    triangles_a: &[[u32; 3]],
    positions_b: &[Point3<f64>],
    triangles_b: &[[u32; 3]],
) -> Result<Intersections, IntersectError> {
    let ia = MeshIndex::new(positions_a, triangles_a)?;
    let ib = MeshIndex::new(positions_b, triangles_b)?;
    Intersections::between(&ia.pose(positions_a)?, &ib.pose(positions_b)?)
}

/// One-call form of [`Intersections::self_contact`]: `parts` labels each face 1 or 2 (other
/// labels: neither part).
pub fn intersect_parts(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    parts: &[u8],
) -> Result<Intersections, IntersectError> {
    let [p1, p2] = MeshIndex::self_contact_parts(positions, triangles, parts)?;
    Intersections::self_contact(&p1.pose(positions)?, &p2.pose(positions)?)
}

#[derive(Default)]
struct Counters {
    candidates: AtomicUsize,
    adjacent: AtomicUsize,
    /// The coplanar face pairs (rare but for coincident surfaces: a lock per pair found).
    coplanar: std::sync::Mutex<Vec<[u32; 2]>>,
    degenerate: AtomicUsize,
    ties: AtomicUsize,
    anomalous: AtomicUsize,
}

impl Counters {
    fn add(c: &AtomicUsize, n: usize) {
        if n > 0 {
            c.fetch_add(n, Ordering::Relaxed);
        }
    }
}

/// The coplanar pairs found (as often as found) and the distinct faces of each side in them.
fn coplanar_counts(counters: &Counters) -> (usize, [usize; 2]) {
    let Ok(pairs) = counters.coplanar.lock() else {
        return (0, [0, 0]);
    };
    let distinct = [0, 1].map(|k| {
        let mut faces: Vec<u32> = pairs.iter().map(|p| p[k]).collect();
        faces.sort_unstable();
        faces.dedup();
        faces.len()
    });
    (pairs.len(), distinct)
}

/// The two hits of an intersecting face pair, `hits[0]` the start of the segment.
struct PairSegment {
    faces: [u32; 2],
    hits: [EdgeHit; 2],
}

/// The intersections of two separate surfaces, or of two parts of one mesh
/// (`self_contact`: face pairs sharing a vertex skipped), their candidate pairs bounded
/// ([`crate::intersect::TriangleBvh::overlapping_pairs_bounded`]).
fn compute(
    a: &PosedMesh,
    b: &PosedMesh,
    self_contact: bool,
) -> Result<Intersections, IntersectError> {
    let counters = Counters::default();
    let pairs = a.bvh().overlapping_pairs_bounded(b.bvh(), |fa, fb| {
        pair_segment(a, fa, b, fb, self_contact, &counters)
    })?;
    Ok(assembled(a, b, pairs, &counters))
}

/// [`assemble`] with both surfaces' index-degenerate faces counted.
fn assembled(
    a: &PosedMesh,
    b: &PosedMesh,
    pairs: Vec<PairSegment>,
    counters: &Counters,
) -> Intersections {
    let degenerate = a.index().index_degenerate_faces() + b.index().index_degenerate_faces();
    assemble(pairs, degenerate, counters)
}

/// The exact test of a candidate pair (skipped when `self_contact` and the faces share a
/// vertex).
fn pair_segment(
    a: &PosedMesh,
    fa: u32,
    b: &PosedMesh,
    fb: u32,
    self_contact: bool,
    counters: &Counters,
) -> Option<PairSegment> {
    Counters::add(&counters.candidates, 1);
    let ctx = Pair::new(a, fa, b, fb);
    if self_contact && ctx.shares_vertex() {
        Counters::add(&counters.adjacent, 1);
        return None;
    }
    ctx.segment(counters)
}

/// Hits shared between the pairs' segments get one index; the segments chained into curves.
fn assemble(
    pairs: Vec<PairSegment>,
    index_degenerate: usize,
    counters: &Counters,
) -> Intersections {
    // Every hit with the slot (pair, end) it fills, sorted by key: equal keys are the same hit
    // (found from both faces around its edge) and get one index.
    let mut slots: Vec<(EdgeHit, usize, usize)> = pairs
        .iter()
        .enumerate()
        .flat_map(|(i, p)| [(p.hits[0], i, 0), (p.hits[1], i, 1)])
        .collect();
    slots.sort_unstable_by_key(|(h, i, end)| (h.key(), *i, *end));
    let mut segments: Vec<IntersectionSegment> = pairs
        .iter()
        .map(|p| IntersectionSegment {
            faces: p.faces,
            hits: [0, 0],
        })
        .collect();
    let mut hits: Vec<EdgeHit> = Vec::with_capacity(pairs.len());
    for (h, i, end) in slots {
        if hits.last().is_none_or(|last| last.key() != h.key()) {
            hits.push(h);
        }
        segments[i].hits[end] = hits.len() as u32 - 1;
    }
    let links: Vec<[u32; 2]> = segments.iter().map(|s| s.hits).collect();
    let curves = chain(hits.len(), &links);
    let load = |c: &AtomicUsize| c.load(Ordering::Relaxed);
    let (coplanar_pairs, coplanar_faces) = coplanar_counts(counters);
    Intersections {
        stats: IntersectionStats {
            candidate_pairs: load(&counters.candidates),
            intersecting_pairs: segments.len(),
            adjacent_pairs_skipped: load(&counters.adjacent),
            coplanar_pairs,
            coplanar_faces,
            degenerate_pairs: load(&counters.degenerate),
            symbolic_ties: load(&counters.ties),
            index_degenerate_faces: index_degenerate,
            anomalous_pairs: load(&counters.anomalous),
        },
        hits,
        segments,
        curves,
    }
}

/// The exact test of one face pair.
struct Pair<'p> {
    faces: [u32; 2],
    tri: [[u32; 3]; 2],
    /// Corner positions of the face of `A` and of the face of `B`.
    pts: [[&'p Point3<f64>; 3]; 2],
}

/// A crossing found in a face pair, before it becomes an [`EdgeHit`].
struct Crossing {
    hit: EdgeHit,
    /// The segment starts at this hit.
    start: bool,
}

impl<'p> Pair<'p> {
    fn new(a: &'p PosedMesh, fa: u32, b: &'p PosedMesh, fb: u32) -> Self {
        let tri = [a.triangles()[fa as usize], b.triangles()[fb as usize]];
        Self {
            faces: [fa, fb],
            tri,
            pts: [a.corners(fa), b.corners(fb)],
        }
    }

    fn shares_vertex(&self) -> bool {
        self.tri[0].iter().any(|v| self.tri[1].contains(v))
    }

    /// Local edge `k` of side `s` as `(canonical vertex ids, canonical local corners, forward)`:
    /// `forward` when the face runs the edge in canonical order.
    fn edge(&self, s: usize, k: usize) -> ([u32; 2], [usize; 2], bool) {
        let (i, j) = (k, (k + 1) % 3);
        let t = &self.tri[s];
        if t[i] < t[j] {
            ([t[i], t[j]], [i, j], true)
        } else {
            ([t[j], t[i]], [j, i], false)
        }
    }

    fn segment(&self, counters: &Counters) -> Option<PairSegment> {
        // Side of each corner of one face with respect to the other face's plane.
        let sa = self.sides(0, counters)?;
        let sb = self.sides(1, counters)?;
        let mut ee = EdgeEdgeCache {
            signs: [[2; 3]; 3],
            ties: 0,
        };
        let mut found: Vec<Crossing> = Vec::with_capacity(2);
        for k in 0..3 {
            found.extend(self.edge_a_crossing(k, &sa, &mut ee));
            found.extend(self.edge_b_crossing(k, &sb, &mut ee));
        }
        Counters::add(&counters.ties, ee.ties);
        match found.as_slice() {
            [] => None,
            [x, y] if x.start != y.start => {
                let (s, e) = if x.start { (x, y) } else { (y, x) };
                Some(PairSegment {
                    faces: self.faces,
                    hits: [s.hit, e.hit],
                })
            }
            _ => {
                Counters::add(&counters.anomalous, 1);
                None
            }
        }
    }

    /// Sides of the corners of face `s` with respect to the other face's plane, or `None` when
    /// they are all strictly on one side (the faces cannot intersect).
    fn sides(&self, s: usize, counters: &Counters) -> Option<[SoSSign; 3]> {
        let plane = FacePlane::new(self.pts[1 - s]);
        let signs = self.pts[s].map(|p| plane.side(p, s == 1));
        Counters::add(&counters.ties, signs.iter().filter(|x| x.tie).count());
        if signs.iter().all(|x| x.tie && x.sign != 0) {
            if let Ok(mut pairs) = counters.coplanar.lock() {
                pairs.push(self.faces);
            }
        }
        if signs.iter().all(|x| x.sign == 0) {
            Counters::add(&counters.degenerate, 1);
        }
        let separated = signs[0].sign != 0 && signs.iter().all(|x| x.sign == signs[0].sign);
        (!separated).then_some(signs)
    }

    /// Edge `k` of the face of `A` against the face of `B`.
    fn edge_a_crossing(
        &self,
        k: usize,
        sa: &[SoSSign; 3],
        ee: &mut EdgeEdgeCache,
    ) -> Option<Crossing> {
        let (edge, [lp, lq], forward) = self.edge(0, k);
        let (sp, sq) = (sa[lp].sign, sa[lq].sign);
        if sp * sq >= 0 {
            return None;
        }
        // orient(p, q, c_j, c_{j+1}) for each edge j of the face of B.
        let signs: [i8; 3] = std::array::from_fn(|j| {
            let (_, _, fwd_b) = self.edge(1, j);
            ee.get(self, k, j) * if fwd_b { 1 } else { -1 }
        });
        let s = signs[0];
        if s == 0 || signs.iter().any(|&x| x != s) {
            return None;
        }
        let (p, q) = (self.pts[0][lp], self.pts[0][lq]);
        let hit = crossing(p, q, sp, sq, self.pts[1], s, Side::A, edge, self.faces[1]);
        // The face of A runs the edge u -> v; the segment starts here iff n_B·(v - u) > 0.
        let s_v = if forward { sq } else { sp };
        Some(Crossing {
            hit,
            start: s_v > 0,
        })
    }

    /// Edge `k` of the face of `B` against the face of `A`.
    fn edge_b_crossing(
        &self,
        k: usize,
        sb: &[SoSSign; 3],
        ee: &mut EdgeEdgeCache,
    ) -> Option<Crossing> {
        let (edge, [la, lb], forward) = self.edge(1, k);
        let (sa_, sb_) = (sb[la].sign, sb[lb].sign);
        if sa_ * sb_ >= 0 {
            return None;
        }
        // orient(a, b, c_i, c_{i+1}) = orient(c_i, c_{i+1}, a, b) for each edge i of A's face.
        let signs: [i8; 3] = std::array::from_fn(|i| {
            let (_, _, fwd_a) = self.edge(0, i);
            ee.get(self, i, k) * if fwd_a { 1 } else { -1 }
        });
        let s = signs[0];
        if s == 0 || signs.iter().any(|&x| x != s) {
            return None;
        }
        let (p, q) = (self.pts[1][la], self.pts[1][lb]);
        let hit = crossing(p, q, sa_, sb_, self.pts[0], s, Side::B, edge, self.faces[0]);
        // The face of B runs the edge u -> v; the segment starts here iff n_A·(v - u) < 0.
        let s_v = if forward { sb_ } else { sa_ };
        Some(Crossing {
            hit,
            start: s_v < 0,
        })
    }
}

/// Lazily evaluated perturbed `orient3d(p, q, a, b)` for canonical edge `pq` of `A`'s face and
/// canonical edge `ab` of `B`'s face.
struct EdgeEdgeCache {
    /// 2 = not evaluated yet.
    signs: [[i8; 3]; 3],
    ties: usize,
}

impl EdgeEdgeCache {
    fn get(&mut self, pair: &Pair, i: usize, j: usize) -> i8 {
        if self.signs[i][j] == 2 {
            let (_, [lp, lq], _) = pair.edge(0, i);
            let (_, [la, lb], _) = pair.edge(1, j);
            let s = edge_edge(
                pair.pts[0][lp],
                pair.pts[0][lq],
                pair.pts[1][la],
                pair.pts[1][lb],
            );
            self.ties += s.tie as usize;
            self.signs[i][j] = s.sign;
        }
        self.signs[i][j]
    }
}

/// Builds the hit of edge `p -> q` (endpoint signs `sp`, `sq` with respect to `face`, opposite)
/// crossing `face`; `s` is the common sign of `orient(p, q, c_j, c_{j+1})`.
#[allow(clippy::too_many_arguments)]
fn crossing(
    p: &Point3<f64>,
    q: &Point3<f64>,
    sp: i8,
    sq: i8,
    face: [&Point3<f64>; 3],
    s: i8,
    side: Side,
    edge: [u32; 2],
    face_id: u32,
) -> EdgeHit {
    let n = (face[1] - face[0]).cross(&(face[2] - face[0]));
    let t = edge_parameter(n.dot(&(p - face[0])), n.dot(&(q - face[0])), sp, sq);
    let point = if t <= 0.5 {
        p + (q - p) * t
    } else {
        q + (p - q) * (1.0 - t)
    };
    EdgeHit {
        side,
        edge,
        t,
        face: face_id,
        bary: barycentric(p, q, face, s),
        point,
        entering: sq < 0,
    }
}

/// `dp / (dp - dq)` in `[0, 1]`, trusting the exact signs `sp`, `sq` where the floating-point
/// plane distances disagree with them.
fn edge_parameter(dp: f64, dq: f64, sp: i8, sq: i8) -> f64 {
    let agree = |d: f64, s: i8| d != 0.0 && (d > 0.0) == (s > 0);
    match (agree(dp, sp), agree(dq, sq)) {
        (false, true) => 0.0,
        (true, false) => 1.0,
        (false, false) => 0.5,
        (true, true) => (dp / (dp - dq)).clamp(0.0, 1.0),
    }
}

/// Barycentric coordinates on `face` of the line `pq` through it: corner `k` weighs
/// `orient(p, q, c_{k+1}, c_{k+2})`, all of sign `s` (clamped, normalized).
pub(crate) fn barycentric(
    p: &Point3<f64>,
    q: &Point3<f64>,
    face: [&Point3<f64>; 3],
    s: i8,
) -> [f64; 3] {
    let d: Vector3<f64> = q - p;
    let vol = |x: &Point3<f64>, y: &Point3<f64>| d.dot(&(x - p).cross(&(y - p)));
    let w = [
        vol(face[1], face[2]),
        vol(face[2], face[0]),
        vol(face[0], face[1]),
    ]
    .map(|v| (v * f64::from(s)).max(0.0));
    let total: f64 = w.iter().sum();
    if total > 0.0 && total.is_finite() {
        w.map(|x| x / total)
    } else {
        [1.0 / 3.0; 3]
    }
}
