//! The original progressive photon mapping (Hachisuka, Ogaki & Jensen 2008), kept as a comparison
//! mode for the surface estimate (`progression = "original"`).
//!
//! Every pixel keeps its own statistics: a radius R, an accumulated photon count N and an
//! accumulated flux τ. After each photon pass the pixel's hit point gathers the M photons within R
//! (constant kernel) with flux Φ = Σ f β_p, and
//!
//!   N' = N + αM,   R'² = R² (N + αM) / (N + M),   τ' = (τ + β Φ) R'² / R²,
//!
//! so the radius shrinks only where photons arrive. The pixel's radiance is
//! τ / (π R² · light paths so far), plus the emission its eye paths saw directly (averaged).
//! A second flux τ_in, of the photons within R/√2 and updated by the same rule, gives the
//! estimate at half the area and so the kernel bias 2 (L − L_in) (docs/theory.md).
//!
//! The eye path is re-jittered every iteration, as in stochastic PPM (Hachisuka & Jensen 2009),
//! which uses the same update: with one fixed hit point per pixel the method would converge to a
//! one-sample-per-pixel image, not to the pixel-filtered image that the references and the
//! probabilistic mode converge to. Scenes with media are refused: the per-pixel statistics are
//! defined for surface hit points only.

use super::camera::{CameraPass, Maps, trace_eye};
use super::frame::{StepTimes, Stopwatch};
use super::ppm::PhotonMapper;
use crate::estimate::Estimate;
use crate::estimate::surface::NORMAL_COS;
use crate::math::Rgb;
use crate::photon::Photon;
use crate::photon::map::PhotonGrid;
use crate::plan::{Plan, Radii};
use crate::scene::Scene;
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// The original PPM: the photon mapper's photon pass and surface map, and per-pixel statistics.
pub(crate) struct OriginalPpm {
    mapper: PhotonMapper,
    /// The statistics after the last finished iteration.
    stats: OriginalState,
    /// A copy the next iteration updates, so that an interrupted one leaves `stats` untouched.
    next: OriginalState,
    /// The root-mean-square pixel radius at the start of the last iteration (reported as its
    /// radius).
    radius: f64,
}

impl OriginalPpm {
    pub(crate) fn new(scene: &Scene, plan: &Plan) -> Self {
        let mapper = PhotonMapper::new(scene, plan);
        let pixels = (scene.camera.resolution[0] * scene.camera.resolution[1]) as usize;
        let (r1, alpha) = (plan.surface.initial, plan.surface.alpha);
        Self {
            stats: OriginalState::new(pixels, r1, alpha),
            next: OriginalState::new(pixels, r1, alpha),
            radius: r1,
            mapper,
        }
    }

    /// Light paths per iteration.
    pub(crate) fn paths(&self) -> u64 {
        self.mapper.paths()
    }

    /// Surface and volume photons stored by the last photon pass.
    pub(crate) fn stored(&self) -> [u64; 2] {
        self.mapper.stored()
    }

    /// The radius the last iteration started from, and the volume schedule's (unused).
    pub(crate) fn radii(&self, i: u64) -> Radii {
        Radii { surface: self.radius, ..self.mapper.plan().radii(i) }
    }

    /// One iteration: photon pass, surface map for the largest pixel radius, gathering at every
    /// pixel's hit point.
    pub(crate) fn iterate(
        &mut self,
        scene: &Scene,
        i: u64,
        stop: &AtomicBool,
        nonfinite: &AtomicU64,
        frame: &mut super::frame::Frame,
    ) -> Option<StepTimes> {
        let mut times = StepTimes::default();
        let r = self.stats.rms_radius();
        let clock = Stopwatch::start();
        if !self.mapper.trace(scene, i, stop) {
            return None;
        }
        (times.photon_trace, times.processor.photon_trace) = clock.lap();
        let clock = Stopwatch::start();
        self.mapper.build_surface_map(self.stats.max_radius());
        (times.surface_map, times.processor.surface_map) = clock.lap();
        let clock = Stopwatch::start();
        let pass = self.mapper.camera_pass(i);
        self.next.pixels.copy_from_slice(&self.stats.pixels);
        let paths = i * self.mapper.paths();
        let maps = self.mapper.maps();
        if !gather_pass(scene, &maps, &pass, &mut self.next, paths, stop, nonfinite, frame) {
            return None;
        }
        std::mem::swap(&mut self.stats, &mut self.next);
        self.radius = r;
        (times.camera, times.processor.camera) = clock.lap();
        Some(times)
    }
}

