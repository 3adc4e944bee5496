//! Working regions of an articulation, derived from skin weights (Brunel et al. 2021, Sec. 6;
//! `PIPELINE.md`, "Working regions").
//!
//! For a body and a parent/child pair of joints of its skin that both deform it:
//! - `W1`: welded vertices whose weight on the parent joint exceeds the threshold;
//! - `W2`: welded vertices whose summed weight on the child joint and all its descendants
//!   exceeds the threshold;
//!
//! each grown by a few rings over the welded mesh, then taken as faces (the faces with all
//! three corners in the grown set; the region's vertices are the corners of its faces). The
//! shared region `R` is the set of vertices in both, and carries the partition of unity `β`
//! ([`super::partition`]). Pairs whose `R` is empty are skipped.
//!
//! [`super::separated`] gives the regions of two sets of joints that share no vertex, for the
//! contacts no parent/child pair holds (sibling joints).
//!
//! The welded weights of a vertex are the row of its representative file vertex
//! ([`WeldedMesh::representative`]); the rest positions are the bind positions of the body.

use super::joint_tree::{JointTree, TreeSource};
use super::layers::Components;
use super::partition::{faces_within, partition_with_adjacency, vertex_adjacency, PartitionStats};
use super::SelfContactError;
use crate::mesh::WeldedMesh;
use crate::rig::{Body, Rig, Skin};
use nalgebra::Point3;

/// Default weight threshold of a working region (`PIPELINE.md`, "Working regions").
pub const DEFAULT_THRESHOLD: f64 = 0.05;

/// Default number of rings a working region is grown by.
pub const DEFAULT_GROW_RINGS: usize = 2;

/// How working regions are derived from skin weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegionOptions {
    /// A vertex belongs to a region when its weight on the region's joints exceeds this
    /// (strictly). Must be finite and `≥ 0`; `≥ 1` selects nothing.
    pub threshold: f64,
    /// Rings of neighbors added to each region after thresholding.
    pub grow_rings: usize,
}

impl Default for RegionOptions {
    fn default() -> Self {
        Self {
            threshold: DEFAULT_THRESHOLD,
            grow_rings: DEFAULT_GROW_RINGS,
        }
    }
}

/// A parent/child pair of joints of one body's skin (2021 Sec. 6: the two sides of an
/// articulation).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct JointPair {
    /// Index of the body in [`Rig::bodies`].
    pub body: usize,
    /// Node index of the parent joint (`W1`'s joint).
    pub parent_joint: usize,
    /// Node index of the child joint (`W2` is this joint and its descendants).
    pub child_joint: usize,
    /// Node at the far end of the child joint's bone ([`JointTree::bone_end`]; `None` for a
    /// leaf joint).
    pub bone_end: Option<usize>,
    /// `body/parent-child`, from the node names (`finger/proximal-middle`).
    pub name: String,
}

/// The two working regions of a pair, their shared region and its partition of unity.
#[derive(Clone, Debug)]
pub struct PairRegions {
    /// The joints.
    pub pair: JointPair,
    /// Welded faces of `W1` (ascending).
    pub w1_faces: Vec<u32>,
    /// Welded faces of `W2` (ascending).
    pub w2_faces: Vec<u32>,
    /// Per welded vertex: corner of a face of `W1`.
    pub w1: Vec<bool>,
    /// Per welded vertex: corner of a face of `W2`.
    pub w2: Vec<bool>,
    /// Welded vertices of the shared region `R = W1 ∩ W2` (ascending).
    pub shared: Vec<u32>,
    /// Welded faces of `R`: the faces whose corners all lie in both regions (ascending; may be
    /// empty where `R` is a ring of vertices between the two regions' faces).
    pub shared_faces: Vec<u32>,
    /// Per welded vertex: the partition of unity `β` (1 on `W1 \ R`, 0 on `W2 \ R`, harmonic
    /// on `R`; 0 outside both regions).
    pub beta: Vec<f64>,
    /// What the harmonic solve found.
    pub partition: PartitionStats,
    /// Rings the two regions were grown by: [`RegionOptions::grow_rings`], or fewer where the
    /// configured growth left the shared region without a partition of unity (see
    /// [`derive_pairs`]).
    pub grow_rings: usize,
    /// Human-readable account: thresholds, counts.
    pub reason: String,
}

