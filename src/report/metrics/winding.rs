//! The generalized winding number (Jacobson et al. 2013) and its fast tree (Barill et al. 2018).

use super::bvh::{Bvh, Node};
use super::*;

/// Signed solid angle of the triangle `t` seen from `q` (Van Oosterom & Strackee 1983):
/// `tan(Ω/2) = det[a b c] / (|a||b||c| + (a·b)|c| + (b·c)|a| + (c·a)|b|)` with `a, b, c` the
/// corners relative to `q`. Positive when `q` is behind the triangle (on the side opposite its
/// counter-clockwise normal), in `(-2π, 2π)`; 0 when `q` is on a corner or an input is not
/// finite.
pub fn solid_angle(t: &[Point3<f64>; 3], q: &Point3<f64>) -> f64 {
    let (a, b, c) = (t[0] - q, t[1] - q, t[2] - q);
    let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
    let num = a.dot(&b.cross(&c));
    let den = la * lb * lc + a.dot(&b) * lc + b.dot(&c) * la + c.dot(&a) * lb;
    let omega = 2.0 * num.atan2(den);
    if omega.is_finite() {
        omega
    } else {
        0.0
    }
}

/// Generalized winding number of the triangle soup at `q` (Jacobson et al. 2013): the sum of
/// the signed solid angles of its faces ([`solid_angle`]) over 4π, by brute force (O(faces)).
///
/// For a closed, outward-oriented surface it is 1 inside, 0 outside (k inside k nested or
/// overlapping bodies), and varies continuously for open surfaces. Faces with an out-of-range
/// index or a non-finite corner are ignored; a non-finite `q` gives 0. See [`WindingNumber`]
/// for many queries.
pub fn winding_number(positions: &[Point3<f64>], triangles: &[[u32; 3]], q: &Point3<f64>) -> f64 {
    if !finite(q) {
        return 0.0;
    }
    let sum: f64 = triangles
        .iter()
        .filter_map(|t| corners(positions, t))
        .map(|t| solid_angle(&t, q))
        .sum();
    sum / (4.0 * PI)
}

/// Far-field data of one tree node (Barill et al. 2018, Sec. 3.2): area-weighted center
/// `p̃`, the moments `N = ∫ n dA`, `M = ∫ (x - p̃) nᵀ dA` and
/// `C[j][k] = ∫ (x - p̃)_j (x - p̃)_k n dA` (exact for flat triangles), and the radius of the
/// ball around `p̃` holding the node's faces.
#[derive(Clone, Copy, Debug)]
struct Moments {
    center: Point3<f64>,
    area: f64,
    radius: f64,
    n: Vector3<f64>,
    m: Matrix3<f64>,
    c: [[Vector3<f64>; 3]; 3],
}

impl Moments {
    fn of(tris: &[[Point3<f64>; 3]], node: &Node) -> Self {
        let slots = &tris[node.slots()];
        let (mut area, mut weighted) = (0.0, Vector3::zeros());
        for t in slots {
            let a = 0.5 * double_area_vector(t).norm();
            area += a;
            weighted += a * (t[0].coords + t[1].coords + t[2].coords) / 3.0;
        }
        let center = if area > 0.0 && (weighted / area).iter().all(|x| x.is_finite()) {
            Point3::from(weighted / area)
        } else {
            nalgebra::center(&node.min, &node.max)
        };
        let mut n = Vector3::zeros();
        let mut m = Matrix3::zeros();
        let mut c = [[Vector3::zeros(); 3]; 3];
        let mut radius: f64 = 0.0;
        for t in slots {
            let an = 0.5 * double_area_vector(t); // A n
            let area = an.norm();
            let centroid = (t[0].coords + t[1].coords + t[2].coords) / 3.0;
            let d = centroid - center.coords;
            n += an;
            m += d * an.transpose();
            // ∫ (x - p̃)(x - p̃)ᵀ dA = A (d dᵀ + 1/12 Σ (v - c)(v - c)ᵀ).
            let mut second = d * d.transpose();
            if area > 0.0 {
                for v in t {
                    let e = v.coords - centroid;
                    second += e * e.transpose() / 12.0;
                }
            }
            // A leaf's C is symmetric in (j, k) to the bit, as `second` is (a sum of products
            // x_j x_k): the upper half, mirrored below. (A merged node's is not: `merge` adds
            // its terms in another order for (j, k) and (k, j).)
            for j in 0..3 {
                for k in j..3 {
                    c[j][k] += an * second[(j, k)];
                }
            }
            for v in t {
                radius = radius.max((v - center).norm());
            }
        }
        for (j, k) in [(1, 0), (2, 0), (2, 1)] {
            c[j][k] = c[k][j];
        }
        Moments {
            center,
            area,
            radius,
            n,
            m,
            c,
        }
    }

