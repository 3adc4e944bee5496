//! Self-contact on skinned rigs (2021 Sec. 6): the bending capsule, the finger and the mouth.

#[path = "common/scenes.rs"]
mod scenes;

use contact_skin::mesh::operators::{vertex_normals, NormalWeighting};
use contact_skin::report::metrics;
use contact_skin::selfcontact::fold::FoldParams;
use contact_skin::selfcontact::pass::SelfContactPass;
use contact_skin::selfcontact::RegionOptions;
use nalgebra::Point3;
use scenes::{load, welded_positions, Loaded};

fn self_pass(l: &Loaded) -> SelfContactPass {
    let rest = welded_positions(&l.rig, &l.pre, 0.0, None);
    SelfContactPass::new(
        &l.rig,
        &l.pre.welded,
        &rest,
        &RegionOptions::default(),
        FoldParams::default(),
        &[],
    )
    .expect("self-contact pass precomputes")
}

fn penetration(l: &Loaded, b: usize, p: &[Point3<f64>]) -> metrics::Penetration {
    let n = vertex_normals(p, &l.triangles[b], NormalWeighting::Area);
    metrics::residual_penetration(p, &l.triangles[b], &n, l.h_rest)
}

/// Per frame of the first animation: penetrating vertices before and after, volume error,
/// inverted faces, NaN count; and the second-difference ratio over the animation.
struct Run {
    rows: Vec<(usize, usize, usize, f64, usize, usize, usize)>,
    ratio: f64,
    pairs: Vec<(usize, String)>,
}

fn run(name: &str, frames: usize) -> Run {
    let l = load(name, frames);
    let pass = self_pass(&l);
    let (mut rows, mut ins, mut outs) = (Vec::new(), Vec::new(), Vec::new());
    for f in 0..frames {
        let input = l.frame(f);
        let mut out = input.clone();
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let res = pass
            .run(&l.rig, &pose, &mut out)
            .expect("self-contact pass runs");
        if res.folds.is_empty() {
            assert_eq!(
                out, input,
                "{name} frame {f}: no fold must leave the input unchanged"
            );
        }
        for b in 0..input.len() {
            let (pi, po) = (penetration(&l, b, &input[b]), penetration(&l, b, &out[b]));
            let v0 = contact_skin::mesh::signed_volume(&input[b], &l.triangles[b]);
            let v1 = contact_skin::mesh::signed_volume(&out[b], &l.triangles[b]);
            let inv = metrics::inverted_faces(&l.triangles[b], &input[b], &out[b]);
            rows.push((
                f,
                pi.vertices,
                po.vertices,
                ((v1 - v0) / v0).abs(),
                inv.inverted,
                metrics::non_finite(&out[b]),
                res.folds.len(),
            ));
        }
        ins.push(input.concat());
        outs.push(out.concat());
    }
    let sd = metrics::second_difference_ratio(&outs, &ins);
    for r in rows.iter().filter(|r| r.6 > 0) {
        println!(
            "{name} frame {}: folds {} penetrating {} -> {}, volume error {:.1e}, inverted {}",
            r.0, r.6, r.1, r.2, r.3, r.4
        );
    }
    println!("{name}: second-difference ratio {:.2}", sd.ratio);
    Run {
        rows,
        ratio: sd.ratio,
        pairs: pass.pairs(),
    }
}

/// The bending capsule's `bend` (0 to 150°): the fold is resolved with the volume kept.
/// Not yet at the targets (see the issue note): faces next to the crease still flip
/// (up to 72 at 150°).
#[test]
fn bending_capsule_fold() {
    let r = run("bending_capsule", 31);
    assert_eq!(r.pairs.len(), 1);
    assert!(
        r.rows.iter().any(|x| x.6 > 0),
        "the bend folds into contact"
    );
    for &(f, before, after, vol, _, nan, folds) in &r.rows {
        assert_eq!(nan, 0, "frame {f}: NaN");
        if folds > 0 {
            assert!(vol < 1e-4, "frame {f}: volume error {vol}");
            assert!(after <= 2, "frame {f}: penetration {before} -> {after}");
        }
        if f <= 15 {
            assert_eq!(after, 0, "frame {f}: penetration left up to 75°");
        }
    }
    assert!(r.ratio < 3.0, "temporal ratio {}", r.ratio);
}

