//! Stability where methods fail: extreme optical thickness, albedo 0.999, strongly anisotropic
//! phase functions, ten thousand iterations, and thinning of photon-dense regions. The scenes of
//! the same names in scenes/ (thin-fog, dense-fog, fog-forward, fog-backward, vdb-edges) are
//! rendered by `bundled_scenes_render_finite_images` and charted in docs/convergence.md; here the
//! same regimes meet known answers.

use crate::common::{assert_agrees, mean_and_se, t_critical};
use crate::media::{
    FURNACE_FOV_DEG, METHODS, furnace, furnace_with_light, homogeneous, volume_settings,
};
use haze::glam::Vec3;
use haze::progress::{Silent, Status};
use haze::scene::LightDesc;
use haze::schedule::radius;
use haze::settings::{Integrator, RenderSettings, VolumeEstimate};
use haze::{Image, Scene};
use std::sync::atomic::AtomicBool;

fn render(scene: &Scene, settings: &RenderSettings) -> Image {
    haze::render(scene, settings, &mut Silent, &AtomicBool::new(false)).unwrap()
}

fn image_mean(scene: &Scene, settings: &RenderSettings) -> f64 {
    let img = render(scene, settings);
    assert_eq!(img.info.nonfinite_samples, 0);
    assert!(img.pixels.iter().flatten().all(|c| c.is_finite() && *c >= 0.0));
    img.mean()
}

/// One furnace configuration rendered once per seed.
struct Run {
    estimate: VolumeEstimate,
    integrator: Integrator,
    r: f64,
    photons: u64,
    iterations: u64,
}

impl Run {
    /// The image mean of each seed's render.
    fn means(&self, scene: &Scene, seeds: std::ops::Range<u64>) -> Vec<f64> {
        seeds
            .map(|seed| {
                let mut s = volume_settings(self.estimate, self.r, seed);
                s.photons = self.photons;
                s.iterations = Some(self.iterations);
                s.integrator = self.integrator;
                image_mean(scene, &s)
            })
            .collect()
    }
}

/// Largest cosine-weighted bias of a furnace pixel mean (see `white_furnace_with_media_for_both_
/// estimators` in media.rs): B = L_e σ_t r / (2 cos θ_max) e^{−σ_t (1 − r)}.
fn furnace_bias(le: f64, sigma_t: f64, r: f64) -> f64 {
    let cos_max = ((FURNACE_FOV_DEG.to_radians() / 2.0).tan() * 2f32.sqrt()).atan().cos() as f64;
    le * sigma_t * r / (2.0 * cos_max) * (-sigma_t * (1.0 - r)).exp()
}

/// The white furnace at the extremes of thickness: optical thickness 0.01 and 100 across the
/// enclosure. Every method must return L_e (t-test at the suite's significance, with the kernel
/// bias bound for photon mapping). In the thin medium only ~0.5% of eye rays collide and few
/// photons are stored, so the estimate is a rare large value: the radius (0.3; its bias bound is
/// still below 10⁻³) and the iteration count are raised until a render holds several collisions,
/// or the t-test would see only the common zeros. The dense case random-walks long paths, so it
/// uses fewer photons and seeds. Strong anisotropy has a test of its own
/// ([`anisotropic_furnace_at_a_working_radius`]).
#[test]
fn furnace_holds_at_extreme_thickness_and_anisotropy() {
    let le = 1.0;
    // (σ_s, g, volume radius, photons, seeds, iterations)
    let cases =
        [(0.005f32, 0.0f32, 0.3f64, 20_000u64, 12u64, 16u64), (50.0, 0.0, 0.03, 3_000, 8, 4)];
    for (sigma_s, g, r, photons, seeds, iterations) in cases {
        let scene = furnace(Vec3::splat(le), homogeneous(Vec3::ZERO, Vec3::splat(sigma_s), g));
        for (estimate, integrator) in METHODS {
            let run = Run { estimate, integrator, r, photons, iterations };
            if integrator == Integrator::Combined && sigma_s > 1.0 {
                // The dense furnace's long walks end the eye at its first merge, without point
                // merges: this case checks that combination too.
                let mut s = volume_settings(estimate, r, 0);
                (s.photons, s.integrator) = (photons, integrator);
                let b = haze::light_path_budget(&scene, &s, &AtomicBool::new(false))
                    .expect("the settings are valid")
                    .expect("the combined integrator has a budget");
                assert!(b.ends_at_merge && !b.point_merges, "{b:?}");
            }
            let xs = run.means(&scene, 0..seeds);
            let bias = match integrator {
                Integrator::Path => 0.0,
                _ => furnace_bias(le as f64, sigma_s as f64, r),
            };
            assert_agrees(
                &format!("furnace σ_s = {sigma_s}, g = {g}, {estimate:?}, {integrator:?}"),
                &xs,
                le as f64,
                bias,
            );
        }
    }
}

