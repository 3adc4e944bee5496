//! The tree of a skin's joints that the articulations follow (2021 Sec. 6: "two bones
//! connected at a joint"): which weighted joint is the parent of which, what lies below a
//! joint (its side of the articulation, `W2`) and where its bone ends (for the skeleton
//! direction).
//!
//! Normally the glTF node hierarchy: a joint's parent is its nearest ancestor node that is a
//! joint of the same skin and carries weight on the body (helper joints without weight are
//! skipped). Hand-tracking models do not nest their joint nodes: the WebXR hands put all 25
//! joints side by side under one armature node, each posed in world space by the tracker, so
//! the hierarchy has no parent/child pair at all. When no weighted joint of a skin has a
//! weighted joint above it and the joints are named as a tracked hand's (WebXR Hand Input;
//! OpenXR's `XR_HAND_JOINT_…_EXT` names), the tree is the hand's: in each finger the
//! metacarpal, proximal, intermediate and distal phalanges and the tip hang from one another,
//! the metacarpals (and a palm joint) from the wrist ([`TreeSource::HandJointNames`]; not in
//! the paper or `PIPELINE.md`). The skin weights alone do not give that tree: the WebXR
//! hand's palm blends the metacarpals sideways (the index metacarpal shares a summed weight of
//! 1.5 with the wrist, 14.9 with the middle metacarpal and 18.8 with the thumb's), so a maximum
//! spanning tree of the shared weights links the metacarpals in a row, and a shortest-path tree
//! over the joints' positions hangs fingers from their neighbours' metacarpals. Other flat skins
//! keep the (empty) hierarchy: `info` says no pair was derived.

use crate::rig::{Body, Rig, Skin};

/// Where a [`JointTree`] comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TreeSource {
    /// The node hierarchy of the file.
    Hierarchy,
    /// The joints' nodes are not nested, and their names are those of a tracked hand
    /// (WebXR Hand Input: `wrist`, `index-finger-phalanx-proximal`, …).
    HandJointNames,
}

/// The weighted joints of one body's skin as a forest (indices into [`Skin::joints`]).
#[derive(Clone, Debug, PartialEq)]
pub struct JointTree {
    /// Per skin joint: some vertex of the body has a positive weight on it.
    pub carries: Vec<bool>,
    /// Per skin joint: its parent joint (`None` for a root or a joint without weight).
    pub parent: Vec<Option<usize>>,
    /// Per skin joint with [`TreeSource::HandJointNames`]: its children, from the palm out.
    children: Vec<Vec<usize>>,
    /// Where the tree comes from.
    pub source: TreeSource,
}

impl JointTree {
    /// The tree of `body`'s skin `skin` (see the module doc).
    pub fn of_body(rig: &Rig, body: &Body, skin: &Skin) -> Self {
        let carries = carried_joints(body, skin.joints.len());
        let parent: Vec<Option<usize>> = (0..skin.joints.len())
            .map(|j| {
                if carries[j] {
                    weighted_ancestor(rig, skin, &carries, skin.joints[j])
                } else {
                    None
                }
            })
            .collect();
        let flat = parent.iter().all(Option::is_none) && carries.iter().filter(|&&c| c).count() > 1;
        if flat {
            if let Some(tree) = hand_tree(rig, skin, &carries) {
                return tree;
            }
        }
        Self {
            children: vec![Vec::new(); skin.joints.len()],
            carries,
            parent,
            source: TreeSource::Hierarchy,
        }
    }

    /// Per skin joint: `joint` itself or below it.
    pub fn below(&self, rig: &Rig, skin: &Skin, joint: usize) -> Vec<bool> {
        match self.source {
            TreeSource::Hierarchy => skin
                .joints
                .iter()
                .map(|&node| descends_from(rig, node, skin.joints[joint]))
                .collect(),
            TreeSource::HandJointNames => {
                let mut below = vec![false; skin.joints.len()];
                let mut stack = vec![joint];
                while let Some(j) = stack.pop() {
                    if !std::mem::replace(&mut below[j], true) {
                        stack.extend(&self.children[j]);
                    }
                }
                below
            }
        }
    }

    /// The node at the far end of `joint`'s bone: with the hierarchy, its first child node
    /// that is a joint of the skin; in a tracked hand, the next segment of its finger.
    /// `None` for a leaf (the skeleton direction then takes the principal axis of its
    /// vertices, [`super::BoneAxes`]).
    pub fn bone_end(&self, rig: &Rig, skin: &Skin, joint: usize) -> Option<usize> {
        match self.source {
            TreeSource::Hierarchy => rig
                .nodes
                .get(*skin.joints.get(joint)?)?
                .children
                .iter()
                .copied()
                .find(|c| skin.joints.contains(c)),
            TreeSource::HandJointNames => {
                self.children.get(joint)?.first().map(|&c| skin.joints[c])
            }
        }
    }
}

