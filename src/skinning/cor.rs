//! Center-of-rotation skinning after Le and Hodgins, *Real-time Skeletal Skinning with Optimized
//! Centers of Rotation* (ACM TOG 35(4), SIGGRAPH 2016).
//!
//! Every vertex `i` gets a bind-pose center of rotation `p*_i`, the area-weighted mean of the
//! surface points whose skin weights look like its own:
//!
//! ```text
//! s(w_p, w_v) = Σ_{j<k} w_pj w_pk w_vj w_vk exp(-(w_pj w_vk - w_pk w_vj)² / σ²)        (similarity)
//! p*_i        = Σ_t s(w_i, w_t) A_t c_t / Σ_t s(w_i, w_t) A_t                           (center)
//! ```
//!
//! over the triangles `t` of the bind pose (`w_t` the mean of the corner weights, `c_t` the
//! centroid, `A_t` the area), after the triangles have been subdivided until the weights of the
//! endpoints of every edge are within `ε` of each other (L2). A vertex without any similar
//! triangle (a single-bone vertex, whose similarity with everything is 0) has no center and is
//! skinned by plain linear blending. At run time (the paper's skinning equation):
//!
//! ```text
//! p'_i = Σ_s w_is M_s p*_i + R_i (p_i - p*_i),   n'_i = R_i n_i,
//! ```
//!
//! with `R_i` the rotation of the normalized quaternion blend `Σ_s w_is q_s` (signs aligned to
//! the heaviest influence), `q_s` the rotation of the polar decomposition `A_s = R_s S_s` of
//! `M_s`. The paper's joints are rigid; a joint that scales (an armature node scaled from
//! centimetres to metres) also gets its stretch, blended as dual quaternion skinning blends
//! it (`S̄_i = Σ_s w_is S_s`): `p'_i = Σ_s w_is M_s p*_i + R_i S̄_i (p_i - p*_i)`,
//! `n'_i = R_i cof(S̄_i) n_i`, which a single joint reproduces exactly (`M_s p_i`); until
//! 2026-12-05 the offset `p_i - p*_i` kept its bind size, and a rig under a root scaled by
//! 2⁻⁶⁴ had its blended vertices one bind size away from the rest.
//!
//! # Precomputation in O(Σ_pairs V_jk · T_jk) instead of O(V · T)
//!
//! The similarity is a sum over joint pairs `(j, k)`, and the `(j, k)` term is nonzero only when
//! both weight vectors contain both joints. The subtriangles are therefore bucketed per joint
//! pair (each entry holding `w_tj`, `w_tk`, `w_tj w_tk A_t` and `w_tj w_tk A_t c_t`), and a vertex
//! visits only the buckets of its own pairs. Vertices with bit-identical weight rows (seam copies)
//! are computed once. Every center is computed independently, in a fixed summation order, so the
//! result does not depend on the number of threads. The reorganization is exact: the result
//! equals the brute-force double sum up to floating-point rounding.
//!
//! The inner loop evaluates `exp(-Δ²/σ²) = 2^-(sΔ)²` (`s = √log2(e) / σ`) with a branch-free
//! polynomial on blocks of 8 entries, so that it vectorizes (with AVX2 where the CPU has it,
//! selected at run time; the bits do not depend on the path). On the benchmark character
//! (`benches/skinning.rs`: 30k vertices, 60k triangles, 20 bones, 13.7k blended vertices) the
//! precomputation evaluates the kernel ~1.4·10⁸ times and takes ~0.25 s on 2 cores, where the
//! naive double sum would take ~30k × 88k subtriangles × pairs evaluations.

