//! Accuracy (issue #6): hard-case scenes against ground truth, the report and conformance for
//! CI. Not built yet: both commands say so and fail.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Result};

/// `revz-tester report`.
#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// `revz-tester conformance`.
#[derive(Debug, clap::Args)]
pub struct ConformanceArgs {
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

pub fn report(_args: &ReportArgs) -> Result<ExitCode> {
    bail!("report: not built yet")
}

pub fn conformance(_args: &ConformanceArgs) -> Result<ExitCode> {
    bail!("conformance: not built yet")
}