    /// The moments of the union of two nodes from theirs (parallel-axis shifts to the
    /// area-weighted center of the union; the radius is an upper bound).
    fn merge(a: &Moments, b: &Moments, node: &Node) -> Moments {
        let area = a.area + b.area;
        let weighted = a.center.coords * a.area + b.center.coords * b.area;
        let center = if area > 0.0 && (weighted / area).iter().all(|x| x.is_finite()) {
            Point3::from(weighted / area)
        } else {
            nalgebra::center(&node.min, &node.max)
        };
        let mut out = Moments {
            center,
            area,
            radius: 0.0,
            n: a.n + b.n,
            m: Matrix3::zeros(),
            c: [[Vector3::zeros(); 3]; 3],
        };
        for child in [a, b] {
            let delta = child.center - center;
            // ∫ (x - p) nᵀ = M + δ Nᵀ; ∫ (x - p)_j (x - p)_k n = C_jk + δ_k Σ_j + δ_j Σ_k + δ_j δ_k N
            // with Σ_j = ∫ (x - p̃)_j n = row j of M.
            out.m += child.m + delta * child.n.transpose();
            for j in 0..3 {
                let row_j: Vector3<f64> = child.m.row(j).transpose();
                for k in 0..3 {
                    let row_k: Vector3<f64> = child.m.row(k).transpose();
                    out.c[j][k] += child.c[j][k]
                        + row_j * delta[k]
                        + row_k * delta[j]
                        + child.n * (delta[j] * delta[k]);
                }
            }
            out.radius = out.radius.max(child.radius + delta.norm());
        }
        out
    }
}

/// What a query reads of a node's [`Moments`]: its ball and the coefficients of the
/// second-order expansion (Barill et al. 2018, Sec. 3.2) gathered per power of the unit
/// direction `u = (p̃ - q)/d`, so that a far-field evaluation is a handful of products rather
/// than the 27 contractions of `C`. The node's `4π ×` winding number at `q` is
/// `u·N / d² + (tr M + uᵀ Q u) / d³ + (u·E + T(u)) / d⁴`, with
/// - `Q = -3 (M + Mᵀ)/2` (from `Σ_ij ∂_j f_i M_ji`, `∂_j f_i = (δ_ij - 3 u_i u_j) / d³`, for
///   the integrand `f(x)·n` with `f(x) = (x - q)/|x - q|³`);
/// - `E_k = -3/2 (2 Σ_j C_jkj + Σ_j C_jjk)` and `T(u) = 15/2 Σ_ijk u_i u_j u_k C_jki`, from
///   `½ Σ_ijk ∂_j∂_k f_i C_jki` with
///   `∂_j∂_k f_i = (-3 (δ_ij u_k + δ_ik u_j + δ_jk u_i) + 15 u_i u_j u_k) / d⁴`; `T` is kept as
///   the ten coefficients of its symmetrized cubic form.
#[derive(Clone, Copy, Debug)]
struct Expansion {
    center: Point3<f64>,
    radius: f64,
    n: Vector3<f64>,
    trace: f64,
    /// `Q`'s `xx, yy, zz` and twice its `xy, xz, yz`.
    q: [f64; 6],
    e: Vector3<f64>,
    /// `T`'s coefficients of `x³, y³, z³, x²y, x²z, xy², y²z, xz², yz², xyz`.
    t: [f64; 10],
}