use super::dqs::{blended_stretch, joint_dqs, JointDq};
use super::{cofactor, lbs, unit_or_zero, BindShape, Skinned};
use crate::rig::{Body, SkinWeights};
use nalgebra::{Matrix4, Point3, Quaternion, UnitQuaternion, Vector3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Parameters of the center precomputation (Le & Hodgins 2016 use σ = 0.1 and ε = 0.1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CorParams {
    /// Width σ of the similarity kernel `exp(-(w_pj w_vk - w_pk w_vj)² / σ²)`.
    pub sigma: f64,
    /// Largest L2 distance between the weight vectors of the two ends of a (sub)triangle edge.
    pub epsilon: f64,
    /// Cap on the per-triangle subdivision level `n` (a triangle becomes at most `n²` pieces).
    /// Normalized weights are at most `√2` apart, so the cap only matters for `ε < √2 / cap`.
    pub max_subdivision: u32,
    /// Most bucket entries (subtriangle, joint pair) planned before the cap is lowered
    /// ([`CorCenters::subdivision_cap`]); `None`: [`entry_budget`] of the body's triangles.
    pub entry_budget: Option<usize>,
}

impl Default for CorParams {
    fn default() -> Self {
        Self {
            sigma: 0.1,
            epsilon: 0.1,
            max_subdivision: 32,
            entry_budget: None,
        }
    }
}

/// The fewest bucket entries (subtriangle, joint pair) the precomputation may plan before it
/// lowers the subdivision cap ([`entry_budget`]).
pub const MIN_ENTRY_BUDGET: usize = 4 << 20;

/// Bucket entries per triangle the precomputation may plan on a large mesh
/// ([`entry_budget`]): the samples plan 30 (CesiumMan) to 377 (RiggedFigure) per triangle.
pub const ENTRIES_PER_TRIANGLE: usize = 512;

/// The bucket entries a body of `triangles` triangles may plan: past it the subdivision cap is
/// halved until the plan fits ([`CorCenters::subdivision_cap`]). Only a broken mesh reaches it:
/// CesiumMan's triangle list read as a fan (slivers spanning the body, each over many joints)
/// planned 1388 entries per triangle, 19.5 M in all, and took 8.7 s and 2 GB to precompute
/// for 3273 vertices; a 30k-vertex one would have needed about 20 GB. An entry costs about
/// 100 bytes (its raw form and its packed block).
pub fn entry_budget(triangles: usize) -> usize {
    MIN_ENTRY_BUDGET.max(ENTRIES_PER_TRIANGLE.saturating_mul(triangles))
}

/// What the precomputation did, for reports and benchmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CorStats {
    /// Vertices of the body.
    pub vertices: usize,
    /// Vertices with at least two influences (the only ones that can get a center).
    pub blended_vertices: usize,
    /// Distinct weight rows among the blended vertices (each computed once).
    pub unique_rows: usize,
    /// Vertices that got a center.
    pub centers: usize,
    /// Subtriangles after the ε-subdivision.
    pub subtriangles: usize,
    /// Joint pairs that occur in some vertex row.
    pub pairs: usize,
    /// Bucket entries (subtriangle, pair) over all pairs.
    pub bucket_entries: usize,
    /// Kernel evaluations of the center integrals (`Σ` over unique rows of the sizes of their
    /// pair buckets, counting the zero padding of each bucket's last block).
    pub kernel_evaluations: u64,
    /// The subdivision cap used: [`CorParams::max_subdivision`], or lower when the planned
    /// entries passed [`entry_budget`].
    pub subdivision_cap: u32,
}

/// Per-vertex centers of rotation (bind pose, mesh space).
#[derive(Clone, Debug, Default)]
pub struct CorCenters {
    /// Center of each file vertex; `None` where the similarity integral vanishes (single-bone
    /// vertices, isolated vertices): such vertices are skinned by plain LBS.
    pub centers: Vec<Option<Point3<f64>>>,
    /// The subdivision cap, when the precomputation lowered it below
    /// [`CorParams::max_subdivision`] to keep within [`entry_budget`] (a broken mesh; the
    /// centers are then those of a coarser ε): `(cap used, entries the parameters planned)`.
    pub subdivision_cap: Option<(u32, usize)>,
}

impl CorCenters {
    /// Precomputes the centers with the paper's parameters ([`CorParams::default`]).
    pub fn precompute(body: &Body) -> Self {
        Self::precompute_with(body, &CorParams::default())
    }

    /// Precomputes the centers with explicit parameters.
    pub fn precompute_with(body: &Body, params: &CorParams) -> Self {
        Self::precompute_with_stats(body, params).0
    }

    /// Precomputes the centers and reports what was done.
    pub fn precompute_with_stats(body: &Body, params: &CorParams) -> (Self, CorStats) {
        let n = body.vertex_count().min(body.weights.len());
        let rows = UniqueRows::new(&body.weights, n);
        let pairs = PairIndex::from_rows(&body.weights, &rows.representatives);
        let budget = (params.entry_budget).unwrap_or_else(|| entry_budget(body.triangles.len()));
        let (buckets, capped) = Buckets::within(body, params, &pairs, budget);
        let solved = solve_rows(body, &rows.representatives, &pairs, &buckets, params.sigma);
        let centers = rows.scatter(&solved, body.vertex_count());
        let stats = CorStats {
            vertices: body.vertex_count(),
            blended_vertices: rows.slot.iter().flatten().count(),
            unique_rows: rows.representatives.len(),
            centers: centers.iter().flatten().count(),
            subtriangles: buckets.subtriangles,
            pairs: pairs.keys.len(),
            bucket_entries: buckets.entries,
            kernel_evaluations: solved.iter().map(|s| s.1).sum(),
            subdivision_cap: capped.map_or(params.max_subdivision.max(1), |c| c.0),
        };
        let centers = Self {
            centers,
            subdivision_cap: capped,
        };
        (centers, stats)
    }
}

/// The similarity `s(w_p, w_v)` of two sparse weight rows (`(joints, weights)`), Le & Hodgins
/// 2016: `Σ_{j<k} w_pj w_pk w_vj w_vk exp(-(w_pj w_vk - w_pk w_vj)² / σ²)` over the joints common
/// to both rows. Rows need not be sorted; a joint listed twice counts once (first entry).
pub fn similarity(p: (&[u16], &[f64]), v: (&[u16], &[f64]), sigma: f64) -> f64 {
    let inv_sigma2 = 1.0 / (sigma * sigma);
    let common: Vec<(f64, f64)> =
        p.0.iter()
            .zip(p.1)
            .enumerate()
            .filter(|&(i, (j, _))| !p.0[..i].contains(j))
            .filter_map(|(_, (j, &wp))| {
                let k = v.0.iter().position(|x| x == j)?;
                Some((wp, *v.1.get(k)?))
            })
            .collect();
    let mut s = 0.0;
    for (a, &(pj, vj)) in common.iter().enumerate() {
        for &(pk, vk) in &common[a + 1..] {
            let d = pj * vk - pk * vj;
            s += pj * pk * vj * vk * (-d * d * inv_sigma2).exp();
        }
    }
    s
}

/// The centers of the given rows (vertex ids), in parallel, with their kernel evaluation counts.
fn solve_rows(
    body: &Body,
    representatives: &[usize],
    pairs: &PairIndex,
    buckets: &Buckets,
    sigma: f64,
) -> Vec<(Option<Point3<f64>>, u64)> {
    // exp(-Δ²/σ²) = 2^-(sΔ)² with s = sqrt(log2 e) / σ.
    let scale = std::f64::consts::LOG2_E.sqrt() / sigma;
    representatives
        .par_iter()
        .with_min_len(16)
        .map(|&v| {
            let (joints, weights) = body.weights.row_slices(v);
            center_of_row(joints, weights, pairs, buckets, scale)
        })
        .collect()
}

/// Distinct multi-influence weight rows: `slot[v]` is the index of vertex `v`'s row in
/// `representatives` (the first vertex carrying it), `None` for rows with fewer than two joints.
struct UniqueRows {
    slot: Vec<Option<usize>>,
    representatives: Vec<usize>,
}

impl UniqueRows {
    fn new(weights: &SkinWeights, n: usize) -> Self {
        let mut seen: HashMap<(&[u16], Vec<u64>), usize> = HashMap::new();
        let mut representatives = Vec::new();
        let slot = (0..n)
            .map(|v| {
                let (joints, ws) = weights.row_slices(v);
                if joints.len() < 2 {
                    return None;
                }
                let key = (joints, ws.iter().map(|w| w.to_bits()).collect());
                Some(*seen.entry(key).or_insert_with(|| {
                    representatives.push(v);
                    representatives.len() - 1
                }))
            })
            .collect();
        Self {
            slot,
            representatives,
        }
    }

    /// Spreads the per-row results back to `vertex_count` vertices (`None` for the others).
    fn scatter(
        &self,
        solved: &[(Option<Point3<f64>>, u64)],
        vertex_count: usize,
    ) -> Vec<Option<Point3<f64>>> {
        let mut centers = vec![None; vertex_count];
        for (center, slot) in centers.iter_mut().zip(&self.slot) {
            if let Some(&(c, _)) = slot.and_then(|s| solved.get(s)) {
                *center = c;
            }
        }
        centers
    }
}

/// Packs an ordered joint pair `j < k` into one key.
fn pair_key(j: u16, k: u16) -> u32 {
    (u32::from(j) << 16) | u32::from(k)
}

/// The joint pairs that occur in some vertex row, sorted; a pair's bucket is its rank.
struct PairIndex {
    keys: Vec<u32>,
}

impl PairIndex {
    fn from_rows(weights: &SkinWeights, representatives: &[usize]) -> Self {
        let mut keys = Vec::new();
        for &v in representatives {
            let (joints, _) = weights.row_slices(v);
            for (a, &j) in joints.iter().enumerate() {
                for &k in &joints[a + 1..] {
                    keys.push(pair_key(j.min(k), j.max(k)));
                }
            }
        }
        keys.sort_unstable();
        keys.dedup();
        Self { keys }
    }

    fn find(&self, j: u16, k: u16) -> Option<usize> {
        self.keys.binary_search(&pair_key(j.min(k), j.max(k))).ok()
    }
}

/// The bind-pose data of one triangle: corner positions and the union of the corner rows,
/// with each joint's weight at the three corners.
struct TriangleData {
    corners: [Point3<f64>; 3],
    joints: Vec<u16>,
    corner_weights: Vec<[f64; 3]>,
}

impl TriangleData {
    /// Gathers triangle `tri`; `None` when an index is out of range.
    fn gather(body: &Body, tri: &[u32; 3]) -> Option<Self> {
        let mut corners = [Point3::origin(); 3];
        let mut joints: Vec<u16> = Vec::with_capacity(12);
        let mut corner_weights: Vec<[f64; 3]> = Vec::with_capacity(12);
        for (c, &v) in tri.iter().enumerate() {
            let v = v as usize;
            corners[c] = *body.positions.get(v)?;
            if v >= body.weights.len() {
                return None;
            }
            for (j, w) in body.weights.row(v) {
                let j = j as u16;
                match joints.iter().position(|&x| x == j) {
                    Some(i) => corner_weights[i][c] += w,
                    None => {
                        joints.push(j);
                        let mut cw = [0.0; 3];
                        cw[c] = w;
                        corner_weights.push(cw);
                    }
                }
            }
        }
        Some(Self {
            corners,
            joints,
            corner_weights,
        })
    }

    /// Largest L2 distance between the weight vectors of two corners.
    fn max_edge_weight_distance(&self) -> f64 {
        [(0, 1), (1, 2), (2, 0)]
            .iter()
            .map(|&(a, b)| {
                let d2: f64 = self
                    .corner_weights
                    .iter()
                    .map(|w| (w[a] - w[b]) * (w[a] - w[b]))
                    .sum();
                d2.sqrt()
            })
            .fold(0.0, f64::max)
    }

    /// Subdivision level: `n = ceil(max edge weight distance / ε)`, clamped to `[1, cap]`
    /// (1 when undefined, e.g. NaN weights or `ε = 0` on an edge without weight change).
    fn subdivision(&self, params: &CorParams) -> u32 {
        let n = (self.max_edge_weight_distance() / params.epsilon).ceil();
        let cap = params.max_subdivision.max(1);
        if n.is_nan() {
            1
        } else {
            n.clamp(1.0, f64::from(cap)) as u32
        }
    }

    fn area(&self) -> f64 {
        let [a, b, c] = &self.corners;
        0.5 * (b - a).cross(&(c - a)).norm()
    }
}

/// Calls `f(piece area, barycentric coordinates of the piece's centroid)` for the `n²` pieces of the uniform barycentric
/// `n × n` subdivision of a triangle of area `area`. With linearly interpolated weights, the
/// mean of a piece's corner weights is the weight at its centroid, so this is exact.
fn for_each_piece(n: u32, area: f64, mut f: impl FnMut(f64, [f64; 3])) {
    let nf = f64::from(n);
    let piece = area / (nf * nf);
    let bary = |i: u32, j: u32, off: f64| {
        let b0 = (3.0 * f64::from(i) + off) / (3.0 * nf);
        let b1 = (3.0 * f64::from(j) + off) / (3.0 * nf);
        [b0, b1, 1.0 - b0 - b1]
    };
    for i in 0..n {
        for j in 0..n - i {
            f(piece, bary(i, j, 1.0));
            if i + j + 2 <= n {
                f(piece, bary(i, j, 2.0));
            }
        }
    }
}

/// What the subdivision of every triangle would emit, before any entry is made: per
/// triangle its uncapped level `n` and the joint pairs it feeds (at most `n²` entries each).
struct Plan {
    triangles: Vec<(u32, usize)>,
}

impl Plan {
    fn of(body: &Body, params: &CorParams, pairs: &PairIndex) -> Self {
        let uncapped = CorParams {
            max_subdivision: u32::MAX,
            ..*params
        };
        let triangles = (body.triangles.par_iter())
            .map(|tri| match TriangleData::gather(body, tri) {
                Some(t) if t.joints.len() >= 2 && !pairs.keys.is_empty() => {
                    (t.subdivision(&uncapped), local_pairs(&t, pairs).len())
                }
                _ => (1, 0),
            })
            .collect();
        Self { triangles }
    }

    /// The entries planned under subdivision cap `cap` (an upper bound: pieces without weight
    /// on a pair emit nothing).
    fn entries(&self, cap: u32) -> usize {
        let cap = cap.max(1);
        (self.triangles.iter())
            .map(|&(n, k)| (n.min(cap) as usize).saturating_pow(2).saturating_mul(k))
            .fold(0, usize::saturating_add)
    }

    /// `cap`, halved until the planned entries fit `budget` (down to 1, whatever they are
    /// then: one piece per triangle and pair, the mesh's own size).
    fn cap_within(&self, cap: u32, budget: usize) -> u32 {
        let mut cap = cap.max(1);
        while cap > 1 && self.entries(cap) > budget {
            cap /= 2;
        }
        cap
    }
}

/// One bucket entry before packing: `(pair, w_tj, w_tk, w_tj w_tk A_t, w_tj w_tk A_t c_t)`.
type RawEntry = (u32, f64, f64, f64, [f64; 3]);

/// Lanes of the kernel loop: entries are stored and summed in blocks of `LANES`, which the
/// compiler maps onto SIMD registers.
const LANES: usize = 8;

/// `LANES` bucket entries, structure-of-arrays: `x = w_tj`, `y = w_tk` and the weights
/// `w = (w_tj w_tk A_t, w_tj w_tk A_t c_t)`. Padding lanes are all zero and add exact zeros.
#[derive(Clone, Copy, Debug, Default)]
struct Block {
    x: [f64; LANES],
    y: [f64; LANES],
    w: [[f64; LANES]; 4],
}

/// The subtriangles bucketed per joint pair; bucket `b` is `blocks[offsets[b]..offsets[b + 1]]`.
#[derive(Default)]
struct Buckets {
    offsets: Vec<usize>,
    blocks: Vec<Block>,
    entries: usize,
    subtriangles: usize,
}

impl Buckets {
    /// [`Buckets::build`] within `budget` entries: when `params` make more, the subdivision cap
    /// is lowered ([`Plan::cap_within`]) and the buckets built again; the cap and the entries
    /// the parameters planned are returned then.
    fn within(
        body: &Body,
        params: &CorParams,
        pairs: &PairIndex,
        budget: usize,
    ) -> (Self, Option<(u32, usize)>) {
        if let Some(buckets) = Self::build(body, params, pairs, budget) {
            return (buckets, None);
        }
        let plan = Plan::of(body, params, pairs);
        let cap = plan.cap_within(params.max_subdivision, budget);
        let capped = CorParams {
            max_subdivision: cap,
            ..*params
        };
        // The plan bounds the entries from above: within the budget at `cap`, or the least
        // there is (one piece per triangle and pair).
        let buckets = Self::build(body, &capped, pairs, usize::MAX).unwrap_or_default();
        let lowered = cap < params.max_subdivision.max(1);
        (
            buckets,
            lowered.then(|| (cap, plan.entries(params.max_subdivision))),
        )
    }

    /// Subdivides every triangle (in parallel, chunk results kept in triangle order) and
    /// counting-sorts the entries into their pair buckets; `None` as soon as more than
    /// `budget` entries are made (whatever the threads: the total only grows).
    fn build(body: &Body, params: &CorParams, pairs: &PairIndex, budget: usize) -> Option<Self> {
        let made = AtomicUsize::new(0);
        let chunks: Vec<(Vec<RawEntry>, usize)> = if pairs.keys.is_empty() {
            Vec::new()
        } else {
            body.triangles
                .par_chunks(512)
                .map(|tris| {
                    if made.load(Ordering::Relaxed) > budget {
                        return None;
                    }
                    let mut out = Vec::new();
                    let pieces = tris
                        .iter()
                        .map(|t| emit_triangle(body, t, params, pairs, &mut out))
                        .sum();
                    made.fetch_add(out.len(), Ordering::Relaxed);
                    Some((out, pieces))
                })
                .collect::<Option<_>>()?
        };
        if made.into_inner() > budget {
            return None;
        }
        let mut counts = vec![0usize; pairs.keys.len()];
        for e in chunks.iter().flat_map(|c| &c.0) {
            counts[e.0 as usize] += 1;
        }
        let mut offsets = Vec::with_capacity(counts.len() + 1);
        offsets.push(0);
        for c in &counts {
            offsets.push(offsets[offsets.len() - 1] + c.div_ceil(LANES));
        }
        let mut blocks = vec![Block::default(); offsets[counts.len()]];
        let mut cursor = vec![0usize; counts.len()];
        for &(b, x, y, a, m) in chunks.iter().flat_map(|c| &c.0) {
            let i = cursor[b as usize];
            cursor[b as usize] += 1;
            let (block, l) = (&mut blocks[offsets[b as usize] + i / LANES], i % LANES);
            (block.x[l], block.y[l]) = (x, y);
            for (w, value) in block.w.iter_mut().zip([a, m[0], m[1], m[2]]) {
                w[l] = value;
            }
        }
        Some(Self {
            offsets,
            blocks,
            entries: counts.iter().sum(),
            subtriangles: chunks.iter().map(|c| c.1).sum(),
        })
    }

    /// The blocks of bucket `bucket`.
    fn bucket(&self, bucket: usize) -> &[Block] {
        &self.blocks[self.offsets[bucket]..self.offsets[bucket + 1]]
    }
}

/// Subdivides one triangle and appends an entry per (piece, pair present in some vertex row).
/// Returns the number of pieces.
fn emit_triangle(
    body: &Body,
    tri: &[u32; 3],
    params: &CorParams,
    pairs: &PairIndex,
    out: &mut Vec<RawEntry>,
) -> usize {
    let Some(t) = TriangleData::gather(body, tri) else {
        return 0;
    };
    let area = t.area();
    let n = t.subdivision(params);
    let pieces = (n as usize).pow(2);
    if !(area > 0.0 && area.is_finite()) || t.joints.len() < 2 {
        return pieces;
    }
    let local: Vec<(usize, usize, usize)> = local_pairs(&t, pairs);
    if local.is_empty() {
        return pieces;
    }
    let mut w = vec![0.0; t.joints.len()];
    for_each_piece(n, area, |a, b| {
        for (wj, cw) in w.iter_mut().zip(&t.corner_weights) {
            *wj = b[0] * cw[0] + b[1] * cw[1] + b[2] * cw[2];
        }
        let c =
            t.corners[0].coords * b[0] + t.corners[1].coords * b[1] + t.corners[2].coords * b[2];
        for &(bucket, lo, hi) in &local {
            let (x, y) = (w[lo], w[hi]);
            let f = x * y * a;
            if f > 0.0 {
                out.push((bucket as u32, x, y, f, [f * c.x, f * c.y, f * c.z]));
            }
        }
    });
    pieces
}

/// The pairs of a triangle's joint union that have a bucket: `(bucket, index of the smaller
/// joint, index of the larger joint)` into `t.joints`.
fn local_pairs(t: &TriangleData, pairs: &PairIndex) -> Vec<(usize, usize, usize)> {
    let mut local = Vec::new();
    for a in 0..t.joints.len() {
        for b in a + 1..t.joints.len() {
            let (ja, jb) = (t.joints[a], t.joints[b]);
            if let Some(bucket) = pairs.find(ja, jb) {
                let (lo, hi) = if ja < jb { (a, b) } else { (b, a) };
                local.push((bucket, lo, hi));
            }
        }
    }
    local
}

/// The center of one weight row: `Σ_pairs w_j w_k Σ_bucket e · (x y A c) / (same with x y A)`,
/// plus the number of kernel evaluations. Pairs are visited in the row's order and entries in
/// bucket order, so the sum order is fixed.
fn center_of_row(
    joints: &[u16],
    weights: &[f64],
    pairs: &PairIndex,
    buckets: &Buckets,
    scale: f64,
) -> (Option<Point3<f64>>, u64) {
    let (mut num, mut den, mut evals) = (Vector3::zeros(), 0.0, 0u64);
    for a in 0..joints.len() {
        for b in a + 1..joints.len() {
            let (wa, wb) = (weights[a], weights[b]);
            let vw = wa * wb;
            let Some(bucket) = pairs.find(joints[a], joints[b]).filter(|_| vw > 0.0) else {
                continue;
            };
            // In the bucket, x is the weight of the smaller joint and y of the larger one.
            let (vx, vy) = if joints[a] < joints[b] {
                (wa, wb)
            } else {
                (wb, wa)
            };
            let blocks = buckets.bucket(bucket);
            evals += (blocks.len() * LANES) as u64;
            let (pn, pd) = bucket_sum(blocks, vx * scale, vy * scale);
            num += pn * vw;
            den += pd * vw;
        }
    }
    let center = Point3::from(num / den);
    let valid = den > 0.0 && center.coords.iter().all(|c| c.is_finite());
    (valid.then_some(center), evals)
}

/// `Σ_t exp(-(x_t v_y - y_t v_x)² / σ²) · (x_t y_t A_t, x_t y_t A_t c_t)` over the blocks
/// of one bucket, returned as `(moment, area)`.
///
/// Entry `i` of the bucket is summed into lane `i % LANES`, the lanes are added in order at the
/// end: a fixed order, independent of threads, that lets the loop vectorize. On x86-64 CPUs with
/// AVX2 the same code is compiled for 256-bit registers; Rust never fuses or reorders
/// floating-point operations, so both paths give identical bits.
fn bucket_sum(blocks: &[Block], vx: f64, vy: f64) -> (Vector3<f64>, f64) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { bucket_sum_avx2(blocks, vx, vy) };
        }
    }
    bucket_sum_portable(blocks, vx, vy)
}

