//! The eight scenes: geometry, skeleton, skin weights and animation of each.
//!
//! Conventions: +Y up, lengths in meters-ish scene units, animations LINEAR with keys every
//! [`KEY_STEP`] seconds or so, starting at the rest pose. Each scene meshes all its bodies with
//! one target edge length `h = reference_length / resolution` (see [`super::Scene`]).

use super::shapes::{self, Frame, MeshData, Stadium};
use super::write::{Clip, Influence, Joint, Keys, SceneSpec, SkinnedBody, Track};
use nalgebra::{Point3, Unit, UnitQuaternion, Vector3};

/// Approximate spacing of animation keys, seconds.
const KEY_STEP: f64 = 0.25;

/// `3x² − 2x³` on `x` clamped to `[0, 1]`.
pub(crate) fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// Influence along a chain of bones on one axis: bone `k` lies between joints `k − 1` and `k`
/// (`joints` = (axial position, half width of the blend band), increasing, bands disjoint);
/// inside a band the weight moves from the lower to the upper bone by a smoothstep.
fn chain_influence(axial: f64, joints: &[(f64, f64)]) -> Influence {
    for (k, &(at, half)) in joints.iter().enumerate() {
        if (axial - at).abs() < half {
            let t = smoothstep((axial - (at - half)) / (2.0 * half));
            return Influence::blend(k as u16, k as u16 + 1, t);
        }
    }
    Influence::rigid(joints.iter().filter(|j| axial >= j.0).count() as u16)
}

/// Key times over `[0, end]`: about `KEY_STEP` apart inside the ramp `[t0, t1]`, plus `0` and
/// `end` when the ramp does not reach them.
fn ramp_times(t0: f64, t1: f64, end: f64) -> Vec<f64> {
    let steps = ((t1 - t0) / KEY_STEP).round().max(1.0) as usize;
    let mut times = Vec::with_capacity(steps + 3);
    if t0 > 0.0 {
        times.push(0.0);
    }
    times.extend((0..=steps).map(|i| t0 + (t1 - t0) * i as f64 / steps as f64));
    if t1 < end {
        times.push(end);
    }
    times
}

/// Progress of the ramp `[t0, t1]` at time `t`, in `[0, 1]`.
fn ramp_progress(t: f64, t0: f64, t1: f64) -> f64 {
    ((t - t0) / (t1 - t0)).clamp(0.0, 1.0)
}

/// A rotation channel turning `joint` (no rest rotation) by up to `degrees` about its local
/// `axis` over `[t0, t1]`, holding until `end`.
fn rotation_ramp(joint: usize, axis: Vector3<f64>, degrees: f64, span: [f64; 3]) -> Track {
    let [t0, t1, end] = span;
    let times = ramp_times(t0, t1, end);
    let axis = Unit::new_normalize(axis);
    let angle = |t: f64| degrees.to_radians() * ramp_progress(t, t0, t1);
    let keys = times
        .iter()
        .map(|&t| UnitQuaternion::from_axis_angle(&axis, angle(t)))
        .collect();
    Track {
        joint,
        times,
        keys: Keys::Rotation(keys),
    }
}

/// A translation channel moving `joint` from `from` to `to` over `[t0, t1]`, holding until `end`.
fn translation_ramp(joint: usize, from: Vector3<f64>, to: Vector3<f64>, span: [f64; 3]) -> Track {
    let [t0, t1, end] = span;
    let times = ramp_times(t0, t1, end);
    let keys = times
        .iter()
        .map(|&t| from.lerp(&to, ramp_progress(t, t0, t1)))
        .collect();
    Track {
        joint,
        times,
        keys: Keys::Translation(keys),
    }
}

/// A body bound rigidly to the single joint `joint`.
fn rigid_body(
    name: &'static str,
    mesh: MeshData,
    joint: usize,
    analytic_volume: f64,
) -> SkinnedBody {
    SkinnedBody {
        name,
        influences: vec![Influence::rigid(0); mesh.positions.len()],
        mesh,
        skin: vec![joint],
        analytic_volume,
    }
}