/// Per skin joint: some vertex of the body has a positive weight on it.
fn carried_joints(body: &Body, joint_count: usize) -> Vec<bool> {
    let mut carries = vec![false; joint_count];
    for (&j, &w) in body.weights.joints.iter().zip(&body.weights.weights) {
        if w > 0.0 {
            if let Some(slot) = carries.get_mut(j as usize) {
                *slot = true;
            }
        }
    }
    carries
}

/// Skin index of the nearest ancestor of `node` that is a weighted joint of `skin`.
fn weighted_ancestor(rig: &Rig, skin: &Skin, carries: &[bool], node: usize) -> Option<usize> {
    let mut current = rig.nodes.get(node)?.parent;
    // The hierarchy is acyclic after loading; the step bound only guards against a bad input.
    for _ in 0..rig.nodes.len() {
        let n = current?;
        if let Some(j) = skin.joints.iter().position(|&x| x == n) {
            if carries.get(j).copied().unwrap_or(false) {
                return Some(j);
            }
        }
        current = rig.nodes.get(n)?.parent;
    }
    None
}

/// Whether `node` is `ancestor` or one of its descendants.
fn descends_from(rig: &Rig, node: usize, ancestor: usize) -> bool {
    let mut current = Some(node);
    for _ in 0..=rig.nodes.len() {
        match current {
            Some(n) if n == ancestor => return true,
            Some(n) => current = rig.nodes.get(n).and_then(|x| x.parent),
            None => return false,
        }
    }
    false
}

/// The segments of a hand-tracking finger chain, from the palm out (WebXR Hand Input names;
/// OpenXR's have no `phalanx-` part).
const SEGMENTS: [&[&str]; 5] = [
    &["metacarpal"],
    &["phalanx-proximal", "proximal"],
    &["phalanx-intermediate", "intermediate"],
    &["phalanx-distal", "distal"],
    &["tip"],
];

/// A joint name split as `(chain, segment)`: lower case, `_` read as `-`,
/// `index-finger-phalanx-distal` → `("index-finger-", 3)`; `None` for other names.
fn hand_segment(name: &str) -> Option<(String, usize)> {
    let name = normalized(name);
    SEGMENTS.iter().enumerate().find_map(|(k, forms)| {
        forms.iter().find_map(|form| {
            let chain = name.strip_suffix(form)?;
            (chain.is_empty() || chain.ends_with('-')).then(|| (chain.to_owned(), k))
        })
    })
}

/// Lower case, `_` read as `-`, without OpenXR's `-ext` suffix.
fn normalized(name: &str) -> String {
    let name = name.to_ascii_lowercase().replace('_', "-");
    match name.strip_suffix("-ext") {
        Some(stem) => stem.to_owned(),
        None => name,
    }
}

/// Whether `name` is a hand's joint named `root` (`wrist`, `Left_Wrist`,
/// `XR_HAND_JOINT_WRIST_EXT`…).
fn is_named(name: &str, root: &str) -> bool {
    let name = normalized(name);
    name == root || name.ends_with(&format!("-{root}"))
}

/// The tree of a skin whose joints are named as a tracked hand's: in every chain (the name
/// without its segment) each segment hangs from the previous one present in the skin, the
/// first from the wrist, a palm joint from the wrist; other joints (a forearm) stay roots.
/// `None` when that gives no weighted joint a weighted parent. Joints without weight (the
/// tips) have no parent but stay their bone's far end.
fn hand_tree(rig: &Rig, skin: &Skin, carries: &[bool]) -> Option<JointTree> {
    let names: Vec<String> = skin
        .joints
        .iter()
        .map(|&node| {
            rig.nodes
                .get(node)
                .and_then(|x| x.name.clone())
                .unwrap_or_default()
        })
        .collect();
    let links = hand_links(&names, carries)?;
    Some(JointTree {
        carries: carries.to_vec(),
        parent: links.parent,
        children: links.children,
        source: TreeSource::HandJointNames,
    })
}

/// Parents (weighted joints only) and children (every joint, for the bone ends) of a tree.
struct Links {
    parent: Vec<Option<usize>>,
    children: Vec<Vec<usize>>,
}