impl PairRegions {
    /// The joint's size: [`crate::mesh::surface_size`] of the shared region `R`'s faces at
    /// `rest`, the unit of [`crate::selfcontact::fold::FoldParams::joint_extent`]; where `R`
    /// has no area (no face, or only degenerate ones), the diagonal of its vertices' bounding
    /// box. A second moment of the surface, so that the size, and the fold's extent with it,
    /// do not depend on the orientation the rig is given in (with the box diagonal, the former
    /// size, the finger rotated by 1 rad came out 0.15 h away from its output rotated;
    /// `a_fold_and_its_mirror_image_agree`).
    /// Separated regions ([`super::separated_regions`]): the smaller of the two regions' sizes (a
    /// hand against the hips deforms over about a hand).
    pub fn joint_size(&self, rest: &[Point3<f64>], triangles: &[[u32; 3]]) -> f64 {
        let size_of = |faces: &[u32]| {
            let faces: Vec<[u32; 3]> = faces
                .iter()
                .filter_map(|&f| triangles.get(f as usize).copied())
                .collect();
            crate::mesh::surface_size(rest, &faces)
        };
        let size = if self.separated() {
            size_of(&self.w1_faces).min(size_of(&self.w2_faces))
        } else {
            size_of(&self.shared_faces)
        };
        if size > 0.0 || size.is_nan() {
            return size;
        }
        self.box_diagonal(rest)
    }

    /// The diagonal of the bounding box of `R`'s vertices at `positions` (the posed size that
    /// [`crate::selfcontact::fold::FoldPre::collapsed`] compares with the rest one); of both
    /// regions' vertices for separated regions.
    pub fn box_diagonal(&self, positions: &[Point3<f64>]) -> f64 {
        box_diagonal_of(&self.sized_vertices(), positions)
    }

    /// The vertices [`PairRegions::box_diagonal`] spans: `R`'s, or both regions' when
    /// separated (a fold keeps the list: [`crate::selfcontact::fold::FoldPre::collapsed`]
    /// measures it every frame).
    pub fn sized_vertices(&self) -> Vec<u32> {
        if self.separated() {
            let inside = |v: &u32| self.w1[*v as usize] || self.w2[*v as usize];
            return (0..self.w1.len() as u32).filter(inside).collect();
        }
        self.shared.clone()
    }

    /// Whether the two regions share no vertex ([`super::separated_regions`]): Sec. 4-5 alone, no
    /// crease cut and no blend. Derived pairs always share some (those that do not are
    /// skipped).
    pub fn separated(&self) -> bool {
        self.shared.is_empty()
    }