// ---------------------------------------------------------------------------------------------
// bending_capsule

/// Reference length of the bending capsule: `h = 0.25 / resolution`.
pub(crate) const BENDING_CAPSULE_REF: f64 = 0.25;

/// One capsule along +Y (radius 0.2, cylinder 0 to 2), joint at y = 1 blended over one radius;
/// "bend" turns the upper bone 150° about +Z, "twist" 150° about its own axis (+Y).
pub(crate) fn bending_capsule(resolution: u32) -> SceneSpec {
    let h = BENDING_CAPSULE_REF / f64::from(resolution);
    let (r, length, joint_y) = (0.2, 2.0, 1.0);
    let mesh = shapes::capsule(&Frame::along(Point3::origin(), Vector3::y()), r, length, h);
    let influences = mesh
        .positions
        .iter()
        .map(|p| chain_influence(p.y, &[(joint_y, 0.5 * r)]))
        .collect();
    let span = [0.0, 2.5, 2.5];
    SceneSpec {
        name: "bending_capsule",
        joints: vec![
            Joint::at("lower", None, Vector3::zeros()),
            Joint::at("upper", Some(0), Vector3::new(0.0, joint_y, 0.0)),
        ],
        bodies: vec![SkinnedBody {
            name: "capsule",
            mesh,
            skin: vec![0, 1],
            influences,
            analytic_volume: shapes::capsule_volume(r, length),
        }],
        clips: vec![
            Clip {
                name: "bend",
                tracks: vec![rotation_ramp(1, Vector3::z(), 150.0, span)],
            },
            Clip {
                name: "twist",
                tracks: vec![rotation_ramp(1, Vector3::y(), 150.0, span)],
            },
        ],
    }
}

// ---------------------------------------------------------------------------------------------
// finger

/// Reference length of the finger: `h = 0.12 / resolution`.
pub(crate) const FINGER_REF: f64 = 0.12;

/// Radius profile of the finger along +Y: (axial position, radius). The first and last entries
/// are the centers of the end caps; the middle ones are the MCP, PIP and DIP joints.
const FINGER_STATIONS: [(f64, f64); 5] = [
    (0.0, 0.10),
    (0.3, 0.095),
    (0.75, 0.085),
    (1.03, 0.075),
    (1.19, 0.068),
];

/// Flexion of the MCP, PIP and DIP joints at the end of "flex", degrees: each joint well past
/// contact, while the curled fingertip still clears the proximal phalanx and the metacarpal
/// (with 110° everywhere the tip would sink about 0.02 into them: a second kind of contact).
const FINGER_FLEX: [f64; 3] = [100.0, 110.0, 100.0];

/// How far the metacarpal stub of [`finger_long`] reaches behind the committed finger's: its
/// metacarpal-proximal working regions then have the size of the paper's skinned finger (its
/// Table 1: 1967 + 2951 vertices; here 1961 + 2961 at the default resolution, against
/// 1361 + 2961 for `finger.glb`).
const FINGER_LONG_EXTRA: f64 = 0.22;

/// A tapered finger along +Y: a metacarpal stub and three phalanges (0.45, 0.28, 0.22 long) on
/// one mesh, each joint blended over about one radius; "flex" bends the three joints toward +Z
/// (the palm side) together, about +X, to [`FINGER_FLEX`].
pub(crate) fn finger(resolution: u32) -> SceneSpec {
    finger_with("finger", resolution, FINGER_STATIONS)
}

/// [`finger`] with a metacarpal stub [`FINGER_LONG_EXTRA`] longer (the same joints, bands and
/// animation): the benchmark's finger at the paper's size.
pub(crate) fn finger_long(resolution: u32) -> SceneSpec {
    let mut stations = FINGER_STATIONS;
    stations[0].0 -= FINGER_LONG_EXTRA;
    finger_with("finger_long", resolution, stations)
}

