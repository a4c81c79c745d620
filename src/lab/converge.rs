//! Speed against accuracy: render a scene while measuring, at log-spaced iteration counts, the
//! error against a reference image, for several series of settings; fit the convergence slope of
//! each series and compare it with theory.
//!
//! Errors are over every pixel and channel (or a region):
//!
//! - RMSE = √(mean (x − ref)² − mean v_ref), where v_ref is the reference's own estimated variance
//!   of the mean per pixel (a `variance` layer written by `haze render --reference`; zero if the
//!   reference has none). Subtracting it removes the reference's noise from the expected squared
//!   error, so a reference need not be far more converged than the renders it judges.
//! - relative RMSE = RMSE / m, with m the mean reference value over the region.
//! - relMSE = mean ((x − ref)² − v_ref) / (ref² + 0.01 m²): the per-pixel relative error, with
//!   pixels darker than a tenth of the mean weighted as if they were that bright.
//!
//! Checkpoints are iteration counts (1, 2, 3, 4, 5, 6, 8, 10, 13, 16, 20, …: ten per decade), so
//! runs with different seeds are measured after the same work and can be averaged: each point of
//! a series averages the squared errors and the times over its runs. The time excludes the
//! measuring itself.
//!
//! Theory (docs/convergence.md, ../DESIGN §3): with kernel dimension k on a schedule of dimension d
//! and reduction α, the variance of the mean falls as N^−(1 − k(1−α)/d) and the squared bias as
//! N^−4(1−α)/d, so the RMSE falls with slope −min(1 − k(1−α)/d, 4(1−α)/d)/2 against N (and against
//! time, which grows as N). A photon-mapping render is as slow as its slowest estimate; the path
//! tracer's slope is −1/2.

use super::chart::{Chart, Line};
use crate::error::{Error, Result};
use crate::output::Image;
use crate::progress::Status;
use crate::scene::Scene;
use crate::settings::{
    Integrator, Kernel, Merges, PhotonBudget, Progression, RenderOptions, RenderSettings,
    VolumeEstimate,
};
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// A reference image.
#[derive(Clone, Debug)]
pub struct Reference {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB, row-major.
    pub pixels: Vec<[f32; 3]>,
    /// Estimated variance of the mean per pixel, if the reference carries one that is sound
    /// (path-traced references only: photon-mapping iterations drift as the radius shrinks).
    pub variance: Option<Vec<[f32; 3]>>,
    /// The file's `variance` layer whatever rendered it (every haze render of two or more
    /// iterations writes one), for per-tile comparisons ([`crate::lab::tiles`]).
    pub variance_layer: Option<Vec<[f32; 3]>>,
    /// The file's kernel-bias layer (photon-mapping references; `bias`), which the coverage of
    /// a render's error bound counts ([`self_estimate`]).
    pub bias_layer: Option<Vec<[f32; 3]>>,
    /// How it was made (the `haze:reference` attribute), if it says.
    pub description: Option<String>,
    /// The integrator and seed that rendered it (`haze:render.integrator` and `haze:render.seed`,
    /// or `haze:integrator` and `haze:seed` in files of older versions), if it says.
    pub made_by: Option<(Integrator, u64)>,
}

impl Reference {
    /// A reference from an image in memory (with its variance estimate).
    pub fn from_image(image: &Image) -> Self {
        Self {
            width: image.width,
            height: image.height,
            pixels: image.pixels.clone(),
            // As in `Image::write_reference`: only the path tracer's variance estimate is sound.
            variance: image
                .variance
                .clone()
                .filter(|_| image.info.settings.integrator == Integrator::Path),
            variance_layer: image.variance.clone(),
            bias_layer: image.bias.clone(),
            description: Some(image.reference_description()),
            made_by: Some((image.info.settings.integrator, image.info.settings.seed)),
        }
    }

