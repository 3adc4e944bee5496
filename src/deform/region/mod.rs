//! Deformation of one working region (2021 Sec. 5 and 7; Algorithm Part 2, lines 31-61).
//!
//! From the contact zones found on the region (one per colliding pair), per frame:
//! 1. the cut boundary `∂C` (union of the zones; exact points on edges) and the geodesic
//!    distance `φ` to it by the heat method on the cut mesh (Sec. 5.1), `u = φ / φ_max,eff`;
//! 2. the direction field (Sec. 5.2, Eq. 6): constant `d̄` with one contact, harmonic blend of
//!    the contacts' directions otherwise, then `d = normalize(w(u) d̄ + (1 - w(u)) n)`,
//!    `w(u) = (1 - u²)^6`;
//! 3. amplitude and slope (Sec. 5.3, lines 44-48) estimated at the exact boundary points and
//!    diffused harmonically (natural Neumann elsewhere);
//! 4. profile curves (lines 49-56), the bulge map (Sec. 7), the exact volume root `h_v`
//!    (line 57) and the displacement `p' = p + f2(t) d` (lines 58-60).
//!
//! One stiffness factorization (of the cut mesh's cotangent matrix) serves the Poisson step
//! of the heat method, the direction diffusion, and both parameter diffusions: the amplitude
//! and slope are imposed as Dirichlet values *at the exact boundary points* (the nodes of
//! the cut mesh) instead of at the first vertices outside (Algorithm lines 46, 48), so no
//! other matrix is factorized; a vertex just outside still receives the `α`-weighted mean of
//! its edges' values in the limit of a fine mesh.
//!
//! This file holds the region's types and its per-frame sequence; beside it: `boundary.rs`
//! (step 1's cut boundary and what is read on it), `fields.rs` (step 2's direction blend and
//! step 3's slope estimates) and `displace.rs` (step 4 but the volume root).

use super::volume::{moved_faces, RootChoice, RootKind, VolumeCubic, VolumeError};
use crate::contact::{ContactSide, SurfaceSample};
use crate::heat::{Boundary, CutProblem, HeatError, HeatParams, RegionSolver};
use crate::mesh::Region;
use crate::solve::SolveError;
use nalgebra::{Point3, Vector3};
use std::time::Instant;

mod boundary;
mod displace;
mod fields;

use boundary::{contact_directions, cut_boundary, effective_extent, intersection_distance};
use displace::{displace, Shape};
pub use fields::SLOPE_REGULARIZATION;
use fields::{blend_direction, fade_with_the_direction, slope_estimates};

/// Per-region deformation parameters (2021 Sec. 5, 7, 8).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeformParams {
    /// `φ̄`: extent of the deformation around the contact zone (scene units).
    pub extent: f64,
    /// `γ`: 0 no bulge, 1 exact volume, > 1 exaggerated.
    pub gamma: f64,
    /// `ω`: exponent of the procedural bulge map (Eq. 7).
    pub omega: f64,
    /// `λ`: floor of the normalized bulge map.
    pub bulge_floor: f64,
    /// Heat-method time step factor (`t = m h²`).
    pub heat: HeatParams,
    /// Extent floor factor `κ`: the extent used is at least `κ φ_I`, `φ_I` the largest
    /// distance from `∂C` to the intersection curve on this region (0: the paper's fixed
    /// `φ̄`). Keeps the part of the intersection region outside a small contact zone
    /// (large `τ`) in the first third of the profile, before the bulge.
    pub intersection_extent_factor: f64,
}

impl Default for DeformParams {
    fn default() -> Self {
        Self {
            extent: 1.0,
            gamma: 1.0,
            omega: 2.0,
            bulge_floor: 0.05,
            heat: HeatParams::default(),
            intersection_extent_factor: 3.0,
        }
    }
}

/// What is precomputed once per working region.
#[derive(Clone, Debug)]
pub struct WorkingRegion {
    /// Topology and symbolic factorization.
    pub solver: RegionSolver,
    /// Local index of each mesh vertex (`u32::MAX` outside the region).
    pub local_of: Vec<u32>,
    /// The region is a whole closed surface (no border): its volume is preserved.
    pub closed: bool,
}

impl WorkingRegion {
    /// Analyses the region made of `faces` of a mesh with `vertex_count` vertices.
    pub fn new(
        triangles: &[[u32; 3]],
        faces: impl IntoIterator<Item = u32>,
        vertex_count: usize,
    ) -> Result<Self, SolveError> {
        let region = Region::from_faces(triangles, faces);
        let mut local_of = vec![u32::MAX; vertex_count];
        for (l, &v) in region.vertices.iter().enumerate() {
            if let Some(slot) = local_of.get_mut(v as usize) {
                *slot = l as u32;
            }
        }
        let closed = region.is_closed();
        Ok(Self {
            solver: RegionSolver::new(region)?,
            local_of,
            closed,
        })
    }

