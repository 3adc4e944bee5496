//! One joint folding into itself, per frame (2021 Sec. 6): detection, crease partition,
//! contact on the truncated working regions, direction field, deformation of both whole
//! regions, partition-of-unity blend and one volume solve over the blended pair.
//!
//! With `PIPELINE.md`'s conventions: `d̂_12` is W1's outward direction at the fold (from the
//! skeleton or the user); both regions use `d̄ = σ d̂_12`, `σ` harmonic on the shared region
//! `R` with `σ = +1` on `W1 \ R` and on `∂C_1`, `-1` on `W2 \ R` and on `∂C_2` (the paper's
//! `(2β - 1) d̄` can reverse W2's own contact displacement); each region is deformed with both
//! contact zones (the zone found on one side is "reported" onto the part of the other region
//! that was cut away); `p' = β p'_1 + (1 - β) p'_2` with one bulge height `h_v` solved on the
//! blended `P` and `Q` (else the indentation inside `R` is compensated twice).
//!
//! This file holds the fold's per-frame sequence; beside it: `params.rs` (the fold's
//! parameters), `pre.rs` (its precomputation and detection), and its steps of its own,
//! `crease_zones.rs` (the zones extended to the crease cut), `sigma.rs` (the sign field `σ`)
//! and `blend.rs` (the blend, the volume solve and the guards' scales).

use super::bulge_guard::{bulge_scales, BulgeStep, TOLERANCE};
use super::crease::{crease_cut, Crease, CreaseInput};
use super::turn_guard::{displacement_scales, GuardInput, TurnReference};
use crate::contact::{
    inside_from, resolve_self_pair, Contact, ContactSide, DirectionMode, InsideTwice, PairOutcome,
    PairParams, SideFrame,
};
use crate::deform::region::{bulge_height, shape_region};
use crate::deform::volume::RootKind;
use crate::deform::{DeformStats, RegionDeformation, RegionFrame};
use crate::heat::{Boundary, EdgePoint};
use crate::intersect::{MeshIndex, PosedMesh};
use crate::pass::StageTimings;
use crate::report::metrics::WindingNumber;
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;
use std::time::Instant;

mod blend;
mod crease_zones;
mod params;
mod pre;
mod sigma;

pub use params::{
    FoldParams, DEFAULT_FOLD_TAU, DEFAULT_JOINT_EXTENT, FOLD_EXTENT_FLOOR, STEEPEST_BULGE,
    UNBALANCED_VOLUME,
};
pub use pre::{Detection, FoldPre};

use blend::blend_and_balance;
use crease_zones::{zones_to_the_crease, CreaseVertices};
use sigma::sigma_field;

