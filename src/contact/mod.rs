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
//!
//! This file holds a pair's result and errors and Algorithm 1's sequence; beside it:
//! `params.rs` (the pair's parameters), `curves.rs` (whether the intersection is a contact),
//! `sides.rs` (each side's mapping region and zone, with the shared threshold) and
//! `self_regions.rs` (the intersection regions of two parts of one mesh, Sec. 6).

mod curves;
pub mod direction;
pub mod mapping;
mod params;
mod self_regions;
mod sides;
pub mod zones;

use crate::intersect::{
    IntersectError, IntersectionRegion, IntersectionStats, Intersections, PosedMesh, Side,
};
use curves::{contact_curves, reach_of};
pub use curves::{COINCIDENT_FRACTION, TOUCH_TOLERANCE};
pub use mapping::{Mapping, MappingRegion, MappingStats, SideFrame};
use nalgebra::Vector3;
pub use params::{DirectionMode, PairParams};
pub(crate) use self_regions::inside_from;
use self_regions::parts_of_one_mesh;
pub use self_regions::{inside_twice, InsideTwice};
use sides::{contact_zones, mapping_regions, ZoneCriterion};
use std::time::Instant;
pub use zones::{SurfaceSample, Zone, ZoneBoundaryPoint};

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