    /// The same regions without the faces `removed` marks (per face of `triangles`): whole
    /// connected components of the mesh ([`super::layers`]), whose vertices leave `W1`, `W2`
    /// and `R` with them. `β` is kept on the rest: the harmonic solve does not couple
    /// components that share no vertex. `None` when `W1` or `W2` is left empty, or `R` for a
    /// pair that had one.
    pub fn without_faces(&self, triangles: &[[u32; 3]], removed: &[bool]) -> Option<Self> {
        let n = self.w1.len();
        let kept = |faces: &[u32]| -> (Vec<u32>, Vec<bool>) {
            let faces: Vec<u32> = (faces.iter().copied())
                .filter(|&f| !removed.get(f as usize).copied().unwrap_or(false))
                .collect();
            let mut corners = vec![false; n];
            for &f in &faces {
                for &v in triangles.get(f as usize).into_iter().flatten() {
                    if let Some(c) = corners.get_mut(v as usize) {
                        *c = true;
                    }
                }
            }
            (faces, corners)
        };
        let (w1_faces, w1) = kept(&self.w1_faces);
        let (w2_faces, w2) = kept(&self.w2_faces);
        let (shared_faces, _) = kept(&self.shared_faces);
        let shared: Vec<u32> = (self.shared.iter().copied())
            .filter(|&v| w1[v as usize] && w2[v as usize])
            .collect();
        if w1_faces.is_empty() || w2_faces.is_empty() || shared.is_empty() != self.separated() {
            return None;
        }
        let beta = (self.beta.iter().enumerate())
            .map(|(v, &b)| if w1[v] || w2[v] { b } else { 0.0 })
            .collect();
        let left = removed.iter().filter(|&&r| r).count();
        Some(Self {
            pair: self.pair.clone(),
            w1_faces,
            w2_faces,
            w1,
            w2,
            shared,
            shared_faces,
            beta,
            partition: self.partition.clone(),
            grow_rings: self.grow_rings,
            reason: format!(
                "{}; without the {left} faces of separate pieces sunk into it or inside others \
                 at rest",
                self.reason
            ),
        })
    }
}

/// Working regions of every parent/child joint pair that deforms a body, body by body, in the
/// skin's joint order of the child (2021 Sec. 6; `PIPELINE.md`, "Working regions").
///
/// The parent of a joint is its parent in the skin's [`JointTree`]: its nearest ancestor node
/// that is a joint of the same skin and carries weight on the body (helper joints without
/// weight are skipped), or, for a tracked hand whose joint nodes are not nested, its parent
/// by the joint names. `welded[b]` is the welded mesh of `rig.bodies[b]`. A pair whose
/// shared region is empty is skipped. A shared region without both Dirichlet borders is
/// derived again with fewer grown rings, down to none, and skipped only when none gives both
/// ([`derive_pairs_reporting`] says why).
pub fn derive_pairs(
    rig: &Rig,
    welded: &[WeldedMesh],
    options: &RegionOptions,
) -> Result<Vec<PairRegions>, SelfContactError> {
    derive_pairs_reporting(rig, welded, options).map(|(pairs, _)| pairs)
}

/// [`derive_pairs`], also returning why pairs were skipped (one message per skipped pair).
pub fn derive_pairs_reporting(
    rig: &Rig,
    welded: &[WeldedMesh],
    options: &RegionOptions,
) -> Result<(Vec<PairRegions>, Vec<String>), SelfContactError> {
    check_options(options)?;
    check_welded(rig, welded)?;
    let mut out = Vec::new();
    let mut skipped = Vec::new();
    for (b, (body, mesh)) in rig.bodies.iter().zip(welded).enumerate() {
        let skin = skin_of(rig, body)?;
        check_body(body, mesh, skin)?;
        let tree = JointTree::of_body(rig, body, skin);
        let src = PairSource::new(rig, b, mesh, skin, &tree)?;
        for c in 0..skin.joints.len() {
            let Some(p) = tree.parent[c] else {
                continue;
            };
            match build_pair(&src, [p, c], options) {
                Ok(Some(pair)) => out.push(pair),
                Ok(None) => {}
                // A pair whose shared region cannot carry a partition of unity (one-sided or
                // unreachable border: e.g. a joint whose weights never overlap its parent's
                // over a band) is skipped, not fatal: the rest of the rig still works.
                Err(e) if no_partition(&e) => skipped.push(if options.grow_rings > 0 {
                    format!("{e} (with {} grown rings, and fewer)", options.grow_rings)
                } else {
                    e.to_string()
                }),
                Err(e) => return Err(e),
            }
        }
    }
    Ok((out, skipped))
}

