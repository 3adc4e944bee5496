//! Self-contact working regions, partition of unity and skeleton direction (Brunel et al.
//! 2021, Sec. 6; `PIPELINE.md`, "Working regions", "Skeleton-derived direction") on the
//! committed rigs of `rigs/`.

#[path = "common/scenes.rs"]
mod scenes;

use contact_skin::frames;
use contact_skin::mesh::operators::FaceGeometry;
use contact_skin::mesh::WeldedMesh;
use contact_skin::rig::{LocalTransform, Rig, SkinWeights};
use contact_skin::selfcontact::{
    derive_pairs, derive_pairs_reporting, pairs_for_joints, partition_of_unity, skeleton_direction,
    BoneAxes, DirectionSource, LeafAxisSource, PairRegions, RegionOptions, SelfContactError,
};
use nalgebra::{Point3, UnitQuaternion, Vector3};

/// Welded rest (bind) positions of body `b`.
fn rest_positions(rig: &Rig, welded: &[WeldedMesh], b: usize) -> Vec<Point3<f64>> {
    welded[b].gather(&rig.bodies[b].positions)
}

/// Rest world position of node `n`.
fn rest_joint(rig: &Rig, n: usize) -> Point3<f64> {
    rig.pose_at(None, 0.0).world[n].transform_point(&Point3::origin())
}

fn node_index(rig: &Rig, name: &str) -> usize {
    rig.nodes
        .iter()
        .position(|n| n.name.as_deref() == Some(name))
        .expect("joint exists")
}

fn adjacency(n: usize, triangles: &[[u32; 3]]) -> Vec<Vec<u32>> {
    let mut adj = vec![Vec::new(); n];
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            adj[a as usize].push(b);
            adj[b as usize].push(a);
        }
    }
    for l in &mut adj {
        l.sort_unstable();
        l.dedup();
    }
    adj
}

/// Border classes of the vertices of R: (next to W1 \ R only, next to W2 \ R only).
fn border_classes(p: &PairRegions, adj: &[Vec<u32>]) -> (Vec<u32>, Vec<u32>) {
    let (mut one, mut zero) = (Vec::new(), Vec::new());
    for &v in &p.shared {
        let near = |a: &[bool], b: &[bool]| {
            adj[v as usize]
                .iter()
                .any(|&u| a[u as usize] && !b[u as usize])
        };
        match (near(&p.w1, &p.w2), near(&p.w2, &p.w1)) {
            (true, false) => one.push(v),
            (false, true) => zero.push(v),
            _ => {}
        }
    }
    (one, zero)
}

/// Checks shared by every pair: R = W1 ∩ W2, β = 1 / 0 outside R and on the two Dirichlet
/// borders, β ∈ [0, 1] everywhere.
fn check_partition(p: &PairRegions, adj: &[Vec<u32>]) {
    let n = p.beta.len();
    assert_eq!(p.w1.len(), n);
    assert_eq!(p.w2.len(), n);
    let shared: Vec<u32> = (0..n as u32)
        .filter(|&v| p.w1[v as usize] && p.w2[v as usize])
        .collect();
    assert_eq!(shared, p.shared, "{}", p.pair.name);
    for v in 0..n {
        let b = p.beta[v];
        assert!((0.0..=1.0).contains(&b), "{}: beta {b}", p.pair.name);
        match (p.w1[v], p.w2[v]) {
            (true, false) => assert_eq!(b, 1.0),
            (false, true) => assert_eq!(b, 0.0),
            _ => {}
        }
    }
    let (one, zero) = border_classes(p, adj);
    assert!(!one.is_empty() && !zero.is_empty(), "{}", p.pair.name);
    assert_eq!(one.len(), p.partition.dirichlet_one);
    assert_eq!(zero.len(), p.partition.dirichlet_zero);
    for &v in &one {
        assert_eq!(p.beta[v as usize], 1.0, "{}: W1 border", p.pair.name);
    }
    for &v in &zero {
        assert_eq!(p.beta[v as usize], 0.0, "{}: W2 border", p.pair.name);
    }
}

