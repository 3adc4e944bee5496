//! The contact surface between two working regions (2021 Sec. 4; Algorithm 1): intersection,
//! mapping direction, mapping regions, potential contact surface, contact zones.
//!
//! | step | paper | module |
//! | --- | --- | --- |
//! | mapping direction `d̂` (Eq. 2) | Sec. 4.1 | [`direction`] |
//! | mapping regions `M_l`, farthest-hit mapping | Sec. 4.2 | [`mapping`] |
//! | potential surface `S`, threshold (Eq. 4), zones (Eq. 3, 5) | Sec. 4.3-4.4 | [`zones`] |
//!
//! Conventions (`PIPELINE.md`): `d̄_l` is the mapping direction of side `l`, oriented outward
//! for `l` (`d̄_B = -d̄_A`); `m̂_l = -d̄_l` is its cast (push) direction; `k̄_l` its relative
//! stiffness: `l` moves `(1 - k̄_l) δ`. The paper's captions quote `k̄_X` as the share `X`
//! moves, i.e. `1 - k̄_X` here.

pub mod direction;
pub mod mapping;
pub mod zones;

use crate::intersect::{
    IntersectError, IntersectionRegion, IntersectionStats, Intersections, PosedMesh, Side,
};
pub use mapping::{Mapping, MappingRegion, MappingStats, SideFrame};
use nalgebra::{Point3, Vector3};
use std::time::Instant;
pub use zones::{SurfaceSample, Zone, ZoneBoundaryPoint};

/// How the mapping direction of a pair is chosen (Sec. 4.1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DirectionMode {
    /// From the normals over the intersection regions (Eq. 2).
    Automatic,
    /// Set by the user: the direction of side A, outward for A (pointing from A toward B
    /// across the contact). Keyframed directions are sampled by the caller.
    Fixed(Vector3<f64>),
}

/// Parameters of one contact pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairParams {
    /// `k̄_A = k_A / (k_A + k_B)`: A moves `(1 - k̄_A) δ`, B moves `k̄_A δ`.
    pub stiffness_a: f64,
    /// `τ` of Eq. 4 (apparent stiffness: extent of the contact zone).
    pub tau: f64,
    /// The safeguard of Sec. 4.4 in degrees, in `(0, 90]` (checked by the configuration, not
    /// here): a vertex stays out of the contact zone unless its normal is within this angle of
    /// its side's direction and the other side's normal at its mapping within this angle of the
    /// opposite direction. Default [`zones::DEFAULT_SAFEGUARD_ANGLE`] (80°, the paper's). A
    /// smaller angle leaves the grazing parts of a contact out of the zone: more residual
    /// penetration, and on CesiumMan fewer pops (measured in `README.md`).
    pub safeguard_angle: f64,
    /// The mapping direction.
    pub direction: DirectionMode,
    /// Whether two separate surfaces lying on each other are refused
    /// ([`ContactError::Coincident`]; default true). On skinned input only a duplicated or
    /// layered mesh puts faces exactly on each other; a contact pass after the first starts
    /// from the contact surface both sides share by construction, where a rigid side's faces
    /// hold the other's (the sphere on the slab: 352 vertices left 0.28 h deep when its second
    /// pass refused them).
    pub refuse_coincident: bool,
}

impl Default for PairParams {
    fn default() -> Self {
        Self {
            stiffness_a: 0.5,
            tau: 0.0,
            safeguard_angle: zones::DEFAULT_SAFEGUARD_ANGLE,
            direction: DirectionMode::Automatic,
            refuse_coincident: true,
        }
    }
}

impl PairParams {
    /// The same contact seen with A and B swapped.
    pub fn swapped(&self) -> Self {
        Self {
            stiffness_a: 1.0 - self.stiffness_a,
            tau: self.tau,
            safeguard_angle: self.safeguard_angle,
            direction: match self.direction {
                DirectionMode::Automatic => DirectionMode::Automatic,
                DirectionMode::Fixed(d) => DirectionMode::Fixed(-d),
            },
            refuse_coincident: self.refuse_coincident,
        }
    }
}

