//! Sparse symmetric positive definite solves with `faer`: the symbolic analysis (AMD ordering,
//! elimination tree) is done once per sparsity pattern — once per working region, before any
//! frame — and only the numeric Cholesky factorization is redone per frame. The matrix is
//! assembled directly in the ordering and triangle the factorization reads (as faer's
//! `factorize_numeric_llt` would permute it), and the factorization's workspace size is known
//! from the pattern: neither is redone per factorization.
//!
//! Matrices on a region have one value *slot* per vertex (the diagonal) and one per edge
//! (the symmetric off-diagonal pair), so a pattern is built from a region's edge list
//! ([`SpdPattern::new`]) and a matrix is a `Vec<f64>` of slot values ([`SpdPattern::factor`]).
//! A slot may hold 0 (a coupling cut away in this frame): the pattern, hence the symbolic
//! factorization, stays valid. faer runs sequentially here (the crate is built without its
//! `rayon` feature); parallelism goes across frames and regions.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, simplicial, supernodal, CholeskySymbolicParams, LltRef,
    SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::utils::{permute_self_adjoint_scratch, permute_self_adjoint_to_unsorted};
use faer::sparse::{Pair, SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, Mat, Par, Side};
use std::sync::Arc;

/// Why a factorization or solve failed.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// The pattern could not be analysed (out of memory, index overflow).
    #[error("symbolic factorization failed: {0}")]
    Symbolic(String),
    /// The matrix is not numerically positive definite (a singular Laplacian without Dirichlet
    /// values, a negative mass, a non-finite value).
    #[error("Cholesky factorization of the {what} matrix failed: {message}")]
    NotPositiveDefinite {
        /// Which matrix.
        what: &'static str,
        /// faer's message.
        message: String,
    },
    /// The factorization's memory could not be allocated.
    #[error("out of memory for the Cholesky factorization of the {what} matrix")]
    OutOfMemory {
        /// Which matrix.
        what: &'static str,
    },
    /// Slot values do not match the pattern.
    #[error("{got} slot values for a pattern of {expected}")]
    SlotCount {
        /// Expected count.
        expected: usize,
        /// Given count.
        got: usize,
    },
}

/// When faer factorizes supernode by supernode (dense blocks) rather than column by column:
/// above 20 floating-point operations per nonzero of the factor (faer's own default switches
/// at 40, which keeps every working region simplicial). Measured in the pass, both paths
/// timed on the same matrices (the finger, `finger_long`, the mouth and the bending capsule,
/// LBS, 31 frames, one thread): the heat and Poisson matrices of the working regions
/// (1361-3060 unknowns, 20-29 operations per nonzero, AMD ordering) factorize in 0.58-0.74 of
/// the simplicial time and solve in about twice the time (a supernodal solve costs a fifth to
/// a quarter of a supernodal factorization, a simplicial one a fourteenth of a simplicial
/// factorization; two solves per factorization): their factorizations and solves together
/// take 18 % less on `finger_long` (534 → 437 ms over 62 frames). The shared regions' `σ`
/// matrices (280-1080 unknowns, 8-18 per nonzero, one solve each) stay simplicial, where the
/// supernodal factorization is 1.1-1.9 times slower. (The planar grids of `cargo bench --bench
/// solve` fill less: its 2k-vertex grid stays simplicial.)
pub const SUPERNODAL_THRESHOLD: SupernodalThreshold = SupernodalThreshold(0.5);

/// The sparsity pattern of a symmetric matrix on `n` unknowns with the given couplings, and its
/// symbolic Cholesky factorization.
#[derive(Clone, Debug)]
pub struct SpdPattern {
    n: usize,
    edges: Vec<[u32; 2]>,
    /// The pattern permuted by the fill-reducing ordering into the triangle the numeric
    /// factorization reads ([`PermutedPattern`]).
    permuted: SymbolicSparseColMat<usize>,
    llt: Arc<SymbolicCholesky<usize>>,
    /// Position of each slot in the value array of `permuted`.
    slot_position: Vec<usize>,
    /// Workspace of one numeric factorization.
    scratch: StackReq,
}

