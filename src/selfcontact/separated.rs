//! Separated working regions of one mesh: two sets of joints whose regions share no vertex,
//! resolved by Secs. 4-5 alone with Eq. 2's direction (the paper's Fig. 14: fingertips
//! pressing the palm of their own hand). A rig config names them ([`separated_regions`]), or
//! they are derived from the skeleton ([`separated_from_skeleton`]): the contacts that no
//! parent/child pair ([`super::derive_pairs`]) holds, between sibling joints (two fingers, a
//! thumb and a finger) and between a joint and its grandchildren (a fingertip curled into its
//! palm).

use super::joint_tree::JointTree;
use super::partition::{vertex_adjacency, PartitionStats};
use super::regions::{
    as_faces, check_body, check_options, check_welded, count, node_name, skin_of, JointPair,
    PairRegions, RegionOptions,
};
use super::SelfContactError;
use crate::mesh::WeldedMesh;
use crate::rig::{Body, Rig};

/// Two separated working regions of one skinned mesh, named by their joints (2021 Sec. 4-5 on
/// parts of one mesh, as the fingertips pressing the palm of their own hand in the paper's
/// Fig. 14; `PIPELINE.md`, "Working regions": a rig config "may name regions by joint names").
/// Side `k`'s region: the welded vertices whose summed weight on `sides[k]`'s joints (node
/// names, `node<i>` for a node without one, as `contact-skin info` lists them) exceeds the
/// threshold and the other side's, grown by the configured rings together and taken as faces
/// (`grow_apart`). The two never share a vertex: `R` is empty and the pair is processed by
/// Sec. 4-5 alone (no crease cut, no partition of unity, the mapping direction from the
/// normals, Eq. 2). One entry per body whose skin holds every joint and on which both regions
/// have faces; none is an error, as are an unknown joint, an empty side and a joint on both.
pub fn separated_regions<S: AsRef<str>>(
    rig: &Rig,
    welded: &[WeldedMesh],
    sides: [&[S]; 2],
    options: &RegionOptions,
) -> Result<Vec<PairRegions>, SelfContactError> {
    check_options(options)?;
    check_welded(rig, welded)?;
    let names = sides.map(|s| s.iter().map(|n| n.as_ref().to_owned()).collect::<Vec<_>>());
    let unusable = |reason: String| SelfContactError::UnusablePair {
        parent: names[0].join("+"),
        child: names[1].join("+"),
        reason,
    };
    let find = |side: &Vec<String>| -> Result<Vec<usize>, SelfContactError> {
        side.iter()
            .map(|name| {
                (0..rig.nodes.len())
                    .find(|&i| node_name(rig, i) == *name)
                    .ok_or_else(|| SelfContactError::UnknownJoint(name.clone()))
            })
            .collect()
    };
    let nodes = [find(&names[0])?, find(&names[1])?];
    if nodes.iter().any(Vec::is_empty) {
        return Err(unusable("a side names no joint".into()));
    }
    if nodes[0].iter().any(|j| nodes[1].contains(j)) {
        return Err(unusable("a joint is on both sides".into()));
    }
    let mut out = Vec::new();
    for (b, mesh) in welded.iter().enumerate() {
        out.extend(separated_on_body(rig, b, mesh, &nodes, options, None)?);
    }
    if out.is_empty() {
        return Err(unusable(
            "no body's skin holds every joint with faces on both sides".into(),
        ));
    }
    Ok(out)
}