    /// Reads an OpenEXR reference: the first layer's R, G and B channels, and the layer named
    /// `variance` if there is one. Errors name the file.
    pub fn load(path: &Path) -> Result<Self> {
        use exr::prelude::*;
        let err = |m: String| crate::Error::Output { path: path.to_path_buf(), message: m };
        if !path.is_file() {
            return Err(crate::Error::Io {
                path: path.to_path_buf(),
                error: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            });
        }
        // The header first: the reader sizes its buffers from the declared data window before
        // it reads a pixel, so a small file declaring a vast image would abort the process.
        let meta = exr::meta::MetaData::read_from_file(path, false)
            .map_err(|e| err(format!("cannot read as an RGB OpenEXR reference: {e}")))?;
        // Every layer is allocated before any is read: at most 4 layers of the largest image
        // haze renders, together.
        let max = 4 * crate::scene::camera::MAX_PIXELS;
        if let Some(refusal) = crate::input::exr_size_refusal(&meta, max, "a reference") {
            return Err(err(refusal));
        }
        let image = read()
            .no_deep_data()
            .largest_resolution_level()
            .rgb_channels(crate::input::rgb_storage, crate::input::rgb_set)
            .all_layers()
            .all_attributes()
            .from_file(path)
            .map_err(|e| err(format!("cannot read as an RGB OpenEXR reference: {e}")))?;
        let Some(first) = image.layer_data.first() else {
            return Err(err("the file holds no image layer".into()));
        };
        let (w, h) = (first.size.width(), first.size.height());
        let pixels = first.channel_data.pixels.1.clone();
        let variance_layer = image
            .layer_data
            .iter()
            .find(|l| l.attributes.layer_name.as_ref().is_some_and(|n| n == "variance"));
        if let Some(l) = variance_layer {
            if (l.size.width(), l.size.height()) != (w, h) {
                return Err(err(format!(
                    "the variance layer is {}x{} but the image is {w}x{h}",
                    l.size.width(),
                    l.size.height()
                )));
            }
        }
        let variance = variance_layer.map(|l| l.channel_data.pixels.1.clone());
        let bias_layer = image
            .layer_data
            .iter()
            .find(|l| l.attributes.layer_name.as_ref().is_some_and(|n| n == "bias"))
            .filter(|l| (l.size.width(), l.size.height()) == (w, h))
            .map(|l| l.channel_data.pixels.1.clone())
            .filter(|b| b.iter().flatten().all(|c| c.is_finite()));
        check_finite(&pixels, variance.as_deref(), w, path)?;
        let (description, made_by) = made_by(&first.attributes);
        // Photon-mapping iterations are not identically distributed, so their spread overstates
        // the noise of the mean; a variance layer in such a file (older haze wrote one) is ignored.
        let variance_layer = variance.clone();
        let variance = variance.filter(|_| made_by.is_none_or(|(i, _)| i == Integrator::Path));
        Ok(Self {
            width: w as u32,
            height: h as u32,
            pixels,
            variance,
            variance_layer,
            bias_layer,
            description,
            made_by,
        })
    }
}

/// Refuses a reference whose pixels or variances are negative or not finite, naming the first.
fn check_finite(
    pixels: &[[f32; 3]],
    variance: Option<&[[f32; 3]]>,
    w: usize,
    path: &Path,
) -> Result<()> {
    let err = |m: String| crate::Error::Output { path: path.to_path_buf(), message: m };
    for (what, data) in [("pixel", Some(pixels)), ("variance", variance)] {
        if let Some(i) =
            data.and_then(|d| d.iter().position(|p| p.iter().any(|c| !c.is_finite() || *c < 0.0)))
        {
            return Err(err(format!(
                "{what} ({}, {}) is negative or not finite; a reference must be a finite radiance image",
                i % w,
                i / w
            )));
        }
    }
    Ok(())
}

/// What a reference's header says of it: its `haze:reference` description, and the integrator
/// and seed it was rendered with (in the scene file's syntax; older files wrote bare names under
/// other keys).
fn made_by(
    attributes: &exr::meta::header::LayerAttributes,
) -> (Option<String>, Option<(Integrator, u64)>) {
    use exr::meta::attribute::AttributeValue;
    let text = |key: &str| {
        attributes.other.iter().find_map(|(k, v)| match v {
            AttributeValue::Text(t) if k == key => Some(t.to_string()),
            _ => None,
        })
    };
    let description = text("haze:reference");
    // Settings are recorded in the scene file's syntax (strings quoted); older files wrote
    // bare names under other keys.
    let setting = |new: &str, old: &str| {
        text(new).map(|v| v.trim_matches('"').to_string()).or_else(|| text(old))
    };
    let made_by = match (
        setting("haze:render.integrator", "haze:integrator"),
        setting("haze:render.seed", "haze:seed"),
    ) {
        (Some(i), Some(s)) => i.parse().ok().zip(s.parse().ok()),
        _ => None,
    };
    (description, made_by)
}

pub use crate::region::Region;

/// Errors of an image against a reference (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorMeasure {
    /// Mean squared error less the reference's own variance. Not clamped (it can come out
    /// slightly negative when the reference's noise dominates), so that averages over runs stay
    /// unbiased; [`Self::rmse`] clamps.
    pub mse: f64,
    /// Relative MSE (likewise unclamped).
    pub rel_mse: f64,
    /// Mean reference value over the region.
    pub reference_mean: f64,
}

impl ErrorMeasure {
    /// Root-mean-square error.
    pub fn rmse(&self) -> f64 {
        self.mse.max(0.0).sqrt()
    }

    /// RMSE relative to the mean reference value.
    pub fn rel_rmse(&self) -> f64 {
        self.rmse() / self.reference_mean
    }
}

