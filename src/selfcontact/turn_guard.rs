//! The turn guard of a fold: where the blended displacement would turn a face over, the
//! displacement of its corners is scaled back just enough that it does not. Not in the paper.
//!
//! A face is *turned* when its normal points more than 90° away from both its input normal and
//! its reference normal (the rest normal carried by the skinning), the criterion of
//! [`crate::report::metrics::turned_faces`]; the guard stops faces at 85° (`MARGIN`). The
//! second reference lets a fold undo the loop that LBS makes at a bent joint (input faces
//! turned against the skinning) without counting it. Faces still turned after `ROUNDS`
//! rounds are left as they are (not met on the rigs and samples). Why: where the crease cut pins a vertex next to a zone vertex sent 2-3 edge lengths
//! along the mapping direction (DQS and CoR input, whose inner joint folds over along `d̂`;
//! the coarse torso of a real character), the faces between them turned over; they show as
//! dark creases in shading. The guard trades them for vertices left short of the contact
//! surface (measured in the fold's doc, [`crate::selfcontact::fold::FoldParams::turn_guard`]).
//!
//! Per face the scale is just short of the first `t ∈ [0, 1]` at which the face, its corners
//! at `x_i + t s_i d_i` (`d_i` the displacement, `s_i` the corner's scale so far), turns
//! (sampled, then bisected; the fold's input, `t = 0`, should not be turned, each fold having
//! been guarded); each corner keeps the smallest scale of its faces, and the faces are checked
//! again with the new scales, a few rounds. The scale leaves 1 only as a face reaches the
//! turning point. It follows the first crossing, which moves continuously with the positions
//! except where two crossings meet, finer than the samples can tell.

use nalgebra::{Point3, Vector3};

/// Rounds of checking the faces again after scaling (each round settles the faces whose
/// corners a neighbour's scale moved).
const ROUNDS: usize = 8;
/// How far short of 90° from both references a face is stopped: `cos 85°`. The pass's
/// reference was linear blend skinning's normal whatever skinning made the input (a DQS or CoR
/// input carries its normals by other rotations, which differ by a few degrees at the joint);
/// without the margin faces within those degrees of turning were let through (bending
/// capsule, worst frame: 2 with CoR input, 1 with DQS). Since 2026-12-03 `pose` gives the
/// pass the skinning's own normals (`SelfContactPass::run_with_normals`), the metric's
/// reference; the margin stays for callers of `SelfContactPass::run`, which keeps LBS's.
const MARGIN: f64 = 0.087_155_742_747_658_17;
/// Evenly spaced parameters sampled for a face's first turning point before the bisection.
const SAMPLES: usize = 16;
/// Bisection steps for one face's scale (the turning point to `2^-30` of the displacement).
const BISECTION_STEPS: usize = 30;

/// What a face must not turn against: the frame's input (before any fold of any sweep:
/// folds follow each other on the same positions) and the skinning's normals.
#[derive(Clone, Copy)]
pub struct TurnReference<'a> {
    /// The frame's input positions (their face normals are the first reference).
    pub positions: &'a [Point3<f64>],
    /// The skinning's normal of a vertex (a face's second reference is the sum over its
    /// corners), asked for the corners of the faces turned against the first reference only.
    pub normal: &'a (dyn Fn(usize) -> Vector3<f64> + Sync),
}

/// The faces a fold may move and what they are checked against.
pub struct GuardInput<'a> {
    /// Mesh triangles.
    pub triangles: &'a [[u32; 3]],
    /// The faces to check (ids into `triangles`).
    pub faces: &'a [u32],
    /// Positions before this fold (the displacement starts there; no face of them should be
    /// turned against `reference`, each fold having been guarded).
    pub input: &'a [Point3<f64>],
    /// The references.
    pub reference: TurnReference<'a>,
}