impl SpdPattern {
    /// Analyses the pattern made of the diagonal and the couplings `edges` (pairs of distinct
    /// unknowns below `n`).
    pub fn new(n: usize, edges: &[[u32; 2]]) -> Result<Self, SolveError> {
        let lower = |a: u32, b: u32| Pair {
            row: a.max(b) as usize,
            col: a.min(b) as usize,
        };
        let mut pairs: Vec<Pair<usize, usize>> = (0..n).map(|i| Pair { row: i, col: i }).collect();
        pairs.extend(edges.iter().map(|e| lower(e[0], e[1])));
        let (symbolic, _) = SymbolicSparseColMat::try_new_from_indices(n, n, &pairs)
            .map_err(|e| SolveError::Symbolic(format!("{e:?}")))?;
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SUPERNODAL_THRESHOLD,
            ..Default::default()
        };
        let llt = factorize_symbolic_cholesky(
            symbolic.as_ref(),
            Side::Lower,
            SymmetricOrdering::Amd,
            params,
        )
        .map_err(|e| SolveError::Symbolic(format!("{e:?}")))?;
        let col_ptr = symbolic.col_ptr();
        let row_idx = symbolic.row_idx();
        let lower_position = pairs.iter().map(|p| {
            let (start, end) = (col_ptr[p.col], col_ptr[p.col + 1]);
            start + row_idx[start..end].binary_search(&p.row).unwrap_or(0)
        });
        let PermutedPattern { pattern, moved_to } = PermutedPattern::new(&symbolic, &llt)?;
        let slot_position = lower_position.map(|p| moved_to[p]).collect();
        Ok(Self {
            n,
            edges: edges.to_vec(),
            permuted: pattern,
            scratch: numeric_scratch(&llt),
            llt: Arc::new(llt),
            slot_position,
        })
    }

    /// Number of unknowns.
    pub fn size(&self) -> usize {
        self.n
    }

    /// Whether the factorization goes supernode by supernode ([`SUPERNODAL_THRESHOLD`]).
    pub fn supernodal(&self) -> bool {
        matches!(self.llt.raw(), SymbolicCholeskyRaw::Supernodal(_))
    }

    /// Number of value slots: `n` diagonal entries then one per coupling.
    pub fn slot_count(&self) -> usize {
        self.slot_position.len()
    }

    /// The couplings, in slot order (slot of coupling `e` is `n + e`).
    pub fn edges(&self) -> &[[u32; 2]] {
        &self.edges
    }

    /// Numeric Cholesky factorization of the matrix given by its slot values.
    pub fn factor(&self, slots: &[f64], what: &'static str) -> Result<Factor, SolveError> {
        if slots.len() != self.slot_count() {
            return Err(SolveError::SlotCount {
                expected: self.slot_count(),
                got: slots.len(),
            });
        }
        let mut values = vec![0.0; self.permuted.row_idx().len()];
        let mut finite = true;
        for (&pos, &v) in self.slot_position.iter().zip(slots) {
            values[pos] += v;
            finite &= v.is_finite();
        }
        // Both of faer's paths reject NaN, but an infinite diagonal passes the simplicial one.
        if !finite {
            return Err(SolveError::NotPositiveDefinite {
                what,
                message: "a non-finite value".to_owned(),
            });
        }
        let mat = SparseColMatRef::new(self.permuted.as_ref(), &values);
        let out_of_memory = SolveError::OutOfMemory { what };
        let mut numeric = Vec::new();
        if numeric.try_reserve_exact(self.llt.len_val()).is_err() {
            return Err(out_of_memory);
        }
        numeric.resize(self.llt.len_val(), 0.0);
        let mut buffer = MemBuffer::try_new(self.scratch).map_err(|_| out_of_memory)?;
        let stack = MemStack::new(&mut buffer);
        // What `SymbolicCholesky::factorize_numeric_llt` does after permuting the matrix.
        let factorized = match self.llt.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => simplicial::factorize_simplicial_numeric_llt(
                &mut numeric,
                mat,
                Default::default(),
                s,
                stack,
            ),
            SymbolicCholeskyRaw::Supernodal(s) => supernodal::factorize_supernodal_numeric_llt(
                &mut numeric,
                mat,
                Default::default(),
                s,
                Par::Seq,
                stack,
                Default::default(),
            ),
        };
        factorized.map_err(|e| SolveError::NotPositiveDefinite {
            what,
            message: format!("{e:?}"),
        })?;
        Ok(Factor {
            symbolic: Arc::clone(&self.llt),
            numeric,
            n: self.n,
        })
    }
}

