//! `haze merge`: partial renders of one scene into the image of the union of their ranges.

use crate::shared::check_output_dir;
use anyhow::{Context, Result, bail};
use clap::Args;
use haze::Partial;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Args)]
pub(crate) struct MergeArgs {
    /// Partial renders (.hpr), in any order.
    #[arg(required = true, value_name = "PART")]
    parts: Vec<PathBuf>,
    /// Output: .exr (OpenEXR with a PNG preview beside it), .png, or .hpr (a merged partial
    /// render, to merge or resume further).
    #[arg(short = 'o', long, value_name = "FILE")]
    output: PathBuf,
    /// Exposure multiplier for the PNG preview.
    #[arg(long, default_value_t = 1.0, value_name = "E")]
    exposure: f32,
}

pub(crate) fn run(args: MergeArgs) -> Result<ExitCode> {
    let ext = args.output.extension().and_then(|e| e.to_str()).unwrap_or_default().to_string();
    if !matches!(ext.as_str(), "exr" | "png" | "hpr") {
        bail!("--output {}: name it .exr, .png or .hpr", args.output.display());
    }
    if !(args.exposure.is_finite() && args.exposure > 0.0) {
        bail!("--exposure must be a positive number, got {}", args.exposure);
    }
    check_output_dir("--output", &args.output)?;
    let mut parts = Vec::new();
    for p in &args.parts {
        parts.push(Partial::read(p)?);
    }
    for (p, part) in args.parts.iter().zip(&parts).skip(1) {
        parts[0]
            .check_compatible(part)
            .map_err(|m| anyhow::anyhow!("{} and {}: {m}", args.parts[0].display(), p.display()))?;
    }
    let merged = Partial::merge(parts).map_err(anyhow::Error::msg).context("cannot merge")?;
    let written = if ext == "hpr" {
        merged.write(&args.output)?;
        vec![args.output.clone()]
    } else {
        merged.image().write(&args.output, args.exposure)?
    };
    let files: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
    eprintln!(
        "merged {} parts: iterations {}..{} ({} in all): wrote {}",
        args.parts.len(),
        merged.info.first_iteration,
        merged.last_iteration(),
        merged.info.iterations,
        files.join(" and ")
    );
    Ok(ExitCode::SUCCESS)
}