/// Position in [`Expansion::t`] of the monomial `u_i u_j u_k`, at `[i][j][k]`.
const CUBIC_SLOT: [[[usize; 3]; 3]; 3] = [
    [[0, 3, 4], [3, 5, 9], [4, 9, 7]],
    [[3, 5, 9], [5, 1, 6], [9, 6, 8]],
    [[4, 9, 7], [9, 6, 8], [7, 8, 2]],
];

impl Expansion {
    fn of(mo: &Moments) -> Self {
        let sym = (mo.m + mo.m.transpose()) * -1.5;
        let q = [
            sym[(0, 0)],
            sym[(1, 1)],
            sym[(2, 2)],
            2.0 * sym[(0, 1)],
            2.0 * sym[(0, 2)],
            2.0 * sym[(1, 2)],
        ];
        let mut e = Vector3::zeros();
        let mut t = [0.0; 10];
        for j in 0..3 {
            for k in 0..3 {
                e[k] += 2.0 * mo.c[j][k][j] + mo.c[j][j][k];
                for i in 0..3 {
                    t[CUBIC_SLOT[i][j][k]] += 7.5 * mo.c[j][k][i];
                }
            }
        }
        Expansion {
            center: mo.center,
            radius: mo.radius,
            n: mo.n,
            trace: mo.m.trace(),
            q,
            e: e * -1.5,
            t,
        }
    }

    /// `4π ×` the node's winding number at `q` by its second-order Taylor expansion about the
    /// center, with `r = p̃ - q`, `d = |r| > 0` (the expansion of [`Expansion`]'s doc).
    #[inline]
    fn far_field(&self, r: &Vector3<f64>, d: f64) -> f64 {
        let u = r / d;
        let (x, y, z) = (u.x, u.y, u.z);
        let inv_d2 = 1.0 / (d * d);
        let order0 = u.dot(&self.n);
        let q = &self.q;
        let quadratic =
            q[0] * x * x + q[1] * y * y + q[2] * z * z + q[3] * x * y + q[4] * x * z + q[5] * y * z;
        let order1 = (self.trace + quadratic) / d;
        let t = &self.t;
        let (xx, yy, zz) = (x * x, y * y, z * z);
        let cubic = x * (t[0] * xx + t[5] * yy + t[7] * zz + t[9] * y * z)
            + y * (t[1] * yy + t[3] * xx + t[8] * zz)
            + z * (t[2] * zz + t[4] * xx + t[6] * yy);
        let order2 = (u.dot(&self.e) + cubic) * inv_d2;
        let w = (order0 + order1 + order2) * inv_d2;
        if w.is_finite() {
            w
        } else {
            0.0
        }
    }
}

/// Fast generalized winding number of one triangle soup, for many query points (Barill et al.
/// 2018, "Fast winding numbers for soups and clouds").
///
/// Built once per surface: a median-split BVH over the faces, and for every node the moments of
/// a second-order Taylor expansion of the solid-angle integrand about the node's area-weighted
/// center. A query descends the tree; a node farther than β × its radius from the query point
/// contributes its expansion (far field), a leaf reached otherwise contributes its exact solid
/// angles (near field). At β = 2 the absolute error stays below 1e-2 (at most 7e-3 measured on
/// the spheres, capsule and torus of `tests/metrics.rs`, whether the point is near the surface
/// or not), so rounding classifies inside/outside exactly off the surface; a larger β is more
/// accurate and slower. Cost: about 200 times faster than the brute force on a 20k-face sphere.
///
/// Faces with an out-of-range index or a non-finite corner are left out (counted by
/// [`WindingNumber::skipped_faces`]); a non-finite query point gives 0.
#[derive(Clone, Debug)]
pub struct WindingNumber {
    pub(super) bvh: Bvh,
    moments: Vec<Moments>,
    /// Per node, what a query reads ([`Expansion::of`] its moments).
    expansions: Vec<Expansion>,
    beta: f64,
    skipped: usize,
    /// Whether every inner node's moments are its children's merged (after any refit; a
    /// built tree computes them from its faces): [`WindingNumber::refit_changed`]'s condition.
    merged: bool,
    /// The positions of the last refit (empty before one): which vertices moved since, for
    /// [`WindingNumber::refit_changed`].
    fitted_at: Vec<Point3<f64>>,
}