/// The white furnace with g = ±0.95 (σ_s 2) at working radii: 0.02 for the beam estimate — the
/// radius this test had before, on 2026-12-02, it was moved to 0.2 to pass (which grew its bias
/// allowance from 0.29 % to 4.2 %) — and 0.05 for the point estimate (allowance 0.74 %), whose
/// 3-D ball at 0.02 is 16 times smaller than at 0.05 and mostly finds no photon at all: at 0.02
/// the means of 64 renders of 10,000 light paths × 8 iterations read 0.52 to 1.73 by method and
/// g, and the hybrid's at g 0.95 lay below L_e even by the bootstrap-t interval (0.636, interval
/// [0.507, 0.991]; measured 2026-12-04): the renders had missed the rare photons that carry a
/// third of the mean. At g = ±0.95 a photon's phase value f(ω_p, −ω) has a relative variance of ~200
/// over directions (∫f² dω = (1 + g²)/(4π (1 − g²)²) against f̄ = 1/4π) and a path's photons are
/// strongly correlated, so at this radius one render's mean is a rare large value: its
/// distribution is right-skewed (skewness 1.5–6.5 over these renders; measured 2026-12-04) and
/// most renders read low. A t-test assumes a normality the means do not have, and batch means of
/// 8 renders were still skewed up to 1.7. So the test uses the bootstrap-t interval (Efron &
/// Tibshirani 1993, ch. 12.5), which carries the skewness of the studentised mean into the
/// interval: 64 renders per method, 20,000 resamples of them, the 0.05 % and 99.95 % quantiles
/// q of t* = (m* − m)/s*, and the interval [m − q₉₉.₉₅ s, m − q₀.₀₅ s] at significance 10⁻³,
/// which must reach L_e within the kernel's wall bias bound at the radius (`furnace_bias`). The path tracer, which has no radius, is held to the same interval. The test
/// prints each interval: its width is what the test can see at this radius (tens of per cent for
/// the photon estimates — the honest power of a furnace this anisotropic at this effort).
#[test]
fn anisotropic_furnace_at_a_working_radius() {
    use crate::common::Rng;
    let (le, renders) = (1.0f64, 64u64);
    let mut failures = Vec::new();
    for g in [0.95f32, -0.95] {
        let scene = furnace(Vec3::splat(le as f32), homogeneous(Vec3::ZERO, Vec3::splat(2.0), g));
        for (estimate, integrator) in METHODS {
            // The point estimate's 3-D ball at 0.02 is a starved estimate, not a working one.
            let r = if estimate == VolumeEstimate::Point { 0.05 } else { 0.02 };
            let run = Run { estimate, integrator, r, photons: 20_000, iterations: 8 };
            let xs = run.means(&scene, 2000..2000 + renders);
            let (mean, se) = mean_and_se(&xs);
            // Bootstrap-t: the distribution of the studentised mean over resamples.
            let mut rng = Rng::new(31, renders);
            let mut ts: Vec<f64> = (0..20_000)
                .filter_map(|_| {
                    let resample: Vec<f64> =
                        (0..xs.len()).map(|_| xs[rng.below(xs.len())]).collect();
                    let (m, s) = mean_and_se(&resample);
                    (s > 0.0).then(|| (m - mean) / s)
                })
                .collect();
            ts.sort_by(f64::total_cmp);
            let q = |p: f64| ts[((p * ts.len() as f64) as usize).min(ts.len() - 1)];
            let alpha = crate::common::SIGNIFICANCE;
            let (lo, hi) = (mean - q(1.0 - alpha / 2.0) * se, mean - q(alpha / 2.0) * se);
            let bias = match integrator {
                Integrator::Path => 0.0,
                _ => furnace_bias(le, 2.0, r),
            };
            let line = format!(
                "anisotropic furnace g {g}, r {r}, {estimate:?} {integrator:?}: mean {mean:.4} ± \
                 {se:.4}, bootstrap-t interval [{lo:.4}, {hi:.4}] at {alpha}, bias bound {bias:.4}"
            );
            eprintln!("{line}");
            if le < lo - bias || le > hi + bias {
                failures.push(line);
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Two independent sets of estimates agree: Welch's difference of means against the critical
/// t value for the smaller sample, beyond a known bias bound.
fn assert_two_agree(what: &str, xs: &[f64], ys: &[f64], bias: f64) {
    let (mx, sx) = mean_and_se(xs);
    let (my, sy) = mean_and_se(ys);
    let se = (sx * sx + sy * sy).sqrt();
    let t = t_critical(xs.len().min(ys.len()));
    let excess = ((mx - my).abs() - bias).max(0.0);
    assert!(
        excess <= t * se,
        "{what}: {mx:.6} ± {sx:.6} vs {my:.6} ± {sy:.6}: |Δ| − bias = {excess:.6} > {t:.2}·{se:.6}"
    );
}

/// An independent answer for the absorbing furnace: the analog random walk of the adjoint path.
/// From the camera through a uniformly jittered pixel, fly exponential distances (σ_t), continue
/// after a collision with probability `albedo` in a uniform direction, and score 1 on reaching a
/// wall of [−1, 1]³ (which emits L_e = 1), 0 on absorption. Scores are 0 or 1 — no weights, no
/// heavy tails — so batch means are nearly normal. Returns 16 batch means.
fn analog_walk(scene: &Scene, sigma_t: f32, albedo: f32, walks: usize, seed: u64) -> Vec<f64> {
    use crate::common::Rng;
    let [w, h] = scene.resolution();
    // The furnace camera: a pinhole at the origin looking down −z, up +y.
    let tan = (FURNACE_FOV_DEG.to_radians() / 2.0).tan();
    let batch = walks / 16;
    (0..16)
        .map(|b| {
            let mut s = Rng::new(seed, b);
            let mut hits = 0usize;
            for _ in 0..batch {
                let (sx, sy) = (2.0 * s.next_f32() - 1.0, 1.0 - 2.0 * s.next_f32());
                let aspect = w as f32 / h as f32;
                let mut o = Vec3::ZERO;
                let mut d = Vec3::new(sx * tan * aspect, sy * tan, -1.0).normalize();
                loop {
                    let t = -(1.0 - s.next_f32()).ln() / sigma_t;
                    o += d * t;
                    if o.abs().max_element() >= 1.0 {
                        hits += 1;
                        break;
                    }
                    if s.next_f32() >= albedo {
                        break;
                    }
                    d = s.unit_vector();
                }
            }
            hits as f64 / batch as f64
        })
        .collect()
}

/// Albedo 0.999 at optical thickness 0.01 and 100: the furnace walls still emit L_e = 1, but
/// paths are now absorbed after ~1000 scatterings, so the radiance falls below L_e by an amount
/// with no closed form (to about a quarter in the dense case). Both photon-mapping estimates must
/// agree with the analog random walk (Welch t-test) within their bias bound: the wall loss of the
/// furnace test plus the smoothing of a field that now varies, at most r² L_e / (2 L_d²) with the
/// diffusion length L_d = 1/√(3 σ_a σ_t) (the kernels' second moments are below r², and
/// ∇²L = L/L_d² in the diffusion limit).
/// The path tracer must agree too, without bias allowance. Before it weighed next-event estimation
/// against phase sampling (MIS), it read about 0.04 here where the answer is about 0.26: light
/// sampling picks a point on a whole wall, so a collision within a mean free path (1/50) of the
/// wall scored rarely and hugely (the 1/d² of the geometry term).
#[test]
fn albedo_0999_photon_mapping_and_path_tracing_match_an_analog_walk() {
    for (sigma_t, r, photons, seeds, iterations) in
        [(0.005f32, 0.3f64, 20_000u64, 12u64, 16u64), (50.0, 0.03, 10_000, 16, 4)]
    {
        let albedo = 0.999f32;
        let sigma_a = Vec3::splat((1.0 - albedo) * sigma_t);
        let sigma_s = Vec3::splat(albedo * sigma_t);
        let scene = furnace(Vec3::ONE, homogeneous(sigma_a, sigma_s, 0.0));
        let walk = analog_walk(&scene, sigma_t, albedo, 32_000, 77);
        let (truth, _) = mean_and_se(&walk);
        // Thin: nearly every walk escapes. Dense: most are absorbed.
        assert!(sigma_t < 1.0 || truth < 0.5, "σ_t = {sigma_t}: walk reads {truth}");
        let l_d = 1.0 / (3.0 * sigma_a.x as f64 * sigma_t as f64).sqrt();
        let bias = furnace_bias(1.0, sigma_t as f64, r) + r * r / (2.0 * l_d * l_d);
        for (estimate, integrator) in METHODS {
            let run = Run { estimate, integrator, r, photons, iterations };
            let xs = run.means(&scene, 100..100 + seeds);
            let bias = if integrator == Integrator::Path { 0.0 } else { bias };
            assert_two_agree(
                &format!(
                    "albedo 0.999, σ_t = {sigma_t}, {estimate:?} {integrator:?} vs analog walk"
                ),
                &xs,
                &walk,
                bias,
            );
        }
    }
}

/// Ten thousand small iterations: the radius follows the schedule to the last iteration (and its
/// asymptote r₁ N^((α−1)/3) within 20 %), no sample is non-finite, and the mean does not drift —
/// the means of the first and second halves of the iterations agree with each other and with L_e.
/// Each iteration's image mean is recovered from the running mean; iterations are independent,
/// so the halves' standard errors come from the spread of those 5000 values each.
#[test]
fn ten_thousand_iterations_without_stall_or_drift() {
    const N: u64 = 10_000;
    let le = 1.0;
    let mut scene = furnace(Vec3::splat(le), homogeneous(Vec3::ZERO, Vec3::splat(1.0), 0.0));
    scene.set_resolution([4, 4]).unwrap();
    let mut s = volume_settings(VolumeEstimate::Beam, 0.05, 7);
    s.iterations = Some(N);
    s.photons = 100;
    let mut per_iteration = Vec::with_capacity(N as usize);
    let mut previous = 0.0;
    let mut on_iteration = |st: &Status| {
        let mean = st.film.mean();
        let m = mean.iter().flatten().map(|&c| c as f64).sum::<f64>() / (mean.len() * 3) as f64;
        let i = st.iteration() as f64;
        per_iteration.push(i * m - (i - 1.0) * previous);
        previous = m;
    };
    let img = haze::render(&scene, &s, &mut on_iteration, &AtomicBool::new(false)).unwrap();
    assert_eq!(img.info.iterations, N);
    assert_eq!(img.info.nonfinite_samples, 0);
    let r = img.info.volume_radius;
    assert!(r > 0.0 && r.is_finite());
    assert!((r - radius(N, 0.05, 0.5, 3)).abs() <= 1e-12 * r);
    let asymptote = 0.05 * (N as f64).powf(-0.5 / 3.0) / statrs::function::gamma::gamma(1.5).cbrt();
    assert!((r / asymptote - 1.0).abs() < 0.2, "r = {r}, asymptote {asymptote}");
    assert!(per_iteration.iter().all(|m| m.is_finite()));
    let (first, second) = per_iteration.split_at(N as usize / 2);
    let bias = furnace_bias(le as f64, 1.0, 0.05);
    assert_two_agree("first against second half of the iterations", first, second, 0.0);
    assert_agrees("first half against L_e", first, le as f64, bias);
    assert_agrees("second half against L_e", second, le as f64, bias);
}

/// Thinning photon-dense cells is unbiased: a point light inside the medium crowds photons around
/// itself; with a cell budget of 2 most of them are dropped and the survivors carry more power.
/// The same seed gives the same photons before thinning, so the per-seed differences of the image
/// means with and without thinning have expectation exactly zero (paired t-test).
#[test]
fn thinning_dense_photons_keeps_the_mean() {
    let medium = homogeneous(Vec3::splat(0.1), Vec3::splat(1.5), 0.3);
    let light = LightDesc::point([0.1, -0.1, -0.6], 20.0);
    let scene = furnace_with_light(Vec3::ZERO, medium, Some(light));
    let diffs: Vec<f64> = (0..16)
        .map(|seed| {
            let full = volume_settings(VolumeEstimate::Beam, 0.04, 300 + seed);
            let thin = RenderSettings { beam_cell_budget: Some(2), ..full.clone() };
            image_mean(&scene, &thin) - image_mean(&scene, &full)
        })
        .collect();
    assert!(diffs.iter().any(|d| *d != 0.0), "thinning changed nothing");
    assert_agrees("thinned minus unthinned image mean", &diffs, 0.0, 0.0);
}

/// A pass-through box (vacuum on both sides) changes nothing, even with its top a hair below an
/// area light: the path tracer's image means with and without it agree (Welch t-test). Shadow rays
/// used to stop short of the light by a relative 10⁻⁴ of their length, but each interface offset
/// pushed their end further, past the light, which then blocked them: next-event estimation lost
/// the light for every point within ~10⁴ offsets of such an interface.
#[test]
fn pass_through_interfaces_near_an_area_light_do_not_block_it() {
    use haze::scene::{CameraDesc, Material, SceneBuilder, ShapeDesc};
    let build = |with_box: bool| {
        let fov = 2.0 * 0.5f32.atan().to_degrees();
        let camera =
            CameraDesc::perspective([0.0, 0.5, 2.5], [0.0, 0.3, 0.0], fov).resolution(8, 8);
        let mut b = SceneBuilder::new(camera);
        let white = b.material("white", Material::diffuse(0.5)).unwrap();
        b.shape(ShapeDesc::rectangle(4.0, 4.0).material(white).rotate([-90.0, 0.0, 0.0])).unwrap();
        let lamp = ShapeDesc::rectangle(0.5, 0.5).material(white).emission(5.0);
        b.shape(lamp.rotate([90.0, 0.0, 0.0]).translate([0.0, 1.0, 0.0])).unwrap();
        if with_box {
            let glass = b.material("boundary", Material::Interface).unwrap();
            // Top face 0.02 below the lamp: 2·10³ ray offsets.
            let cube = ShapeDesc::cuboid([1.5, 0.78, 1.5]).material(glass);
            b.shape(cube.translate([0.0, 0.59, 0.0])).unwrap();
        }
        b.build().unwrap()
    };
    let means = |scene: &Scene| -> Vec<f64> {
        (0..16)
            .map(|seed| {
                let s = RenderSettings {
                    iterations: Some(128),
                    integrator: Integrator::Path,
                    max_bounces: 4,
                    seed,
                    ..RenderSettings::default()
                };
                image_mean(scene, &s)
            })
            .collect()
    };
    let (with, without) = (means(&build(true)), means(&build(false)));
    assert_two_agree("path tracer with and without a pass-through box", &with, &without, 0.0);
}

/// Photon memory per iteration stays bounded, whatever the medium: the albedo roulette ends paths
/// where the medium absorbs, and a pass of M light paths stores every photon of a path's first
/// A = max(32, 2²⁰/M) events and each later one (the k-th) with probability A/k (power divided by
/// it), so a path of K events stores at most A(1 + ln(K/A)) photons in expectation. Two media
/// that once took gigabytes: the dense fog (τ 120, albedo 0.999: ~1000 events per path) with
/// 20,000 light paths (A = 52), and an albedo-0.001 medium with σ_t = 1000 and a bounce limit of
/// 10,000 (paths never ended: 6 GB for 2,000 paths; A = 524).
#[test]
fn photon_memory_is_bounded_per_iteration() {
    let dense = Scene::load(crate::common::scene_path("dense-fog.toml")).unwrap();
    let absorbing = Scene::from_toml(
        &std::fs::read_to_string(crate::common::scene_path("dense-fog.toml"))
            .unwrap()
            .replace("sigma_a = 0.06\nsigma_s = 59.94", "sigma_a = 999\nsigma_s = 1"),
        std::path::Path::new("absorbing.toml"),
        &crate::common::scene_path(""),
    )
    .unwrap();
    for (name, mut scene, paths, bounces) in
        [("dense fog", dense, 20_000u64, 20_000u32), ("absorbing", absorbing, 2_000, 10_000)]
    {
        scene.set_resolution([64, 64]).unwrap();
        let s = RenderSettings {
            iterations: Some(1),
            photons: paths,
            max_bounces: bounces,
            // Every light path asked for is traced (the combined integrator's pilot may trace
            // fewer, and splits in dense fog).
            integrator: haze::settings::Integrator::Hybrid,
            ..scene.settings.clone()
        };
        let mut stored = 0u64;
        let mut on_iteration = |st: &Status| stored = st.photons_stored + st.volume_photons_stored;
        haze::render(&scene, &s, &mut on_iteration, &AtomicBool::new(false)).unwrap();
        let per_path = stored as f64 / paths as f64;
        let a = (1_048_576.0 / paths as f64).max(32.0);
        let bound = a * (1.0 + (bounces as f64 / a).ln());
        assert!(per_path <= 1.05 * bound, "{name}: {per_path:.1} photons per light path");
        assert!(stored > 0, "{name}: no photons");
        eprintln!("{name}: {per_path:.2} photons per light path (bound {bound:.1})");
    }
}