/// [`bucket_sum_portable`] compiled for AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn bucket_sum_avx2(blocks: &[Block], vx: f64, vy: f64) -> (Vector3<f64>, f64) {
    bucket_sum_portable(blocks, vx, vy)
}

#[inline(always)]
fn bucket_sum_portable(blocks: &[Block], vx: f64, vy: f64) -> (Vector3<f64>, f64) {
    let mut acc = [[0.0f64; LANES]; 4];
    for b in blocks {
        let e = kernel_lanes(&b.x, &b.y, vx, vy);
        for (acc, w) in acc.iter_mut().zip(&b.w) {
            for l in 0..LANES {
                acc[l] += e[l] * w[l];
            }
        }
    }
    let sum = |a: &[f64; LANES]| a.iter().fold(0.0, |s, x| s + x);
    (
        Vector3::new(sum(&acc[1]), sum(&acc[2]), sum(&acc[3])),
        sum(&acc[0]),
    )
}

/// The similarity kernel `exp(-(x v_y - y v_x)² / σ²)` of `LANES` entries.
#[inline(always)]
fn kernel_lanes(x: &[f64; LANES], y: &[f64; LANES], vx: f64, vy: f64) -> [f64; LANES] {
    let mut e = [0.0f64; LANES];
    for l in 0..LANES {
        let delta = x[l] * vy - y[l] * vx;
        e[l] = exp2_neg(delta * delta);
    }
    e
}

