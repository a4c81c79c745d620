//! `haze sky`: a daylight sky (the scene format's `type = "sky"`) written as an OpenEXR
//! environment map, with the sun folded into its texel, for scenes and other renderers.

use crate::shared::check_output_dir;
use anyhow::{Result, bail};
use clap::Args;
use haze::scene::{EnvMap, SkyParams};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Args)]
pub(crate) struct SkyArgs {
    /// The sun's elevation above the horizon, degrees (0 to 90).
    #[arg(long, value_name = "DEG")]
    elevation: f32,
    /// The sun's azimuth, degrees from +z towards +x.
    #[arg(long, default_value_t = 0.0, value_name = "DEG")]
    azimuth: f32,
    /// Atmospheric turbidity, 1.7 to 10 (2 very clear, 3 clear, 6 hazy).
    #[arg(long, default_value_t = 3.0, value_name = "T")]
    turbidity: f32,
    /// Albedo of the ground below the horizon, 0 to 1.
    #[arg(long, default_value_t = 0.3, value_name = "A")]
    ground_albedo: f32,
    /// Width of the map in texels (its height is half), 16 to 8192.
    #[arg(long, default_value_t = 1024, value_name = "W")]
    resolution: u32,
    /// Multiplies the whole map (sky radiance is in photometric W/(m²·sr): ~10 at a clear
    /// zenith).
    #[arg(long, default_value_t = 1.0, value_name = "S")]
    scale: f32,
    /// Leave the sun out of the map (for a scene that adds it as a directional light).
    #[arg(long)]
    no_sun: bool,
    /// Output file (.exr).
    #[arg(short = 'o', long, value_name = "FILE.exr")]
    output: PathBuf,
}

pub(crate) fn run(args: SkyArgs) -> Result<ExitCode> {
    if args.output.extension().and_then(|e| e.to_str()) != Some("exr") {
        bail!(
            "--output {}: an environment map is an OpenEXR file: name it .exr",
            args.output.display()
        );
    }
    if let Err(m) = haze::scene::sky::check_elevation(args.elevation) {
        bail!("--elevation {m}");
    }
    let widths = haze::scene::sky::WIDTHS;
    if !widths.contains(&args.resolution) {
        let (lo, hi) = (widths.start(), widths.end());
        bail!("--resolution must lie in [{lo}, {hi}], got {}", args.resolution);
    }
    if !(args.scale.is_finite() && args.scale > 0.0) {
        bail!("--scale must be a positive number, got {}", args.scale);
    }
    let params = SkyParams {
        sun: haze::scene::sky::sun_towards(args.elevation, args.azimuth),
        turbidity: args.turbidity,
        ground_albedo: haze::glam::Vec3::splat(args.ground_albedo),
    };
    // The model's limits, each named by its flag.
    params.check().map_err(|(field, m)| {
        let flag = match field {
            "turbidity" => "--turbidity",
            "ground_albedo" => "--ground-albedo",
            _ => "--elevation",
        };
        anyhow::anyhow!("{flag} {m}")
    })?;
    check_output_dir("--output", &args.output)?;
    let (map, sun) =
        EnvMap::sky(&params, args.resolution, !args.no_sun).map_err(anyhow::Error::msg)?;
    let map = map.scaled(args.scale).map_err(anyhow::Error::msg)?;
    map.write_exr(&args.output)?;
    let [w, h] = map.size();
    eprintln!(
        "wrote {} ({w} × {h}): sun at {:.1}° elevation, {:.1}° azimuth, turbidity {}, sun irradiance [{:.6}, {:.6}, {:.6}] (photometric W/m², scaled){}",
        args.output.display(),
        args.elevation,
        args.azimuth,
        args.turbidity,
        sun.x * args.scale,
        sun.y * args.scale,
        sun.z * args.scale,
        if args.no_sun { ", left out of the map" } else { ", in the map" }
    );
    Ok(ExitCode::SUCCESS)
}
