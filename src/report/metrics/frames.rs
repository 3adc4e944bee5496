//! Volume error, inverted and turned faces, and the temporal measures over a run (second
//! differences, displacement steps).

use super::*;

/// Relative volume error `|after - before| / |before|` (`MEASURING.md`: signed volumes by the
/// divergence theorem, [`crate::mesh::signed_volume`]). Guards: 0 when both are 0,
/// `f64::INFINITY` when only `before` is 0 or when either is not finite.
pub fn volume_error(before: f64, after: f64) -> f64 {
    if !before.is_finite() || !after.is_finite() {
        return f64::INFINITY;
    }
    if before == 0.0 {
        return if after == 0.0 { 0.0 } else { f64::INFINITY };
    }
    let e = (after - before).abs() / before.abs();
    if e.is_finite() {
        e
    } else {
        f64::INFINITY
    }
}

/// Face counts of [`inverted_faces`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InvertedFaces {
    /// Faces whose normal turned by more than 90° against the input (negative dot product of
    /// the unnormalized normals), among faces valid and non-degenerate in both.
    pub inverted: usize,
    /// Valid faces degenerate in the input or the output (the criterion of
    /// [`crate::mesh::operators::DEGENERATE_AREA`]); they are not counted as inverted.
    pub degenerate: usize,
    /// Faces with an out-of-range index or a non-finite corner in the input or the output.
    pub invalid: usize,
}

/// Counts the faces of `triangles` whose normal turned by more than 90° from
/// `input_positions` to `output_positions` (`MEASURING.md`, target 0); degenerate and invalid
/// faces are counted separately.
pub fn inverted_faces(
    triangles: &[[u32; 3]],
    input_positions: &[Point3<f64>],
    output_positions: &[Point3<f64>],
) -> InvertedFaces {
    let mut out = InvertedFaces::default();
    for t in triangles {
        match (corners(input_positions, t), corners(output_positions, t)) {
            (Some(a), Some(b)) => {
                if is_degenerate(&a) || is_degenerate(&b) {
                    out.degenerate += 1;
                } else if double_area_vector(&a).dot(&double_area_vector(&b)) < 0.0 {
                    out.inverted += 1;
                }
            }
            _ => out.invalid += 1,
        }
    }
    out
}

/// Face counts of [`turned_faces`]: orientation against two references, for inputs that may be
/// turned over themselves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct TurnedFaces {
    /// Input faces turned against the skinning's normal field (LBS's loop at a collapsed
    /// joint: the input is already folded there).
    pub input_against_skinning: usize,
    /// Output faces turned against the input (`MEASURING.md`'s inverted faces).
    pub against_input: usize,
    /// Output faces turned against the skinning's normal field.
    pub against_skinning: usize,
    /// Output faces turned against both: the faces the deformer turned over.
    pub turned: usize,
    /// Of [`TurnedFaces::turned`], those with material on both sides (buried in a closed crease,
    /// where the two sides of a fold coincide): invisible from outside.
    pub buried: usize,
}

add_assign_fields!(
    "Counts of several bodies or frames, summed.",
    TurnedFaces {
        input_against_skinning,
        against_input,
        against_skinning,
        turned,
        buried,
    }
);

impl TurnedFaces {
    /// Turned faces that can be seen from outside the body.
    pub fn exposed(&self) -> usize {
        self.turned - self.buried
    }
}

