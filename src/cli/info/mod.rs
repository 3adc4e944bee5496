//! `contact-skin info`: what a rig holds and what is wrong with it.

use super::CliResult;
use contact_skin::mesh::{TopologyReport, WeldedMesh};
use contact_skin::rig::{self, Rig};
use serde::Serialize;
use std::path::PathBuf;

mod contact;
mod self_contact;

use contact::{
    describe_contact, describe_crossing_at_rest, print_contact, print_crossing_at_rest,
    ContactInfo, RestCrossingInfo,
};
use self_contact::{describe_self_contact, print_self_contact, SelfContactInfo};

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

#[derive(Serialize)]
struct BodyInfo {
    name: String,
    mesh: usize,
    skin: usize,
    /// A mesh without a skin, posed rigidly by its node.
    rigid: bool,
    primitives: usize,
    vertices: usize,
    welded_vertices: usize,
    seams_welded: usize,
    triangles: usize,
    max_influences: usize,
    /// Number of morph targets, applied before skinning.
    morph_targets: usize,
    /// Their default weights (the node's, else the mesh's, else zeros).
    morph_default_weights: Vec<f64>,
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
    /// The pairs of bodies crossing at rest (modeled overlaps).
    crossing_at_rest: Vec<RestCrossingInfo>,
    self_contact: Option<SelfContactInfo>,
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
            rigid: b.rigid,
            primitives: b.primitives.len(),
            vertices: b.vertex_count(),
            welded_vertices: w.vertex_count(),
            seams_welded: w.seams_welded(),
            triangles: b.triangles.len(),
            max_influences: (0..b.vertex_count())
                .map(|v| b.weights.row(v).count())
                .max()
                .unwrap_or(0),
            morph_targets: b.morphs.len(),
            morph_default_weights: b.morphs.default_weights.clone(),
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
        crossing_at_rest: Vec::new(),
        self_contact: None,
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
    info.crossing_at_rest = describe_crossing_at_rest(&a.rig, a.config.as_deref(), &rig)?;
    info.self_contact = Some(describe_self_contact(
        &a.rig,
        a.config.as_deref(),
        &rig,
        &welded,
    )?);
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
        let skin = if b.rigid {
            format!("no skin: rigid, skin {} its own", b.skin)
        } else {
            format!("skin {}", b.skin)
        };
        println!(
            "  body '{}' (mesh {}, {skin}): {} primitives, {} vertices ({} welded, {} seam copies merged), {} triangles, up to {} influences",
            b.name, b.mesh, b.primitives, b.vertices, b.welded_vertices, b.seams_welded, b.triangles, b.max_influences
        );
        if b.morph_targets > 0 {
            println!(
                "    {} morph targets (applied before skinning), default weights {:?}",
                b.morph_targets, b.morph_default_weights
            );
        }
        let t = &b.topology;
        if t.is_closed_manifold() {
            println!("    closed oriented 2-manifold");
        } else {
            println!(
                "    problems: {} boundary edges, {} non-manifold edges, {} inconsistently oriented edges, {} degenerate faces, {} duplicate faces, {} isolated vertices",
                t.boundary_edges, t.non_manifold_edges, t.inconsistent_edges, t.degenerate_faces, t.duplicate_faces, t.isolated_vertices
            );
            if t.duplicate_faces > 0 {
                println!("    (a face repeating another's vertices, as a double-sided copy does, is left out of the contact surface)");
            }
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
    print_crossing_at_rest(&info.crossing_at_rest);
    if let Some(s) = &info.self_contact {
        print_self_contact(s);
    }
    Ok(())
}

/// A length in scene units: six decimals, or six significant digits in scientific notation
/// below 1e-3 and from 1e9 (a rig in other units printed its joint sizes as `0.000000`).
fn length(x: f64) -> String {
    if x != 0.0 && (x.abs() < 1e-3 || x.abs() >= 1e9) {
        format!("{x:.5e}")
    } else {
        format!("{x:.6}")
    }
}
