//! The benchmark (issue #7). Not built yet: the command says so and fails.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Result};

/// `revz-tester bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

pub fn run(_args: &BenchArgs) -> Result<ExitCode> {
    bail!("bench: not built yet")
}
