//! Self-contact on the real characters of `../shared/gltf-samples/` (read from there, never
//! copied): which animations fold a joint into contact, and what the pass does to them.

#[path = "common/glb.rs"]
mod glb;
#[path = "common/rng.rs"]
mod rng;
#[path = "common/scenes.rs"]
mod scenes;

use contact_skin::frames::{self, Precomputed};
use contact_skin::mesh::operators::{mean_edge_length, vertex_normals, NormalWeighting};
use contact_skin::pass::RestOverlaps;
use contact_skin::report::metrics;
use contact_skin::rig;
use contact_skin::selfcontact::fold::FoldParams;
use contact_skin::selfcontact::pass::{SelfContactPass, SelfPassOutput};
use contact_skin::selfcontact::{
    derive_pairs_reporting, separated_from_skeleton, separated_regions, BoneAxes, PairRegions,
    RegionOptions,
};
use contact_skin::skinning::Method;
use nalgebra::{Point3, Vector3};
use scenes::Posed;
use std::path::Path;

/// The sample `rel` of `../shared/gltf-samples/`, or `None` (said on stdout: the test skips it).
fn sample(rel: &str) -> Option<std::path::PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/gltf-samples")
        .join(rel);
    if !p.exists() {
        println!("{rel}: not found, skipped");
    }
    p.exists().then_some(p)
}

/// What the pass did to a character over 21 frames of one of its animations.
struct Summary {
    pairs: usize,
    frames: usize,
    folded: usize,
    /// Penetrating vertices summed over the frames with a fold: input, output.
    before: usize,
    after: usize,
    /// Largest residual depth in any frame with a fold, in rest edge lengths.
    deepest: f64,
    turned: metrics::TurnedFaces,
    /// Worst relative volume error.
    volume: f64,
    unbalanced: usize,
    /// Largest displacement by the pass in any frame, in rest edge lengths.
    largest: f64,
}

/// A character loaded for a skinning method, its welded rest positions and its self-contact
/// pass.
struct Prepared {
    rig: rig::Rig,
    pre: Precomputed,
    rest: Vec<Vec<nalgebra::Point3<f64>>>,
    pass: SelfContactPass,
}

/// One posed frame through the pass: the skinned frame, its welded input, the pass's output.
struct Passed {
    frame: frames::Frame,
    input: Vec<Vec<nalgebra::Point3<f64>>>,
    out: Vec<Vec<nalgebra::Point3<f64>>>,
    report: SelfPassOutput,
}

impl Prepared {
    /// Frame `k` of `anim`, at time `t`, through the self-contact pass.
    fn pass_frame(&self, anim: Option<usize>, k: usize, t: f64) -> Passed {
        let frame = frames::evaluate(&self.rig, &self.pre, anim, k, t);
        let input = frame.welded(&self.pre);
        let normals = frame.welded_normals(&self.pre);
        let mut out = input.clone();
        let pose = self.rig.pose_at(anim, t);
        let report = self
            .pass
            .run_with_normals(&self.rig, &pose, &mut out, &normals)
            .expect("self-contact runs");
        Passed {
            frame,
            input,
            out,
            report,
        }
    }
}

fn prepare(path: &Path, params: FoldParams) -> Prepared {
    prepare_with(path, params, Method::Lbs)
}

/// [`prepare`] with `method`'s skinning as the pass's input.
fn prepare_with(path: &Path, params: FoldParams, method: Method) -> Prepared {
    prepare_rig(rig::load(path).expect("sample loads"), params, method)
}

/// [`prepare_with`] on a rig already loaded.
fn prepare_rig(rig: rig::Rig, params: FoldParams, method: Method) -> Prepared {
    let pre = Precomputed::new(&rig, method);
    let rest = scenes::welded_positions(&rig, &pre, 0.0, None);
    let pass = SelfContactPass::new(
        &rig,
        &pre.welded,
        &rest,
        &RegionOptions::default(),
        params,
        &[],
    )
    .expect("pairs derive");
    Prepared {
        rig,
        pre,
        rest,
        pass,
    }
}

/// Runs the self-contact pass with `params` on the character `rel` at `path` (LBS input).
fn run_sample(rel: &str, path: &Path, params: FoldParams) -> Summary {
    run_prepared(rel, prepare(path, params))
}

/// [`run_sample`] with the pass already prepared.
fn run_prepared(rel: &str, prepared: Prepared) -> Summary {
    run_animation(rel, prepared, None)
}

/// [`run_prepared`] on the animation named `name` (the first one for `None`).
fn run_animation(rel: &str, prepared: Prepared, name: Option<&str>) -> Summary {
    let Prepared {
        rig,
        pre,
        rest,
        pass,
        ..
    } = &prepared;
    let anim = match name {
        Some(name) => Some(
            rig.animations
                .iter()
                .position(|a| a.name.as_deref() == Some(name))
                .expect("the animation"),
        ),
        None => (!rig.animations.is_empty()).then_some(0),
    };
    let times = frames::sample_times(rig, anim, Some(21)).expect("frames");
    let mut sum = Summary {
        pairs: pass.pairs().len(),
        frames: times.len(),
        folded: 0,
        before: 0,
        after: 0,
        deepest: 0.0,
        turned: metrics::TurnedFaces::default(),
        volume: 0.0,
        unbalanced: 0,
        largest: 0.0,
    };
    for (k, &t) in times.iter().enumerate() {
        let Passed {
            frame,
            input,
            out,
            report: res,
        } = prepared.pass_frame(anim, k, t);
        let skinned = frame.welded_normals(&prepared.pre);
        sum.folded += usize::from(!res.folds.is_empty());
        sum.unbalanced += res.unbalanced.total();
        for (b, w) in pre.welded.iter().enumerate() {
            assert_eq!(metrics::non_finite(&out[b]), 0, "{rel}: NaN");
            if !res.folds.iter().any(|f| f.body == b) {
                continue;
            }
            let h = mean_edge_length(&rest[b], &w.triangles);
            let pen = |p: &[nalgebra::Point3<f64>]| {
                let n = vertex_normals(p, &w.triangles, NormalWeighting::Area);
                metrics::residual_penetration(p, &w.triangles, &n, h)
            };
            let moved = input[b]
                .iter()
                .zip(&out[b])
                .map(|(p, q)| (p - q).norm() / h)
                .fold(0.0, f64::max);
            sum.largest = sum.largest.max(moved);
            let after = pen(&out[b]);
            sum.before += pen(&input[b]).vertices;
            sum.after += after.vertices;
            sum.deepest = sum.deepest.max(after.max_depth / h);
            sum.turned += metrics::turned_faces(&w.triangles, &input[b], &out[b], &skinned[b], h);
            let v0 = contact_skin::mesh::signed_volume(&input[b], &w.triangles);
            let v1 = contact_skin::mesh::signed_volume(&out[b], &w.triangles);
            sum.volume = sum.volume.max(metrics::volume_error(v0, v1));
        }
    }
    let t = &sum.turned;
    println!(
        "{rel}: pairs {}, frames with a fold {}/{}, penetrating vertices (summed over those frames) {} -> {} (deepest left {:.2} h), faces turned (summed): input against skinning {}, output against input {}, against skinning {}, against both {} ({} buried), worst volume error {:.1e}, folds left unbalanced {}, largest displacement {:.1} h",
        sum.pairs,
        sum.folded,
        sum.frames,
        sum.before,
        sum.after,
        sum.deepest,
        t.input_against_skinning,
        t.against_input,
        t.against_skinning,
        t.turned,
        t.buried,
        sum.volume,
        sum.unbalanced,
        sum.largest,
    );
    sum
}