/// One side of a resolved contact.
#[derive(Clone, Debug)]
pub struct ContactSide {
    /// `d̄_l`, outward for this side.
    pub direction: Vector3<f64>,
    /// `m̂_l = -d̄_l`.
    pub cast: Vector3<f64>,
    /// `k̄_l`.
    pub stiffness: f64,
    /// Samples on `S` of the vertices of `M_l` (indexed by mesh vertex).
    pub samples: zones::VertexSamples,
    /// `C_l` and its exact boundary.
    pub zone: Zone,
    /// Counters of the mapping step.
    pub mapping: MappingStats,
    /// Boundary points of `M_l` found by bisection.
    pub bisected_boundaries: usize,
    /// The intersection points on this side's edges: `(edge [a, b] with a < b, t from a)`.
    pub crossings: Vec<([u32; 2], f64)>,
}

/// Time spent per step, in seconds (the paper's Table 1 columns i., m., c.).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactTimings {
    /// Intersection detection and regions.
    pub intersection: f64,
    /// Direction and mapping.
    pub mapping: f64,
    /// Potential surface, threshold and zones.
    pub zones: f64,
}

/// A resolved contact between sides A and B.
#[derive(Clone, Debug)]
pub struct Contact {
    /// `[A, B]`.
    pub sides: [ContactSide; 2],
    /// `ε_c` (Eq. 4).
    pub threshold: f64,
    /// `m_S`.
    pub mean_depth: f64,
    /// `σ_S`.
    pub depth_deviation: f64,
    /// Counters of the intersection query.
    pub intersections: IntersectionStats,
    /// Per-step timings.
    pub timings: ContactTimings,
}

/// Why a contact could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum ContactError {
    /// Invalid geometry for the intersection queries.
    #[error(transparent)]
    Intersect(#[from] IntersectError),
    /// A user direction that is zero or not finite.
    #[error("the mapping direction {0:?} is zero or not finite")]
    BadDirection([f64; 3]),
    /// The normal arrays do not match the meshes.
    #[error("expected {expected} normals, got {got}")]
    NormalCount {
        /// Vertices.
        expected: usize,
        /// Normals.
        got: usize,
    },
    /// Two separate surfaces lying on each other: at least half the faces of one of them
    /// exactly coplanar with faces of the other ([`COINCIDENT_FRACTION`]).
    #[error(
        "the surfaces coincide ({coplanar} of one's {faces} faces exactly coplanar with the \
         other's): a duplicated or layered mesh, not a contact; `[[pair]] enabled = false` or \
         `[[object]] contact = false` leaves it out"
    )]
    Coincident {
        /// Faces of that surface with a coplanar partner.
        coplanar: usize,
        /// Its faces.
        faces: usize,
    },
}

/// Fraction of either surface's faces that may be exactly coplanar with faces of the other
/// before two separate surfaces count as coincident ([`ContactError::Coincident`]). A mesh and
/// its duplicate have every face coplanar with its twin (the two fingers with a second copy
/// of their body: 13760 of 13760); a flat side resting exactly on another (a box on a floor)
/// only its few faces there; the committed scenes none. Coplanar pairs never cross under the
/// predicates' perturbation, so the pass would resolve only the few real crossings of the
/// copies, slowly, and turn thousands of faces over.
pub const COINCIDENT_FRACTION: f64 = 0.5;

/// Algorithm 1 for one pair: `None` when the surfaces do not intersect (or when the
/// intersection has no area and no direction can be derived: a grazing touch).
pub fn resolve_pair(
    a: SideFrame,
    b: SideFrame,
    params: &PairParams,
) -> Result<Option<Contact>, ContactError> {
    resolve(a, b, params, Surfaces::Separate).map(PairOutcome::into_contact)
}

/// [`resolve_pair`] for the two truncated working regions of one mesh (2021 Sec. 6: Sections
/// 4.2 to 4.4 "carried out on these truncated working regions without any modification"):
/// both sides are parts of one mesh posed with the same positions (see
/// [`crate::intersect::MeshIndex::self_contact_parts`]); face pairs sharing a vertex are not
/// intersections.
///
/// `inside`: the inside-twice test at the current positions (see [`InsideTwice`]); built here
/// from the whole mesh when `None`. Unlike [`resolve_pair`], the whole [`PairOutcome`]: the
/// self-contact pass counts the parts that intersect without a direction.
pub fn resolve_self_pair(
    part1: SideFrame,
    part2: SideFrame,
    params: &PairParams,
    inside: Option<&InsideTwice>,
) -> Result<PairOutcome, ContactError> {
    resolve(part1, part2, params, Surfaces::PartsOfOneMesh(inside))
}

/// What the two sides of a contact are.
#[derive(Clone, Copy)]
enum Surfaces<'w> {
    /// Two separate closed surfaces.
    Separate,
    /// Two parts of one closed mesh, with an optional inside-twice test of the whole mesh.
    PartsOfOneMesh(Option<&'w InsideTwice<'w>>),
}

