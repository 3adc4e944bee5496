//! Loading a committed rig and running the contact pass on its frames, with the metrics of
//! `MEASURING.md`.

#![allow(dead_code)]

use contact_skin::frames::{self, Precomputed};
use contact_skin::mesh::operators::{mean_edge_length, vertex_normals, NormalWeighting};
use contact_skin::pass::{ContactPass, ObjectParams, PairOverride, PassOutput, RestBody};
use contact_skin::report::metrics;
use contact_skin::rig::{self, Rig};
use contact_skin::skinning::Method;
use nalgebra::{Point3, Vector3};
use std::path::Path;

/// A rig with its welded bodies, ready for the contact pass.
pub struct Loaded {
    pub rig: Rig,
    pub pre: Precomputed,
    pub times: Vec<f64>,
    pub triangles: Vec<Vec<[u32; 3]>>,
    pub h_rest: f64,
}

pub fn load(name: &str, frames: usize) -> Loaded {
    load_with(name, frames, Method::Lbs)
}

/// A committed rig skinned with `method`.
pub fn load_with(name: &str, frames: usize, method: Method) -> Loaded {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("rigs")
        .join(format!("{name}.glb"));
    let rig = rig::load(&path).expect("committed rig loads");
    prepare(rig, frames, method)
}

/// A scene generated in memory at another resolution.
pub fn load_generated(name: &str, resolution: u32, frames: usize) -> Loaded {
    let scene = contact_skin::scenes::Scene::from_name(name).expect("known scene");
    let bytes = contact_skin::scenes::build_glb(scene, resolution).expect("scene builds");
    load_bytes(name, &bytes, frames)
}

/// A GLB held in memory (LBS).
pub fn load_bytes(name: &str, bytes: &[u8], frames: usize) -> Loaded {
    let rig = rig::load_from_bytes(Path::new(name), bytes).expect("rig loads");
    prepare(rig, frames, Method::Lbs)
}

/// The committed rig `name`'s GLB bytes.
pub fn committed_bytes(name: &str) -> Vec<u8> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("rigs")
        .join(format!("{name}.glb"));
    std::fs::read(path).expect("committed rig reads")
}

/// A committed rig's copy with a strap layered across its first body's joint, as a belt is
/// modeled sunk into a waist: the faces of the band of the body within `half_width` of the
/// plane through its rest box's centre square to its longest side, copied (with their
/// vertices' skin weights and normals) and tilted by `degrees` about an axis of that plane
/// through the centre, so that the strap crosses the body's surface at rest on both sides of
/// the joint. The copy is an open surface in the same body and primitive, welded to the body
/// where the tilt's axis meets its surface (its vertices there do not move): one piece with
/// it.
pub fn strapped(name: &str, frames: usize, half_width: f64, degrees: f64) -> Loaded {
    strapped_scaled(name, frames, half_width, degrees, 1.0)
}

/// [`strapped`] with the strap also scaled by `scale` about the centre: a separate piece of
/// the mesh (no vertex of it on the body's) when `scale` is not 1, as a belt is.
pub fn strapped_scaled(
    name: &str,
    frames: usize,
    half_width: f64,
    degrees: f64,
    scale: f64,
) -> Loaded {
    let mut rig = load(name, frames).rig;
    let body = &mut rig.bodies[0];
    let strap = Strap::of(body, half_width, degrees, scale);
    let first = body.positions.len() as u32;
    for row in &strap.weights {
        body.weights.push_row(row);
    }
    body.positions.extend(&strap.positions);
    body.normals.extend(&strap.normals);
    (body.triangles).extend(strap.triangles.iter().map(|t| t.map(|v| v + first)));
    if let Some(last) = body.primitives.last_mut() {
        last.vertex_count = body.positions.len() - last.first_vertex;
        last.triangle_count = body.triangles.len() - last.first_triangle;
    }
    prepare(rig, frames, Method::Lbs)
}