#[test]
fn bending_capsule_has_one_pair_whose_shared_region_is_a_band_around_the_joint() {
    let loaded = scenes::load("bending_capsule", 2);
    let (rig, welded) = (&loaded.rig, &loaded.pre.welded);
    let pairs = derive_pairs(rig, welded, &RegionOptions::default()).expect("pairs");
    assert_eq!(pairs.len(), 1, "{pairs:#?}");
    let p = &pairs[0];
    assert_eq!(p.pair.name, "capsule/lower-upper");
    assert_eq!(p.pair.parent_joint, node_index(rig, "lower"));
    assert_eq!(p.pair.child_joint, node_index(rig, "upper"));
    println!("{}", p.reason);

    // The joint plane: through the child joint, normal to the bone from the parent joint.
    let joint = rest_joint(rig, p.pair.child_joint);
    let axis = (joint - rest_joint(rig, p.pair.parent_joint)).normalize();
    let pos = rest_positions(rig, welded, 0);
    let height = |v: usize| (pos[v] - joint).dot(&axis);
    // Half-width of the weight blend (vertices with both bones' weight) plus the growth:
    // (rings + 1) longest edges on each side.
    let body = &rig.bodies[0];
    let blend = welded[0]
        .representative
        .iter()
        .enumerate()
        .filter(|&(_, &f)| body.weights.row(f as usize).count() == 2)
        .map(|(v, _)| height(v).abs())
        .fold(0.0, f64::max);
    let longest = welded[0]
        .triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
        .map(|(a, b)| (pos[a as usize] - pos[b as usize]).norm())
        .fold(0.0, f64::max);
    let rings = RegionOptions::default().grow_rings as f64;
    let half_band = blend + (rings + 1.0) * longest;
    let (lo, hi) = p
        .shared
        .iter()
        .map(|&v| height(v as usize))
        .fold((f64::MAX, f64::MIN), |(l, h), y| (l.min(y), h.max(y)));
    println!(
        "R: {} vertices, height over the joint plane [{lo:.4}, {hi:.4}], blend {blend:.4}, \
         bound {half_band:.4}",
        p.shared.len()
    );
    assert!(lo >= -half_band && hi <= half_band);
    // ... and it reaches past the blend on both sides (the growth).
    assert!(lo < -blend && hi > blend);
    // W1 ∪ W2 covers every vertex; the parts outside R lie on their own side of the plane.
    for v in 0..pos.len() {
        assert!(p.w1[v] || p.w2[v], "vertex {v} in no region");
        if p.w1[v] && !p.w2[v] {
            assert!(height(v) < 0.0);
        }
        if p.w2[v] && !p.w1[v] {
            assert!(height(v) > 0.0);
        }
    }
    let adj = adjacency(pos.len(), &welded[0].triangles);
    check_partition(p, &adj);
    let (one, zero) = border_classes(p, &adj);
    println!(
        "border rings: {} at beta = 1, {} at beta = 0",
        one.len(),
        zero.len()
    );
    assert!(one.iter().all(|&v| (height(v as usize) - lo).abs() < 1e-6));
    assert!(zero.iter().all(|&v| (height(v as usize) - hi).abs() < 1e-6));

    // Monotone along the axis: a vertex lower than another has at least its β (all pairs).
    let mut worst: f64 = 0.0;
    for &a in &p.shared {
        for &b in &p.shared {
            if height(a as usize) < height(b as usize) - 1e-9 {
                worst = worst.max(p.beta[b as usize] - p.beta[a as usize]);
            }
        }
    }
    println!("largest increase of beta along the axis: {worst:.3e}");
    assert!(worst <= 1e-9);

    // Harmonic: discrete maximum principle and cotangent-Laplacian residual at the free
    // vertices of R (assembled here on R's faces at the rest positions).
    assert!(p.partition.raw_min >= -1e-12 && p.partition.raw_max <= 1.0 + 1e-12);
    let in_r: Vec<bool> = (0..pos.len()).map(|v| p.w1[v] && p.w2[v]).collect();
    let mut fixed = vec![false; pos.len()];
    for &v in one.iter().chain(&zero) {
        fixed[v as usize] = true;
    }
    let mut residual = vec![0.0; pos.len()];
    let mut diagonal = vec![0.0; pos.len()];
    for t in welded[0]
        .triangles
        .iter()
        .filter(|t| t.iter().all(|&v| in_r[v as usize]))
    {
        let g = FaceGeometry::new(t.map(|v| pos[v as usize]));
        for i in 0..3 {
            for j in (0..3).filter(|&j| j != i) {
                let w = g.stiffness(i, j);
                let (vi, vj) = (t[i] as usize, t[j] as usize);
                residual[vi] += w * (p.beta[vj] - p.beta[vi]);
                diagonal[vi] -= w;
            }
        }
    }
    let scale = diagonal.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    let (mut max_res, mut free) = (0.0f64, 0);
    for &v in &p.shared {
        let v = v as usize;
        if fixed[v] {
            continue;
        }
        free += 1;
        max_res = max_res.max(residual[v].abs() / scale);
        let (nlo, nhi) = adj[v]
            .iter()
            .filter(|&&u| in_r[u as usize])
            .map(|&u| p.beta[u as usize])
            .fold((f64::MAX, f64::MIN), |(l, h), b| (l.min(b), h.max(b)));
        assert!(
            p.beta[v] >= nlo - 1e-12 && p.beta[v] <= nhi + 1e-12,
            "maximum principle at {v}"
        );
    }
    println!("relative Laplacian residual over {free} free vertices: {max_res:.3e}");
    assert!(max_res < 1e-10);
    assert_eq!(free, p.shared.len() - one.len() - zero.len());

    // A config naming the same joints gives the same regions.
    let named = pairs_for_joints(
        rig,
        welded,
        &[("lower", "upper")],
        &RegionOptions::default(),
    )
    .expect("named pair");
    assert_eq!(named.len(), 1);
    assert_eq!(named[0].pair, p.pair);
    assert_eq!(named[0].shared, p.shared);
    assert_eq!(named[0].beta, p.beta);
}

