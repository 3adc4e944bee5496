//! Self-contact on skinned rigs (2021 Sec. 6): the bending capsule, the finger and the mouth.

#[path = "common/glb.rs"]
mod glb;
#[path = "common/scenes.rs"]
mod scenes;

use contact_skin::mesh::operators::{vertex_normals, NormalWeighting};
use contact_skin::pass::RestOverlaps;
use contact_skin::report::metrics;
use contact_skin::rig;
use contact_skin::selfcontact::fold::{FoldInput, FoldParams};
use contact_skin::selfcontact::pass::{FoldReport, SelfContactPass, SelfPassOutput};
use contact_skin::selfcontact::turn_guard::TurnReference;
use contact_skin::selfcontact::{DirectionSource, RegionOptions};
use contact_skin::skinning::Method;
use nalgebra::{Matrix4, Point3, Vector3};
use scenes::{
    double_sided, load, load_with, strapped, strapped_scaled, welded_positions, with_pieces_inside,
    Loaded,
};

fn self_pass(l: &Loaded, directions: &[(String, DirectionSource)]) -> SelfContactPass {
    self_pass_with(l, directions, FoldParams::default())
}

fn self_pass_with(
    l: &Loaded,
    directions: &[(String, DirectionSource)],
    params: FoldParams,
) -> SelfContactPass {
    let rest = welded_positions(&l.rig, &l.pre, 0.0, None);
    SelfContactPass::new(
        &l.rig,
        &l.pre.welded,
        &rest,
        &RegionOptions::default(),
        params,
        directions,
    )
    .expect("self-contact pass precomputes")
}

fn penetration(l: &Loaded, b: usize, p: &[Point3<f64>]) -> metrics::Penetration {
    let n = vertex_normals(p, &l.triangles[b], NormalWeighting::Area);
    metrics::residual_penetration(p, &l.triangles[b], &n, l.h_rest)
}

/// One frame of one body.
struct Row {
    frame: usize,
    folds: usize,
    /// Penetrating vertices in the input and the output.
    before: usize,
    after: usize,
    /// Largest residual depth in `h_rest` (`metrics::residual_penetration`).
    depth_after: f64,
    volume_error: f64,
    turned: metrics::TurnedFaces,
    nan: usize,
}

/// Per frame of the first animation, the metrics of `MEASURING.md`, and the second-difference
/// ratio over the animation.
struct Run {
    rows: Vec<Row>,
    ratio: f64,
    /// `metrics::displacement_step_ratio` of the output against the input.
    step_ratio: f64,
    /// Largest second difference of the output (absolute).
    output_max: f64,
    pairs: Vec<(usize, String)>,
    /// Largest `FoldOutput::bulge_steepness` of the folds resolved.
    steepness: f64,
    /// Each fold's frame and direction `d̂_12`, in order.
    directions: Vec<(usize, Vector3<f64>)>,
    /// Vertices whose bulge the bulge guard scaled back, summed over the folds.
    bulge_guarded: usize,
    /// The welded vertices at rest, then per frame the input and the output (bodies
    /// concatenated).
    rest: Vec<Point3<f64>>,
    ins: Vec<Vec<Point3<f64>>>,
    outs: Vec<Vec<Point3<f64>>>,
}

impl Run {
    /// The largest second difference of the output over the vertices whose rest position
    /// satisfies `keep` (absolute).
    fn output_max_where(&self, keep: impl Fn(&Point3<f64>) -> bool) -> f64 {
        let kept = |frames: &[Vec<Point3<f64>>]| -> Vec<Vec<Point3<f64>>> {
            frames
                .iter()
                .map(|f| {
                    f.iter()
                        .zip(&self.rest)
                        .filter(|(_, r)| keep(r))
                        .map(|(p, _)| *p)
                        .collect()
                })
                .collect()
        };
        metrics::second_difference_ratio(&kept(&self.outs), &kept(&self.ins)).output_max
    }
}

fn run(name: &str, frames: usize, directions: &[(String, DirectionSource)]) -> Run {
    run_with(name, frames, directions, Method::Lbs)
}

fn run_with(
    name: &str,
    frames: usize,
    directions: &[(String, DirectionSource)],
    method: Method,
) -> Run {
    run_full(name, frames, directions, method, FoldParams::default())
}

/// A run of `name`'s first animation (no configured direction) with a pass built with
/// `params`.
fn run_params(name: &str, frames: usize, method: Method, params: FoldParams) -> Run {
    run_full(name, frames, &[], method, params)
}

fn run_full(
    name: &str,
    frames: usize,
    directions: &[(String, DirectionSource)],
    method: Method,
    params: FoldParams,
) -> Run {
    run_loaded(name, &load_with(name, frames, method), directions, params)
}

/// [`run_full`] on the rig `l` (its first animation, `l.times`).
fn run_loaded(
    name: &str,
    l: &Loaded,
    directions: &[(String, DirectionSource)],
    params: FoldParams,
) -> Run {
    let frames = l.times.len();
    let pass = self_pass_with(l, directions, params);
    let (mut rows, mut ins, mut outs) = (Vec::new(), Vec::new(), Vec::new());
    let mut steepness = 0.0f64;
    let mut bulge_guarded = 0;
    let mut directions = Vec::new();
    for f in 0..frames {
        let (input, skinned) = (l.frame(f), l.frame_normals(f));
        let mut out = input.clone();
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let res = pass
            .run_with_normals(&l.rig, &pose, &mut out, &skinned)
            .expect("self-contact pass runs");
        for fold in res.folds.iter().filter(|f| f.output.unbalanced.is_none()) {
            steepness = steepness.max(fold.output.bulge_steepness);
        }
        directions.extend(res.folds.iter().map(|fold| (f, fold.direction)));
        bulge_guarded += res.bulge_guarded;
        if res.folds.is_empty() {
            assert_eq!(
                out, input,
                "{name} frame {f}: no fold must leave the input unchanged"
            );
        }
        for b in 0..input.len() {
            let (pi, po) = (penetration(l, b, &input[b]), penetration(l, b, &out[b]));
            let v0 = contact_skin::mesh::signed_volume(&input[b], &l.triangles[b]);
            let v1 = contact_skin::mesh::signed_volume(&out[b], &l.triangles[b]);
            let t = &l.triangles[b];
            rows.push(Row {
                frame: f,
                folds: res.folds.len(),
                before: pi.vertices,
                after: po.vertices,
                depth_after: po.max_depth / l.h_rest,
                volume_error: ((v1 - v0) / v0).abs(),
                turned: metrics::turned_faces(t, &input[b], &out[b], &skinned[b], l.h_rest),
                nan: metrics::non_finite(&out[b]),
            });
        }
        ins.push(input.concat());
        outs.push(out.concat());
    }
    let sd = metrics::second_difference_ratio(&outs, &ins);
    let step = metrics::displacement_step_ratio(&outs, &ins);
    for r in rows.iter().filter(|r| r.folds > 0) {
        let t = &r.turned;
        println!(
            "{name} frame {}: folds {} penetrating {} -> {}, volume error {:.1e}, faces turned: \
             input against skinning {}, output against input {}, against skinning {}, against \
             both {} ({} buried, {} exposed)",
            r.frame,
            r.folds,
            r.before,
            r.after,
            r.volume_error,
            t.input_against_skinning,
            t.against_input,
            t.against_skinning,
            t.turned,
            t.buried,
            t.exposed()
        );
    }
    println!(
        "{name}: second-difference ratio {:.2} (output {:.2e} at frame {:?}, vertex {:?}; input {:.2e})",
        sd.ratio, sd.output_max, sd.frame, sd.vertex, sd.input_max
    );
    println!(
        "{name}: displacement-step ratio {:.3} (step {:.2e} from frame {:?}, vertex {:?}; input {:.2e})",
        step.ratio, step.output_max, step.frame, step.vertex, step.input_max
    );
    Run {
        rows,
        ratio: sd.ratio,
        step_ratio: step.ratio,
        output_max: sd.output_max,
        pairs: pass.pairs(),
        steepness,
        directions,
        bulge_guarded,
        rest: welded_positions(&l.rig, &l.pre, 0.0, None).concat(),
        ins,
        outs,
    }
}

/// The checks shared by the scenes: no NaN; where a fold is resolved, the volume kept, at most
/// `max_after` penetrating vertices and `max_turned` faces turned over by the pass (against
/// the input and the skinning's normals, `metrics::turned_faces`); a bounded temporal ratio.
fn check(name: &str, r: &Run, max_after: usize, max_turned: usize, max_ratio: f64) {
    assert!(
        r.rows.iter().any(|x| x.folds > 0),
        "{name}: the animation folds into contact"
    );
    for x in &r.rows {
        let f = x.frame;
        assert_eq!(x.nan, 0, "{name} frame {f}: NaN");
        // In every frame: a fold that is detected but not resolved (no contact zone) leaves
        // its input's penetration.
        assert!(
            x.after <= max_after,
            "{name} frame {f}: penetration {} -> {} ({} folds)",
            x.before,
            x.after,
            x.folds
        );
        if x.folds > 0 {
            assert!(x.volume_error < 1e-4, "{name} frame {f}: volume error");
            assert!(
                x.turned.turned <= max_turned,
                "{name} frame {f}: {} faces turned ({} exposed)",
                x.turned.turned,
                x.turned.exposed()
            );
        }
    }
    assert!(r.ratio < max_ratio, "{name}: temporal ratio {}", r.ratio);
    // The bulge rises from its band far below 45° (measured at most 0.055 of the extent).
    assert!(r.steepness < 0.1, "{name}: bulge steepness {}", r.steepness);
}

/// `bending_capsule.glb` with a corrective morph target, as rigs swell a joint's inside where
/// it bends: a ring round the joint pushed out radially by up to `swell` times the capsule's
/// radius, fading to nothing one radius along the axis; its weight animated from 0 at the
/// start of `bend` to 1 at its end (glTF 2.0 §3.7.2.2).
fn capsule_with_swell(swell: f64) -> Vec<u8> {
    let bytes = scenes::committed_bytes("bending_capsule");
    let rig = rig::load_from_bytes(std::path::Path::new("capsule.glb"), &bytes).expect("loads");
    let body = &rig.bodies[0];
    let (lo, hi) = body.positions.iter().fold(
        (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)),
    );
    let extent = hi - lo;
    let axis = extent.imax();
    let centre = (lo + hi) / 2.0;
    let radius = (0..3)
        .filter(|&i| i != axis)
        .map(|i| extent[i] / 2.0)
        .fold(0.0, f64::max);
    let mut data: Vec<u8> = Vec::new();
    for p in &body.positions {
        let mut radial = p.coords - centre;
        let along = radial[axis].abs() / radius;
        radial[axis] = 0.0;
        let fade = (1.0 - along).max(0.0).powi(2);
        let d = radial.try_normalize(1e-12).unwrap_or_default() * (swell * radius * fade);
        data.extend(d.iter().flat_map(|&x| (x as f32).to_le_bytes()));
    }
    let anim = &rig.animations[0];
    let ramp = ([anim.start, anim.end], [0.0, 1.0]);
    with_weighted_target(&bytes, &data, body, (&ramp.0, &ramp.1), false)
}

/// `bytes` with a POSITION morph target on `body`'s (one) primitive, its displacements the f32
/// triples `deltas`, and an animation channel on its node weighting it `weights` at `times`:
/// beside the first animation's channels, or in place of them when `alone`.
fn with_weighted_target(
    bytes: &[u8],
    deltas: &[u8],
    body: &rig::Body,
    (times, weights): (&[f64], &[f64]),
    alone: bool,
) -> Vec<u8> {
    use serde_json::json;
    let mut data = deltas.to_vec();
    data.extend(
        times
            .iter()
            .chain(weights)
            .flat_map(|&x| (x as f32).to_le_bytes()),
    );
    let (n, k) = (body.vertex_count(), times.len());
    glb::with_bin_appended(bytes, &data, |json, offset| {
        let vec3 = json!({"componentType": 5126, "count": n, "type": "VEC3"});
        let target = glb::push_accessor(json, (offset, deltas.len()), None, vec3);
        let (first, last) = (times[0], times[k - 1]);
        let input = json!({"componentType": 5126, "count": k, "type": "SCALAR",
                           "min": [first], "max": [last]});
        let at = offset + deltas.len();
        let input = glb::push_accessor(json, (at, 4 * k), None, input);
        let output = json!({"componentType": 5126, "count": k, "type": "SCALAR"});
        let output = glb::push_accessor(json, (at + 4 * k, 4 * k), None, output);
        json["meshes"][0]["primitives"][0]["targets"] = json!([{"POSITION": target}]);
        json["meshes"][0]["weights"] = json!([0.0]);
        let animation = &mut json["animations"][0];
        if alone {
            animation["samplers"] = json!([]);
            animation["channels"] = json!([]);
        }
        let samplers = animation["samplers"].as_array_mut().expect("samplers");
        samplers.push(json!({"input": input, "output": output}));
        let sampler = samplers.len() - 1;
        let channel = json!({"sampler": sampler, "target": {"node": body.node, "path": "weights"}});
        animation["channels"]
            .as_array_mut()
            .expect("channels")
            .push(channel);
    })
}

/// A joint that folds while a corrective morph target swells it (`capsule_with_swell`): the
/// morphed surface is what the pass resolves, with the checks of the plain capsule.
#[test]
fn a_joint_swollen_by_a_morph_target_folds() {
    let l = scenes::load_bytes("bending_capsule", &capsule_with_swell(0.2), 31);
    let swollen = run_loaded("swollen capsule", &l, &[], FoldParams::default());
    let plain = run("bending_capsule", 31, &[]);
    // The target reaches the pass: no change at the first frame (weight 0), 0.3 of the
    // radius at the last (the capsule's radius is several edge lengths: > 0.5 h).
    assert_eq!(swollen.ins[0], plain.ins[0]);
    let moved = max_distance(&swollen.ins[30], &plain.ins[30]);
    assert!(moved > 0.5 * l.h_rest, "moved {moved} (h {})", l.h_rest);
    // Measured (2026-12-06): 0 to 2 vertices left just inside in 5 of the 23 frames with a
    // fold (the plain capsule: none), at most 0.1 h deep.
    check("swollen capsule", &swollen, 2, 0, 3.0);
    let depth = swollen
        .rows
        .iter()
        .map(|x| x.depth_after)
        .fold(0.0, f64::max);
    println!("swollen capsule: left at most {depth:.3} h deep");
    assert!(depth < 0.25, "left {depth} h deep");
}

/// The bending capsule's `bend` (0 to 150°): the fold is resolved with the volume kept.
#[test]
fn bending_capsule_fold() {
    let r = run("bending_capsule", 31, &[]);
    assert_eq!(r.pairs.len(), 1);
    check("bending_capsule", &r, 0, 0, 3.0);
    assert!(r.bulge_guarded > 0, "the bulge guard acts on the capsule");
}