/// Working regions of the joint pairs a rig config names, as `(parent, child)` node names
/// (same construction as [`derive_pairs`], fewer-rings fallback included: the error of a
/// pair no growth saves is the configured growth's). Each named pair gives one entry per body
/// whose skin holds both joints and whose shared region is not empty, in the given order, then
/// body order; a named pair that gives nothing is an error.
pub fn pairs_for_joints<S: AsRef<str>>(
    rig: &Rig,
    welded: &[WeldedMesh],
    joints: &[(S, S)],
    options: &RegionOptions,
) -> Result<Vec<PairRegions>, SelfContactError> {
    check_options(options)?;
    check_welded(rig, welded)?;
    let find = |name: &str| {
        rig.nodes
            .iter()
            .position(|n| n.name.as_deref() == Some(name))
            .ok_or_else(|| SelfContactError::UnknownJoint(name.to_owned()))
    };
    let mut out = Vec::new();
    for (parent_name, child_name) in joints {
        let (parent_name, child_name) = (parent_name.as_ref(), child_name.as_ref());
        let unusable = |reason: &str| SelfContactError::UnusablePair {
            parent: parent_name.to_owned(),
            child: child_name.to_owned(),
            reason: reason.to_owned(),
        };
        let (parent, child) = (find(parent_name)?, find(child_name)?);
        if parent == child {
            return Err(unusable("the two joints are the same node"));
        }
        let before = out.len();
        let mut holders = 0;
        for (b, (body, mesh)) in rig.bodies.iter().zip(welded).enumerate() {
            let skin = skin_of(rig, body)?;
            let index = |node: usize| skin.joints.iter().position(|&j| j == node);
            let (Some(p), Some(c)) = (index(parent), index(child)) else {
                continue;
            };
            holders += 1;
            check_body(body, mesh, skin)?;
            let tree = JointTree::of_body(rig, body, skin);
            let src = PairSource::new(rig, b, mesh, skin, &tree)?;
            if let Some(pair) = build_pair(&src, [p, c], options)? {
                out.push(pair);
            }
        }
        if out.len() == before {
            return Err(unusable(if holders == 0 {
                "no body's skin holds both joints"
            } else {
                "the shared region is empty on every body holding both joints"
            }));
        }
    }
    Ok(out)
}

pub(super) fn check_options(options: &RegionOptions) -> Result<(), SelfContactError> {
    if options.threshold.is_finite() && options.threshold >= 0.0 {
        Ok(())
    } else {
        Err(SelfContactError::InconsistentInput(format!(
            "weight threshold {} (must be finite and >= 0)",
            options.threshold
        )))
    }
}

pub(super) fn check_welded(rig: &Rig, welded: &[WeldedMesh]) -> Result<(), SelfContactError> {
    if welded.len() == rig.bodies.len() {
        Ok(())
    } else {
        Err(SelfContactError::InconsistentInput(format!(
            "{} welded meshes for {} bodies",
            welded.len(),
            rig.bodies.len()
        )))
    }
}

pub(super) fn skin_of<'a>(rig: &'a Rig, body: &Body) -> Result<&'a Skin, SelfContactError> {
    rig.skins.get(body.skin).ok_or_else(|| {
        SelfContactError::InconsistentInput(format!(
            "body {} uses skin {} of {}",
            body.name,
            body.skin,
            rig.skins.len()
        ))
    })
}

/// Checks that the welded mesh, the weights and the skin match the body.
pub(super) fn check_body(
    body: &Body,
    mesh: &WeldedMesh,
    skin: &Skin,
) -> Result<(), SelfContactError> {
    let n = body.vertex_count();
    let bad = |what: String| {
        Err(SelfContactError::InconsistentInput(format!(
            "body {}: {what}",
            body.name
        )))
    };
    if mesh.to_welded.len() != n || body.weights.len() != n {
        return bad(format!(
            "{} file vertices, {} welded entries, {} weight rows",
            n,
            mesh.to_welded.len(),
            body.weights.len()
        ));
    }
    if mesh.representative.iter().any(|&r| r as usize >= n) {
        return bad("a welded representative is out of range".into());
    }
    if body
        .weights
        .joints
        .iter()
        .any(|&j| j as usize >= skin.joints.len())
    {
        return bad("a weight names a joint outside the skin".into());
    }
    if body.weights.offsets.windows(2).any(|w| w[0] > w[1])
        || body
            .weights
            .offsets
            .last()
            .is_some_and(|&e| e as usize > body.weights.joints.len())
        || body.weights.joints.len() != body.weights.weights.len()
    {
        return bad("malformed weight table".into());
    }
    Ok(())
}

