//! The heat method with a source curve on edges (2021 paper Sec. 5.1, after Crane et al. 2013),
//! and harmonic diffusion of scalars and vectors with the same machinery (Sec. 5.2, 5.3).
//!
//! The source is the boundary `∂C` of a region `C` (a contact zone): its exact points on edges
//! are inserted as Dirichlet nodes of a *cut mesh*, as `PIPELINE.md` prescribes. Imposing
//! `(1 - α) v_i + α v_j = 1` as exact constraints instead collapses on a closed curve (as many
//! constraints as band vertices: `v = 1` on the whole band). Each face crossed by `∂C` is
//! replaced by its outside part (one or two triangles), `K` (cotangent stiffness) and `M`
//! (lumped mass) are assembled on it, the boundary nodes are eliminated into the right-hand
//! side, and vertices inside `C` get identity rows. Couplings between two outside vertices are
//! always original edges of the region, so the region's symbolic factorization
//! ([`RegionSolver`], computed once) serves every frame: one numeric factorization per matrix,
//! no Schur complement. Vertices may also be Dirichlet nodes themselves (a point source).
//!
//! Steps (Crane et al. 2013, Algorithm 1, with Dirichlet data):
//! 1. `(M + t K) u = 0` on free vertices with `u = 1` on the source, `t = m h²`
//!    ([`HeatParams::time_factor`] `m`, default 10 as in `PIPELINE.md`, `h` the mean edge length
//!    of the region in the current frame);
//! 2. `X = -∇u / |∇u|` per (sub)triangle;
//! 3. `K φ = b` with `b_i = Σ_f A_f X_f·∇φ_i` and `φ = 0` on the source.
//!
//! Components of the outside that no Dirichlet node reaches get identity rows and are reported
//! in [`CutProblem::unreached`] (distance `+∞`, harmonic value 0).

mod cut;

pub use cut::{band_faces, Boundary, CutMesh, EdgePoint, HeatError};

use crate::mesh::Region;
use crate::solve::{Factor, SolveError, SpdPattern};
use nalgebra::{Point3, Vector3};

/// Parameters of the heat method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeatParams {
    /// Time step factor `m` in `t = m h²`.
    pub time_factor: f64,
}

impl Default for HeatParams {
    fn default() -> Self {
        Self { time_factor: 10.0 }
    }
}

/// What is precomputed once per working region: its topology and the symbolic factorization
/// of its pattern (diagonal + edges).
#[derive(Clone, Debug)]
pub struct RegionSolver {
    /// The region.
    pub region: Region,
    /// Its sparsity pattern and symbolic Cholesky factorization.
    pub pattern: SpdPattern,
}

impl RegionSolver {
    /// Analyses `region` (symbolic factorization).
    pub fn new(region: Region) -> Result<Self, SolveError> {
        let pattern = SpdPattern::new(region.vertex_count(), &region.edges)?;
        Ok(Self { region, pattern })
    }

    /// Builds this frame's problem: the cut mesh for `boundary` at region-local `positions`.
    pub fn problem(
        &self,
        positions: &[Point3<f64>],
        boundary: &Boundary,
    ) -> Result<CutProblem<'_>, HeatError> {
        let cut = CutMesh::new(&self.region, positions, boundary)?;
        Ok(CutProblem {
            solver: self,
            cut,
            stiffness: None,
            factor_seconds: std::cell::Cell::new(0.0),
        })
    }
}

/// One frame's solves on a cut mesh. The stiffness factorization is computed on first use
/// and shared by the distance's Poisson step and every harmonic diffusion.
#[derive(Debug)]
pub struct CutProblem<'a> {
    solver: &'a RegionSolver,
    /// The cut mesh.
    pub cut: CutMesh,
    stiffness: Option<Factor>,
    factor_seconds: std::cell::Cell<f64>,
}