/// The same bend with Center-of-Rotation and dual-quaternion skinning as input: resolved with
/// the volume kept and no face turned (the turn guard), but not yet at the issue's targets (see
/// the issue note): up to 4 penetrating vertices (CoR; DQS 3) at 120-150°, none deeper than
/// 0.14 h (DQS 0.13 h; with exactly two sweeps, the default until 2026-12-03: up to 6 and 4,
/// 0.23 and 0.15 h); since Eq. 4's moments are taken over each part's own faces
/// (2026-12-03), 3 and 5 (DQS frame 20, which further sweeps leave as they find it), 0.12 and
/// 0.08 h deep; the temporal ratio reaches 23
/// (the input folds over along `d̂` at the inner elbow, and a vertex the crease cut moves
/// across jumps by about 2 h). Without the turn guard 15 and 9 faces turned at the crease's
/// bottom (see
/// [`the_turn_guard_keeps_faces_from_turning`]; before the amplitude faded across the crease:
/// 17 and 19; with `τ = 0`: CoR 30, DQS 22; before the buried band got the crease's
/// intersection terms: CoR 57, DQS 61).
fn volume_preserving_input(method: Method) {
    volume_preserving_input_on("bending_capsule", method, 5);
}

/// [`volume_preserving_input`]'s checks on `scene` with at most `max_after` penetrating
/// vertices in a frame.
fn volume_preserving_input_on(scene: &str, method: Method, max_after: usize) {
    let r = run_with(scene, 31, &[], method);
    assert!(
        r.rows.iter().any(|x| x.folds > 0),
        "{scene} {method:?}: the animation folds"
    );
    for x in r.rows.iter().filter(|x| x.folds > 0) {
        let f = x.frame;
        assert_eq!(x.nan, 0, "{method:?} frame {f}: NaN");
        assert!(x.volume_error < 1e-4, "{method:?} frame {f}: volume");
        assert!(
            x.after <= max_after,
            "{scene} {method:?} frame {f}: penetration {} -> {}",
            x.before,
            x.after
        );
        // What is left is shallow: measured at most 0.14 h (CoR) and 0.13 h (DQS) over the
        // capsule's 31 frames, where the inputs are up to 7 h deep; the finger's 0.35 h and
        // 0.31 h.
        assert!(
            x.depth_after <= 0.5,
            "{method:?} frame {f}: residual depth {:.2} h",
            x.depth_after
        );
        assert_eq!(x.turned.turned, 0, "{method:?} frame {f}: faces turned");
    }
}

/// The turn guard on the bend with CoR input, frame by frame from 90° to 150°: without it
/// faces turn over at the crease's bottom (0 to 15 per frame, measured), with it none, with
/// 16 to 160 vertices scaled back and at most 4 penetrating vertices per frame either way
/// (measured per frame: -4 to +2, frame 21 2 → 4, frame 30 4 → 0; with exactly two sweeps,
/// the default until 2026-12-03, at most 6). The LBS bend and the
/// finger never trigger it (their outputs are the same to the bit with and without).
#[test]
fn the_turn_guard_keeps_faces_from_turning() {
    let l = load_with("bending_capsule", 31, Method::Cor);
    let rest = welded_positions(&l.rig, &l.pre, 0.0, None);
    let pass = |turn_guard: bool| {
        let params = FoldParams {
            turn_guard,
            ..FoldParams::default()
        };
        let (w, o) = (&l.pre.welded, RegionOptions::default());
        SelfContactPass::new(&l.rig, w, &rest, &o, params, &[]).expect("pass")
    };
    let (guarded, free) = (pass(true), pass(false));
    let (mut turned_free, mut guarded_vertices) = (0, 0);
    for f in 18..31 {
        let (input, skinned) = (l.frame(f), l.frame_normals(f));
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let outcome = |pass: &SelfContactPass| {
            let mut out = input.clone();
            let res = pass
                .run_with_normals(&l.rig, &pose, &mut out, &skinned)
                .expect("runs");
            let t =
                metrics::turned_faces(&l.triangles[0], &input[0], &out[0], &skinned[0], l.h_rest);
            (t.turned, penetration(&l, 0, &out[0]).vertices, res.guarded)
        };
        let (t_on, p_on, g_on) = outcome(&guarded);
        let (t_off, p_off, g_off) = outcome(&free);
        assert_eq!(t_on, 0, "frame {f}: {t_on} faces turned with the guard");
        println!(
            "frame {f}: turned {t_off} -> {t_on}, penetrating {p_off} -> {p_on}, {g_on} scaled"
        );
        assert!(p_on <= 4, "frame {f}: penetration {p_off} -> {p_on}");
        assert_eq!(g_off, 0, "the guard off scales nothing");
        turned_free = turned_free.max(t_off);
        guarded_vertices += g_on;
    }
    assert!(
        turned_free >= 5,
        "without the guard {turned_free} faces turn"
    );
    assert!(guarded_vertices > 0);
}

/// The same folds without the bulge guard (`FoldParams::bulge_guard`, on by default), the
/// paper's method alone: every check holds as well. The guard acts on them all the same
/// (bulges scaled back on the capsule, measured 31 frames, two sweeps) and changes no count.
#[test]
fn the_lbs_folds_resolve_without_the_bulge_guard() {
    let free = FoldParams {
        bulge_guard: false,
        ..FoldParams::default()
    };
    for name in ["bending_capsule", "finger", "mouth"] {
        let r = run_params(name, 31, Method::Lbs, free);
        check(name, &r, 0, 0, 3.0);
        assert_eq!(r.bulge_guarded, 0, "{name}: the guard is off");
    }
}

/// The bend with CoR and DQS input without the bulge guard: the same bounds as with it
/// ([`volume_preserving_input`]; measured summed over the 31 frames 12 and 8 penetrating
/// vertices, 10 and 9 with the guard; the worst frame 4 and 3 either way, at most 0.18 h
/// deep; no face turned; with exactly two sweeps 23 and 21, the worst frame 6 and 4; since
/// Eq. 4's moments are taken over each part's own faces, 2026-12-03, DQS's frame 20 keeps 5).
#[test]
fn volume_preserving_input_without_the_bulge_guard() {
    let free = FoldParams {
        bulge_guard: false,
        ..FoldParams::default()
    };
    for method in [Method::Cor, Method::Dqs] {
        let r = run_params("bending_capsule", 31, method, free);
        for x in r.rows.iter().filter(|x| x.folds > 0) {
            let f = x.frame;
            assert_eq!(x.nan, 0, "{method:?} frame {f}: NaN");
            assert!(x.volume_error < 1e-4, "{method:?} frame {f}: volume");
            assert!(x.after <= 5, "{method:?} frame {f}: {} left", x.after);
            assert!(x.depth_after <= 0.5, "{method:?} frame {f}: depth");
            assert_eq!(x.turned.turned, 0, "{method:?} frame {f}: faces turned");
        }
    }
}

#[test]
fn bending_capsule_fold_cor() {
    volume_preserving_input(Method::Cor);
}

#[test]
fn bending_capsule_fold_dqs() {
    volume_preserving_input(Method::Dqs);
}

/// The finger with CoR and DQS input, the same checks: not at the issue's targets either. The
/// worst frame keeps 9 and 15 penetrating vertices (CoR, DQS: 45 and 65 summed over the 31
/// frames, at most 0.35 and 0.31 h deep; with exactly two sweeps 35 and 34, 366 and 321, 0.36
/// and 0.37 h), no face turned, the volume kept. The bound guards the state the issue note
/// reports.
#[test]
fn finger_folds_with_volume_preserving_input() {
    for method in [Method::Cor, Method::Dqs] {
        volume_preserving_input_on("finger", method, 20);
    }
}

/// The finger's three joints flexing past contact; and `finger_long`, the benchmark's finger
/// at the paper's size (a longer metacarpal stub), which must fold as well.
#[test]
fn finger_folds() {
    let r = run("finger", 31, &[]);
    assert_eq!(r.pairs.len(), 3);
    check("finger", &r, 0, 0, 3.0);
    let long = run("finger_long", 31, &[]);
    assert_eq!(long.pairs.len(), 3);
    check("finger_long", &long, 0, 0, 3.0);
}

/// A joint pair's own parameters (`SelfContactPass::with_pair_params`, the configuration's
/// `[[self_contact.pair]]` `τ`, `γ`, `ω`) apply to that pair only: on the finger, `γ = 0` for
/// the middle-distal joint (the last fold of a sweep; with `τ = 0`, `ω = 1`) leaves the first
/// sweep's other folds bit for bit as with the defaults and that fold without a bulge, so the
/// body loses volume (kept to round-off with the defaults); every pair given those parameters
/// is the pass built with them, to the bit; an unknown name is an error.
#[test]
fn a_pair_takes_its_own_parameters() {
    let l = load("finger", 31);
    let rest = welded_positions(&l.rig, &l.pre, 0.0, None);
    let build = |params: FoldParams| {
        SelfContactPass::new(
            &l.rig,
            &l.pre.welded,
            &rest,
            &RegionOptions::default(),
            params,
            &[],
        )
        .expect("pass")
    };
    // γ, τ and ω of its own (a configuration's `[[self_contact.pair]]` sets these three).
    let flat = FoldParams {
        tau: 0.0,
        deform: contact_skin::deform::DeformParams {
            gamma: 0.0,
            omega: 1.0,
            ..FoldParams::default().deform
        },
        ..FoldParams::default()
    };
    let plain = build(FoldParams::default());
    let names: Vec<String> = plain.pairs().into_iter().map(|(_, n)| n).collect();
    let last = "finger/middle-distal".to_string();
    assert_eq!(names.last(), Some(&last), "{names:?}");
    let one = build(FoldParams::default())
        .with_pair_params(&[(last.clone(), flat)])
        .expect("a derived pair");
    let all = build(FoldParams::default())
        .with_pair_params(&names.iter().map(|n| (n.clone(), flat)).collect::<Vec<_>>())
        .expect("derived pairs");
    let section = build(flat);
    let (mut compared, mut lost) = (0, 0.0f64);
    for f in [20, 26, 30] {
        let input = l.frame(f);
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let go = |pass: &SelfContactPass| {
            let mut out = input.clone();
            let res = pass.run(&l.rig, &pose, &mut out).expect("runs");
            (out, res)
        };
        let ((p_out, p_res), (o_out, o_res)) = (go(&plain), go(&one));
        let (a_out, _) = go(&all);
        let (s_out, _) = go(&section);
        assert_eq!(
            a_out, s_out,
            "frame {f}: every pair's parameters are the section's"
        );
        // The folds before the middle-distal one in the first sweep are untouched.
        for (p, o) in p_res.folds.iter().zip(&o_res.folds) {
            if p.name == last {
                break;
            }
            assert_eq!(p.name, o.name);
            assert_eq!(
                p.output.positions, o.output.positions,
                "frame {f}: {}",
                p.name
            );
            compared += 1;
        }
        let volume = |x: &[Point3<f64>]| contact_skin::mesh::signed_volume(x, &l.triangles[0]);
        let v0 = volume(&input[0]);
        assert!(
            metrics::volume_error(v0, volume(&p_out[0])) < 1e-10,
            "frame {f}"
        );
        if o_res.folds.iter().any(|r| r.name == last) {
            lost = lost.max(metrics::volume_error(v0, volume(&o_out[0])));
        }
    }
    assert!(compared >= 2, "{compared} folds compared");
    assert!(
        lost > 1e-4,
        "the middle-distal fold without its bulge loses volume: {lost:e}"
    );
    let e = build(FoldParams::default())
        .with_pair_params(&[("finger/no-such-pair".into(), flat)])
        .expect_err("unknown pair");
    assert!(e.to_string().contains("finger/no-such-pair"), "{e}");
}

/// The frame count of `name`'s first animation sampled at its own rate (30 per second).
fn native_frames(name: &str) -> usize {
    let l = load(name, 2);
    contact_skin::frames::sample_times(&l.rig, Some(0), None)
        .expect("frames")
        .len()
}

/// The LBS folds sampled at their animations' own rate (30 per second: 76 frames of the
/// capsule's bend, 91 of the finger's flex), where the 31-frame tests above are 2.5-3 times
/// coarser. The capsule's output pops: its largest second difference stays at about 0.2 h
/// however finely it is sampled (0.23 h at frame 53 of 76, vertex 1948, where the zones grow
/// by 10 and 12 vertices at once: Eq. 4's threshold drops by 0.44 h as 22 zero-depth samples
/// of vertices on the crease cut, whose rays land on their own faces of the other part, enter
/// the mapping region through the propagation from the walls), while the input's shrinks
/// with the square of the step, so the ratio grows with the square of the frame count: 1.70 at
/// 31 frames, 5.42 at 76, above the issue's bound of 3. The finger: 1.84, no penetrating
/// vertex (one at frames 85 and 89 before the walls' crossings at contour points were made
/// independent of round-off). Since 2026-12-03 the seam vertices of the crease cut are in the
/// mapping regions whether the propagation reaches them or not (`contact::mapping`): the
/// threshold no longer jumps there, and the capsule measures 1.89 at 31 frames and 3.93 at 76
/// (its largest second difference now at vertex 2109, frame 63), the finger 2.07 at 91
/// (vertex 1046, frame 63), still no penetrating vertex in either. Since Eq. 4's moments are
/// taken over each part's own faces: the capsule 1.76 and 4.31 (vertex 1867, frame 45), the
/// finger 1.81 (vertex 2392, frame 84). The capsule's largest second differences at 76 frames
/// are in frame 45, where the threshold still dips (the seam's own faces with all corners on
/// the cut lie at depth 0 and come and go with it), and kinks: a vertex entering the contact
/// zone (Eq. 3: its depth reaches the threshold) goes from the profile's nearly constant
/// displacement to following `S`, at `k̄` times its depth's rate (vertex 2109, frame 63, before
/// the change: 0.033 h per frame before, 0.199 h after, the depth growing by 0.398 h per frame,
/// `k̄ = 0.5`); such a step in velocity makes a second difference proportional to the frame
/// step, the input's to its square, so the ratio of a kink grows with the frame count. The
/// bounds below are those measurements with a margin, not the issue's targets: this test
/// guards the state the issue note reports.
///
/// What tells a pop from a kink is the displacement's continuity in time
/// (`metrics::displacement_step_ratio`: the displacement's largest change in one frame over
/// the input's fastest vertex's motion in one frame), which keeps its value as the animation
/// is sampled more finely where the displacement is continuous and grows with the frame count
/// where it jumps. Measured (2026-12-03): the capsule 0.249 at 31 frames, 0.267 at 76 (0.276
/// at 151), the finger 0.058 and 0.059 at 91: continuous, the largest steps where the folds
/// deepen fastest; against the capsule with CoR input 1.02 at 31 frames and 2.65 at 76, with
/// DQS 1.55 and 3.95 (pops of 3-5 h, the issue note's), and the mouth 0.88 at 31 and 2.75 at
/// 91 (its corners' crease vertices, 0.27 h; 0.51 and 0.60 with `free_isolated_crease`).
#[test]
fn lbs_folds_at_the_animations_frame_rate() {
    for (name, native, max_ratio) in [("bending_capsule", 76, 4.5), ("finger", 91, 2.4)] {
        let frames = native_frames(name);
        assert_eq!(frames, native);
        let fine = run(name, frames, &[]);
        check(name, &fine, 0, 0, max_ratio);
        let coarse = run(name, 31, &[]);
        // Continuous: never faster than the input's fastest vertex, and no growth with the
        // frame count beyond the measured 7 % (a jump that makes the largest step at both
        // rates grows it 2.45 times from 31 to 76 frames, 2.9 times to 91).
        assert!(
            fine.step_ratio < 1.0 && coarse.step_ratio < 1.0,
            "{name}: displacement-step ratios {} and {}",
            coarse.step_ratio,
            fine.step_ratio
        );
        assert!(
            fine.step_ratio < 1.15 * coarse.step_ratio,
            "{name}: displacement-step ratio {} at 31 frames, {} at {frames}",
            coarse.step_ratio,
            fine.step_ratio
        );
    }
}