impl OriginalPpm {
    /// The per-pixel statistics as bytes: per pixel R², N, τ (3), the direct sum (3) and τ_in
    /// (3), as little-endian f64, then the RMS radius reported last.
    pub(crate) fn save_state(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.stats.pixels.len() * STATE_BYTES + 8);
        for p in &self.stats.pixels {
            for v in [p.radius2, p.photons, p.flux.x, p.flux.y, p.flux.z]
                .into_iter()
                .chain([p.direct.x, p.direct.y, p.direct.z])
                .chain([p.flux_inner.x, p.flux_inner.y, p.flux_inner.z])
            {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out.extend_from_slice(&self.radius.to_le_bytes());
        out
    }

    /// Restores statistics saved by [`Self::save_state`] for an image of the same size.
    pub(crate) fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let n = self.stats.pixels.len();
        if bytes.len() == n * 64 + 8 {
            return Err("the partial render holds original-PPM statistics of an older haze \
                 (partial format 1, without the flux τ_in of the bias estimate): it cannot be \
                 resumed by this one; render again"
                .into());
        }
        if bytes.len() != n * STATE_BYTES + 8 {
            return Err(format!(
                "the partial render's original-PPM statistics hold {} bytes, not {} for {n} pixels",
                bytes.len(),
                n * STATE_BYTES + 8
            ));
        }
        let f =
            |k: usize| f64::from_le_bytes(bytes[8 * k..8 * k + 8].try_into().unwrap_or_default());
        let per = STATE_BYTES / 8;
        for (i, p) in self.stats.pixels.iter_mut().enumerate() {
            let b = per * i;
            p.radius2 = f(b);
            p.photons = f(b + 1);
            p.flux = DVec3::new(f(b + 2), f(b + 3), f(b + 4));
            p.direct = DVec3::new(f(b + 5), f(b + 6), f(b + 7));
            p.flux_inner = DVec3::new(f(b + 8), f(b + 9), f(b + 10));
        }
        self.radius = f(per * n);
        self.next.pixels.clone_from(&self.stats.pixels);
        Ok(())
    }
}

/// Bytes of one pixel's saved statistics (11 f64).
pub(crate) const STATE_BYTES: usize = 88;

/// One pixel's statistics.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PixelStats {
    /// Squared gathering radius R².
    pub radius2: f64,
    /// Accumulated (α-weighted) photon count N.
    pub photons: f64,
    /// Accumulated flux τ.
    pub flux: DVec3,
    /// Sum of the emission seen directly by the pixel's eye paths.
    pub direct: DVec3,
    /// Accumulated flux τ_in of the photons within R/√2 (the bias estimate's).
    pub flux_inner: DVec3,
}

/// The per-pixel state of an original-PPM render.
pub(crate) struct OriginalState {
    /// One entry per pixel, row-major.
    pub pixels: Vec<PixelStats>,
    /// Radius reduction α.
    pub alpha: f64,
}

impl OriginalState {
    /// Every pixel starts at radius `r1`, with no photons and no flux.
    pub fn new(pixels: usize, r1: f64, alpha: f64) -> Self {
        let zero = DVec3::ZERO;
        let p = PixelStats {
            radius2: r1 * r1,
            photons: 0.0,
            flux: zero,
            direct: zero,
            flux_inner: zero,
        };
        Self { pixels: vec![p; pixels], alpha }
    }