/// Why a fold could not be resolved in a frame.
#[derive(Debug, thiserror::Error)]
pub enum FoldError {
    /// Intersection queries on the parts.
    #[error(transparent)]
    Intersect(#[from] crate::intersect::IntersectError),
    /// The crease min-cut.
    #[error(transparent)]
    MinCut(#[from] crate::mincut::MinCutError),
    /// The contact between the truncated regions.
    #[error(transparent)]
    Contact(#[from] crate::contact::ContactError),
    /// A region's deformation.
    #[error(transparent)]
    Deform(#[from] crate::deform::DeformError),
    /// A harmonic solve (`σ`).
    #[error(transparent)]
    Heat(#[from] crate::heat::HeatError),
    /// A region's analysis.
    #[error(transparent)]
    Solve(#[from] crate::solve::SolveError),
}

/// Time per step of one fold, in seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct FoldTimings {
    /// Detection with the rest partition.
    pub detection: f64,
    /// Crease cut and truncated parts.
    pub crease: f64,
    /// Contact surface and zones (Sec. 4.2-4.4).
    pub contact: f64,
    /// The zones' extension to the crease and the direction field `σ`.
    pub directions: f64,
    /// Both regions' deformation (Sec. 5).
    pub deformation: f64,
    /// Blend and volume.
    pub volume: f64,
    /// The same time in the columns of the paper's Table 1: i. the detection, the crease cut
    /// and the truncated parts' intersection; m. and c. the contact's mapping and zones; di.
    /// the zones' extension to the crease, `σ` and both regions' direction fields; p., g. and
    /// s. both regions' parametrization, diffusions and numeric factorizations; de. both
    /// regions' profiles and bulge map, the blend and the volume solve.
    pub stages: StageTimings,
}

add_assign_fields!(
    "Times of several folds, summed step by step.",
    FoldTimings {
        detection,
        crease,
        contact,
        directions,
        deformation,
        volume,
        stages,
    }
);

impl FoldTimings {
    /// The fold's whole time: the sum of its steps.
    pub fn total(&self) -> f64 {
        self.detection
            + self.crease
            + self.contact
            + self.directions
            + self.deformation
            + self.volume
    }
}

/// The result of one fold in one frame.
#[derive(Clone, Debug)]
pub struct FoldOutput {
    /// Output positions of the whole mesh.
    pub positions: Vec<Point3<f64>>,
    /// The crease partition.
    pub crease: Crease,
    /// `PIPELINE.md`'s check of the crease cut: the detection's crossing face pairs left with
    /// both faces on one side of it (0 when every pair straddles the cut, as it should; 0 for
    /// separated regions, which have no cut).
    pub unseparated: usize,
    /// The detection's crossing face pairs that the crease cut should separate (0 for
    /// separated regions): what `unseparated` counts among.
    pub crossing: usize,
    /// The contact between the truncated regions.
    pub contact: Contact,
    /// `σ` per mesh vertex (0 outside `W1 ∪ W2`).
    pub sigma: Vec<f64>,
    /// Statistics of W1's and W2's deformations.
    pub stats: [DeformStats; 2],
    /// The common bulge height.
    pub bulge_height: f64,
    /// How it was found (`None` for an open mesh: no volume to keep).
    pub root: Option<RootKind>,
    /// The largest blended bulge displacement `γ h_v |Q|` over either region's vertices, over
    /// that region's effective extent `φ_max,eff` (0 without bulge; `+∞` for a bulge on a zero
    /// extent).
    pub bulge_steepness: f64,
    /// Why the fold was left unresolved, `None` when it was resolved: no plausible bulge
    /// could keep the volume ([`Unbalanced`]). `positions` is then the input: the fold is left
    /// unresolved rather than resolved with a volume error (measured on CesiumMan: 7e-3), a
    /// spike or a face turned over.
    pub unbalanced: Option<Unbalanced>,
    /// Vertices whose displacement the turn guard scaled back ([`FoldParams::turn_guard`]).
    pub guarded: usize,
    /// Vertices whose bulge the bulge guard scaled back ([`FoldParams::bulge_guard`]).
    pub bulge_guarded: usize,
    /// Each region's own deformation with the common bulge height, before the blend (`p'_1`,
    /// `p'_2`; whole mesh, unchanged outside the region).
    pub region_positions: [Vec<Point3<f64>>; 2],
    /// Timings.
    pub timings: FoldTimings,
}

/// Why a fold was left unresolved ([`FoldOutput::unbalanced`]), in the order checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Unbalanced {
    /// No exact root of the volume cubic while the deformation changed the volume by more
    /// than [`UNBALANCED_VOLUME`]: no bulge band (the zone reaches its region's border, which
    /// caps the extent to nothing; the zone is the whole region) or displacement directions
    /// pointing inward (deep penetration).
    NoVolumeRoot,
    /// The root gives a bulge higher than [`STEEPEST_BULGE`] × the band it rises from.
    SteepBulge,
    /// The guards and volume solves did not settle within their cap and every exactly
    /// balanced blend turns a face over (`blend::GUARD_SOLVES`).
    TurnedFace,
}

/// What a fold detected intersecting itself amounts to in one frame.
#[derive(Clone, Debug)]
pub enum FoldOutcome {
    /// The truncated parts turn out not to be in contact, or neither side has a contact zone
    /// (the time spent finding that out is not reported in any fold's timings).
    Apart,
    /// Separated regions ([`crate::selfcontact::regions::PairRegions::separated`]) that
    /// intersect with no direction: Eq. 2's normals cancel out over both intersection
    /// regions (a symmetric crossing, [`crate::contact::PairOutcome::NoDirection`]). Left as
    /// they were; the pass counts them with the folds the skeleton gives no direction.
    NoDirection,
    /// The fold, resolved.
    Resolved(Box<FoldOutput>),
}

impl FoldOutcome {
    /// The resolved fold, if any.
    pub fn into_output(self) -> Option<FoldOutput> {
        match self {
            FoldOutcome::Resolved(out) => Some(*out),
            FoldOutcome::Apart | FoldOutcome::NoDirection => None,
        }
    }
}

/// The fold in one frame, once [`FoldPre::detect`] found it intersecting itself.
pub fn resolve_detected(
    pre: &FoldPre,
    detection: &Detection,
    geometry: &FoldInput,
    params: &FoldParams,
) -> Result<FoldOutcome, FoldError> {
    let mut winding = pre.body_tree();
    resolve_detected_in(pre, detection, geometry, params, &mut winding)
}

/// [`resolve_detected`] with the body's winding-number tree `winding` kept by the caller
/// between the folds of a frame: [`FoldPre::body_tree`], or that tree as an earlier fold of the
/// same body in the same frame left it. It is refit whole at the first fold, then only at its
/// leaves with a moved corner ([`WindingNumber::refit_changed`]), to the same bits as a copy
/// of the rest tree refit whole: the folds of a body each move one joint's regions.
pub fn resolve_detected_in(
    pre: &FoldPre,
    detection: &Detection,
    geometry: &FoldInput,
    params: &FoldParams,
    winding: &mut WindingNumber,
) -> Result<FoldOutcome, FoldError> {
    let FoldInput {
        positions,
        normals,
        triangles,
        direction,
        ..
    } = *geometry;
    let mut timings = FoldTimings {
        detection: detection.seconds,
        ..FoldTimings::default()
    };
    let mut laps = Laps::start();
    let surface = pre.inside_surface(triangles);
    let inside = winding
        .refit_changed(positions, triangles)
        .then(|| InsideTwice::new(std::borrow::Cow::Borrowed(&*winding), positions, surface));
    let tree = inside.as_ref();
    let separated = pre.regions.separated();
    let (crease, unseparated, truncated) = partition(pre, detection, geometry, tree, params)?;
    timings.crease = laps.next();
    // Separated regions: their intersection regions are apart, so Eq. 2 applies (Sec. 6
    // replaces it by the skeleton's direction only where the regions overlap).
    let mode = if separated {
        DirectionMode::Automatic
    } else {
        DirectionMode::Fixed(direction)
    };
    let contact = truncated_contact(&truncated, positions, normals, mode, params, tree)?;
    timings.contact = laps.next();
    let mut contact = match contact {
        PairOutcome::Contact(contact) => *contact,
        PairOutcome::NoDirection => return Ok(FoldOutcome::NoDirection),
        PairOutcome::Apart => return Ok(FoldOutcome::Apart),
    };
    // The direction the regions deform along: W1's outward one, the contact's own for
    // separated regions.
    let geometry = &FoldInput {
        direction: if separated {
            contact.sides[0].direction
        } else {
            direction
        },
        ..*geometry
    };
    // Intersecting faces without a contact zone on either side (zero depth: the Quaternius
    // robot's rigid finger pieces, modeled interpenetrating) leave every vertex where it is:
    // the crease can extend zones, not create them, and the rest of the fold only moved
    // vertices by round-off (at most 2.3e-16 on CesiumMan), at 0.6 ms per robot frame.
    if contact.sides.iter().all(|s| s.zone.vertices.is_empty()) {
        return Ok(FoldOutcome::Apart);
    }
    if let Some(tree) = tree.filter(|_| !separated) {
        zones_to_the_crease(
            pre,
            &CreaseVertices::of(geometry, &crease, tree),
            &mut contact,
            params.free_isolated_crease,
        );
    }
    let sigma = sigma_field(pre, positions, &contact)?;
    timings.directions = laps.next();
    let [s1, s2] = deform_both(pre, geometry, &contact, &sigma, params)?;
    timings.deformation = laps.next();
    let blended = blend_and_balance(pre, geometry, [&s1, &s2], params, truncated.indices())?;
    timings.volume = laps.next();
    let gamma_h = params.deform.gamma * blended.h;
    timings.stages = table1_stages(&timings, &contact.timings, [&s1.timings, &s2.timings]);
    Ok(FoldOutcome::Resolved(Box::new(FoldOutput {
        region_positions: [own_positions(&s1, gamma_h), own_positions(&s2, gamma_h)],
        positions: blended.positions,
        crease,
        unseparated,
        crossing: if separated {
            0
        } else {
            detection.face_pairs.len()
        },
        contact,
        sigma,
        stats: [s1.stats, s2.stats],
        bulge_height: blended.h,
        root: blended.root,
        bulge_steepness: blended.steepness,
        unbalanced: blended.unbalanced,
        guarded: blended.guarded,
        bulge_guarded: blended.bulge_guarded,
        timings,
    })))
}

/// The posed body of one frame, as a fold reads it.
#[derive(Clone, Copy)]
pub struct FoldInput<'a> {
    /// Positions of the whole mesh.
    pub positions: &'a [Point3<f64>],
    /// Unit vertex normals of `positions`.
    pub normals: &'a [Vector3<f64>],
    /// Mesh triangles.
    pub triangles: &'a [[u32; 3]],
    /// `d̂_12`, W1's outward direction (not read for separated regions,
    /// [`crate::selfcontact::regions::PairRegions::separated`], which take Eq. 2's from their
    /// contact).
    pub direction: Vector3<f64>,
    /// What the turn guard keeps faces from turning against ([`FoldParams::turn_guard`]):
    /// the frame's input and the skinning's normals; `None`: no guard.
    pub turn_reference: Option<TurnReference<'a>>,
    /// Per mesh vertex, whether the frame's previous sweep left it penetrating (set in the
    /// further sweeps of [`crate::selfcontact::pass::SelfContactPass::with_max_passes`],
    /// `None` in a frame's first sweeps): such a vertex of the crease cut does not join a
    /// contact zone at depth 0, where it would be pinned inside again, and is left to Sec. 5's
    /// profile.
    pub left_penetrating: Option<&'a [bool]>,
}

/// Seconds between successive calls of [`Laps::next`].
struct Laps {
    clock: Instant,
    mark: f64,
}

impl Laps {
    fn start() -> Self {
        Self {
            clock: Instant::now(),
            mark: 0.0,
        }
    }

    /// Seconds since the previous lap (or the start).
    fn next(&mut self) -> f64 {
        let now = self.clock.elapsed().as_secs_f64();
        let step = now - self.mark;
        self.mark = now;
        step
    }
}

/// The fold's two parts in this frame: the crease cut's truncated regions with the count of
/// the detection's crossing pairs it leaves on one side ([`cut_the_crease`]), or separated
/// regions as they are, with no cut (their sides are apart by construction, 0 such pairs).
fn partition<'p>(
    pre: &'p FoldPre,
    detection: &Detection,
    g: &FoldInput,
    tree: Option<&InsideTwice>,
    params: &FoldParams,
) -> Result<(Crease, usize, Truncated<'p>), FoldError> {
    if pre.regions.separated() {
        let (crease, parts) = separated_parts(pre, g.positions, g.triangles)?;
        return Ok((crease, 0, parts));
    }
    cut_the_crease(pre, detection, g, tree, params)
}

/// Sec. 6 "Crease detection & Partitioning": the min-cut of `R` (intersection terms on the
/// intersecting vertices and, when the body is closed, those of `R` buried in the other
/// part), and the two truncated parts it leaves, indexed for Sec. 4.2-4.4.
fn cut_the_crease(
    pre: &FoldPre,
    detection: &Detection,
    g: &FoldInput,
    tree: Option<&InsideTwice>,
    params: &FoldParams,
) -> Result<(Crease, usize, Truncated<'static>), FoldError> {
    let r = &pre.regions;
    let intersecting = match tree {
        Some(tree) => with_buried(pre, g.positions, g.normals, tree, &detection.vertices),
        None => detection.vertices.clone(),
    };
    let crease = crease_cut(
        &CreaseInput {
            positions: g.positions,
            normals: g.normals,
            triangles: g.triangles,
            faces: &pre.faces,
            w1: &r.w1,
            w2: &r.w2,
            beta: &r.beta,
            direction: g.direction,
            intersecting: &intersecting,
            topology: Some(&pre.topology),
        },
        &params.crease,
    )?;
    let labels = cut_labels(g.triangles, &pre.faces, &crease.on_w1);
    let unseparated = unseparated_pairs(&detection.face_pairs, &labels);
    let truncated =
        MeshIndex::self_contact_parts_within(Some(&pre.parts), g.positions, g.triangles, &labels)?;
    Ok((crease, unseparated, Truncated::Cut(Box::new(truncated))))
}

/// `PIPELINE.md`'s check of a crease cut, "every intersecting face pair straddles the cut":
/// how many of the detection's crossing face `pairs` have both faces on one side of the
/// cut's face `labels` (0 when it holds).
fn unseparated_pairs(pairs: &[[u32; 2]], labels: &[u8]) -> usize {
    pairs
        .iter()
        .filter(|[a, b]| labels[*a as usize] == labels[*b as usize])
        .count()
}

/// A fold's two truncated parts in one frame, indexed for Sec. 4.2-4.4.
enum Truncated<'p> {
    /// Indexed at the frame's positions: the crease cut moves them every frame.
    Cut(Box<[MeshIndex; 2]>),
    /// Separated regions' parts, indexed once at rest ([`FoldPre`]): their trees are refit
    /// to the frame's positions where posed.
    AtRest(&'p [MeshIndex; 2]),
}

impl Truncated<'_> {
    /// The two parts' indices.
    fn indices(&self) -> [&MeshIndex; 2] {
        match self {
            Truncated::Cut(parts) => [&parts[0], &parts[1]],
            Truncated::AtRest([a, b]) => [a, b],
        }
    }

    /// The two parts at `positions`, those of the frame.
    fn posed<'a>(&'a self, positions: &'a [Point3<f64>]) -> Result<[PosedMesh<'a>; 2], FoldError> {
        Ok(match self {
            // Indexed at these positions (`cut_the_crease`): no second refit.
            Truncated::Cut(parts) => [
                parts[0].posed_as_built(positions)?,
                parts[1].posed_as_built(positions)?,
            ],
            Truncated::AtRest([a, b]) => [a.pose(positions)?, b.pose(positions)?],
        })
    }
}