/// Measures `pixels` (the reference's size, row-major) against `reference` over `region` (or the
/// whole image).
pub fn measure(pixels: &[[f32; 3]], reference: &Reference, region: Option<Region>) -> ErrorMeasure {
    let (w, h) = (reference.width, reference.height);
    let r = region.unwrap_or(Region::whole(w, h));
    let idx = || r.indices(w, h);
    let n = (3 * (r.x1 - r.x0) as usize * (r.y1 - r.y0) as usize) as f64;
    let mean: f64 =
        idx().map(|i| reference.pixels[i].iter().map(|&c| c as f64).sum::<f64>()).sum::<f64>() / n;
    let eps = 0.01 * mean * mean;
    let (mut se, mut rel) = (0.0, 0.0);
    for i in idx() {
        for c in 0..3 {
            let v = reference.variance.as_ref().map_or(0.0, |v| v[i][c] as f64);
            let rc = reference.pixels[i][c] as f64;
            let d2 = (pixels[i][c] as f64 - rc).powi(2) - v;
            se += d2;
            rel += d2 / (rc * rc + eps);
        }
    }
    ErrorMeasure { mse: se / n, rel_mse: rel / n, reference_mean: mean }
}

/// What a render says about its own error over a region, to be checked against what a
/// reference measures (docs/error.md, "Checking the estimates").
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SelfEstimate {
    /// The render's estimate of its MSE: the mean over the region's pixels and channels of
    /// v + b̂² − w (v the variance of the mean, b̂ the kernel-bias estimate, w its variance; 0
    /// without a kernel). Unclamped, so that averages over runs stay unbiased.
    pub mse: f64,
    /// The share of the region's pixel channels whose measured error |x − ref| lies within the
    /// render's stated 95 % bound 1.707 (|b̂| + |b̂_ref|) + t √(v + w + v_ref), t the two-sided
    /// 95 % Student-t quantile for the iterations, b̂_ref and v_ref the reference's `bias` and
    /// `variance` layers (zero where it has none).
    pub coverage: f64,
}

impl SelfEstimate {
    /// The estimated RMSE relative to `reference_mean`.
    pub fn rel_rmse(&self, reference_mean: f64) -> f64 {
        self.mse.max(0.0).sqrt() / reference_mean
    }
}

/// The factor between the kernel-bias estimate and a bias of first order in r (boundaries):
/// 1 / (2 (1 − 1/√2)) (docs/theory.md); the bound a render states is this times |b̂|.
pub const FIRST_ORDER_BIAS: f64 = 1.707_106_781_186_547_5;

/// The self-estimate of `film` over `region` against `reference` (same size); `None` before the
/// second iteration.
pub fn self_estimate(
    film: &crate::film::Film,
    reference: &Reference,
    region: Option<Region>,
) -> Option<SelfEstimate> {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    let n = film.iterations();
    if n < 2 {
        return None;
    }
    let t = StudentsT::new(0.0, 1.0, (n - 1) as f64).ok()?.inverse_cdf(0.975);
    let (mean, v) = (film.mean(), film.variance_of_mean());
    let (b, w) = (film.bias(), film.bias_variance());
    let (width, height) = (reference.width, reference.height);
    let (mut mse, mut covered, mut count) = (0.0f64, 0u64, 0u64);
    for i in region.unwrap_or(Region::whole(width, height)).indices(width, height) {
        for c in 0..3 {
            let at = |l: &Option<Vec<[f32; 3]>>| l.as_ref().map_or(0.0, |l| l[i][c] as f64);
            let (bi, wi, vi) = (at(&b), at(&w), v[i][c] as f64);
            let (b_ref, v_ref) = (at(&reference.bias_layer), at(&reference.variance_layer));
            mse += vi + bi * bi - wi;
            let bound = FIRST_ORDER_BIAS * (bi.abs() + b_ref.abs()) + t * (vi + wi + v_ref).sqrt();
            let error = (mean[i][c] as f64 - reference.pixels[i][c] as f64).abs();
            covered += (error <= bound) as u64;
            count += 1;
        }
    }
    (count > 0)
        .then(|| SelfEstimate { mse: mse / count as f64, coverage: covered as f64 / count as f64 })
}

/// Iteration counts at which to measure: ten per decade, rounded and deduplicated, up to `max`.
pub fn checkpoints(max: u64) -> Vec<u64> {
    let mut out: Vec<u64> = Vec::new();
    for k in 0.. {
        let n = 10f64.powf(k as f64 / 10.0).round() as u64;
        if n > max {
            break;
        }
        if out.last() != Some(&n) {
            out.push(n);
        }
    }
    out
}

/// A named set of render settings to chart.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Settings (seed, iterations and time limit are set per run).
    pub settings: RenderSettings,
}

/// One measurement.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// Index of the series.
    pub series: usize,
    /// Run number (0-based); the run's seed is the series' seed plus this.
    pub run: u32,
    /// Iterations finished.
    pub iterations: u64,
    /// Light paths traced (0 for the path tracer).
    pub light_paths: u64,
    /// Render seconds (excluding measuring).
    pub seconds: f64,
    /// The errors.
    pub error: ErrorMeasure,
    /// What the render said about its error (probabilistic progressions from the second
    /// iteration on).
    pub estimate: Option<SelfEstimate>,
}