/// Display name of a node.
pub(crate) fn node_name(rig: &Rig, node: usize) -> String {
    rig.nodes
        .get(node)
        .and_then(|n| n.name.clone())
        .unwrap_or_else(|| format!("node{node}"))
}

/// What the pairs of one body are derived from: the rig, the body's welded mesh, skin and
/// joint tree, and (computed once for all its pairs) the mesh's vertex adjacency and welded
/// rest positions.
struct PairSource<'a> {
    rig: &'a Rig,
    body: usize,
    mesh: &'a WeldedMesh,
    skin: &'a Skin,
    tree: &'a JointTree,
    adjacency: Vec<Vec<u32>>,
    rest: Vec<Point3<f64>>,
    /// The body's separate pieces ([`pieces_wholly_in_r`]).
    pieces: Components,
}

impl<'a> PairSource<'a> {
    fn new(
        rig: &'a Rig,
        body: usize,
        mesh: &'a WeldedMesh,
        skin: &'a Skin,
        tree: &'a JointTree,
    ) -> Result<Self, SelfContactError> {
        let rest = welded_rest(&rig.bodies[body], mesh)?;
        Ok(Self {
            adjacency: vertex_adjacency(mesh.vertex_count(), &mesh.triangles)?,
            pieces: Components::of(&rest, &mesh.triangles),
            rest,
            rig,
            body,
            mesh,
            skin,
            tree,
        })
    }
}

/// The regions of one pair (skin indices `p`, `c`) on `src`'s body, or `None` when `R` is
/// empty.
///
/// Fallback (not in the paper): when the shared region grown by `options.grow_rings` cannot
/// carry a partition of unity (on a coarse mesh a short end segment, a foot or a tail's tip,
/// lies wholly within its parent's grown region, so `W2 \ R` is empty), the pair is derived
/// again with one ring fewer, down to none; the first that works is kept and
/// [`PairRegions::grow_rings`] says which. The error of the configured growth is returned
/// when none does, or when fewer rings leave no shared region at all.
fn build_pair(
    src: &PairSource,
    [p, c]: [usize; 2],
    options: &RegionOptions,
) -> Result<Option<PairRegions>, SelfContactError> {
    let seeded = seed_pair(src, [p, c], options.threshold);
    let configured = match grown_pair(src, &seeded, options) {
        Err(e) if no_partition(&e) => e,
        other => return other,
    };
    for rings in (0..options.grow_rings).rev() {
        let fewer = RegionOptions {
            grow_rings: rings,
            ..*options
        };
        match grown_pair(src, &seeded, &fewer) {
            Ok(Some(mut regions)) => {
                regions.reason = format!(
                    "{} (fewer than the configured {}: the shared region had no partition of \
                     unity with more)",
                    regions.reason, options.grow_rings
                );
                return Ok(Some(regions));
            }
            Err(e) if no_partition(&e) => {}
            // Fewer rings emptied the shared region: the configured growth's reason stands.
            Ok(None) => break,
            Err(e) => return Err(e),
        }
    }
    Err(configured)
}

/// Whether `e` says a shared region cannot carry a partition of unity (the cases the ring
/// fallback of [`build_pair`] retries).
fn no_partition(e: &SelfContactError) -> bool {
    matches!(
        e,
        SelfContactError::DegenerateSharedRegion { .. }
            | SelfContactError::UnreachedSharedRegion { .. }
    )
}

