//! Discrete operators on a triangle mesh (P1 finite elements): face areas and normals, vertex
//! normals, the cotangent stiffness matrix, the lumped mass, per-face gradients and the
//! matching vertex divergence (Crane, Weischedel, Wardetzky 2013, "Geodesics in Heat", Sec. 3.2).
//!
//! Sign conventions: the stiffness `K = Σ_f A_f ∇φ_i·∇φ_j` is positive semi-definite
//! (`K_ij = -½ (cot α_ij + cot β_ij)` off the diagonal), and the divergence of a face field `X`
//! is the load vector `b_i = Σ_f A_f X_f·∇φ_i`, so that `K φ = b` is the least-squares fit
//! `∇φ ≈ X`.
//!
//! **Degenerate faces.** A face whose area is below [`DEGENERATE_AREA`] times its longest edge
//! squared (angles below about 1e-10 rad: collinear or repeated corners) contributes nothing:
//! no stiffness, no mass, zero gradient. Every other face contributes its exact P1 stiffness,
//! which is positive semi-definite however obtuse or needle-like the face is, so `K` stays PSD
//! and finite. We do not clamp individual cotangents (that can break the per-face PSD
//! property) and do not use an intrinsic Delaunay Laplacian (its edge flips change the sparsity
//! pattern from frame to frame, which would defeat the symbolic factorization computed once per
//! working region).

use nalgebra::{Point3, Vector3};

/// Relative area below which a face is treated as degenerate (see the module doc).
pub const DEGENERATE_AREA: f64 = 1e-10;

/// The per-face quantities every operator needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceGeometry {
    /// Area (0 for a degenerate face).
    pub area: f64,
    /// Unit normal (zero for a degenerate face).
    pub normal: Vector3<f64>,
    /// `cot` of the angle at each corner (0 for a degenerate face).
    pub cot: [f64; 3],
    /// Gradient of the hat function of each corner, `N × e_i / (2A)` with `e_i` the edge
    /// opposite corner `i` (zero for a degenerate face).
    pub grad: [Vector3<f64>; 3],
}

impl FaceGeometry {
    /// Computes the geometry of the triangle `p`.
    pub fn new(p: [Point3<f64>; 3]) -> Self {
        let e = [p[2] - p[1], p[0] - p[2], p[1] - p[0]];
        let cross = e[2].cross(&(-e[1]));
        let double_area = cross.norm();
        let longest = e.iter().map(|v| v.norm_squared()).fold(0.0, f64::max);
        let usable = double_area.is_finite() && double_area > 2.0 * DEGENERATE_AREA * longest;
        if !usable {
            return Self::degenerate();
        }
        let normal = cross / double_area;
        let cot = std::array::from_fn(|i| {
            let (a, b) = (-e[(i + 2) % 3], e[(i + 1) % 3]);
            a.dot(&b) / double_area
        });
        let grad = std::array::from_fn(|i| normal.cross(&e[i]) / double_area);
        Self {
            area: 0.5 * double_area,
            normal,
            cot,
            grad,
        }
    }

    /// The zero contribution of a degenerate face.
    pub fn degenerate() -> Self {
        Self {
            area: 0.0,
            normal: Vector3::zeros(),
            cot: [0.0; 3],
            grad: [Vector3::zeros(); 3],
        }
    }

    /// Whether the face was found degenerate.
    pub fn is_degenerate(&self) -> bool {
        self.area == 0.0
    }

    /// Stiffness coupling of corners `i` and `j != i`: `-½ cot` of the third corner's angle.
    pub fn stiffness(&self, i: usize, j: usize) -> f64 {
        -0.5 * self.cot[3 - i - j]
    }

    /// Gradient of the linear interpolant of corner values `u`.
    pub fn gradient(&self, u: [f64; 3]) -> Vector3<f64> {
        self.grad[0] * u[0] + self.grad[1] * u[1] + self.grad[2] * u[2]
    }
}

/// Geometry of every face.
pub fn face_geometry(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> Vec<FaceGeometry> {
    triangles
        .iter()
        .map(|t| FaceGeometry::new(t.map(|i| positions[i as usize])))
        .collect()
}

/// Lumped (barycentric) mass: a third of the area of every incident face.
pub fn lumped_mass(
    vertex_count: usize,
    triangles: &[[u32; 3]],
    faces: &[FaceGeometry],
) -> Vec<f64> {
    let mut m = vec![0.0; vertex_count];
    for (t, g) in triangles.iter().zip(faces) {
        for &v in t {
            m[v as usize] += g.area / 3.0;
        }
    }
    m
}

/// How vertex normals weight their incident faces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalWeighting {
    /// By face area.
    Area,
    /// By the corner angle (Thürmer & Wüthrich 1998): independent of the tessellation.
    Angle,
}