/// How long and how often to render.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    /// Seconds per run.
    pub seconds: f64,
    /// Independent runs per series (seeds seed, seed + 1, …).
    pub runs: u32,
    /// Stop a run after this many iterations even if time is left.
    pub max_iterations: Option<u64>,
    /// Measure over this region only.
    pub region: Option<Region>,
}

/// Renders every series `plan.runs` times, measuring at the [`checkpoints`]. `progress(series,
/// run, seconds)` is called after every iteration. A raised `stop` ends the current run and skips
/// the rest; the samples so far are returned.
pub fn run(
    scene: &Scene,
    series: &[Series],
    reference: &Reference,
    plan: &Plan,
    progress: &mut dyn FnMut(usize, u32, f64),
    stop: &AtomicBool,
) -> Result<Vec<Sample>> {
    check(scene, series, reference, plan)?;
    let marks = checkpoints(u64::MAX / 2);
    let mut samples = Vec::new();
    for (si, s) in series.iter().enumerate() {
        for run in 0..plan.runs {
            if stop.load(std::sync::atomic::Ordering::Relaxed) {
                return Ok(samples);
            }
            let mut settings = s.settings.clone();
            settings.seed = s.settings.seed.wrapping_add(run as u64);
            settings.iterations = plan.max_iterations;
            settings.time_limit = Some(plan.seconds);
            let mut next = 0;
            let mut overhead = 0.0;
            let mut on_iteration = |st: &Status| {
                let t0 = Instant::now();
                let seconds = st.elapsed() - overhead;
                if st.iteration() == marks[next] {
                    next += 1;
                    let error = measure(&st.film.mean(), reference, plan.region);
                    let estimate = (st.info.settings.progression == Progression::Probabilistic)
                        .then(|| self_estimate(st.film, reference, plan.region))
                        .flatten();
                    samples.push(Sample {
                        series: si,
                        run,
                        iterations: st.iteration(),
                        light_paths: st.info.light_paths,
                        seconds,
                        error,
                        estimate,
                    });
                }
                progress(si, run, seconds);
                overhead += t0.elapsed().as_secs_f64();
            };
            crate::render(scene, &settings, &mut on_iteration, stop)
                .map_err(|e| Error::Settings(format!("series `{}`: {e}", s.label)))?;
        }
    }
    Ok(samples)
}

/// Refuses, before any work is done, a reference of the wrong size, a region outside the image,
/// a series that would reuse the reference's seed, and a series that cannot render.
fn check(scene: &Scene, series: &[Series], reference: &Reference, plan: &Plan) -> Result<()> {
    let [w, h] = scene.resolution();
    if [w, h] != [reference.width, reference.height] {
        return Err(Error::Settings(format!(
            "the reference is {}x{} but the scene renders {w}x{h}; render the reference at the same resolution",
            reference.width, reference.height
        )));
    }
    if let Some(r) = plan.region {
        if r.x1 > w || r.y1 > h {
            return Err(Error::Settings(format!(
                "region {},{},{},{} lies outside the {w}x{h} image",
                r.x0, r.y0, r.x1, r.y1
            )));
        }
    }
    // A render sharing the reference's seed repeats some of the reference's random numbers (the
    // same photons for the same integrator; the same pixel jitter for either, since both draw
    // eye paths from one stream), and its error would fall for that reason alone.
    if let Some((_, seed)) = reference.made_by {
        for s in series {
            let seeds = s.settings.seed..s.settings.seed.saturating_add(plan.runs as u64);
            if seeds.contains(&seed) {
                return Err(Error::Settings(format!(
                    "series `{}` would use seed {seed}, which rendered the reference: its samples would repeat the reference's; give another --seed",
                    s.label
                )));
            }
        }
    }
    // Refuse a series that cannot render before any work is done.
    for s in series {
        s.settings.validate().map_err(|e| Error::Settings(format!("series `{}`: {e}", s.label)))?;
        if s.settings.progression == Progression::Original && scene.has_media() {
            return Err(Error::Settings(format!(
                "series `{}`: the original progression is for surfaces only; this scene has media",
                s.label
            )));
        }
    }
    Ok(())
}

/// One point of a series: a checkpoint reached by every run, averaged over the runs.
#[derive(Clone, Copy, Debug)]
pub struct Point {
    /// Iterations.
    pub iterations: u64,
    /// Mean render seconds over the runs.
    pub seconds: f64,
    /// Light paths per run.
    pub light_paths: u64,
    /// The errors, squared errors averaged over the runs.
    pub error: ErrorMeasure,
    /// The renders' self-estimates averaged over the runs (if every run had one).
    pub estimate: Option<SelfEstimate>,
}

/// A series' convergence, summarised.
#[derive(Clone, Debug)]
pub struct Summary {
    /// Legend label.
    pub label: String,
    /// Averaged checkpoints.
    pub points: Vec<Point>,
    /// Least-squares slope of log RMSE against log time over the later half (in log time) of the
    /// points; `None` with fewer than three points there.
    pub fitted_slope: Option<f64>,
    /// The slope theory predicts.
    pub theory_slope: f64,
}

