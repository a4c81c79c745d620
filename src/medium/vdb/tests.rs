//! Tests of the OpenVDB medium: albedo, extinction and emission grids point by point, and its
//! tracking (transmittance, free flights, emission) against analytic integrals and histograms.

#![cfg(test)]

use super::super::{BEAM_SEGMENT_RATE, Medium};
use super::*;
use crate::medium::blackbody::blackbody;
use crate::rng::Sampler;
use crate::testing::{ChiSquare, Domain, Sample, assert_agrees, batch_means};
use glam::DVec2;
use std::path::Path;

fn media(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("media").join(name)
}

fn grid_medium(file: &str, scale: f32, sigma_a: Vec3, sigma_s: Vec3) -> Medium {
    let grid = DensityGrid::load(&media(file), "density").unwrap();
    let phase = HenyeyGreenstein { g: 0.0 };
    Medium::Vdb(Box::new(VdbMedium::new(grid, Affine3A::IDENTITY, scale, sigma_a, sigma_s, phase)))
}

/// Grid `name` of media/albedo.vdb (`density`, and channels linear along x, y and z).
fn albedo_grid(name: &str) -> DensityGrid {
    DensityGrid::load(&media("albedo.vdb"), name).unwrap()
}

/// media/albedo.vdb's three channels `albedo.r`, `.g`, `.b` as a colour field scaled by `scale`.
fn albedo_field(scale: f32) -> ColourField {
    let names = ["albedo.r", "albedo.g", "albedo.b"].map(String::from);
    ColourField::new(names.clone().map(|n| albedo_grid(&n)), names, Affine3A::IDENTITY, scale)
}

/// An albedo grid sets σ_s(p) = albedo(p) σ_t(p) and σ_a(p) = σ_t(p) − σ_s(p) per channel
/// (coloured extinction included), replacing the constant split, and the medium emits σ_a(p)
/// L_e: media/albedo.vdb's channels are linear along x, y and z.
#[test]
fn albedo_grids_set_the_scattering_share_point_by_point() {
    let load = albedo_grid;
    let field = albedo_field(1.0);
    let (sigma_a, sigma_s) = (Vec3::new(0.5, 0.2, 1.0), Vec3::new(0.5, 0.3, 1.0));
    let sigma_t = sigma_a + sigma_s;
    let m = VdbMedium::new(
        load("density"),
        Affine3A::IDENTITY,
        1.0,
        sigma_a,
        sigma_s,
        HenyeyGreenstein { g: 0.0 },
    )
    .with_albedo_grid(Some(field))
    .with_emission(Rgb::splat(2.0), None);
    assert!(m.emits());
    // Voxel centres at i/16: albedo R = 0.1 + 0.8·16x/15, G = 0.9 − 0.8·16y/15, B = 0.1 +
    // 0.8·16z/15 inside the box of centres, where the density is 1.
    for p in [Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.8, 0.05, 0.5), Vec3::new(0.33, 0.9, 0.71)] {
        let k = 0.8 * 16.0 / 15.0;
        let albedo = Rgb::new(0.1 + k * p.x, 0.9 - k * p.y, 0.1 + k * p.z);
        let close = |a: Rgb, b: Rgb| (a - b).abs().max_element() < 1e-5;
        assert!(close(m.sigma_s(p), albedo * sigma_t), "σ_s at {p}: {}", m.sigma_s(p));
        assert!(close(m.sigma_a(p), (Rgb::ONE - albedo) * sigma_t), "σ_a at {p}");
    }
    // Outside the grid: nothing.
    assert_eq!(m.sigma_s(Vec3::splat(3.0)), Rgb::ZERO);
}

/// `m` with cells bisected whenever more than `split` tentative collisions are expected in
/// them (1 bisects nearly every cell with a density edge in it).
fn with_split(mut m: Medium, split: f32) -> Medium {
    if let Medium::Vdb(v) = &mut m {
        v.split_steps = split;
    }
    m
}

fn batches(n: usize, k: usize, seed: u64, f: impl FnMut(&mut Sampler) -> f64) -> Vec<f64> {
    batch_means(k, n, seed, f)
}