/// What two surfaces amount to (Sec. 4): [`resolve_pair_lazily`]'s result, which
/// [`resolve_pair`] and [`resolve_self_pair`] give as their contact alone.
#[derive(Clone, Debug)]
pub enum PairOutcome {
    /// They do not intersect, or only touch.
    Apart,
    /// They intersect, but Eq. 2 gives no direction: the normals over both intersection
    /// regions cancel out (two bodies crossing each other symmetrically) and the pair sets
    /// none. The intersection is left unresolved; the caller reports it.
    NoDirection,
    /// A contact.
    Contact(Box<Contact>),
}

impl PairOutcome {
    /// The contact, if there is one.
    pub fn into_contact(self) -> Option<Contact> {
        match self {
            PairOutcome::Contact(c) => Some(*c),
            PairOutcome::Apart | PairOutcome::NoDirection => None,
        }
    }
}

/// [`resolve_pair`] with the sides' vertex normals made only when the surfaces meet:
/// `normals(k)` (side `k`, 0 or 1) is called once per side after the intersection test finds
/// a contact, never in a frame without one (where the normals, which only Sections 4.2 to 5
/// read, would cost more than the test). The same contact as [`resolve_pair`] with those
/// normals; their time counts in the intersection's.
pub fn resolve_pair_lazily<'m, 'a>(
    meshes: [&'m PosedMesh<'a>; 2],
    normals: impl Fn(usize) -> &'m [Vector3<f64>],
    params: &PairParams,
) -> Result<PairOutcome, ContactError> {
    match crossing(meshes, params)? {
        Some(c) => resolve_crossing(meshes, c, normals, params),
        None => Ok(PairOutcome::Apart),
    }
}

/// Two separate surfaces found crossing ([`crossing`]): their intersection, and when the test
/// began (its time counts in the contact's).
#[derive(Debug)]
pub struct Crossing {
    ints: Intersections,
    start: Instant,
}

/// The first step of [`resolve_pair_lazily`]: whether two separate surfaces cross along curves
/// longer than a touch (surfaces lying on each other are [`ContactError::Coincident`] when
/// `params` refuse them), without normals. [`crate::pass::ContactPass::new`] runs it on the
/// bodies' rest pose (a pair crossing there is a modeled overlap, which `pose` leaves out:
/// [`crate::pass::RestOverlaps`]), and the pass between its two steps leaves out a body turned
/// inside out.
pub fn crossing(
    meshes: [&PosedMesh; 2],
    params: &PairParams,
) -> Result<Option<Crossing>, ContactError> {
    let start = Instant::now();
    let ints = contact_curves(meshes, Surfaces::Separate, params)?;
    Ok(ints.map(|ints| Crossing { ints, start }))
}

/// The second step of [`resolve_pair_lazily`]: the contact of a [`crossing`] of `meshes`, the
/// sides' normals made now.
pub fn resolve_crossing<'m, 'a>(
    meshes: [&'m PosedMesh<'a>; 2],
    crossing: Crossing,
    normals: impl Fn(usize) -> &'m [Vector3<f64>],
    params: &PairParams,
) -> Result<PairOutcome, ContactError> {
    let [a, b] = [0, 1].map(|k| SideFrame {
        mesh: meshes[k],
        normals: normals(k),
        hittable: None,
    });
    check_normals(&a, &b)?;
    let Crossing { ints, start } = crossing;
    resolve_intersecting(a, b, ints, start, params, Surfaces::Separate)
}

/// One normal per vertex on each side.
fn check_normals(a: &SideFrame, b: &SideFrame) -> Result<(), ContactError> {
    for s in [a, b] {
        let (expected, got) = (s.mesh.positions().len(), s.normals.len());
        if expected != got {
            return Err(ContactError::NormalCount { expected, got });
        }
    }
    Ok(())
}

/// The intersection of the two sides when it amounts to a contact (curves longer than a
/// touch), else `None`; separate surfaces lying on each other refused when `params` say so.
fn contact_curves(
    meshes: [&PosedMesh; 2],
    surfaces: Surfaces,
    params: &PairParams,
) -> Result<Option<Intersections>, ContactError> {
    let ints = match surfaces {
        Surfaces::PartsOfOneMesh(_) => Intersections::self_contact(meshes[0], meshes[1])?,
        Surfaces::Separate => Intersections::between(meshes[0], meshes[1])?,
    };
    if matches!(surfaces, Surfaces::Separate) && params.refuse_coincident {
        not_coincident(meshes, &ints)?;
    }
    let touch = TOUCH_TOLERANCE * reach_of(meshes[0], meshes[1]);
    let contact = !(ints.is_empty() || curve_length(&ints) <= touch);
    Ok(contact.then_some(ints))
}