/// `2^-u` for `u ≥ 0` (0 beyond 1020), branch-free so that lanes vectorize: `u = k - x` with
/// `k = round(u)` (exact, `|x| ≤ 1/2`), `2^x` by its degree-13 Taylor polynomial in `x ln 2`
/// (truncation below 1e-17, Estrin's scheme for short dependency chains) and `2^-k` built from
/// the exponent bits. Within a few ulps of `(-u ln 2).exp()`.
#[inline(always)]
fn exp2_neg(u: f64) -> f64 {
    const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2^52: adding it rounds to an integer
    /// `ln(2)^n / n!`.
    const C: [f64; 14] = [
        1.0,
        std::f64::consts::LN_2,
        0.240_226_506_959_100_72,
        0.055_504_108_664_821_58,
        0.009_618_129_107_628_477,
        0.001_333_355_814_642_844_3,
        0.000_154_035_303_933_816_1,
        1.525_273_380_405_984_1e-5,
        1.321_548_679_014_431e-6,
        1.017_808_600_923_97e-7,
        7.054_911_620_801_123e-9,
        4.445_538_271_870_811_6e-10,
        2.567_843_599_348_820_6e-11,
        1.369_148_885_390_412_8e-12,
    ];
    let t = u + MAGIC;
    let k = t - MAGIC;
    let x = k - u;
    let x2 = x * x;
    let x4 = x2 * x2;
    let pair = |i: usize| C[i] + C[i + 1] * x;
    let q0 = pair(0) + pair(2) * x2;
    let q1 = pair(4) + pair(6) * x2;
    let q2 = pair(8) + pair(10) * x2;
    let q3 = pair(12);
    let p = (q0 + q1 * x4) + (q2 + q3 * x4) * (x4 * x4);
    let ki = (t.to_bits() as i64).wrapping_sub(MAGIC.to_bits() as i64);
    let scale = f64::from_bits((1023i64.wrapping_sub(ki) as u64) << 52);
    // Branch-free `if u ≤ 1020 { p · 2^-k } else { 0 }` (also 0 for NaN).
    let keep = u64::from(u <= 1020.0).wrapping_neg();
    f64::from_bits((p * scale).to_bits() & keep)
}