/// The skinned characters of `../shared/gltf-samples/`.
const CHARACTERS: [&str; 7] = [
    "CesiumMan/CesiumMan.glb",
    "Fox/Fox.glb",
    "QuaterniusRobot/robot.glb",
    "WebXRGenericHand/left.glb",
    "RiggedFigure/RiggedFigure.glb",
    "RiggedSimple/RiggedSimple.glb",
    "SimpleSkin/SimpleSkin.gltf",
];

#[test]
fn real_characters_never_get_worse() {
    for rel in CHARACTERS {
        let Some(path) = sample(rel) else {
            continue;
        };
        let s = run_sample(rel, &path, FoldParams::default());
        // The turn guard: CesiumMan's 21 frames turned 225 faces over (37 buried) without it,
        // 2 with it until 2026-12-03 (the guard checked only the working regions' faces, while
        // the bulge moves the vertices of their border too), none since it checks every face
        // with a corner in them (and against the skinning's own normals, as here).
        assert_not_worse(rel, &s, 0);
    }
}

/// What every sample's run must show: no more penetrating vertices than the input, the
/// volume kept, what is left shallow (CesiumMan's LBS residual is at most 0.67 h deep,
/// measured; the skinned input up to 1.04 h by the same measure; samples without a fold hold
/// it trivially), at most `turned_at_most` faces turned against both the input and the
/// skinning, and no spike (measured 4.0 edge lengths at most on CesiumMan with LBS; 5.3
/// without the turn guard). `rel` names the run in the messages.
fn assert_not_worse(rel: &str, s: &Summary, turned_at_most: usize) {
    assert!(
        s.after <= s.before,
        "{rel}: self-contact made penetration worse ({} -> {})",
        s.before,
        s.after
    );
    assert!(s.volume < 1e-4, "{rel}: volume error {:.1e}", s.volume);
    assert!(
        s.deepest < 1.0,
        "{rel}: a vertex left {:.2} h deep",
        s.deepest
    );
    assert!(
        s.turned.turned <= turned_at_most,
        "{rel}: {} faces turned over",
        s.turned.turned
    );
    assert!(
        s.largest < 8.0,
        "{rel}: the pass moved a vertex by {:.1} edge lengths",
        s.largest
    );
}

/// The same with DQS and CoR input (the "with LBS, DQS or CoR skinning as input"):
/// never more penetrating vertices than the input, the volume kept, no NaN (checked in
/// [`run_animation`]), what is left shallow, no spike; on the first animation of every sample
/// and on Fox's `Run`, whose first animation does not fold. Measured (2026-12-04): CesiumMan
/// DQS 335 -> 23 penetrating vertices (0.34 h deep at most), CoR 376 -> 25 (0.42 h), summed
/// over the frames with a fold; Fox's run DQS 73 -> 19 (8 of 21 frames fold, 0.22 h), CoR
/// 79 -> 21 (9 frames, 0.29 h); volume errors below 1e-14, largest displacement 3.9 and 3.6 h
/// on CesiumMan, faces turned against both the input and the skinning 0, and 1 on CesiumMan
/// with CoR (not traced).
#[test]
fn real_characters_with_dqs_and_cor_input_never_get_worse() {
    let runs = CHARACTERS
        .iter()
        .map(|&rel| (rel, None))
        .chain([("Fox/Fox.glb", Some("Run"))]);
    for method in [Method::Dqs, Method::Cor] {
        for (rel, animation) in runs.clone() {
            let Some(path) = sample(rel) else {
                continue;
            };
            let prepared = prepare_with(&path, FoldParams::default(), method);
            let s = run_animation(rel, prepared, animation);
            assert_not_worse(&format!("{rel} ({method:?})"), &s, 1);
        }
    }
}

/// The sample at `path` loaded for LBS and its joint pairs with the default options, with
/// the reasons of those skipped.
fn derived_pairs(path: &Path) -> (rig::Rig, Precomputed, Vec<PairRegions>, Vec<String>) {
    let rig = rig::load(path).expect("sample loads");
    let pre = Precomputed::new(&rig, Method::Lbs);
    let (pairs, skipped) =
        derive_pairs_reporting(&rig, &pre.welded, &RegionOptions::default()).expect("pairs");
    (rig, pre, pairs, skipped)
}

/// The skeleton's direction keeps a rest fold's sense past a full fold only for a leaf joint,
/// whose "bone" is the direction of its vertices (`contact_skin::selfcontact::RestFold`; the
/// mouth's lower lip, tested in `tests/selfcontact.rs`): an articulation that opens the other
/// way folds the other way. Fox's hip-to-leg pairs are folded 132° at rest (the angle here from
/// the joints' rest positions) and get none; no sample has a leaf pair folded past 90° at rest.
#[test]
fn only_leaf_joints_keep_a_rest_fold() {
    let mut folded_articulations = 0;
    for rel in CHARACTERS {
        let Some(path) = sample(rel) else {
            continue;
        };
        let (rig, pre, pairs, _) = derived_pairs(&path);
        let rest = rig.pose_at(None, 0.0);
        let at = |n: usize| rest.world[n].transform_point(&Point3::origin());
        for p in &pairs {
            let axes = BoneAxes::new(&rig, &pre.welded[p.pair.body], p);
            let name = &p.pair.name;
            match p.pair.bone_end {
                Some(end) => {
                    assert_eq!(axes.rest_fold, None, "{rel} {name}: an articulation");
                    let joint = at(p.pair.child_joint);
                    let u1 = (at(p.pair.parent_joint) - joint).normalize();
                    let u2 = (at(end) - joint).normalize();
                    // Folded past 90°: the bones within 90° of each other.
                    folded_articulations += usize::from(u1.dot(&u2) > 0.0);
                }
                None => assert_eq!(axes.rest_fold, None, "{rel} {name}: folded at rest"),
            }
        }
    }
    if sample("Fox/Fox.glb").is_some() {
        assert!(
            folded_articulations >= 2,
            "Fox's hips: {folded_articulations}"
        );
    }
}

/// CesiumMan's hands (node14-node15, node17-node18) are short end segments of a coarse mesh:
/// their regions grown by the default 2 rings leave nothing of the hand outside the shared
/// region, and they used to be skipped. They are derived with fewer rings now, with a valid
/// partition of unity (1 on `W1 \ R`, 0 on `W2 \ R`, both not empty, in `[0, 1]`), and no pair
/// of the character is skipped. Measured: both with 1 ring; Fox gains 3 pairs that way (tail
/// tip, both ankles), the Quaternius robot 14, RiggedFigure 5; none of them folds into
/// contact in the samples' animations.
#[test]
fn cesium_man_hands_are_derived_with_fewer_rings() {
    let rel = "CesiumMan/CesiumMan.glb";
    let Some(path) = sample(rel) else {
        return;
    };
    let (_, _, pairs, skipped) = derived_pairs(&path);
    assert!(skipped.is_empty(), "{skipped:?}");
    for hand in ["Cesium_Man/node14-node15", "Cesium_Man/node17-node18"] {
        let p = pairs
            .iter()
            .find(|p| p.pair.name == hand)
            .unwrap_or_else(|| panic!("{hand} derived"));
        println!("{}", p.reason);
        assert!(p.grow_rings < RegionOptions::default().grow_rings, "{hand}");
        let only = |a: &[bool], b: &[bool]| (0..a.len()).filter(|&v| a[v] && !b[v]).count();
        assert!(only(&p.w1, &p.w2) > 0 && only(&p.w2, &p.w1) > 0, "{hand}");
        for (v, &b) in p.beta.iter().enumerate() {
            assert!((0.0..=1.0).contains(&b), "{hand}: beta {b}");
            match (p.w1[v], p.w2[v]) {
                (true, false) => assert_eq!(b, 1.0),
                (false, true) => assert_eq!(b, 0.0),
                _ => {}
            }
        }
    }
}