/// RMSE slope against time that theory predicts for `settings` on `scene` (module docs).
pub fn theory_slope(scene: &Scene, settings: &RenderSettings) -> f64 {
    let integrator = settings.integrator.resolve(scene.has_emissive_media());
    if integrator == Integrator::Path {
        return -0.5;
    }
    // MSE exponent of an estimate with kernel dimension k on a schedule of dimension d.
    let exponent = |k: f64, d: f64, a: f64| (1.0 - k * (1.0 - a) / d).min(4.0 * (1.0 - a) / d);
    let mut e = exponent(2.0, 2.0, settings.alpha);
    if scene.has_media() && settings.progression == Progression::Probabilistic {
        // The combined integrator reads no volume estimate: it weighs both merges, and the point
        // merge's share against the beam's shrinks with the radius (∝ σ_t r), so the beam's rate
        // is its rate.
        let k = match (integrator, settings.volume_estimate) {
            (Integrator::Combined, _) | (_, VolumeEstimate::Beam) => 2.0,
            (_, VolumeEstimate::Point) => 3.0,
        };
        e = e.min(exponent(k, settings.volume_dimension as f64, settings.volume_alpha));
    }
    -0.5 * e
}

/// Least-squares slope of log y against log x.
pub fn fit_slope(points: &[(f64, f64)]) -> Option<f64> {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if pts.len() < 3 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = pts.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let sxx: f64 = pts.iter().map(|(x, _)| (x - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// Averages the runs of each series at the checkpoints every run reached, and fits slopes.
pub fn summarize(scene: &Scene, series: &[Series], samples: &[Sample], runs: u32) -> Vec<Summary> {
    series
        .iter()
        .enumerate()
        .map(|(si, s)| {
            let mut points = Vec::new();
            for n in checkpoints(u64::MAX / 2) {
                let at: Vec<&Sample> =
                    samples.iter().filter(|x| x.series == si && x.iterations == n).collect();
                if at.is_empty() || at.len() < runs as usize {
                    break;
                }
                let k = at.len() as f64;
                let estimates: Option<Vec<SelfEstimate>> = at.iter().map(|x| x.estimate).collect();
                let estimate = estimates.map(|e| SelfEstimate {
                    mse: e.iter().map(|x| x.mse).sum::<f64>() / k,
                    coverage: e.iter().map(|x| x.coverage).sum::<f64>() / k,
                });
                points.push(Point {
                    estimate,
                    iterations: n,
                    seconds: at.iter().map(|x| x.seconds).sum::<f64>() / k,
                    light_paths: at[0].light_paths,
                    error: ErrorMeasure {
                        mse: at.iter().map(|x| x.error.mse).sum::<f64>() / k,
                        rel_mse: at.iter().map(|x| x.error.rel_mse).sum::<f64>() / k,
                        reference_mean: at[0].error.reference_mean,
                    },
                });
            }
            let fitted_slope = points.last().and_then(|last| {
                let first = points[0].seconds;
                let mid = (first * last.seconds).sqrt();
                let late: Vec<(f64, f64)> = points
                    .iter()
                    .filter(|p| p.seconds >= mid)
                    .map(|p| (p.seconds, p.error.rmse()))
                    .collect();
                fit_slope(&late)
            });
            Summary {
                label: s.label.clone(),
                points,
                fitted_slope,
                theory_slope: theory_slope(scene, &s.settings),
            }
        })
        .collect()
}

impl Summary {
    /// Seconds until the relative RMSE first fell to `target` (log-log interpolation between the
    /// checkpoints around it); `None` if it never did.
    pub fn time_to(&self, target: f64) -> Option<f64> {
        let i = self.points.iter().position(|p| p.error.rel_rmse() <= target)?;
        if i == 0 {
            return Some(self.points[0].seconds);
        }
        let (a, b) = (&self.points[i - 1], &self.points[i]);
        let (ea, eb) = (a.error.rel_rmse().ln(), b.error.rel_rmse().ln());
        let t = if ea > eb { (ea - target.ln()) / (ea - eb) } else { 1.0 };
        Some((a.seconds.ln() + t * (b.seconds.ln() - a.seconds.ln())).exp())
    }
}

impl Summary {
    /// If the relative RMSE never reached `target`: the seconds the fitted slope predicts from the
    /// last point (an extrapolation, labelled as such in tables).
    pub fn extrapolated_time_to(&self, target: f64) -> Option<f64> {
        let last = self.points.last()?;
        let slope = self.fitted_slope.filter(|s| *s < 0.0)?;
        let e = last.error.rel_rmse();
        (e > target).then(|| last.seconds * (target / e).powf(1.0 / slope))
    }
}

/// Formats a slope for tables and legends.
fn slope(s: Option<f64>) -> String {
    s.map_or("n/a".to_string(), |s| format!("{s:.2}"))
}

/// The log-log chart of RMSE against time: each series with its theory slope as a dashed line of
/// the same colour through the series' last point, across its fitted range.
pub fn chart(title: &str, summaries: &[Summary]) -> Chart {
    let mut lines = Vec::new();
    for (i, s) in summaries.iter().enumerate() {
        lines.push(Line {
            label: format!(
                "{}: slope {} (theory {:.2})",
                s.label,
                slope(s.fitted_slope),
                s.theory_slope
            ),
            points: s.points.iter().map(|p| (p.seconds, p.error.rmse())).collect(),
            dashed: false,
            color: i,
        });
        if let (Some(first), Some(last)) = (s.points.first(), s.points.last()) {
            let t0 = (first.seconds * last.seconds).sqrt();
            let e0 = last.error.rmse() * (t0 / last.seconds).powf(s.theory_slope);
            lines.push(Line {
                label: format!("{}: theory", s.label),
                points: vec![(t0, e0), (last.seconds, last.error.rmse())],
                dashed: true,
                color: i,
            });
        }
    }
    Chart {
        title: title.to_string(),
        x_label: "render time [s]".into(),
        y_label: "RMSE".into(),
        lines,
    }
}

/// The chart of each series' estimated relative RMSE (what the renders said of themselves)
/// against the measured one, log-log, with the diagonal where they agree dashed; `None` if no
/// series has estimates.
pub fn estimate_chart(title: &str, summaries: &[Summary]) -> Option<Chart> {
    let mut lines = Vec::new();
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for (i, s) in summaries.iter().enumerate() {
        let points: Vec<(f64, f64)> = s
            .points
            .iter()
            .filter_map(|p| {
                let e = p.estimate?;
                let pair = (p.error.rel_rmse(), e.rel_rmse(p.error.reference_mean));
                (pair.0 > 0.0 && pair.1 > 0.0).then_some(pair)
            })
            .collect();
        for &(x, y) in &points {
            (lo, hi) = (lo.min(x.min(y)), hi.max(x.max(y)));
        }
        if !points.is_empty() {
            lines.push(Line { label: s.label.clone(), points, dashed: false, color: i });
        }
    }
    if lines.is_empty() {
        return None;
    }
    lines.push(Line {
        label: "estimate = measured".into(),
        points: vec![(lo, lo), (hi, hi)],
        dashed: true,
        color: summaries.len(),
    });
    Some(Chart {
        title: title.to_string(),
        x_label: "measured relative RMSE".into(),
        y_label: "estimated relative RMSE".into(),
        lines,
    })
}

/// The samples as CSV: one row per run and checkpoint.
pub fn csv(series: &[Series], samples: &[Sample]) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    let header = [
        "series",
        "run",
        "seed",
        "iterations",
        "light_paths",
        "seconds",
        "rmse",
        "rel_rmse",
        "rel_mse",
        "estimated_rel_rmse",
        "coverage",
    ];
    let _ = w.write_record(header);
    for s in samples {
        let se = &series[s.series];
        let _ = w.write_record([
            se.label.clone(),
            s.run.to_string(),
            se.settings.seed.wrapping_add(s.run as u64).to_string(),
            s.iterations.to_string(),
            s.light_paths.to_string(),
            format!("{:.6}", s.seconds),
            format!("{:.6e}", s.error.rmse()),
            format!("{:.6e}", s.error.rel_rmse()),
            format!("{:.6e}", s.error.rel_mse),
            s.estimate
                .map_or(String::new(), |e| format!("{:.6e}", e.rel_rmse(s.error.reference_mean))),
            s.estimate.map_or(String::new(), |e| format!("{:.4}", e.coverage)),
        ]);
    }
    String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
}

/// A Markdown table of the summaries: slopes and seconds to 5% and 1% relative RMSE, and at the
/// last point the render's own estimate of its relative RMSE and the coverage of its 95 % bound.
pub fn markdown(summaries: &[Summary]) -> String {
    let mut out = String::from(
        "| series | iterations | seconds | rel. RMSE | estimated | coverage | slope (fit) | slope (theory) | s to 5% | s to 1% |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for s in summaries {
        let last = s.points.last();
        let t = |target: f64| match (s.time_to(target), s.extrapolated_time_to(target)) {
            (Some(v), _) => format!("{v:.2}"),
            (None, Some(v)) => format!("not reached (fit: ~{})", round_seconds(v)),
            (None, None) => "not reached".into(),
        };
        let estimate = last.and_then(|p| p.estimate.map(|e| (p, e)));
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {:.2} | {} | {} |\n",
            s.label.replace('|', "/"),
            last.map_or(0, |p| p.iterations),
            last.map_or("-".into(), |p| format!("{:.1}", p.seconds)),
            last.map_or("-".into(), |p| format!("{:.2}%", 100.0 * p.error.rel_rmse())),
            estimate.map_or("-".into(), |(p, e)| {
                format!("{:.2}%", 100.0 * e.rel_rmse(p.error.reference_mean))
            }),
            estimate.map_or("-".into(), |(_, e)| format!("{:.1}%", 100.0 * e.coverage)),
            slope(s.fitted_slope),
            s.theory_slope,
            t(0.05),
            t(0.01),
        ));
    }
    out
}