/// Separated working regions derived from the skeleton of every skinned body, for the
/// contacts no parent/child pair holds (not in the paper, whose Fig. 14 names its regions):
/// for every weighted joint `p` of the body's [`JointTree`],
/// - each two of its children's subtrees (sibling fingers, a thumb against a finger, two
///   legs), named `body/a* vs b*` (`*`: the joint and every weighted joint below it);
/// - `p` against each of its grandchildren's subtrees (a fingertip curled into its palm, a
///   distal phalanx into its metacarpal), named `body/p vs g*`,
///
/// each built as [`separated_regions`] builds a configured pair; a pair whose regions have no
/// face on one side is left out. On by default in a configuration (`[self_contact]
/// separated_from_skeleton = false` turns it off):
/// measured in the README ("Separated regions from the skeleton").
pub fn separated_from_skeleton(
    rig: &Rig,
    welded: &[WeldedMesh],
    options: &RegionOptions,
) -> Result<Vec<PairRegions>, SelfContactError> {
    check_options(options)?;
    check_welded(rig, welded)?;
    let mut out = Vec::new();
    for (b, (body, mesh)) in rig.bodies.iter().zip(welded).enumerate() {
        let skin = skin_of(rig, body)?;
        check_body(body, mesh, skin)?;
        let tree = JointTree::of_body(rig, body, skin);
        for (sides, why) in skeleton_sides(rig, &tree, skin) {
            let [(l1, s1), (l2, s2)] = sides;
            let found = separated_on_body(rig, b, mesh, &[s1, s2], options, Some([l1, l2]))?;
            if let Some(mut r) = found {
                r.reason.push_str(&format!("; from the skeleton: {why}"));
                out.push(r);
            }
        }
    }
    Ok(out)
}

/// `more` added to `pairs`, except those whose two regions a pair of the same body already
/// has (in either order): a configured pair that the skeleton also derives is resolved once,
/// under its configured name.
pub fn extend_distinct(pairs: &mut Vec<PairRegions>, more: Vec<PairRegions>) {
    for r in more {
        let same = |p: &PairRegions| {
            p.pair.body == r.pair.body
                && ((p.w1_faces == r.w1_faces && p.w2_faces == r.w2_faces)
                    || (p.w1_faces == r.w2_faces && p.w2_faces == r.w1_faces))
        };
        if !pairs.iter().any(same) {
            pairs.push(r);
        }
    }
}

/// One pair [`separated_from_skeleton`] derives: each side's label and joint nodes, and why.
type SkeletonSides = ([(String, Vec<usize>); 2], String);

/// The pairs [`separated_from_skeleton`] derives on one body's tree, siblings first.
fn skeleton_sides(rig: &Rig, tree: &JointTree, skin: &crate::rig::Skin) -> Vec<SkeletonSides> {
    let n = skin.joints.len();
    let children: Vec<Vec<usize>> = (0..n)
        .map(|p| (0..n).filter(|&c| tree.parent[c] == Some(p)).collect())
        .collect();
    let name = |j: usize| node_name(rig, skin.joints[j]);
    let subtree = |j: usize| -> (String, Vec<usize>) {
        // The subtree's root first: the pair's joint as `info` shows it.
        let below = tree.below(rig, skin, j);
        let nodes = std::iter::once(j)
            .chain((0..n).filter(|&k| k != j && below[k] && tree.carries[k]))
            .map(|k| skin.joints[k])
            .collect();
        (format!("{}*", name(j)), nodes)
    };
    let mut sides = Vec::new();
    for (p, kids) in children.iter().enumerate() {
        for (i, &a) in kids.iter().enumerate() {
            for &b in &kids[i + 1..] {
                let why = format!("two children of '{}' and the joints below them", name(p));
                sides.push(([subtree(a), subtree(b)], why));
            }
        }
    }
    for (p, kids) in children.iter().enumerate() {
        for &c in kids {
            for &g in &children[c] {
                let why = format!(
                    "'{}' against its grandchild (through '{}') and the joints below it",
                    name(p),
                    name(c)
                );
                sides.push(([(name(p), vec![skin.joints[p]]), subtree(g)], why));
            }
        }
    }
    sides
}