/// What every growth of one pair starts from: its joints and the weight seeds of W1 and W2.
struct SeededPair {
    pair: JointPair,
    seeds: [Vec<bool>; 2],
}

/// The pair's joints and seeds (skin indices `p`, `c`) at `threshold`.
fn seed_pair(src: &PairSource, [p, c]: [usize; 2], threshold: f64) -> SeededPair {
    let PairSource {
        rig,
        body: b,
        mesh,
        skin,
        tree,
        ..
    } = *src;
    let body = &rig.bodies[b];
    let (parent, child) = (skin.joints[p], skin.joints[c]);
    let pair = JointPair {
        body: b,
        parent_joint: parent,
        child_joint: child,
        bone_end: tree.bone_end(rig, skin, c),
        name: format!(
            "{}/{}-{}",
            body.name,
            node_name(rig, parent),
            node_name(rig, child)
        ),
    };
    let below = tree.below(rig, skin, c);
    let (seed1, seed2) = weight_seeds(body, mesh, p, &below, threshold);
    SeededPair {
        pair,
        seeds: [seed1, seed2],
    }
}

/// The regions of a seeded pair grown by exactly `options.grow_rings` rings, or `None` when
/// `R` is empty.
fn grown_pair(
    src: &PairSource,
    seeded: &SeededPair,
    options: &RegionOptions,
) -> Result<Option<PairRegions>, SelfContactError> {
    let mesh = src.mesh;
    let n = mesh.vertex_count();
    let mut grown = (seeded.seeds.each_ref())
        .map(|seed| grow(seed.clone(), &src.adjacency, options.grow_rings));
    let [(w1_faces, w1), (w2_faces, w2)] = grown.each_ref().map(|g| as_faces(&mesh.triangles, g));
    // Separate pieces lying wholly in `R` (no partition of unity can reach them) follow the
    // skinning: both regions leave them.
    let unreached = pieces_wholly_in_r(&src.pieces, &mesh.triangles, &w1, &w2);
    let [(w1_faces, w1), (w2_faces, w2)] = if unreached.is_empty() {
        [(w1_faces, w1), (w2_faces, w2)]
    } else {
        for g in &mut grown {
            for &v in &unreached {
                g[v as usize] = false;
            }
        }
        grown.each_ref().map(|g| as_faces(&mesh.triangles, g))
    };
    let in_r: Vec<bool> = w1.iter().zip(&w2).map(|(&a, &b)| a && b).collect();
    let shared: Vec<u32> = (0..n).filter(|&v| in_r[v]).map(|v| v as u32).collect();
    if shared.is_empty() {
        return Ok(None);
    }
    let shared_faces = faces_within(&mesh.triangles, &in_r);
    let (beta, partition) =
        partition_with_adjacency(&src.rest, &mesh.triangles, &src.adjacency, &w1, &w2)
            .map_err(|e| e.for_pair(&seeded.pair.name))?;
    let mut regions = PairRegions {
        pair: seeded.pair.clone(),
        w1_faces,
        w2_faces,
        w1,
        w2,
        shared,
        shared_faces,
        beta,
        partition,
        grow_rings: options.grow_rings,
        reason: String::new(),
    };
    let seeds = seeded.seeds.each_ref().map(|s| count(s));
    regions.reason = derivation(src.rig, src.tree.source, options, seeds, &regions);
    if !unreached.is_empty() {
        regions.reason = format!(
            "{}; {} vertices of separate pieces lying wholly in R (no border of R reaches \
             them) left to the skinning",
            regions.reason,
            unreached.len()
        );
    }
    Ok(Some(regions))
}