/// Ratio tracking and delta tracking through the gradient slab against exp(−optical depth):
/// density(x) = x + 1/64 along x (voxel i holds (i + ½)/32 at x = i/32, and trilinear
/// interpolation of a linear function is exact), so with extinction σ per unit density and
/// density scale s the optical depth from x = a to b is τ = σ s [(b² − a²)/2 + (b − a)/64].
/// Both estimators are unbiased: t-tests over batch means, no bias allowance.
#[test]
fn transmittance_through_the_gradient_matches_the_analytic_integral() {
    let (sigma, scale) = (1.0f32, 2.0f32);
    let grid = grid_medium("gradient.vdb", scale, Vec3::splat(0.2), Vec3::splat(sigma - 0.2));
    // As built, and with cells bisected under tighter bounds wherever it can help.
    for (k, split) in [SPLIT_STEPS, 1.0].into_iter().enumerate() {
        let m = with_split(grid.clone(), split);
        let seed = 10 * k as u64;
        let (a, b) = (0.1f64, 0.9f64);
        let tau = (sigma * scale) as f64 * ((b * b - a * a) / 2.0 + (b - a) / 64.0);
        let o = Vec3::new(a as f32, 0.25, 0.25);
        let len = (b - a) as f32;
        let ratio = batches(4000, 20, seed + 1, |s| m.transmittance(o, Vec3::X, len, s).x as f64);
        assert_agrees(&format!("ratio tracking, split {split}"), &ratio, (-tau).exp(), 0.0);
        // At 4 times the majorants, as next-event estimation towards emitting media runs it.
        let rated = batches(4000, 20, seed + 4, |s| {
            m.transmittance_at_rate(o, Vec3::X, len, 4.0, s).x as f64
        });
        assert_agrees(
            &format!("ratio tracking at rate 4, split {split}"),
            &rated,
            (-tau).exp(),
            0.0,
        );
        let passes = batches(4000, 20, seed + 2, |s| {
            if m.sample_free_flight(o, Vec3::X, len, s).scattered { 0.0 } else { 1.0 }
        });
        assert_agrees(&format!("delta tracking, split {split}"), &passes, (-tau).exp(), 0.0);
        // The step function is a ratio-tracking estimate at every t: at the beam estimate's
        // rate, and at rate 1 as single scattering in the path tracer uses it.
        let mid = a + (b - a) / 2.0;
        let tau_half = (sigma * scale) as f64 * ((mid * mid - a * a) / 2.0 + (mid - a) / 64.0);
        for (j, rate) in [BEAM_SEGMENT_RATE, 1.0].into_iter().enumerate() {
            let half = batches(4000, 20, seed + 3 + 100 * j as u64, |s| {
                m.segment(o, Vec3::X, len, rate, s).at(len / 2.0).x as f64
            });
            let what = format!("segment at t/2, rate {rate}, split {split}");
            assert_agrees(&what, &half, (-tau_half).exp(), 0.0);
        }
    }
}

/// Russian roulette in ratio tracking keeps it unbiased where it plays: through the gradient
/// slab at density scale 12 (optical depth 4.7, T ≈ 0.009, so almost every walk drops below
/// the tracker's roulette threshold) transmittance at rates 1 and 4 and the beam's step function at
/// both ends agree with exp(−τ) by t-tests; and most walks at rate 4 end at zero before the
/// segment's end, which without roulette none would.
#[test]
fn russian_roulette_keeps_ratio_tracking_unbiased_through_thick_media() {
    let (sigma, scale) = (1.0f32, 12.0f32);
    let m = grid_medium("gradient.vdb", scale, Vec3::splat(0.2), Vec3::splat(sigma - 0.2));
    let depth = |a: f64, b: f64| (sigma * scale) as f64 * ((b * b - a * a) / 2.0 + (b - a) / 64.0);
    let (a, b) = (0.1f64, 0.9f64);
    let o = Vec3::new(a as f32, 0.25, 0.25);
    let len = (b - a) as f32;
    for (k, rate) in [1.0f32, 4.0].into_iter().enumerate() {
        let tr = batches(4000, 20, 30 + k as u64, |s| {
            m.transmittance_at_rate(o, Vec3::X, len, rate, s).x as f64
        });
        assert_agrees(&format!("ratio tracking at rate {rate}"), &tr, (-depth(a, b)).exp(), 0.0);
    }
    let (mid, end) = (a + (b - a) / 2.0, len * 0.999);
    let steps = batches(4000, 20, 40, |s| {
        m.segment(o, Vec3::X, len, BEAM_SEGMENT_RATE, s).at(end).x as f64
    });
    let far = depth(a, a + end as f64);
    assert_agrees("segment near its end", &steps, (-far).exp(), 0.0);
    let half = batches(4000, 20, 41, |s| {
        m.segment(o, Vec3::X, len, BEAM_SEGMENT_RATE, s).at(len / 2.0).x as f64
    });
    assert_agrees("segment at t/2", &half, (-depth(a, mid)).exp(), 0.0);
    // At rate 4 every factor is at least ¾, so only roulette can end a walk at zero.
    let Medium::Vdb(v) = &m else { unreachable!() };
    let mut s = Sampler::new(42, crate::rng::Purpose::Other, 0, 0);
    let ended = (0..1000)
        .filter(|_| {
            let steps =
                crate::medium::tracker::transmittance_steps(&**v, o, Vec3::X, len, 4.0, &mut s);
            steps.last().is_some_and(|&(_, t)| t.x == 0.0)
        })
        .count();
    assert!(ended > 500, "{ended} of 1000 walks ended by roulette");
}