/// The workspace of one numeric factorization with `llt` (sequential, default parameters):
/// what `SymbolicCholesky::factorize_numeric_llt_scratch` gives but the permuted copy of the
/// matrix, which [`SpdPattern`] assembles itself.
fn numeric_scratch(llt: &SymbolicCholesky<usize>) -> StackReq {
    match llt.raw() {
        SymbolicCholeskyRaw::Simplicial(_) => {
            simplicial::factorize_simplicial_numeric_llt_scratch::<usize, f64>(llt.nrows())
        }
        SymbolicCholeskyRaw::Supernodal(s) => {
            supernodal::factorize_supernodal_numeric_llt_scratch::<usize, f64>(
                s,
                Par::Seq,
                Default::default(),
            )
        }
    }
}

/// The lower-triangular pattern `P A Pᵀ` of a matrix `A`, `P` the fill-reducing ordering of a
/// symbolic factorization, stored in the triangle its numeric factorization reads (lower for
/// the supernodal one, upper for the simplicial one) and in faer's own entry order: what
/// `SymbolicCholesky::factorize_numeric_llt` builds from `A` before every factorization,
/// built once here (same entries in the same order, so the same factor to the bit).
struct PermutedPattern {
    pattern: SymbolicSparseColMat<usize>,
    /// Position in `pattern` of each entry of `A`'s lower-triangular value array.
    moved_to: Vec<usize>,
}

impl PermutedPattern {
    fn new(
        lower: &SymbolicSparseColMat<usize>,
        llt: &SymbolicCholesky<usize>,
    ) -> Result<Self, SolveError> {
        let n = lower.nrows();
        let nnz = lower.row_idx().len();
        let perm = llt
            .perm()
            .ok_or_else(|| SolveError::Symbolic("no fill-reducing ordering".to_owned()))?;
        let out_side = match llt.raw() {
            SymbolicCholeskyRaw::Simplicial(_) => Side::Upper,
            SymbolicCholeskyRaw::Supernodal(_) => Side::Lower,
        };
        // Each entry carries its own position (exact in f64), to read where it went.
        let ids: Vec<f64> = (0..nnz).map(|p| p as f64).collect();
        let (mut new_ids, mut col_ptr, mut row_idx) =
            (vec![0.0; nnz], vec![0; n + 1], vec![0; nnz]);
        let mut buffer = MemBuffer::try_new(permute_self_adjoint_scratch::<usize>(n))
            .map_err(|_| SolveError::OutOfMemory { what: "permuted" })?;
        permute_self_adjoint_to_unsorted(
            &mut new_ids,
            &mut col_ptr,
            &mut row_idx,
            SparseColMatRef::new(lower.as_ref(), &ids),
            perm,
            Side::Lower,
            out_side,
            MemStack::new(&mut buffer),
        );
        let mut moved_to = vec![0; nnz];
        for (q, &id) in new_ids.iter().enumerate() {
            moved_to[id as usize] = q;
        }
        let pattern = SymbolicSparseColMat::new_unsorted_checked(n, n, col_ptr, None, row_idx);
        Ok(Self { pattern, moved_to })
    }
}

/// A numeric Cholesky factorization, reusable for any number of right-hand sides.
#[derive(Debug)]
pub struct Factor {
    symbolic: Arc<SymbolicCholesky<usize>>,
    numeric: Vec<f64>,
    n: usize,
}

impl Factor {
    /// Solves in place for the columns of `m`.
    fn solve_in_place(&self, m: faer::MatMut<'_, f64>) {
        let llt = LltRef::<usize, f64>::new(&self.symbolic, &self.numeric);
        let scratch = self
            .symbolic
            .solve_in_place_scratch::<f64>(m.ncols(), Par::Seq);
        let mut buffer = MemBuffer::new(scratch);
        llt.solve_in_place_with_conj(Conj::No, m, Par::Seq, MemStack::new(&mut buffer));
    }