/// The bending capsule at every half degree of its 0-150° bend (301 frames, LBS, defaults):
/// no face turned, the volume kept, the displacement continuous, and what is left inside
/// bounded. Measured 2026-12-06: 4 vertices at 106.5° and 2 at 111.5° (0.050 and 0.065 h
/// deep), none at any other angle. They lie on the crease's flank (vertices 1623 / 1703 and
/// their mirror images, either side of the ring at `β = 0.5`), where the bands either side of
/// the crease cross by a twentieth of an edge: the detection still finds those face pairs
/// after the pass, but the flank's normals lie beyond the 80° safeguard of Sec. 4.4 from
/// `d̂`, so the last sweep's contact has no zone and the sweeps stop. The second-difference
/// ratio, 79 here, is not bounded: the contact's kinks' second differences shrink as `1 / N`
/// with the frame count, the input's as `1 / N²`.
#[test]
fn capsule_at_every_half_degree() {
    let r = run("bending_capsule", 301, &[]);
    check("bending_capsule", &r, 4, 0, f64::INFINITY);
    let left: Vec<(usize, usize, f64)> = (r.rows.iter())
        .filter(|x| x.after > 0)
        .map(|x| (x.frame, x.after, x.depth_after))
        .collect();
    assert!(
        left.len() <= 2 && left.iter().all(|&(_, _, depth)| depth < 0.1),
        "frames with vertices left inside (frame, vertices, depth in h): {left:?}"
    );
    assert!(
        r.step_ratio < 1.0,
        "displacement-step ratio {}",
        r.step_ratio
    );
}

/// Sweeps past the count while the folds' shared regions keep penetrating vertices
/// (`with_max_passes`, by default up to 6 in all since the twenty-fourth session, 4 before): the
/// bending capsule with CoR input at 31 frames, defaults, keeps penetrating vertices after its 2
/// sweeps in frames 23, 29 and 30 (1, 2 and 4), which further sweeps resolve (3, 4 and 3 sweeps
/// in all, as before); in frame
/// 15, clear after 2, the further sweeps change nothing. (The case moves with the pass's
/// discrete decisions: until Eq. 4's moments were taken over each part's own faces,
/// 2026-12-03, it was `finger_long` without the bulge guard, frame 56 of 61, which 2 sweeps
/// now clear, and frame 59 before the seam vertices joined the mapping regions.)
#[test]
fn further_sweeps_resolve_what_two_leave() {
    use contact_skin::selfcontact::pass::DEFAULT_MAX_FOLD_PASSES;
    let l = load_with("bending_capsule", 31, Method::Cor);
    let exact = self_pass(&l, &[]).with_passes(2);
    let further = self_pass(&l, &[])
        .with_passes(2)
        .with_max_passes(DEFAULT_MAX_FOLD_PASSES);
    for f in [15, 23, 29, 30] {
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let skinned = l.frame_normals(f);
        let (mut two, mut more) = (l.frame(f), l.frame(f));
        let r2 = exact
            .run_with_normals(&l.rig, &pose, &mut two, &skinned)
            .expect("pass runs");
        let rm = further
            .run_with_normals(&l.rig, &pose, &mut more, &skinned)
            .expect("pass runs");
        let (p2, pm) = (penetration(&l, 0, &two[0]), penetration(&l, 0, &more[0]));
        println!(
            "frame {f}: {} sweeps leave {} penetrating, {} sweeps leave {}",
            r2.sweeps, p2.vertices, rm.sweeps, pm.vertices
        );
        assert_eq!(r2.sweeps, 2);
        if f == 15 {
            assert_eq!((p2.vertices, rm.sweeps), (0, 2));
            assert_eq!(
                two, more,
                "frame {f}: clear after 2 sweeps, nothing more runs"
            );
        } else {
            assert!(
                p2.vertices > 0,
                "frame {f} is no longer a case for further sweeps"
            );
            assert!(rm.sweeps > 2);
        }
        assert_eq!(
            pm.vertices, 0,
            "frame {f}: further sweeps leave {}",
            pm.vertices
        );
    }
}

/// A further sweep does not pin again the crease vertices that the sweep before left
/// penetrating (`FoldInput::left_penetrating`, since the twenty-fifth session): the finger with
/// DQS input at 31 frames, defaults. Before, frames 21 and 23 kept 3 and 1 penetrating vertices
/// through their six sweeps, and frame 25 kept 3, two of them crease vertices pinned at their
/// skinned position (the seam's own point at depth 0) in every sweep; now frames 21 and 23 end
/// clear and no penetrating vertex of frame 25 is left where the skinning put it.
#[test]
fn further_sweeps_do_not_pin_the_crease_vertices_they_left_inside() {
    let l = load_with("finger", 31, Method::Dqs);
    let two = self_pass(&l, &[]).with_passes(2);
    let further = self_pass(&l, &[]).with_passes(2).with_max_passes(6);
    for f in [21, 23, 25] {
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let skinned = l.frame_normals(f);
        let input = l.frame(f);
        let (mut after_two, mut after_more) = (input.clone(), input.clone());
        two.run_with_normals(&l.rig, &pose, &mut after_two, &skinned)
            .expect("pass runs");
        let r = further
            .run_with_normals(&l.rig, &pose, &mut after_more, &skinned)
            .expect("pass runs");
        let (p2, pm) = (
            penetration(&l, 0, &after_two[0]),
            penetration(&l, 0, &after_more[0]),
        );
        println!(
            "frame {f}: 2 sweeps leave {:?}, {} sweeps leave {:?}",
            p2.flagged, r.sweeps, pm.flagged
        );
        assert!(
            p2.vertices > 0,
            "frame {f} is no longer a case for further sweeps"
        );
        let pinned: Vec<u32> = pm
            .flagged
            .iter()
            .copied()
            .filter(|&v| after_more[0][v as usize] == input[0][v as usize])
            .collect();
        assert!(
            pinned.is_empty(),
            "frame {f}: {pinned:?} penetrate where the input had them"
        );
        if f != 25 {
            assert_eq!(
                pm.vertices, 0,
                "frame {f}: further sweeps leave {:?}",
                pm.flagged
            );
        }
    }
}

/// The paper's hand-set direction of the mouth (Fig. 1d): vertical, the upper lip's outward
/// direction -Y.
fn mouth_vertical() -> Vec<(String, DirectionSource)> {
    vec![(
        "lips/head-jaw".to_string(),
        DirectionSource::Fixed(-Vector3::y()),
    )]
}

/// The mouth closing with the vertical direction and `params`, at 31 and 61 frames, each
/// passing [`check`] (no penetrating vertex, no turned face, ratio below 3), and its edge
/// length at rest.
fn mouth_closing(params: FoldParams) -> (Run, Run, f64) {
    let dirs = mouth_vertical();
    let coarse = run_full("mouth", 31, &dirs, Method::Lbs, params);
    let fine = run_full("mouth", 61, &dirs, Method::Lbs, params);
    check("mouth", &coarse, 0, 0, 3.0);
    check("mouth", &fine, 0, 0, 3.0);
    (coarse, fine, load("mouth", 2).h_rest)
}

/// `mouth.glb` whose lips close by a morph target instead of the jaw: the target lifts each
/// vertex by 0.22 times its jaw weight (the lower lip's middle rises as the jaw's 11° lift it,
/// sinking 0.12 into the upper lip; the corners half as much), and `close`'s jaw rotation is
/// replaced by the target's weight, 0 at the start, 1 from 2.5 s (as the jaw's ramp).
fn mouth_closed_by_a_morph_target() -> Vec<u8> {
    let bytes = scenes::committed_bytes("mouth");
    let rig = rig::load_from_bytes(std::path::Path::new("mouth.glb"), &bytes).expect("loads");
    let body = &rig.bodies[0];
    let mut data: Vec<u8> = Vec::new();
    for v in 0..body.vertex_count() {
        let jaw: f64 = body
            .weights
            .row(v)
            .filter(|&(j, _)| j == 1)
            .map(|(_, w)| w)
            .sum();
        for x in [0.0, 0.22 * jaw, 0.0] {
            data.extend((x as f32).to_le_bytes());
        }
    }
    with_weighted_target(
        &bytes,
        &data,
        body,
        (&[0.0, 2.5, 3.0], &[0.0, 1.0, 1.0]),
        true,
    )
}

/// Lips that close by a blend shape, the bones still (a face rig's usual way): the head-jaw
/// pair's fold detects the lips crossing and resolves them as when the jaw turns, with the
/// default direction (the skeleton's, folded 171° at rest), passing [`check`]. Measured
/// (2026-12-06): 820 penetrating vertices at the closed frames → 0, volume error ≤ 9e-15,
/// second-difference ratio 1.01 (1.00 with the paper's vertical).
#[test]
fn lips_closed_by_a_morph_target_fold() {
    let l = scenes::load_bytes("mouth", &mouth_closed_by_a_morph_target(), 31);
    let r = run_loaded("morph mouth", &l, &[], FoldParams::default());
    let deepest = r.rows.iter().map(|x| x.before).max().unwrap_or(0);
    assert!(
        deepest > 100,
        "the target closes the lips into each other: {deepest}"
    );
    check("morph mouth", &r, 0, 0, 3.0);
}

/// `bytes` (one body, one morph target) with NORMAL displacements added to its target that
/// turn every normal over at full weight (`-1.5 n`).
fn with_normals_turned_by_the_target(bytes: &[u8]) -> Vec<u8> {
    let rig = rig::load_from_bytes(std::path::Path::new("morph.glb"), bytes).expect("loads");
    let normals = &rig.bodies[0].normals;
    let data: Vec<u8> = (normals
        .iter()
        .flat_map(|n| n.iter().map(|&c| (-1.5 * c) as f32)))
    .flat_map(f32::to_le_bytes)
    .collect();
    glb::with_bin_appended(bytes, &data, |json, offset| {
        let vec3 =
            serde_json::json!({"componentType": 5126, "count": normals.len(), "type": "VEC3"});
        let a = glb::push_accessor(json, (offset, data.len()), None, vec3);
        json["meshes"][0]["primitives"][0]["targets"][0]["NORMAL"] = serde_json::json!(a);
    })
}

/// Without given normals, the pass takes the turn guard's reference from the bind normals
/// skinned by LBS, morphed by the pose's weights: the same output, to the bit, as with the
/// frame's own LBS normals, on lips whose target also turns their normals over (until
/// 2026-12-06 the bind normals were taken unmorphed).
#[test]
fn the_pass_without_normals_follows_the_morphed_normals() {
    let bytes = with_normals_turned_by_the_target(&mouth_closed_by_a_morph_target());
    let l = scenes::load_bytes("mouth", &bytes, 31);
    let pass = self_pass(&l, &[]);
    let mut folds = 0;
    for f in [14, 20, 26, 30] {
        let input = l.frame(f);
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let (mut own, mut given) = (input.clone(), input.clone());
        let res = pass.run(&l.rig, &pose, &mut own).expect("runs");
        pass.run_with_normals(&l.rig, &pose, &mut given, &l.frame_normals(f))
            .expect("runs");
        folds += res.folds.len();
        assert!(own == given, "frame {f}: the outputs differ");
    }
    assert!(folds > 0, "the lips fold");
}

/// The mouth closing, with the paper's hand-set vertical direction (Fig. 1d): the upper lip's
/// outward direction is -Y. The jaw stops abruptly (frame 24 of 31). Sampled twice as finely,
/// the input's largest second difference halves (0.31 -> 0.15 h), and so does the output's
/// over the lips' middles (|x| < 0.45 at rest, where they press on each other). Over the
/// corners it does not (0.44 -> 0.34 h): the corners' crease pops, a vertex next to a zero-depth
/// crease vertex that joins its zone moving by 0.15-0.3 h for one frame (at 121 frames the
/// temporal ratio is 3.71), as the capsule's crease does at 76 frames. The corners fold into
/// each other since 2026-12-03 (the rig's corners half on each bone); before, the fold lay
/// outside the shared region and the whole output's second difference halved. The bound
/// guards the pop's size.
#[test]
fn mouth_closes() {
    let (coarse, fine, h) = mouth_closing(FoldParams::default());
    assert_eq!(coarse.pairs.len(), 1);
    let middle = |r: &Run| r.output_max_where(|p| p.x.abs() < 0.45) / h;
    println!(
        "mouth: largest second difference {:.2} h at 31 frames, {:.2} h at 61; over the lips' \
         middles {:.3} h and {:.3} h",
        coarse.output_max / h,
        fine.output_max / h,
        middle(&coarse),
        middle(&fine)
    );
    assert!(
        middle(&fine) < 0.6 * middle(&coarse),
        "mouth: the largest second difference over the lips' middles does not shrink with the \
         frame step"
    );
    assert!(
        fine.output_max < 0.4 * h,
        "mouth: the largest second difference at 61 frames is {:.2} h",
        fine.output_max / h
    );
}

/// The mouth's corners with [`FoldParams::free_isolated_crease`]: the crease vertices that do
/// not connect to their zone, whose pins and signs made the corners pop (`mouth_closes`), stay
/// out of it. The output's largest second difference then halves with the frame step over the
/// whole mouth, like the input's (measured 0.315 -> 0.157 h, as with the former rule that left
/// them in their zone with `σ` free; without the setting 0.44 -> 0.34 h), with no penetrating
/// vertex nor turned face.
#[test]
fn freeing_isolated_crease_vertices_removes_the_mouths_pop() {
    let (coarse, fine, h) = mouth_closing(FoldParams {
        free_isolated_crease: true,
        ..FoldParams::default()
    });
    println!(
        "mouth, isolated crease vertices free: largest second difference {:.3} h at 31 frames, \
         {:.3} h at 61",
        coarse.output_max / h,
        fine.output_max / h
    );
    assert!(
        fine.output_max < 0.6 * coarse.output_max,
        "the mouth still pops with the isolated crease vertices free"
    );
}