/// Faces turned over (normal more than 90° away) against the input and against the normal
/// field of the skinning (`skinned_normals`, the rest normals carried by the blended joint
/// transforms, one per vertex; a face's reference is the sum over its corners).
///
/// `MEASURING.md` counts faces turned against the input. Where the skinned input is itself
/// folded (the loop LBS makes at a joint bent into contact, whose tip is turned against the
/// skinning's normals) undoing the fold turns those faces back, and the input criterion
/// counts them; a face is turned by the deformer when it is turned against both references.
/// A turned face is *buried* when the generalized winding number of the output is at least
/// 0.5 at both points `0.1 h` in front of and behind its centroid (material on both sides).
/// Degenerate and invalid faces are skipped (see [`inverted_faces`]).
pub fn turned_faces(
    triangles: &[[u32; 3]],
    input_positions: &[Point3<f64>],
    output_positions: &[Point3<f64>],
    skinned_normals: &[Vector3<f64>],
    h: f64,
) -> TurnedFaces {
    let mut out = TurnedFaces::default();
    let winding = WindingNumber::new(output_positions, triangles);
    for t in triangles {
        let (Some(a), Some(b)) = (corners(input_positions, t), corners(output_positions, t)) else {
            continue;
        };
        if is_degenerate(&a) || is_degenerate(&b) {
            continue;
        }
        let reference: Vector3<f64> = t
            .iter()
            .filter_map(|&v| skinned_normals.get(v as usize))
            .sum();
        let (na, nb) = (double_area_vector(&a), double_area_vector(&b));
        let vs_input = na.dot(&nb) < 0.0;
        let vs_skinning = nb.dot(&reference) < 0.0;
        out.input_against_skinning += usize::from(na.dot(&reference) < 0.0);
        out.against_input += usize::from(vs_input);
        out.against_skinning += usize::from(vs_skinning);
        if vs_input && vs_skinning {
            out.turned += 1;
            let c = Point3::from((b[0].coords + b[1].coords + b[2].coords) / 3.0);
            let e = nb.normalize() * (0.1 * h);
            if winding.query(&(c + e)) >= 0.5 && winding.query(&(c - e)) >= 0.5 {
                out.buried += 1;
            }
        }
    }
    out
}

/// Largest second difference of an animation, relative to its input (see
/// [`second_difference_ratio`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SecondDifference {
    /// `output_max / input_max` (see [`second_difference_ratio`] for the guards).
    pub ratio: f64,
    /// Largest `|x_{t+1} - 2 x_t + x_{t-1}|` of the output (absolute units).
    pub output_max: f64,
    /// The same for the input.
    pub input_max: f64,
    /// Middle frame `t` at which the output's maximum occurs (`None` without any triple).
    pub frame: Option<usize>,
    /// Vertex at which it occurs.
    pub vertex: Option<usize>,
    /// Triples `(t, vertex)` skipped, in either sequence, because a position is not finite.
    pub skipped: usize,
}

/// Largest second difference and where it occurs: `(max, frame, vertex, skipped)`.
fn max_second_difference(frames: &[Vec<Point3<f64>>]) -> (f64, Option<(usize, usize)>, usize) {
    let mut best = 0.0;
    let mut at = None;
    let mut skipped = 0;
    for t in 1..frames.len().saturating_sub(1) {
        let (a, b, c) = (&frames[t - 1], &frames[t], &frames[t + 1]);
        let n = a.len().min(b.len()).min(c.len());
        for v in 0..n {
            if !(finite(&a[v]) && finite(&b[v]) && finite(&c[v])) {
                skipped += 1;
                continue;
            }
            let d = (c[v].coords - 2.0 * b[v].coords + a[v].coords).norm();
            if !d.is_finite() {
                skipped += 1;
            } else if d > best || at.is_none() {
                best = d;
                at = Some((t, v));
            }
        }
    }
    (best, at, skipped)
}

/// Temporal smoothness (`MEASURING.md`): the largest second difference
/// `|x_{t+1} - 2 x_t + x_{t-1}|` over the vertices and frames of `output_frames`, divided by the
/// same maximum over `input_frames` (the skinned input). A pop or a flicker shows as a large
/// ratio; identical sequences give exactly 1.
///
/// Vertex `v` of triple `t` is used when it exists in the three frames and is finite there
/// (others are counted in `skipped`).
///
/// **Still input.** When the input's maximum is not above `1e-9` times the diagonal of the
/// bounding box of all input positions (a still or uniformly moving input, or round-off), the
/// ratio is 1 when the output's maximum is not above it either, and the output's maximum
/// divided by that floor otherwise (a large number: the output moves where the input did not).
pub fn second_difference_ratio(
    output_frames: &[Vec<Point3<f64>>],
    input_frames: &[Vec<Point3<f64>>],
) -> SecondDifference {
    let (output_max, at, skipped_out) = max_second_difference(output_frames);
    let (input_max, _, skipped_in) = max_second_difference(input_frames);
    SecondDifference {
        ratio: guarded_ratio(output_max, input_max, still_floor(input_frames)),
        output_max,
        input_max,
        frame: at.map(|(t, _)| t),
        vertex: at.map(|(_, v)| v),
        skipped: skipped_out + skipped_in,
    }
}