    /// Solves `A x = b` in place for one right-hand side.
    pub fn solve(&self, b: &mut [f64]) {
        let mut m = Mat::from_fn(self.n, 1, |i, _| b[i]);
        self.solve_in_place(m.as_mut());
        for (i, x) in b.iter_mut().enumerate() {
            *x = m[(i, 0)];
        }
    }

    /// Solves `A X = B` in place for `K` right-hand sides stored per unknown (e.g. 3D vectors).
    pub fn solve_many<const K: usize>(&self, b: &mut [[f64; K]]) {
        let mut m = Mat::from_fn(self.n, K, |i, j| b[i][j]);
        self.solve_in_place(m.as_mut());
        for (i, row) in b.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = m[(i, j)];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// A chain-plus-chords pattern and a diagonally dominant SPD matrix on it.
    fn example() -> (usize, Vec<[u32; 2]>, Vec<f64>) {
        let n = 12;
        let mut edges: Vec<[u32; 2]> = (0..n as u32 - 1).map(|i| [i, i + 1]).collect();
        edges.extend([[0, 5], [3, 9], [2, 11], [7, 4]]);
        let mut slots = vec![0.0; n + edges.len()];
        for (e, edge) in edges.iter().enumerate() {
            let w = -0.3 - 0.1 * (e % 4) as f64;
            slots[n + e] = w;
            slots[edge[0] as usize] -= w;
            slots[edge[1] as usize] -= w;
        }
        for (i, s) in slots.iter_mut().take(n).enumerate() {
            *s += 0.5 + 0.01 * i as f64;
        }
        (n, edges, slots)
    }

    fn dense(n: usize, edges: &[[u32; 2]], slots: &[f64]) -> DMatrix<f64> {
        let mut a = DMatrix::zeros(n, n);
        for i in 0..n {
            a[(i, i)] = slots[i];
        }
        for (e, edge) in edges.iter().enumerate() {
            let (i, j) = (edge[0] as usize, edge[1] as usize);
            a[(i, j)] += slots[n + e];
            a[(j, i)] += slots[n + e];
        }
        a
    }

    #[test]
    fn factor_and_solve_match_a_dense_solve() {
        let (n, edges, slots) = example();
        let pattern = SpdPattern::new(n, &edges).expect("symbolic");
        let factor = pattern.factor(&slots, "test").expect("numeric");
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
        let mut x = b.clone();
        factor.solve(&mut x);
        let expect = dense(n, &edges, &slots)
            .lu()
            .solve(&DVector::from_vec(b.clone()))
            .expect("dense");
        for i in 0..n {
            assert!((x[i] - expect[i]).abs() < 1e-12);
        }
        let mut many: Vec<[f64; 3]> = b.iter().map(|&v| [v, 2.0 * v, -v]).collect();
        factor.solve_many(&mut many);
        for i in 0..n {
            assert!((many[i][1] - 2.0 * expect[i]).abs() < 1e-12);
        }
    }

    /// The graph Laplacian plus `0.1 I` of a closed tube (a `k × k` torus grid, each quad
    /// split in two): fill like a working region's, hence the supernodal path.
    fn torus(k: u32) -> (usize, Vec<[u32; 2]>, Vec<f64>) {
        let id = |i: u32, j: u32| (i % k) * k + j % k;
        let mut edges = Vec::new();
        for i in 0..k {
            for j in 0..k {
                let v = id(i, j);
                edges.extend([[v, id(i + 1, j)], [v, id(i, j + 1)], [v, id(i + 1, j + 1)]]);
            }
        }
        let n = (k * k) as usize;
        let mut slots = vec![0.1; n];
        for e in &edges {
            slots[e[0] as usize] += 1.0;
            slots[e[1] as usize] += 1.0;
        }
        slots.extend(edges.iter().map(|_| -1.0));
        (n, edges, slots)
    }

    #[test]
    fn both_factorization_paths_solve_to_round_off() {
        for (k, supernodal) in [(3, false), (40, true)] {
            let (n, edges, slots) = torus(k);
            let pattern = SpdPattern::new(n, &edges).expect("symbolic");
            assert_eq!(pattern.supernodal(), supernodal, "{n} unknowns");
            let factor = pattern.factor(&slots, "test").expect("numeric");
            let b: Vec<[f64; 2]> = (0..n)
                .map(|i| [(i as f64 * 0.37).sin(), (i as f64 * 0.11).cos()])
                .collect();
            let mut x = b.clone();
            factor.solve_many(&mut x);
            // The residual A x - b, from the slots directly.
            let mut r: Vec<[f64; 2]> = (0..n)
                .map(|i| [slots[i] * x[i][0] - b[i][0], slots[i] * x[i][1] - b[i][1]])
                .collect();
            for (e, &[a, c]) in edges.iter().enumerate() {
                let (a, c, w) = (a as usize, c as usize, slots[n + e]);
                for d in 0..2 {
                    r[a][d] += w * x[c][d];
                    r[c][d] += w * x[a][d];
                }
            }
            let worst = r.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(worst < 1e-10, "{n} unknowns: residual {worst:e}");
            // Indefinite and non-finite matrices are typed errors on both paths.
            let mut bad = slots.clone();
            bad[n / 2] = -50.0;
            assert!(matches!(
                pattern.factor(&bad, "test"),
                Err(SolveError::NotPositiveDefinite { .. })
            ));
            for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                bad[n / 2] = v;
                assert!(
                    matches!(
                        pattern.factor(&bad, "test"),
                        Err(SolveError::NotPositiveDefinite { .. })
                    ),
                    "{n} unknowns: {v}"
                );
            }
        }
    }