/// [`FoldParams::free_isolated_crease`]'s rule, read off the folds' own zones: the zones with
/// the setting are exactly those without it less the crease vertices the fold added (zone
/// vertices of `R` that Eq. 3 did not take) that no path over `R`'s edges through vertices of
/// the zone joins to one that Eq. 3 took, the paths read off the zones without the setting
/// (on the same input: one sweep, one fold a frame); `σ` is its zone's sign at every zone
/// vertex either way. On
/// the mouth (vertical direction) and the CoR capsule, 31 frames. Measured: on the mouth 161
/// crease vertices joined without the setting, all isolated, none with it; on the capsule
/// most connect.
#[test]
fn isolated_crease_vertices_stay_out_of_the_zones() {
    use contact_skin::contact::zones::safeguard_cos;
    use contact_skin::selfcontact::derive_pairs;
    let mut connected_anywhere = 0;
    for (name, method, directions) in [
        ("mouth", Method::Lbs, mouth_vertical()),
        ("bending_capsule", Method::Cor, vec![]),
    ] {
        let l = load_with(name, 31, method);
        let pairs = derive_pairs(&l.rig, &l.pre.welded, &RegionOptions::default()).expect("pairs");
        let r = &pairs[0];
        let shared = |v: usize| r.w1[v] && r.w2[v];
        let adj = vertex_adjacency(r.w1.len(), &l.triangles[0]);
        // `R`'s own edges (those of its faces), over which the fold connects a crease vertex.
        let r_faces: Vec<[u32; 3]> = r
            .shared_faces
            .iter()
            .map(|&t| l.triangles[0][t as usize])
            .collect();
        let r_adj = vertex_adjacency(r.w1.len(), &r_faces);
        let guard = safeguard_cos(FoldParams::default().safeguard_angle);
        let zones = |free: bool| {
            let params = FoldParams {
                free_isolated_crease: free,
                ..FoldParams::default()
            };
            let pass = self_pass_with(&l, &directions, params).with_passes(1);
            let mut per_frame = vec![None; l.times.len()];
            each_fold(&l, &pass, |f, fold, _| {
                let c = &fold.output.contact;
                for v in (0..c.sides[0].zone.inside.len()).filter(|&v| shared(v)) {
                    if let Some(k) = (0..2).find(|&k| c.sides[k].zone.inside[v]) {
                        let sign = if k == 0 { 1.0 } else { -1.0 };
                        assert_eq!(fold.output.sigma[v], sign, "{name} frame {f}: vertex {v}");
                    }
                }
                assert!(per_frame[f].is_none(), "one fold a frame");
                per_frame[f] = Some(c.clone());
            });
            per_frame
        };
        let (without, with) = (zones(false), zones(true));
        let (mut isolated, mut connected) = (0, 0);
        for (f, (a, b)) in without.iter().zip(&with).enumerate() {
            let (Some(a), Some(b)) = (a, b) else {
                assert!(
                    a.is_none() && b.is_none(),
                    "{name} frame {f}: the same folds"
                );
                continue;
            };
            for k in 0..2 {
                let eq3 = |v: usize| {
                    a.sides[k]
                        .samples
                        .get(v)
                        .is_some_and(|s| s.depth >= a.threshold && s.safeguard >= guard)
                };
                let reach = zone_reach(&a.sides[k].zone.inside, &r_adj, &eq3);
                for v in (0..adj.len()).filter(|&v| shared(v) && a.sides[k].zone.inside[v]) {
                    let kept = b.sides[k].zone.inside[v];
                    if eq3(v) {
                        assert!(kept, "{name} frame {f}: Eq. 3's vertex {v} left its zone");
                    } else if reach[v] {
                        assert!(
                            kept,
                            "{name} frame {f}: connected crease vertex {v} left out"
                        );
                        connected += 1;
                    } else {
                        assert!(!kept, "{name} frame {f}: isolated crease vertex {v} kept");
                        isolated += 1;
                    }
                }
                let extra = (0..adj.len())
                    .find(|&v| b.sides[k].zone.inside[v] && !a.sides[k].zone.inside[v]);
                assert_eq!(extra, None, "{name} frame {f}: the setting only removes");
            }
        }
        println!("{name} ({method:?}): {connected} crease vertices connect to their zone, {isolated} do not");
        assert!(isolated > 0, "{name}: isolated crease vertices occur");
        connected_anywhere += connected;
    }
    assert!(connected_anywhere > 0, "connected crease vertices occur");
}

/// Per vertex, whether it is reached from a vertex of `zone` that Eq. 3 took (`eq3`) through
/// vertices of `zone` over `adj` (`R`'s edges): from the zone without the setting alone, the
/// crease vertices the setting must keep.
fn zone_reach(zone: &[bool], adj: &[Vec<usize>], eq3: &dyn Fn(usize) -> bool) -> Vec<bool> {
    let mut reach = vec![false; zone.len()];
    let mut stack: Vec<usize> = (0..zone.len()).filter(|&v| zone[v] && eq3(v)).collect();
    for &v in &stack {
        reach[v] = true;
    }
    while let Some(v) = stack.pop() {
        for &w in &adj[v] {
            if zone[w] && !reach[w] {
                reach[w] = true;
                stack.push(w);
            }
        }
    }
    reach
}

/// Runs `pass` on every frame of `l` and calls `visit(frame, fold, input)` for each fold, with
/// the positions that fold started from (the frame's input, then each fold's output).
fn each_fold(
    l: &Loaded,
    pass: &SelfContactPass,
    mut visit: impl FnMut(usize, &FoldReport, &[Vec<Point3<f64>>]),
) {
    for f in 0..l.times.len() {
        let mut out = l.frame(f);
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let mut before = out.clone();
        let res = pass.run(&l.rig, &pose, &mut out).expect("pass runs");
        for fold in &res.folds {
            visit(f, fold, &before);
            before[fold.body].clone_from(&fold.output.positions);
        }
    }
}

/// Vertex neighbours over the edges of `triangles`.
fn vertex_adjacency(n: usize, triangles: &[[u32; 3]]) -> Vec<Vec<usize>> {
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            adj[a].push(b);
            adj[b].push(a);
        }
    }
    adj
}

/// The mouth with the direction estimated from the relative motion of the parts (2021 Sec. 6)
/// instead of set by hand: the same checks as with the vertical.
#[test]
fn mouth_closes_with_the_motion_direction() {
    let dirs = [("lips/head-jaw".to_string(), DirectionSource::Motion)];
    let r = run("mouth", 31, &dirs);
    assert_eq!(r.pairs.len(), 1);
    check("mouth (motion)", &r, 0, 0, 3.0);
}

/// The mouth with the default direction, from the skeleton. The jaw is a leaf joint: its
/// "bone" is the direction of the lower lip's vertices, 9° from the head joint's at rest, and
/// closing the jaw sweeps it past, where `normalize(u2 - u1)` turned over into the lips: from
/// frame 21 of 31 on the fold found no contact zone and left the input's penetration (464 to
/// 588 vertices). The rest fold's sense keeps the direction (`skeleton_direction`, past a full
/// fold), within 12° of the paper's vertical in every frame with a fold (measured
/// 8.4-11.5°), and the mouth closes as with the vertical.
#[test]
fn mouth_closes_with_the_skeleton_direction() {
    let r = run("mouth", 31, &[]);
    assert_eq!(r.pairs.len(), 1);
    check("mouth (skeleton)", &r, 0, 0, 3.0);
    let worst = r
        .directions
        .iter()
        .map(|(_, d)| d.dot(&-Vector3::y()).clamp(-1.0, 1.0).acos().to_degrees())
        .fold(0.0, f64::max);
    let mut frames: Vec<usize> = r.directions.iter().map(|(f, _)| *f).collect();
    frames.dedup();
    println!("mouth: folds in frames {frames:?}, skeleton direction within {worst:.1}° of -Y");
    // Once the lips touch, every frame folds (frames 11 to 30).
    let first = *frames.first().expect("folds");
    assert_eq!(frames, (first..31).collect::<Vec<_>>());
    assert!(worst < 12.0, "{worst:.1}° from the vertical");
}

/// The direction from the relative motion of the parts agrees with the skeleton's on the
/// articulations (capsule, finger) and with the paper's hand-set vertical on the mouth (the
/// lips are no articulation: the paper sets their direction by hand), in every frame with a
/// fold.
/// Measured: capsule 0.0°, finger at most 6.8°, mouth at most 6.9°.
#[test]
fn the_motion_direction_agrees_with_the_skeleton_and_the_vertical() {
    use contact_skin::selfcontact::{derive_pairs, skeleton_direction, BoneAxes};
    for (name, bound) in [("bending_capsule", 1.0), ("finger", 10.0), ("mouth", 10.0)] {
        let l = load(name, 31);
        let pairs = derive_pairs(&l.rig, &l.pre.welded, &RegionOptions::default()).expect("pairs");
        let motion: Vec<(String, DirectionSource)> = pairs
            .iter()
            .map(|p| (p.pair.name.clone(), DirectionSource::Motion))
            .collect();
        let pass = self_pass(&l, &motion).with_passes(1);
        let (mut worst, mut folds) = (0.0f64, 0);
        for f in 0..31 {
            let mut out = l.frame(f);
            let pose = l.rig.pose_at(Some(0), l.times[f]);
            let res = pass.run(&l.rig, &pose, &mut out).expect("pass runs");
            assert_eq!(res.no_direction, 0, "{name} frame {f}: a direction exists");
            for fold in &res.folds {
                let p = pairs
                    .iter()
                    .find(|p| p.pair.name == fold.name)
                    .expect("a derived pair");
                let reference = if name == "mouth" {
                    -Vector3::y()
                } else {
                    let axes = BoneAxes::new(&l.rig, &l.pre.welded[p.pair.body], p);
                    skeleton_direction(&pose, &p.pair, &axes).expect("skeleton")
                };
                let cosine = fold.direction.dot(&reference).clamp(-1.0, 1.0);
                worst = worst.max(cosine.acos().to_degrees());
                folds += 1;
            }
        }
        println!("{name}: {folds} folds, motion direction within {worst:.1}° of the reference");
        assert!(folds > 0, "{name}: folds");
        assert!(worst < bound, "{name}: {worst:.1}° from the reference");
    }
}

/// One sweep (`passes = 1`, half the time of the default two) leaves the folds touching, not
/// interpenetrating: the vertices `MEASURING.md` still flags (its nudge is 0.05 h, and two
/// triangulations of one curved contact surface `S` cross each other by more) lie within
/// 0.25 h of the surface on the other side of a fold's crease cut, which bounds how deep they
/// can be. Measured at frames 20, 25 and 30 (summed): finger 393 flagged, capsule 12, all
/// within 0.25 h. The second sweep clears them.
#[test]
fn one_sweep_leaves_the_folds_touching() {
    for name in ["finger", "bending_capsule"] {
        let l = load(name, 31);
        let pass = self_pass(&l, &[]).with_passes(1);
        let t = &l.triangles[0];
        let mut flagged = 0;
        for f in [20, 25, 30] {
            let mut out = l.frame(f);
            let pose = l.rig.pose_at(Some(0), l.times[f]);
            let res = pass.run(&l.rig, &pose, &mut out).expect("pass runs");
            let p = &out[0];
            for &v in &penetration(&l, 0, p).flagged {
                let v = v as usize;
                let gap = res
                    .folds
                    .iter()
                    .filter(|fold| fold.output.sigma[v] != 0.0)
                    .flat_map(|fold| {
                        let (on, sigma) = (&fold.output.crease.on_w1, &fold.output.sigma);
                        t.iter().filter(move |tri| {
                            tri.iter()
                                .all(|&c| sigma[c as usize] != 0.0 && on[c as usize] != on[v])
                        })
                    })
                    .map(|tri| {
                        let c = tri.map(|i| p[i as usize]);
                        metrics::point_triangle_distance(&p[v], &c)
                    })
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    gap < 0.25 * l.h_rest,
                    "{name} frame {f}: vertex {v} is {:.2} h from the other side",
                    gap / l.h_rest
                );
                flagged += 1;
            }
        }
        println!("{name}: one sweep, {flagged} flagged vertices, all touching");
    }
}

/// The bending capsule's one fold, precomputed, for tests of single folds.
struct CapsuleFold {
    l: Loaded,
    pre: contact_skin::selfcontact::fold::FoldPre,
    axes: contact_skin::selfcontact::BoneAxes,
    pair: contact_skin::selfcontact::JointPair,
}

/// One frame of [`CapsuleFold`]: the input, its normals, `d̂` and the fold (if any).
struct FoldFrame {
    input: Vec<Point3<f64>>,
    normals: Vec<Vector3<f64>>,
    direction: Vector3<f64>,
    out: Option<contact_skin::selfcontact::fold::FoldOutput>,
}

impl CapsuleFold {
    fn new() -> Self {
        Self::skinned_with(Method::Lbs)
    }

    fn skinned_with(method: Method) -> Self {
        use contact_skin::selfcontact::{derive_pairs, fold::FoldPre, BoneAxes};
        let l = load_with("bending_capsule", 31, method);
        let rest = welded_positions(&l.rig, &l.pre, 0.0, None);
        let pairs = derive_pairs(&l.rig, &l.pre.welded, &RegionOptions::default()).expect("pairs");
        let regions = pairs.into_iter().next().expect("one pair");
        let axes = BoneAxes::new(&l.rig, &l.pre.welded[0], &regions);
        let pair = regions.pair.clone();
        let pre = FoldPre::new(&rest[0], &l.triangles[0], regions).expect("fold");
        Self { l, pre, axes, pair }
    }

    /// The convex side of the joint (rest `x > 0`; the bend turns toward -X) where
    /// `β ∈ [0.4, 0.6]`.
    fn exterior_band(&self) -> Vec<usize> {
        let r = &self.pre.regions;
        let rest = welded_positions(&self.l.rig, &self.l.pre, 0.0, None);
        (0..rest[0].len())
            .filter(|&v| r.w1[v] && r.w2[v] && (r.beta[v] - 0.5).abs() < 0.1)
            .filter(|&v| rest[0][v].x > 0.0)
            .collect()
    }