    /// The region of a whole mesh.
    pub fn whole(triangles: &[[u32; 3]], vertex_count: usize) -> Result<Self, SolveError> {
        Self::new(triangles, 0..triangles.len() as u32, vertex_count)
    }

    fn region(&self) -> &Region {
        &self.solver.region
    }
}

/// Why a region could not be deformed.
#[derive(Debug, thiserror::Error)]
pub enum DeformError {
    /// A heat-method or diffusion solve failed.
    #[error(transparent)]
    Heat(#[from] HeatError),
    /// The volume cubic could not be assembled or solved.
    #[error(transparent)]
    Volume(#[from] VolumeError),
    /// Input arrays do not match the region.
    #[error("expected {expected} {what}, got {got}")]
    Count {
        /// What.
        what: &'static str,
        /// Expected.
        expected: usize,
        /// Given.
        got: usize,
    },
}

/// Time per step in seconds (the paper's Table 1 columns p., di., g., de.).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeformTimings {
    /// Cut mesh and heat-method distance.
    pub parametrization: f64,
    /// Direction field.
    pub directions: f64,
    /// Amplitude and slope estimation and diffusion.
    pub fields: f64,
    /// Profiles, bulge map, volume, displacement.
    pub deformation: f64,
    /// Numeric factorizations (inside the steps above; Table 1 column s.).
    pub factorization: f64,
}

/// Counters and fallbacks of one region's deformation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeformStats {
    /// Vertices in the contact zones.
    pub zone_vertices: usize,
    /// Exact boundary points.
    pub boundary_points: usize,
    /// Edges leaving a zone without an exact point (a point was placed next to the zone
    /// vertex with its values).
    pub filled_boundary_points: usize,
    /// Vertices displaced outside the zones (`0 < u < 1`).
    pub deformed_vertices: usize,
    /// `φ_max,eff` used.
    pub extent: f64,
    /// `κ φ_I`, the floor of the extent from the intersection curve.
    pub extent_floor: f64,
    /// The region's cut border bounded the extent (`φ_max,eff < φ̄`).
    pub extent_bound: bool,
    /// Slope estimates dropped (ill-posed least squares).
    pub dropped_slopes: usize,
    /// Vertices whose blended direction vanished (normal used).
    pub direction_fallbacks: usize,
    /// The bulge height `h_v`.
    pub bulge_height: f64,
    /// How `h_v` was found (`None` for an open region: no volume to preserve).
    pub root: Option<RootKind>,
}

/// The result of one region's deformation (mesh-indexed arrays).
#[derive(Clone, Debug)]
pub struct RegionDeformation {
    /// Output positions of every mesh vertex (unchanged outside the deformed part).
    pub positions: Vec<Point3<f64>>,
    /// `P`: the positions without bulge (contact zones on `S`, profiles with `v2 = 0`).
    pub base: Vec<Point3<f64>>,
    /// `Q = N_2(t) η d` per mesh vertex: the bulge per unit `h_v`.
    pub bulge_unit: Vec<Vector3<f64>>,
    /// `u` per mesh vertex (0 in the zones, 1 beyond the extent and outside the region).
    pub u: Vec<f64>,
    /// Per mesh vertex: in a contact zone.
    pub zone: Vec<bool>,
    /// Displacement direction `d` per mesh vertex (zero where not displaced).
    pub direction: Vec<Vector3<f64>>,
    /// Diffused amplitude `a` per mesh vertex (0 outside the region).
    pub amplitude: Vec<f64>,
    /// Diffused slope `s` per mesh vertex (0 outside the region).
    pub slope: Vec<f64>,
    /// The bulge part of the displacement at `γ = 1`, `h_v N_2(t) η d` (the output is
    /// `P + γ ×` this, `P` the displacement without bulge).
    pub bulge: Vec<Vector3<f64>>,
    /// Counters.
    pub stats: DeformStats,
    /// Timings.
    pub timings: DeformTimings,
}

/// A boundary point of the union of the zones, with the contact it comes from.
#[derive(Clone, Copy)]
struct CutPoint {
    contact: usize,
    /// Local vertices inside / outside.
    inside: u32,
    outside: u32,
    sample: SurfaceSample,
}