#[test]
fn finger_has_the_mcp_pip_and_dip_pairs() {
    let loaded = scenes::load("finger", 2);
    let (rig, welded) = (&loaded.rig, &loaded.pre.welded);
    let pairs = derive_pairs(rig, welded, &RegionOptions::default()).expect("pairs");
    let names: Vec<&str> = pairs.iter().map(|p| p.pair.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "finger/metacarpal-proximal",
            "finger/proximal-middle",
            "finger/middle-distal"
        ]
    );
    let pos = rest_positions(rig, welded, 0);
    let adj = adjacency(pos.len(), &welded[0].triangles);
    for p in &pairs {
        println!("{}", p.reason);
        check_partition(p, &adj);
        assert_eq!(p.partition.components, 1);
        // R surrounds its joint: every R vertex is within 0.1 (about one finger radius) of the
        // joint's plane (the finger lies along +Y at rest), on both sides.
        let joint = rest_joint(rig, p.pair.child_joint);
        let (lo, hi) = p
            .shared
            .iter()
            .map(|&v| pos[v as usize].y - joint.y)
            .fold((f64::MAX, f64::MIN), |(l, h), y| (l.min(y), h.max(y)));
        println!("  R height over the joint plane [{lo:.4}, {hi:.4}]");
        assert!(lo < 0.0 && hi > 0.0 && lo > -0.1 && hi < 0.1);
        // β decreases from the parent's side to the child's.
        let mean = |sel: &dyn Fn(f64) -> bool| {
            let v: Vec<f64> = p
                .shared
                .iter()
                .filter(|&&v| sel(pos[v as usize].y - joint.y))
                .map(|&v| p.beta[v as usize])
                .collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        assert!(mean(&|y| y < 0.5 * lo) > 0.5 && mean(&|y| y > 0.5 * hi) < 0.5);
    }
    // The distal joint is a leaf: its far end comes from the fingertip's rest vertices.
    let axes = BoneAxes::new(rig, &welded[0], &pairs[2]);
    println!("distal axes: {axes:?}");
    assert_ne!(axes.source, LeafAxisSource::None);
    let axis = axes.leaf_axis.expect("leaf axis");
    assert!(axis.dot(&Vector3::y()) > 0.99);
    let other = BoneAxes::new(rig, &welded[0], &pairs[1]);
    assert_eq!(
        other.source,
        LeafAxisSource::ChildJoint(node_index(rig, "distal"))
    );
}