    /// Per frame `0..=last` with a fold: how far the `exterior` moved at most (edge lengths).
    fn exterior_motion(
        &self,
        exterior: &[usize],
        last: usize,
        params: &FoldParams,
    ) -> Vec<(usize, f64)> {
        (0..=last)
            .filter_map(|f| {
                let frame = self.at(f, params);
                let out = frame.out?;
                let moved = exterior
                    .iter()
                    .map(|&v| (out.positions[v] - frame.input[v]).norm() / self.l.h_rest)
                    .fold(0.0, f64::max);
                Some((f, moved))
            })
            .collect()
    }

    fn at(&self, f: usize, params: &FoldParams) -> FoldFrame {
        self.at_with(&self.pre, 1.0, f, params)
    }

    /// The same fold with the two working regions' roles exchanged: `W1 ↔ W2`, `β → 1 - β`
    /// (0 outside both, as before), the faces' lists swapped; `d̂_12` (W1's outward direction)
    /// is then the negated one.
    fn swapped(&self) -> contact_skin::selfcontact::fold::FoldPre {
        use contact_skin::selfcontact::fold::FoldPre;
        let mut r = self.pre.regions.clone();
        std::mem::swap(&mut r.w1, &mut r.w2);
        std::mem::swap(&mut r.w1_faces, &mut r.w2_faces);
        for (v, b) in r.beta.iter_mut().enumerate() {
            if r.w1[v] || r.w2[v] {
                *b = 1.0 - *b;
            }
        }
        let rest = welded_positions(&self.l.rig, &self.l.pre, 0.0, None);
        FoldPre::new(&rest[0], &self.l.triangles[0], r).expect("swapped fold")
    }

    /// Frame `f` of the fold `pre` (this one or [`CapsuleFold::swapped`]) with the skeleton's
    /// direction times `sign`.
    fn at_with(
        &self,
        pre: &contact_skin::selfcontact::fold::FoldPre,
        sign: f64,
        f: usize,
        params: &FoldParams,
    ) -> FoldFrame {
        use contact_skin::selfcontact::{fold::resolve_detected, skeleton_direction};
        let l = &self.l;
        let input = l.frame(f).swap_remove(0);
        let skinned = l.frame_normals(f).swap_remove(0);
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let direction =
            sign * skeleton_direction(&pose, &self.pair, &self.axes).expect("direction");
        let normals = vertex_normals(&input, &l.triangles[0], NormalWeighting::Area);
        let detection = pre.detect(&input, &l.triangles[0]).expect("detection runs");
        let out = detection.and_then(|d| {
            resolve_detected(
                pre,
                &d,
                &FoldInput {
                    positions: &input,
                    normals: &normals,
                    triangles: &l.triangles[0],
                    direction,
                    turn_reference: Some(TurnReference {
                        positions: &input,
                        normal: &|v| skinned[v],
                    }),
                    left_penetrating: None,
                },
                params,
            )
            .expect("fold runs")
            .into_output()
        });
        FoldFrame {
            input,
            normals,
            direction,
            out,
        }
    }
}

/// Exchanging the roles of the two working regions (`W1 ↔ W2`, `β → 1 - β`,
/// `d̂_12 → -d̂_12`, `k̄ → 1 - k̄`) describes the same fold: the crease cut, the contact
/// between the truncated parts, `σ d̂`, the blend, the volume solve and the turn guard must
/// give the same surface.
/// Bending capsule with LBS and CoR input, one material and a stiffer W2, every frame with a
/// fold (from frame 8 of 31 to 150°): the same cut (complemented), the same zones (swapped),
/// the same positions. Measured: 6.7e-15 h at most.
#[test]
fn a_fold_is_the_same_with_its_regions_exchanged() {
    for method in [Method::Lbs, Method::Cor] {
        let fold = CapsuleFold::skinned_with(method);
        let swapped = fold.swapped();
        let r = &fold.pre.regions;
        for stiffness_1 in [0.5, 0.3] {
            let params = FoldParams {
                stiffness_1,
                ..FoldParams::default()
            };
            let exchanged = FoldParams {
                stiffness_1: 1.0 - stiffness_1,
                ..params
            };
            let (mut folds, mut worst) = (0, 0.0f64);
            for f in 0..31 {
                let (a, b) = (
                    fold.at(f, &params).out,
                    fold.at_with(&swapped, -1.0, f, &exchanged).out,
                );
                let label = format!("{method:?} k̄ {stiffness_1} frame {f}");
                let (a, b) = match (a, b) {
                    (Some(a), Some(b)) => (a, b),
                    (None, None) => continue,
                    _ => panic!("{label}: a fold in one description only"),
                };
                let cut_differs = (0..r.w1.len())
                    .filter(|&v| r.w1[v] && r.w2[v])
                    .any(|v| a.crease.on_w1[v] == b.crease.on_w1[v]);
                assert!(!cut_differs, "{label}: the crease cuts are not complements");
                let zone = |o: &contact_skin::selfcontact::fold::FoldOutput, k: usize| {
                    o.contact.sides[k].zone.vertices.clone()
                };
                assert_eq!(zone(&a, 0), zone(&b, 1), "{label}: W1's zone");
                assert_eq!(zone(&a, 1), zone(&b, 0), "{label}: W2's zone");
                let gap = a
                    .positions
                    .iter()
                    .zip(&b.positions)
                    .map(|(p, q)| (p - q).norm() / fold.l.h_rest)
                    .fold(0.0, f64::max);
                assert!(
                    gap < 1e-9,
                    "{label}: the descriptions differ by {gap:.2e} h"
                );
                worst = worst.max(gap);
                folds += 1;
            }
            println!("{method:?} k̄ {stiffness_1}: {folds} folds, largest gap {worst:.1e} h");
            assert!(folds >= 20, "{method:?}: the capsule folds from frame 8 on");
        }
    }
}

/// The reflection through the plane by the origin of normal `n` (`I - 2 n̂ n̂ᵀ`).
fn reflection(n: Vector3<f64>) -> Matrix4<f64> {
    let n = n.normalize();
    let h: nalgebra::Matrix3<f64> = nalgebra::Matrix3::identity() - n * n.transpose() * 2.0;
    h.to_homogeneous()
}

/// The image of `rig` under the orthogonal map `s` (a reflection or a rotation about the
/// origin): rest transforms and inverse bind matrices conjugated, positions and normals mapped,
/// and, for a reflection, every triangle's winding reversed (normals stay outward). Its
/// animations are not mapped (a reflection has no translation-rotation-scale form): it is
/// posed with the original's world matrices conjugated.
fn mapped_rig(rig: &rig::Rig, s: &Matrix4<f64>) -> rig::Rig {
    let inverse = s.transpose();
    let mut m = rig.clone();
    for node in &mut m.nodes {
        node.rest = rig::LocalTransform::Matrix(s * node.rest.matrix() * inverse);
    }
    for skin in &mut m.skins {
        for b in &mut skin.inverse_bind {
            *b = s * *b * inverse;
        }
    }
    let reverses = s.fixed_view::<3, 3>(0, 0).determinant() < 0.0;
    for body in &mut m.bodies {
        body.positions
            .iter_mut()
            .for_each(|p| *p = s.transform_point(p));
        body.normals
            .iter_mut()
            .for_each(|n| *n = s.transform_vector(n));
        if reverses {
            body.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        }
    }
    m
}

/// Every body's points mapped by `s` (a reflection or a rotation).
fn map_points(s: &Matrix4<f64>, bodies: &[Vec<Point3<f64>>]) -> Vec<Vec<Point3<f64>>> {
    bodies
        .iter()
        .map(|b| b.iter().map(|p| s.transform_point(p)).collect())
        .collect()
}

/// A fold and its mirror image, or the fold rotated, give mirrored or rotated surfaces: the rig
/// mapped (a reflection also reverses its triangles' winding so that they still face out),
/// posed by the mapped skeleton and skinned to the mapped input. The skeleton's direction, the
/// joints' sizes, the crease cut, the truncated parts' contours and their inside tags (an
/// orientation), the zones, `σ`, the deformation, the volume solve and the turn guard must not
/// depend on the handedness of space nor on the frame the rig is given in. The finger (three
/// joints), the mouth and the bending capsule, LBS, every frame of 31, one sweep: the same
/// folds in every frame, the pass moving vertices by edge lengths (2.8, 1.2, 4.9 h), the same
/// positions mapped, to within what round-off makes of the pass's discrete decisions. Measured
/// (finger, mouth, capsule):
/// - through `x = 0`, each rig's own plane of symmetry (the mirror image is the same surface
///   with its triangles reversed, so only the order of operations changes): 8.9e-3 h (a
///   boundary point bisected to `2^-16` of its edge, a vertex with `n·m̂` near 0 on a contour
///   or not, and Eq. 4's threshold, a statistic of those, turning that into a zone vertex more
///   or less), 3.5e-5 h, 1.6e-4 h; before the walls' crossings at contour points were made
///   independent of round-off: 5.8e-2, 8.9e-5 and 5.6e-3 h;
/// - through a plane tilted against every axis (normal `(1, 2, 3)`): 1.5e-2, 2.0e-3,
///   6.7e-2 h; rotated by 1 rad about that axis: 1.9e-2, 2.1e-3, 0.13 h. The mouth's were
///   8.8e-5, 8.8e-5 and 2.9e-13 h while its corners followed the head alone (until 2026-12-03:
///   its shared region lay on the lower lip, away from the fold, whose crease now lies in it
///   and brings the crease cut's and the zones' decisions there). While a joint's size
///   (which scales `φ̄`) was the diagonal of its shared region's axis-aligned box: 0.13, 8.7e-3,
///   0.35 h and 0.15, 7.8e-3, 0.39 h. What remains on the capsule is round-off at the pass's
///   ties (its crease cut, for one, has two mirror-image cuts of equal cost at `β = 0.5`).
///
/// Since 2026-12-03 the crease cut's seam vertices join the mapping regions
/// (`contact::mapping`'s seam rule): 5.6e-2, 3.4e-5 and 7.5e-5 h through `x = 0`, 0.11, 5.0e-3
/// and 0.10 h through the tilted plane, 0.11, 1.3e-2 and 0.15 h under the rotation. The seam
/// lies on the silhouette (`n·m̂` near 0), where a vertex shared by the two parts is in one
/// side's mapping region or the other's by round-off: under the rotation, one vertex of the
/// finger (welded 3154, frame 27, the middle-distal fold) is, over 31 frames, the only
/// difference between the images' mapping regions, and the zones' threshold spreads it.
///
/// Since Eq. 4's moments are taken over each part's own faces (also 2026-12-03; they took in
/// the other part's faces along the seam): 8.9e-2, 3.4e-5 and 9.7e-5 h through `x = 0`,
/// 6.0e-2, 2.8e-3 and 0.11 h through the tilted plane, 8.4e-2, 2.7e-3 and 0.13 h under the
/// rotation.
///
/// The bounds guard these measurements.
#[test]
fn a_fold_and_its_mirror_image_agree() {
    let tilted = Vector3::new(1.0, 2.0, 3.0);
    let turn = nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(tilted), 1.0);
    let maps = [
        ("plane x = 0", reflection(Vector3::x()), [0.15, 1e-3, 2e-3]),
        ("tilted plane", reflection(tilted), [0.2, 1e-2, 0.25]),
        ("rotation", turn.to_homogeneous(), [0.2, 1e-2, 0.25]),
    ];
    for (label, s, bounds) in maps {
        for (name, bound) in ["finger", "mouth", "bending_capsule"]
            .into_iter()
            .zip(bounds)
        {
            let (worst, moved) = mapped_run(name, &s);
            println!(
                "{name}, {label}: vertices moved by up to {moved:.2} h, images differ by \
                 {worst:.1e} h"
            );
            assert!(moved > 1.0, "{name}: the pass moved vertices by {moved} h");
            assert!(
                worst < bound,
                "{name}, {label}: images differ by {worst:.1e} h"
            );
        }
    }
}

/// Runs `name`'s 31 frames (one sweep) and their images under `s` (a reflection or a
/// rotation): the largest difference between the output mapped by `s` and the image's output,
/// and the largest displacement, both in edge lengths.
fn mapped_run(name: &str, s: &Matrix4<f64>) -> (f64, f64) {
    let l = load(name, 31);
    let pass = self_pass(&l, &[]).with_passes(1);
    let m_rig = mapped_rig(&l.rig, s);
    let m_pre = contact_skin::frames::Precomputed::new(&m_rig, Method::Lbs);
    assert_eq!(
        m_pre.welded[0].to_welded, l.pre.welded[0].to_welded,
        "{name}: welds"
    );
    let rest = welded_positions(&l.rig, &l.pre, 0.0, None);
    let (o, p) = (RegionOptions::default(), FoldParams::default());
    let m_pass = SelfContactPass::new(&m_rig, &m_pre.welded, &map_points(s, &rest), &o, p, &[])
        .expect("mapped pass precomputes")
        .with_passes(1);
    let names = |r: &SelfPassOutput| -> Vec<String> {
        r.folds.iter().map(|fold| fold.name.clone()).collect()
    };
    let (mut worst, mut moved) = (0.0f64, 0.0f64);
    for f in 0..l.times.len() {
        let input = l.frame(f);
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let m_pose = rig::Pose::new(pose.world.iter().map(|w| s * w * s.transpose()).collect());
        // The mapped rig skinned at the mapped pose is the mapped input.
        let m_input =
            contact_skin::frames::evaluate_pose(&m_rig, &m_pre, &m_pose, f, 0.0).welded(&m_pre);
        let skinned = max_distance(&m_input[0], &map_points(s, &input)[0]) / l.h_rest;
        assert!(skinned < 1e-9, "{name} frame {f}: skinning {skinned:e} h");
        let mut out = input.clone();
        let res = pass.run(&l.rig, &pose, &mut out).expect("pass runs");
        let mut m_out = m_input;
        let m_res = m_pass
            .run(&m_rig, &m_pose, &mut m_out)
            .expect("mapped pass runs");
        assert_eq!(names(&res), names(&m_res), "{name} frame {f}: folds");
        worst = worst.max(max_distance(&map_points(s, &out)[0], &m_out[0]) / l.h_rest);
        moved = moved.max(max_distance(&out[0], &input[0]) / l.h_rest);
    }
    (worst, moved)
}

fn max_distance(a: &[Point3<f64>], b: &[Point3<f64>]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max)
}

/// A fold's time in Table 1's columns (`FoldTimings::stages`) is a partition of its steps' time:
/// on one thread the columns are sub-intervals of the steps, none negative, their sum at most
/// the fold's whole time, the factorizations inside p., di. and g.
#[test]
fn table1_columns_partition_the_fold_time() {
    let fold = CapsuleFold::new();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let frame = pool.install(|| fold.at(30, &FoldParams::default()));
    let out = frame.out.expect("the capsule folds at 150°");
    let s = out.timings.stages;
    let columns = [
        s.intersection,
        s.mapping,
        s.zones,
        s.parametrization,
        s.directions,
        s.fields,
        s.deformation,
    ];
    assert!(columns.iter().all(|&c| c >= 0.0), "{s:?}");
    assert!(s.parametrization > 0.0 && s.intersection > 0.0, "{s:?}");
    assert_eq!(s.wall, out.timings.total());
    assert!(columns.iter().sum::<f64>() <= s.wall, "{s:?}");
    assert!(
        s.factorization > 0.0 && s.factorization <= s.parametrization + s.directions + s.fields,
        "{s:?}"
    );
}