/// Per vertex, the factor in `[0, 1]` of its displacement `output - input` that keeps every
/// face of `g.faces` from turning over; `None` when no face turns at full displacement.
pub fn displacement_scales(g: &GuardInput, output: &[Point3<f64>]) -> Option<Vec<f64>> {
    let displacement: Vec<Vector3<f64>> = g.input.iter().zip(output).map(|(x, y)| y - x).collect();
    let mut scale = vec![1.0; g.input.len()];
    // After the first round only the faces with a corner scaled in the round before can turn.
    let mut changed: Option<Vec<bool>> = None;
    let mut any = false;
    for _ in 0..ROUNDS {
        let mut next = scale.clone();
        let mut turned = false;
        for &f in g.faces {
            let t = g.triangles[f as usize];
            let moving = |v: &u32| displacement[*v as usize] != Vector3::zeros();
            let stale = changed
                .as_ref()
                .is_some_and(|c| !t.iter().any(|&v| c[v as usize]));
            if stale || !t.iter().any(moving) {
                continue;
            }
            let moved =
                t.map(|v| g.input[v as usize] + displacement[v as usize] * scale[v as usize]);
            let first = area_vector(t.map(|v| g.reference.positions[v as usize]));
            if !below(&area_vector(moved), &first) {
                continue;
            }
            let face = GuardedFace::new(g, &displacement, &scale, t);
            if !face.turned_at(1.0) {
                continue;
            }
            turned = true;
            let keep = face.first_turning_scale();
            for v in t {
                let v = v as usize;
                next[v] = next[v].min(scale[v] * keep);
            }
        }
        if !turned {
            break;
        }
        any = true;
        changed = Some(next.iter().zip(&scale).map(|(a, b)| a != b).collect());
        scale = next;
    }
    any.then_some(scale)
}

/// Whether `output` turns over a face of `g.faces` that `g.input` did not have turned: its
/// normal more than 90° away from both references, the criterion of
/// [`crate::report::metrics::turned_faces`] (not the guard's 85°). What a fold checks its
/// output against when its guard and volume solves did not settle
/// ([`crate::selfcontact::fold::FoldOutput::unbalanced`]). As in [`displacement_scales`],
/// the skinning's normals are asked for the faces turned against the first reference only.
pub fn turns_over(g: &GuardInput, output: &[Point3<f64>]) -> bool {
    g.faces.iter().any(|&f| {
        let t = g.triangles[f as usize];
        let first = area_vector(t.map(|v| g.reference.positions[v as usize]));
        let normal = |p: &[Point3<f64>]| area_vector(t.map(|v| p[v as usize]));
        let (after, before) = (normal(output), normal(g.input));
        if after.dot(&first) >= 0.0 {
            return false;
        }
        let reference: Vector3<f64> = t.iter().map(|&v| (g.reference.normal)(v as usize)).sum();
        let over = |n: &Vector3<f64>| n.dot(&first) < 0.0 && n.dot(&reference) < 0.0;
        over(&after) && !over(&before)
    })
}

/// One face of the guard: its corners moving along their (scaled) displacements.
struct GuardedFace {
    start: [Point3<f64>; 3],
    motion: [Vector3<f64>; 3],
    input_normal: Vector3<f64>,
    reference: Vector3<f64>,
}

impl GuardedFace {
    fn new(g: &GuardInput, displacement: &[Vector3<f64>], scale: &[f64], t: [u32; 3]) -> Self {
        Self {
            start: t.map(|v| g.input[v as usize]),
            motion: t.map(|v| displacement[v as usize] * scale[v as usize]),
            input_normal: area_vector(t.map(|v| g.reference.positions[v as usize])),
            reference: t.iter().map(|&v| (g.reference.normal)(v as usize)).sum(),
        }
    }

    /// Whether the face, its corners moved by `t` times their motion, is turned against both
    /// references. A face degenerate in the frame's input has no orientation to keep: never
    /// turned.
    fn turned_at(&self, t: f64) -> bool {
        let moved = [0, 1, 2].map(|k| self.start[k] + self.motion[k] * t);
        let n = area_vector(moved);
        below(&n, &self.input_normal) && below(&n, &self.reference)
    }

