//! Morph targets (glTF 2.0 §3.7.2.2): per-vertex displacements of a mesh's POSITION and
//! NORMAL, weighted and added to the bind shape before skinning,
//! `p = p_bind + Σ_k w_k Δp_k`, `n = normalize(n_bind + Σ_k w_k Δn_k)`.
//!
//! A mesh's primitives all have the same number of targets (the specification requires it): a
//! body keeps target `k` of every primitive concatenated, as it keeps their positions. A
//! target stores only its non-zero displacements (a face shape moves the face), so morphing
//! costs a copy of the bind shape and the displaced vertices (`cargo bench --bench skinning`,
//! 2026-12-06: 10 weighted blend shapes of 2k vertices take LBS on 30k vertices from 0.53-0.56
//! to 0.69-0.81 ms on two threads; the morph runs on one). The weights are the node's
//! `weights`, else the mesh's, else zeros, unless an animation's `weights` channel drives the
//! node ([`crate::rig::Pose::morph_weights`]).
//!
//! Not read: TANGENT displacements (nothing here uses tangents). The welded topology and the
//! centers of rotation come from the bind shape without morphs (the shape the inverse bind
//! matrices refer to); the contact passes' rest geometry (working regions, partition of unity,
//! rest crossings) is the rest pose as evaluated, the default weights applied (the character
//! as the file shows it without animation); each frame's skinning and contact passes see the
//! surface morphed by that frame's weights.

use nalgebra::{Point3, Vector3};

/// One morph target of a body: its non-zero displacements, by increasing vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MorphTarget {
    /// `(file vertex, ΔPOSITION)`.
    pub positions: Vec<(u32, Vector3<f64>)>,
    /// `(file vertex, ΔNORMAL)`.
    pub normals: Vec<(u32, Vector3<f64>)>,
}

/// A body's morph targets and its default weights.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Morphs {
    /// The targets, in the file's order (target `k` of every primitive, concatenated).
    pub targets: Vec<MorphTarget>,
    /// The node's `weights`, else the mesh's, else zeros; one per target.
    pub default_weights: Vec<f64>,
    /// The body's normals were computed from its triangles (the file has no NORMAL): a morphed
    /// shape's normals are recomputed from its positions the same way.
    pub normals_from_triangles: bool,
}

/// A morphed bind shape: positions and unit normals per file vertex.
#[derive(Clone, Debug, PartialEq)]
pub struct MorphedShape {
    /// Positions.
    pub positions: Vec<Point3<f64>>,
    /// Unit normals (zero where the sum is zero).
    pub normals: Vec<Vector3<f64>>,
}

impl MorphTarget {
    /// Number of displacements it holds (POSITION and NORMAL).
    pub fn len(&self) -> usize {
        self.positions.len() + self.normals.len()
    }

    /// Whether it displaces nothing.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty() && self.normals.is_empty()
    }
}

impl Morphs {
    /// Number of targets.
    pub fn len(&self) -> usize {
        self.targets.len()
    }

    /// Whether the body has no target.
    pub fn is_empty(&self) -> bool {
        self.targets.is_empty()
    }