/// PIPELINE.md's check of the crease cut: it follows the fold, i.e. every vertex of a cut edge
/// of the shared region lies within one ring of the silhouette of `R` seen from `d̂`
/// (vertices where `n·d̂` changes sign along an edge). Measured on the bending capsule.
#[test]
fn crease_cut_follows_the_silhouette() {
    let fold = CapsuleFold::new();
    let r = &fold.pre.regions;
    let shared: Vec<bool> = r.w1.iter().zip(&r.w2).map(|(a, b)| *a && *b).collect();
    let (mut worst, mut cut_frames) = (0, 0);
    for f in [12, 18, 24, 30] {
        let frame = fold.at(f, &FoldParams::default());
        let Some(out) = frame.out else { continue };
        cut_frames += 1;
        let dist = cut_rings(
            &fold.l.triangles[0],
            &frame.normals,
            &out.crease.on_w1,
            &shared,
            &frame.direction,
            &[],
        )
        .everywhere;
        println!("frame {f}: crease vertices within {dist} rings of the silhouette");
        worst = worst.max(dist);
    }
    assert!(cut_frames >= 3);
    assert!(
        worst <= 1,
        "the crease cut strays {worst} rings from the silhouette"
    );
}

/// The same check through the pass (one sweep, so that each fold's input is the previous
/// fold's output) on every frame with a fold of the finger's three joints, of the capsule with
/// LBS, CoR and DQS input, and of the mouth with the paper's vertical direction and with the
/// skeleton's (the default). Each cut is held to what any partition of `R` can reach: it lies
/// within one ring of the silhouette wherever some partition does, and never farther than the
/// nearest partition must go ([`fewest_rings_of_any_cut`], a bound computed from the terminals
/// and the silhouette alone, not from the cut). Measured: the finger and the capsule within
/// one ring (the bound is 1 in 120 of their 127 cuts and 0 in the other 7, the capsule's, of
/// which one cut takes 1 ring); the mouth's shared region is a band round each lip corner, so its cut is a
/// loop round the lip: where it crosses the fold (within one ring of a crossing face) it lies
/// on the silhouette (0 rings; 36 of its 152 cut vertices there at the deepest frames; the
/// first 9 of its 20 cuts, before the corners fold, do not meet the fold), and it closes round
/// the front and back of the lip, away from the fold, 2-3 rings from the silhouette (4 with
/// the skeleton's direction, 8-12° from the vertical), whose lines there run along the lip:
/// in each of the 40 cuts exactly the bound, so no partition of the mouth's `R` lies within
/// one ring of that silhouette. With it, `PIPELINE.md`'s other check of the cut: every pair of
/// faces that cross (the detection's, across `β = 0.5`) straddles it. Measured: on the capsule
/// with all three inputs and on the mouth, in every frame; on the finger 3 pairs in 2 of its
/// 58 cuts (the middle-distal joint, frames 28 and 29: a face across the silhouette, at the
/// crease's bottom, goes with its two corners past it to the side of the face it crosses).
/// Not measured here: a second sweep, which starts from the first's output, where both sides
/// lie on one contact surface and their faces cross by a fraction of an edge (LBS capsule 0-3
/// pairs out of 300-800 per frame, CoR 2-39, DQS 1-54).
#[test]
fn crease_cut_follows_the_silhouette_on_every_rig() {
    use contact_skin::selfcontact::derive_pairs;
    // (rig, input, directions, crossing pairs left on one side, cuts that do not meet the
    // fold)
    for (name, method, directions, unseparated_at_most, missing_at_most) in [
        ("finger", Method::Lbs, vec![], 4, 0),
        ("bending_capsule", Method::Lbs, vec![], 0, 0),
        ("bending_capsule", Method::Cor, vec![], 0, 0),
        ("bending_capsule", Method::Dqs, vec![], 0, 0),
        ("mouth", Method::Lbs, mouth_vertical(), 0, 9),
        ("mouth", Method::Lbs, vec![], 0, 9),
    ] {
        let l = load_with(name, 31, method);
        let pass = self_pass(&l, &directions).with_passes(1);
        let pairs = derive_pairs(&l.rig, &l.pre.welded, &RegionOptions::default()).expect("pairs");
        let (mut worst, mut cuts, mut unseparated, mut missing) = (CutRings::default(), 0, 0, 0);
        let mut worst_bound = 0;
        each_fold(&l, &pass, |f, fold, before| {
            let b = fold.body;
            let r = pairs
                .iter()
                .find(|p| p.pair.name == fold.name)
                .expect("a derived pair");
            let shared: Vec<bool> = r.w1.iter().zip(&r.w2).map(|(a, b)| *a && *b).collect();
            let normals = vertex_normals(&before[b], &l.triangles[b], NormalWeighting::Area);
            let crossing = crossing_face_pairs(&before[b], &l.triangles[b], r);
            let rings = cut_rings(
                &l.triangles[b],
                &normals,
                &fold.output.crease.on_w1,
                &shared,
                &fold.direction,
                &crossing,
            );
            let bound = fewest_rings_of_any_cut(&l.triangles[b], &normals, r, &fold.direction);
            assert!(
                bound <= rings.everywhere && rings.everywhere <= bound.max(1),
                "{name} ({method:?}) {} frame {f}: the crease cut strays {} rings, any \
                 partition at least {bound}",
                fold.name,
                rings.everywhere
            );
            worst_bound = worst_bound.max(bound);
            worst.everywhere = worst.everywhere.max(rings.everywhere);
            worst.at_fold = worst.at_fold.max(rings.at_fold);
            worst.at_fold_vertices += rings.at_fold_vertices;
            missing += usize::from(rings.at_fold_vertices == 0);
            cuts += 1;
            let labels = cut_sides(&l.triangles[b], r, &fold.output.crease.on_w1);
            let here = crossing
                .iter()
                .filter(|p| labels[p[0] as usize] == labels[p[1] as usize])
                .count();
            // The fold's own count of the same check (reported in the diagnostics).
            assert_eq!(fold.output.unseparated, here, "{name}: {}", fold.name);
            unseparated += here;
        });
        println!(
            "{name} ({method:?}): {cuts} crease cuts, {missing} not meeting the fold, within {} \
             rings of the silhouette (any partition at least {worst_bound}; {} at the fold, {} \
             cut vertices there over the cuts), {unseparated} crossing face pairs on one side",
            worst.everywhere, worst.at_fold, worst.at_fold_vertices
        );
        assert!(cuts > 0, "{name}: folds");
        assert!(
            missing <= missing_at_most,
            "{name} ({method:?}): {missing} of {cuts} crease cuts do not meet the fold"
        );
        assert!(
            worst.at_fold <= 1,
            "{name} ({method:?}): the crease cut strays {} rings at the fold",
            worst.at_fold
        );
        assert!(
            unseparated <= unseparated_at_most,
            "{name} ({method:?}): {unseparated} crossing face pairs left on one side of the cut"
        );
    }
}

/// The pairs of faces that cross at `positions` between the two rest sides of `W1 ∪ W2` (a
/// face is on W1's side where its corners' mean `β` is at least 0.5, as the fold's detection
/// labels them), found by the intersection module rather than by the fold; one per pair.
fn crossing_face_pairs(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    r: &contact_skin::selfcontact::PairRegions,
) -> Vec<[u32; 2]> {
    let labels: Vec<u8> = triangles
        .iter()
        .map(|t| {
            let all = |w: &[bool]| t.iter().all(|&v| w[v as usize]);
            let beta = t.iter().map(|&v| r.beta[v as usize]).sum::<f64>() / 3.0;
            match (all(&r.w1) || all(&r.w2), beta >= 0.5) {
                (false, _) => 0,
                (true, true) => 1,
                (true, false) => 2,
            }
        })
        .collect();
    let found = contact_skin::intersect::mesh_mesh::intersect_parts(positions, triangles, &labels)
        .expect("intersections");
    found.segments.iter().map(|s| s.faces).collect()
}

/// Per face of `W1 ∪ W2`, the side of the cut `on_w1` that holds at least two of its corners
/// (1: W1's, 2: W2's; 0 outside both regions).
fn cut_sides(
    triangles: &[[u32; 3]],
    r: &contact_skin::selfcontact::PairRegions,
    on_w1: &[bool],
) -> Vec<u8> {
    triangles
        .iter()
        .map(|t| {
            let all = |w: &[bool]| t.iter().all(|&v| w[v as usize]);
            if !(all(&r.w1) || all(&r.w2)) {
                0
            } else if t.iter().filter(|&&v| on_w1[v as usize]).count() >= 2 {
                1
            } else {
                2
            }
        })
        .collect()
}

/// How far a crease cut lies from the silhouette of the shared region seen from `d̂`, in rings
/// (topological distance to a vertex of `R` where `n·d̂` changes sign along an edge of `R`).
#[derive(Default)]
struct CutRings {
    /// Largest over the vertices of the cut edges of `R`.
    everywhere: usize,
    /// Largest over those within one ring of a face of the crossing pairs given (the fold).
    at_fold: usize,
    /// How many cut vertices lie within one ring of the fold.
    at_fold_vertices: usize,
}

fn cut_rings(
    triangles: &[[u32; 3]],
    normals: &[nalgebra::Vector3<f64>],
    on_w1: &[bool],
    shared: &[bool],
    d: &nalgebra::Vector3<f64>,
    crossing: &[[u32; 2]],
) -> CutRings {
    let n = normals.len();
    let (adj, dist) = silhouette_rings(triangles, normals, shared, d);
    let fold_corners = crossing
        .iter()
        .flatten()
        .flat_map(|&f| triangles[f as usize])
        .map(|v| v as usize);
    let from_fold = rings_from(&adj, fold_corners);
    let mut out = CutRings::default();
    let cut =
        (0..n).filter(|&v| shared[v] && adj[v].iter().any(|&w| shared[w] && on_w1[w] != on_w1[v]));
    for v in cut {
        out.everywhere = out.everywhere.max(dist[v]);
        if from_fold[v] <= 1 {
            out.at_fold = out.at_fold.max(dist[v]);
            out.at_fold_vertices += 1;
        }
    }
    out
}

/// The fewest rings from the silhouette of `R` seen from `d` that any partition of `R` must
/// reach (the measure of [`cut_rings`]'s `everywhere`): the least `t` such that cutting only
/// edges of `R` whose two ends lie within `t` rings of the silhouette separates the cut's
/// terminals (the vertices of `R` next to `W1 \ R` from those next to `W2 \ R`).
fn fewest_rings_of_any_cut(
    triangles: &[[u32; 3]],
    normals: &[nalgebra::Vector3<f64>],
    r: &contact_skin::selfcontact::PairRegions,
    d: &nalgebra::Vector3<f64>,
) -> usize {
    let n = normals.len();
    let shared: Vec<bool> = (0..n).map(|v| r.w1[v] && r.w2[v]).collect();
    let (adj, dist) = silhouette_rings(triangles, normals, &shared, d);
    let next_to = |v: usize, w: &[bool]| adj[v].iter().any(|&o| w[o] && !shared[o]);
    let sources: Vec<usize> = (0..n)
        .filter(|&v| shared[v] && next_to(v, &r.w1) && !next_to(v, &r.w2))
        .collect();
    let sink: Vec<bool> = (0..n)
        .map(|v| shared[v] && next_to(v, &r.w2) && !next_to(v, &r.w1))
        .collect();
    (0..n)
        .find(|&t| {
            // Reach the sinks from the sources without crossing an edge that may be cut.
            let mut seen = vec![false; n];
            let mut stack = sources.clone();
            for &v in &stack {
                seen[v] = true;
            }
            while let Some(v) = stack.pop() {
                if sink[v] {
                    return false;
                }
                for &w in &adj[v] {
                    let cuttable = dist[v] <= t && dist[w] <= t;
                    if shared[w] && !seen[w] && !cuttable {
                        seen[w] = true;
                        stack.push(w);
                    }
                }
            }
            true
        })
        .unwrap_or(usize::MAX)
}

/// The vertex neighbours over `triangles`, and each vertex's distance in rings from the
/// silhouette of the shared region (`shared`) seen from `d`: the vertices of `R` where `n·d`
/// changes sign along an edge of `R`.
fn silhouette_rings(
    triangles: &[[u32; 3]],
    normals: &[nalgebra::Vector3<f64>],
    shared: &[bool],
    d: &nalgebra::Vector3<f64>,
) -> (Vec<Vec<usize>>, Vec<usize>) {
    let n = normals.len();
    let adj = vertex_adjacency(n, triangles);
    let g: Vec<f64> = normals.iter().map(|x| x.dot(d)).collect();
    let silhouette =
        (0..n).filter(|&v| shared[v] && adj[v].iter().any(|&w| shared[w] && g[v] * g[w] <= 0.0));
    let dist = rings_from(&adj, silhouette);
    (adj, dist)
}

/// Breadth-first distance, in edges, from `seeds` over the graph `adj` (`usize::MAX` where
/// unreached).
fn rings_from(adj: &[Vec<usize>], seeds: impl Iterator<Item = usize>) -> Vec<usize> {
    let mut dist = vec![usize::MAX; adj.len()];
    let mut queue = std::collections::VecDeque::new();
    for v in seeds {
        if dist[v] == usize::MAX {
            dist[v] = 0;
            queue.push_back(v);
        }
    }
    while let Some(v) = queue.pop_front() {
        for &w in &adj[v] {
            if dist[w] == usize::MAX {
                dist[w] = dist[v] + 1;
                queue.push_back(w);
            }
        }
    }
    dist
}