#[test]
fn mouth_shared_region_covers_both_lip_corners() {
    let loaded = scenes::load("mouth", 2);
    let (rig, welded) = (&loaded.rig, &loaded.pre.welded);
    let pairs = derive_pairs(rig, welded, &RegionOptions::default()).expect("pairs");
    assert_eq!(pairs.len(), 1);
    let p = &pairs[0];
    assert_eq!(p.pair.name, "lips/head-jaw");
    println!("{}", p.reason);
    let pos = rest_positions(rig, welded, 0);
    let adj = adjacency(pos.len(), &welded[0].triangles);
    check_partition(p, &adj);
    // One part per corner, each with both borders.
    assert_eq!(p.partition.components, 2);
    assert_eq!(p.partition.one_sided_components, 0);
    // The lip ring: straight lips |x| ≤ 0.5 at y = ±0.2 (sections 0.15 high), corners of radius
    // 0.2 centered at (±0.5, 0), the commissure (corner tip) at (±0.7, 0). R is a band round
    // each corner, over both lips from their straight parts through the commissure, symmetric
    // about it (the rig's corners half on each bone), with β = 0.5 at the commissure.
    for side in [-1.0, 1.0] {
        let on_side: Vec<u32> = p
            .shared
            .iter()
            .copied()
            .filter(|&v| pos[v as usize].x * side > 0.0)
            .collect();
        let at = |v: &u32| &pos[*v as usize];
        assert!(on_side.iter().all(|v| at(v).x.abs() > 0.2));
        let top = on_side.iter().map(|v| at(v).y).fold(f64::MIN, f64::max);
        let bottom = on_side.iter().map(|v| -at(v).y).fold(f64::MIN, f64::max);
        println!("side {side}: R from y = {:.3} to {top:.3}", -bottom);
        assert!(top > 0.3 && (top - bottom).abs() < 0.02, "{top} {bottom}");
        for upper in [true, false] {
            assert!(on_side
                .iter()
                .any(|v| at(v).x.abs() < 0.5 && (at(v).y > 0.0) == upper));
        }
        let commissure: Vec<f64> = on_side
            .iter()
            .filter(|v| at(v).y.abs() < 0.03 && at(v).x.abs() > 0.5)
            .map(|&v| p.beta[v as usize])
            .collect();
        assert!(!commissure.is_empty());
        let mean = commissure.iter().sum::<f64>() / commissure.len() as f64;
        println!("side {side}: mean β {mean:.3} at the commissure");
        assert!((mean - 0.5).abs() < 0.05, "β {mean} at the commissure");
    }
    // The middle of each lip belongs to one region only.
    for (v, q) in pos.iter().enumerate() {
        if q.x.abs() < 0.2 {
            assert!(!(p.w1[v] && p.w2[v]));
            assert_eq!(p.w1[v], q.y > 0.0, "vertex {v} at {q}");
        }
    }
}