/// [`hand_tree`] on the joints' `names` and whether each `carries` weight.
fn hand_links(names: &[String], carries: &[bool]) -> Option<Links> {
    let n = names.len();
    let wrist = (0..n).find(|&j| is_named(&names[j], "wrist"));
    let palm = (0..n).find(|&j| is_named(&names[j], "palm"));
    let segments: Vec<Option<(String, usize)>> = names.iter().map(|x| hand_segment(x)).collect();
    let mut parent = vec![None; n];
    let mut children = vec![Vec::new(); n];
    if let (Some(p), Some(w)) = (palm, wrist) {
        parent[p] = Some(w);
        children[w].push(p);
    }
    for c in 0..n {
        let Some((chain, k)) = &segments[c] else {
            continue;
        };
        let previous = (0..n)
            .filter_map(|j| match &segments[j] {
                Some((other, m)) if other == chain && m < k => Some((*m, j)),
                _ => None,
            })
            .max();
        parent[c] = previous.map(|(_, j)| j).or(wrist.filter(|&w| w != c));
        if let Some(p) = parent[c] {
            children[p].push(c);
        }
    }
    for list in &mut children {
        list.sort_by_key(|&c| segments[c].as_ref().map(|(_, k)| *k));
    }
    // As in the hierarchy, a joint without weight is skipped: the parent is the nearest
    // weighted joint up the chain (at most the wrist, the palm and five segments).
    let weighted: Vec<Option<usize>> = (0..n)
        .map(|c| {
            let mut p = parent[c];
            for _ in 0..n {
                match p {
                    Some(j) if !carries.get(j).copied().unwrap_or(false) => p = parent[j],
                    _ => break,
                }
            }
            p.filter(|_| carries.get(c).copied().unwrap_or(false))
        })
        .collect();
    weighted.iter().any(Option::is_some).then_some(Links {
        parent: weighted,
        children,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_joint_names_split_into_chain_and_segment() {
        assert_eq!(
            hand_segment("index-finger-phalanx-distal"),
            Some(("index-finger-".into(), 3))
        );
        assert_eq!(hand_segment("thumb-metacarpal"), Some(("thumb-".into(), 0)));
        assert_eq!(
            hand_segment("pinky-finger-tip"),
            Some(("pinky-finger-".into(), 4))
        );
        assert_eq!(
            hand_segment("XR_HAND_JOINT_RING_INTERMEDIATE_EXT"),
            Some(("xr-hand-joint-ring-".into(), 2))
        );
        assert_eq!(
            hand_segment("l_ring_intermediate"),
            Some(("l-ring-".into(), 2))
        );
        assert_eq!(hand_segment("tiptoe"), None);
        assert_eq!(hand_segment("distal"), Some((String::new(), 3)));
        assert!(is_named("wrist", "wrist") && is_named("Left_Wrist", "wrist"));
        assert!(is_named("XR_HAND_JOINT_WRIST_EXT", "wrist"));
        assert!(!is_named("wristband", "wrist") && !is_named("forearm", "wrist"));
    }

    fn names(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn a_hand_chains_its_fingers_from_the_wrist() {
        let n = names(&[
            "forearm",
            "wrist",
            "thumb-metacarpal",
            "thumb-phalanx-proximal",
            "thumb-phalanx-distal",
            "thumb-tip",
            "index-finger-phalanx-proximal",
            "index-finger-metacarpal",
        ]);
        // The tip carries no weight; an unknown weighted joint (a forearm) stays a root.
        let carries = [true, true, true, true, true, false, true, true];
        let links = hand_links(&n, &carries).expect("a hand");
        assert_eq!(
            links.parent,
            vec![
                None,
                None,
                Some(1),
                Some(2),
                Some(3),
                None,
                Some(7),
                Some(1)
            ]
        );
        assert_eq!(links.children[4], vec![5], "the tip ends the distal bone");
        assert_eq!(links.children[1], vec![2, 7], "metacarpals, in joint order");
    }

    #[test]
    fn an_unweighted_wrist_is_skipped_like_a_helper_joint() {
        let n = names(&["wrist", "ring-metacarpal", "ring-proximal", "ring-distal"]);
        let links = hand_links(&n, &[false, true, true, true]).expect("a hand");
        assert_eq!(links.parent, vec![None, None, Some(1), Some(2)]);
        let links = hand_links(&n, &[true, true, false, true]).expect("a hand");
        assert_eq!(links.parent, vec![None, Some(0), None, Some(1)]);
    }

    #[test]
    fn other_names_give_no_hand() {
        let carries = [true, true, true];
        assert!(hand_links(&names(&["hip", "knee", "ankle"]), &carries).is_none());
        // Segments of different chains without a wrist: nothing hangs from anything.
        let lone = names(&["a-metacarpal", "b-proximal", "c-distal"]);
        assert!(hand_links(&lone, &carries).is_none());
    }
}
