//! Command-line interface: argument parsing and dispatch to one module per subcommand.

mod contact;
mod demo;
mod info;
mod measure;
mod pose;

use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// Poses rigged glTF characters and resolves their contacts geometrically.
#[derive(Parser, Debug)]
#[command(name = "contact-skin", version, about, long_about = None)]
pub struct Cli {
    /// Number of worker threads, at least 1 (default: all cores).
    #[arg(long, global = true, value_parser = clap::value_parser!(u64).range(1..=4096))]
    threads: Option<u64>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Describe a rig: meshes, vertices, joints, animations, welded seams, problems found, its
    /// contact configuration resolved (objects and pairs) and the joint pairs of self-contact.
    Info(info::Args),
    /// Pose a rig through an animation, resolve the contacts between its objects (unless
    /// --no-contact) and, with --self-contact, the joints folding into themselves, and write
    /// the frames (OBJ per frame, or one baked glb).
    Pose(pose::Args),
    /// Write the procedural test scenes (bending capsule, finger, mouth, ...) as glb files.
    Generate(GenerateArgs),
    /// Run the built-in scenes end to end (skinning; the contact pass on the scenes of
    /// separate objects, the self-contact pass on the single-body ones) and print what was
    /// done, with timings and metrics.
    Demo(demo::Args),
}

/// Arguments of `generate`.
#[derive(clap::Args, Debug)]
struct GenerateArgs {
    /// Output folder.
    #[arg(long, short, default_value = "rigs")]
    out: PathBuf,
    /// Tessellation resolution, 1 to 64 (see rigs/README.md for the mapping).
    #[arg(
        long,
        short,
        default_value_t = contact_skin::scenes::DEFAULT_RESOLUTION,
        value_parser = clap::value_parser!(u32).range(
            contact_skin::scenes::MIN_RESOLUTION as i64..=contact_skin::scenes::MAX_RESOLUTION as i64
        )
    )]
    resolution: u32,
    /// Only these scenes (default: all; repeat the flag for several).
    #[arg(long = "scene", value_parser = scene_names())]
    scenes: Vec<String>,
}

/// The names `--scene` takes: every scene's ([`contact_skin::scenes::Scene::ALL`]), listed by
/// `generate --help` (its list, written by hand, had missed `two_fingers`).
fn scene_names() -> clap::builder::PossibleValuesParser {
    use contact_skin::scenes::Scene;
    clap::builder::PossibleValuesParser::new(Scene::ALL.map(Scene::name))
}

/// Creates an output folder (and its parents), naming it in the error (a file in the way
/// otherwise reads only "File exists").
fn create_folder(path: &std::path::Path) -> Result<(), String> {
    std::fs::create_dir_all(path)
        .map_err(|e| format!("{}: cannot create the output folder: {e}", path.display()))
}

/// A `--frames` count as the sampler takes it (a count beyond `usize` saturates, and the
/// sampler refuses it as too many).
fn frame_count(n: u64) -> usize {
    usize::try_from(n).unwrap_or(usize::MAX)
}

/// Parses the command line, runs it and returns the process exit code.
pub fn run() -> i32 {
    let cli = Cli::parse();
    if let Some(n) = cli.threads {
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n as usize)
            .build_global()
        {
            eprintln!("warning: cannot set the thread count: {e}");
        }
    }
    let result = match cli.command {
        Command::Info(a) => info::run(&a),
        Command::Pose(a) => pose::run(&a),
        Command::Generate(a) => generate(&a),
        Command::Demo(a) => demo::run(&a),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            let mut source = e.source();
            while let Some(s) = source {
                eprintln!("  caused by: {s}");
                source = s.source();
            }
            1
        }
    }
}

/// Errors of the command-line front end.
pub type CliResult = Result<(), Box<dyn std::error::Error + Send + Sync>>;

fn generate(a: &GenerateArgs) -> CliResult {
    use contact_skin::scenes::{self, Scene};
    let list: Vec<Scene> = if a.scenes.is_empty() {
        Scene::ALL.to_vec()
    } else {
        a.scenes
            .iter()
            .map(|n| Scene::from_name(n).ok_or_else(|| format!("unknown scene '{n}'")))
            .collect::<Result<_, _>>()?
    };
    create_folder(&a.out)?;
    for s in list {
        let path = scenes::write(s, a.resolution, &a.out)?;
        println!("wrote {} ({})", path.display(), s.description());
    }
    Ok(())
}
