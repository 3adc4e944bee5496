//! Writes the seven procedural test scenes as `.glb` files.
//!
//! ```text
//! cargo run --release --example generate_rigs -- [DIR] [RESOLUTION]
//! ```
//! `DIR` defaults to `rigs`, `RESOLUTION` to [`contact_skin::scenes::DEFAULT_RESOLUTION`].
//! Prints one line per file with its bodies' vertex and triangle counts.

use contact_skin::scenes::{self, Scene, DEFAULT_RESOLUTION};
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().unwrap_or_else(|| "rigs".into()));
    let resolution = match args.next().map(|s| s.parse::<u32>()) {
        None => DEFAULT_RESOLUTION,
        Some(Ok(r)) => r,
        Some(Err(e)) => {
            eprintln!("generate_rigs: RESOLUTION must be a positive integer: {e}");
            return ExitCode::from(2);
        }
    };
    match run(&dir, resolution) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("generate_rigs: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(dir: &std::path::Path, resolution: u32) -> Result<(), scenes::SceneError> {
    for scene in Scene::ALL {
        let path = scenes::write(scene, resolution, dir)?;
        let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        let bodies = scenes::summarize(scene, resolution)?;
        let parts: Vec<String> = bodies
            .iter()
            .map(|b| format!("{} {} v / {} t", b.name, b.vertices, b.triangles))
            .collect();
        let total: usize = bodies.iter().map(|b| b.vertices).sum();
        println!(
            "{} ({} bytes, {} vertices): {}",
            path.display(),
            bytes,
            total,
            parts.join(", ")
        );
    }
    Ok(())
}