/// Separated regions (no shared region, [`crate::selfcontact::regions::PairRegions::separated`]):
/// no crease to cut; the parts are the two regions as they are (the rest labels), indexed
/// once at rest ([`FoldPre`]; indexed here at `positions` should a pre lack them).
fn separated_parts<'p>(
    pre: &'p FoldPre,
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
) -> Result<(Crease, Truncated<'p>), FoldError> {
    let parts = match &pre.separated_parts {
        Some(parts) => Truncated::AtRest(parts),
        None => Truncated::Cut(Box::new(MeshIndex::self_contact_parts_within(
            Some(&pre.parts),
            positions,
            triangles,
            &pre.labels,
        )?)),
    };
    let crease = Crease {
        on_w1: pre.regions.w1.clone(),
        value: 0.0,
        stray: 0,
    };
    Ok((crease, parts))
}

/// Sec. 5 on both working regions with the mapping field `σ d̂` (Sec. 6 "Consistent mapping
/// direction"), `R`'s vertices free to move: the two are independent until the blend.
fn deform_both(
    pre: &FoldPre,
    g: &FoldInput,
    contact: &Contact,
    sigma: &[f64],
    params: &FoldParams,
) -> Result<[RegionDeformation; 2], FoldError> {
    let r = &pre.regions;
    let field: Vec<Vector3<f64>> = sigma.iter().map(|s| g.direction * *s).collect();
    let sides: Vec<&ContactSide> = contact.sides.iter().collect();
    let shared: Vec<bool> = r.w1.iter().zip(&r.w2).map(|(a, b)| *a && *b).collect();
    let frame = RegionFrame {
        positions: g.positions,
        normals: g.normals,
        triangles: g.triangles,
        contacts: &sides,
        painted: None,
        direction_field: Some(&field),
        free_border: Some(&shared),
    };
    let deform = params.deform_at(pre);
    let (s1, s2) = rayon::join(
        || shape_region(&pre.w1, &frame, &deform),
        || shape_region(&pre.w2, &frame, &deform),
    );
    Ok([s1?, s2?])
}