impl CutProblem<'_> {
    /// Seconds spent in numeric factorizations so far (the paper's Table 1 column s.).
    pub fn factorization_seconds(&self) -> f64 {
        self.factor_seconds.get()
    }

    fn add_factor_time(&self, start: std::time::Instant) {
        self.factor_seconds
            .set(self.factor_seconds.get() + start.elapsed().as_secs_f64());
    }

    /// Vertices no Dirichlet node reaches (identity rows).
    pub fn unreached(&self) -> &[bool] {
        &self.cut.unreached
    }

    fn stiffness_factor(&mut self) -> Result<&Factor, HeatError> {
        if self.stiffness.is_none() {
            let slots = self.cut.stiffness_slots(&self.solver.pattern);
            let start = std::time::Instant::now();
            self.stiffness = Some(self.solver.pattern.factor(&slots, "stiffness")?);
            self.add_factor_time(start);
        }
        self.stiffness
            .as_ref()
            .ok_or(HeatError::Internal("stiffness factor"))
    }

    /// Geodesic distance `φ` from the source (0 on it and inside `C`, `+∞` where unreached).
    pub fn distance(&mut self, params: HeatParams) -> Result<Vec<f64>, HeatError> {
        let u = self.heat(params)?;
        let mut b = self.cut.normalized_gradient_load(&u);
        let zeros = vec![0.0; self.cut.dirichlet_count()];
        self.cut.apply_dirichlet(&mut b, &zeros, 1.0);
        self.stiffness_factor()?.solve(&mut b);
        for (v, x) in b.iter_mut().enumerate() {
            if self.cut.unreached[v] {
                *x = f64::INFINITY;
            } else if !self.cut.is_free(v) {
                *x = 0.0;
            }
        }
        Ok(b)
    }

    /// Step 1: the heat `u` after time `t = m h²`, with `u = 1` on the source.
    pub fn heat(&self, params: HeatParams) -> Result<Vec<f64>, HeatError> {
        let h = self.cut.mean_edge_length;
        let t = params.time_factor * h * h;
        if !(t > 0.0 && t.is_finite()) {
            return Err(HeatError::DegenerateRegion);
        }
        let slots = self.cut.heat_slots(&self.solver.pattern, t);
        let start = std::time::Instant::now();
        let factor = self.solver.pattern.factor(&slots, "heat")?;
        self.add_factor_time(start);
        let ones = vec![1.0; self.cut.dirichlet_count()];
        let mut b = vec![0.0; self.cut.vertex_count()];
        self.cut.apply_dirichlet(&mut b, &ones, t);
        for (v, x) in b.iter_mut().enumerate() {
            if !self.cut.is_free(v) {
                *x = if self.cut.unreached[v] { 0.0 } else { 1.0 };
            }
        }
        factor.solve(&mut b);
        Ok(b)
    }

    /// Harmonic interpolation (`K x = 0`, natural Neumann on the region border) of the scalar
    /// Dirichlet `values` (one per boundary point, then one per Dirichlet vertex).
    pub fn harmonic(&mut self, values: &[f64]) -> Result<Vec<f64>, HeatError> {
        self.cut.check_values(values.len())?;
        let mut b = vec![0.0; self.cut.vertex_count()];
        self.cut.apply_dirichlet(&mut b, values, 1.0);
        self.cut.set_fixed_rows(&mut b, values);
        self.stiffness_factor()?.solve(&mut b);
        Ok(b)
    }

    /// Harmonic interpolation of 3-vector Dirichlet values (component-wise, one solve with
    /// three right-hand sides).
    pub fn harmonic_vector(
        &mut self,
        values: &[Vector3<f64>],
    ) -> Result<Vec<Vector3<f64>>, HeatError> {
        self.cut.check_values(values.len())?;
        let mut cols: Vec<[f64; 3]> = vec![[0.0; 3]; self.cut.vertex_count()];
        for c in 0..3 {
            let comp: Vec<f64> = values.iter().map(|v| v[c]).collect();
            let mut b = vec![0.0; self.cut.vertex_count()];
            self.cut.apply_dirichlet(&mut b, &comp, 1.0);
            self.cut.set_fixed_rows(&mut b, &comp);
            for (row, x) in cols.iter_mut().zip(&b) {
                row[c] = *x;
            }
        }
        self.stiffness_factor()?.solve_many(&mut cols);
        Ok(cols.into_iter().map(Vector3::from).collect())
    }
}

/// `u = φ / φ_max`, clamped to `[0, 1]` (1 where unreached).
pub fn normalized_distance(phi: &[f64], phi_max: f64) -> Vec<f64> {
    phi.iter().map(|&p| (p / phi_max).clamp(0.0, 1.0)).collect()
}