/// A committed rig's copy with `n` tiny separate triangles inside its first body (each at
/// half the distance of a body vertex from the `y` axis, with that vertex's skin weights):
/// studs, teeth, a lining's bits, many of them wholly in a joint's shared region.
pub fn with_pieces_inside(name: &str, frames: usize, n: usize) -> Loaded {
    let mut rig = load(name, frames).rig;
    let body = &mut rig.bodies[0];
    let nv = body.positions.len();
    for k in 0..n {
        let v = (k * 7) % nv;
        let p = body.positions[v];
        let c = Point3::new(p.x * 0.5, p.y, p.z * 0.5);
        let (joints, weights) = body.weights.row_slices(v);
        let row: Vec<(u16, f64)> = joints
            .iter()
            .copied()
            .zip(weights.iter().copied())
            .collect();
        let first = body.positions.len() as u32;
        for d in [Vector3::x(), Vector3::y(), Vector3::z()] {
            body.positions.push(c + d * 0.01);
            body.normals.push(Vector3::x());
            body.weights.push_row(&row);
        }
        body.triangles.push([first, first + 1, first + 2]);
    }
    if let Some(last) = body.primitives.last_mut() {
        last.vertex_count = body.positions.len() - last.first_vertex;
        last.triangle_count = body.triangles.len() - last.first_triangle;
    }
    prepare(rig, frames, Method::Lbs)
}

/// The strap of [`strapped_scaled`] on its own: vertices (positions, normals, skin weight
/// rows) and triangles indexing them.
pub struct Strap {
    pub positions: Vec<Point3<f64>>,
    pub normals: Vec<Vector3<f64>>,
    pub weights: Vec<Vec<(u16, f64)>>,
    pub triangles: Vec<[u32; 3]>,
}

impl Strap {
    /// The strap of `body` (see [`strapped`] and [`strapped_scaled`]).
    pub fn of(body: &rig::Body, half_width: f64, degrees: f64, scale: f64) -> Self {
        let (lo, hi) = body.positions.iter().fold(
            (Point3::from([f64::MAX; 3]), Point3::from([f64::MIN; 3])),
            |(lo, hi), p| (lo.inf(p), hi.sup(p)),
        );
        let centre = nalgebra::center(&lo, &hi);
        let axis = (hi - lo).iamax();
        let in_band = |v: u32| (body.positions[v as usize][axis] - centre[axis]).abs() < half_width;
        let tilt = nalgebra::Rotation3::from_axis_angle(
            &Vector3::ith_axis((axis + 1) % 3),
            degrees.to_radians(),
        );
        let mut strap = Strap {
            positions: Vec::new(),
            normals: Vec::new(),
            weights: Vec::new(),
            triangles: Vec::new(),
        };
        let mut copy_of = std::collections::HashMap::new();
        for t in body
            .triangles
            .iter()
            .filter(|t| t.iter().all(|&v| in_band(v)))
        {
            let copied = t.map(|v| {
                *copy_of.entry(v).or_insert_with(|| {
                    let (joints, weights) = body.weights.row_slices(v as usize);
                    let row = joints.iter().copied().zip(weights.iter().copied());
                    strap.weights.push(row.collect());
                    let p = body.positions[v as usize];
                    strap.positions.push(centre + tilt * (p - centre) * scale);
                    strap.normals.push(tilt * body.normals[v as usize]);
                    (strap.positions.len() - 1) as u32
                })
            });
            strap.triangles.push(copied);
        }
        strap
    }
}

/// A committed rig's copy with every body made double-sided, as exporters make a two-sided
/// surface: each face listed a second time, with its winding `reversed` or not.
pub fn double_sided(name: &str, frames: usize, reversed: bool) -> Loaded {
    let mut rig = load(name, frames).rig;
    for body in &mut rig.bodies {
        let copies: Vec<[u32; 3]> = body
            .triangles
            .iter()
            .map(|&[a, b, c]| if reversed { [a, c, b] } else { [a, b, c] })
            .collect();
        body.triangles.extend(copies);
    }
    prepare(rig, frames, Method::Lbs)
}

fn prepare(rig: Rig, frames: usize, method: Method) -> Loaded {
    let pre = Precomputed::new(&rig, method);
    let times = frames::sample_times(&rig, Some(0), Some(frames)).expect("frames");
    let triangles: Vec<Vec<[u32; 3]>> = pre.welded.iter().map(|w| w.triangles.clone()).collect();
    let rest = welded_positions(&rig, &pre, 0.0, None);
    let (sum, n) = rest
        .iter()
        .zip(&triangles)
        .fold((0.0, 0usize), |(s, n), (p, t)| {
            (s + mean_edge_length(p, t), n + 1)
        });
    Loaded {
        rig,
        pre,
        times,
        triangles,
        h_rest: sum / n as f64,
    }
}

