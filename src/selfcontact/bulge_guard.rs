//! The bulge guard of a fold: where the bulge would carry a face of one truncated part
//! through a face of the other, the bulge of their corners is scaled back to where the two
//! faces would meet. Not in the paper.
//!
//! Why: the volume the contact takes from a fold comes back as a bulge round the contact zones
//! (Sec. 5.3), and at a joint the two parts meet in a concave crease: the bulge of one part
//! next to the crease rises into the other (CesiumMan's shoulders, the arm pressed against the
//! chest: most of the vertices left penetrating by the pass were not penetrating in the
//! skinned input, and with `γ = 0` on the shoulders two thirds of the residual goes, with
//! 4.9 % of the body's volume). The guard keeps the bulge out of the other part and the volume
//! exact: the fold solves the bulge height again after each scaling
//! ([`crate::selfcontact::fold`]), so the volume the guard takes from the crease comes back
//! where the bulge is free.
//!
//! Along the bulge's path (`x + t s`, `x` the blended positions without the bulge, `s` the
//! bulge step `γ h_v Q` as scaled so far, `t` from 0 to 1) each pair of faces, one of each
//! part, whose boxes over the path overlap is followed by continuous collision detection: the
//! first `t` at which a corner of one passes through the other face, or an edge through an
//! edge. Each corner with a bulge keeps, as the scale of its bulge, the smallest of its pairs'
//! first meetings, plus the fraction of the step that carries it [`TOLERANCE`] edge lengths
//! further. The scale is 1 where the first meeting reaches the output, and follows it
//! continuously from there.
//!
//! Only pairs that the bulge brings together are followed: faces closer than the tolerance
//! without the bulge (crossing, or touching) are the contact's business and left alone, as
//! are pairs whose bulge is shorter than the tolerance. Near the crease the faces of both
//! parts' contact zones lie on the one contact surface, touching; whether they cross there is
//! round-off's, and a first version that followed them (from a crossing test at a tiny `t`)
//! decided it differently for the fold's mirror image (5.6e-2 h apart on the capsule, against
//! 1.6e-4 h without the guard) and for its regions exchanged (1e-4 h, against 1e-14 h). With
//! the separation test both agree as without the guard.

use crate::contact::zones::quadratic_roots;
use crate::intersect::{IntersectError, MeshIndex};
use nalgebra::{Matrix3, Point3, Vector3};

/// Bisection steps for an event's time (to `2^-50` of the bulge step).
const BISECTION_STEPS: usize = 50;
/// How far a bulge may carry a face into the other part, in the fold's edge lengths
/// ([`BulgeStep::tolerance`]; measured along the fastest corner of the pair, so two faces
/// closing head-on may pass each other by up to twice as much): a bulge this shallow is no
/// penetration by the metric's test (`MEASURING.md`: the winding number `0.05 h` inside a
/// vertex). Also the separation below
/// which two faces without their bulge are in contact already, and the shortest bulge the
/// guard looks at.
pub const TOLERANCE: f64 = 0.01;

/// The bulge of a fold as the guard sees it.
pub struct BulgeStep<'a> {
    /// Mesh triangles.
    pub triangles: &'a [[u32; 3]],
    /// Blended positions without the bulge (`x`).
    pub base: &'a [Point3<f64>],
    /// The bulge step per vertex (`s`, zero where there is no bulge).
    pub step: &'a [Vector3<f64>],
    /// `x + s`, the fold's output.
    pub output: &'a [Point3<f64>],
    /// How far a face may be carried past the point where it meets the other part (scene
    /// units: [`TOLERANCE`] times the fold's edge length).
    pub tolerance: f64,
}

/// Per vertex, the scale of its bulge that keeps the bulge's face pairs between the truncated
/// `parts` from crossing by more than the tolerance along the bulge's path (1 where no pair
/// asks for less); `None` when no pair does.
pub fn bulge_scales(
    parts: [&MeshIndex; 2],
    bulge: &BulgeStep,
) -> Result<Option<Vec<f64>>, IntersectError> {
    let trees = [
        parts[0].swept_tree(bulge.base, bulge.output)?,
        parts[1].swept_tree(bulge.base, bulge.output)?,
    ];
    // Pairs whose paths' boxes overlap and whose bulge reaches past the tolerance: the first
    // time they meet.
    // Bounded: a bulge sweeping through far more of the other part than a fold's crease
    // (a broken rig) is no bulge to guard, and the fold fails ([`IntersectError::Entangled`]).
    let limits = trees[0].overlapping_pairs_bounded(&trees[1], |fa, fb| {
        let mut tri = [fa, fb].map(|f| bulge.triangles[f as usize]);
        tri.sort_unstable();
        let reach = largest_step(bulge, &tri);
        if reach <= bulge.tolerance || on_one_side(bulge, &tri) {
            return None;
        }
        if separation(bulge, &tri) <= bulge.tolerance {
            return None;
        }
        // Past the meeting point by the tolerance (continuous: 1 as the meeting nears the
        // output).
        let scale = onset(bulge, tri)? + bulge.tolerance / reach;
        (scale < 1.0).then_some((tri, scale))
    })?;
    if limits.is_empty() {
        return Ok(None);
    }
    let mut scale = vec![1.0; bulge.base.len()];
    for (tri, s) in limits {
        for v in tri.iter().flatten().map(|&v| v as usize) {
            if bulge.step[v] != Vector3::zeros() {
                scale[v] = f64::min(scale[v], s);
            }
        }
    }
    Ok(Some(scale))
}