/// Coloured extinction through the gradient grid (σ_t = 0.5, 1, 2 per unit density in the
/// three channels), see [`assert_unbiased_in_every_channel`].
#[test]
fn coloured_extinction_is_unbiased_in_every_channel() {
    let sigma_t = Vec3::new(0.5, 1.0, 2.0);
    let sigma_a = Vec3::new(0.1, 0.5, 1.5);
    let le = Rgb::new(1.0, 2.0, 3.0);
    let m = emitting(grid_medium("gradient.vdb", 2.0, sigma_a, sigma_t - sigma_a), le, None);
    let a = 0.1f64;
    let ray = Ray { o: Vec3::new(a as f32, 0.25, 0.25), len: 0.8 };
    // τ_c from x = a to a + t, and σ_t,c at a + t.
    let depth = |c: usize, t: f64| {
        let x = a + t;
        sigma_t[c] as f64 * 2.0 * ((x * x - a * a) / 2.0 + (x - a) / 64.0)
    };
    let sigma_t_at = |c: usize, t: f32| sigma_t[c] * 2.0 * (ray.o.x + t + 1.0 / 64.0);
    let largest =
        assert_unbiased_in_every_channel(&m, ray, depth, sigma_t_at, le * sigma_a / sigma_t, 80);
    assert!(largest <= 3.0 + 1e-4, "a weight reached {largest}");
}

/// Extinction coloured by grids: media/albedo.vdb's three linear channels (R rising along x,
/// G falling along y, B rising along z, between 0.1 and 0.9 at voxel centres, density 1) times
/// a scale of 2.5 (so that the field, at most 2.25, is normalised into σ_t) colour σ_t = 0.5,
/// 1, 2 per unit density. Along x at y = 0.3, z = 0.6, σ_t,c(x) = σ_c · 2.5 · e_c(x) with
/// e_R linear in x and e_G, e_B constant; σ_a and σ_s scale with it (the albedo stays). See
/// [`assert_unbiased_in_every_channel`], with the majorants as built and bisected.
#[test]
fn extinction_grids_colour_the_extinction_point_by_point() {
    let load = albedo_grid;
    let field = albedo_field(2.5);
    let sigma_t = Vec3::new(0.5, 1.0, 2.0);
    let sigma_a = Vec3::new(0.1, 0.5, 1.5);
    let le = Rgb::new(1.0, 2.0, 3.0);
    let g = HenyeyGreenstein { g: 0.0 };
    let v = VdbMedium::new(load("density"), Affine3A::IDENTITY, 1.0, sigma_a, sigma_t - sigma_a, g)
        .with_extinction_grid(Some(field))
        .with_emission(le, None);
    let m = Medium::Vdb(Box::new(v));
    let k = 0.8 * 16.0 / 15.0;
    let e = |p: Vec3| Rgb::new(0.1 + k * p.x, 0.9 - k * p.y, 0.1 + k * p.z) * 2.5;
    for p in [Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.8, 0.05, 0.5)] {
        let close = |a: Rgb, b: Rgb| (a - b).abs().max_element() < 1e-5 * b.max_element();
        assert!(close(m.sigma_a(p), sigma_a * e(p)), "σ_a at {p}: {}", m.sigma_a(p));
        let Medium::Vdb(v) = &m else { unreachable!() };
        assert!(close(v.sigma_s(p), (sigma_t - sigma_a) * e(p)), "σ_s at {p}");
    }
    let (a, y, z) = (0.1f64, 0.3f32, 0.6f32);
    let ray = Ray { o: Vec3::new(a as f32, y, z), len: 0.7 };
    let depth = |c: usize, t: f64| {
        let x = a + t;
        let mean = match c {
            0 => 0.1 * t + k as f64 * (x * x - a * a) / 2.0,
            1 => (0.9 - k * y) as f64 * t,
            _ => (0.1 + k * z) as f64 * t,
        };
        sigma_t[c] as f64 * 2.5 * mean
    };
    let sigma_t_at = |c: usize, t: f32| sigma_t[c] * e(ray.o + Vec3::X * t)[c];
    // The majorants follow the field (its grids share the density's index space).
    let Medium::Vdb(v) = &m else { unreachable!() };
    let e = v.extinction_majorant.as_ref().expect("the field's majorants");
    let tightest = e.stored().fold(1.0f32, f32::min);
    assert!(tightest < 0.9, "extinction majorants {e:?}");
    // As built, and with cells bisected wherever a tighter bound can help.
    for (k, split) in [SPLIT_STEPS, 1.0].into_iter().enumerate() {
        let m = with_split(m.clone(), split);
        let share = le * sigma_a / sigma_t;
        let seed = 90 + 100 * k as u64;
        let largest = assert_unbiased_in_every_channel(&m, ray, depth, sigma_t_at, share, seed);
        assert!(largest <= 3.0 + 1e-4, "a weight reached {largest}");
    }
}