/// One region's own result before the blend: `P + γ h_v Q`.
fn own_positions(region: &RegionDeformation, gamma_h: f64) -> Vec<Point3<f64>> {
    region
        .base
        .iter()
        .zip(&region.bulge_unit)
        .map(|(p, q)| p + q * gamma_h)
        .collect()
}

/// A fold's time in the columns of the paper's Table 1 ([`FoldTimings::stages`] says what each
/// holds: the paper does not say where Sec. 6's own steps go in its skinned finger row).
/// `wall` is the fold's whole time ([`FoldTimings::total`]).
fn table1_stages(
    fold: &FoldTimings,
    contact: &crate::contact::ContactTimings,
    regions: [&crate::deform::DeformTimings; 2],
) -> StageTimings {
    let sum = |f: fn(&crate::deform::DeformTimings) -> f64| regions.iter().map(|r| f(r)).sum();
    StageTimings {
        setup: 0.0,
        intersection: fold.detection + fold.crease + contact.intersection,
        mapping: contact.mapping,
        zones: contact.zones,
        parametrization: sum(|r| r.parametrization),
        directions: fold.directions + sum(|r| r.directions),
        fields: sum(|r| r.fields),
        deformation: sum(|r| r.deformation) + fold.volume,
        factorization: sum(|r| r.factorization),
        wall: fold.total(),
    }
}

