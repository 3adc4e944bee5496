//! The contact pass as the command line runs it: configuration discovery, the one
//! [`ContactPass`] of a run, per-frame evaluation (skinning → welded → pass → file vertices),
//! the `frame_NNNN.diag.json` diagnostics and median stage timings.

use contact_skin::config::ContactConfig;
use contact_skin::frames::{self, Frame, Precomputed};
use contact_skin::pass::{ContactPass, PassOutput, RestBody, StageTimings};
use contact_skin::rig::Rig;
use nalgebra::Point3;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Boxed error of the command line.
pub type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// The contact pass of one run, shared by every frame.
pub struct ContactRun {
    /// The precomputed pass.
    pub pass: ContactPass,
    /// The configuration file used, if any.
    pub config: Option<PathBuf>,
    /// Passes per frame.
    pub passes: usize,
}

impl ContactRun {
    /// Finds the configuration (`config`, else `<rig stem>.contact.toml` next to the rig, else
    /// defaults), resolves it against `rig` and precomputes the pass on the rest pose.
    /// `passes` overrides the configuration's.
    pub fn new(
        rig_path: &Path,
        rig: &Rig,
        pre: &Precomputed,
        config: Option<&Path>,
        passes: Option<usize>,
    ) -> Result<Self, BoxError> {
        let found = ContactConfig::for_rig(rig_path, config)?;
        let used = found.as_ref().map(|c| c.file.clone());
        let (params, overrides, file_passes) =
            found.unwrap_or_default().resolve(rig, &pre.welded)?;
        let rest = rest_welded(rig, pre);
        let bodies: Vec<RestBody> = rest
            .iter()
            .zip(&pre.welded)
            .map(|(p, w)| (p.as_slice(), w.triangles.as_slice()))
            .collect();
        let passes = passes.unwrap_or(file_passes).max(1);
        let pass = ContactPass::new(&bodies, params, overrides)
            .map_err(|e| {
                format!(
                    "{}: contact pass: {e} (--no-contact writes plain skinning)",
                    rig_path.display()
                )
            })?
            .with_passes(passes);
        Ok(Self {
            pass,
            config: used,
            passes,
        })
    }
}

/// Welded positions of every body at the rest pose (skinned with `pre`'s method).
pub fn rest_welded(rig: &Rig, pre: &Precomputed) -> Vec<Vec<Point3<f64>>> {
    welded(&frames::evaluate(rig, pre, None, 0, 0.0), pre)
}

/// Welded positions of every body of a frame.
pub fn welded(frame: &Frame, pre: &Precomputed) -> Vec<Vec<Point3<f64>>> {
    frame
        .bodies
        .iter()
        .zip(&pre.welded)
        .map(|(b, w)| w.gather(&b.positions))
        .collect()
}

/// One frame through the contact pass.
pub struct ContactFrame {
    /// The frame with the pass's positions on every file vertex.
    pub frame: Frame,
    /// The skinned positions (file vertices), before the pass.
    pub input: Frame,
    /// The pass's output (welded vertices).
    pub output: PassOutput,
}

/// Skins frame `index` at time `t` and runs the pass on it. Every file copy of a welded vertex
/// the pass moved gets the pass's position; the others keep their skinned position, so a
/// frame without contact is exactly the skinning result.
pub fn run_frame(
    rig: &Rig,
    pre: &Precomputed,
    pass: &ContactPass,
    animation: Option<usize>,
    index: usize,
    t: f64,
) -> Result<ContactFrame, String> {
    let input = frames::evaluate(rig, pre, animation, index, t);
    let before = welded(&input, pre);
    let output = pass
        .run_at(&before, t)
        .map_err(|e| format!("frame {index} (t = {t}): contact pass: {e}"))?;
    let mut frame = input.clone();
    for (b, body) in frame.bodies.iter_mut().enumerate() {
        let w = &pre.welded[b];
        let (old, new) = (&before[b], &output.positions[b]);
        for (f, p) in body.positions.iter_mut().enumerate() {
            let v = w.to_welded[f] as usize;
            if new[v] != old[v] {
                *p = new[v];
            }
        }
    }
    Ok(ContactFrame {
        frame,
        input,
        output,
    })
}

// ---------------------------------------------------------------------------------------------
// Diagnostics

/// `frame_NNNN.diag.json`.
#[derive(Serialize)]
pub struct FrameDiagnostics {
    /// Frame index.
    pub frame: usize,
    /// Animation time (s).
    pub time: f64,
    /// Per body, per file vertex.
    pub bodies: Vec<BodyDiagnostics>,
    /// Contacts of the first pass.
    pub contacts: Vec<ContactDiagnostics>,
    /// Contacts resolved by later passes.
    pub later_contacts: usize,
    /// Stage timings in seconds.
    pub timings_s: StageTimings,
}