/// Inputs of one region's deformation in the current frame.
pub struct RegionFrame<'a> {
    /// Positions of the whole mesh.
    pub positions: &'a [Point3<f64>],
    /// Unit normals of the whole mesh.
    pub normals: &'a [Vector3<f64>],
    /// Triangles of the whole mesh.
    pub triangles: &'a [[u32; 3]],
    /// The contacts of this region: this region's side of each.
    pub contacts: &'a [&'a ContactSide],
    /// Optional painted bulge map per mesh vertex (multiplies `η`; negative allowed).
    pub painted: Option<&'a [f64]>,
    /// Optional mapping-direction field `d̄` per mesh vertex, replacing the contacts'
    /// directions (self-contact: `σ d̂_12`, `PIPELINE.md`).
    pub direction_field: Option<&'a [Vector3<f64>]>,
    /// Optional per mesh vertex: border vertices that do not bound the extent (self-contact:
    /// the border of `W1` inside the shared region, where the blend gives `W1` no weight).
    pub free_border: Option<&'a [bool]>,
}

/// Algorithm Part 2 for one working region.
pub fn deform_region(
    wr: &WorkingRegion,
    frame: &RegionFrame,
    params: &DeformParams,
) -> Result<RegionDeformation, DeformError> {
    let mut out = shape_region(wr, frame, params)?;
    let start = Instant::now();
    if wr.closed {
        let (h, kind) = bulge_height(frame.triangles, frame.positions, &out.base, &out.bulge_unit)?;
        out.stats.root = Some(kind);
        apply_bulge(&mut out, h, params.gamma);
    }
    out.timings.deformation += start.elapsed().as_secs_f64();
    Ok(out)
}

/// The bulge height `h_v` that makes the volume of the closed surface `triangles` with
/// positions `base + h bulge` equal to that of `rest` (2021 Sec. 5.3: the exact cubic, first
/// crossing). Without an exact root (deep penetration: the displacement directions of what is
/// left of the region point inward, so no bulge along them restores the volume), no bulge
/// (`h = 0`) rather than the closest approach, which can turn faces inside out.
pub fn bulge_height(
    triangles: &[[u32; 3]],
    rest: &[Point3<f64>],
    base: &[Point3<f64>],
    bulge: &[Vector3<f64>],
) -> Result<(f64, RootKind), DeformError> {
    let faces = moved_faces(triangles, rest, base, bulge);
    let root = VolumeCubic::assemble(triangles, &faces, rest, base, bulge)?
        .solve_with(RootChoice::FirstCrossing)?;
    let h = if root.kind == RootKind::Exact {
        root.h
    } else {
        0.0
    };
    Ok((h, root.kind))
}

/// Lines 58-60: `p' = P + γ h_v Q`.
pub fn apply_bulge(out: &mut RegionDeformation, h: f64, gamma: f64) {
    out.stats.bulge_height = h;
    out.positions = out
        .base
        .iter()
        .zip(&out.bulge_unit)
        .map(|(p, q)| p + q * (gamma * h))
        .collect();
    out.bulge = out.bulge_unit.iter().map(|q| q * h).collect();
}

/// Algorithm Part 2 without the volume solve (lines 31-56): the displaced positions without
/// bulge `P` and the bulge vectors `Q` (per unit `h_v`), for callers that solve one volume
/// over several regions (self-contact, Sec. 6). `positions` holds `P`.
pub fn shape_region(
    wr: &WorkingRegion,
    frame: &RegionFrame,
    params: &DeformParams,
) -> Result<RegionDeformation, DeformError> {
    check_counts(wr, frame)?;
    let start = Instant::now();
    let region = wr.region();
    let local_pos = region.gather(frame.positions);
    let mut stats = DeformStats::default();
    let (boundary, points) = cut_boundary(wr, frame.contacts, &mut stats);
    let mut problem = wr.solver.problem(&local_pos, &boundary)?;
    let u = parametrization(wr, frame, params, &boundary, &mut problem, &mut stats)?;
    let t_param = start.elapsed().as_secs_f64();

    let dirs = contact_directions(frame.contacts, &points);
    let dbar = if let Some(field) = frame.direction_field {
        region.gather(field)
    } else if frame.contacts.len() > 1 {
        problem.harmonic_vector(&dirs)?
    } else {
        vec![dirs.first().copied().unwrap_or_else(Vector3::zeros); region.vertex_count()]
    };
    let local_normals = region.gather(frame.normals);
    let d: Vec<Vector3<f64>> = (0..region.vertex_count())
        .map(|l| blend_direction(&dbar[l], &local_normals[l], u[l], &mut stats))
        .collect();
    let t_dir = start.elapsed().as_secs_f64();

    let (a, s) = guiding_fields(&mut problem, &points, &local_pos, &u, &d, &dbar, &mut stats)?;
    let t_fields = start.elapsed().as_secs_f64();

    let zone_local: Vec<bool> = boundary.inside.clone();
    let shape = Shape {
        positions: &local_pos,
        edge_length: problem.cut.mean_edge_length,
        u: &u,
        a: &a,
        s: &s,
        d: &d,
        zone: &zone_local,
    };
    let mut out = displace(wr, frame, params, &shape, &mut stats)?;
    let t_def = start.elapsed().as_secs_f64();

    scatter_fields(&mut out, region, frame.positions.len(), &shape);
    stats.zone_vertices = zone_local.iter().filter(|&&z| z).count();
    stats.boundary_points = points.len();
    out.stats = stats;
    out.timings = DeformTimings {
        factorization: problem.factorization_seconds(),
        parametrization: t_param,
        directions: t_dir - t_param,
        fields: t_fields - t_dir,
        deformation: t_def - t_fields,
    };
    Ok(out)
}