/// [`separated_regions`] of the joint nodes `nodes` on body `b`, `None` when its skin lacks
/// one of them or a side has no face.
fn separated_on_body(
    rig: &Rig,
    b: usize,
    mesh: &WeldedMesh,
    nodes: &[Vec<usize>; 2],
    options: &RegionOptions,
    labels: Option<[String; 2]>,
) -> Result<Option<PairRegions>, SelfContactError> {
    let body = &rig.bodies[b];
    let skin = skin_of(rig, body)?;
    let index = |side: &Vec<usize>| -> Option<Vec<usize>> {
        side.iter()
            .map(|&node| skin.joints.iter().position(|&j| j == node))
            .collect()
    };
    let (Some(j1), Some(j2)) = (index(&nodes[0]), index(&nodes[1])) else {
        return Ok(None);
    };
    check_body(body, mesh, skin)?;
    let adjacency = vertex_adjacency(mesh.vertex_count(), &mesh.triangles)?;
    let seeds = side_seeds(body, mesh, [&j1, &j2], options.threshold);
    let grown = grow_apart(seeds, &adjacency, options.grow_rings);
    let [(w1_faces, w1), (w2_faces, w2)] = grown.map(|g| as_faces(&mesh.triangles, &g));
    if w1_faces.is_empty() || w2_faces.is_empty() {
        return Ok(None);
    }
    let label = |side: &Vec<usize>| {
        let side: Vec<String> = side.iter().map(|&n| node_name(rig, n)).collect();
        side.join("+")
    };
    let [l1, l2] = labels.unwrap_or_else(|| [label(&nodes[0]), label(&nodes[1])]);
    let name = format!("{}/{l1} vs {l2}", body.name);
    let reason = format!(
        "{name}: separated regions (no shared region; Sec. 4-5 with the direction of Eq. 2): \
         W1 = weight on {l1} > {t}, W2 = weight on {l2} > {t}, each grown {rings} rings: W1 \
         {} vertices / {} faces, W2 {} vertices / {} faces",
        count(&w1),
        w1_faces.len(),
        count(&w2),
        w2_faces.len(),
        t = options.threshold,
        rings = options.grow_rings,
    );
    Ok(Some(PairRegions {
        pair: JointPair {
            body: b,
            parent_joint: nodes[0][0],
            child_joint: nodes[1][0],
            bone_end: None,
            name,
        },
        w1_faces,
        w2_faces,
        beta: w1.iter().map(|&a| if a { 1.0 } else { 0.0 }).collect(),
        w1,
        w2,
        shared: Vec::new(),
        shared_faces: Vec::new(),
        partition: PartitionStats::default(),
        grow_rings: options.grow_rings,
        reason,
    }))
}

/// Per side, the welded vertices whose summed weight on the side's skin joints exceeds
/// `threshold` and is the larger of the two sides' (ties go to the first side): skins blend
/// neighbouring joints (Fox's neck and upper arms share a vertex), and a vertex belongs to one
/// side only.
fn side_seeds(
    body: &Body,
    mesh: &WeldedMesh,
    sides: [&[usize]; 2],
    threshold: f64,
) -> [Vec<bool>; 2] {
    let mut seeds = [
        vec![false; mesh.vertex_count()],
        vec![false; mesh.vertex_count()],
    ];
    for (v, &rep) in mesh.representative.iter().enumerate() {
        let on = sides.map(|joints| {
            body.weights
                .row(rep as usize)
                .filter(|(j, _)| joints.contains(j))
                .map(|(_, w)| w)
                .sum::<f64>()
        });
        seeds[0][v] = on[0] > threshold && on[0] >= on[1];
        seeds[1][v] = on[1] > threshold && on[1] > on[0];
    }
    seeds
}

/// Both `seeds` grown ring by ring together, `rings` times: a vertex goes to the side whose
/// ring reaches it first, to neither when both reach it in the same ring, so that the two
/// sets stay disjoint where they grow into each other.
fn grow_apart(seeds: [Vec<bool>; 2], adjacency: &[Vec<u32>], rings: usize) -> [Vec<bool>; 2] {
    let mut sets = seeds;
    let mut fronts = sets.each_ref().map(|set| {
        (0..set.len())
            .filter(|&v| set[v])
            .map(|v| v as u32)
            .collect::<Vec<u32>>()
    });
    for _ in 0..rings {
        let reached = fronts.each_ref().map(|front| {
            let mut next: Vec<u32> = front
                .iter()
                .flat_map(|&v| adjacency[v as usize].iter().copied())
                .filter(|&u| !sets[0][u as usize] && !sets[1][u as usize])
                .collect();
            next.sort_unstable();
            next.dedup();
            next
        });
        let contested = |u: &u32, other: &[u32]| other.binary_search(u).is_ok();
        fronts = [0, 1].map(|k| {
            reached[k]
                .iter()
                .copied()
                .filter(|u| !contested(u, &reached[1 - k]))
                .collect()
        });
        for (set, front) in sets.iter_mut().zip(&fronts) {
            for &u in front {
                set[u as usize] = true;
            }
        }
        if fronts.iter().all(Vec::is_empty) {
            break;
        }
    }
    sets
}
