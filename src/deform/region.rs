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

use super::bulge::{apply_painted, procedural_bulge, BulgeParams, ContactSample};
use super::profile::{bulge_basis, Profile};
use super::volume::{moved_faces, RootChoice, RootKind, VolumeCubic, VolumeError};
use crate::contact::{ContactSide, SurfaceSample};
use crate::heat::{Boundary, CutProblem, EdgePoint, HeatError, HeatParams, RegionSolver};
use crate::mesh::Region;
use crate::solve::SolveError;
use nalgebra::{Point3, Vector3};
use std::time::Instant;

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

/// The union of the contact zones as a cut boundary (local indices), with one exact point per
/// edge leaving it. Where two zones' points share an edge, the one farther from the zone
/// vertex is kept; edges leaving the union without a point get one next to the zone vertex.
fn cut_boundary(
    wr: &WorkingRegion,
    contacts: &[&ContactSide],
    stats: &mut DeformStats,
) -> (Boundary, Vec<CutPoint>) {
    let region = wr.region();
    let n = region.vertex_count();
    let mut inside = vec![false; n];
    for (l, &v) in region.vertices.iter().enumerate() {
        inside[l] = contacts.iter().any(|c| c.zone.inside[v as usize]);
    }
    let mut per_edge: Vec<Option<(f64, CutPoint)>> =
        (0..region.edges.len()).map(|_| None).collect();
    for (k, c) in contacts.iter().enumerate() {
        for bp in &c.zone.boundary {
            let (li, lj) = (
                wr.local_of[bp.inside as usize],
                wr.local_of[bp.outside as usize],
            );
            if li == u32::MAX || lj == u32::MAX || inside[lj as usize] {
                continue;
            }
            let Some(e) = region.edge(li, lj) else {
                continue;
            };
            let slot = &mut per_edge[e as usize];
            if slot.as_ref().is_none_or(|(alpha, _)| bp.alpha > *alpha) {
                *slot = Some((
                    bp.alpha,
                    CutPoint {
                        contact: k,
                        inside: li,
                        outside: lj,
                        sample: bp.sample,
                    },
                ));
            }
        }
    }
    let mut points = Vec::new();
    let mut edge_points = Vec::new();
    for (e, &[a, b]) in region.edges.iter().enumerate() {
        if inside[a as usize] == inside[b as usize] {
            continue;
        }
        let (li, lj) = if inside[a as usize] { (a, b) } else { (b, a) };
        let (alpha, cp) = match per_edge[e].take() {
            Some(x) => x,
            None => {
                stats.filled_boundary_points += 1;
                (0.0, filled_point(wr, contacts, li, lj))
            }
        };
        let alpha_first = if li == a { alpha } else { 1.0 - alpha };
        edge_points.push(EdgePoint {
            edge: e as u32,
            alpha: alpha_first,
        });
        points.push(cp);
    }
    let boundary = Boundary {
        inside,
        points: edge_points,
        vertices: Vec::new(),
    };
    (boundary, points)
}

/// A boundary point at the zone vertex itself, carrying its sample.
fn filled_point(wr: &WorkingRegion, contacts: &[&ContactSide], li: u32, lj: u32) -> CutPoint {
    let v = wr.region().vertices[li as usize] as usize;
    let (contact, sample) = contacts
        .iter()
        .enumerate()
        .find_map(|(k, c)| {
            c.zone.inside[v]
                .then(|| c.samples.get(v).map(|s| (k, *s)))
                .flatten()
        })
        .unwrap_or((
            0,
            SurfaceSample {
                point: Point3::origin(),
                own_normal: Vector3::zeros(),
                mapping: crate::contact::Mapping {
                    target: Point3::origin(),
                    target_normal: Vector3::zeros(),
                },
                surface_point: Point3::origin(),
                surface_normal: Vector3::zeros(),
                depth: 0.0,
                safeguard: 0.0,
            },
        ));
    CutPoint {
        contact,
        inside: li,
        outside: lj,
        sample,
    }
}