/// The Quaternius robot's left middle finger is modeled as rigid pieces that interpenetrate at
/// the joint with zero depth: its faces intersect in every frame, but neither side has a
/// contact zone. Such a fold is not one: it is not reported and leaves the frame as it is, to
/// the bit (it was reported in every frame, cost 0.6 ms per frame and moved vertices by
/// round-off).
#[test]
fn intersections_without_a_contact_zone_are_not_folds() {
    let rel = "QuaterniusRobot/robot.glb";
    let Some(path) = sample(rel) else {
        return;
    };
    let prepared = prepare(&path, FoldParams::default());
    let pass = &prepared.pass;
    assert!(
        pass.pairs()
            .iter()
            .any(|(_, n)| n == "Hand.L/Middle1.L-Middle2.L"),
        "{:?}",
        pass.pairs()
    );
    let times = frames::sample_times(&prepared.rig, Some(0), Some(21)).expect("frames");
    for (k, &t) in times.iter().enumerate() {
        let p = prepared.pass_frame(Some(0), k, t);
        assert!(
            p.report.folds.is_empty(),
            "frame {k}: {:?}",
            p.report.folds.iter().map(|f| &f.name).collect::<Vec<_>>()
        );
        assert_eq!(p.out, p.input, "frame {k}");
    }
}

/// CesiumMan's walk over 61 frames, second-difference ratio against the skinned input: 7.05
/// measured (frame 17, vertex 1795), above the bound of 3, which is open. While the
/// joints' sizes were box diagonals the worst pop was at the hips (7.31, frame 15, vertex
/// 1312): the hips-spine fold starts with a one-vertex zone whose ray leaves at 79° to its
/// normal, just inside the paper's 80° safeguard, and lands 4.5 h away, so the zone's birth
/// moves it and its neighbours by 2-4 h at once. The pop's size follows the joints' extent,
/// not monotonically (with the regions' diameters as sizes: 6.88, 7.83, 7.95 and 7.35 at 2.0,
/// 2.2, 2.3 and 2.5 of them). This guards against it getting worse. (At 21 frames the input's
/// own second differences are as large, and the ratio reads 1.2.)
#[test]
fn cesium_man_walk_pops_no_more_than_measured() {
    let rel = "CesiumMan/CesiumMan.glb";
    let Some(path) = sample(rel) else {
        return;
    };
    let prepared = prepare(&path, FoldParams::default());
    let times = frames::sample_times(&prepared.rig, Some(0), Some(61)).expect("frames");
    let (mut ins, mut outs) = (Vec::new(), Vec::new());
    for (k, &t) in times.iter().enumerate() {
        let p = prepared.pass_frame(Some(0), k, t);
        ins.push(p.input.concat());
        outs.push(p.out.concat());
    }
    let sd = metrics::second_difference_ratio(&outs, &ins);
    println!(
        "{rel}: second-difference ratio {:.2} (frame {:?}, vertex {:?})",
        sd.ratio, sd.frame, sd.vertex
    );
    assert!(sd.ratio < 8.0, "ratio {:.2}", sd.ratio);
}

/// CesiumMan with the object pass's extent floor (`κ = 3`), which spreads a fold whose
/// intersection runs along the body over a large extent: before the amplitude faded across the
/// crease, frame 5 got bulges of 14 to 42 edge lengths from zones of a few vertices on their
/// regions' borders, which `STEEPEST_BULGE` refused (2 folds; the rule is now exercised by
/// `bulges_higher_than_their_band_are_refused` in `tests/selfcontact.rs`). Measured now: no
/// fold refused, 10.5 edge lengths at most (9.8 without the turn guard), volume exact.
#[test]
fn cesium_man_with_the_object_pass_extent_floor_stays_bounded() {
    let rel = "CesiumMan/CesiumMan.glb";
    let Some(path) = sample(rel) else {
        return;
    };
    let mut params = FoldParams::default();
    params.deform.intersection_extent_factor = 3.0;
    let s = run_sample(rel, &path, params);
    assert!(s.after <= s.before, "{} -> {}", s.before, s.after);
    assert!(
        s.largest < 12.0,
        "the pass moved a vertex by {:.1} edge lengths",
        s.largest
    );
    assert!(s.volume < 1e-4, "volume error {:.1e}", s.volume);
}

/// CesiumMan's residual is mostly the shoulders' bulge: the two shoulder folds (`node12` to
/// each upper arm) pushed against the torso's side give back the lost volume round the
/// armpit, and part of the upper arm swells into the lower torso, which no joint pair covers.
/// With `γ = 0` for those two pairs only (`[[self_contact.pair]] gamma = 0`), 58 -> 18
/// penetrating vertices over the 21 frames (measured; `γ = 0.5`: 31, `0.25`: 23; for
/// `node12-node13` alone 25, `node12-node16` alone 53), the body losing up to 4.9 % of its
/// volume instead of none. Since 2026-12-03 (the crease cut's seam vertices in the mapping
/// regions, the turn guard on every face with a corner in the working regions) 33 -> 17; since
/// the twenty-fourth session's further sweeps (no stop when a sweep leaves as many, up to 6)
/// 29 -> 18: the further sweeps now resolve part of what the bulge pushed in, so less is left
/// to take away. Asserted: at most 0.7 of it is left (0.6 until then; round-off at the pass's
/// ties moves these counts by a few). All without the bulge guard, which keeps
/// the bulge out of the other side with the volume kept
/// ([`the_bulge_guard_cuts_cesium_mans_residual_with_the_volume_kept`]).
#[test]
fn cesium_man_shoulders_without_bulge_leave_two_thirds_at_most() {
    let rel = "CesiumMan/CesiumMan.glb";
    let Some(path) = sample(rel) else {
        return;
    };
    let free = FoldParams {
        bulge_guard: false,
        ..FoldParams::default()
    };
    let default = run_sample(rel, &path, free);
    let mut prepared = prepare(&path, free);
    let mut flat = free;
    flat.deform.gamma = 0.0;
    let shoulders: Vec<(String, FoldParams)> =
        ["Cesium_Man/node12-node13", "Cesium_Man/node12-node16"]
            .iter()
            .map(|n| (n.to_string(), flat))
            .collect();
    prepared.pass = prepared
        .pass
        .with_pair_params(&shoulders)
        .expect("the shoulders are derived pairs");
    let s = run_prepared(rel, prepared);
    assert!(
        10 * s.after <= 7 * default.after,
        "shoulders without bulge: {} penetrating, with: {}",
        s.after,
        default.after
    );
    assert!(
        s.volume > 1e-3,
        "the shoulders' lost volume: {:.1e}",
        s.volume
    );
    assert!(default.volume < 1e-4, "{:.1e}", default.volume);
}