/// [`ContactError::Coincident`] when the intersection of two separate surfaces found them
/// lying on each other.
fn not_coincident(meshes: [&PosedMesh; 2], ints: &Intersections) -> Result<(), ContactError> {
    for (k, mesh) in meshes.iter().enumerate() {
        let (coplanar, faces) = (ints.stats.coplanar_faces[k], mesh.triangles().len());
        if coplanar > 0 && coplanar as f64 >= COINCIDENT_FRACTION * faces as f64 {
            return Err(ContactError::Coincident { coplanar, faces });
        }
    }
    Ok(())
}

fn resolve(
    a: SideFrame,
    b: SideFrame,
    params: &PairParams,
    surfaces: Surfaces,
) -> Result<PairOutcome, ContactError> {
    check_normals(&a, &b)?;
    let start = Instant::now();
    let Some(ints) = contact_curves([a.mesh, b.mesh], surfaces, params)? else {
        return Ok(PairOutcome::Apart);
    };
    resolve_intersecting(a, b, ints, start, params, surfaces)
}

/// Sections 4.1 to 4.4 on two sides whose intersection `ints` is a contact (its test started
/// at `start`); [`PairOutcome::NoDirection`] when Eq. 2's normals cancel out.
fn resolve_intersecting(
    a: SideFrame,
    b: SideFrame,
    ints: Intersections,
    start: Instant,
    params: &PairParams,
    surfaces: Surfaces,
) -> Result<PairOutcome, ContactError> {
    let mut regions = [
        IntersectionRegion::inside(&ints, Side::A, a.mesh)?,
        IntersectionRegion::inside(&ints, Side::B, b.mesh)?,
    ];
    // Eq. 2 integrates the normals over the exact regions the curves bound (Sec. 4.1): for
    // two parts of one mesh (separated working regions) it is taken before the inside-twice
    // test completes the regions, whose cut faces carry no clipped parts.
    let early = match (surfaces, params.direction) {
        (Surfaces::PartsOfOneMesh(_), DirectionMode::Automatic) => {
            Some(pair_direction(a, b, &regions, params)?)
        }
        _ => None,
    };
    let masks = match surfaces {
        Surfaces::PartsOfOneMesh(given) => {
            Some(parts_of_one_mesh([a, b], &ints, given, &mut regions))
        }
        Surfaces::Separate => None,
    };
    let (a, b) = match &masks {
        Some([m0, m1]) => (
            SideFrame {
                hittable: Some(m0),
                ..a
            },
            SideFrame {
                hittable: Some(m1),
                ..b
            },
        ),
        None => (a, b),
    };
    let t_int = start.elapsed().as_secs_f64();
    let dir = match early {
        Some(dir) => dir,
        None => pair_direction(a, b, &regions, params)?,
    };
    let Some(dir_a) = dir else {
        return Ok(PairOutcome::NoDirection);
    };
    let reach = 2.0 * reach_of(a.mesh, b.mesh);
    let stiffness_a = params.stiffness_a.clamp(0.0, 1.0);
    let frames = [
        zones::SurfaceFrame {
            cast: -dir_a,
            stiffness: stiffness_a,
        },
        zones::SurfaceFrame {
            cast: dir_a,
            stiffness: 1.0 - stiffness_a,
        },
    ];
    let seams = matches!(surfaces, Surfaces::PartsOfOneMesh(_));
    let mapped = mapping_regions([a, b], &regions, &frames, reach, seams);
    let t_map = start.elapsed().as_secs_f64();
    let criterion = ZoneCriterion {
        tau: params.tau,
        guard: zones::safeguard_cos(params.safeguard_angle),
    };
    let zoned = contact_zones([a, b], &ints, &mapped, frames, reach, criterion);
    let t_zone = start.elapsed().as_secs_f64();
    Ok(PairOutcome::Contact(Box::new(Contact {
        sides: zoned.sides,
        threshold: zoned.threshold,
        mean_depth: zoned.mean_depth,
        depth_deviation: zoned.depth_deviation,
        intersections: ints.stats,
        timings: ContactTimings {
            intersection: t_int,
            mapping: t_map - t_int,
            zones: t_zone - t_map,
        },
    })))
}