/// The distance between the faces `tri` without their bulge (0 where they touch or cross,
/// and for faces sharing a corner). Measured in units of the power of two nearest the fold's
/// edge length ([`unit_of`]): parry's distance stops at absolute tolerances, and a rig in
/// other units (scaled by 2⁻⁶⁴) guarded other faces until 2026-12-05.
fn separation(bulge: &BulgeStep, tri: &[[u32; 3]; 2]) -> f64 {
    use parry3d_f64::math::{Pose, Vector};
    use parry3d_f64::shape::Triangle;
    let unit = unit_of(bulge.tolerance / TOLERANCE);
    let shape = |f: &[u32; 3]| {
        let p = f.map(|v| {
            let x = bulge.base[v as usize] / unit;
            Vector::new(x.x, x.y, x.z)
        });
        Triangle::new(p[0], p[1], p[2])
    };
    let (a, b) = (shape(&tri[0]), shape(&tri[1]));
    parry3d_f64::query::distance(&Pose::IDENTITY, &a, &Pose::IDENTITY, &b)
        .map_or(0.0, |d| d.distance * unit)
}

/// The power of two nearest `length` (1 for a length that is not positive and finite; at most
/// 2¹⁰²³, which `length` near `f64::MAX` would round past): a unit to divide by without
/// rounding.
fn unit_of(length: f64) -> f64 {
    if length > 0.0 && length.is_finite() {
        length.log2().round().min(1023.0).exp2()
    } else {
        1.0
    }
}

/// The longest bulge step of the faces `tri`'s corners.
fn largest_step(bulge: &BulgeStep, tri: &[[u32; 3]; 2]) -> f64 {
    tri.iter()
        .flatten()
        .map(|&v| bulge.step[v as usize].norm())
        .fold(0.0, f64::max)
}

/// The corners' paths of the faces `tri`.
fn paths(bulge: &BulgeStep, tri: &[[u32; 3]; 2]) -> [[Path; 3]; 2] {
    let path = |v: u32| Path {
        from: bulge.base[v as usize],
        step: bulge.step[v as usize],
    };
    tri.map(|f| f.map(path))
}

/// Whether one of the faces `tri` stays strictly on one side of the other's plane all along
/// the path (then they cannot meet): its three corners' coplanarity cubics with the other face
/// have one sign at 0 and no sign change on the way. A cheap test before the dearer ones.
/// [`onset`] computes the six corner-face cubics again for the pairs that pass: computing them
/// once for every pair, to share them, made CesiumMan's blend-and-volume step slower (7.0 →
/// 7.6 ms per frame), since most pairs stop at the first side.
fn on_one_side(bulge: &BulgeStep, tri: &[[u32; 3]; 2]) -> bool {
    let [a, b] = paths(bulge, tri);
    [(a, b), (b, a)].iter().any(|(corners, face)| {
        let cubics = corners.map(|q| Coplanarity::of(&[face[0], face[1], face[2], q]));
        let sign = cubics[0].at(0.0).signum();
        cubics
            .iter()
            .all(|c| c.at(0.0) != 0.0 && c.at(0.0).signum() == sign && !c.changes_sign(0.0, 1.0))
    })
}