/// Separated regions on a real skin (`[[self_contact.separated]]`): CesiumMan's forearms and
/// hands (`node17`+`node18`, `node14`+`node15`, nodes without names) against its hips
/// (`node2`), the contact of frame 6 of its walk that the hips-spine pair holds with its
/// joint's direction. Measured (`pose --metrics`, 21 frames): 19 -> 17 penetrating vertices,
/// the deepest 0.46 -> 0.13 h, frame 5 2 -> 4 (the hips-spine fold moves two hips vertices
/// 2.5 h down, and the pair the hand onto them). Asserted: no more left than without the pair,
/// a shallower deepest, the volume kept, no face turned.
#[test]
fn cesium_man_hands_against_the_hips_as_separated_regions() {
    let rel = "CesiumMan/CesiumMan.glb";
    let Some(path) = sample(rel) else {
        return;
    };
    let without = run_sample(rel, &path, FoldParams::default());
    let prepared = prepare(&path, FoldParams::default());
    let options = RegionOptions::default();
    let mut separated = Vec::new();
    for hand in [["node17", "node18"], ["node14", "node15"]] {
        let sides: [&[&str]; 2] = [&hand, &["node2"]];
        separated.extend(
            separated_regions(&prepared.rig, &prepared.pre.welded, sides, &options)
                .expect("the hands and the hips share no vertex"),
        );
    }
    let with = run_prepared(rel, with_separated(prepared, separated));
    assert!(
        with.after <= without.after,
        "{} -> {}",
        without.after,
        with.after
    );
    assert!(
        with.deepest < without.deepest,
        "{:.2} h -> {:.2} h",
        without.deepest,
        with.deepest
    );
    assert!(with.volume < 1e-4, "{:.1e}", with.volume);
    assert_eq!(with.turned.turned, 0, "{:?}", with.turned);
}

/// `prepared` with its pass rebuilt to also hold the `separated` regions.
fn with_separated(mut prepared: Prepared, separated: Vec<PairRegions>) -> Prepared {
    prepared.pass = SelfContactPass::with_separated(
        &prepared.rig,
        &prepared.pre.welded,
        &prepared.rest,
        &RegionOptions::default(),
        FoldParams::default(),
        &[],
        separated,
    )
    .expect("pairs derive");
    prepared
}

/// `prepared` with its pass rebuilt to also hold the separated regions of its skeleton
/// ([`separated_from_skeleton`], on by default in a configuration).
fn with_skeleton_pairs(prepared: Prepared) -> Prepared {
    let separated = separated_from_skeleton(
        &prepared.rig,
        &prepared.pre.welded,
        &RegionOptions::default(),
    )
    .expect("separated regions derive");
    with_separated(prepared, separated)
}

/// CesiumMan's triangle list read as a strip (`mode = 5`, one edit of the file's JSON; the
/// fuzzing of 2026-12-05): a broken mesh on which some folds' heat or stiffness matrix is not
/// positive definite and others entangled (more candidate face pairs than
/// `bvh::PAIRS_PER_FACE` allows). Those folds fail and are left as they were, reported with
/// their error, while the pass resolves the others (a fold may fail in one sweep and resolve
/// in the next, once the others moved its vertices); until 2026-12-05 the first failure
/// stopped the run.
#[test]
fn a_failing_fold_is_left_as_skinned_and_the_others_resolve() {
    let Some((_, prepared)) = cesium_man_read_as_a_strip() else {
        return;
    };
    let p = prepared.pass_frame(Some(0), 0, 0.0);
    let failed = &p.report.failed;
    assert!(!failed.is_empty(), "the strip's folds fail");
    assert!(!p.report.folds.is_empty(), "the others resolve");
    let pairs = prepared.pass.pairs();
    for f in failed {
        let known = ["factorization", "entangled"];
        assert!(known.iter().any(|k| f.error.contains(k)), "{f:?}");
        assert!(pairs.iter().any(|(_, name)| *name == f.name), "{f:?}");
    }
    let finite =
        |x: &[Vec<Point3<f64>>]| x.iter().flatten().all(|q| q.iter().all(|c| c.is_finite()));
    assert!(finite(&p.out));
}

/// The same strip-read CesiumMan under `pose`'s rule for folds whose sides cross at rest
/// (`RestOverlaps::LeftOut`): every fold crosses there, each is left as it comes in every
/// frame, and the frames run without a failed fold: the output is the input. Read as a fan,
/// its folds' detection fails at rest (entangled): those are left out too, with the reason. Before
/// (measured 2026-12-05, `pose --self-contact`, 2 frames): 184 folds failed and the others
/// "resolved" the broken mesh, 13.6 s per frame; now 0.16 ms per frame.
#[test]
fn folds_crossing_at_rest_are_left_out_of_a_broken_mesh() {
    let Some((path, mut prepared)) = cesium_man_read_as_a_strip() else {
        return;
    };
    let crossing: Vec<String> = (prepared.pass.crossing_at_rest().iter())
        .map(|c| c.name.clone())
        .collect();
    let pairs: Vec<String> = prepared.pass.pairs().into_iter().map(|(_, n)| n).collect();
    assert_eq!(crossing, pairs, "every fold of the strip crosses at rest");
    prepared.pass = prepared.pass.with_rest_overlaps(RestOverlaps::LeftOut);
    assert_eq!(prepared.pass.left_out().len(), pairs.len());
    let p = prepared.pass_frame(Some(0), 0, 0.0);
    assert!(p.report.failed.is_empty() && p.report.folds.is_empty());
    assert_eq!(p.out, p.input);
    // Read as a fan: the detection of the folds found fails at rest (entangled), and each
    // such fold is left out with its reason.
    let bytes = std::fs::read(&path).expect("sample reads");
    let rig = rig::load_from_bytes(&path, &with_first_primitive_mode(&bytes, 6)).expect("loads");
    let fan = prepare_rig(rig, FoldParams::default(), Method::Lbs);
    let failing: Vec<_> = (fan.pass.crossing_at_rest().into_iter())
        .filter(|c| c.crossing_face_pairs().is_none())
        .cloned()
        .collect();
    assert!(!failing.is_empty());
    for c in &failing {
        assert!(
            c.failure
                .as_deref()
                .is_some_and(|e| e.contains("entangled")),
            "{c:?}"
        );
    }
    let fan_pass = fan.pass.with_rest_overlaps(RestOverlaps::LeftOut);
    let left_out = fan_pass.left_out();
    assert!((failing.iter()).all(|c| left_out.iter().any(|f| f.name == c.name)));
    // The sample itself: no fold crosses at rest.
    let clean = with_skeleton_pairs(prepare(&path, FoldParams::default()));
    assert!(clean.pass.crossing_at_rest().is_empty());
}

/// CesiumMan's path and its copy with the triangle list read as a strip, prepared with the
/// skeleton's pairs (LBS); `None` without the sample.
fn cesium_man_read_as_a_strip() -> Option<(std::path::PathBuf, Prepared)> {
    let path = sample("CesiumMan/CesiumMan.glb")?;
    let bytes = std::fs::read(&path).expect("sample reads");
    let rig = rig::load_from_bytes(&path, &with_first_primitive_mode(&bytes, 5)).expect("loads");
    let prepared = with_skeleton_pairs(prepare_rig(rig, FoldParams::default(), Method::Lbs));
    Some((path, prepared))
}

/// A GLB with its first mesh's first primitive given `mode` (its JSON chunk rewritten).
fn with_first_primitive_mode(glb: &[u8], mode: u32) -> Vec<u8> {
    glb::with_json(glb, |json| {
        json["meshes"][0]["primitives"][0]["mode"] = mode.into()
    })
}