/// A segment along +x.
#[derive(Clone, Copy)]
struct Ray {
    o: Vec3,
    len: f32,
}

/// Per channel c along `ray` through `m`, with optical depth `depth(c, t)` from its origin
/// and extinction `sigma_t_at(c, t)`: ratio tracking's transmittance and the beam's step
/// function at t/2 against e^{−τ_c}; spectral delta tracking's weights, whose expectations
/// are E[W_c; passes] = T_c(L) and E[W_c σ_t,c(x); collides] = 1 − T_c(L); and the emission,
/// `share`_c (1 − e^{−τ_c}) where `share` is L_e σ_a / σ_t. t-tests over batch means, no bias
/// allowance. Returns the largest of W_c σ_t,c at a collision and W_c when passing (the
/// weights stay bounded: at most 3).
fn assert_unbiased_in_every_channel(
    m: &Medium,
    ray: Ray,
    depth: impl Fn(usize, f64) -> f64,
    sigma_t_at: impl Fn(usize, f32) -> f32,
    share: Rgb,
    seed: u64,
) -> f32 {
    let (o, len) = (ray.o, ray.len);
    let mut largest = 0.0f32;
    for c in 0..3 {
        let tr = (-depth(c, len as f64)).exp();
        let seed = seed + 10 * c as u64;
        let ratio = batches(4000, 20, seed, |s| m.transmittance(o, Vec3::X, len, s)[c] as f64);
        assert_agrees(&format!("ratio tracking, channel {c}"), &ratio, tr, 0.0);
        let rated = batches(4000, 20, seed + 5, |s| {
            m.transmittance_at_rate(o, Vec3::X, len, 4.0, s)[c] as f64
        });
        assert_agrees(&format!("ratio tracking at rate 4, channel {c}"), &rated, tr, 0.0);
        let want = (-depth(c, len as f64 / 2.0)).exp();
        for (j, rate) in [BEAM_SEGMENT_RATE, 1.0].into_iter().enumerate() {
            let half = batches(4000, 20, seed + 1 + 100 * j as u64, |s| {
                m.segment(o, Vec3::X, len, rate, s).at(len / 2.0)[c] as f64
            });
            assert_agrees(&format!("steps at t/2, rate {rate}, channel {c}"), &half, want, 0.0);
        }
        let (mut pass, mut hit) = (Vec::new(), Vec::new());
        for k in 0..20 {
            let (mut sp, mut sh) = (0.0f64, 0.0f64);
            let mut s = Sampler::new(seed + 2, crate::rng::Purpose::Photon, k, 0);
            for _ in 0..4000 {
                let f = m.sample_free_flight(o, Vec3::X, len, &mut s);
                if f.scattered {
                    let w = f.weight[c] * sigma_t_at(c, f.t);
                    largest = largest.max(w);
                    sh += w as f64;
                } else {
                    largest = largest.max(f.weight[c]);
                    sp += f.weight[c] as f64;
                }
            }
            pass.push(sp / 4000.0);
            hit.push(sh / 4000.0);
        }
        assert_agrees(&format!("delta tracking passes, channel {c}"), &pass, tr, 0.0);
        assert_agrees(&format!("delta tracking collides, channel {c}"), &hit, 1.0 - tr, 0.0);
        let emitted = batches(4000, 20, seed + 3, |s| m.emitted(o, Vec3::X, len, s)[c] as f64);
        let want = share[c] as f64 * (1.0 - tr);
        assert_agrees(&format!("emission, channel {c}"), &emitted, want, 0.0);
    }
    largest
}

/// `m` emitting `le` wherever it absorbs, and blackbody light from `temperature`.
fn emitting(m: Medium, le: Rgb, temperature: Option<TemperatureField>) -> Medium {
    match m {
        Medium::Vdb(v) => Medium::Vdb(Box::new(v.with_emission(le, temperature))),
        other => other,
    }
}