    /// faer's own path: the lower-triangular matrix of `slots` in sorted CSC, permuted and
    /// factorized by `SymbolicCholesky::factorize_numeric_llt`.
    fn faer_factor(pattern: &SpdPattern, slots: &[f64]) -> Vec<f64> {
        let n = pattern.size();
        let mut triplets: Vec<faer::sparse::Triplet<usize, usize, f64>> = (0..n)
            .map(|i| faer::sparse::Triplet::new(i, i, slots[i]))
            .collect();
        for (e, &[a, b]) in pattern.edges().iter().enumerate() {
            let (row, col) = (a.max(b) as usize, a.min(b) as usize);
            triplets.push(faer::sparse::Triplet::new(row, col, slots[n + e]));
        }
        let lower = faer::sparse::SparseColMat::try_new_from_triplets(n, n, &triplets)
            .expect("lower matrix");
        let mut numeric = vec![0.0; pattern.llt.len_val()];
        let scratch = pattern
            .llt
            .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default());
        let mut buffer = MemBuffer::new(scratch);
        pattern
            .llt
            .factorize_numeric_llt(
                &mut numeric,
                lower.as_ref(),
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .expect("faer's factorization");
        numeric
    }

    #[test]
    fn the_matrix_assembled_permuted_gives_faers_factor_to_the_bit() {
        for k in [3, 40] {
            let (n, edges, slots) = torus(k);
            let pattern = SpdPattern::new(n, &edges).expect("symbolic");
            let ours = pattern.factor(&slots, "test").expect("numeric").numeric;
            let faers = faer_factor(&pattern, &slots);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&ours), bits(&faers), "{n} unknowns");
        }
    }

    #[test]
    fn zero_slots_keep_the_pattern_valid() {
        let (n, edges, mut slots) = example();
        let pattern = SpdPattern::new(n, &edges).expect("symbolic");
        slots[n + 3] = 0.0; // a coupling cut away this frame
        slots[n] = 0.0;
        pattern.factor(&slots, "test").expect("still SPD");
    }

    #[test]
    fn indefinite_and_mismatched_inputs_are_typed_errors() {
        let (n, edges, mut slots) = example();
        let pattern = SpdPattern::new(n, &edges).expect("symbolic");
        assert!(matches!(
            pattern.factor(&slots[1..], "test"),
            Err(SolveError::SlotCount { .. })
        ));
        slots[4] = -10.0;
        assert!(matches!(
            pattern.factor(&slots, "test"),
            Err(SolveError::NotPositiveDefinite { .. })
        ));
        slots[4] = f64::NAN;
        assert!(pattern.factor(&slots, "test").is_err());
    }
}