/// The intersection points of a side's edges, by edge then `t` (not in the map's order,
/// which changes from run to run).
fn sorted_crossings(hits: &zones::EdgeHits) -> Vec<([u32; 2], f64)> {
    let mut out: Vec<([u32; 2], f64)> = hits
        .iter()
        .flat_map(|(e, list)| list.iter().map(move |(t, _)| (*e, *t)))
        .collect();
    out.sort_unstable_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
    out
}

/// Two parts of one mesh (Sec. 6): the intersection regions `I_l` completed by the
/// inside-twice test (built here when not `given`), and, per part, the faces its rays may
/// land on: those within `HIT_REACH` edge lengths of its intersection region.
fn parts_of_one_mesh(
    parts: [SideFrame; 2],
    ints: &Intersections,
    given: Option<&InsideTwice>,
    regions: &mut [IntersectionRegion; 2],
) -> [Vec<bool>; 2] {
    let built;
    let inside = match given {
        Some(t) => t,
        None => {
            built = InsideTwice::build(parts[0].mesh.positions(), parts[0].mesh.triangles());
            &built
        }
    };
    inside_by_winding(parts, ints, inside, regions);
    let reach = HIT_REACH * inside.h;
    [
        near_region(parts[0].mesh, &regions[0], reach),
        near_region(parts[1].mesh, &regions[1], reach),
    ]
}

/// Sec. 4.2: the mapping region `M_l` of each side, cast along its `frames[l].cast` (with the
/// seam vertices of two parts of one mesh when `seams`, [`mapping::mapping_region`]).
fn mapping_regions(
    sides: [SideFrame; 2],
    regions: &[IntersectionRegion; 2],
    frames: &[zones::SurfaceFrame; 2],
    reach: f64,
    seams: bool,
) -> [MappingRegion; 2] {
    [0, 1].map(|k| {
        mapping::mapping_region(
            sides[k],
            sides[1 - k],
            &regions[k].inside,
            &regions[1 - k],
            &frames[k].cast,
            reach,
            seams,
        )
    })
}

/// The two sides' contact zones and the threshold they share (Sec. 4.3-4.4).
struct ZonedSides {
    sides: [ContactSide; 2],
    threshold: f64,
    mean_depth: f64,
    depth_deviation: f64,
}

/// What puts a sample in a contact zone: `τ` of Eq. 4 and the cosine of the safeguard angle.
#[derive(Clone, Copy, Debug)]
struct ZoneCriterion {
    tau: f64,
    guard: f64,
}

/// Sec. 4.3-4.4: the samples of each mapping region on the potential contact surface `S`,
/// the symmetric threshold of Eq. 4 (`τ`) and the zones with their exact boundaries.
fn contact_zones(
    sides: [SideFrame; 2],
    ints: &Intersections,
    mapped: &[MappingRegion; 2],
    frames: [zones::SurfaceFrame; 2],
    reach: f64,
    criterion: ZoneCriterion,
) -> ZonedSides {
    let labels = [Side::A, Side::B];
    let hits: [zones::EdgeHits; 2] =
        [0, 1].map(|k| zones::edge_hits(ints, labels[k], sides[1 - k]));
    let inputs = [0, 1].map(|k| zones::SideInput {
        own: sides[k],
        other: sides[1 - k],
        region: &mapped[k],
        hits: &hits[k],
        frame: frames[k],
        reach,
    });
    let samples: [zones::SideSamples; 2] = [0, 1].map(|k| inputs[k].samples());
    let moments = [0, 1].map(|k| side_moments(&sides[k], &samples[k]));
    let (threshold, mean_depth, depth_deviation) = zones::threshold(moments, criterion.tau);
    let zones = [0, 1].map(|k| zones::zone(&inputs[k], &samples[k], threshold, criterion.guard));
    // The samples move into the sides (no copy).
    let side = |k: usize, own: zones::SideSamples, zone: Zone| ContactSide {
        direction: -frames[k].cast,
        cast: frames[k].cast,
        stiffness: frames[k].stiffness,
        samples: own.vertices,
        zone,
        mapping: mapped[k].stats,
        bisected_boundaries: own.bisected,
        crossings: sorted_crossings(&hits[k]),
    };
    let ([s0, s1], [z0, z1]) = (samples, zones);
    ZonedSides {
        sides: [side(0, s0, z0), side(1, s1, z1)],
        threshold,
        mean_depth,
        depth_deviation,
    }
}