/// Welded positions of every body at time `t` of animation `anim` (rest pose for `None`).
pub fn welded_positions(
    rig: &Rig,
    pre: &Precomputed,
    t: f64,
    anim: Option<usize>,
) -> Vec<Vec<Point3<f64>>> {
    frames::welded_positions(rig, pre, anim, t)
}

impl Loaded {
    pub fn frame(&self, k: usize) -> Vec<Vec<Point3<f64>>> {
        welded_positions(&self.rig, &self.pre, self.times[k], Some(0))
    }

    /// The skinned normals of frame `k` (welded), the reference of `metrics::turned_faces`.
    pub fn frame_normals(&self, k: usize) -> Vec<Vec<Vector3<f64>>> {
        frames::evaluate(&self.rig, &self.pre, Some(0), k, self.times[k]).welded_normals(&self.pre)
    }

    pub fn pass(&self, params: Vec<ObjectParams>, overrides: Vec<PairOverride>) -> ContactPass {
        let rest = welded_positions(&self.rig, &self.pre, 0.0, None);
        let bodies: Vec<RestBody> = rest
            .iter()
            .zip(&self.triangles)
            .map(|(p, t)| (p.as_slice(), t.as_slice()))
            .collect();
        ContactPass::new(&bodies, params, overrides).expect("pass precomputes")
    }

    /// The pass with the bodies in reverse order.
    pub fn swapped_pass(&self, params: Vec<ObjectParams>) -> ContactPass {
        let rest = welded_positions(&self.rig, &self.pre, 0.0, None);
        let bodies: Vec<RestBody> = rest
            .iter()
            .zip(&self.triangles)
            .rev()
            .map(|(p, t)| (p.as_slice(), t.as_slice()))
            .collect();
        ContactPass::new(&bodies, params, vec![]).expect("pass precomputes")
    }

    /// Residual penetration of a frame (all bodies together).
    pub fn penetration(&self, positions: &[Vec<Point3<f64>>]) -> metrics::Penetration {
        let normals: Vec<Vec<Vector3<f64>>> = positions
            .iter()
            .zip(&self.triangles)
            .map(|(p, t)| vertex_normals(p, t, NormalWeighting::Area))
            .collect();
        let bodies: Vec<metrics::Body> = positions
            .iter()
            .zip(&self.triangles)
            .zip(&normals)
            .map(|((p, t), n)| (p.as_slice(), t.as_slice(), n.as_slice()))
            .collect();
        metrics::residual_penetration_bodies(&bodies, self.h_rest)
    }

    /// Relative volume error of body `b`.
    pub fn volume_error(&self, b: usize, input: &[Vec<Point3<f64>>], out: &PassOutput) -> f64 {
        let v_in = contact_skin::mesh::signed_volume(&input[b], &self.triangles[b]);
        let v_out = contact_skin::mesh::signed_volume(&out.positions[b], &self.triangles[b]);
        metrics::volume_error(v_in, v_out)
    }
}

impl Loaded {
    /// Largest distance from a zone vertex of one side (after deformation) to the other
    /// side's deformed faces touching its zone, both ways, for the contact `c` of `out`.
    pub fn zone_gap(&self, out: &PassOutput, c: usize) -> f64 {
        let summary = &out.contacts[c];
        let [a, b] = summary.bodies;
        let mut worst: f64 = 0.0;
        for (own, other, ko, kx) in [(a, b, 0, 1), (b, a, 1, 0)] {
            let zo = &summary.contact.sides[ko].zone;
            let zx = &summary.contact.sides[kx].zone;
            let points: Vec<Point3<f64>> = zo
                .vertices
                .iter()
                .map(|&v| out.positions[own][v as usize])
                .collect();
            let faces: Vec<u32> = self.triangles[other]
                .iter()
                .enumerate()
                .filter(|(_, t)| t.iter().any(|&v| zx.inside[v as usize]))
                .map(|(f, _)| f as u32)
                .collect();
            if points.is_empty() || faces.is_empty() {
                continue;
            }
            let d = metrics::surface_distance(
                &points,
                &out.positions[other],
                &self.triangles[other],
                &faces,
            );
            worst = d.into_iter().fold(worst, f64::max);
        }
        worst
    }
}