#[test]
fn skeleton_direction_follows_the_bend() {
    let loaded = scenes::load("bending_capsule", 2);
    let (rig, welded) = (&loaded.rig, &loaded.pre.welded);
    let pairs = derive_pairs(rig, welded, &RegionOptions::default()).expect("pairs");
    let p = &pairs[0];
    let axes = BoneAxes::new(rig, &welded[0], p);
    println!("{axes:?}");
    assert_eq!(axes.source, LeafAxisSource::PrincipalAxis);
    let anim = rig.find_animation("bend").expect("bend");
    let times = frames::sample_times(rig, Some(anim), Some(31)).expect("frames");
    assert_eq!(times.len(), 31);
    let mut previous: Option<Vector3<f64>> = None;
    let mut steps = Vec::new();
    let mut at_90 = None;
    for &t in &times {
        let pose = rig.pose_at(Some(anim), t);
        let d = skeleton_direction(&pose, &p.pair, &axes).expect("direction");
        let source = DirectionSource::Skeleton.direction(&pose, &p.pair, &axes, None);
        assert_eq!(source, Some(d));
        let at = |n: usize| pose.world[n].transform_point(&Point3::origin());
        let joint = at(p.pair.child_joint);
        let u1 = (at(p.pair.parent_joint) - joint).normalize();
        let u2 = pose.world[p.pair.child_joint]
            .transform_vector(&axes.leaf_axis.expect("leaf"))
            .normalize();
        assert!((d.norm() - 1.0).abs() < 1e-12);
        assert!(
            d.dot(&(u1 + u2)).abs() < 1e-12,
            "not orthogonal to the bisector"
        );
        // In the bones' plane.
        assert!(d.dot(&u1.cross(&u2)).abs() < 1e-12);
        let bend = u1.dot(&u2).clamp(-1.0, 1.0).acos().to_degrees();
        if (bend - 90.0).abs() < 1e-6 {
            at_90 = Some((d, u1, u2));
        }
        if let Some(prev) = previous {
            steps.push(prev.dot(&d).clamp(-1.0, 1.0).acos().to_degrees());
        }
        previous = Some(d);
    }
    let max_step = steps.iter().copied().fold(0.0, f64::max);
    let min_step = steps.iter().copied().fold(f64::MAX, f64::min);
    println!("direction steps per frame: {min_step:.4} .. {max_step:.4} deg");
    // 150° over 30 frames: the bisector, hence d, turns 2.5° a frame.
    assert!(max_step < 2.5 + 1e-6 && min_step > 2.5 - 1e-6);
    // At 90° (frame 18 of 31) d points from the parent bone's side toward the child's.
    let (d, u1, u2) = at_90.expect("a frame at 90 degrees");
    println!(
        "at 90 deg: d = {d:?}, d.u1 = {}, d.u2 = {}",
        d.dot(&u1),
        d.dot(&u2)
    );
    assert!(d.dot(&u2) > 0.0 && d.dot(&u1) < 0.0);
    // The bend is about +Z toward -X: W1's outward side at the fold is (-1, 1, 0) / √2.
    assert!((d - Vector3::new(-1.0, 1.0, 0.0).normalize()).norm() < 1e-9);
}

#[test]
fn skeleton_direction_degenerates_only_at_a_full_fold() {
    let loaded = scenes::load("bending_capsule", 2);
    let (rig, welded) = (&loaded.rig, &loaded.pre.welded);
    let pairs = derive_pairs(rig, welded, &RegionOptions::default()).expect("pairs");
    let p = &pairs[0];
    let axes = BoneAxes::new(rig, &welded[0], p);
    let pose_at = |degrees: f64| {
        let mut locals = rig.rest_locals();
        let mut trs = locals[p.pair.child_joint].trs();
        trs.rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), degrees.to_radians());
        locals[p.pair.child_joint] = LocalTransform::Trs(trs);
        rig.pose_from_locals(&locals)
    };
    assert!(skeleton_direction(&pose_at(180.0), &p.pair, &axes).is_none());
    assert!(skeleton_direction(&pose_at(179.0), &p.pair, &axes).is_some());
    // A leaf joint without axis has no direction; a fixed direction is normalized.
    let rest = rig.pose_at(None, 0.0);
    let no_axis = BoneAxes {
        leaf_axis: None,
        ..axes
    };
    assert!(skeleton_direction(&rest, &p.pair, &no_axis).is_none());
    let fixed = DirectionSource::Fixed(Vector3::new(0.0, 3.0, 0.0));
    assert_eq!(
        fixed.direction(&rest, &p.pair, &axes, None),
        Some(Vector3::y())
    );
    let zero = DirectionSource::Fixed(Vector3::zeros());
    assert_eq!(zero.direction(&rest, &p.pair, &axes, None), None);
}

