//! Sparse per-vertex skin weights.

/// Per-vertex joint influences in compressed rows: vertex `v` has the influences
/// `offsets[v]..offsets[v + 1]` of `joints` / `weights`. Rows hold only positive weights,
/// sorted by joint index, summing to 1.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkinWeights {
    /// Row starts, `len = vertex count + 1`.
    pub offsets: Vec<u32>,
    /// Joint index (into the skin's joint list) of each influence.
    pub joints: Vec<u16>,
    /// Weight of each influence.
    pub weights: Vec<f64>,
}

impl SkinWeights {
    /// An empty table for `vertex_capacity` vertices.
    pub fn with_capacity(vertex_capacity: usize) -> Self {
        let mut offsets = Vec::with_capacity(vertex_capacity + 1);
        offsets.push(0);
        Self {
            offsets,
            joints: Vec::with_capacity(vertex_capacity * 4),
            weights: Vec::with_capacity(vertex_capacity * 4),
        }
    }

    /// `n` vertices each bound to joint 0 with weight 1 (a rigid body).
    pub fn rigid(n: usize) -> Self {
        Self {
            offsets: (0..=n as u32).collect(),
            joints: vec![0; n],
            weights: vec![1.0; n],
        }
    }

    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// True when there is no vertex.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Appends the row of one vertex. The influences must already be positive, merged per
    /// joint, sorted by joint and normalized (see `normalize_row`).
    pub fn push_row(&mut self, row: &[(u16, f64)]) {
        for &(j, w) in row {
            self.joints.push(j);
            self.weights.push(w);
        }
        self.offsets.push(self.joints.len() as u32);
    }

    /// The influences `(joint, weight)` of vertex `v`.
    pub fn row(&self, v: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let (a, b) = (self.offsets[v] as usize, self.offsets[v + 1] as usize);
        self.joints[a..b]
            .iter()
            .zip(&self.weights[a..b])
            .map(|(&j, &w)| (j as usize, w))
    }

    /// Joint indices and weights of vertex `v` as slices.
    pub fn row_slices(&self, v: usize) -> (&[u16], &[f64]) {
        let (a, b) = (self.offsets[v] as usize, self.offsets[v + 1] as usize);
        (&self.joints[a..b], &self.weights[a..b])
    }

    /// Weight of `joint` at vertex `v` (0 when it has no influence).
    pub fn weight(&self, v: usize, joint: usize) -> f64 {
        self.row(v)
            .find(|&(j, _)| j == joint)
            .map_or(0.0, |(_, w)| w)
    }
}

/// What [`normalize_row`] had to fix in one row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RowFixes {
    /// Some weight was NaN, infinite or negative and was dropped.
    pub dropped_invalid: bool,
    /// The weights did not sum to 1 (beyond 2e-3, the glTF validator's tolerance) and were rescaled.
    pub renormalized: bool,
    /// All weights were zero or invalid.
    pub empty: bool,
}

/// Cleans one vertex's raw influences: drops non-finite and non-positive weights, merges
/// duplicated joints, sorts by joint and rescales to a sum of 1. An empty result is reported
/// in [`RowFixes::empty`]; the caller decides the fallback.
pub fn normalize_row(raw: &[(u16, f64)], out: &mut Vec<(u16, f64)>) -> RowFixes {
    let mut fixes = RowFixes::default();
    out.clear();
    for &(j, w) in raw {
        if !w.is_finite() || w < 0.0 {
            fixes.dropped_invalid = true;
            continue;
        }
        if w == 0.0 {
            continue;
        }
        match out.iter_mut().find(|(jj, _)| *jj == j) {
            Some(entry) => entry.1 += w,
            None => out.push((j, w)),
        }
    }
    out.sort_unstable_by_key(|&(j, _)| j);
    let sum: f64 = out.iter().map(|&(_, w)| w).sum();
    if out.is_empty() || sum <= 0.0 {
        out.clear();
        fixes.empty = true;
        return fixes;
    }
    if (sum - 1.0).abs() > 2e-3 {
        fixes.renormalized = true;
    }
    for entry in out.iter_mut() {
        entry.1 /= sum;
    }
    fixes
}
