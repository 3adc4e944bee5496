//! `contact-skin info`: what a rig holds and what is wrong with it.

use super::CliResult;
use contact_skin::config::{self, ContactConfig};
use contact_skin::mesh::{TopologyReport, WeldedMesh};
use contact_skin::pass::DEFAULT_EXTENT_FACTOR;
use contact_skin::rig::{self, Rig};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `info`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The rig (.gltf or .glb).
    rig: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
    /// Contact configuration (TOML) to resolve against the rig. Default:
    /// `<rig stem>.contact.toml` next to the rig, when it exists.
    #[arg(long, value_name = "PATH")]
    config: Option<PathBuf>,
}

/// The resolved contact parameters of one body.
#[derive(Serialize)]
struct ObjectInfo {
    body: usize,
    name: String,
    /// Named by an `[[object]]` table (else: the defaults).
    configured: bool,
    /// `null` for a rigid body.
    stiffness: Option<f64>,
    tau: f64,
    /// `φ̄` in scene units (the pass default resolved when the file does not set it).
    extent: f64,
    gamma: f64,
    omega: f64,
    /// The painted map as written (`null`: none).
    bulge_map: Option<String>,
    /// Smallest and largest painted value (welded vertices).
    painted_range: Option<[f64; 2]>,
}

/// One configured pair.
#[derive(Serialize)]
struct PairInfo {
    bodies: [usize; 2],
    names: [String; 2],
    tau: Option<f64>,
    /// `automatic`, `constant [x, y, z]` or `N keys from t0 to t1`.
    direction: String,
}

/// The contact configuration of the rig, resolved.
#[derive(Serialize)]
struct ContactInfo {
    file: String,
    passes: usize,
    objects: Vec<ObjectInfo>,
    pairs: Vec<PairInfo>,
}

#[derive(Serialize)]
struct BodyInfo {
    name: String,
    mesh: usize,
    skin: usize,
    primitives: usize,
    vertices: usize,
    welded_vertices: usize,
    seams_welded: usize,
    triangles: usize,
    max_influences: usize,
    topology: TopologyReport,
}

#[derive(Serialize)]
struct AnimationInfo {
    index: usize,
    name: Option<String>,
    start: f64,
    end: f64,
    duration: f64,
    channels: usize,
}

#[derive(Serialize)]
struct RigInfo {
    file: String,
    nodes: usize,
    skins: Vec<(Option<String>, usize)>,
    joints: usize,
    bodies: Vec<BodyInfo>,
    animations: Vec<AnimationInfo>,
    warnings: Vec<String>,
    contact: Option<ContactInfo>,
}

fn describe(rig: &Rig, welded: &[WeldedMesh]) -> RigInfo {
    let bodies = rig
        .bodies
        .iter()
        .zip(welded)
        .map(|(b, w)| BodyInfo {
            name: b.name.clone(),
            mesh: b.mesh,
            skin: b.skin,
            primitives: b.primitives.len(),
            vertices: b.vertex_count(),
            welded_vertices: w.vertex_count(),
            seams_welded: w.seams_welded(),
            triangles: b.triangles.len(),
            max_influences: (0..b.vertex_count())
                .map(|v| b.weights.row(v).count())
                .max()
                .unwrap_or(0),
            topology: w.report.clone(),
        })
        .collect();
    let animations = rig
        .animations
        .iter()
        .enumerate()
        .map(|(index, a)| AnimationInfo {
            index,
            name: a.name.clone(),
            start: a.start,
            end: a.end,
            duration: a.duration(),
            channels: a.channels.len(),
        })
        .collect();
    RigInfo {
        file: rig.source.display().to_string(),
        nodes: rig.nodes.len(),
        skins: rig
            .skins
            .iter()
            .map(|s| (s.name.clone(), s.joints.len()))
            .collect(),
        joints: rig.skins.iter().map(|s| s.joints.len()).sum(),
        bodies,
        animations,
        warnings: rig.warnings.clone(),
        contact: None,
    }
}