/// Eq. 4's depth moments of one side, over its own faces: for a part of one mesh
/// (self-contact) the part's, not the whole mesh's, whose other part's faces along the seam
/// have sampled corners at depth 0 ([`zones::depth_moments`]).
fn side_moments(side: &SideFrame, samples: &zones::SideSamples) -> [f64; 3] {
    let mesh = side.mesh;
    zones::depth_moments(mesh.triangles(), mesh.index().faces(), samples)
}

fn pair_direction(
    a: SideFrame,
    b: SideFrame,
    regions: &[IntersectionRegion; 2],
    params: &PairParams,
) -> Result<Option<Vector3<f64>>, ContactError> {
    match params.direction {
        DirectionMode::Fixed(d) => d
            .try_normalize(1e-300)
            .filter(|d| d.iter().all(|x| x.is_finite()))
            .map(Some)
            .ok_or(ContactError::BadDirection([d.x, d.y, d.z])),
        DirectionMode::Automatic => {
            let sa = direction::NormalStats::over(&regions[0], a.mesh, a.normals);
            let sb = direction::NormalStats::over(&regions[1], b.mesh, b.normals);
            Ok(direction::automatic_direction(sa.as_ref(), sb.as_ref()))
        }
    }
}

/// How far from a part's intersection region (along its edges, in mean edge lengths) the
/// other part's rays may land in a self-contact.
const HIT_REACH: f64 = 8.0;

/// Faces of `mesh` with a corner within `reach` (edge-path length) of `region` (its vertices
/// and the corners of its cut faces).
///
/// In a self-contact the farthest hit of a mapping ray (Algorithm 1 line 12) belongs near the
/// other part's intersection region: the segment from a vertex inside the other part to the
/// other surface crosses the intersection volume. The truncated parts are open and curve back
/// on themselves (a lip wraps around the mouth's corner), so an unrestricted farthest hit can
/// land on a far layer of the other part: the vertex is then mapped through the lip (measured
/// on the mouth: a jump of 4 h in one frame, temporal ratio 12.5). Not in the paper. The reach
/// is generous on purpose: on the bending capsule at 150°, 2 edges of reach leave 7
/// penetrating vertices, 4 or more none; the mouth's far layer is more than 16 edges away.
fn near_region(mesh: &PosedMesh, region: &IntersectionRegion, reach: f64) -> Vec<bool> {
    use crate::mesh::Queued;
    let (index, positions) = (mesh.index(), mesh.positions());
    let mut dist = vec![f64::INFINITY; positions.len()];
    let mut heap = std::collections::BinaryHeap::new();
    let corners = region
        .cut_faces
        .iter()
        .flat_map(|c| mesh.triangles()[c.face as usize]);
    let seeds = (0..region.inside.len() as u32).filter(|&v| region.inside[v as usize]);
    for v in seeds.chain(corners) {
        dist[v as usize] = 0.0;
        heap.push(Queued(0.0, v));
    }
    while let Some(Queued(d, v)) = heap.pop() {
        if d > dist[v as usize] {
            continue;
        }
        for &e in index.vertex_edges(v) {
            let [p, q] = index.edges()[e as usize];
            let w = if p == v { q } else { p };
            let dw = d + (positions[w as usize] - positions[v as usize]).norm();
            if dw <= reach && dw < dist[w as usize] {
                dist[w as usize] = dw;
                heap.push(Queued(dw, w));
            }
        }
    }
    mesh.triangles()
        .iter()
        .map(|t| t.iter().any(|&v| dist[v as usize].is_finite()))
        .collect()
}

/// Whether a point of a closed body with unit normal `n` lies inside it twice over (inside its
/// own side and inside another part of the same body): the generalized winding number of the
/// body at the point nudged `10⁻³ h` inward is at least 1.5.
pub fn inside_twice(
    winding: &crate::report::metrics::WindingNumber,
    p: &Point3<f64>,
    n: &Vector3<f64>,
    h: f64,
) -> bool {
    winding.query(&(p - n * (1e-3 * h))) >= 1.5
}

/// [`inside_twice`] for the vertices of one body at one frame, each vertex queried at most
/// once: the self-contact of a joint asks it for the crease cut, `I_l` and the crease zones,
/// often of the same vertices (a winding query costs microseconds near a fold).
pub struct InsideTwice<'w> {
    winding: std::borrow::Cow<'w, crate::report::metrics::WindingNumber>,
    /// The nudge length: the body's mean edge length.
    pub h: f64,
    /// Per vertex: 0 not asked yet, 1 outside, 2 inside.
    known: Vec<std::sync::atomic::AtomicU8>,
}