/// Bad input to the self-contact pass: typed errors, never a panic.
#[test]
fn bad_input_gives_typed_errors() {
    use contact_skin::selfcontact::pass::SelfPassError;
    let l = load("bending_capsule", 31);
    let pass = self_pass(&l, &[]);
    let pose = l.rig.pose_at(Some(0), l.times[30]);
    let mut nan = l.frame(30);
    nan[0][7].y = f64::NAN;
    assert!(matches!(
        pass.run(&l.rig, &pose, &mut nan),
        Err(SelfPassError::NonFinite { body: 0, vertex: 7 })
    ));
    let mut none: Vec<Vec<Point3<f64>>> = Vec::new();
    assert!(matches!(
        pass.run(&l.rig, &pose, &mut none),
        Err(SelfPassError::Mismatch(_))
    ));
    let mut short = l.frame(30);
    short[0].truncate(10);
    assert!(pass.run(&l.rig, &pose, &mut short).is_err());
    // A pose of another rig (fewer nodes): refused before any fold reads a joint from it.
    let mut frame = l.frame(30);
    let before = frame.clone();
    let mut other = pose.clone();
    other.world.pop();
    assert!(matches!(
        pass.run(&l.rig, &other, &mut frame),
        Err(SelfPassError::Mismatch(_))
    ));
    assert_eq!(frame, before, "nothing moved");
    // The skinning's normals for the turn guard: one per position, or refused before anything
    // moves; a non-finite normal is no reference (the frame still resolves, finite).
    let mut normals = l.frame_normals(30);
    normals[0].pop();
    assert!(matches!(
        pass.run_with_normals(&l.rig, &pose, &mut frame, &normals),
        Err(SelfPassError::Mismatch(_))
    ));
    assert_eq!(frame, before, "nothing moved");
    let mut normals = l.frame_normals(30);
    normals[0][7].x = f64::NAN;
    pass.run_with_normals(&l.rig, &pose, &mut frame, &normals)
        .expect("a NaN normal is no reference, not an error");
    assert_eq!(metrics::non_finite(&frame[0]), 0);
    assert_ne!(frame, before, "the fold resolved");
}

/// The issue's "exterior of the joint unchanged where β = 0.5 and no contact": on the convex
/// side of the bending capsule (rest `x > 0`, the bend turns toward -X) at `β ∈ [0.4, 0.6]`
/// both regions leave the surface alone, so the blend must too. Checked with the deformation
/// extent `φ̄` set to one capsule radius, as long as the extent floor `κ φ_I` stays below the
/// joint's diameter: without bulge (γ = 0) up to 80°, with the bulge (γ = 1) up to 60°; past
/// that the floor (or the bulge) reaches round the joint. With the default `φ̄` (1.5 × the
/// joint's size, five radii here) see [`exterior_with_the_default_extent`].
#[test]
fn exterior_of_the_joint_is_left_alone() {
    let fold = CapsuleFold::new();
    let exterior = fold.exterior_band();
    assert!(exterior.len() >= 8, "the capsule has an exterior band");
    for (gamma, last) in [(0.0, 16), (1.0, 12)] {
        let mut params = FoldParams {
            joint_extent: None,
            ..FoldParams::default()
        };
        params.deform.extent = 0.2;
        params.deform.gamma = gamma;
        let motion = fold.exterior_motion(&exterior, last, &params);
        for (f, moved) in &motion {
            assert!(
                *moved < 0.01,
                "gamma {gamma}, frame {f}: the exterior moved {moved:.4} h"
            );
        }
        let folds = motion.len();
        assert!(
            folds >= 3,
            "gamma {gamma}: the bend folds in {folds} frames"
        );
    }
}

/// `STEEPEST_BULGE`: a band too narrow for the volume the fold removes is refused, not filled
/// with a spike. With `φ̄` = 0.084 × the joint's size (a tenth of its shared region's box
/// diagonal, the former size: a second moment of the region is 1.19 of that diagonal on the
/// capsule) the capsule's bulge would have to rise 1.5 to 35 times higher than its band is
/// wide (frames 16 to 30, the blended bulge over each region's vertices; 1.3 to 9 measured by
/// each region's own bulge before 2026-12-05): each such fold is counted as unbalanced and leaves the input as it
/// was; with the default `φ̄` (1.5 × the joint's size) no fold is refused and the bulge stays
/// below a tenth of its band. Without the bulge guard: the guard scales the steepest bulge
/// back where it would enter the other side, and can bring such a fold under the limit
/// (frame 24).
#[test]
fn bulges_higher_than_their_band_are_refused() {
    use contact_skin::selfcontact::fold::{Unbalanced, STEEPEST_BULGE};
    let fold = CapsuleFold::new();
    let narrow = FoldParams {
        joint_extent: Some(0.084),
        bulge_guard: false,
        ..FoldParams::default()
    };
    let mut refused = 0;
    for f in [16, 20, 24, 28, 30] {
        let frame = fold.at(f, &narrow);
        let out = frame.out.expect("the bend folds");
        assert!(out.bulge_steepness > STEEPEST_BULGE, "frame {f}");
        assert_eq!(
            out.unbalanced,
            Some(Unbalanced::SteepBulge),
            "frame {f}: refused as too steep"
        );
        assert_eq!(out.positions, frame.input, "frame {f}: the input is kept");
        refused += 1;
        let frame = fold.at(f, &FoldParams::default());
        let out = frame.out.expect("the bend folds");
        assert!(
            out.unbalanced.is_none() && out.bulge_steepness < 0.1,
            "frame {f}"
        );
    }
    assert_eq!(refused, 5);
}

/// The safeguard angle of Sec. 4.4 (`FoldParams::safeguard_angle`) only takes vertices out of
/// the contact zones: the threshold `ε_c` does not depend on it, a smaller angle gives a subset
/// of the zone, and every zone vertex (and no other sample at or above `ε_c`) has both normals
/// within the angle of the mapping direction, except the crease vertices that the pass adds
/// to a zone by a test of their own (`zones_to_the_crease`, for any angle that leaves the
/// side a zone). Bending capsule with CoR input (whose squashed
/// inner elbow grazes the mapping direction), every frame with a fold; the angle must change
/// some zone between 80° and 60°, so the parameter reaches the pass.
#[test]
fn the_safeguard_angle_only_narrows_the_zones() {
    use contact_skin::contact::zones::safeguard_cos;
    let fold = CapsuleFold::skinned_with(Method::Cor);
    let angles = [90.0, 80.0, 70.0, 60.0];
    let (mut folds, mut narrowed) = (0, 0);
    for f in 0..31 {
        let runs: Vec<_> = angles
            .iter()
            .map(|&safeguard_angle| {
                let params = FoldParams {
                    safeguard_angle,
                    ..FoldParams::default()
                };
                fold.at(f, &params).out.map(|o| (o.contact, o.crease.on_w1))
            })
            .collect();
        let Some((widest, on_w1)) = &runs[0] else {
            assert!(
                runs.iter().all(Option::is_none),
                "frame {f}: detection is the same"
            );
            continue;
        };
        let crease: Vec<bool> = {
            let mut c = vec![false; on_w1.len()];
            for t in &fold.l.triangles[0] {
                if t.iter().any(|&v| on_w1[v as usize] != on_w1[t[0] as usize]) {
                    t.iter().for_each(|&v| c[v as usize] = true);
                }
            }
            c
        };
        folds += 1;
        for (run, &angle) in runs.iter().zip(&angles) {
            let (c, cut) = run.as_ref().expect("the same detection");
            assert_eq!(cut, on_w1, "frame {f}, {angle}°: the same crease cut");
            assert_eq!(c.threshold, widest.threshold, "frame {f}, {angle}°");
            let guard = safeguard_cos(angle);
            for (side, wide) in c.sides.iter().zip(&widest.sides) {
                for (v, (&inside, &on_crease)) in side.zone.inside.iter().zip(&crease).enumerate() {
                    let Some(s) = side.samples.get(v) else {
                        assert!(!inside, "frame {f}: a zone vertex is sampled");
                        continue;
                    };
                    // Sec. 4.4: min(-d̂ᵀn_i, d̂ᵀn''_i) with d̂ the ray's direction.
                    let d = side.direction;
                    let definition = s.own_normal.dot(&d).min(-s.mapping.target_normal.dot(&d));
                    assert!((s.safeguard - definition).abs() < 1e-12, "frame {f}, {v}");
                    let expected = s.depth >= c.threshold && definition >= guard;
                    if !on_crease {
                        assert_eq!(inside, expected, "frame {f}, {angle}°, {v}");
                    }
                    assert!(!inside || wide.zone.inside[v], "frame {f}: subset");
                }
            }
        }
        let zone_sizes = |k: usize| {
            let (c, _) = runs[k].as_ref().expect("fold");
            c.sides[0].zone.vertices.len() + c.sides[1].zone.vertices.len()
        };
        narrowed += (zone_sizes(3) < zone_sizes(1)) as usize;
    }
    assert!(folds >= 20, "the bend folds ({folds} frames)");
    assert!(narrowed > 0, "60° narrows some zone");
    println!("{folds} folds, {narrowed} zones narrowed by 60° against 80°");
}

/// The exterior band of [`exterior_of_the_joint_is_left_alone`] with the default extent `φ̄`
/// (the profile reaches round the joint) through the whole bend, 0 to 150°. Without bulge
/// (γ = 0) the profile's amplitude fades with `σ` there (`deform::region`'s
/// `fade_with_the_direction`): measured at most 0.056 h (frame 26), 0.25 h before the fade.
/// With the bulge (γ = 1) the exterior rises along its normals by up to 0.7 h at 150°: the
/// paper's own reading of Sec. 6 ("the final displacement direction will gently fall back to
/// the normal field ... consider the exterior of an elbow"), bounded here by the bulge's
/// share of the removed volume, not by "unchanged".
#[test]
fn exterior_with_the_default_extent() {
    let fold = CapsuleFold::new();
    let exterior = fold.exterior_band();
    for (gamma, bound) in [(0.0, 0.1), (1.0, 1.0)] {
        let mut params = FoldParams::default();
        params.deform.gamma = gamma;
        let motion = fold.exterior_motion(&exterior, 30, &params);
        let folds = motion.len();
        let worst = motion.iter().map(|m| m.1).fold(0.0, f64::max);
        println!("gamma {gamma}: the exterior moved {worst:.3} h at most over {folds} folds");
        assert!(
            folds >= 20,
            "gamma {gamma}: the bend folds in {folds} frames"
        );
        assert!(
            worst < bound,
            "gamma {gamma}: the exterior moved {worst:.3} h"
        );
    }
}

/// A joint scaled to 0: the bent capsule shrunk about a point by 1e-9, and collapsed to one
/// point, is not resolved (nothing to resolve at that size) and comes back as it went in; so
/// is it blown up by 1e11 (a broken animation's scale: `pass::STRETCHED`), where by 1e5 it
/// still folds.
#[test]
fn a_fold_scaled_out_of_measure_is_left_alone() {
    let l = load("bending_capsule", 31);
    let pass = self_pass(&l, &[]);
    let pose = l.rig.pose_at(Some(0), l.times[30]);
    let input = l.frame(30);
    let mut folded = input.clone();
    assert!(!pass
        .run(&l.rig, &pose, &mut folded)
        .expect("runs")
        .folds
        .is_empty());
    let centre = input[0][0];
    let scaled = |scale: f64| -> Vec<Vec<Point3<f64>>> {
        input
            .iter()
            .map(|b| b.iter().map(|p| centre + (p - centre) * scale).collect())
            .collect()
    };
    let mut large = scaled(1e5);
    let res = pass.run(&l.rig, &pose, &mut large).expect("runs");
    assert!(!res.folds.is_empty(), "scale 1e5");
    for scale in [1e-9, 0.0, 1e11] {
        let scaled = scaled(scale);
        let mut out = scaled.clone();
        let res = pass.run(&l.rig, &pose, &mut out).expect("runs");
        assert!(res.folds.is_empty(), "scale {scale}");
        assert_eq!(out, scaled);
    }
}

/// A body made double-sided by a second copy of each face (with the same winding, or
/// reversed, as exporters make a two-sided surface) folds exactly as the body: its welded
/// surface keeps one copy of each face, which moves the other's vertices too. Before, every
/// face lay on its copy (the capsule with its faces copied: 8 folds over 11 frames that
/// resolved nothing, 3.5 s instead of 0.5 s; with reversed copies no fold at all).
#[test]
fn a_double_sided_body_folds_as_the_body() {
    let l = load("bending_capsule", 31);
    let pass = self_pass(&l, &[]);
    for reversed in [false, true] {
        let d = double_sided("bending_capsule", 31, reversed);
        assert_eq!(
            d.rig.bodies[0].triangles.len(),
            2 * l.rig.bodies[0].triangles.len()
        );
        assert_eq!(d.pre.welded[0].report.duplicate_faces, l.triangles[0].len());
        let d_pass = self_pass(&d, &[]);
        let mut folds = 0;
        for f in (0..31).step_by(3) {
            let pose = l.rig.pose_at(Some(0), l.times[f]);
            let (mut out, mut d_out) = (l.frame(f), d.frame(f));
            assert_eq!(out, d_out, "frame {f}: the input");
            folds += pass.run(&l.rig, &pose, &mut out).expect("runs").folds.len();
            d_pass.run(&d.rig, &pose, &mut d_out).expect("runs");
            assert_eq!(out, d_out, "reversed {reversed}, frame {f}");
        }
        assert!(folds >= 5, "{folds} folds");
    }
}

/// `a` and `b` as one rig: `b`'s nodes, skins, bodies and first animation's channels after
/// `a`'s, every index shifted (the two skeletons are two roots; the bodies overlap in space,
/// which the self-contact pass, one body at a time, does not see).
fn merged_rig(a: &rig::Rig, b: &rig::Rig) -> rig::Rig {
    let (nodes, skins) = (a.nodes.len(), a.skins.len());
    let mut m = a.clone();
    m.nodes.extend(b.nodes.iter().cloned().map(|mut n| {
        n.parent = n.parent.map(|p| p + nodes);
        n.children.iter_mut().for_each(|c| *c += nodes);
        n
    }));
    m.node_order.extend(b.node_order.iter().map(|i| i + nodes));
    m.skins.extend(b.skins.iter().cloned().map(|mut s| {
        s.joints.iter_mut().for_each(|j| *j += nodes);
        s
    }));
    m.bodies.extend(b.bodies.iter().cloned().map(|mut body| {
        body.node += nodes;
        body.skin += skins;
        body
    }));
    m.extra_attributes
        .extend(b.extra_attributes.iter().cloned());
    let (ma, ba) = (&mut m.animations[0], &b.animations[0]);
    ma.channels.extend(ba.channels.iter().cloned().map(|mut c| {
        c.node += nodes;
        c
    }));
    ma.start = ma.start.min(ba.start);
    ma.end = ma.end.max(ba.end);
    m
}