/// The finger's three joints flexing past contact.
#[test]
fn finger_folds() {
    let r = run("finger", 31);
    assert_eq!(r.pairs.len(), 3);
    for &(f, before, after, vol, _, nan, folds) in &r.rows {
        assert_eq!(nan, 0, "frame {f}: NaN");
        if folds > 0 {
            assert!(vol < 1e-4, "frame {f}: volume error {vol}");
            assert!(after <= 10, "frame {f}: penetration {before} -> {after}");
        }
    }
    assert!(r.ratio < 3.0, "temporal ratio {}", r.ratio);
}

/// PIPELINE.md's check of the crease cut: it follows the fold, i.e. every vertex of a cut edge
/// of the shared region lies within one ring of the silhouette of `R` seen from `d̂`
/// (vertices where `n·d̂` changes sign along an edge). Measured on the bending capsule.
#[test]
fn crease_cut_follows_the_silhouette() {
    use contact_skin::selfcontact::fold::{resolve_fold, FoldPre};
    use contact_skin::selfcontact::{derive_pairs, skeleton_direction, BoneAxes};
    let l = load("bending_capsule", 31);
    let rest = welded_positions(&l.rig, &l.pre, 0.0, None);
    let pairs = derive_pairs(&l.rig, &l.pre.welded, &RegionOptions::default()).expect("pairs");
    let regions = pairs.into_iter().next().expect("one pair");
    let axes = BoneAxes::new(&l.rig, &l.pre.welded[0], &regions);
    let pair = regions.pair.clone();
    let (w1, w2) = (regions.w1.clone(), regions.w2.clone());
    let pre = FoldPre::new(&rest[0], &l.triangles[0], regions).expect("fold");
    let mut worst = 0;
    let mut cut_frames = 0;
    for f in [12, 18, 24, 30] {
        let input = l.frame(f);
        let pose = l.rig.pose_at(Some(0), l.times[f]);
        let d = skeleton_direction(&l.rig, &pose, &pair, axes.leaf_axis).expect("direction");
        let n = vertex_normals(&input[0], &l.triangles[0], NormalWeighting::Area);
        let Some(out) = resolve_fold(
            &pre,
            &input[0],
            &n,
            &l.triangles[0],
            d,
            &FoldParams::default(),
        )
        .expect("fold runs") else {
            continue;
        };
        cut_frames += 1;
        let shared: Vec<bool> = w1.iter().zip(&w2).map(|(a, b)| *a && *b).collect();
        let dist =
            crease_distance_to_silhouette(&l.triangles[0], &n, &out.crease.on_w1, &shared, &d);
        println!("frame {f}: crease vertices within {dist} rings of the silhouette");
        worst = worst.max(dist);
    }
    assert!(cut_frames >= 3);
    assert!(
        worst <= 1,
        "the crease cut strays {worst} rings from the silhouette"
    );
}

/// Largest topological distance (in rings) from a vertex of a cut edge of the shared region to
/// the silhouette of the shared region seen from `d̂`.
fn crease_distance_to_silhouette(
    triangles: &[[u32; 3]],
    normals: &[nalgebra::Vector3<f64>],
    on_w1: &[bool],
    shared: &[bool],
    d: &nalgebra::Vector3<f64>,
) -> usize {
    let n = normals.len();
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            adj[a].push(b);
            adj[b].push(a);
        }
    }
    let g: Vec<f64> = normals.iter().map(|x| x.dot(d)).collect();
    let mut dist = vec![usize::MAX; n];
    let mut queue = std::collections::VecDeque::new();
    for v in 0..n {
        if shared[v] && adj[v].iter().any(|&w| shared[w] && g[v] * g[w] <= 0.0) {
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
    (0..n)
        .filter(|&v| shared[v] && adj[v].iter().any(|&w| shared[w] && on_w1[w] != on_w1[v]))
        .map(|v| dist[v])
        .max()
        .unwrap_or(0)
}

/// Bad input to the self-contact pass: typed errors, never a panic.
#[test]
fn bad_input_gives_typed_errors() {
    use contact_skin::selfcontact::pass::SelfPassError;
    let l = load("bending_capsule", 31);
    let pass = self_pass(&l);
    let pose = l.rig.pose_at(Some(0), l.times[30]);
    let mut nan = l.frame(30);
    nan[0][7].y = f64::NAN;
    assert!(matches!(
        pass.run(&l.rig, &pose, &mut nan),
        Err(SelfPassError::Fold { .. })
    ));
    let mut none: Vec<Vec<Point3<f64>>> = Vec::new();
    assert!(matches!(
        pass.run(&l.rig, &pose, &mut none),
        Err(SelfPassError::Mismatch(_))
    ));
    let mut short = l.frame(30);
    short[0].truncate(10);
    assert!(pass.run(&l.rig, &pose, &mut short).is_err());
}