/// Emission along a ray through the gradient grid, where σ_a and σ_t are both proportional
/// to the density: ∫ T σ_a L_e dt = L_e (σ_a/σ_t)(1 − e^{−τ}) whatever the profile. The
/// ratio-tracking estimate is unbiased: t-tests over batch means per channel, no bias
/// allowance, with cells as built and bisected everywhere.
#[test]
fn emission_through_the_gradient_matches_the_analytic_integral() {
    let (sigma_a, sigma_s) = (Vec3::new(0.3, 0.5, 0.7), Vec3::new(0.7, 0.5, 0.3));
    let le = Rgb::new(2.0, 1.0, 0.5);
    let grid = emitting(grid_medium("gradient.vdb", 2.0, sigma_a, sigma_s), le, None);
    assert!(grid.emits());
    let (a, b) = (0.1f64, 0.9f64);
    let tau = 2.0 * ((b * b - a * a) / 2.0 + (b - a) / 64.0);
    let o = Vec3::new(a as f32, 0.25, 0.25);
    for (k, split) in [SPLIT_STEPS, 1.0].into_iter().enumerate() {
        let m = with_split(grid.clone(), split);
        for c in 0..3 {
            let seed = 40 + 3 * k as u64 + c as u64;
            let got =
                batches(4000, 20, seed, |s| m.emitted(o, Vec3::X, (b - a) as f32, s)[c] as f64);
            let want = (le[c] * sigma_a[c]) as f64 * -(-tau).exp_m1();
            assert_agrees(&format!("emission, channel {c}, split {split}"), &got, want, 0.0);
        }
    }
    // A grid that does not absorb cannot emit, and draws nothing.
    let clear = emitting(grid_medium("gradient.vdb", 2.0, Vec3::ZERO, Vec3::ONE), le, None);
    assert!(!clear.emits());
    let mut s = Sampler::new(1, crate::rng::Purpose::Camera, 0, 0);
    assert_eq!(clear.emitted(o, Vec3::X, 0.8, &mut s), Rgb::ZERO);
}

/// The emission along x from 0.1 to 0.9 through a medium on the gradient grid (σ_t 1 per unit
/// density, scale 2: τ(x) = 2 ∫ (s + 1/64) ds) agrees per channel with a 4000-step midpoint
/// quadrature of ∫ T σ_a L_e dx, `source(x, c)` being σ_a L_e in channel c (t-test over batch
/// means; the quadrature's error, below 10⁻⁶ of the result for smooth sources, allowed for).
fn assert_emission_along_the_gradient(
    m: &Medium,
    what: &str,
    seed: u64,
    source: impl Fn(f64, usize) -> f64,
) {
    let (a, b) = (0.1f64, 0.9f64);
    let n = 4000;
    let mut want = [0.0f64; 3];
    for i in 0..n {
        let x = a + (b - a) * (i as f64 + 0.5) / n as f64;
        let tau = 2.0 * ((x * x - a * a) / 2.0 + (x - a) / 64.0);
        for (c, w) in want.iter_mut().enumerate() {
            *w += (-tau).exp() * source(x, c) * (b - a) / n as f64;
        }
    }
    let o = Vec3::new(a as f32, 0.25, 0.25);
    for (c, want) in want.into_iter().enumerate() {
        let got = batches(4000, 20, seed + c as u64, |s| {
            m.emitted(o, Vec3::X, (b - a) as f32, s)[c] as f64
        });
        assert_agrees(&format!("{what}, channel {c}"), &got, want, 1e-6 * want);
    }
}

/// A temperature grid's emission: L_e(p) = scale_bb · B̂((T(p) − offset) · scale) above the
/// cutoff and zero below it, read trilinearly from its own grid; and the emission along a ray
/// through a grid with it agrees with a quadrature of ∫ T σ_a L_e dt (t-test over batch
/// means; the quadrature's error, 4000 midpoint steps of a smooth integrand, is below 10⁻⁶
/// of the result and allowed for).
#[test]
fn temperature_grids_emit_blackbody_light() {
    let raw = DensityGrid::load(&media("gradient.vdb"), "density").unwrap();
    // T = 3000 (x + 1/64 − 0.05): below the 500 K cutoff where x < 0.2.
    let field = TemperatureField::new(raw, Affine3A::IDENTITY, 3000.0, 0.05, 500.0, 0.5);
    let density = |x: f64| x + 1.0 / 64.0;
    let temperature = |x: f64| ((density(x) - 0.05) * 3000.0) as f32;
    for x in [0.1f32, 0.15, 0.25, 0.5, 0.85] {
        let p = Vec3::new(x, 0.25, 0.25);
        let t = temperature(x as f64);
        let want = if t > 500.0 { blackbody(t) * 0.5 } else { Rgb::ZERO };
        let got = field.le(p);
        assert!(
            (got - want).abs().max_element() <= 1e-4 * want.max_element().max(1e-6),
            "{x}: {got} vs {want}"
        );
    }
    let (sigma_a, sigma_s) = (Vec3::splat(0.6), Vec3::splat(0.4));
    let m = emitting(grid_medium("gradient.vdb", 2.0, sigma_a, sigma_s), Rgb::ZERO, Some(field));
    assert!(m.emits());
    let source = |x: f64, c: usize| {
        let le = if temperature(x) > 500.0 { blackbody(temperature(x)) * 0.5 } else { Rgb::ZERO };
        0.6 * 2.0 * density(x) * le[c] as f64
    };
    assert_emission_along_the_gradient(&m, "blackbody emission", 60, source);
}