/// The normalized, sign-aligned quaternion blend `Σ_s w_s q_s` of one vertex (signs aligned to
/// the heaviest influence), as a rotation; identity when the blend vanishes.
fn blended_rotation(joints: &[u16], weights: &[f64], split: &[JointDq]) -> UnitQuaternion<f64> {
    let pivot = joints
        .iter()
        .zip(weights)
        .max_by(|a, b| a.1.total_cmp(b.1))
        .and_then(|(&j, _)| split.get(j as usize));
    let Some(q0) = pivot.map(|d| d.real) else {
        return UnitQuaternion::identity();
    };
    let mut q = Quaternion::new(0.0, 0.0, 0.0, 0.0);
    for (&j, &w) in joints.iter().zip(weights) {
        if let Some(r) = split.get(j as usize).map(|d| d.real) {
            q += r * if r.dot(&q0) < 0.0 { -w } else { w };
        }
    }
    UnitQuaternion::try_new(q, 1e-12).unwrap_or_else(UnitQuaternion::identity)
}

/// Skins one vertex with its center: `p' = (Σ w_s M_s) p* + R S̄ (p - p*)`, `n' = R cof(S̄) n` (`S̄`
/// the identity for rigid joints).
fn skin_vertex_cor(
    joints: &[u16],
    weights: &[f64],
    p: &Point3<f64>,
    n: &Vector3<f64>,
    center: &Point3<f64>,
    mats: &[Matrix4<f64>],
    split: &[JointDq],
) -> (Point3<f64>, Vector3<f64>) {
    let mut m = Matrix4::zeros();
    for (&j, &w) in joints.iter().zip(weights) {
        if let Some(mj) = mats.get(j as usize) {
            m += mj * w;
        }
    }
    let r = blended_rotation(joints, weights, split);
    let (offset, normal) = match blended_stretch(joints, weights, split) {
        Some(s) => (s * (p - center), cofactor(&s) * n),
        None => (p - center, *n),
    };
    let p2 = m.transform_point(center) + r * offset;
    (p2, unit_or_zero(r * normal))
}