#[test]
fn degenerate_inputs_give_no_pair_or_a_typed_error() {
    let loaded = scenes::load("bending_capsule", 2);
    let welded = &loaded.pre.welded;
    // No weight on the child joint: nothing deforms the mesh there, no pair.
    let mut rig = loaded.rig.clone();
    let n = rig.bodies[0].vertex_count();
    let mut weights = SkinWeights::with_capacity(n);
    for _ in 0..n {
        weights.push_row(&[(0, 1.0)]);
    }
    rig.bodies[0].weights = weights;
    let pairs = derive_pairs(&rig, welded, &RegionOptions::default()).expect("no error");
    assert!(pairs.is_empty());
    match pairs_for_joints(
        &rig,
        welded,
        &[("lower", "upper")],
        &RegionOptions::default(),
    ) {
        Err(SelfContactError::UnusablePair { .. }) => {}
        other => panic!("expected an unusable pair, got {other:?}"),
    }

    // A threshold of 1 or more selects no vertex.
    let rig = &loaded.rig;
    for threshold in [1.0, 1.5] {
        let options = RegionOptions {
            threshold,
            ..Default::default()
        };
        assert!(derive_pairs(rig, welded, &options).expect("ok").is_empty());
    }
    // Nonsense options, names and inputs are typed errors.
    for threshold in [f64::NAN, -0.1, f64::INFINITY] {
        let options = RegionOptions {
            threshold,
            ..Default::default()
        };
        assert!(matches!(
            derive_pairs(rig, welded, &options),
            Err(SelfContactError::InconsistentInput(_))
        ));
    }
    assert!(matches!(
        pairs_for_joints(rig, welded, &[("lower", "nope")], &RegionOptions::default()),
        Err(SelfContactError::UnknownJoint(_))
    ));
    assert!(matches!(
        derive_pairs(rig, &[], &RegionOptions::default()),
        Err(SelfContactError::InconsistentInput(_))
    ));
    // No growth still works on the capsule (R = the blend band itself).
    let tight = RegionOptions {
        grow_rings: 0,
        ..Default::default()
    };
    let pairs = derive_pairs(rig, welded, &tight).expect("pairs");
    assert_eq!(pairs.len(), 1);
    println!("no growth: {}", pairs[0].reason);

    // A shared region that is all of W2 (nothing of W2 outside it) has no β = 0 border.
    let pos = rest_positions(rig, welded, 0);
    let w1 = vec![true; pos.len()];
    let w2: Vec<bool> = pos.iter().map(|q| q.y > 1.0).collect();
    match partition_of_unity(&pos, &welded[0].triangles, &w1, &w2) {
        Err(e @ SelfContactError::DegenerateSharedRegion { .. }) => println!("{e}"),
        other => panic!("expected a degenerate region, got {other:?}"),
    }
    // Out-of-range triangles are an error, not a panic.
    assert!(matches!(
        partition_of_unity(&pos[..10], &welded[0].triangles, &w1[..10], &w2[..10]),
        Err(SelfContactError::InconsistentInput(_))
    ));
}

