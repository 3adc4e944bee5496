//! `contact-skin demo` (placeholder until the scenes land).
use super::CliResult;
use std::path::PathBuf;

/// Arguments of `demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output folder.
    #[arg(long, short, default_value = "demo-out")]
    out: PathBuf,
}

/// Runs `demo`.
pub fn run(_a: &Args) -> CliResult {
    Ok(())
}