/// The vertices that get the crease's intersection terms: those of the crossing faces
/// (`crossing`, sorted) and the vertices of `R` inside the other part
/// ([`crate::contact::inside_twice`]) reached from them across `R`'s edges through such
/// vertices (as `I_l` is found). A scan of the whole of `R` finds 0 to 5 more per 31-frame
/// animation (isolated vertices, CoR and DQS) for 4 times the winding queries.
///
/// Not in `PIPELINE.md`, which gives the intersection terms to the crossing faces only. With
/// DQS or CoR input the joint's inner side bulges into the other part: between the crease and
/// the bulge's top (up to 8 h deep at 150° on the bending capsule) lies a band whose normals
/// face the other part's direction (`n·d̂` of W1's sign on W2's side). Far from the
/// intersection curve, the band got the `β` terms, stayed on W2's side, could not be mapped
/// (back-facing, Sec. 4.2) and the zone ended 8 h deep: the profile then carried its
/// amplitude (4 h) onto the band and folded it. With the intersection terms the band goes to
/// the side its normals face. Measured on the bending capsule, 31 frames, worst frame:
/// CoR 19 → 5 penetrating vertices, 57 → 30 faces turned; DQS 22 → 2, 61 → 22; LBS, finger and
/// mouth unchanged. The temporal ratio does not improve (CoR 12 → 23, DQS 17 → 23: the
/// crease's bottom still jumps, see the issue note).
fn with_buried(
    pre: &FoldPre,
    positions: &[Point3<f64>],
    normals: &[Vector3<f64>],
    inside: &InsideTwice,
    crossing: &[u32],
) -> Vec<u32> {
    let region = &pre.shared.solver.region;
    let local = |v: u32| {
        pre.shared
            .local_of
            .get(v as usize)
            .copied()
            .filter(|&l| l != u32::MAX)
    };
    let buried = inside_from(
        region.vertex_count(),
        crossing.iter().filter_map(|&v| local(v)),
        |l, out| out.extend(&pre.shared_adjacency[l as usize]),
        |l| {
            let v = region.vertices[l as usize] as usize;
            inside.at(v, &positions[v], &normals[v])
        },
    );
    let mut out = crossing.to_vec();
    out.extend(
        region
            .vertices
            .iter()
            .zip(&buried)
            .filter(|(_, &b)| b)
            .map(|(&v, _)| v),
    );
    out.sort_unstable();
    out.dedup();
    out
}

