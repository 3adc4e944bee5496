//! Separated working regions of one skinned mesh (2021 Sec. 4-5 on two parts of one mesh, the
//! paper's Fig. 14, `[[self_contact.separated]]`): the committed `two_fingers` rig, whose
//! fingers are sibling joints pressed against each other. No parent/child pair holds that
//! contact; the pair of separated regions `index` / `middle` resolves it, named in a
//! configuration or derived from the skeleton (`separated_from_skeleton`).

#[path = "common/scenes.rs"]
mod scenes;

use contact_skin::mesh::operators::{vertex_normals, NormalWeighting};
use contact_skin::mesh::signed_volume;
use contact_skin::report::metrics;
use contact_skin::selfcontact::pass::SelfContactPass;
use contact_skin::selfcontact::{
    extend_distinct, separated_from_skeleton, separated_regions, PairRegions, RegionOptions,
    SelfContactError,
};
use nalgebra::Point3;
use scenes::{load, self_pass_separated, Loaded};

const INDEX: &[&str] = &["index"];
const MIDDLE: &[&str] = &["middle"];

/// The self-contact pass of `l` with the derived pairs and, for `Some(sides)`, the separated
/// regions of `sides`.
fn pass(l: &Loaded, sides: Option<[&[&str]; 2]>) -> SelfContactPass {
    let options = RegionOptions::default();
    let separated = sides.map_or_else(Vec::new, |sides| {
        separated_regions(&l.rig, &l.pre.welded, sides, &options).expect("separated regions")
    });
    self_pass_separated(l, separated)
}

fn penetrating(l: &Loaded, p: &[Point3<f64>]) -> usize {
    let n = vertex_normals(p, &l.triangles[0], NormalWeighting::Area);
    metrics::residual_penetration(p, &l.triangles[0], &n, l.h_rest).vertices
}

/// The body's positions per frame, in and out, and how many folds of separated regions ran.
struct Run {
    ins: Vec<Vec<Point3<f64>>>,
    outs: Vec<Vec<Point3<f64>>>,
    separated: usize,
}

/// Every frame of `l` through `pass`.
fn run(l: &Loaded, pass: &SelfContactPass) -> Run {
    let (mut ins, mut outs, mut separated) = (Vec::new(), Vec::new(), 0);
    for (k, &t) in l.times.iter().enumerate() {
        let input = l.frame(k);
        let mut out = input.clone();
        let pose = l.rig.pose_at(Some(0), t);
        let o = pass.run(&l.rig, &pose, &mut out).expect("frame");
        separated += o.folds.iter().filter(|f| f.name.contains(" vs ")).count();
        ins.push(input[0].clone());
        outs.push(out[0].clone());
    }
    Run {
        ins,
        outs,
        separated,
    }
}

#[test]
fn the_derived_pairs_leave_the_sibling_fingers_inside_each_other() {
    let l = load("two_fingers", 21);
    let Run {
        ins,
        outs,
        separated,
    } = run(&l, &pass(&l, None));
    assert_eq!(separated, 0);
    let last = ins.len() - 1;
    let (before, after) = (penetrating(&l, &ins[last]), penetrating(&l, &outs[last]));
    // The input presses the tips 0.1 into each other; the two palm-finger folds do not reach.
    assert!(before > 100, "input penetrating vertices {before}");
    assert!(
        after * 10 > before * 9,
        "{before} -> {after} without the pair"
    );
}

#[test]
fn separated_regions_resolve_the_sibling_fingers() {
    let l = load("two_fingers", 21);
    let Run {
        ins,
        outs,
        separated,
    } = run(&l, &pass(&l, Some([INDEX, MIDDLE])));
    assert!(separated > 0, "the separated pair never ran");
    let skinned: Vec<_> = (0..ins.len()).map(|k| l.frame_normals(k)).collect();
    for (k, (input, out)) in ins.iter().zip(&outs).enumerate() {
        let before = penetrating(&l, input);
        let after = penetrating(&l, out);
        assert_eq!(
            after, 0,
            "frame {k}: {before} -> {after} penetrating vertices"
        );
        let volume = metrics::volume_error(
            signed_volume(input, &l.triangles[0]),
            signed_volume(out, &l.triangles[0]),
        );
        assert!(volume < 1e-4, "frame {k}: volume error {volume:.2e}");
        assert_eq!(metrics::non_finite(out), 0, "frame {k}");
        let turned = metrics::turned_faces(&l.triangles[0], input, out, &skinned[k][0], l.h_rest);
        assert_eq!(turned.turned, 0, "frame {k}: {turned:?}");
    }
    // Continuous in time: the largest step of the displacement stays below the input's
    // fastest motion per frame, and does not grow when the frame step halves (a pop would).
    let step = metrics::displacement_step_ratio(&outs, &ins);
    let l2 = load("two_fingers", 41);
    let r2 = run(&l2, &pass(&l2, Some([INDEX, MIDDLE])));
    let step2 = metrics::displacement_step_ratio(&r2.outs, &r2.ins);
    assert!(step.ratio < 1.5, "{step:?}");
    assert!(
        step2.ratio < 1.5 * step.ratio.max(0.5),
        "{step:?} -> {step2:?}"
    );
}