/// Resolves the rig's configuration, if there is one.
fn describe_contact(
    path: &Path,
    explicit: Option<&Path>,
    rig: &Rig,
    welded: &[WeldedMesh],
) -> Result<Option<ContactInfo>, config::ConfigError> {
    let Some(cfg) = ContactConfig::for_rig(path, explicit)? else {
        return Ok(None);
    };
    let (params, overrides, passes) = cfg.resolve(rig, welded)?;
    let diagonals = config::rest_diagonals(rig);
    let mut configured: Vec<Option<&config::ObjectSpec>> = vec![None; rig.bodies.len()];
    for (i, o) in cfg.objects.iter().enumerate() {
        let b = cfg.body_index(rig, &o.name, &format!("object[{i}].name"))?;
        configured[b] = Some(o);
    }
    let objects = params
        .iter()
        .enumerate()
        .map(|(b, p)| ObjectInfo {
            body: b,
            name: rig.bodies[b].name.clone(),
            configured: configured[b].is_some(),
            stiffness: p.stiffness.is_finite().then_some(p.stiffness),
            tau: p.tau,
            extent: p.extent.unwrap_or(DEFAULT_EXTENT_FACTOR * diagonals[b]),
            gamma: p.gamma,
            omega: p.omega,
            bulge_map: configured[b].and_then(|o| o.bulge_map.clone()),
            painted_range: p.painted.as_ref().map(|v| {
                let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                [lo, hi]
            }),
        })
        .collect();
    let pairs = overrides
        .iter()
        .zip(&cfg.pairs)
        .map(|(o, spec)| PairInfo {
            bodies: o.bodies,
            names: o.bodies.map(|b| rig.bodies[b].name.clone()),
            tau: o.tau,
            direction: describe_direction(spec),
        })
        .collect();
    Ok(Some(ContactInfo {
        file: cfg.file.display().to_string(),
        passes,
        objects,
        pairs,
    }))
}

fn describe_direction(p: &config::PairSpec) -> String {
    match (&p.direction, &p.direction_keys) {
        (Some(d), _) => format!("constant {d:?}"),
        (None, Some(keys)) => {
            let t = keys.iter().map(|k| k[0]);
            let lo = t.clone().fold(f64::INFINITY, f64::min);
            let hi = t.fold(f64::NEG_INFINITY, f64::max);
            format!("{} keys from t = {lo} to t = {hi}", keys.len())
        }
        (None, None) => "automatic".into(),
    }
}

fn print_contact(c: &ContactInfo) {
    println!(
        "  contact configuration {} ({} passes per frame):",
        c.file, c.passes
    );
    for o in &c.objects {
        let k = o.stiffness.map_or("rigid".into(), |k| k.to_string());
        let map = match (&o.bulge_map, o.painted_range) {
            (Some(m), Some([lo, hi])) => format!(", bulge map {m} (values {lo} to {hi})"),
            _ => String::new(),
        };
        println!(
            "    object {} '{}'{}: stiffness {k}, tau {}, extent {:.6}, gamma {}, omega {}{map}",
            o.body,
            o.name,
            if o.configured { "" } else { " (defaults)" },
            o.tau,
            o.extent,
            o.gamma,
            o.omega
        );
    }
    for p in &c.pairs {
        let tau = p.tau.map_or("from the objects".into(), |t| t.to_string());
        println!(
            "    pair '{}' / '{}': tau {tau}, direction {}",
            p.names[0], p.names[1], p.direction
        );
    }
}

/// Runs `info`.
pub fn run(a: &Args) -> CliResult {
    let rig = rig::load(&a.rig)?;
    let welded: Vec<WeldedMesh> = rig
        .bodies
        .iter()
        .map(|b| WeldedMesh::weld(&b.positions, &b.triangles))
        .collect();
    let mut info = describe(&rig, &welded);
    info.contact = describe_contact(&a.rig, a.config.as_deref(), &rig, &welded)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&info)?);
        return Ok(());
    }
    println!(
        "{}: {} nodes, {} skins, {} joints",
        info.file,
        info.nodes,
        info.skins.len(),
        info.joints
    );
    for b in &info.bodies {
        println!(
            "  body '{}' (mesh {}, skin {}): {} primitives, {} vertices ({} welded, {} seam copies merged), {} triangles, up to {} influences",
            b.name, b.mesh, b.skin, b.primitives, b.vertices, b.welded_vertices, b.seams_welded, b.triangles, b.max_influences
        );
        let t = &b.topology;
        if t.is_closed_manifold() {
            println!("    closed oriented 2-manifold");
        } else {
            println!(
                "    problems: {} boundary edges, {} non-manifold edges, {} inconsistently oriented edges, {} degenerate faces, {} duplicate faces, {} isolated vertices",
                t.boundary_edges, t.non_manifold_edges, t.inconsistent_edges, t.degenerate_faces, t.duplicate_faces, t.isolated_vertices
            );
        }
    }
    for a in &info.animations {
        println!(
            "  animation {} '{}': {:.3} s ({} to {}), {} channels",
            a.index,
            a.name.as_deref().unwrap_or(""),
            a.duration,
            a.start,
            a.end,
            a.channels
        );
    }
    for w in &info.warnings {
        println!("  warning: {w}");
    }
    match &info.contact {
        Some(c) => print_contact(c),
        None => println!("  no contact configuration (the contact pass uses its defaults)"),
    }
    Ok(())
}