/// The level below which an input's motion is round-off: `1e-9` times the diagonal of the
/// bounding box of all its finite positions (at least the smallest positive number).
fn still_floor(input_frames: &[Vec<Point3<f64>>]) -> f64 {
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for p in input_frames.iter().flatten().filter(|p| finite(p)) {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    let diagonal = if lo.x <= hi.x { (hi - lo).norm() } else { 0.0 };
    if diagonal.is_finite() && diagonal > 0.0 {
        (1e-9 * diagonal).max(f64::MIN_POSITIVE)
    } else {
        f64::MIN_POSITIVE
    }
}

/// `output / input`, with the still-input guard of [`second_difference_ratio`]: 1 when both
/// are at most `floor`, `output / floor` when only the input is; never NaN.
fn guarded_ratio(output: f64, input: f64, floor: f64) -> f64 {
    let ratio = if input > floor {
        output / input
    } else if output <= floor {
        1.0
    } else {
        output / floor
    };
    if ratio.is_nan() {
        f64::INFINITY
    } else {
        ratio
    }
}

/// Largest frame-to-frame change of an animation's displacement against its input (see
/// [`displacement_step_ratio`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DisplacementStep {
    /// `output_max / input_max` (with the guards of [`second_difference_ratio`]).
    pub ratio: f64,
    /// Largest `|D_{t+1} - D_t|`, `D_t = output_t - input_t` (absolute units).
    pub output_max: f64,
    /// Largest `|x_{t+1} - x_t|` of the input: its fastest vertex's motion in one frame.
    pub input_max: f64,
    /// First frame `t` of the pair where the output's maximum occurs (`None` without a pair).
    pub frame: Option<usize>,
    /// Vertex at which it occurs.
    pub vertex: Option<usize>,
    /// Pairs `(t, vertex)` skipped because a position is not finite.
    pub skipped: usize,
}

/// Temporal continuity of the displacement a deformer adds to its input: the largest change
/// from one frame to the next of `D_t = output_t - input_t` over the vertices, divided by the
/// largest motion of an input vertex from one frame to the next.
///
/// Both shrink in proportion to the frame step when `D` is continuous in time, so the ratio
/// stays as the animation is sampled more finely; a *pop* (a jump of `D` between two frames)
/// keeps its size while the input's motion per frame shrinks: its ratio grows in proportion
/// to the frame count. A *kink* (a step in the velocity of `D`, such as a vertex entering a
/// contact zone whose threshold is on the depth, 2021 Eq. 3) leaves this ratio and raises the
/// [`second_difference_ratio`], whose input term shrinks with the square of the step. Compare
/// runs of one animation at two frame counts: a ratio that keeps its value is continuous, one
/// that grows with the frame count pops.
///
/// Vertex `v` of pair `t` is used when it exists in both frames of both sequences and is
/// finite there (others are counted in `skipped`).
pub fn displacement_step_ratio(
    output_frames: &[Vec<Point3<f64>>],
    input_frames: &[Vec<Point3<f64>>],
) -> DisplacementStep {
    let (mut output_max, mut input_max, mut at, mut skipped) = (0.0, 0.0f64, None, 0);
    let count = output_frames.len().min(input_frames.len());
    for t in 1..count {
        let (o0, o1) = (&output_frames[t - 1], &output_frames[t]);
        let (i0, i1) = (&input_frames[t - 1], &input_frames[t]);
        let n = o0.len().min(o1.len()).min(i0.len()).min(i1.len());
        for v in 0..n {
            if ![o0[v], o1[v], i0[v], i1[v]].iter().all(finite) {
                skipped += 1;
                continue;
            }
            let step = ((o1[v] - i1[v]) - (o0[v] - i0[v])).norm();
            input_max = input_max.max((i1[v] - i0[v]).norm());
            if step > output_max || at.is_none() {
                output_max = step;
                at = Some((t - 1, v));
            }
        }
    }
    DisplacementStep {
        ratio: guarded_ratio(output_max, input_max, still_floor(input_frames)),
        output_max,
        input_max,
        frame: at.map(|(t, _)| t),
        vertex: at.map(|(_, v)| v),
        skipped,
    }
}