/// Center-of-rotation skinning of a whole body (Le & Hodgins 2016): vertices with a center use
/// `p' = Σ_s w_s M_s p* + R (p - p*)`, the others plain LBS. A missing center (e.g. `centers`
/// computed for another body) also falls back to LBS.
pub fn skin(body: &Body, centers: &CorCenters, mats: &[Matrix4<f64>]) -> Skinned {
    skin_shape(&body.weights, BindShape::of(body), centers, mats)
}

/// [`skin`] of `shape` (a body's bind shape or a morph of it, whose centers stay the bind
/// shape's) with its `skin_weights`.
pub fn skin_shape(
    skin_weights: &SkinWeights,
    shape: BindShape,
    centers: &CorCenters,
    mats: &[Matrix4<f64>],
) -> Skinned {
    let split = joint_dqs(mats);
    let (positions, normals) = (0..shape.positions.len())
        .into_par_iter()
        .with_min_len(1024)
        .map(|v| {
            let p = &shape.positions[v];
            let n = shape.normals.get(v).copied().unwrap_or_else(Vector3::zeros);
            match centers.centers.get(v).copied().flatten() {
                Some(c) if v < skin_weights.len() => {
                    let (joints, weights) = skin_weights.row_slices(v);
                    skin_vertex_cor(joints, weights, p, &n, &c, mats, &split)
                }
                _ if v < skin_weights.len() => lbs::skin_vertex(skin_weights, v, p, &n, mats),
                _ => (*p, unit_or_zero(n)),
            }
        })
        .unzip();
    Skinned { positions, normals }
}