impl WindingNumber {
    /// Precomputes the tree for the surface `triangles` over `positions`, with β =
    /// [`WINDING_BETA`].
    pub fn new(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> Self {
        Self::with_beta(positions, triangles, WINDING_BETA)
    }

    /// As [`WindingNumber::new`] with the accuracy parameter β (larger is more accurate and
    /// slower; a non-finite or negative β is taken as [`WINDING_BETA`]; β = ∞ is the brute
    /// force).
    pub fn with_beta(positions: &[Point3<f64>], triangles: &[[u32; 3]], beta: f64) -> Self {
        Self::with_faces_beta(positions, triangles, 0..triangles.len() as u32, beta)
    }

    /// [`WindingNumber::with_beta`] for the surface of `faces` alone (indices into
    /// `triangles`, which refits and queries read with these faces only).
    pub fn with_faces_beta(
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        faces: impl Iterator<Item = u32>,
        beta: f64,
    ) -> Self {
        let (bvh, skipped) = Bvh::build(positions, triangles, faces);
        let moments: Vec<Moments> = bvh
            .nodes
            .par_iter()
            .map(|n| Moments::of(&bvh.tris, n))
            .collect();
        let expansions = moments.iter().map(Expansion::of).collect();
        let beta = if beta.is_nan() || beta < 0.0 {
            WINDING_BETA
        } else {
            beta
        };
        Self {
            bvh,
            moments,
            expansions,
            beta,
            skipped,
            merged: false,
            fitted_at: Vec::new(),
        }
    }

    /// Updates the tree to new `positions` of the same `triangles` (same topology), in
    /// `O(faces)`: the split of the faces is kept, boxes and moments are recomputed bottom-up
    /// (leaves exactly, inner nodes by merging their children's moments). Queries stay within
    /// the same accuracy (the node radii become upper bounds, so slightly more of the tree is
    /// evaluated exactly). Returns `false`, leaving the tree unchanged, when a corner is not
    /// finite or the triangles do not match (rebuild with [`WindingNumber::new`] then).
    pub fn refit(&mut self, positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> bool {
        let Some(tris) = self.corners_of(positions, triangles) else {
            return false;
        };
        self.bvh.tris = tris;
        let mut fitted = vec![false; self.bvh.nodes.len()];
        for i in (0..self.bvh.nodes.len()).rev() {
            self.refit_node(i, &mut fitted);
        }
        self.merged = true;
        self.fitted_at.clear();
        self.fitted_at.extend_from_slice(positions);
        true
    }

    /// [`WindingNumber::refit`] that recomputes only the leaves holding a face with a corner
    /// that moved (bit for bit) since the last refit and their ancestors: a node's box and
    /// moments depend on its faces' corners only, so the result is [`WindingNumber::refit`]'s
    /// to the bit once the inner nodes are merges of their children (after any refit; on a
    /// tree as built, whose inner moments come from their faces, this is a whole refit). For a
    /// mesh that a few regions at a time move (the folds of one body, one after the other).
    /// The moved vertices are found against the last refit's positions, then only their faces'
    /// corners are read (`triangles` must be the tree's own; a non-finite moved corner leaves
    /// the tree unchanged and returns `false`, as [`WindingNumber::refit`] does).
    pub fn refit_changed(&mut self, positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> bool {
        if !self.merged || self.fitted_at.len() != positions.len() {
            return self.refit(positions, triangles);
        }
        let bits = |p: &Point3<f64>| p.coords.map(f64::to_bits);
        let moved_vertex: Vec<bool> = positions
            .iter()
            .zip(&self.fitted_at)
            .map(|(p, q)| bits(p) != bits(q))
            .collect();
        // Per slot whose face has a moved corner, its corners now.
        let mut moved: Vec<(usize, [Point3<f64>; 3])> = Vec::new();
        for (slot, &f) in self.bvh.faces.iter().enumerate() {
            let Some(t) = triangles.get(f as usize) else {
                return false;
            };
            if t.iter()
                .any(|&v| moved_vertex.get(v as usize) != Some(&false))
            {
                let Some(c) = corners(positions, t) else {
                    return false;
                };
                moved.push((slot, c));
            }
        }
        let mut stale_slot = vec![false; self.bvh.tris.len()];
        for (slot, c) in moved {
            self.bvh.tris[slot] = c;
            stale_slot[slot] = true;
        }
        self.fitted_at.copy_from_slice(positions);
        // Per node: recomputed in this call (children come after their parent).
        let mut fitted = vec![false; self.bvh.nodes.len()];
        for i in (0..self.bvh.nodes.len()).rev() {
            let node = self.bvh.nodes[i];
            let stale = if node.is_leaf() {
                stale_slot[node.slots()].iter().any(|&m| m)
            } else {
                fitted[i + 1] || fitted[node.right as usize]
            };
            if stale {
                self.refit_node(i, &mut fitted);
            }
        }
        true
    }

    /// The corners of every slot's face at `positions` (`None`: a corner is not finite or a
    /// face is out of range).
    fn corners_of(
        &self,
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
    ) -> Option<Vec<[Point3<f64>; 3]>> {
        self.bvh
            .faces
            .iter()
            .map(|&f| {
                triangles
                    .get(f as usize)
                    .and_then(|t| corners(positions, t))
            })
            .collect()
    }

    /// Recomputes node `i`'s box and moments from its slots' corners (a leaf) or its
    /// children's (an inner node), and marks it in `fitted`.
    fn refit_node(&mut self, i: usize, fitted: &mut [bool]) {
        let node = self.bvh.nodes[i];
        if node.is_leaf() {
            let (mut lo, mut hi) = (
                Point3::from(Vector3::repeat(f64::INFINITY)),
                Point3::from(Vector3::repeat(f64::NEG_INFINITY)),
            );
            for t in &self.bvh.tris[node.slots()] {
                for p in t {
                    lo = lo.inf(p);
                    hi = hi.sup(p);
                }
            }
            self.bvh.nodes[i].min = lo;
            self.bvh.nodes[i].max = hi;
            self.moments[i] = Moments::of(&self.bvh.tris, &self.bvh.nodes[i]);
        } else {
            let (l, r) = (i + 1, node.right as usize);
            let (a, b) = (self.bvh.nodes[l], self.bvh.nodes[r]);
            self.bvh.nodes[i].min = a.min.inf(&b.min);
            self.bvh.nodes[i].max = a.max.sup(&b.max);
            self.moments[i] =
                Moments::merge(&self.moments[l], &self.moments[r], &self.bvh.nodes[i]);
        }
        self.expansions[i] = Expansion::of(&self.moments[i]);
        fitted[i] = true;
    }

    /// Faces left out because of an out-of-range index or a non-finite corner.
    pub fn skipped_faces(&self) -> usize {
        self.skipped
    }

    /// Winding number at `q` (0 for a non-finite `q` or an empty surface).
    pub fn query(&self, q: &Point3<f64>) -> f64 {
        if !finite(q) || self.bvh.nodes.is_empty() {
            return 0.0;
        }
        let mut sum = 0.0;
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = &self.bvh.nodes[i as usize];
            let ex = &self.expansions[i as usize];
            let r = ex.center - q;
            let d = r.norm();
            if d > self.beta * ex.radius {
                sum += ex.far_field(&r, d);
            } else if node.is_leaf() {
                sum += self.bvh.tris[node.slots()]
                    .iter()
                    .map(|t| solid_angle(t, q))
                    .sum::<f64>();
            } else {
                stack.push(node.right);
                stack.push(i + 1);
            }
        }
        let w = sum / (4.0 * PI);
        if w.is_finite() {
            w
        } else {
            0.0
        }
    }

    /// Winding numbers at every point of `qs`, in parallel, in the order of `qs` (the same bits
    /// as calling [`WindingNumber::query`] on each).
    pub fn query_many(&self, qs: &[Point3<f64>]) -> Vec<f64> {
        qs.par_iter()
            .with_min_len(64)
            .map(|q| self.query(q))
            .collect()
    }
}