/// Two bodies folding in one rig (the bending capsule and the finger, CoR input, where the
/// further sweeps act on both) give each body what it gets alone, positions and fold reports:
/// the sweeps, their further-sweep test and its stopping decision are per body, so a body's
/// result does not depend on what else the rig holds.
#[test]
fn bodies_fold_independently() {
    let frames = 31;
    let alone = [
        load_with("bending_capsule", frames, Method::Cor),
        load_with("finger", frames, Method::Cor),
    ];
    let merged = merged_rig(&alone[0].rig, &alone[1].rig);
    let pre = contact_skin::frames::Precomputed::new(&merged, Method::Cor);
    let rest = welded_positions(&merged, &pre, 0.0, None);
    let both = SelfContactPass::new(
        &merged,
        &pre.welded,
        &rest,
        &RegionOptions::default(),
        FoldParams::default(),
        &[],
    )
    .expect("merged pass precomputes");
    assert_eq!(both.pairs().len(), 4, "{:?}", both.pairs());
    let passes: Vec<SelfContactPass> = alone.iter().map(|l| self_pass(l, &[])).collect();
    let times = contact_skin::frames::sample_times(&merged, Some(0), Some(frames)).expect("times");
    let mut further = [0, 0];
    for (f, &t) in times.iter().enumerate() {
        let mut out = welded_positions(&merged, &pre, t, Some(0));
        let r = both
            .run(&merged, &merged.pose_at(Some(0), t), &mut out)
            .expect("merged pass runs");
        for (b, (l, pass)) in alone.iter().zip(&passes).enumerate() {
            let mut own = welded_positions(&l.rig, &l.pre, t, Some(0));
            let input = own.clone();
            let ro = pass
                .run(&l.rig, &l.rig.pose_at(Some(0), t), &mut own)
                .expect("pass runs");
            further[b] += usize::from(ro.sweeps > 2);
            // The same folds resolved, not only the same positions: no sweep repeated on a
            // body that another body's sweeps kept going.
            let reports = |o: &SelfPassOutput, body: usize| -> Vec<String> {
                o.folds
                    .iter()
                    .filter(|x| x.body == body)
                    .map(|x| x.name.clone())
                    .collect()
            };
            assert_eq!(reports(&r, b), reports(&ro, 0), "frame {f}, body {b}");
            assert!(
                r.sweeps >= ro.sweeps,
                "frame {f}: {} < {}",
                r.sweeps,
                ro.sweeps
            );
            if out[b] != own[0] {
                let moved = out[b].iter().zip(&own[0]).filter(|(p, q)| p != q).count();
                panic!(
                    "frame {f}, body {b}: {moved} vertices differ from the body alone \
                     ({} sweeps together, {} alone; input the same: {})",
                    r.sweeps,
                    ro.sweeps,
                    input[0] == welded_positions(&merged, &pre, t, Some(0))[b]
                );
            }
        }
    }
    println!(
        "frames with further sweeps alone: capsule {}, finger {}",
        further[0], further[1]
    );
    assert!(
        further.iter().all(|&n| n > 0),
        "both bodies need further sweeps somewhere: {further:?}"
    );
}

/// `σ` where the shared region has no face of its own (`PairRegions::shared_faces` may be
/// empty: `R` a ring of vertices between the two regions' faces): every vertex of `R` in a
/// contact zone takes its zone's sign, +1 in `C_1` and -1 in `C_2`, as on a shared region with
/// faces (until 2026-12-05 they kept 0 there, the normals' blend). Built from the capsule's
/// pair with its shared faces left out.
#[test]
fn sigma_takes_the_zones_signs_where_the_shared_region_has_no_face() {
    use contact_skin::selfcontact::fold::FoldPre;
    let fold = CapsuleFold::new();
    let mut r = fold.pre.regions.clone();
    r.shared_faces.clear();
    let rest = welded_positions(&fold.l.rig, &fold.l.pre, 0.0, None);
    let faceless = FoldPre::new(&rest[0], &fold.l.triangles[0], r).expect("fold");
    let mut zone_vertices = 0;
    for f in [20, 26, 30] {
        let frame = fold.at_with(&faceless, 1.0, f, &FoldParams::default());
        let Some(out) = frame.out else { continue };
        let r = &faceless.regions;
        for v in (0..r.w1.len()).filter(|&v| r.w1[v] && r.w2[v]) {
            let sign = match (
                out.contact.sides[0].zone.inside[v],
                out.contact.sides[1].zone.inside[v],
            ) {
                (true, _) => 1.0,
                (false, true) => -1.0,
                (false, false) => continue,
            };
            zone_vertices += 1;
            assert_eq!(out.sigma[v], sign, "frame {f}, vertex {v}");
        }
    }
    assert!(zone_vertices > 0, "no zone vertex in the shared region");
}

/// The points of `p` reflected through their centroid: the same surface for a centrally
/// symmetric one, its winding turned inward (a reflection reverses orientation in 3D), as a
/// joint scaled by -1 in an animation poses it.
fn reflected(p: &[Point3<f64>]) -> Vec<Point3<f64>> {
    let c = p.iter().fold(Vector3::zeros(), |s, q| s + q.coords) / p.len() as f64;
    p.iter().map(|q| Point3::from(2.0 * c - q.coords)).collect()
}

/// A pose that turns a closed body inside out leaves its folds as they are and reports the
/// body: the bending capsule at its deepest frame folds; reflected through its centroid (the
/// same surface, winding inward) its detection still finds the fold, which the pass no longer
/// resolves (it did, the wrong way, before 2026-12-05).
#[test]
fn a_body_turned_inside_out_is_left_as_it_came() {
    let l = load("bending_capsule", 31);
    let pass = self_pass(&l, &[]);
    let pose = l.rig.pose_at(Some(0), l.times[30]);
    let mut folded = l.frame(30);
    let out = pass.run(&l.rig, &pose, &mut folded).expect("runs");
    assert!(!out.folds.is_empty() && out.inside_out.is_empty());
    let inverted = vec![reflected(&l.frame(30)[0])];
    let mut positions = inverted.clone();
    let out = pass.run(&l.rig, &pose, &mut positions).expect("runs");
    assert_eq!(out.inside_out, vec![0]);
    assert!(out.folds.is_empty() && out.failed.is_empty());
    assert_eq!(positions, inverted, "as it came");
}

/// A strap layered across the capsule's joint, sunk into it at rest as a belt is modeled into
/// a waist ([`scenes::strapped`]; welded to the capsule where the tilt's axis meets it, so in
/// one piece with it: no separate piece to run without, unlike
/// `a_layer_sunk_across_a_joint_is_left_to_the_skinning`): the fold's two sides cross at rest.
/// `pose` leaves such a
/// fold as it comes in every frame (its overlap is the model's; resolving it in every frame
/// works against the model), unless the configuration enables it; the library resolves it by
/// default, as it does pairs of bodies crossing at rest. A rig whose sides do not cross at
/// rest is the same to the bit under either rule, and a pair disabled is left as it comes.
#[test]
fn a_fold_crossing_at_rest_is_left_out_unless_enabled() {
    let s = strapped("bending_capsule", 31, 0.25, 25.0);
    let pass = self_pass(&s, &[]);
    let crossing = pass.crossing_at_rest();
    let name = "capsule/lower-upper".to_string();
    assert_eq!(crossing.len(), 1, "{crossing:?}");
    assert_eq!((crossing[0].body, &crossing[0].name), (0, &name));
    assert!(crossing[0].face_pairs > 0 && crossing[0].failure.is_none());
    assert!(pass.left_out().is_empty(), "resolved by default");
    let left = self_pass(&s, &[]).with_rest_overlaps(RestOverlaps::LeftOut);
    let named = |p: &SelfContactPass| -> Vec<(usize, String, bool)> {
        (p.left_out().into_iter())
            .map(|f| (f.body, f.name, f.disabled))
            .collect()
    };
    assert_eq!(named(&left), vec![(0, name.clone(), false)]);
    assert_eq!(left.left_out()[0].at_rest.as_ref(), Some(crossing[0]));
    let enabled = (self_pass(&s, &[]).with_rest_overlaps(RestOverlaps::LeftOut))
        .with_pair_enabled(&[(name.clone(), true)])
        .expect("named");
    assert!(enabled.left_out().is_empty());
    let (mut moved_by_default, mut moved_enabled) = (0, 0);
    for f in [0, 10, 20, 30] {
        let pose = s.rig.pose_at(Some(0), s.times[f]);
        let input = s.frame(f);
        let run = |p: &SelfContactPass| {
            let mut out = input.clone();
            let report = p.run(&s.rig, &pose, &mut out).expect("runs");
            (out, report.folds.len())
        };
        let (out, folds) = run(&left);
        assert_eq!((&out, folds), (&input, 0), "frame {f}: left as it comes");
        moved_by_default += usize::from(run(&pass).0 != input);
        moved_enabled += usize::from(run(&enabled).0 != input);
    }
    println!("frames moved: by default {moved_by_default}, enabled {moved_enabled}");
    assert!(moved_by_default >= 3 && moved_enabled == moved_by_default);
    // The capsule without the strap: nothing crosses at rest, the rule changes nothing.
    let l = load("bending_capsule", 31);
    let (plain, ruled) = (
        self_pass(&l, &[]),
        self_pass(&l, &[]).with_rest_overlaps(RestOverlaps::LeftOut),
    );
    assert!(plain.crossing_at_rest().is_empty() && ruled.left_out().is_empty());
    let disabled = (self_pass(&l, &[]).with_pair_enabled(&[(name.clone(), false)])).expect("named");
    assert_eq!(named(&disabled), vec![(0, name, true)]);
    assert!(self_pass(&l, &[])
        .with_pair_enabled(&[("no/such-pair".into(), true)])
        .is_err());
    for f in [10, 20, 30] {
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let input = l.frame(f);
        let (mut a, mut b, mut c) = (input.clone(), input.clone(), input.clone());
        assert!(!plain
            .run(&l.rig, &pose, &mut a)
            .expect("runs")
            .folds
            .is_empty());
        ruled.run(&l.rig, &pose, &mut b).expect("runs");
        disabled.run(&l.rig, &pose, &mut c).expect("runs");
        assert_eq!(a, b, "frame {f}");
        assert_eq!(c, input, "frame {f}: disabled");
    }
}

/// A strap sunk across the capsule's joint (a separate piece of the same mesh, crossing it
/// at rest), and one inside it (a lining, not crossing it): the fold runs without either.
/// Checked against the capsule alone, an independent run: every frame's capsule vertices as
/// the plain capsule's output (its faces, regions and `β` are the same; only the volume solve
/// reads the strap, whose terms do not move), the strap's the skinning's, and no capsule
/// vertex left inside the capsule.
#[test]
fn a_layer_sunk_across_a_joint_is_left_to_the_skinning() {
    let l = load("bending_capsule", 31);
    for (degrees, scale) in [(25.0, 1.02), (0.0, 0.9)] {
        let s = strapped_scaled("bending_capsule", 31, 0.25, degrees, scale);
        println!("strap tilted by {degrees}°, scaled by {scale}:");
        a_layer_is_left_to_the_skinning(&s, &l);
    }
}

fn a_layer_is_left_to_the_skinning(s: &Loaded, l: &Loaded) {
    let name = "capsule/lower-upper".to_string();
    let capsule_vertices = l.pre.welded[0].vertex_count();
    let capsule_faces = l.triangles[0].len();
    let strap_faces = s.triangles[0].len() - capsule_faces;
    for rule in [RestOverlaps::Resolved, RestOverlaps::LeftOut] {
        let pass = self_pass(s, &[]).with_rest_overlaps(rule);
        assert!(pass.crossing_at_rest().is_empty() && pass.left_out().is_empty());
        let layers = pass.layers();
        assert_eq!(layers.len(), 1, "{layers:?}");
        assert_eq!((layers[0].body, &layers[0].name), (0, &name));
        assert_eq!(layers[0].layers.len(), 1);
        let layer = &layers[0].layers[0];
        assert_eq!(layer.faces, strap_faces);
        assert_eq!(layer.first_vertex as usize, capsule_vertices);
    }
    assert!(self_pass(l, &[]).layers().is_empty());
    let (folded, worst, inside) = against_the_capsule_alone(s, l, 3);
    println!("frames with a fold {folded}, largest gap to the plain capsule {worst:.2e} h, penetrating {inside}");
    assert!(folded >= 5 && worst < 1e-9 && inside == 0);
}

/// The capsule `s` with extra pieces of mesh (its first vertices the capsule's), run every
/// `step` frames beside the capsule alone `l`: frames with a fold (asserted in both the
/// same), the largest gap of its capsule vertices to the capsule's own output (in `h`), the
/// most penetrating capsule vertices in a frame; the pieces asserted as skinned.
fn against_the_capsule_alone(s: &Loaded, l: &Loaded, step: usize) -> (usize, f64, usize) {
    let capsule_vertices = l.pre.welded[0].vertex_count();
    let (pass, plain_pass) = (self_pass(s, &[]), self_pass(l, &[]));
    let (mut worst, mut folded, mut inside) = (0.0_f64, 0, 0);
    for f in (0..s.times.len()).step_by(step) {
        let pose = s.rig.pose_at(Some(0), s.times[f]);
        let input = s.frame(f);
        let mut out = input.clone();
        let report = pass.run(&s.rig, &pose, &mut out).expect("runs");
        let mut plain = l.frame(f);
        let plain_report = plain_pass.run(&l.rig, &pose, &mut plain).expect("runs");
        assert_eq!(report.folds.len(), plain_report.folds.len(), "frame {f}");
        folded += usize::from(!report.folds.is_empty());
        assert_eq!(
            &out[0][capsule_vertices..],
            &input[0][capsule_vertices..],
            "frame {f}"
        );
        for (a, b) in out[0][..capsule_vertices].iter().zip(&plain[0]) {
            worst = worst.max((a - b).norm() / l.h_rest);
        }
        let p = penetration(l, 0, &out[0][..capsule_vertices]);
        inside = inside.max(p.vertices);
    }
    (folded, worst, inside)
}

/// Many tiny separate pieces inside the bending capsule, a third of them wholly in its joint's
/// shared region: their vertices reach no border of it, so no partition of unity covers them,
/// and the pair's derivation used to fail ("vertices of the shared region reach no Dirichlet
/// border": the pair skipped, no fold at all). Those parts now leave both regions, the others
/// leave the fold as pieces inside a larger one; every frame's capsule vertices come out as
/// the capsule's own output (an independent run), the pieces as skinned.
#[test]
fn pieces_inside_a_joint_follow_the_skinning() {
    let s = with_pieces_inside("bending_capsule", 31, 300);
    let l = load("bending_capsule", 31);
    let pass = self_pass(&s, &[]);
    assert!(pass.skipped().is_empty(), "{:?}", pass.skipped());
    assert_eq!(pass.pairs().len(), 1);
    let (derived, _) = contact_skin::selfcontact::derive_pairs_reporting(
        &s.rig,
        &s.pre.welded,
        &RegionOptions::default(),
    )
    .expect("derives");
    assert!(
        derived[0].reason.contains("left to the skinning"),
        "{}",
        derived[0].reason
    );
    let layers = pass.layers();
    assert_eq!(layers.len(), 1);
    let (folded, worst, inside) = against_the_capsule_alone(&s, &l, 5);
    println!(
        "pieces left out of the fold: {}; frames with a fold {folded}; largest gap to the plain capsule {worst:.2e} h, penetrating {inside}",
        layers[0].layers.len()
    );
    assert!(folded >= 4 && worst < 1e-9 && inside == 0);
}