/// A finger named `name` with the radius profile `stations` (end cap, MCP, PIP, DIP, end cap;
/// the metacarpal joint at the first cap's center).
fn finger_with(name: &'static str, resolution: u32, stations: [(f64, f64); 5]) -> SceneSpec {
    let h = FINGER_REF / f64::from(resolution);
    let mesh = shapes::tapered_tube(&Frame::along(Point3::origin(), Vector3::y()), &stations, h);
    let bands: Vec<(f64, f64)> = stations[1..4].iter().map(|&(y, r)| (y, 0.5 * r)).collect();
    let influences = mesh
        .positions
        .iter()
        .map(|p| chain_influence(p.y, &bands))
        .collect();
    let root = Vector3::new(0.0, stations[0].0, 0.0);
    let mut joints = vec![Joint::at("metacarpal", None, root)];
    let names = ["proximal", "middle", "distal"];
    for (k, name) in names.into_iter().enumerate() {
        // The metacarpal joint sits at station 0, each other joint at its station.
        let along = stations[k + 1].0 - stations[k].0;
        joints.push(Joint::at(name, Some(k), Vector3::new(0.0, along, 0.0)));
    }
    let tracks = (0..3)
        .map(|k| rotation_ramp(k + 1, Vector3::x(), FINGER_FLEX[k], [0.0, 3.0, 3.0]))
        .collect();
    SceneSpec {
        name,
        joints,
        bodies: vec![SkinnedBody {
            name: "finger",
            mesh,
            skin: vec![0, 1, 2, 3],
            influences,
            analytic_volume: shapes::tapered_tube_volume(&stations),
        }],
        clips: vec![Clip {
            name: "flex",
            tracks,
        }],
    }
}

// ---------------------------------------------------------------------------------------------
// two fingers

/// Radius profile of each of the two fingers (base cap center at 0, the knuckle at 0.3, the
/// tip cap at 1.0), a tapered tube like [`finger`]'s.
const TWO_FINGER_STATIONS: [(f64, f64); 3] = [(0.0, 0.1), (0.3, 0.095), (1.0, 0.075)];

/// Half the distance between the two fingers' axes: a gap of 0.02 between them at the knuckles.
const TWO_FINGER_HALF_GAP: f64 = 0.115;

/// Rotation of each finger toward the other at the end of "press", degrees: each tip moves
/// 0.061 sideways, so they cross by 0.1 at the tips.
const TWO_FINGER_PRESS: f64 = 5.0;

/// Two fingers side by side on one palm joint, pressed against each other: a contact between
/// two sibling joints' regions, which no parent/child pair holds (the paper's Fig. 14, the
/// palm "between the index and middle fingers"; `[[self_contact.separated]]`). One body of two
/// closed tubes; each blends from `palm` to its own joint over the knuckle band.
pub(crate) fn two_fingers(resolution: u32) -> SceneSpec {
    let h = FINGER_REF / f64::from(resolution);
    let stations = TWO_FINGER_STATIONS;
    let knuckle = stations[1].0;
    let mut mesh = MeshData::default();
    let mut influences = Vec::new();
    for (k, side) in [-1.0, 1.0].into_iter().enumerate() {
        let origin = Point3::new(side * TWO_FINGER_HALF_GAP, 0.0, 0.0);
        let tube = shapes::tapered_tube(&Frame::along(origin, Vector3::y()), &stations, h);
        let band = [(knuckle, 0.5 * stations[1].1)];
        influences.extend(tube.positions.iter().map(|p| {
            let mut inf = chain_influence(p.y, &band);
            // Skin joint 0 is the palm, 1 + k this finger.
            for j in inf.joints.iter_mut().filter(|j| **j == 1) {
                *j = 1 + k as u16;
            }
            inf
        }));
        append(&mut mesh, tube);
    }
    let joints = vec![
        Joint::at("palm", None, Vector3::zeros()),
        Joint::at(
            "index",
            Some(0),
            Vector3::new(-TWO_FINGER_HALF_GAP, knuckle, 0.0),
        ),
        Joint::at(
            "middle",
            Some(0),
            Vector3::new(TWO_FINGER_HALF_GAP, knuckle, 0.0),
        ),
    ];
    // The index turns toward +X (about -Z), the middle finger toward -X.
    let tracks = vec![
        rotation_ramp(1, -Vector3::z(), TWO_FINGER_PRESS, [0.0, 2.5, 2.5]),
        rotation_ramp(2, Vector3::z(), TWO_FINGER_PRESS, [0.0, 2.5, 2.5]),
    ];
    SceneSpec {
        name: "two_fingers",
        joints,
        bodies: vec![SkinnedBody {
            name: "fingers",
            mesh,
            skin: vec![0, 1, 2],
            influences,
            analytic_volume: 2.0 * shapes::tapered_tube_volume(&stations),
        }],
        clips: vec![Clip {
            name: "press",
            tracks,
        }],
    }
}