/// Unit vertex normals (zero where no non-degenerate face touches the vertex).
pub fn vertex_normals(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    weighting: NormalWeighting,
) -> Vec<Vector3<f64>> {
    let mut n = vec![Vector3::zeros(); positions.len()];
    for t in triangles {
        let p = t.map(|i| positions[i as usize]);
        let e = [p[2] - p[1], p[0] - p[2], p[1] - p[0]];
        let cross = e[2].cross(&(-e[1]));
        let double_area = cross.norm();
        let longest = e.iter().map(|v| v.norm_squared()).fold(0.0, f64::max);
        // The same degeneracy test as `FaceGeometry::new`.
        if !(double_area.is_finite() && double_area > 2.0 * DEGENERATE_AREA * longest) {
            continue;
        }
        let unit = cross / double_area;
        for k in 0..3 {
            let w = match weighting {
                NormalWeighting::Area => 0.5 * double_area,
                NormalWeighting::Angle => {
                    let (a, b) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                    a.angle(&b)
                }
            };
            n[t[k] as usize] += unit * w;
        }
    }
    for v in &mut n {
        *v = v.try_normalize(1e-300).unwrap_or_else(Vector3::zeros);
    }
    n
}

/// Per-face gradient of a per-vertex scalar field.
pub fn gradient(triangles: &[[u32; 3]], faces: &[FaceGeometry], u: &[f64]) -> Vec<Vector3<f64>> {
    triangles
        .iter()
        .zip(faces)
        .map(|(t, g)| g.gradient(t.map(|i| u[i as usize])))
        .collect()
}

/// Integrated divergence of a per-face vector field: `b_i = Σ_f A_f X_f·∇φ_i` (the load vector
/// of the least-squares problem `∇φ ≈ X`).
pub fn divergence(
    vertex_count: usize,
    triangles: &[[u32; 3]],
    faces: &[FaceGeometry],
    x: &[Vector3<f64>],
) -> Vec<f64> {
    let mut b = vec![0.0; vertex_count];
    for ((t, g), xf) in triangles.iter().zip(faces).zip(x) {
        for k in 0..3 {
            b[t[k] as usize] += g.area * xf.dot(&g.grad[k]);
        }
    }
    b
}

/// Mean edge length over the faces (each interior edge counted twice); 0 without faces.
pub fn mean_edge_length(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for t in triangles {
        for k in 0..3 {
            sum += (positions[t[k] as usize] - positions[t[(k + 1) % 3] as usize]).norm();
            n += 1;
        }
    }
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> [Point3<f64>; 3] {
        [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(2.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ]
    }

    #[test]
    fn gradient_of_a_linear_function_is_exact() {
        let p = tri();
        let g = FaceGeometry::new(p);
        let f = |q: &Point3<f64>| 3.0 * q.x - 2.0 * q.y + 7.0;
        let grad = g.gradient(p.map(|q| f(&q)));
        assert!((grad - Vector3::new(3.0, -2.0, 0.0)).norm() < 1e-14);
        assert!((g.area - 1.0).abs() < 1e-15);
        assert!((g.normal - Vector3::z()).norm() < 1e-15);
    }

    #[test]
    fn stiffness_matches_the_hat_gradients() {
        let g = FaceGeometry::new(tri());
        for i in 0..3 {
            for j in 0..3 {
                if i != j {
                    let direct = g.area * g.grad[i].dot(&g.grad[j]);
                    assert!((direct - g.stiffness(i, j)).abs() < 1e-14);
                }
            }
        }
    }

    #[test]
    fn needles_are_finite_and_collinear_faces_vanish() {
        let needle = FaceGeometry::new([
            Point3::origin(),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.5, 1e-7, 0.0),
        ]);
        assert!(!needle.is_degenerate());
        assert!(needle.cot.iter().all(|c| c.is_finite()));
        let flat = FaceGeometry::new([
            Point3::origin(),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(2.0, 0.0, 0.0),
        ]);
        assert!(flat.is_degenerate());
        let repeated = FaceGeometry::new([
            Point3::origin(),
            Point3::origin(),
            Point3::new(2.0, 0.0, 0.0),
        ]);
        assert!(repeated.is_degenerate());
        let nan = FaceGeometry::new([
            Point3::origin(),
            Point3::new(f64::NAN, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ]);
        assert!(nan.is_degenerate());
    }

    #[test]
    fn divergence_is_minus_the_adjoint_of_the_gradient() {
        // <div X, u> = Σ_f A_f X_f·∇u_f for every u (discrete integration by parts).
        let pos = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.2),
            Point3::new(0.0, 1.0, -0.1),
            Point3::new(1.0, 1.3, 0.4),
        ];
        let tris = vec![[0, 1, 2], [1, 3, 2]];
        let faces = face_geometry(&pos, &tris);
        let x = vec![Vector3::new(0.3, -1.0, 2.0), Vector3::new(-0.5, 0.1, 0.7)];
        let u = [0.4, -1.2, 2.5, 0.9];
        let b = divergence(4, &tris, &faces, &x);
        let lhs: f64 = b.iter().zip(&u).map(|(a, c)| a * c).sum();
        let grad = gradient(&tris, &faces, &u);
        let rhs: f64 = faces
            .iter()
            .zip(&grad)
            .zip(&x)
            .map(|((f, g), xf)| f.area * g.dot(xf))
            .sum();
        assert!((lhs - rhs).abs() < 1e-13);
    }
}