impl<'w> InsideTwice<'w> {
    /// The test with a tree (owned or borrowed) of the body at `positions`.
    pub fn new(
        winding: std::borrow::Cow<'w, crate::report::metrics::WindingNumber>,
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
    ) -> Self {
        Self {
            winding,
            h: crate::mesh::operators::mean_edge_length(positions, triangles),
            known: (0..positions.len())
                .map(|_| std::sync::atomic::AtomicU8::new(0))
                .collect(),
        }
    }

    /// The test with its own tree of the body at `positions`.
    pub fn build(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> InsideTwice<'static> {
        let tree = crate::report::metrics::WindingNumber::new(positions, triangles);
        InsideTwice::new(std::borrow::Cow::Owned(tree), positions, triangles)
    }

    /// Whether vertex `v` (at `p`, unit normal `n`) lies inside the body twice over.
    pub fn at(&self, v: usize, p: &Point3<f64>, n: &Vector3<f64>) -> bool {
        use std::sync::atomic::Ordering::Relaxed;
        match self.known.get(v).map(|k| k.load(Relaxed)) {
            Some(1) => false,
            Some(2) => true,
            slot => {
                let inside = inside_twice(&self.winding, p, n, self.h);
                if slot.is_some() {
                    self.known[v].store(if inside { 2 } else { 1 }, Relaxed);
                }
                inside
            }
        }
    }
}

/// Self-contact: the truncated parts are open surfaces whose intersection curves usually end
/// at the crease cut, so the flood fill of [`IntersectionRegion`] has nothing to stop it.
/// Instead, a vertex of a part is in `I_l` when it lies inside the closed body twice over:
/// the generalized winding number of the whole mesh at the vertex nudged inward by `10⁻³ h`
/// is at least 1.5 (the nudged point is inside its own body and inside the other part).
/// Faces with all corners inside are whole faces, faces with some are cut faces (without
/// sub-triangles: the self-contact direction comes from the skeleton, not from Eq. 2).
fn inside_by_winding(
    parts: [SideFrame; 2],
    ints: &Intersections,
    test: &InsideTwice,
    regions: &mut [IntersectionRegion; 2],
) {
    let positions = parts[0].mesh.positions();
    let triangles = parts[0].mesh.triangles();
    for (k, (part, region)) in parts.iter().zip(regions.iter_mut()).enumerate() {
        let index = part.mesh.index();
        let is_inside = |v: u32| {
            test.at(
                v as usize,
                &positions[v as usize],
                &part.normals[v as usize],
            )
        };
        // Every component of I_l touches the intersection curve: search from the corners of
        // the crossed faces.
        let seeds = ints
            .segments
            .iter()
            .flat_map(|s| triangles[s.faces[k] as usize]);
        let inside = inside_from(
            positions.len(),
            seeds,
            |v, out| {
                out.extend(index.vertex_edges(v).iter().map(|&e| {
                    let [a, b] = index.edges()[e as usize];
                    if a == v {
                        b
                    } else {
                        a
                    }
                }))
            },
            |v| index.uses_vertex(v) && is_inside(v),
        );
        let (mut whole, mut cut) = (Vec::new(), Vec::new());
        for &f in index.faces() {
            let n = triangles[f as usize]
                .iter()
                .filter(|&&v| inside[v as usize])
                .count();
            if n == 3 {
                whole.push(f);
            } else if n > 0 {
                cut.push(crate::intersect::CutFace {
                    face: f,
                    sub_triangles: Vec::new(),
                    holes: Vec::new(),
                });
            }
        }
        region.inside = inside;
        region.whole_faces = whole;
        region.cut_faces = cut;
    }
}

/// The vertices (ids below `n`) reached from `seeds` through vertices that pass `inside`:
/// the search crosses edges (`neighbours(v, out)` pushes the vertices next to `v`) but
/// expands only from vertices found inside, and asks `inside` once per vertex. This is how the
/// inside regions of a self-contact are found: each of their components touches the
/// intersection curve.
pub(crate) fn inside_from(
    n: usize,
    seeds: impl IntoIterator<Item = u32>,
    neighbours: impl Fn(u32, &mut Vec<u32>),
    mut inside: impl FnMut(u32) -> bool,
) -> Vec<bool> {
    let mut state = vec![0u8; n]; // 0 unseen, 1 outside, 2 inside
    let mut stack: Vec<u32> = seeds.into_iter().collect();
    while let Some(v) = stack.pop() {
        if state.get(v as usize) != Some(&0) {
            continue;
        }
        let found = inside(v);
        state[v as usize] = if found { 2 } else { 1 };
        if found {
            neighbours(v, &mut stack);
        }
    }
    state.iter().map(|&s| s == 2).collect()
}