/// The vertices of the separate pieces of the mesh (`pieces`) lying wholly in
/// `R = W1 ∩ W2` (per-vertex flags), when another piece holds only part of `R`: no border of
/// `R` reaches them, so they can carry no partition of unity (a button, a stud, teeth: every
/// vertex weighted to both joints). Ascending; empty when every piece holding `R` lies
/// wholly in it (Khronos's RiggedSimple, both joints over the whole cylinder: the partition
/// reports that region).
fn pieces_wholly_in_r(
    pieces: &Components,
    triangles: &[[u32; 3]],
    w1: &[bool],
    w2: &[bool],
) -> Vec<u32> {
    if pieces.len() < 2 {
        return Vec::new();
    }
    let in_r = |v: &&u32| w1[**v as usize] && w2[**v as usize];
    let (mut whole, mut partial) = (Vec::new(), false);
    for c in 0..pieces.len() as u32 {
        let vertices = pieces.vertices_of(c, triangles);
        match vertices.iter().filter(in_r).count() {
            0 => {}
            k if k == vertices.len() => whole.extend(vertices),
            _ => partial = true,
        }
    }
    if !partial {
        return Vec::new();
    }
    whole.sort_unstable();
    whole
}

/// The seeds of W1 and W2: vertices whose weight on the parent joint (skin index `p`), and on
/// the joints `below` the child, exceeds `threshold`.
fn weight_seeds(
    body: &Body,
    mesh: &WeldedMesh,
    p: usize,
    below: &[bool],
    threshold: f64,
) -> (Vec<bool>, Vec<bool>) {
    let n = mesh.vertex_count();
    let mut seed1 = vec![false; n];
    let mut seed2 = vec![false; n];
    for (v, &rep) in mesh.representative.iter().enumerate() {
        let (mut on_parent, mut on_child) = (0.0, 0.0);
        for (j, w) in body.weights.row(rep as usize) {
            if j == p {
                on_parent += w;
            }
            if below.get(j).copied().unwrap_or(false) {
                on_child += w;
            }
        }
        seed1[v] = on_parent > threshold;
        seed2[v] = on_child > threshold;
    }
    (seed1, seed2)
}

/// The rest positions of the welded vertices.
fn welded_rest(body: &Body, mesh: &WeldedMesh) -> Result<Vec<Point3<f64>>, SelfContactError> {
    mesh.representative
        .iter()
        .map(|&r| body.positions.get(r as usize).copied())
        .collect::<Option<_>>()
        .ok_or_else(|| {
            SelfContactError::InconsistentInput(format!(
                "body {}: positions do not match the welded mesh",
                body.name
            ))
        })
}

/// Why a pair's regions are what they are (`contact-skin info`): the seeds' rule and sizes
/// (`seeds`: W1's and W2's), the grown regions, `R` and its partition of unity.
fn derivation(
    rig: &Rig,
    source: TreeSource,
    options: &RegionOptions,
    seeds: [usize; 2],
    r: &PairRegions,
) -> String {
    let t = options.threshold;
    let partition = &r.partition;
    format!(
        "{name}: W1 = weight on {pj} > {t} ({n1} vertices), W2 = weight on {cj} and its \
         descendants{from} > {t} ({n2} vertices), each grown {rings} rings: W1 {v1} vertices / {f1} \
         faces, W2 {v2} vertices / {f2} faces; R {rv} vertices / {rf} faces in {comp} part(s), \
         border beta = 1 on {d1}, beta = 0 on {d0}, {both} next to both (Neumann), {orph} \
         orphan(s); harmonic range before clamping [{lo:.3e}, {hi:.3e}]",
        name = r.pair.name,
        from = match source {
            TreeSource::Hierarchy => "",
            TreeSource::HandJointNames => {
                " (joint nodes not nested: the tree of a tracked hand's joint names)"
            }
        },
        pj = node_name(rig, r.pair.parent_joint),
        cj = node_name(rig, r.pair.child_joint),
        n1 = seeds[0],
        n2 = seeds[1],
        rings = options.grow_rings,
        v1 = count(&r.w1),
        f1 = r.w1_faces.len(),
        v2 = count(&r.w2),
        f2 = r.w2_faces.len(),
        rv = r.shared.len(),
        rf = partition.faces,
        comp = partition.components,
        d1 = partition.dirichlet_one,
        d0 = partition.dirichlet_zero,
        both = partition.touching_both,
        orph = partition.orphans,
        lo = partition.raw_min,
        hi = partition.raw_max,
    )
}

