//! `contact-skin info`: what a rig holds and what is wrong with it.

use super::CliResult;
use contact_skin::mesh::{TopologyReport, WeldedMesh};
use contact_skin::rig::{self, Rig};
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `info`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The rig (.gltf or .glb).
    rig: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
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
}

fn describe(rig: &Rig) -> RigInfo {
    let bodies = rig
        .bodies
        .iter()
        .map(|b| {
            let w = WeldedMesh::weld(&b.positions, &b.triangles);
            BodyInfo {
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
                topology: w.report,
            }
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
    }
}

/// Runs `info`.
pub fn run(a: &Args) -> CliResult {
    let rig = rig::load(&a.rig)?;
    let info = describe(&rig);
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
    Ok(())
}