/// Intersection curves shorter than this fraction of the scene size are a touch (surfaces
/// meeting at a point or along a degenerate curve, e.g. two vertices placed on the same point
/// of `S` by a previous pass): nothing to resolve.
pub const TOUCH_TOLERANCE: f64 = 1e-9;

/// Total length of the intersection curves.
fn curve_length(ints: &Intersections) -> f64 {
    ints.segments
        .iter()
        .map(|s| (ints.hits[s.hits[1] as usize].point - ints.hits[s.hits[0] as usize].point).norm())
        .sum()
}

/// The diagonal of the box around both surfaces (at least the smallest positive number: a
/// floor of 1e-9, until 2026-12-05, made every contact of a rig scaled below 1e-18 a touch).
fn reach_of(a: &PosedMesh, b: &PosedMesh) -> f64 {
    let boxes = [a.bvh().root_box(), b.bvh().root_box()];
    let mut it = boxes.iter().flatten();
    let Some(first) = it.next() else { return 1.0 };
    let all = it.fold(*first, |acc, x| acc.union(x));
    (all.max - all.min).norm().max(f64::MIN_POSITIVE)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::intersect::MeshIndex;

    /// A part of one mesh takes Eq. 4's moments over its own faces: the folded square's flat
    /// part, every vertex sampled at depth `1 + x`, has area 1 and mean depth 1.5, although
    /// the other part's faces (area `√2`) have sampled corners too.
    #[test]
    fn a_parts_moments_are_over_its_own_faces() {
        let (positions, triangles) = fixtures::folded_square();
        let [a, _] =
            MeshIndex::self_contact_parts(&positions, &triangles, &[1, 1, 2, 2]).expect("parts");
        let a = a.pose(&positions).expect("A");
        let normals = vec![Vector3::z(); positions.len()];
        let side = SideFrame {
            mesh: &a,
            normals: &normals,
            hittable: None,
        };
        let samples = fixtures::sampled_at_depth(&positions, |q| 1.0 + q.x);
        let [area, first, _] = side_moments(&side, &samples);
        assert!((area - 1.0).abs() < 1e-14, "area {area}");
        assert!((first / area - 1.5).abs() < 1e-14, "mean {}", first / area);
    }
}

/// Meshes shared by the unit tests of the contact steps.
#[cfg(test)]
mod fixtures {
    use super::{mapping, zones};
    use nalgebra::{Point3, Vector3};

    /// Two parts of one mesh meeting at a seam (the edge `x = z = 0`, vertices 0 and 1): the
    /// unit square in the plane `z = 0` (faces 0 and 1) and a square leaning away below it in
    /// the plane `x = z`, `x ≤ 0` (faces 2 and 3).
    pub fn folded_square() -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let p = Point3::new;
        let positions = vec![
            p(0.0, 0.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(1.0, 1.0, 0.0),
            p(-1.0, 0.0, -1.0),
            p(-1.0, 1.0, -1.0),
        ];
        (positions, vec![[0, 2, 3], [0, 3, 1], [0, 1, 5], [0, 5, 4]])
    }

    /// Every vertex sampled on a flat `S` through itself (normal `+z`) at `depth(position)`.
    pub fn sampled_at_depth(
        positions: &[Point3<f64>],
        depth: impl Fn(&Point3<f64>) -> f64,
    ) -> zones::SideSamples {
        let mut samples = zones::SideSamples {
            vertices: zones::VertexSamples::new(positions.len()),
            ..Default::default()
        };
        for (v, q) in positions.iter().enumerate() {
            let mapping = mapping::Mapping {
                target: *q,
                target_normal: -Vector3::z(),
            };
            let sample = zones::SurfaceSample {
                point: *q,
                own_normal: Vector3::z(),
                mapping,
                surface_point: *q,
                surface_normal: Vector3::z(),
                depth: depth(q),
                safeguard: 1.0,
            };
            samples.vertices.insert(v, sample);
        }
        samples
    }
}