/// Seconds rounded to two significant digits, for extrapolations.
fn round_seconds(v: f64) -> String {
    if !v.is_finite() {
        return "never".into();
    }
    let digits = v.abs().log10().floor() as i32 - 1;
    let scale = 10f64.powi(digits);
    format!("{:.0}", (v / scale).round() * scale)
}

/// Named comparisons for `haze converge --compare`: the series each one charts, derived from the
/// scene's settings `base`.
pub fn preset(name: &str, base: &RenderSettings) -> std::result::Result<Vec<Series>, String> {
    let with = |label: String, f: &dyn Fn(&mut RenderSettings)| {
        let mut s = base.clone();
        f(&mut s);
        Series { label, settings: s }
    };
    Ok(match name {
        // The volume estimate is the hybrid's and photon mapping's (the combined integrator
        // weighs both): with the default or the combined integrator, the hybrid's.
        "estimate" => [VolumeEstimate::Beam, VolumeEstimate::Point]
            .iter()
            .map(|&e| {
                with(e.name().to_string(), &|s| {
                    s.volume_estimate = e;
                    if matches!(s.integrator, Integrator::Auto | Integrator::Combined) {
                        s.integrator = Integrator::Hybrid;
                    }
                })
            })
            .collect(),
        "alpha" => [0.5, 2.0 / 3.0, 0.9]
            .iter()
            .map(|&a| with(format!("alpha {a:.2}"), &|s| s.alpha = a))
            .collect(),
        "volume-alpha" => [0.3, 0.5, 4.0 / 7.0, 0.8]
            .iter()
            .map(|&a| with(format!("volume alpha {a:.2}"), &|s| s.volume_alpha = a))
            .collect(),
        "kernel" => {
            Kernel::ALL.iter().map(|&k| with(k.name().to_string(), &|s| s.kernel = k)).collect()
        }
        "dimension" => [3, 2]
            .iter()
            .map(|&d| {
                with(format!("beam, d = {d}"), &|s| {
                    s.volume_estimate = VolumeEstimate::Beam;
                    s.volume_dimension = d;
                })
            })
            .collect(),
        "photons" => [base.photons / 4, base.photons, base.photons * 4]
            .iter()
            .map(|&p| {
                with(format!("{p} photons/it"), &|s| {
                    s.photons = p.max(1);
                    // The count itself, not the most the combined integrator's pilot traces.
                    s.photon_budget = Some(PhotonBudget::Fixed);
                })
            })
            .collect(),
        "progression" => [Progression::Probabilistic, Progression::Original]
            .iter()
            .map(|&p| {
                with(format!("{} PPM", p.name()), &|s| {
                    s.progression = p;
                    s.integrator = Integrator::PhotonMapping;
                })
            })
            .collect(),
        "integrator" => [
            (Integrator::Combined, "combined"),
            (Integrator::Hybrid, "hybrid"),
            (Integrator::PhotonMapping, "photon mapping"),
            (Integrator::Path, "path tracing"),
        ]
        .iter()
        .map(|&(i, label)| with(label.to_string(), &|s| s.integrator = i))
        .collect(),
        "merges" | "photon-budget" => combined_preset(name, base),
        _ => {
            return Err(format!(
                "unknown comparison `{name}`; expected estimate, alpha, volume-alpha, kernel, dimension, photons, progression, integrator, merges or photon-budget"
            ));
        }
    })
}