    /// The largest radius of any pixel (the photon grid must be built for it).
    pub fn max_radius(&self) -> f64 {
        self.pixels.iter().map(|p| p.radius2).fold(0.0, f64::max).sqrt()
    }

    /// The root-mean-square radius over the pixels (reported as the render's radius).
    pub fn rms_radius(&self) -> f64 {
        let n = self.pixels.len().max(1) as f64;
        (self.pixels.iter().map(|p| p.radius2).sum::<f64>() / n).sqrt()
    }
}

/// Gathers photons at every pixel's hit point for iteration `pass.iteration`, updates the
/// statistics and writes the current estimate and its kernel bias (after `iterations` photon
/// passes of `paths` light paths each) into `frame`. Returns `false` if `stop` was raised before it finished; the state is
/// then partly updated and must be discarded.
#[allow(clippy::too_many_arguments)]
pub(crate) fn gather_pass(
    scene: &Scene,
    maps: &Maps,
    pass: &CameraPass,
    state: &mut OriginalState,
    paths_so_far: u64,
    stop: &AtomicBool,
    nonfinite: &AtomicU64,
    frame: &mut super::frame::Frame,
) -> bool {
    let width = scene.camera.resolution[0] as usize;
    let alpha = state.alpha;
    let iterations = pass.iteration as f64;
    let surface: &PhotonGrid<Photon> = maps.surface;
    let out = frame.value.par_chunks_mut(width).zip(frame.bias.par_chunks_mut(width));
    state.pixels.par_chunks_mut(width).zip(out).enumerate().with_max_len(1).for_each(
        |(y, (stats, (row, bias)))| {
            if stop.load(Ordering::Relaxed) {
                return;
            }
            for (x, (st, (px, b))) in stats.iter_mut().zip(row.iter_mut().zip(bias)).enumerate() {
                let r2 = st.radius2;
                let r = r2.sqrt() as f32;
                let inner2 = (r2 / 2.0) as f32;
                let (mut m, mut phi, mut phi_inner) = (0u64, DVec3::ZERO, DVec3::ZERO);
                let direct =
                    trace_eye(scene, maps, pass, x as u32, y as u32, |p, n, f, beta, b| {
                        let (mut sum, mut inner) = (Rgb::ZERO, Rgb::ZERO);
                        surface.query(p, r, |ph, d2| {
                            if ph.n.dot(n) > NORMAL_COS && b.contains(ph.bounces) {
                                m += 1;
                                sum += ph.beta;
                                if d2 < inner2 {
                                    inner += ph.beta;
                                }
                            }
                        });
                        phi = (beta * f * sum).as_dvec3();
                        phi_inner = (beta * f * inner).as_dvec3();
                        Estimate::ZERO
                    })
                    .value;
                let direct = direct.as_dvec3();
                if direct.is_finite() && phi.is_finite() && phi_inner.is_finite() {
                    st.direct += direct;
                    if m > 0 {
                        let m = m as f64;
                        let ratio = (st.photons + alpha * m) / (st.photons + m);
                        st.photons += alpha * m;
                        st.radius2 *= ratio;
                        st.flux = (st.flux + phi) * ratio;
                        st.flux_inner = (st.flux_inner + phi_inner) * ratio;
                    }
                } else {
                    nonfinite.fetch_add(1, Ordering::Relaxed);
                }
                let area_paths = std::f64::consts::PI * st.radius2 * paths_so_far as f64;
                let l = st.direct / iterations + st.flux / area_paths;
                // L_r − L_{r/√2} = (τ − 2 τ_in) / (π R² · paths); the bias is twice it.
                *b = (2.0 * (st.flux - 2.0 * st.flux_inner) / area_paths).as_vec3();
                *px = l.as_vec3();
            }
        },
    );
    !stop.load(Ordering::Relaxed)
}