/// Diagnostics of one body, one entry per file vertex (scattered from welded vertices).
#[derive(Serialize)]
pub struct BodyDiagnostics {
    /// Body index.
    pub index: usize,
    /// Body name.
    pub name: String,
    /// File vertices.
    pub vertices: usize,
    /// The body was deformed.
    pub deformed: bool,
    /// `u` (1 where undeformed).
    pub u: Vec<f64>,
    /// 1 in a contact zone, else 0.
    pub zone: Vec<u8>,
    /// Output − input position.
    pub displacement: Vec<[f64; 3]>,
    /// Amplitude field `a`.
    pub amplitude: Vec<f64>,
    /// Slope field `s`.
    pub slope: Vec<f64>,
    /// Bulge part of the displacement at `γ = 1`.
    pub bulge: Vec<[f64; 3]>,
}

/// One contact between two bodies.
#[derive(Serialize)]
pub struct ContactDiagnostics {
    /// The two bodies (the first is side A).
    pub bodies: [usize; 2],
    /// Their names.
    pub names: [String; 2],
    /// `ε_c` (Eq. 4).
    pub threshold: f64,
    /// `m_S`.
    pub mean_depth: f64,
    /// `σ_S`.
    pub depth_deviation: f64,
    /// Welded vertices in each side's contact zone.
    pub zone_sizes: [usize; 2],
    /// Mapping direction of the first body (outward for it).
    pub direction: [f64; 3],
}

/// The diagnostics of a frame, per file vertex.
pub fn diagnostics(rig: &Rig, pre: &Precomputed, c: &ContactFrame) -> FrameDiagnostics {
    let bodies = rig
        .bodies
        .iter()
        .enumerate()
        .map(|(b, body)| {
            let w = &pre.welded[b];
            let d = &c.output.diagnostics[b];
            let v3 = |v: &nalgebra::Vector3<f64>| [v.x, v.y, v.z];
            BodyDiagnostics {
                index: b,
                name: body.name.clone(),
                vertices: body.vertex_count(),
                deformed: d.stats.is_some(),
                u: w.scatter(&d.u),
                zone: w.scatter(&d.zone).into_iter().map(u8::from).collect(),
                displacement: c.frame.bodies[b]
                    .positions
                    .iter()
                    .zip(&c.input.bodies[b].positions)
                    .map(|(o, i)| v3(&(o - i)))
                    .collect(),
                amplitude: w.scatter(&d.amplitude),
                slope: w.scatter(&d.slope),
                bulge: w.scatter(&d.bulge).iter().map(v3).collect(),
            }
        })
        .collect();
    let contacts = c
        .output
        .contacts
        .iter()
        .map(|s| {
            let k = &s.contact;
            let d = k.sides[0].direction;
            ContactDiagnostics {
                bodies: s.bodies,
                names: s.bodies.map(|b| rig.bodies[b].name.clone()),
                threshold: k.threshold,
                mean_depth: k.mean_depth,
                depth_deviation: k.depth_deviation,
                zone_sizes: [
                    k.sides[0].zone.vertices.len(),
                    k.sides[1].zone.vertices.len(),
                ],
                direction: [d.x, d.y, d.z],
            }
        })
        .collect();
    FrameDiagnostics {
        frame: c.frame.index,
        time: c.frame.time,
        bodies,
        contacts,
        later_contacts: c.output.later_contacts,
        timings_s: c.output.timings,
    }
}

/// The diagnostics file name of frame `index`: `frame_NNNN.diag.json`.
pub fn diagnostics_file_name(index: usize) -> String {
    format!("frame_{index:04}.diag.json")
}

// ---------------------------------------------------------------------------------------------
// Timings

/// Median per-stage time in milliseconds (the paper's Table 1 columns).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct StageMs {
    /// i.: intersection detection and regions.
    pub intersection: f64,
    /// m.: direction and mapping.
    pub mapping: f64,
    /// c.: potential surface and contact zones.
    pub zones: f64,
    /// p.: parametrization.
    pub parametrization: f64,
    /// di.: direction field.
    pub directions: f64,
    /// g.: amplitude and slope diffusion.
    pub fields: f64,
    /// de.: profiles, bulge, volume, displacement.
    pub deformation: f64,
    /// The whole pass.
    pub wall: f64,
}

/// Median of each stage over `timings` (in ms).
pub fn median_stages(timings: &[StageTimings]) -> StageMs {
    let m = |f: fn(&StageTimings) -> f64| median(timings.iter().map(f).collect()) * 1e3;
    StageMs {
        intersection: m(|t| t.intersection),
        mapping: m(|t| t.mapping),
        zones: m(|t| t.zones),
        parametrization: m(|t| t.parametrization),
        directions: m(|t| t.directions),
        fields: m(|t| t.fields),
        deformation: m(|t| t.deformation),
        wall: m(|t| t.wall),
    }
}

/// Median of a list (0 for an empty one).
pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}