/// Object parameters with stiffness `k[i]` (last value repeated) and one `τ`.
pub fn object_params(n: usize, k: &[f64], tau: f64) -> Vec<ObjectParams> {
    (0..n)
        .map(|i| ObjectParams {
            stiffness: k[i.min(k.len() - 1)],
            tau,
            ..Default::default()
        })
        .collect()
}

/// The pseudo-stiffness giving body 0 the relative stiffness `kbar` against a body of `k = 1`.
pub fn stiffness_for(kbar: f64) -> f64 {
    if kbar >= 1.0 {
        f64::INFINITY
    } else {
        kbar / (1.0 - kbar)
    }
}

/// The self-contact pass of `l` (default regions and parameters): its parent/child pairs and
/// the `separated` regions.
pub fn self_pass_separated(
    l: &Loaded,
    separated: Vec<contact_skin::selfcontact::PairRegions>,
) -> contact_skin::selfcontact::pass::SelfContactPass {
    let rest = welded_positions(&l.rig, &l.pre, 0.0, None);
    contact_skin::selfcontact::pass::SelfContactPass::with_separated(
        &l.rig,
        &l.pre.welded,
        &rest,
        &contact_skin::selfcontact::RegionOptions::default(),
        contact_skin::selfcontact::fold::FoldParams::default(),
        &[],
        separated,
    )
    .expect("self-contact pass")
}

/// What the self-contact pass did to one pose, every body summed: its folds, penetrating
/// vertices before and after, the deepest left (in the given edge lengths), faces turned
/// against both the input and the skinning, the worst volume error, non-finite values.
#[derive(Clone, Debug, Default)]
pub struct Posed {
    pub folds: usize,
    pub before: usize,
    pub after: usize,
    pub deepest: f64,
    pub turned: usize,
    pub volume: f64,
    pub non_finite: usize,
}

impl Posed {
    /// Both poses' counts summed, the worst of their depths and volume errors.
    pub fn add(&mut self, o: &Posed) {
        self.folds += o.folds;
        self.before += o.before;
        self.after += o.after;
        self.deepest = self.deepest.max(o.deepest);
        self.turned += o.turned;
        self.volume = self.volume.max(o.volume);
        self.non_finite += o.non_finite;
    }
}

/// `pose` of `rig` skinned by `pre` and through `pass`; `h[b]`: body `b`'s edge length (the
/// metrics' unit).
pub fn pass_pose(
    rig: &Rig,
    pre: &Precomputed,
    pass: &contact_skin::selfcontact::pass::SelfContactPass,
    pose: &rig::Pose,
    h: &[f64],
) -> Posed {
    let frame = frames::evaluate_pose(rig, pre, pose, 0, 0.0);
    let input = frame.welded(pre);
    let normals = frame.welded_normals(pre);
    let mut out = input.clone();
    let report = pass
        .run_with_normals(rig, pose, &mut out, &normals)
        .expect("self-contact runs");
    let mut s = Posed {
        folds: report.folds.len(),
        ..Posed::default()
    };
    for (b, w) in pre.welded.iter().enumerate() {
        let (t, h) = (&w.triangles, h[b]);
        let pen = |x: &[Point3<f64>]| {
            let n = vertex_normals(x, t, NormalWeighting::Area);
            metrics::residual_penetration(x, t, &n, h)
        };
        let left = pen(&out[b]);
        let volume = |x: &[Point3<f64>]| contact_skin::mesh::signed_volume(x, t);
        s.add(&Posed {
            folds: 0,
            before: pen(&input[b]).vertices,
            after: left.vertices,
            deepest: left.max_depth / h,
            turned: metrics::turned_faces(t, &input[b], &out[b], &normals[b], h).turned,
            volume: metrics::volume_error(volume(&input[b]), volume(&out[b])),
            non_finite: metrics::non_finite(&out[b]),
        });
    }
    s
}