/// The combined integrator's comparisons: where its eye paths merge (`merges`), and its
/// light-path pilot against the count as given (`photon-budget`).
fn combined_preset(name: &str, base: &RenderSettings) -> Vec<Series> {
    let with = |label: String, f: &dyn Fn(&mut RenderSettings)| {
        let mut s = base.clone();
        s.integrator = Integrator::Combined;
        f(&mut s);
        Series { label, settings: s }
    };
    if name == "merges" {
        [Merges::First, Merges::Everywhere, Merges::Last]
            .iter()
            .map(|&m| with(format!("combined, merges {}", m.name()), &|s| s.merges = Some(m)))
            .collect()
    } else {
        [PhotonBudget::Pilot, PhotonBudget::Fixed]
            .iter()
            .map(|&b| {
                with(format!("combined, photon budget {}", b.name()), &|s| {
                    s.photon_budget = Some(b)
                })
            })
            .collect()
    }
}

/// Parses a series `LABEL:KEY=VALUE,KEY=VALUE…` (keys of the scene file's `[render]` table)
/// against the base settings.
pub fn parse_series(spec: &str, base: &RenderSettings) -> std::result::Result<Series, String> {
    let (label, rest) = spec
        .split_once(':')
        .ok_or_else(|| format!("series `{spec}`: expected LABEL:KEY=VALUE[,KEY=VALUE…]"))?;
    let options =
        RenderOptions::parse_assignments(rest).map_err(|e| format!("series `{label}`: {e}"))?;
    let mut settings = base.with(&options);
    settings.iterations = base.iterations;
    settings.time_limit = base.time_limit;
    settings.validate().map_err(|e| format!("series `{label}`: {e}"))?;
    Ok(Series { label: label.trim().to_string(), settings })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkpoints_are_log_spaced() {
        assert_eq!(checkpoints(40), vec![1, 2, 3, 4, 5, 6, 8, 10, 13, 16, 20, 25, 32, 40]);
    }

    #[test]
    fn slope_of_a_power_law() {
        let pts: Vec<(f64, f64)> = (1..10).map(|i| (i as f64, (i as f64).powf(-0.4))).collect();
        assert!((fit_slope(&pts).unwrap() + 0.4).abs() < 1e-12);
    }

    /// The series of comparison `name`, each as its integrator and the setting `field` reads;
    /// every one valid.
    fn series_of<T>(name: &str, field: fn(&RenderSettings) -> T) -> Vec<(Integrator, T)> {
        let series = preset(name, &RenderSettings::default()).unwrap();
        series.iter().for_each(|s| s.settings.validate().unwrap());
        series.iter().map(|s| (s.settings.integrator, field(&s.settings))).collect()
    }

    #[test]
    fn the_estimate_comparison_is_the_hybrids_under_the_default() {
        // The combined integrator reads no volume estimate: two identical series otherwise.
        let want = [VolumeEstimate::Beam, VolumeEstimate::Point].map(|e| (Integrator::Hybrid, e));
        assert_eq!(series_of("estimate", |s| s.volume_estimate), want);
    }

    #[test]
    fn the_merges_comparison_sets_the_combined_integrator() {
        let combined = Integrator::Combined;
        let want = [Merges::First, Merges::Everywhere, Merges::Last].map(|m| (combined, Some(m)));
        assert_eq!(series_of("merges", |s| s.merges), want);
    }

    #[test]
    fn the_photon_budget_comparison_sets_the_combined_integrator() {
        let combined = Integrator::Combined;
        let want = [(combined, Some(PhotonBudget::Pilot)), (combined, Some(PhotonBudget::Fixed))];
        assert_eq!(series_of("photon-budget", |s| s.photon_budget), want);
        // The photons comparison compares the counts themselves.
        let counts = preset("photons", &RenderSettings::default()).unwrap();
        assert!(counts.iter().all(|s| s.settings.photon_budget == Some(PhotonBudget::Fixed)));
    }

    #[test]
    fn region_parsing() {
        assert_eq!("1,2,3,4".parse::<Region>(), Ok(Region { x0: 1, y0: 2, x1: 3, y1: 4 }));
        assert!("3,2,1,4".parse::<Region>().is_err());
        assert!("1,2,3".parse::<Region>().is_err());
    }

    /// Two iterations of 1 and 3 with bias estimates 0.1 and 0.3: v = 1, b̂ = 0.2, w = 0.01, so
    /// the estimated MSE is 1 + 0.04 − 0.01 and the bound 1.707 · 0.2 + t₁ √1.01 = 13.11 (t₁ the
    /// 97.5 % quantile of Student's t with one degree of freedom, 12.706): an error of 13.0 is
    /// covered, one of 13.2 is not.
    #[test]
    fn self_estimates_state_the_mse_and_cover_within_the_bound() {
        let mut film = crate::film::Film::with_bias(1, 1);
        film.add_with_bias(&[glam::Vec3::splat(1.0)], &[glam::Vec3::splat(0.1)]);
        film.add_with_bias(&[glam::Vec3::splat(3.0)], &[glam::Vec3::splat(0.3)]);
        let reference = |v: f32| Reference {
            width: 1,
            height: 1,
            pixels: vec![[v; 3]],
            variance: None,
            variance_layer: None,
            bias_layer: None,
            description: None,
            made_by: None,
        };
        let e = self_estimate(&film, &reference(2.0 + 13.0), None).unwrap();
        assert!((e.mse - 1.03).abs() < 1e-6, "{e:?}");
        assert_eq!(e.coverage, 1.0);
        assert_eq!(self_estimate(&film, &reference(2.0 + 13.2), None).unwrap().coverage, 0.0);
        assert_eq!(self_estimate(&film, &reference(2.0 - 13.2), None).unwrap().coverage, 0.0);
    }

    #[test]
    fn reference_variance_is_subtracted() {
        let reference = Reference {
            width: 1,
            height: 1,
            pixels: vec![[1.0; 3]],
            variance: Some(vec![[0.01; 3]]),
            variance_layer: None,
            bias_layer: None,
            description: None,
            made_by: None,
        };
        let e = measure(&[[1.2; 3]], &reference, None);
        assert!((e.mse - 0.03).abs() < 1e-6, "{}", e.mse);
        assert!((e.rel_rmse() - 0.03f64.sqrt()).abs() < 1e-6);
    }
}