/// Appends `part` to `mesh` (its vertex indices shifted).
fn append(mesh: &mut MeshData, part: MeshData) {
    let offset = mesh.positions.len() as u32;
    mesh.positions.extend(part.positions);
    mesh.normals.extend(part.normals);
    mesh.triangles
        .extend(part.triangles.iter().map(|t| t.map(|i| i + offset)));
}

// ---------------------------------------------------------------------------------------------
// mouth

/// Reference length of the mouth: `h = 0.26 / resolution`.
pub(crate) const MOUTH_REF: f64 = 0.26;

/// The lip ring: straight lips 1.0 long, corners of radius 0.2, lips 0.3 high and 0.4 deep,
/// leaving a slit 0.1 high between them.
const LIPS: Stadium = Stadium {
    half_length: 0.5,
    corner: 0.2,
    thickness: 0.15,
    depth: 0.2,
};

/// Jaw hinge, relative to the head joint: above the mouth and well behind it.
const JAW_HINGE: [f64; 3] = [0.0, 0.2, -1.2];

/// Jaw rotation about +X at the end of "close", degrees (negative closes).
const JAW_CLOSE: f64 = -11.0;

/// Half length of the middle of each lip, which follows one bone only (|x| < 0.25).
const LIP_MIDDLE: f64 = 0.25;

/// Half width, in arc length along the lip ring's centerline, of the band over which the jaw
/// weight goes from 0 (upper lip) to 1 (lower lip) round each corner: from the corner tip, a
/// quarter arc and the straight lip beyond |x| = `LIP_MIDDLE`.
const CORNER_BAND: f64 =
    (LIPS.half_length - LIP_MIDDLE) + std::f64::consts::FRAC_PI_2 * LIPS.corner;

/// Jaw weight of a lip section centered at `center`: 0.5 at the corner tips (the
/// commissures), rising by a smoothstep of the arc length along the centerline to 1 on the
/// lower lip and falling to 0 on the upper lip, each `CORNER_BAND` away (the corners move half
/// with the jaw, as in face rigs). The shared region is then a band round each corner,
/// symmetric about the crease the closing mouth makes there, as the paper asks of a shared
/// region (Sec. 6). Weights are constant over a section, so sections move rigidly.
fn jaw_weight(center: &Point3<f64>) -> f64 {
    let beyond = center.x.abs() - LIPS.half_length;
    // Signed arc length from the corner tip, positive on the lower lip.
    let arc = if beyond > 0.0 {
        -LIPS.corner * center.y.atan2(beyond)
    } else {
        (std::f64::consts::FRAC_PI_2 * LIPS.corner - beyond).copysign(-center.y)
    };
    smoothstep(0.5 + arc / (2.0 * CORNER_BAND))
}