pub(super) fn count(flags: &[bool]) -> usize {
    flags.iter().filter(|&&x| x).count()
}

/// Adds `rings` rings of neighbors to `set`.
fn grow(mut set: Vec<bool>, adjacency: &[Vec<u32>], rings: usize) -> Vec<bool> {
    let mut front: Vec<u32> = (0..set.len())
        .filter(|&v| set[v])
        .map(|v| v as u32)
        .collect();
    for _ in 0..rings {
        let mut next = Vec::new();
        for &v in &front {
            for &u in &adjacency[v as usize] {
                if !std::mem::replace(&mut set[u as usize], true) {
                    next.push(u);
                }
            }
        }
        if next.is_empty() {
            break;
        }
        front = next;
    }
    set
}

/// The faces with all three corners in `set`, and the vertices of those faces.
pub(super) fn as_faces(triangles: &[[u32; 3]], set: &[bool]) -> (Vec<u32>, Vec<bool>) {
    let mut vertices = vec![false; set.len()];
    let mut faces = Vec::new();
    for (f, t) in triangles.iter().enumerate() {
        if t.iter().all(|&v| set[v as usize]) {
            faces.push(f as u32);
            for &v in t {
                vertices[v as usize] = true;
            }
        }
    }
    (faces, vertices)
}

/// The diagonal of the bounding box of `vertices` at `positions` (those out of range left
/// out).
pub fn box_diagonal_of(vertices: &[u32], positions: &[Point3<f64>]) -> f64 {
    crate::mesh::bbox_diagonal(vertices.iter().filter_map(|&v| positions.get(v as usize)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles sharing an edge: `W1` the first, `W2` the second, `R` their shared edge.
    fn two_triangles(shared_faces: Vec<u32>) -> (PairRegions, Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let rest = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(3.0, 0.0, 0.0),
            Point3::new(0.0, 4.0, 0.0),
            Point3::new(3.0, 4.0, 0.0),
        ];
        let triangles = vec![[0, 1, 2], [1, 3, 2]];
        let regions = PairRegions {
            pair: JointPair {
                body: 0,
                parent_joint: 0,
                child_joint: 1,
                bone_end: None,
                name: "test/a-b".into(),
            },
            w1_faces: vec![0],
            w2_faces: vec![1],
            w1: vec![true, true, true, false],
            w2: vec![false, true, true, true],
            shared: vec![1, 2],
            shared_faces,
            beta: vec![1.0, 0.5, 0.5, 0.0],
            partition: PartitionStats::default(),
            grow_rings: 0,
            reason: String::new(),
        };
        (regions, rest, triangles)
    }

    /// A shared region with faces is sized by their second moment; one without area (here an
    /// edge between the two regions' faces) by its vertices' box diagonal, never 0 (a zero size
    /// would give the fold a zero extent).
    #[test]
    fn a_joint_without_shared_area_is_sized_by_its_box() {
        let (with_area, rest, triangles) = two_triangles(vec![0]);
        let size = with_area.joint_size(&rest, &triangles);
        let expected = crate::mesh::surface_size(&rest, &triangles[..1]);
        assert!(size > 0.0 && (size - expected).abs() < 1e-15, "{size}");
        let (edge_only, rest, triangles) = two_triangles(vec![]);
        assert_eq!(edge_only.joint_size(&rest, &triangles), 5.0);
        let (out_of_range, rest, triangles) = two_triangles(vec![7]);
        assert_eq!(out_of_range.joint_size(&rest, &triangles), 5.0);
    }
}