/// The committed finger with its joint nodes taken out of their hierarchy (all four side by
/// side under the root, as a hand tracker's) and named as a tracked hand's index finger: the
/// joint tree then comes from the names, and everything the self-contact pass derives and does
/// is what it derives and does on the nested finger (same regions, `β`, bone ends and, posed
/// by the same world matrices, the same output to the bit).
#[test]
fn a_flat_hand_skin_gets_the_tree_of_its_joint_names() {
    use contact_skin::selfcontact::fold::FoldParams;
    use contact_skin::selfcontact::pass::SelfContactPass;
    use contact_skin::selfcontact::{JointTree, TreeSource};
    let l = scenes::load("finger", 31);
    let nested = &l.rig;
    let mut flat = nested.clone();
    let skin = &nested.skins[0];
    let root = nested.nodes[skin.joints[0]].parent;
    let names = [
        "index-finger-metacarpal",
        "index-finger-phalanx-proximal",
        "index-finger-phalanx-intermediate",
        "index-finger-phalanx-distal",
    ];
    for (k, &j) in skin.joints.iter().enumerate() {
        assert_eq!(
            nested.nodes[j].name.as_deref(),
            Some(["metacarpal", "proximal", "middle", "distal"][k])
        );
        flat.nodes[j].name = Some(names[k].into());
        flat.nodes[j].parent = root;
        flat.nodes[j].children.retain(|c| !skin.joints.contains(c));
    }
    if let Some(r) = root {
        for &j in &skin.joints {
            if !flat.nodes[r].children.contains(&j) {
                flat.nodes[r].children.push(j);
            }
        }
    }
    let body = &flat.bodies[0];
    let tree = JointTree::of_body(&flat, body, &flat.skins[0]);
    assert_eq!(tree.source, TreeSource::HandJointNames);
    assert_eq!(tree.parent, vec![None, Some(0), Some(1), Some(2)]);
    let nested_tree = JointTree::of_body(nested, &nested.bodies[0], skin);
    assert_eq!(nested_tree.source, TreeSource::Hierarchy);
    assert_eq!(nested_tree.parent, tree.parent);

    let options = RegionOptions::default();
    let a = derive_pairs(nested, &l.pre.welded, &options).expect("nested pairs");
    let b = derive_pairs(&flat, &l.pre.welded, &options).expect("flat pairs");
    assert_eq!(a.len(), 3);
    assert_eq!(a.len(), b.len());
    for (p, q) in a.iter().zip(&b) {
        assert_eq!(
            (p.pair.parent_joint, p.pair.child_joint, p.pair.bone_end),
            (q.pair.parent_joint, q.pair.child_joint, q.pair.bone_end)
        );
        assert_eq!((&p.w1, &p.w2, &p.shared), (&q.w1, &q.w2, &q.shared));
        assert_eq!(p.beta, q.beta);
    }

    let rest = scenes::welded_positions(nested, &l.pre, 0.0, None);
    let pass = |rig: &Rig| {
        SelfContactPass::new(
            rig,
            &l.pre.welded,
            &rest,
            &options,
            FoldParams::default(),
            &[],
        )
        .expect("pass")
    };
    let (pa, pb) = (pass(nested), pass(&flat));
    let f = 24;
    let pose = nested.pose_at(Some(0), l.times[f]);
    let (mut oa, mut ob) = (l.frame(f), l.frame(f));
    let ra = pa.run(nested, &pose, &mut oa).expect("nested runs");
    let rb = pb.run(&flat, &pose, &mut ob).expect("flat runs");
    assert!(!ra.folds.is_empty(), "frame {f} folds");
    assert_eq!(ra.folds.len(), rb.folds.len());
    assert_eq!(oa, ob);

    // Flat joints with other names have no tree: no pair.
    let mut unnamed = flat.clone();
    for (k, &j) in skin.joints.iter().enumerate() {
        unnamed.nodes[j].name = Some(format!("bone{k}"));
    }
    let pairs = derive_pairs(&unnamed, &l.pre.welded, &options).expect("no pairs");
    assert!(pairs.is_empty());
}