/// Both lips as one closed ring facing +Z (a tube swept along a stadium), on a head and a jaw
/// bone, with a slit 0.1 high at rest; "close" turns the jaw 11° about its hinge (behind the
/// mouth), lifting the middle of the lower lip 0.22: it sinks 0.12 into the upper lip, the
/// overlap fading toward the corners. The paper sets the contact direction to vertical.
pub(crate) fn mouth(resolution: u32) -> SceneSpec {
    let h = MOUTH_REF / f64::from(resolution);
    let (mesh, centers) = LIPS.mesh(h);
    let influences = centers
        .iter()
        .map(|c| Influence::blend(0, 1, jaw_weight(c)))
        .collect();
    SceneSpec {
        name: "mouth",
        joints: vec![
            Joint::at("head", None, Vector3::zeros()),
            Joint::at("jaw", Some(0), Vector3::from(JAW_HINGE)),
        ],
        bodies: vec![SkinnedBody {
            name: "lips",
            mesh,
            skin: vec![0, 1],
            influences,
            analytic_volume: LIPS.volume(),
        }],
        clips: vec![Clip {
            name: "close",
            tracks: vec![rotation_ramp(1, Vector3::x(), JAW_CLOSE, [0.0, 2.5, 3.0])],
        }],
    }
}

// ---------------------------------------------------------------------------------------------
// capsule_pair

/// Reference length of the capsule pair: `h = 0.3 / resolution`.
pub(crate) const CAPSULE_PAIR_REF: f64 = 0.3;

/// Two capsules (radius 0.25, cylinder 1.5): the lower one along X at the origin, the upper one
/// along Z, crossing it 0.0625 above contact. "press" lowers the upper capsule until it sinks
/// 0.75 radius into the lower one while turning it 30° about +Y.
pub(crate) fn capsule_pair(resolution: u32) -> SceneSpec {
    let h = CAPSULE_PAIR_REF / f64::from(resolution);
    let (r, length) = (0.25, 1.5);
    let start = Vector3::new(0.0, 2.0 * r + 0.25 * r, 0.0);
    let end = Vector3::new(0.0, 2.0 * r - 0.75 * r, 0.0);
    let lower = shapes::capsule(
        &Frame::along(Point3::new(-0.5 * length, 0.0, 0.0), Vector3::x()),
        r,
        length,
        h,
    );
    let upper_origin = Point3::from(start) + Vector3::new(0.0, 0.0, -0.5 * length);
    let upper = shapes::capsule(&Frame::along(upper_origin, Vector3::z()), r, length, h);
    let volume = shapes::capsule_volume(r, length);
    let span = [0.0, 2.5, 3.0];
    SceneSpec {
        name: "capsule_pair",
        joints: vec![
            Joint::at("lower", None, Vector3::zeros()),
            Joint::at("upper", None, start),
        ],
        bodies: vec![
            rigid_body("capsule_lower", lower, 0, volume),
            rigid_body("capsule_upper", upper, 1, volume),
        ],
        clips: vec![Clip {
            name: "press",
            tracks: vec![
                translation_ramp(1, start, end, span),
                rotation_ramp(1, Vector3::y(), 30.0, span),
            ],
        }],
    }
}

// ---------------------------------------------------------------------------------------------
// fingertips_ball

/// Reference length of the fingertips and ball: `h = 0.45 / resolution`.
pub(crate) const FINGERTIPS_BALL_REF: f64 = 0.45;

/// Fingertips: name, direction from the ball center to the contact point.
const FINGERTIPS: [(&str, [f64; 3]); 3] = [
    ("thumb", [-1.0, -0.2, 0.35]),
    ("index", [0.85, 0.45, 0.3]),
    ("middle", [0.9, -0.35, 0.35]),
];

/// Ball radius, fingertip radius and cylinder length, rest gap between a fingertip and the
/// ball, and how deep "squeeze" pushes each fingertip into the ball.
const BALL_R: f64 = 0.5;
const TIP_R: f64 = 0.17;
const TIP_LEN: f64 = 0.6;
const TIP_GAP: f64 = 0.05;
const TIP_DEPTH: f64 = 0.1;