    /// The bind shape (`positions`, `normals`, `triangles`) morphed by `weights` (one per
    /// target: missing ones count as 0, extra and non-finite ones are ignored); `None` when no
    /// target has a non-zero weight, the bind shape being the shape.
    pub fn apply(
        &self,
        weights: &[f64],
        positions: &[Point3<f64>],
        normals: &[Vector3<f64>],
        triangles: &[[u32; 3]],
    ) -> Option<MorphedShape> {
        let active: Vec<(&MorphTarget, f64)> = (self.targets.iter().zip(weights))
            .filter(|&(_, &w)| w != 0.0 && w.is_finite())
            .map(|(t, &w)| (t, w))
            .collect();
        if active.is_empty() {
            return None;
        }
        let mut moved = positions.to_vec();
        for &(target, w) in &active {
            add_weighted(&mut moved, &target.positions, w, |p, d| p.coords += d);
        }
        let normals = if self.normals_from_triangles {
            super::load::area_weighted_normals(&moved, triangles)
        } else {
            // Only the displaced normals are summed and normalized again: the others stay the
            // bind normals to the bit.
            let mut turned = normals.to_vec();
            let mut touched: Vec<u32> = Vec::new();
            for &(target, w) in &active {
                add_weighted(&mut turned, &target.normals, w, |n, d| *n += d);
                touched.extend(target.normals.iter().map(|&(v, _)| v));
            }
            touched.sort_unstable();
            touched.dedup();
            for v in touched {
                if let Some(n) = turned.get_mut(v as usize) {
                    *n = crate::skinning::unit_or_zero(*n);
                }
            }
            turned
        };
        Some(MorphedShape {
            positions: moved,
            normals,
        })
    }
}

/// Adds `w Δ` to `values[v]` for every `(v, Δ)` of `deltas` within range.
fn add_weighted<T>(
    values: &mut [T],
    deltas: &[(u32, Vector3<f64>)],
    w: f64,
    add: impl Fn(&mut T, Vector3<f64>),
) {
    for &(v, d) in deltas {
        if let Some(x) = values.get_mut(v as usize) {
            add(x, d * w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square's positions, normals (+z) and two triangles.
    type Square = (Vec<Point3<f64>>, Vec<Vector3<f64>>, Vec<[u32; 3]>);

    fn square() -> Square {
        let p = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(1.0, 1.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ];
        (p, vec![Vector3::z(); 4], vec![[0, 1, 2], [0, 2, 3]])
    }

    fn lift(v: u32, dz: f64) -> MorphTarget {
        MorphTarget {
            positions: vec![(v, Vector3::new(0.0, 0.0, dz))],
            normals: vec![(v, Vector3::new(1.0, 0.0, -1.0))],
        }
    }

    #[test]
    fn weighted_displacements_add_to_the_bind_shape() {
        let (p, n, t) = square();
        let morphs = Morphs {
            targets: vec![lift(2, 1.0), lift(2, 4.0), lift(0, 8.0)],
            ..Morphs::default()
        };
        assert_eq!(morphs.apply(&[0.0, 0.0, 0.0], &p, &n, &t), None);
        assert_eq!(morphs.apply(&[], &p, &n, &t), None);
        let shape = morphs
            .apply(&[0.5, 0.25, f64::NAN], &p, &n, &t)
            .expect("a weight is non-zero");
        // 0.5 · 1 + 0.25 · 4 along z; the NaN weight of target 2 is ignored.
        assert_eq!(shape.positions[2], Point3::new(1.0, 1.0, 1.5));
        assert_eq!(shape.positions[0], p[0]);
        // n + 0.75 (1, 0, -1) = (0.75, 0, 0.25), normalized.
        let expected = Vector3::new(0.75, 0.0, 0.25).normalize();
        assert!((shape.normals[2] - expected).norm() < 1e-15);
        assert_eq!(shape.normals[1], Vector3::z());
    }

    #[test]
    fn normals_computed_from_triangles_are_recomputed() {
        let (p, _, t) = square();
        let n = crate::rig::load::area_weighted_normals(&p, &t);
        let morphs = Morphs {
            targets: vec![lift(1, 1.0)],
            default_weights: vec![1.0],
            normals_from_triangles: true,
        };
        let shape = morphs.apply(&[1.0], &p, &n, &t).expect("morphed");
        // Vertex 1, of face [0, 1, 2] alone, lifted to (1, 0, 1): the face's normal is
        // (1, 0, 1) × (1, 1, 0) = (-1, 1, 1), normalized.
        let slope = Vector3::new(-1.0, 1.0, 1.0).normalize();
        assert!(
            (shape.normals[1] - slope).norm() < 1e-12,
            "{}",
            shape.normals[1]
        );
    }
}