/// The first bulge fraction `t ∈ (0, 1]` at which the faces `tri` (apart at 0; in a fixed
/// order whatever the parts' order), their corners at `x + t s`, meet: a corner of one passing
/// through the other face, or an edge of one through an edge of the other (continuous
/// collision detection: the times at which the four points are coplanar, roots of a cubic,
/// kept where the points meet). `None` when they never meet on the way. Two faces sliding
/// into each other within one plane have no coplanarity event and are missed.
fn onset(bulge: &BulgeStep, tri: [[u32; 3]; 2]) -> Option<f64> {
    let [a, b] = paths(bulge, &tri);
    let mut first: Option<f64> = None;
    let mut keep = |t: Option<f64>| {
        if let Some(t) = t {
            first = Some(first.map_or(t, |f| f.min(t)));
        }
    };
    for (corners, face) in [(a, b), (b, a)] {
        for q in corners {
            keep(first_meeting(
                &[face[0], face[1], face[2], q],
                Meeting::CornerFace,
            ));
        }
    }
    for i in 0..3 {
        for j in 0..3 {
            let points = [a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3]];
            keep(first_meeting(&points, Meeting::EdgeEdge));
        }
    }
    first
}

/// A corner's straight path: `from + t step`.
#[derive(Clone, Copy)]
struct Path {
    from: Point3<f64>,
    step: Vector3<f64>,
}

impl Path {
    fn at(&self, t: f64) -> Point3<f64> {
        self.from + self.step * t
    }
}

/// What four moving points are: a face and a corner, or two edges.
#[derive(Clone, Copy)]
enum Meeting {
    /// `[a, b, c]` a face, the fourth point a corner.
    CornerFace,
    /// `[p, q]` and `[r, s]` two edges.
    EdgeEdge,
}

/// The first `t ∈ (0, 1]` at which the four moving points are coplanar with the corner
/// inside the face, or the two edges crossing.
fn first_meeting(points: &[Path; 4], kind: Meeting) -> Option<f64> {
    Coplanarity::of(points)
        .roots(0.0, 1.0)
        .find(|&t| meets(&points.map(|p| p.at(t)), kind))
}

/// Whether four coplanar points meet: the corner in the face (barycentric coordinates in the
/// face's plane all non-negative), or the edges crossing (each edge's endpoints on both sides
/// of the other edge's line, in the common plane).
fn meets(p: &[Point3<f64>; 4], kind: Meeting) -> bool {
    match kind {
        Meeting::CornerFace => {
            let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
            let side = |i: usize, j: usize| (p[j] - p[i]).cross(&(p[3] - p[i])).dot(&n);
            n.norm_squared() > 0.0 && side(0, 1) >= 0.0 && side(1, 2) >= 0.0 && side(2, 0) >= 0.0
        }
        Meeting::EdgeEdge => {
            let (e, f) = (p[1] - p[0], p[3] - p[2]);
            let n = e.cross(&f);
            let across = |o: &Point3<f64>, d: &Vector3<f64>, x: &Point3<f64>, y: &Point3<f64>| {
                d.cross(&(x - o)).dot(&n) * d.cross(&(y - o)).dot(&n) <= 0.0
            };
            n.norm_squared() > 0.0
                && across(&p[0], &e, &p[2], &p[3])
                && across(&p[2], &f, &p[0], &p[1])
        }
    }
}

/// `det[p1 - p0, p2 - p0, p3 - p0]` of four moving points, a cubic in `t`.
struct Coplanarity {
    /// Coefficients of `1, t, t², t³`.
    c: [f64; 4],
}

impl Coplanarity {
    fn of(p: &[Path; 4]) -> Self {
        let u = [1, 2, 3].map(|k| (p[k].from - p[0].from, p[k].step - p[0].step));
        let det = |x: &Vector3<f64>, y: &Vector3<f64>, z: &Vector3<f64>| {
            Matrix3::from_columns(&[*x, *y, *z]).determinant()
        };
        let ([a0, a1], [b0, b1], [c0, c1]) = ([u[0].0, u[0].1], [u[1].0, u[1].1], [u[2].0, u[2].1]);
        Self {
            c: [
                det(&a0, &b0, &c0),
                det(&a1, &b0, &c0) + det(&a0, &b1, &c0) + det(&a0, &b0, &c1),
                det(&a1, &b1, &c0) + det(&a1, &b0, &c1) + det(&a0, &b1, &c1),
                det(&a1, &b1, &c1),
            ],
        }
    }

    fn at(&self, t: f64) -> f64 {
        ((self.c[3] * t + self.c[2]) * t + self.c[1]) * t + self.c[0]
    }