    /// Just short of the first `t ∈ [0, 1]` at which the face turns: the first of
    /// [`SAMPLES`] evenly spaced parameters that is turned, then bisection between it and the
    /// one before. Turning is not monotone in `t` (the normal is quadratic in it and must pass
    /// both references), and a bare bisection could land on a later crossing and jump between
    /// crossings as the positions move. 0 if the fold's input is turned already (it should
    /// not be, each fold having been guarded; its corners then keep none of this fold's
    /// displacement).
    fn first_turning_scale(&self) -> f64 {
        if self.turned_at(0.0) {
            return 0.0;
        }
        let step = 1.0 / SAMPLES as f64;
        let first = (1..=SAMPLES)
            .map(|k| k as f64 * step)
            .find(|&t| self.turned_at(t))
            .unwrap_or(1.0);
        let (mut lo, mut hi) = (first - step, first);
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            if self.turned_at(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        lo
    }
}

/// Whether `n` is more than `acos(MARGIN)` away from `reference`.
fn below(n: &Vector3<f64>, reference: &Vector3<f64>) -> bool {
    n.dot(reference) < MARGIN * n.norm() * reference.norm()
}

/// Twice the area vector of a triangle.
fn area_vector(p: [Point3<f64>; 3]) -> Vector3<f64> {
    (p[1] - p[0]).cross(&(p[2] - p[0]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles sharing the edge 1-2 in the plane `z = 0`, facing +Z (the reference).
    fn hinge() -> (Vec<[u32; 3]>, Vec<Point3<f64>>) {
        let x = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, -1.0, 0.0),
            Point3::new(1.0, 1.0, 0.0),
            Point3::new(2.0, 0.0, 0.0),
        ];
        (vec![[0, 1, 2], [1, 3, 2]], x)
    }

    /// The guard's scales of `output` against `input` (also the frame's input) and +Z.
    fn scales(
        tris: &[[u32; 3]],
        input: &[Point3<f64>],
        output: &[Point3<f64>],
    ) -> Option<Vec<f64>> {
        let g = GuardInput {
            triangles: tris,
            faces: &[0, 1],
            input,
            reference: TurnReference {
                positions: input,
                normal: &|_| Vector3::z(),
            },
        };
        displacement_scales(&g, output)
    }

    /// `turns_over`: a face pushed past its edge turns over (against both references), one
    /// tilted short of edge-on does not (the guard's 85° is not the criterion), and a face
    /// already turned in the fold's input is not counted again.
    #[test]
    fn turns_over_counts_the_faces_a_fold_turns_past_90_degrees() {
        let (tris, x) = hinge();
        let over = |input: &[Point3<f64>], output: &[Point3<f64>]| {
            let g = GuardInput {
                triangles: &tris,
                faces: &[0, 1],
                input,
                reference: TurnReference {
                    positions: &x,
                    normal: &|_| Vector3::z(),
                },
            };
            turns_over(&g, output)
        };
        let mut past = x.clone();
        past[3].x = 0.5; // past the edge at x = 1: the second face faces -Z
        let mut steep = x.clone();
        steep[3] = Point3::new(1.01, 0.0, 1.0); // 89.4° from +Z, not past it
        assert!(!over(&x, &x));
        assert!(over(&x, &past));
        assert!(!over(&x, &steep));
        assert!(!over(&past, &past), "turned in the input already");
    }

    #[test]
    fn a_face_pushed_past_its_edge_stops_short_of_it() {
        let (tris, x) = hinge();
        let mut y = x.clone();
        y[3].x = -1.0; // 3 units toward -X: past the edge at x = 1 after 1 unit
        let s = scales(&tris, &x, &y).expect("the second face turns");
        assert_eq!(s[0], 1.0);
        // Stopped at 5° short of edge-on, within the 1/3 that reaches the edge.
        assert!(s[3] > 0.0 && s[3] < 1.0 / 3.0, "scale {}", s[3]);
        let guarded: Vec<Point3<f64>> = (0..4).map(|v| x[v] + (y[v] - x[v]) * s[v]).collect();
        let n = area_vector([guarded[1], guarded[3], guarded[2]]);
        assert!(n.z > 0.0, "not turned: {n:?}");
    }

    #[test]
    fn nothing_turned_leaves_the_output_alone() {
        let (tris, x) = hinge();
        let mut y = x.clone();
        y[3].x = 1.5;
        y[3].z = 0.4;
        assert!(scales(&tris, &x, &y).is_none());
    }

    #[test]
    fn undoing_a_fold_of_the_input_is_not_turning() {
        // The input face is turned against the reference (LBS's loop): the output turned back
        // against its input but along the reference is allowed.
        let (tris, mut x) = hinge();
        x[3].x = 0.5; // input: the second face turned over against +Z
        let mut y = x.clone();
        y[3].x = 2.0;
        assert!(scales(&tris, &x, &y).is_none());
    }

    #[test]
    fn the_scale_is_continuous_where_a_face_starts_to_turn() {
        // Vertex 3 moves toward -X by `reach`: the scale leaves 1 continuously as the face
        // reaches the margin.
        let (tris, x) = hinge();
        let scale_at = |reach: f64| {
            let mut y = x.clone();
            y[3].x -= reach;
            scales(&tris, &x, &y).map_or(1.0, |s| s[3])
        };
        let mut previous_motion = 0.0;
        for k in 0..=300 {
            let reach = 0.9 + 0.001 * k as f64;
            let motion = reach * scale_at(reach);
            assert!(
                (motion - previous_motion).abs() < 0.01 || k == 0,
                "reach {reach}: the vertex moves {motion} after {previous_motion}"
            );
            previous_motion = motion;
        }
    }
}