/// `φ_max,eff = min(φ̄, min φ over the region's open border)` (`PIPELINE.md`).
fn effective_extent(
    region: &Region,
    boundary: &Boundary,
    phi: &[f64],
    extent: f64,
    free_border: Option<&[bool]>,
    stats: &mut DeformStats,
) -> f64 {
    let free =
        |l: usize| free_border.is_some_and(|f| f.get(region.vertices[l] as usize) == Some(&true));
    let border_min = (0..region.vertex_count())
        .filter(|&l| region.border[l] && !boundary.inside[l] && !free(l))
        .map(|l| phi[l])
        .fold(f64::INFINITY, f64::min);
    let ext = if extent.is_finite() && extent > 0.0 {
        extent
    } else {
        f64::INFINITY
    };
    let eff = ext.min(border_min);
    stats.extent_bound = border_min < ext;
    let eff = if eff.is_finite() && eff > 0.0 {
        eff
    } else {
        1e-12_f64.max(ext.min(1.0))
    };
    stats.extent = eff;
    eff
}

/// `φ_I`: the largest distance from `∂C` to the intersection curve (interpolated at the
/// edge-face intersection points, so it moves continuously).
fn intersection_distance(wr: &WorkingRegion, contacts: &[&ContactSide], phi: &[f64]) -> f64 {
    let mut best: f64 = 0.0;
    for c in contacts {
        for &([a, b], t) in &c.crossings {
            let (la, lb) = (wr.local_of[a as usize], wr.local_of[b as usize]);
            if la == u32::MAX || lb == u32::MAX {
                continue;
            }
            let v = phi[la as usize] * (1.0 - t) + phi[lb as usize] * t;
            if v.is_finite() {
                best = best.max(v);
            }
        }
    }
    best
}

/// The Dirichlet direction of each cut point: its contact's `d̄`.
fn contact_directions(contacts: &[&ContactSide], points: &[CutPoint]) -> Vec<Vector3<f64>> {
    if contacts.len() == 1 {
        return vec![contacts[0].direction];
    }
    points
        .iter()
        .map(|p| contacts[p.contact].direction)
        .collect()
}

/// The amplitude where the mapping field fades: `a |d̄|` (`|d̄| ≤ 1`), so the displacement
/// fades where the directions cancel, as the direction itself does ([`blend_direction`]):
/// self-contact's `d̄ = σ d̂` across the crease (`σ → 0`), several contacts pulling apart
/// (their harmonic blend). With a single contact `|d̄| = 1` and nothing changes. Not in the
/// paper, whose Sec. 6 only turns the direction back to the normal there: the profile then
/// pushed the band along the crease along its normals by the whole amplitude diffused from the
/// zones. Measured against that (31-frame animations, worst frame): faces turned 1 → 0 on the
/// LBS capsule, 2 → 0 on the finger, 0 → 0 on the mouth, penetration unchanged there (0),
/// temporal ratios 1.78, 1.00, 1.03 → 1.02; CoR capsule 17 → 15 turned faces, 2 → 5
/// penetrating vertices, ratio 24.9 → 22.1; DQS 19 → 9, 3 → 4, 23.1 → 20.8; CesiumMan (21
/// frames, summed) 260 → 225 turned faces, 49 → 54 penetrating vertices. Object contact (the
/// fingertips on the ball, several contacts per body): temporal ratio 1.78 → 1.35, still no
/// vertex deeper than the chords (0.142 h) on the `k̄ × τ` grid, those at chord depth up to
/// 46 instead of 30 (`τ = 0.6`). The slopes at `∂C` are estimated before the fade (from the
/// zone's own amplitude).
fn fade_with_the_direction(a: &mut [f64], dbar: &[Vector3<f64>]) {
    for (x, d) in a.iter_mut().zip(dbar) {
        *x *= d.norm().min(1.0);
    }
}

/// Eq. 6 with `w(u) = (1 - u²)^6`, generalized to a mapping field `d̄` shorter than 1:
/// `d = normalize(w d̄ + (1 - w |d̄|) n)`. With a unit `d̄` (one contact) this is Eq. 6 exactly;
/// where `d̄` fades (self-contact's `σ d̂` across the crease, `σ → 0`; several contacts pulling
/// apart) the normal takes over continuously, as Sec. 6 intends ("gently fall back to the
/// normal field"), instead of `normalize(σ d̂)` flipping between `±d̂` at `u ≈ 0`, which turned
/// faces over along the crease. `w` fades where `d̄` opposes the normal (see the body); the
/// normal where the blend vanishes.
fn blend_direction(
    dbar: &Vector3<f64>,
    n: &Vector3<f64>,
    u: f64,
    stats: &mut DeformStats,
) -> Vector3<f64> {
    let w = (1.0 - u * u).powi(6);
    let strength = dbar.norm().min(1.0);
    // Where the mapping direction points into the surface (the far side of a limb, the
    // underside of a lip), `w d̄ + (1 - w) n` passes through zero as `w` falls: the normalized
    // direction swings by 180° over a few edges and the bulge raises ridges (measured on the
    // bending capsule's outer side at 150°: dihedral angles up to 47°, against 10° in the
    // input). Not in the paper: `w` is scaled by how much `d̄` faces along the normal,
    // `1 + d̂·n` clamped to [0, 1], so that the normal takes over smoothly there.
    let facing = dbar
        .try_normalize(1e-12)
        .map_or(1.0, |d| (1.0 + d.dot(n)).clamp(0.0, 1.0));
    let w = w * facing;
    let v = dbar * w + n * (1.0 - w * strength);
    match v.try_normalize(1e-6) {
        Some(d) => d,
        None => {
            stats.direction_fallbacks += 1;
            *n
        }
    }
}