/// Colour grids: L_e = scale × (R, G, B) read trilinearly from three float grids (here the
/// gradient grid as every channel, so L_e ∝ the raw density), and the emission along a ray
/// agrees with a quadrature of ∫ T σ_a L_e dt per channel (t-test over batch means).
#[test]
fn colour_grids_emit_their_values() {
    let raw = || DensityGrid::load(&media("gradient.vdb"), "density").unwrap();
    let names = ["density", "density", "density"].map(String::from);
    let field = ColourField::new([raw(), raw(), raw()], names, Affine3A::IDENTITY, 3.0);
    let density = |x: f64| x + 1.0 / 64.0;
    let p = Vec3::new(0.4, 0.25, 0.25);
    let want = 3.0 * density(0.4) as f32;
    assert!((field.at(p) - Rgb::splat(want)).abs().max_element() < 1e-5, "{}", field.at(p));
    let (sigma_a, sigma_s) = (Vec3::new(0.2, 0.5, 0.8), Vec3::new(0.8, 0.5, 0.2));
    let m = match grid_medium("gradient.vdb", 2.0, sigma_a, sigma_s) {
        Medium::Vdb(v) => Medium::Vdb(Box::new(v.with_emission_grid(Some(field)))),
        other => other,
    };
    assert!(m.emits());
    let source = |x: f64, c: usize| sigma_a[c] as f64 * 2.0 * density(x) * 3.0 * density(x);
    assert_emission_along_the_gradient(&m, "colour-grid emission", 90, source);
}