/// The separated regions of the skeleton (sibling subtrees, each joint against its
/// grandchildren's) on the walking and running characters, 21 frames, LBS. The summaries count
/// only the frames where some fold ran, and the new pairs fold in more frames, so the two runs
/// are compared by the vertices they resolve (input minus output, summed): over all frames the
/// output's count is the input's minus that. Measured (penetrating vertices summed over the
/// frames with a fold, parent/child pairs alone; with the skeleton's pairs): CesiumMan 341 ->
/// 19 (deepest 0.46 h); 341 -> 13 (0.35 h): 6 fewer; Fox's `Walk` 34 -> 14; 34 -> 13; its `Run`
/// 73 -> 8; 84 -> 19 over 3 more frames: the same output count over all frames (the 3 frames'
/// 11 vertices are the neck inside the upper arms, where the two regions meet: held by neither).
/// Asserted: no fewer resolved, more on CesiumMan, the volume kept, no face turned against both
/// the input and the skinning.
#[test]
fn the_skeletons_separated_regions_on_the_walking_characters() {
    for (rel, anim, gain) in [
        ("CesiumMan/CesiumMan.glb", None, 1),
        ("Fox/Fox.glb", Some("Walk"), 0),
        ("Fox/Fox.glb", Some("Run"), 0),
    ] {
        let Some(path) = sample(rel) else {
            continue;
        };
        let without = run_animation(rel, prepare(&path, FoldParams::default()), anim);
        let with = run_animation(
            rel,
            with_skeleton_pairs(prepare(&path, FoldParams::default())),
            anim,
        );
        let resolved = |s: &Summary| s.before as i64 - s.after as i64;
        assert!(
            resolved(&with) >= resolved(&without) + gain,
            "{rel} {anim:?}: {} -> {} resolved",
            resolved(&without),
            resolved(&with)
        );
        assert!(with.volume < 1e-4, "{rel}: {:.1e}", with.volume);
        assert_eq!(with.turned.turned, 0, "{rel}: {:?}", with.turned);
    }
}

/// The bulge guard (`[self_contact] bulge_guard`, on by default) on CesiumMan: where a fold's
/// bulge would carry a face of one side through the other, the bulge is scaled back and the
/// volume solved again. Measured over 21 frames: 58 -> 21 penetrating vertices (about as few
/// as with no bulge on the shoulders), the volume exact; Fox's run (41 frames) 102 -> 79; since
/// 2026-12-03 (the seam vertices in the mapping regions, the turn guard on every face with a
/// corner in the working regions) CesiumMan 33 -> 17; since the twenty-fourth session's
/// further sweeps 29 -> 19 (they resolve part of what the bulge pushes in without the guard).
/// Asserted: at most 0.7 is left (0.6 until then), with the volume kept.
#[test]
fn the_bulge_guard_cuts_cesium_mans_residual_with_the_volume_kept() {
    let free = FoldParams {
        bulge_guard: false,
        ..FoldParams::default()
    };
    let rel = "CesiumMan/CesiumMan.glb";
    if let Some(path) = sample(rel) {
        let without = run_sample(rel, &path, free);
        let s = run_sample(rel, &path, FoldParams::default());
        println!("{rel}: {} -> {} with the guard", without.after, s.after);
        assert!(
            10 * s.after <= 7 * without.after,
            "{} -> {}",
            without.after,
            s.after
        );
        assert!(s.volume < 1e-9, "volume error {:.1e}", s.volume);
        assert!(s.largest < 5.0, "largest displacement {:.1} h", s.largest);
    }
}

/// The pose of Khronos's WebXR left hand with `fingers` curled toward the palm by `angles`
/// (radians) at their proximal, intermediate and distal joints, about the hand's lateral axis
/// (from the index finger's knuckle to the little finger's), as a hand tracker poses it: each
/// joint's world matrix set on its own (the joint nodes are not nested).
fn curled_hand(rig: &rig::Rig, fingers: &[&str], angles: [f64; 3]) -> rig::Pose {
    use nalgebra::{Matrix4, Point3, Rotation3, Translation3, Unit, Vector3};
    let mut pose = rig.pose_at(None, 0.0);
    let node = |name: &str| {
        rig.nodes
            .iter()
            .position(|n| n.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("joint {name}"))
    };
    let at = |m: &Matrix4<f64>| m.transform_point(&Point3::origin());
    let rest = pose.clone();
    let lateral = at(&rest.world[node("pinky-finger-phalanx-proximal")])
        - at(&rest.world[node("index-finger-phalanx-proximal")]);
    let axis = Unit::new_normalize(lateral);
    for finger in fingers {
        let mut g: Matrix4<f64> = Matrix4::identity();
        let segments = [
            "phalanx-proximal",
            "phalanx-intermediate",
            "phalanx-distal",
            "tip",
        ];
        for (k, segment) in segments.iter().enumerate() {
            let j = node(&format!("{finger}-finger-{segment}"));
            if let Some(&angle) = angles.get(k) {
                // Turn about this joint where the previous turns have carried it.
                let pivot: Vector3<f64> = at(&(g * rest.world[j])).coords;
                let turn = Translation3::from(pivot).to_homogeneous()
                    * Rotation3::from_axis_angle(&axis, angle).to_homogeneous()
                    * Translation3::from(-pivot).to_homogeneous();
                g = turn * g;
            }
            pose.world[j] = g * rest.world[j];
        }
    }
    pose
}