#[cfg(test)]
mod tests {
    use super::{bucket_sum, bucket_sum_portable, exp2_neg, Block, LANES};

    #[test]
    fn exp2_neg_matches_std() {
        let ln2 = std::f64::consts::LN_2;
        let mut worst = 0.0f64;
        for i in 0..=2_000_000 {
            let u = 1030.0 * f64::from(i) / 2_000_000.0;
            let (a, b) = (exp2_neg(u), (-u * ln2).exp());
            if u <= 1020.0 {
                // (-u ln2) itself is rounded: allow its conditioning, u ulps.
                worst = worst.max((a - b).abs() / b / (1.0 + u * ln2));
            } else {
                assert_eq!(a, 0.0);
            }
        }
        assert!(worst < 4e-16, "relative error {worst:e}");
        assert_eq!(exp2_neg(f64::NAN), 0.0);
        assert_eq!(exp2_neg(f64::INFINITY), 0.0);
    }

    #[test]
    fn dispatched_and_portable_kernels_agree_bitwise() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let blocks: Vec<Block> = (0..37)
            .map(|_| {
                let mut b = Block::default();
                for l in 0..LANES {
                    (b.x[l], b.y[l]) = (next(), next());
                    for w in &mut b.w {
                        w[l] = next();
                    }
                }
                b
            })
            .collect();
        for _ in 0..50 {
            let (vx, vy) = (12.0 * next(), 12.0 * next());
            let (n1, d1) = bucket_sum(&blocks, vx, vy);
            let (n2, d2) = bucket_sum_portable(&blocks, vx, vy);
            assert_eq!(d1.to_bits(), d2.to_bits());
            assert!(n1.iter().zip(&n2).all(|(a, b)| a.to_bits() == b.to_bits()));
        }
    }
}