/// The null-scattering densities of free flights (`tracker::ln_flight_pdf`) against their
/// histograms, through the gradient along +x (the forward decision) and along −x from the
/// far end (the reverse one), for a grey extinction (delta tracking) and a coloured one
/// (spectral tracking, hero-averaged). With μ̄ the majorant pieces of the ray and
/// σ_c(x) = k t_c (x + 1/64): flights with no null collision collide at t with density
/// (1/C) Σ_c e^{−∫₀^t μ̄} σ_c(t) or pass with probability e^{−∫₀^L μ̄}; flights with one null at
/// t₁ collide at t₂ with density (1/C) Σ_c e^{−∫₀^{t₂} μ̄} (μ̄(t₁) − σ_c(t₁)) σ_c(t₂)
/// (chi-square; every other flight in the failure bin). At every such flight `ln_flight_pdf`
/// is the log of that density to 10⁻⁴: each of its few factors and the majorant integral
/// carry f32 rounding of about 10⁻⁷ relative, far below.
#[test]
fn null_scattering_densities_match_their_histograms() {
    use crate::medium::tracker::{Tracked, free_flight_with, ln_flight_pdf};
    let (lo, hi) = (0.05f64, 0.9f64);
    let len = hi - lo;
    let media = [("grey", Vec3::splat(1.5)), ("coloured", Vec3::new(1.5, 0.9, 0.6))];
    for (m_index, (name, sigma)) in media.into_iter().enumerate() {
        let scale = 2.0f32;
        let m = grid_medium("gradient.vdb", scale, Vec3::ZERO, sigma);
        let Medium::Vdb(v) = &m else { unreachable!() };
        let v: &VdbMedium = v;
        assert_eq!(v.coloured(), m_index == 1);
        let k = (sigma.max_element() * scale) as f64;
        let tint = (sigma / sigma.max_element()).as_dvec3();
        let channels = if m_index == 1 { 3 } else { 1 };
        for (j, (start, sign)) in [(lo, 1.0f64), (hi, -1.0)].into_iter().enumerate() {
            let o = Vec3::new(start as f32, 0.25, 0.25);
            let d = Vec3::X * sign as f32;
            let sigma_c = |c: usize, t: f64| tint[c] * k * (start + sign * t + 1.0 / 64.0);
            let mut pieces = Vec::new();
            v.majorants(o, d, len as f32, 1.0, |mu, a, b| {
                pieces.push((mu as f64, a as f64, b as f64));
                true
            });
            assert!(pieces.len() > 2, "{pieces:?}");
            let mu_at = |t: f64| pieces.iter().find(|p| t >= p.1 && t < p.2).map_or(0.0, |p| p.0);
            let integral =
                |t: f64| pieces.iter().map(|&(mu, a, b)| mu * (b.min(t) - a).max(0.0)).sum::<f64>();
            let mean =
                |f: &dyn Fn(usize) -> f64| (0..channels).map(f).sum::<f64>() / channels as f64;
            let p0 = |t: f64| (-integral(t)).exp() * mean(&|c| sigma_c(c, t));
            let pass = (-integral(len)).exp();
            let p1 = |t1: f64, t2: f64| {
                let null_real = mean(&|c| (mu_at(t1) - sigma_c(c, t1)) * sigma_c(c, t2));
                if t1 < t2 { (-integral(t2)).exp() * null_real } else { 0.0 }
            };
            for nulls_wanted in [0usize, 1] {
                let what = format!("{name}, {nulls_wanted} null, direction {sign}");
                let mut test =
                    ChiSquare::new(format!("null-scattering density, {what}"), Domain::Square, 8);
                test.seed = 10 + 4 * m_index as u64 + 2 * j as u64 + nulls_wanted as u64;
                // No null: collisions in the lower half, passes in the top right bin.
                test.bins = if nulls_wanted == 0 { [24, 2] } else { [8, 8] };
                test.run(
                    |s| {
                        let mut nulls = Vec::new();
                        let f = free_flight_with(v, o, d, len as f32, s, |t| nulls.push(t));
                        if nulls.len() != nulls_wanted || (!f.scattered && nulls_wanted == 1) {
                            return None;
                        }
                        let end = f.scattered.then_some(f.t);
                        let t = f.t as f64;
                        let want = match (nulls.first(), end) {
                            (None, Some(_)) => p0(t),
                            (None, None) => pass,
                            (Some(&t1), _) => p1(t1 as f64, t),
                        };
                        let got = ln_flight_pdf(v, o, d, len as f32, &nulls, end);
                        assert!((got - want.ln()).abs() < 1e-4, "{what}: {got} vs {}", want.ln());
                        Some(Sample::Point(match (nulls.first(), end) {
                            (None, Some(_)) => DVec2::new(t / len, 0.25),
                            (None, None) => DVec2::new(0.99, 0.75),
                            (Some(&t1), _) => DVec2::new(t1 as f64 / len, t / len),
                        }))
                    },
                    |p| {
                        let q = p.point();
                        match nulls_wanted {
                            0 if q.y < 0.5 => 2.0 * len * p0(q.x * len),
                            0 if q.x >= 23.0 / 24.0 => 48.0 * pass,
                            0 => 0.0,
                            _ => len * len * p1(q.x * len, q.y * len),
                        }
                    },
                );
            }
        }
    }
}

/// Delta tracking's free-flight distances follow the exact distribution for the gradient
/// profile: density σ_t(t) e^{−τ(t)}, and P(no collision) = e^{−τ(L)} (chi-square).
#[test]
fn delta_tracking_distances_follow_their_density() {
    let (sigma, scale) = (1.5f32, 2.0f32);
    let m = grid_medium("gradient.vdb", scale, Vec3::ZERO, Vec3::splat(sigma));
    let (a, len) = (0.05f64, 0.85f64);
    let k = (sigma * scale) as f64;
    let tau = |t: f64| k * (((a + t) * (a + t) - a * a) / 2.0 + t / 64.0);
    let sigma_t = |t: f64| k * (a + t + 1.0 / 64.0);
    let o = Vec3::new(a as f32, 0.25, 0.25);
    let mut test = ChiSquare::new("delta tracking", Domain::Square, 1);
    test.bins = [24, 1];
    test.samples = 100_000;
    test.run(
        |s| {
            let f = m.sample_free_flight(o, Vec3::X, len as f32, s);
            f.scattered.then(|| Sample::Point(DVec2::new(f.t as f64 / len, 0.5)))
        },
        |p| {
            let t = p.point().x * len;
            len * sigma_t(t) * (-tau(t)).exp()
        },
    );
}