/// Sec. 4.2-4.4 between the truncated parts, with the skeleton's (or the user's) direction.
fn truncated_contact(
    truncated: &Truncated,
    positions: &[Point3<f64>],
    normals: &[Vector3<f64>],
    direction: DirectionMode,
    params: &FoldParams,
    tree: Option<&InsideTwice>,
) -> Result<PairOutcome, FoldError> {
    let posed = truncated.posed(positions)?;
    let side = |k: usize| SideFrame {
        mesh: &posed[k],
        normals,
        hittable: None,
    };
    let pair = PairParams {
        stiffness_a: params.stiffness_1,
        tau: params.tau,
        safeguard_angle: params.safeguard_angle,
        direction,
        ..PairParams::default()
    };
    Ok(resolve_self_pair(side(0), side(1), &pair, tree)?)
}

/// Face labels after the cut: a face of `W1 ∪ W2` goes to the side of at least two of its
/// corners.
fn cut_labels(triangles: &[[u32; 3]], faces: &[u32], on_w1: &[bool]) -> Vec<u8> {
    let mut labels = vec![0u8; triangles.len()];
    for &f in faces {
        let t = triangles[f as usize];
        let ones = t.iter().filter(|&&v| on_w1[v as usize]).count();
        labels[f as usize] = if ones >= 2 { 1 } else { 2 };
    }
    labels
}