/// A tracked hand (Khronos's WebXR hand: 25 joint nodes side by side, no animation) gets its
/// finger pairs from the joint names (19: four per finger, three for the thumb; the node
/// hierarchy gives none), and with its four fingers curled by 110° at the middle and 90° at
/// the last joint (the phalanges pressed into one another, the tips short of the palm) the pass
/// resolves the folds. Measured: 29 → 3 penetrating vertices, at most 0.051 h deep, no face
/// turned, volume error 6e-16, largest displacement 0.37 edge lengths. (It read 29 → 4, the
/// 4 with a "depth" of 1-2 h, when the metric's depth left out the faces within 3 rings; the
/// count went to 3 in an earlier session without this comment following.) What is left lies
/// at the last joints, whose folds the pass detects but leaves alone (one or two vertices of
/// one part lie 0.02-0.06 h inside the other along the mapping direction and none of the
/// other part does: no ray finds a depth, no zone forms), and where the ring finger's tip
/// meets its first phalanx (no joint pair spans the two).
#[test]
fn a_tracked_hand_curls_into_contact() {
    let rel = "WebXRGenericHand/left.glb";
    let Some(path) = sample(rel) else {
        return;
    };
    let Prepared {
        rig,
        pre,
        rest,
        pass,
    } = prepare(&path, FoldParams::default());
    let names = pass.pairs();
    assert_eq!(names.len(), 19, "{names:?}");
    for (parent, child) in [
        ("wrist", "thumb-metacarpal"),
        ("thumb-phalanx-proximal", "thumb-phalanx-distal"),
        ("wrist", "index-finger-metacarpal"),
        ("index-finger-metacarpal", "index-finger-phalanx-proximal"),
        (
            "pinky-finger-phalanx-intermediate",
            "pinky-finger-phalanx-distal",
        ),
    ] {
        let name = format!("l_handMeshNode/{parent}-{child}");
        assert!(names.iter().any(|(_, n)| *n == name), "{name}: {names:?}");
    }
    let fingers = ["index", "middle", "ring", "pinky"];
    let pose = curled_hand(
        &rig,
        &fingers,
        [0.0, 110f64.to_radians(), 90f64.to_radians()],
    );
    let frame = frames::evaluate_pose(&rig, &pre, &pose, 0, 0.0);
    let input = frame.welded(&pre);
    let mut out = input.clone();
    let res = pass.run(&rig, &pose, &mut out).expect("self-contact runs");
    let w = &pre.welded[0];
    let h = mean_edge_length(&rest[0], &w.triangles);
    let pen = |p: &[nalgebra::Point3<f64>]| {
        let n = vertex_normals(p, &w.triangles, NormalWeighting::Area);
        metrics::residual_penetration(p, &w.triangles, &n, h)
    };
    let (before, left) = (pen(&input[0]).vertices, pen(&out[0]));
    let (after, deepest) = (left.vertices, left.max_depth / h);
    let skinned = frame.welded_normals(&pre);
    let turned = metrics::turned_faces(&w.triangles, &input[0], &out[0], &skinned[0], h);
    let volume = metrics::volume_error(
        contact_skin::mesh::signed_volume(&input[0], &w.triangles),
        contact_skin::mesh::signed_volume(&out[0], &w.triangles),
    );
    let moved = input[0]
        .iter()
        .zip(&out[0])
        .map(|(p, q)| (p - q).norm() / h)
        .fold(0.0, f64::max);
    let folded: std::collections::BTreeSet<&str> =
        res.folds.iter().map(|f| f.name.as_str()).collect();
    println!(
        "{rel} curled: {} pairs folded, penetrating {before} -> {after} (deepest {deepest:.3} h), turned {} ({} buried), volume error {volume:.1e}, largest displacement {moved:.2} h, unbalanced {}",
        folded.len(),
        turned.turned,
        turned.buried,
        res.unbalanced.total()
    );
    for finger in fingers {
        let joint = format!(
            "l_handMeshNode/{finger}-finger-phalanx-proximal-{finger}-finger-phalanx-intermediate"
        );
        assert!(folded.contains(joint.as_str()), "{joint} folds: {folded:?}");
    }
    assert!(before >= 10, "the curl interpenetrates: {before}");
    assert_eq!(metrics::non_finite(&out[0]), 0);
    assert!(after * 5 <= before, "{before} -> {after}");
    assert!(deepest < 0.1, "a vertex left {deepest:.3} h deep");
    // What remains is contact: every flagged vertex is outside when nudged inward by 0.1 h.
    let normals = vertex_normals(&out[0], &w.triangles, NormalWeighting::Area);
    let winding = metrics::WindingNumber::new(&out[0], &w.triangles);
    let flagged = metrics::residual_penetration(&out[0], &w.triangles, &normals, h).flagged;
    for v in flagged.iter().map(|&v| v as usize) {
        let nudged = out[0][v] - normals[v].normalize() * (0.1 * h);
        let inside = winding.query(&nudged);
        assert!(
            inside < 1.5,
            "vertex {v} deeper than 0.1 h: winding {inside:.2}"
        );
    }
    assert_eq!(turned.turned, 0);
    assert_eq!(res.unbalanced.total(), 0);
    assert!(volume < 1e-4, "volume error {volume:.1e}");
    assert!(moved < 2.0, "a vertex moved by {moved:.1} edge lengths");
}

/// `pose` of `p`'s rig through its pass (depths in each body's rest edge lengths).
fn pass_pose(p: &Prepared, pose: &rig::Pose) -> Posed {
    let h: Vec<f64> = (p.rest.iter().zip(&p.pre.welded))
        .map(|(r, w)| mean_edge_length(r, &w.triangles))
        .collect();
    scenes::pass_pose(&p.rig, &p.pre, &p.pass, pose, &h)
}

/// A fist on Khronos's WebXR hand: the four fingers curled at all three joints until their
/// last phalanges press the palm, the neighbouring finger's knuckle and the thumb, which stays
/// where it rests across the palm. Those contacts are between a finger and its own palm, two
/// fingers, or a finger and the thumb: no parent/child pair holds them, the separated regions
/// of the skeleton do (the paper's Fig. 14, fingertips pressing their own palm). Measured
/// (penetrating vertices, parent/child pairs alone -> with the skeleton's separated regions):
/// curled 80°/100°/70° 95 -> 58 -> 7 (deepest 1.14 -> 0.09 h), 90°/100°/80° 137 -> 111 -> 11
/// (1.49 -> 0.13 h; 2 faces turned either way), volume error below 1e-15. Since a fold whose
/// guards did not settle goes back to a blend that turns no face over, or is refused
/// (2026-12-06): 90°/100°/80° 137 -> 114 -> 12, no face turned either way, volume error
/// 1.0e-6, the sum of the inexact volume roots the later folds accept (each within the pass's
/// `UNBALANCED_VOLUME`); the bound is the issue's.
#[test]
fn a_fist_presses_the_fingertips_into_the_palm() {
    let rel = "WebXRGenericHand/left.glb";
    let Some(path) = sample(rel) else {
        return;
    };
    let derived = prepare(&path, FoldParams::default());
    let skeleton = with_skeleton_pairs(prepare(&path, FoldParams::default()));
    let fingers = ["index", "middle", "ring", "pinky"];
    for angles in [[80.0, 100.0, 70.0], [90.0, 100.0, 80.0]] {
        let pose = curled_hand(&derived.rig, &fingers, angles.map(f64::to_radians));
        let (a, b) = (pass_pose(&derived, &pose), pass_pose(&skeleton, &pose));
        println!(
            "{rel} fist {angles:?}: penetrating {} -> {} (deepest {:.2} h) -> {} ({:.2} h) with \
             the skeleton's separated regions, turned {} / {}, volume error {:.1e}",
            a.before, a.after, a.deepest, b.after, b.deepest, a.turned, b.turned, b.volume
        );
        assert!(a.before >= 90, "the fist interpenetrates: {}", a.before);
        assert!(b.after * 5 <= a.after, "{} -> {}", a.after, b.after);
        assert!(b.deepest < 0.25, "a vertex left {:.2} h deep", b.deepest);
        assert!(
            b.turned <= a.turned,
            "{} -> {} turned faces",
            a.turned,
            b.turned
        );
        assert!(b.volume < 1e-4, "volume error {:.1e}", b.volume);
        assert_eq!(b.non_finite, 0);
    }
}

/// How far inward along `-n` from `p` the point stays inside twice over (winding number at
/// least [`metrics::PENETRATION_THRESHOLD`]), from the metric's nudge on, within `reach`:
/// marched in steps of `h / 100`, then bisected; `None` when the nudged point is not inside
/// twice or the march does not leave within `reach`.
///
/// Why it bounds [`metrics::residual_penetration`]'s depth, on a closed mesh: the winding
/// number changes only across the surface, so the march leaves through a face; not one of the
/// vertex's own faces (a ray from a vertex meets them only within their plane, and leaves
/// none of them); and it leaves that face from its inside, along `-n`, so the face's normal
/// points away from `n`: the face faces the vertex, and the depth, the distance to the nearest
/// such face, is no larger than the distance marched. (On an open mesh the winding number also
/// changes away from the surface, and the bound does not hold.)
fn way_out_inward(
    w: &metrics::WindingNumber,
    p: &Point3<f64>,
    n: &Vector3<f64>,
    h: f64,
    reach: f64,
) -> Option<f64> {
    let inside = |t: f64| w.query(&(p - n * t)) >= metrics::PENETRATION_THRESHOLD;
    let start = metrics::PENETRATION_NUDGE * h;
    if !inside(start) {
        return None;
    }
    let step = 0.01 * h;
    let mut t = start;
    while t < reach {
        if !inside(t + step) {
            return Some(bisect_exit(&inside, t, t + step));
        }
        t += step;
    }
    None
}