/// Empty space and a 5× density contrast (cubes of 8, a sheet of 40, zero elsewhere): along a
/// ray through voxel centres the density is piecewise linear in x, so the optical depth is the
/// trapezoid sum of the voxel values; ratio and delta tracking must match e^{−τ} (t-tests).
#[test]
fn empty_regions_and_sharp_edges_are_tracked_without_bias() {
    let sigma = 0.25f32;
    let medium = grid_medium("holes.vdb", 1.0, Vec3::splat(0.05), Vec3::splat(sigma - 0.05));
    let grid = DensityGrid::load(&media("holes.vdb"), "density").unwrap();
    // As built, and with every cell that has an edge bisected under tighter bounds.
    for (split, (j, k)) in [SPLIT_STEPS, 1.0]
        .into_iter()
        .flat_map(|split| [(10, 10), (33, 20), (45, 45)].map(|row| (split, row)))
    {
        let m = with_split(medium.clone(), split);
        let v: Vec<f64> = (0..48).map(|i| grid.voxel(IVec3::new(i, j, k)) as f64).collect();
        let tau = sigma as f64 / 32.0 * v.windows(2).map(|w| (w[0] + w[1]) / 2.0).sum::<f64>();
        let o = Vec3::new(0.0, j as f32 / 32.0, k as f32 / 32.0);
        let len = 47.0 / 32.0;
        let ratio = batches(3000, 16, 4, |s| m.transmittance(o, Vec3::X, len, s).x as f64);
        let label = format!("row ({j}, {k}), split {split}");
        assert_agrees(&format!("ratio tracking, {label}"), &ratio, (-tau).exp(), 0.0);
        let passes = batches(3000, 16, 5, |s| {
            if m.sample_free_flight(o, Vec3::X, len, s).scattered { 0.0 } else { 1.0 }
        });
        assert_agrees(&format!("delta tracking, {label}"), &passes, (-tau).exp(), 0.0);
    }
}

/// A grid scaled to 10³⁰ (scenes/vdb-edges.toml with `density_scale = 1e30`): every cell
/// with a voxel of density in it has a majorant of 10³⁰ or more, so tracking a ray through
/// the empty part of such a cell at that rate would need ~10³⁰ steps. With cells bisected
/// under tighter bounds (and steps below t's precision moving on by an ulp), no tracking
/// reaches the step cap, every estimate is in [0, 1], and both outcomes occur: rays through
/// density are opaque, rays that miss it pass.
#[test]
fn a_grid_scaled_to_1e30_is_tracked_without_reaching_the_step_cap() {
    let m = grid_medium("holes.vdb", 1e30, Vec3::splat(0.1), Vec3::splat(0.9));
    let Medium::Vdb(v) = &m else { unreachable!() };
    let (mut opaque, mut clear) = (0, 0);
    for i in 0..3000u64 {
        let mut s = Sampler::new(9, crate::rng::Purpose::Other, 0, i);
        // From a point in the grid's box (1.5 units a side) across it.
        let o = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 1.5;
        let d = crate::math::sample_uniform_sphere(s.next_2d());
        let tr = m.transmittance(o, d, 3.0, &mut s).x;
        assert!((0.0..=1.0).contains(&tr), "ray {i}: transmittance {tr}");
        opaque += (tr == 0.0) as u32;
        clear += (tr == 1.0) as u32;
        let f = m.sample_free_flight(o, d, 3.0, &mut s);
        assert!(f.t.is_finite() && f.weight.x.is_finite(), "ray {i}: {f:?}");
        let steps = m.segment(o, d, 3.0, BEAM_SEGMENT_RATE, &mut s);
        assert!((0.0..=1.0).contains(&steps.at(1.0).x), "ray {i}");
    }
    assert_eq!(v.truncated_trackings(), 0, "trackings cut at the step cap");
    assert!(opaque > 100 && clear > 100, "{opaque} opaque, {clear} clear of 3000");
    // The cap stays as the last guard: without bisection, trackings through the empty part
    // of a cell with density elsewhere (here the corner of the first cube's cell, where
    // every factor is 1 and Russian roulette never plays) reach it, are counted, and end
    // opaque.
    let unsplit = with_split(m.clone(), f32::INFINITY);
    let Medium::Vdb(u) = &unsplit else { unreachable!() };
    let o = Vec3::new(0.0, 2.5 / 32.0, 2.5 / 32.0);
    for i in 0..8 {
        let mut s = Sampler::new(10, crate::rng::Purpose::Other, 0, i);
        assert_eq!(unsplit.transmittance(o, Vec3::X, 1.5, &mut s).x, 0.0);
    }
    assert!(u.truncated_trackings() > 0, "no tracking reached the cap without bisection");
}