    /// The roots in `(lo, hi]` where the sign changes, ascending, found as they are asked
    /// for: the cubic is monotone between its critical points, each piece bisected where its
    /// ends differ in sign.
    fn roots(&self, lo: f64, hi: f64) -> impl Iterator<Item = f64> + '_ {
        self.pieces(lo, hi)
            .filter_map(move |(a, b)| self.bisect(a, b))
    }

    /// Whether the cubic changes sign in `(lo, hi]` ([`Coplanarity::roots`] not empty),
    /// without bisecting.
    fn changes_sign(&self, lo: f64, hi: f64) -> bool {
        self.pieces(lo, hi).any(|(a, b)| self.sign_change(a, b))
    }

    /// The monotone pieces of `[lo, hi]`: its ends and the critical points inside, ascending.
    fn pieces(&self, lo: f64, hi: f64) -> impl Iterator<Item = (f64, f64)> {
        // `hi` after the inner knots: every slot past them already holds it.
        let mut knots = [lo, hi, hi, hi];
        let mut n = 1;
        for t in self.critical_points().into_iter().flatten() {
            if lo < t && t < hi {
                knots[n] = t;
                n += 1;
            }
        }
        (0..n).map(move |i| (knots[i], knots[i + 1]))
    }

    /// Roots of the derivative `c1 + 2 c2 t + 3 c3 t²`, ascending (NaN roots, which
    /// [`Coplanarity::pieces`] leaves out, in either order).
    fn critical_points(&self) -> [Option<f64>; 2] {
        match quadratic_roots(self.c[1], 2.0 * self.c[2], 3.0 * self.c[3]) {
            [Some(a), Some(b)] if b < a => [Some(b), Some(a)],
            r => r,
        }
    }

    /// Whether a monotone piece changes sign in `(lo, hi]` (also a zero exactly at `hi`
    /// where the cubic only touches 0: harmless, the meeting test decides).
    fn sign_change(&self, lo: f64, hi: f64) -> bool {
        let (f_lo, f_hi) = (self.at(lo), self.at(hi));
        f_lo != 0.0 && (f_lo.signum() != f_hi.signum() || f_hi == 0.0)
    }

    /// The sign change in `(lo, hi]` of a monotone piece, if any.
    fn bisect(&self, mut lo: f64, mut hi: f64) -> Option<f64> {
        if !self.sign_change(lo, hi) {
            return None;
        }
        let sign = self.at(lo).signum();
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            let f = self.at(mid);
            if f.signum() == sign && f != 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Some(hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Positions, triangles and bulge steps.
    type Scene = (Vec<Point3<f64>>, Vec<[u32; 3]>, Vec<Vector3<f64>>);

    /// A triangle of part 1 standing under a flat triangle of part 2 at height 1; its apex at
    /// height `apex` rises by `rise` with the bulge.
    fn scene(apex: f64, rise: f64) -> Scene {
        let p = |x, y, z| Point3::new(x, y, z);
        let positions = vec![
            p(0.2, 0.2, 0.0),
            p(0.4, 0.2, 0.0),
            p(0.3, 0.3, apex),
            p(-1.0, -1.0, 1.0),
            p(2.0, -1.0, 1.0),
            p(-1.0, 2.0, 1.0),
        ];
        let mut step = vec![Vector3::zeros(); 6];
        step[2] = Vector3::new(0.0, 0.0, rise);
        (positions, vec![[0, 1, 2], [3, 4, 5]], step)
    }

    fn scales(apex: f64, rise: f64, tolerance: f64) -> Option<Vec<f64>> {
        guard(&scene(apex, rise), &[1, 2], tolerance)
    }

    /// The guard's scales for `scene`, its faces in the parts `parts`.
    fn guard(scene: &Scene, parts: &[u8], tolerance: f64) -> Option<Vec<f64>> {
        let (base, triangles, step) = scene;
        let output: Vec<Point3<f64>> = base.iter().zip(step).map(|(x, s)| x + s).collect();
        let parts = MeshIndex::self_contact_parts(base, triangles, parts).expect("parts");
        let bulge = BulgeStep {
            triangles,
            base,
            step,
            output: &output,
            tolerance,
        };
        bulge_scales([&parts[0], &parts[1]], &bulge).expect("finite")
    }

    /// The apex at 0.5 rising by 1 pierces the flat face at `t = 0.5` of its bulge: without
    /// tolerance the apex's scale is 0.5 (to the bisection's precision), the unbulged corners
    /// keep 1; a tolerance lets it through by that distance.
    #[test]
    fn a_bulge_through_the_other_part_stops_where_it_meets_it() {
        let s = scales(0.5, 1.0, 0.0).expect("the bulge pierces the other part");
        assert!((s[2] - 0.5).abs() < 1e-9, "apex scale {}", s[2]);
        for v in [0, 1, 3, 4, 5] {
            assert_eq!(s[v], 1.0, "vertex {v} has no bulge");
        }
        // Analytic for another height: the apex at 0.8 rising by 0.4 meets the face at 0.5.
        let s = scales(0.8, 0.4, 0.0).expect("pierces");
        assert!((s[2] - 0.5).abs() < 1e-9, "apex scale {}", s[2]);
        // A tolerance of 0.1 past the face: 0.6 of the bulge of 1.
        let s = scales(0.5, 1.0, 0.1).expect("pierces by more than 0.1");
        assert!((s[2] - 0.6).abs() < 1e-9, "apex scale {}", s[2]);
    }

    /// The same apex with the faces' ids (and parts) the other way round: the meeting is the
    /// second face's corner passing through the first face, the other direction of the
    /// corner-face events.
    #[test]
    fn the_corner_face_events_go_both_ways() {
        let (base, _, step) = scene(0.5, 1.0);
        let order = [3, 4, 5, 0, 1, 2];
        let base: Vec<Point3<f64>> = order.iter().map(|&v| base[v]).collect();
        let step: Vec<Vector3<f64>> = order.iter().map(|&v| step[v]).collect();
        let s = guard(&(base, vec![[0, 1, 2], [3, 4, 5]], step), &[2, 1], 0.0).expect("meets");
        assert!((s[5] - 0.5).abs() < 1e-9, "apex scale {}", s[5]);
    }

    /// Two faces whose first meeting is an edge of one through an edge of the other (no
    /// corner passes through a face before): a flat-lying face of part 1 along `x`, a face of
    /// part 2 above it coming down by 2 with its edge along `y` at height 1; the edges meet at
    /// `t = 0.5`.
    #[test]
    fn an_edge_through_an_edge_is_a_meeting() {
        let p = |x, y, z| Point3::new(x, y, z);
        let base = vec![
            p(-1.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(0.0, 0.5, -1.0),
            p(0.0, -1.0, 1.0),
            p(0.0, 1.0, 1.0),
            p(0.2, 0.0, 2.0),
        ];
        let down = Vector3::new(0.0, 0.0, -2.0);
        let step = vec![
            Vector3::zeros(),
            Vector3::zeros(),
            Vector3::zeros(),
            down,
            down,
            down,
        ];
        let scene = (base, vec![[0, 1, 2], [3, 4, 5]], step);
        let s = guard(&scene, &[1, 2], 0.0).expect("the edges meet");
        for (v, scale) in s.iter().enumerate().skip(3) {
            assert!((scale - 0.5).abs() < 1e-9, "vertex {v} scale {scale}");
        }
    }

    /// The cubic's roots in `(0, 1]` where it changes sign, with critical points inside:
    /// `(t - 0.2)(t - 0.5)(t - 0.9)`; a double root (no crossing) gives none.
    #[test]
    fn the_coplanarity_cubic_finds_each_sign_change() {
        let three = Coplanarity {
            c: [-0.09, 0.73, -1.6, 1.0],
        };
        let roots: Vec<f64> = three.roots(0.0, 1.0).collect();
        assert_eq!(roots.len(), 3, "{roots:?}");
        for (r, want) in roots.iter().zip([0.2, 0.5, 0.9]) {
            assert!((r - want).abs() < 1e-12, "{roots:?}");
        }
        // (t - 0.3)² (t - 2): touches 0 at 0.3 without crossing, crosses at 2, past 1.
        let touch = Coplanarity {
            c: [-0.18, 1.29, -2.6, 1.0],
        };
        let roots: Vec<f64> = touch.roots(0.0, 1.0).collect();
        assert!(roots.iter().all(|r| (r - 0.3).abs() < 1e-6));
        assert!(roots.len() <= 1);
        assert!(three.changes_sign(0.0, 1.0));
        assert_eq!(touch.changes_sign(0.0, 1.0), !roots.is_empty());
    }

    /// A bulge that stays short of the other part, or within the tolerance past it, and a
    /// pair that crosses or touches without the bulge (the contact's business, not the
    /// bulge's), are left alone.
    #[test]
    fn the_guard_leaves_what_the_bulge_did_not_cross() {
        assert!(scales(0.5, 0.4, 0.0).is_none(), "stays below the face");
        assert!(scales(0.5, 0.55, 0.1).is_none(), "0.05 past, within 0.1");
        assert!(
            scales(0.95, 0.08, 0.1).is_none(),
            "a bulge shorter than the tolerance"
        );
        assert!(scales(1.2, 0.3, 0.0).is_none(), "crosses without the bulge");
        // Closer than the tolerance without the bulge: in contact already, the contact's.
        assert!(
            scales(0.995, 1.0, 0.01).is_none(),
            "touching without the bulge"
        );
        assert!(
            scales(0.98, 1.0, 0.01).is_some(),
            "apart by twice the tolerance"
        );
    }
}