/// A ball (radius 0.5) at the origin and three fingertip capsules (radius 0.17, cylinder 0.6)
/// around it, each tilted 35° off the ball normal toward +Z and starting 0.05 away; "squeeze"
/// pushes each fingertip 0.15 along the ball normal (0.1 into the ball), one after another.
pub(crate) fn fingertips_ball(resolution: u32) -> SceneSpec {
    let h = FINGERTIPS_BALL_REF / f64::from(resolution);
    let ball = shapes::capsule(
        &Frame::along(Point3::origin(), Vector3::y()),
        BALL_R,
        0.0,
        h,
    );
    let mut joints = vec![Joint::at("ball", None, Vector3::zeros())];
    let ball_volume = shapes::capsule_volume(BALL_R, 0.0);
    let mut bodies = vec![rigid_body("ball", ball, 0, ball_volume)];
    let mut tracks = Vec::new();
    for (i, &(name, dir)) in FINGERTIPS.iter().enumerate() {
        let (joint, body, track) = fingertip(i + 1, name, Vector3::from(dir), h);
        joints.push(joint);
        bodies.push(body);
        tracks.push(track);
    }
    SceneSpec {
        name: "fingertips_ball",
        joints,
        bodies,
        clips: vec![Clip {
            name: "squeeze",
            tracks,
        }],
    }
}

/// Fingertip number `joint` (1-based) approaching the ball along `-dir`: its bone (at the
/// center of the cap facing the ball, +Y along the finger), its body and its press track
/// (starting 0.4 s after the previous fingertip's).
fn fingertip(
    joint: usize,
    name: &'static str,
    dir: Vector3<f64>,
    h: f64,
) -> (Joint, SkinnedBody, Track) {
    let d = dir.normalize();
    let tangent = (Vector3::z() - d * d.z).normalize();
    let axis = (d + tangent * 35f64.to_radians().tan()).normalize();
    let origin = d * (BALL_R + TIP_R + TIP_GAP);
    let rotation = UnitQuaternion::rotation_between(&Vector3::y(), &axis)
        .unwrap_or_else(UnitQuaternion::identity);
    let mesh = shapes::capsule(&Frame::along(Point3::from(origin), axis), TIP_R, TIP_LEN, h);
    let body = rigid_body(name, mesh, joint, shapes::capsule_volume(TIP_R, TIP_LEN));
    let t0 = 0.4 * (joint - 1) as f64;
    let pressed = origin - d * (TIP_GAP + TIP_DEPTH);
    let track = translation_ramp(joint, origin, pressed, [t0, t0 + 1.6, 3.0]);
    let bone = Joint {
        name,
        parent: None,
        translation: origin,
        rotation,
    };
    (bone, body, track)
}

// ---------------------------------------------------------------------------------------------
// sphere_plane

/// Reference length of the sphere and plane: `h = 0.6 / resolution`.
pub(crate) const SPHERE_PLANE_REF: f64 = 0.6;

/// A slab 3 × 0.4 × 3 (top face at y = 0) and a sphere of radius 0.5 starting 0.05 above it;
/// "press" lowers the sphere 0.3, i.e. 0.25 (half a radius) into the slab, less than its
/// thickness.
pub(crate) fn sphere_plane(resolution: u32) -> SceneSpec {
    let h = SPHERE_PLANE_REF / f64::from(resolution);
    let (r, gap, depth) = (0.5, 0.05, 0.25);
    let size = Vector3::new(3.0, 0.4, 3.0);
    let slab = shapes::slab(Point3::new(-1.5, -0.4, -1.5), size, h);
    let start = Vector3::new(0.0, r + gap, 0.0);
    let sphere = shapes::capsule(&Frame::along(Point3::from(start), Vector3::y()), r, 0.0, h);
    SceneSpec {
        name: "sphere_plane",
        joints: vec![
            Joint::at("plane", None, Vector3::zeros()),
            Joint::at("sphere", None, start),
        ],
        bodies: vec![
            rigid_body("plane", slab, 0, size.x * size.y * size.z),
            rigid_body("sphere", sphere, 1, shapes::capsule_volume(r, 0.0)),
        ],
        clips: vec![Clip {
            name: "press",
            tracks: vec![translation_ramp(
                1,
                start,
                Vector3::new(0.0, r - depth, 0.0),
                [0.0, 2.5, 3.0],
            )],
        }],
    }
}