/// Lines 32-37: the geodesic distance `φ` from the zones' boundary (heat method, Sec. 5.1)
/// normalized by the effective extent into `u ∈ [0, 1]` (region-local; the deformable region
/// `D_l` of line 37 is where `u < 1`).
fn parametrization(
    wr: &WorkingRegion,
    frame: &RegionFrame,
    params: &DeformParams,
    boundary: &Boundary,
    problem: &mut CutProblem,
    stats: &mut DeformStats,
) -> Result<Vec<f64>, DeformError> {
    let phi = problem.distance(params.heat)?;
    let floor = params.intersection_extent_factor * intersection_distance(wr, frame.contacts, &phi);
    let extent = effective_extent(
        wr.region(),
        boundary,
        &phi,
        params.extent.max(floor),
        frame.free_border,
        stats,
    );
    stats.extent_floor = floor;
    Ok(phi.iter().map(|&p| (p / extent).clamp(0.0, 1.0)).collect())
}

/// Lines 44-48: the amplitude `a` and slope `s` fields, harmonic from the zones' boundary
/// points (Sec. 5.3 "Parameter diffusions"), the amplitude then faded where the mapping
/// field `d̄` fades ([`fade_with_the_direction`]).
fn guiding_fields(
    problem: &mut CutProblem,
    points: &[CutPoint],
    local_pos: &[Point3<f64>],
    u: &[f64],
    d: &[Vector3<f64>],
    dbar: &[Vector3<f64>],
    stats: &mut DeformStats,
) -> Result<(Vec<f64>, Vec<f64>), DeformError> {
    let amplitudes: Vec<f64> = points
        .iter()
        .map(|p| (p.sample.surface_point - p.sample.point).norm())
        .collect();
    let mut a = problem.harmonic(&amplitudes)?;
    let slopes = slope_estimates(points, local_pos, u, d, &a, stats);
    let s = problem.harmonic(&slopes)?;
    fade_with_the_direction(&mut a, dbar);
    Ok((a, s))
}

/// Scatters the region-local `u`, zone, `a` and `s` of `shape` over the `n` mesh vertices
/// (`u = 1`, no zone and 0 outside the region).
fn scatter_fields(out: &mut RegionDeformation, region: &Region, n: usize, shape: &Shape) {
    let (mut u_mesh, mut zone) = (vec![1.0; n], vec![false; n]);
    let (mut amp, mut slope) = (vec![0.0; n], vec![0.0; n]);
    for (l, &v) in region.vertices.iter().enumerate() {
        u_mesh[v as usize] = shape.u[l];
        zone[v as usize] = shape.zone[l];
        amp[v as usize] = shape.a[l];
        slope[v as usize] = shape.s[l];
    }
    out.amplitude = amp;
    out.slope = slope;
    out.u = u_mesh;
    out.zone = zone;
}

fn check_counts(wr: &WorkingRegion, frame: &RegionFrame) -> Result<(), DeformError> {
    let n = wr.local_of.len();
    for (what, got) in [
        ("positions", frame.positions.len()),
        ("normals", frame.normals.len()),
    ] {
        if got != n {
            return Err(DeformError::Count {
                what,
                expected: n,
                got,
            });
        }
    }
    for c in frame.contacts {
        if c.samples.len() != n || c.zone.inside.len() != n {
            return Err(DeformError::Count {
                what: "contact samples",
                expected: n,
                got: c.samples.len(),
            });
        }
    }
    Ok(())
}