/// Weight of the global slope in each point's estimate, relative to the mean denominator
/// (see the slope estimation in this module).
pub const SLOPE_REGULARIZATION: f64 = 0.25;

/// Slope estimates at the cut points (Sec. 5.3 with the corrected anchor of `PIPELINE.md`):
/// the least-squares slope of one edge is `s_ij = num / den` with
/// `num = (d·n')((b - p_j)·n' + a_j d·n') + a_j (d·m)²` and
/// `den = u_j ((d·n')² + (d·m)²)`.
///
/// `den → 0` as the boundary point nears its outside vertex (`u_j → 0`), where `num / den`
/// becomes noise that changes quickly as `∂C` slides, a pop in time. Instead of dropping those
/// edges (which also pops), each estimate is regularized toward the least-squares slope of
/// the whole boundary, `s̄ = Σ num / Σ den`:
/// `s_ij = (num + w s̄) / (den + w)`, `w = SLOPE_REGULARIZATION × mean(den)`. This is
/// continuous in every input. Estimates with `den < w` are counted in
/// [`DeformStats::dropped_slopes`].
fn slope_estimates(
    points: &[CutPoint],
    pos: &[Point3<f64>],
    u: &[f64],
    d: &[Vector3<f64>],
    a: &[f64],
    stats: &mut DeformStats,
) -> Vec<f64> {
    let terms: Vec<(f64, f64)> = points
        .iter()
        .map(|p| {
            let (i, j) = (p.inside as usize, p.outside as usize);
            let n = p.sample.surface_normal;
            let Some(e) = (pos[j] - pos[i]).try_normalize(1e-300) else {
                return (0.0, 0.0);
            };
            let dij = d[i];
            let m = (e - dij * e.dot(&dij))
                .try_normalize(1e-12)
                .unwrap_or_else(Vector3::zeros);
            let (dn, dm) = (d[j].dot(&n), d[j].dot(&m));
            let den = u[j] * (dn * dn + dm * dm);
            let num = dn * ((p.sample.surface_point - pos[j]).dot(&n) + a[j] * dn) + a[j] * dm * dm;
            if num.is_finite() && den.is_finite() && den >= 0.0 {
                (num, den)
            } else {
                (0.0, 0.0)
            }
        })
        .collect();
    let (sum_num, sum_den) = terms
        .iter()
        .fold((0.0, 0.0), |(a, b), (n, d)| (a + n, b + d));
    let global = if sum_den > 0.0 {
        sum_num / sum_den
    } else {
        0.0
    };
    let w = SLOPE_REGULARIZATION * sum_den / terms.len().max(1) as f64;
    stats.dropped_slopes = terms.iter().filter(|(_, den)| *den < w).count();
    terms
        .iter()
        .map(|&(num, den)| {
            if den + w > 0.0 {
                (num + w * global) / (den + w)
            } else {
                global
            }
        })
        .collect()
}

/// The per-vertex fields the displacement needs (local indices).
struct Shape<'a> {
    /// Region positions (local indices) and mean edge length of this frame.
    positions: &'a [Point3<f64>],
    edge_length: f64,
    u: &'a [f64],
    a: &'a [f64],
    s: &'a [f64],
    d: &'a [Vector3<f64>],
    zone: &'a [bool],
}