#[test]
fn separated_regions_give_the_same_result_with_their_sides_exchanged() {
    let l = load("two_fingers", 11);
    let a = run(&l, &pass(&l, Some([INDEX, MIDDLE]))).outs;
    let b = run(&l, &pass(&l, Some([MIDDLE, INDEX]))).outs;
    let gap = a
        .iter()
        .zip(&b)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).norm()))
        .fold(0.0, f64::max);
    // Eq. 2 flips with the sides, and each side moves half the depth (k̄ = 0.5).
    assert!(gap <= 1e-9 * l.h_rest, "{:.3e} h", gap / l.h_rest);
}

#[test]
fn separated_regions_are_checked() {
    let l = load("two_fingers", 2);
    let options = RegionOptions::default();
    let regions = |sides: [&[&str]; 2]| separated_regions(&l.rig, &l.pre.welded, sides, &options);
    let found = regions([INDEX, MIDDLE]).expect("index / middle");
    assert_eq!(found.len(), 1);
    let r = &found[0];
    assert!(r.separated() && r.shared.is_empty());
    assert!(
        r.w1.iter().zip(&r.w2).all(|(a, b)| !(*a && *b)),
        "the regions share a vertex"
    );
    assert!(!r.w1_faces.is_empty() && !r.w2_faces.is_empty());
    assert!(matches!(
        regions([&["ring"], MIDDLE]),
        Err(SelfContactError::UnknownJoint(name)) if name == "ring"
    ));
    assert!(matches!(
        regions([&["index", "middle"], MIDDLE]),
        Err(SelfContactError::UnusablePair { .. })
    ));
    assert!(matches!(
        regions([&[], MIDDLE]),
        Err(SelfContactError::UnusablePair { .. })
    ));
}

/// The separated pairs the skeleton gives a rig, by name.
fn skeleton_pairs(l: &Loaded) -> Vec<PairRegions> {
    separated_from_skeleton(&l.rig, &l.pre.welded, &RegionOptions::default()).expect("derived")
}

/// The skeleton gives the sibling fingers the pair a configuration names (the same regions,
/// so the same output to the bit), and a chain each joint against its grandchild's subtree;
/// the regions of every derived pair share no vertex.
#[test]
fn the_skeleton_gives_siblings_and_grandchildren_their_separated_regions() {
    let l = load("two_fingers", 2);
    let derived = skeleton_pairs(&l);
    let names: Vec<&str> = derived.iter().map(|r| r.pair.name.as_str()).collect();
    assert_eq!(names, ["fingers/index* vs middle*"]);
    let named = separated_regions(
        &l.rig,
        &l.pre.welded,
        [INDEX, MIDDLE],
        &RegionOptions::default(),
    )
    .expect("index / middle");
    assert_eq!(derived[0].w1_faces, named[0].w1_faces);
    assert_eq!(derived[0].w2_faces, named[0].w2_faces);
    // A configured pair the skeleton also derives is kept once, under its configured name.
    let mut both = named.clone();
    extend_distinct(&mut both, derived);
    assert_eq!(both.len(), 1);
    assert_eq!(both[0].pair.name, named[0].pair.name);

    let finger = load("finger", 2);
    let derived = skeleton_pairs(&finger);
    let names: Vec<&str> = derived.iter().map(|r| r.pair.name.as_str()).collect();
    assert_eq!(
        names,
        ["finger/metacarpal vs middle*", "finger/proximal vs distal*"]
    );
    for r in &derived {
        assert!(r.separated(), "{}", r.pair.name);
        assert!(
            r.w1.iter().zip(&r.w2).all(|(a, b)| !(*a && *b)),
            "{}: the regions share a vertex",
            r.pair.name
        );
    }
    // The bending capsule's one joint has no sibling and no grandchild.
    assert!(skeleton_pairs(&load("bending_capsule", 2)).is_empty());
}

/// Through the pass, the derived pair resolves the sibling fingers as the configured one does:
/// the same output to the bit.
#[test]
fn the_skeletons_pair_resolves_the_sibling_fingers_as_the_configured_one() {
    let l = load("two_fingers", 11);
    let derived = self_pass_separated(&l, skeleton_pairs(&l));
    let a = run(&l, &derived);
    let b = run(&l, &pass(&l, Some([INDEX, MIDDLE])));
    assert!(a.separated > 0);
    assert_eq!(a.outs, b.outs);
    let last = a.outs.len() - 1;
    assert!(penetrating(&l, &a.ins[last]) > 100);
    assert_eq!(penetrating(&l, &a.outs[last]), 0);
}