/// A short end segment: on the bending capsule reweighted so that only the tip (3 rings around
/// the vertex farthest along the upper bone) carries the child joint, with its first two rings
/// on the child alone, the parent's region grown by the default 2 rings swallows the child's
/// whole region (`W2 \ R` empty: no `β = 0` border). The pair is derived again with fewer rings
/// and kept, with a valid partition of unity; the same regions as asking for 1 ring outright.
#[test]
fn a_short_end_segment_is_derived_with_fewer_rings() {
    let loaded = scenes::load("bending_capsule", 2);
    let welded = &loaded.pre.welded;
    let mut rig = loaded.rig.clone();
    let skin = &rig.skins[0];
    let index = |name: &str| {
        let node = node_index(&rig, name);
        skin.joints.iter().position(|&j| j == node).expect("joint") as u16
    };
    let (lower, upper) = (index("lower"), index("upper"));
    let pos = rest_positions(&rig, welded, 0);
    let adj = adjacency(pos.len(), &welded[0].triangles);
    let axis =
        rest_joint(&rig, node_index(&rig, "upper")) - rest_joint(&rig, node_index(&rig, "lower"));
    let tip = (0..pos.len())
        .max_by(|&a, &b| {
            pos[a]
                .coords
                .dot(&axis)
                .total_cmp(&pos[b].coords.dot(&axis))
        })
        .expect("vertices");
    // Rings from the tip, breadth first.
    let mut ring = vec![usize::MAX; pos.len()];
    ring[tip] = 0;
    let mut queue = std::collections::VecDeque::from([tip]);
    while let Some(v) = queue.pop_front() {
        for &u in &adj[v] {
            if ring[u as usize] == usize::MAX {
                ring[u as usize] = ring[v] + 1;
                queue.push_back(u as usize);
            }
        }
    }
    let body = &mut rig.bodies[0];
    let mut weights = SkinWeights::with_capacity(body.vertex_count());
    for f in 0..body.vertex_count() {
        match ring[welded[0].to_welded[f] as usize] {
            0..=1 => weights.push_row(&[(upper, 1.0)]),
            2..=3 => weights.push_row(&[(lower, 0.5), (upper, 0.5)]),
            _ => weights.push_row(&[(lower, 1.0)]),
        }
    }
    body.weights = weights;

    let (pairs, skipped) =
        derive_pairs_reporting(&rig, welded, &RegionOptions::default()).expect("no error");
    assert!(skipped.is_empty(), "{skipped:?}");
    assert_eq!(pairs.len(), 1);
    let p = &pairs[0];
    println!("{}", p.reason);
    assert_eq!(p.grow_rings, 1, "the largest growth that leaves W2 \\ R");
    assert!(
        p.reason.contains("fewer than the configured 2"),
        "{}",
        p.reason
    );
    check_partition(p, &adj);
    // W2 \ R is the tip itself, where β = 0.
    assert!(p.w2[tip] && !p.w1[tip]);
    assert_eq!(p.beta[tip], 0.0);

    // Grown by the configured 2 rings from its seeds (the parent's weight from ring 2 on),
    // W1 covers the whole capsule: no partition of unity.
    let seed1: Vec<bool> = ring.iter().map(|&r| r >= 2).collect();
    let seed2: Vec<bool> = ring.iter().map(|&r| r <= 3).collect();
    let (w1, w2) = (grown(&seed1, &adj, 2), grown(&seed2, &adj, 2));
    assert!(w1.iter().all(|&x| x));
    match partition_of_unity(&pos, &welded[0].triangles, &w1, &w2) {
        Err(SelfContactError::DegenerateSharedRegion { .. }) => {}
        other => panic!(
            "expected 2 rings to be degenerate, got {:?}",
            other.map(|_| ())
        ),
    }
    // Asking for 1 ring outright gives the same regions.
    let one = RegionOptions {
        grow_rings: 1,
        ..Default::default()
    };
    let direct = derive_pairs(&rig, welded, &one).expect("pairs");
    assert_eq!(direct.len(), 1);
    assert_eq!(direct[0].shared, p.shared);
    assert_eq!(direct[0].beta, p.beta);
    assert_eq!(direct[0].grow_rings, 1);
}

/// `set` grown by `rings` rings over `adj`.
fn grown(set: &[bool], adj: &[Vec<u32>], rings: usize) -> Vec<bool> {
    let mut set = set.to_vec();
    for _ in 0..rings {
        let before = set.clone();
        for (v, n) in adj.iter().enumerate() {
            if n.iter().any(|&u| before[u as usize]) {
                set[v] = true;
            }
        }
    }
    set
}