/// The exit point between `lo` (inside) and `hi` (outside), to 2^-40 of the interval.
fn bisect_exit(inside: &impl Fn(f64) -> bool, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if inside(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// What [`depths_against_the_way_out`] measured on one mesh.
struct DepthCheck {
    flagged: usize,
    /// Largest depth, in `h`.
    deepest: f64,
    /// Median of depth / way out.
    median: f64,
}

/// Checks every flagged vertex's depth on the closed mesh `(positions, tris)` against its way
/// out ([`way_out_inward`], within the mesh's box diagonal): it must exist and be no shorter.
fn depths_against_the_way_out(
    name: &str,
    positions: &[Point3<f64>],
    tris: &[[u32; 3]],
    h: f64,
) -> DepthCheck {
    assert!(
        contact_skin::mesh::Region::whole(tris).is_closed(),
        "{name}: the bound holds on closed meshes"
    );
    let normals = vertex_normals(positions, tris, NormalWeighting::Area);
    let pen = metrics::residual_penetration(positions, tris, &normals, h);
    let w = metrics::WindingNumber::new(positions, tris);
    let reach = contact_skin::mesh::bbox_diagonal(positions.iter());
    let (mut worst, mut deepest, mut ratios) = (0.0f64, 0.0f64, Vec::new());
    for (&v, &d) in pen.flagged.iter().zip(&pen.depths) {
        let v = v as usize;
        let n = normals[v].normalize();
        let out = way_out_inward(&w, &positions[v], &n, h, reach)
            .unwrap_or_else(|| panic!("{name}: vertex {v} flagged without a way out"));
        worst = worst.max(d / out);
        ratios.push(d / out);
        deepest = deepest.max(d / h);
    }
    ratios.sort_by(f64::total_cmp);
    let median = ratios.get(ratios.len() / 2).copied().unwrap_or(1.0);
    println!(
        "{name}: {} flagged, deepest {deepest:.3} h, depth / way out: largest {worst:.3}, \
         median {median:.3}",
        pen.vertices
    );
    assert!(
        worst <= 1.0 + 1e-9,
        "{name}: a depth exceeds its way out ({worst:.3})"
    );
    DepthCheck {
        flagged: pen.vertices,
        deepest,
        median,
    }
}

/// The residual penetration's depth (`MEASURING.md`) against an independent bound: a flagged
/// vertex's depth is at most the distance it can travel inward along its normal before it
/// stops being inside twice ([`way_out_inward`]). The depth's former rule (faces within 3
/// rings of the vertex never counted) broke the bound by up to 57 times on CesiumMan's
/// skinned frames and 51 on its resolved ones (vertices a fraction of an edge under a
/// neighbour's face folded over them, at the knees and shoulders, read 3.0-6.1 edge lengths
/// deep, about the radius of the excluded rings), 2.9-14 on the bending capsule's LBS fold and
/// 1.16 on its CoR output (over its 31 frames `pose --metrics` reported 2.4 h at most, 0.23 h
/// now). Measured now: at most 1.000 everywhere; on the capsule's LBS fold the deepest depths
/// are within 5 % of the former ones (4.1, 5.9, 6.9 h then; 4.0, 5.6, 6.9 h now). Guards
/// against understating: the capsule's fold stays deep and its depths stay a fair share of the
/// way out (the way along the normal crosses the other arm obliquely).
#[test]
fn penetration_depths_are_no_deeper_than_the_way_out() {
    // The bending capsule skinned with LBS (hundreds of vertices inside the other part,
    // several edge lengths deep), and its CoR and DQS skinning resolved by the pass in the
    // frames that leave vertices inside.
    for (method, resolve, frames) in [
        (Method::Lbs, false, (20..31).step_by(2)),
        (Method::Cor, true, (18..31).step_by(1)),
        (Method::Dqs, true, (18..31).step_by(1)),
    ] {
        let l = scenes::load_with("bending_capsule", 31, method);
        let rest = scenes::welded_positions(&l.rig, &l.pre, 0.0, None);
        let (w, o) = (&l.pre.welded, RegionOptions::default());
        let pass = SelfContactPass::new(&l.rig, w, &rest, &o, FoldParams::default(), &[])
            .expect("pairs derive");
        let mut flagged = 0;
        for k in frames {
            let mut pos = l.frame(k);
            if resolve {
                let pose = l.rig.pose_at(Some(0), l.times[k]);
                pass.run(&l.rig, &pose, &mut pos).expect("pass runs");
            }
            let name = format!("bending capsule {method:?} frame {k}");
            let c = depths_against_the_way_out(&name, &pos[0], &l.triangles[0], l.h_rest);
            flagged += c.flagged;
            if !resolve && k >= 24 {
                // Measured: deepest 5.6-6.9 h, median depth / way out 0.44-0.49 (the way
                // out along the normal crosses the other arm obliquely).
                assert!(c.deepest > 2.0, "{name}: a deep fold");
                assert!(
                    c.median > 0.3,
                    "{name}: depths understated ({:.3})",
                    c.median
                );
            }
        }
        assert!(flagged > 0, "{method:?}: nothing to measure");
    }
    let rel = "CesiumMan/CesiumMan.glb";
    let Some(path) = sample(rel) else {
        return;
    };
    let prepared = prepare(&path, FoldParams::default());
    let tris = &prepared.pre.welded[0].triangles;
    let h = mean_edge_length(&prepared.rest[0], tris);
    let times = frames::sample_times(&prepared.rig, Some(0), Some(21)).expect("frames");
    for (k, &t) in times.iter().enumerate() {
        let p = prepared.pass_frame(Some(0), k, t);
        depths_against_the_way_out(&format!("{rel} frame {k}, skinned"), &p.input[0], tris, h);
        depths_against_the_way_out(&format!("{rel} frame {k}, resolved"), &p.out[0], tris, h);
    }
}

/// `rig`'s rest pose with every joint of its skins turned about a random axis by a random
/// angle up to `max_angle` (radians), after its rest rotation.
fn random_pose(rig: &rig::Rig, r: &mut rng::Rng, max_angle: f64) -> rig::Pose {
    use nalgebra::{Unit, UnitQuaternion};
    let mut locals = rig.rest_locals();
    let joints = rig.skins.iter().flat_map(|s| s.joints.iter().copied());
    for j in joints {
        let axis = Unit::new_normalize(r.unit());
        let turn = UnitQuaternion::from_axis_angle(&axis, r.range(0.0, max_angle));
        locals[j] = match locals[j] {
            rig::LocalTransform::Trs(mut t) => {
                t.rotation *= turn;
                rig::LocalTransform::Trs(t)
            }
            rig::LocalTransform::Matrix(m) => {
                rig::LocalTransform::Matrix(m * turn.to_homogeneous())
            }
        };
    }
    rig.pose_from_locals(&locals)
}

/// Random poses of every sample through the pass as `pose` runs it (the parent/child pairs and
/// the skeleton's separated regions), with LBS, DQS and CoR input: each joint turned about a
/// random axis by up to 120° from its rest rotation, far past what the animations ask (limbs
/// twisted into the body, fingers through the palm, joints folded both ways). In every pose
/// the pass must run without an error, stay finite and keep the volume (the 1e-4),
/// and it must leave fewer penetrating vertices than the skinning gave, except on the robot
/// (its rigid pieces interpenetrate by construction wherever two meet, in the rest pose too,
/// and a fold that moves one piece's vertices may push a few into the next: at 90°, 6 poses,
/// DQS, 2362 -> 2367, measured), and at most a third of them over the four characters that
/// fold. Measured (4 poses, the same for each input, 2026-12-04; penetrating vertices
/// summed, LBS / DQS / CoR): CesiumMan 691 -> 27 / 745 -> 23 / 845 -> 54, Fox 92 -> 27 /
/// 103 -> 31 / 112 -> 39, the WebXR hand 167 -> 37 / 209 -> 113 / 201 -> 101, RiggedFigure
/// 23 -> 7 / 29 -> 4 / 29 -> 8 (over the four, 3046 -> 471), the robot 1581 -> 1570 / 1578 ->
/// 1567 / 1581 -> 1573; what is left at most 1.0 h deep (1.5 h on the hand with DQS and
/// CoR); volume errors at most 6e-7; faces turned against both the input and the skinning 0-7
/// per character and input, 14 and 27 on the hand with DQS and CoR. Those came from folds
/// whose guards and volume solves had not settled within their cap (the last solve raising the
/// bulge on the vertices left, unchecked); such a fold now goes back to its last blend that
/// turns no face over, or is refused (2026-12-06): no face turned on any character with any
/// input, asserted; penetrating vertices over the four 3046 -> 400 (CesiumMan 30 / 27 / 54,
/// Fox 22 / 37 / 30, the hand 39 / 78 / 68, RiggedFigure 7 / 4 / 4). Up to 160°
/// (12 poses each, another seed) the same holds: no error, no NaN, volume error at most
/// 1.2e-6. The samples without a fold (RiggedSimple, SimpleSkin) run through as well.
#[test]
fn random_poses_of_every_sample_stay_finite_and_keep_the_volume() {
    let (mut before, mut after) = (0, 0);
    for rel in CHARACTERS {
        let Some(path) = sample(rel) else {
            continue;
        };
        for method in [Method::Lbs, Method::Dqs, Method::Cor] {
            let p = with_skeleton_pairs(prepare_with(&path, FoldParams::default(), method));
            let mut r = rng::Rng(0x5eed_0004);
            let mut s = Posed::default();
            for _ in 0..4 {
                let pose = random_pose(&p.rig, &mut r, 120f64.to_radians());
                s.add(&pass_pose(&p, &pose));
            }
            println!(
                "{rel} ({method:?}), 4 random poses: {} folds, penetrating vertices {} -> {} \
                 (deepest left {:.2} h), {} faces turned, worst volume error {:.1e}",
                s.folds, s.before, s.after, s.deepest, s.turned, s.volume
            );
            assert_eq!(s.non_finite, 0, "{rel} ({method:?}): NaN");
            assert_eq!(s.turned, 0, "{rel} ({method:?}): faces turned over");
            assert!(
                s.volume < 1e-4,
                "{rel} ({method:?}): volume {:.1e}",
                s.volume
            );
            if rel.contains("robot") {
                continue;
            }
            assert!(
                s.after <= s.before && (s.before == 0 || s.after < s.before),
                "{rel} ({method:?}): {} -> {} penetrating vertices",
                s.before,
                s.after
            );
            before += s.before;
            after += s.after;
        }
    }
    assert!(
        3 * after <= before,
        "over the characters that fold: {before} -> {after} penetrating vertices"
    );
}

/// CesiumMan read as a triangle fan (slivers from its first vertex spanning the body, each
/// over many joints): the centers of rotation planned 19.5 M bucket entries (8.7 s and 2 GB
/// to precompute for 3273 vertices); the subdivision is capped to keep within the entry
/// budget, the precomputation says so, and every center is finite. CesiumMan itself is not
/// capped.
#[test]
fn centers_of_rotation_of_a_fan_read_mesh_keep_within_their_budget() {
    use contact_skin::skinning::cor::{entry_budget, CorCenters, CorParams};
    let Some(path) = sample("CesiumMan/CesiumMan.glb") else {
        return;
    };
    let bytes = std::fs::read(&path).expect("sample reads");
    let fan = rig::load_from_bytes(&path, &with_first_primitive_mode(&bytes, 6)).expect("loads");
    let body = &fan.bodies[0];
    let (centers, stats) = CorCenters::precompute_with_stats(body, &CorParams::default());
    let (cap, planned) = centers.subdivision_cap.expect("capped");
    println!("cap {cap}, planned {planned}: {stats:?}");
    assert!(planned > entry_budget(body.triangles.len()) && cap < 32);
    assert!(stats.bucket_entries <= entry_budget(body.triangles.len()));
    let finite = |p: &Point3<f64>| p.coords.iter().all(|x| x.is_finite());
    assert!(centers.centers.iter().flatten().all(finite));
    let plain = rig::load(&path).expect("loads");
    let (own, _) = CorCenters::precompute_with_stats(&plain.bodies[0], &CorParams::default());
    assert_eq!(own.subdivision_cap, None);
    let pre = Precomputed::new(&fan, Method::Cor);
    assert_eq!(pre.warnings(&fan).len(), 1);
    assert!(Precomputed::new(&plain, Method::Cor)
        .warnings(&plain)
        .is_empty());
}

/// A fold left unresolved says why (`FoldOutput::unbalanced`), and the reason agrees with
/// what the fold measured: no exact root of the volume cubic, a bulge steeper than its band
/// allows, or (neither) a face turned over; the frame's counts add them up. On Fox's walk
/// (21 frames, the skeleton's separated pairs, LBS) measured 2026-12-06: 45 folds refused, 27
/// without a root and 18 too steep, none for a turned face. Every fold without a root was a
/// separated pair (`b_Spine01_02* vs b_LeftLeg01_015*`, `b_Hip_01 vs b_RightLeg02_020*`, …)
/// with a zone of 1 to 10 vertices on one side, none on the other, and 0 or 1 vertex in its
/// band: a zone at its region's border, where the extent is capped to nothing, so no bulge
/// can give back the volume the zone's displacement took.
#[test]
fn refused_folds_say_why() {
    use contact_skin::deform::volume::RootKind;
    use contact_skin::selfcontact::fold::{Unbalanced, STEEPEST_BULGE};
    use contact_skin::selfcontact::pass::UnbalancedCounts;
    let Some(path) = sample("Fox/Fox.glb") else {
        return;
    };
    let p = with_skeleton_pairs(prepare(&path, FoldParams::default()));
    let anim = p
        .rig
        .animations
        .iter()
        .position(|a| a.name.as_deref() == Some("Walk"));
    let times = frames::sample_times(&p.rig, anim, Some(21)).expect("frames");
    let mut counts = UnbalancedCounts::default();
    for (k, &t) in times.iter().enumerate() {
        let report = p.pass_frame(anim, k, t).report;
        let mut frame = UnbalancedCounts::default();
        for fold in &report.folds {
            let o = &fold.output;
            frame.count(o.unbalanced);
            let steep = o.bulge_steepness > STEEPEST_BULGE;
            let exact = o.root.is_none_or(|r| r == RootKind::Exact);
            match o.unbalanced {
                Some(Unbalanced::NoVolumeRoot) => assert!(!exact, "{}", fold.name),
                Some(Unbalanced::SteepBulge) => assert!(exact && steep, "{}", fold.name),
                Some(Unbalanced::TurnedFace) => assert!(exact && !steep, "{}", fold.name),
                None => assert!(!steep, "{}", fold.name),
            }
        }
        assert_eq!(frame, report.unbalanced, "frame {k}");
        counts += frame;
    }
    println!("Fox's walk, 21 frames: refused {counts:?}");
    assert!(
        counts.no_volume_root > 0 && counts.steep_bulge > 0,
        "{counts:?}"
    );
}