/// Lines 49-60: profiles, bulge map, exact volume, displacement.
fn displace(
    wr: &WorkingRegion,
    frame: &RegionFrame,
    params: &DeformParams,
    shape: &Shape,
    stats: &mut DeformStats,
) -> Result<RegionDeformation, DeformError> {
    let region = wr.region();
    let rest = frame.positions;
    let mut base = rest.to_vec();
    let mut bulge_dir = vec![Vector3::zeros(); rest.len()];
    let mut deformable: Vec<(usize, f64)> = Vec::new();
    let mut direction = vec![Vector3::zeros(); rest.len()];
    for (l, &v) in region.vertices.iter().enumerate() {
        let v = v as usize;
        if shape.zone[l] {
            if let Some(s) = zone_sample(frame.contacts, v) {
                base[v] = s.surface_point;
            }
            continue;
        }
        let u = shape.u[l];
        if u.is_nan() || u >= 1.0 {
            continue;
        }
        let profile = Profile::new(shape.a[l].max(0.0), shape.s[l]);
        let t = profile.parameter_at(u);
        base[v] = rest[v] + shape.d[l] * profile.base_ordinate(t);
        bulge_dir[v] = shape.d[l] * bulge_basis(t);
        direction[v] = shape.d[l];
        deformable.push((l, t));
    }
    stats.deformed_vertices = deformable.len();
    let eta = bulge_map(wr, frame, params, shape, &deformable);
    for (&(l, _), e) in deformable.iter().zip(&eta) {
        let v = region.vertices[l] as usize;
        bulge_dir[v] *= *e;
    }
    Ok(RegionDeformation {
        positions: base.clone(),
        base,
        bulge_unit: bulge_dir,
        bulge: vec![Vector3::zeros(); rest.len()],
        u: Vec::new(),
        zone: Vec::new(),
        direction,
        amplitude: Vec::new(),
        slope: Vec::new(),
        stats: DeformStats::default(),
        timings: DeformTimings::default(),
    })
}

/// The sample on `S` of a zone vertex (the deepest when several contacts claim it).
fn zone_sample(contacts: &[&ContactSide], v: usize) -> Option<SurfaceSample> {
    contacts
        .iter()
        .filter(|c| c.zone.inside[v])
        .filter_map(|c| c.samples.get(v))
        .max_by(|x, y| x.depth.total_cmp(&y.depth))
        .copied()
}

/// `A_j`: a third of the area of the faces around each zone vertex (local indices; 0 for
/// other vertices, which are not needed).
fn zone_areas(
    region: &Region,
    local_pos: &[Point3<f64>],
    contacts: &[&ContactSide],
    local_of: &[u32],
) -> Vec<f64> {
    let mut in_zone = vec![false; region.vertex_count()];
    for c in contacts {
        for &v in &c.zone.vertices {
            if let Some(&l) = local_of.get(v as usize).filter(|&&l| l != u32::MAX) {
                in_zone[l as usize] = true;
            }
        }
    }
    let mut area = vec![0.0; region.vertex_count()];
    for t in &region.triangles {
        if !t.iter().any(|&v| in_zone[v as usize]) {
            continue;
        }
        let [a, b, c] = t.map(|v| local_pos[v as usize]);
        let third = (b - a).cross(&(c - a)).norm() / 6.0;
        for &v in t {
            area[v as usize] += third;
        }
    }
    area
}

/// Eq. 7 at the deformable vertices, from every zone vertex of every contact.
fn bulge_map(
    wr: &WorkingRegion,
    frame: &RegionFrame,
    params: &DeformParams,
    shape: &Shape,
    deformable: &[(usize, f64)],
) -> Vec<f64> {
    let region = wr.region();
    let local_pos = shape.positions;
    let area = zone_areas(region, local_pos, frame.contacts, &wr.local_of);
    let mut samples = Vec::new();
    for c in frame.contacts {
        for &v in &c.zone.vertices {
            let (Some(s), l) = (c.samples.get(v as usize), wr.local_of[v as usize]) else {
                continue;
            };
            if l == u32::MAX {
                continue;
            }
            samples.push(ContactSample {
                position: s.point,
                area: area[l as usize],
                depth: (s.surface_point - s.point).norm(),
                push: c.cast,
            });
        }
    }
    let points: Vec<Point3<f64>> = deformable.iter().map(|&(l, _)| local_pos[l]).collect();
    let h = shape.edge_length;
    let bp = BulgeParams {
        omega: params.omega,
        floor: params.bulge_floor,
        ..BulgeParams::for_edge_length(h)
    };
    let mut eta = procedural_bulge(&points, &samples, &bp);
    if let Some(painted) = frame.painted {
        let per_point: Vec<f64> = deformable
            .iter()
            .map(|&(l, _)| {
                painted
                    .get(region.vertices[l] as usize)
                    .copied()
                    .unwrap_or(1.0)
            })
            .collect();
        apply_painted(&mut eta, &per_point);
    }
    eta
}
