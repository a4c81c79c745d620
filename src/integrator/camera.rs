//! The camera pass: one jittered eye path per pixel and iteration, followed by the eye-path
//! walker (`walk.rs`) through specular events (mirror, glass with Fresnel, pass-through
//! interfaces) to the first diffuse surface, where
//! the photon map gives the reflected radiance. Emitters seen directly or through specular chains
//! add their radiance. Along every segment inside a medium, in-scattered radiance comes from the
//! volume photons by the beam estimate (the whole segment, then the path goes on attenuated by its
//! transmittance) or the point estimate (at a sampled collision, where the path ends; without a
//! collision the path goes on with the free-flight weight).

use super::direct::surface_direct;
use super::single::single_scattering;
use super::walk::{EyePath, EyeVisitor, Next, walk_eye};
use crate::accel::Hit;
use crate::estimate::Estimate;
use crate::estimate::surface::{Gather, surface_radiance};
use crate::estimate::volume::{BeamReach, EyeSegment, beam_radiance, point_radiance};
use crate::math::{Rgb, luminance};
use crate::medium::{BEAM_SEGMENT_RATE, Medium, SegmentTransmittance};
use crate::photon::beam::BeamMap;
use crate::photon::map::PhotonGrid;
use crate::photon::marks::GatherMarks;
use crate::photon::{BounceRange, Photon, VolumePhoton};
use crate::scene::Scene;
use crate::scene::light::LightSampler;
use crate::scene::light::media::EmitterPool;
use crate::scene::material::Material;
use crate::settings::VolumeEstimate;
use glam::Vec3;
use std::sync::atomic::{AtomicBool, AtomicU64};

/// The photon maps of one iteration.
pub(crate) struct Maps<'a> {
    /// Surface photons.
    pub surface: &'a PhotonGrid<Photon>,
    /// Volume photons for point queries (used by the point estimate).
    pub volume_points: &'a PhotonGrid<VolumePhoton>,
    /// Volume photons for beam queries (used by the beam estimate).
    pub volume_beams: &'a BeamMap,
    /// The lights, for next-event estimation (the hybrid integrator).
    pub lights: &'a LightSampler,
    /// Where to record the photons the pass gathers (the guiding pilot, `haze bench`).
    pub marks: Option<&'a GatherMarks>,
    /// The iteration's candidate points of emitting media, for next-event estimation towards
    /// them (the hybrid with `media_near` finite; else empty).
    pub emitters: &'a EmitterPool,
}

/// Settings of one camera pass.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CameraPass {
    /// Render seed.
    pub seed: u64,
    /// Iteration number (1-based).
    pub iteration: u64,
    /// Maximum scattering events per whole light-to-camera path (pass-through interfaces are not
    /// events): an eye path of `max_bounces` specular bounces can still see an emitter, but it
    /// gathers photons only before its last event.
    pub max_bounces: u32,
    /// Density estimation, surface and volume (each radius is the one its map was built with).
    pub gather: Gather,
    /// Beam or point estimate in media.
    pub estimate: VolumeEstimate,
    /// Direct light by next-event estimation, photons only for light that interacted on its way
    /// (the hybrid integrator).
    pub hybrid: bool,
    /// Next-event estimates per eye vertex (hybrid), averaged.
    pub direct_samples: u32,
    /// The hybrid's next-event estimation of emitting media at diffuse surfaces covers their
    /// points at least this far from the receiver (infinite: none; `PhotonPass::media_near`).
    pub media_near: f32,
}

#[cfg(feature = "profile")]
thread_local! {
    /// Nanoseconds this thread spent in volume estimates (with the `profile` feature).
    static VOLUME_NANOS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// With the `profile` feature, returns and resets the time the worker threads spent in volume
/// estimates since the last call, summed and divided by the thread count (the share of the
/// camera pass's wall time, since every thread works through the pass); `None` without it.
pub(crate) fn take_volume_times() -> Option<f64> {
    #[cfg(feature = "profile")]
    {
        let threads = rayon::current_num_threads() as f64;
        let take = || VOLUME_NANOS.with(|c| c.replace(0)) as f64 * 1e-9;
        Some(rayon::broadcast(|_| take()).iter().sum::<f64>() / threads)
    }
    #[cfg(not(feature = "profile"))]
    None
}

/// Runs `f`; with the `profile` feature, adds its duration to this thread's volume-estimate time.
#[inline(always)]
fn timed<T>(f: impl FnOnce() -> T) -> T {
    #[cfg(feature = "profile")]
    {
        let start = std::time::Instant::now();
        let out = f();
        let ns = start.elapsed().as_nanos() as u64;
        VOLUME_NANOS.with(|c| c.set(c.get() + ns));
        out
    }
    #[cfg(not(feature = "profile"))]
    f()
}

/// Radiance along one eye path for pixel (x, y), with the kernel bias of its photon estimates.
fn pixel_radiance(scene: &Scene, maps: &Maps, pass: &CameraPass, x: u32, y: u32) -> Estimate {
    trace_eye(scene, maps, pass, x, y, |p, n, f, beta, bounces| {
        let tally = maps.marks.map(|m| (&m.surface, luminance(beta)));
        beta * surface_radiance(maps.surface, p, n, f, &pass.gather, bounces, tally)
    })
}

/// Follows the eye path of pixel (x, y) and returns the radiance it collects, and the kernel bias
/// of its volume estimates and of what `at_diffuse` returns: at the first diffuse surface
/// (position p, normal n on the viewer's side, BRDF value f, path throughput β) the contribution
/// is whatever `at_diffuse(p, n, f, β, bounces)` returns, `bounces` being the photons' events the
/// bounce limit leaves room for.
pub(crate) fn trace_eye(
    scene: &Scene,
    maps: &Maps,
    pass: &CameraPass,
    x: u32,
    y: u32,
    at_diffuse: impl FnMut(Vec3, Vec3, Rgb, Rgb, BounceRange) -> Estimate,
) -> Estimate {
    let mut visitor = PhotonEye { maps, pass, at_diffuse, bias: Rgb::ZERO };
    let value = walk_eye(scene, pass.seed, pass.iteration, [x, y], pass.max_bounces, &mut visitor);
    Estimate { value, bias: visitor.bias }
}

/// The photon mapper's eye path: volume estimates along segments in media, emitters counted in
/// full, and the path's end at the first diffuse surface.
struct PhotonEye<'a, F> {
    maps: &'a Maps<'a>,
    pass: &'a CameraPass,
    at_diffuse: F,
    /// The kernel bias of the path's photon estimates, throughput included.
    bias: Rgb,
}

impl<F> PhotonEye<'_, F> {
    /// Adds a photon estimate, weighted by the path's throughput, to the path.
    fn add(&mut self, path: &mut EyePath, e: Estimate) {
        path.l += path.beta * e.value;
        self.bias += path.beta * e.bias;
    }
}

impl<F> PhotonEye<'_, F> {
    /// The photons an estimate at the path's next vertex may gather: a photon of k events,
    /// gathered there (one more event) after the path's specular bounces, keeps the whole path
    /// within the bounce limit. The hybrid leaves light straight from the lights (k = 0) to
    /// next-event estimation: its photon pass stores no such photon (`PhotonPass::skip_direct`),
    /// nor a medium's photon whose first event is on a surface at least `media_near` from where
    /// it was emitted, so every stored photon is gathered.
    fn bounces(&self, path: &EyePath) -> BounceRange {
        let room = path.max_bounces.saturating_sub(1 + path.depth);
        BounceRange { min: 0, max: room.min(u16::MAX as u32) as u16 }
    }

    /// The hybrid's single scattering along the segment (0 for photon mapping alone, whose
    /// photons carry it).
    fn single(
        &self,
        path: &mut EyePath,
        m: &Medium,
        id: u32,
        t_max: f32,
        tr: &SegmentTransmittance,
    ) -> Rgb {
        if !self.pass.hybrid {
            return Rgb::ZERO;
        }
        let segment = EyeSegment { o: path.ray.o, w: path.ray.d, t_max };
        let scene = path.scene;
        let n = self.pass.direct_samples;
        let sum = (0..n).fold(Rgb::ZERO, |l, _| {
            let s = &mut path.s;
            l + single_scattering(scene, self.maps.lights, &segment, (id, m), tr, s)
        });
        sum / n as f32
    }
}

impl<F: FnMut(Vec3, Vec3, Rgb, Rgb, BounceRange) -> Estimate> EyeVisitor for PhotonEye<'_, F> {
    fn medium(
        &mut self,
        path: &mut EyePath,
        m: &Medium,
        id: u32,
        t_max: f32,
        _end: Option<&Hit>,
    ) -> Next {
        let (o, d) = (path.ray.o, path.ray.d);
        match self.pass.estimate {
            VolumeEstimate::Beam => {
                // One transmittance estimate per segment, shared by every photon on it and by the
                // path's continuation.
                let tr = m.segment(o, d, t_max, BEAM_SEGMENT_RATE, &mut path.s);
                let single = self.single(path, m, id, t_max, &tr);
                path.l += path.beta * single;
                let segment = EyeSegment { o, w: d, t_max };
                let (beams, volume, bounces) =
                    (self.maps.volume_beams, &self.pass.gather, self.bounces(path));
                let tally = self.maps.marks.map(|t| (&t.volume, luminance(path.beta)));
                let reach = BeamReach::new(&tr, t_max, &mut path.s);
                let e = timed(|| {
                    beam_radiance(beams, m, id, &segment, &tr, reach, volume, bounces, tally)
                });
                self.add(path, e);
                path.beta *= tr.at(t_max);
                Next::Continue
            }
            VolumeEstimate::Point => {
                if self.pass.hybrid {
                    let tr = m.segment(o, d, t_max, 1.0, &mut path.s);
                    let single = self.single(path, m, id, t_max, &tr);
                    path.l += path.beta * single;
                }
                let flight = m.sample_free_flight(o, d, t_max, &mut path.s);
                path.beta *= flight.weight;
                if !flight.scattered {
                    return Next::Continue;
                }
                let x = o + d * flight.t;
                let (points, volume, bounces) =
                    (self.maps.volume_points, &self.pass.gather, self.bounces(path));
                let tally = self.maps.marks.map(|t| (&t.volume, luminance(path.beta)));
                let e = timed(|| point_radiance(points, m, id, x, d, volume, bounces, tally));
                self.add(path, e);
                Next::Stop
            }
        }
    }

    fn emission(&mut self, path: &EyePath, _hit: &Hit, le: Rgb) -> Rgb {
        path.beta * le
    }

    fn environment(&mut self, path: &EyePath, le: Rgb) -> Rgb {
        path.beta * le
    }

    fn diffuse(&mut self, path: &mut EyePath, hit: &Hit, material: &Material) -> Next {
        let wo = -path.ray.d;
        let n = if wo.dot(hit.ng) >= 0.0 { hit.ng } else { -hit.ng };
        if self.pass.hybrid {
            let scene = path.scene;
            let (lights, medium) = (self.maps.lights, path.ray.medium);
            let near = self.pass.media_near;
            let media = near.is_finite().then_some((near, self.maps.emitters));
            let s = &mut path.s;
            path.l +=
                path.beta * surface_direct(scene, lights, hit, wo, material, medium, media, s);
        }
        let bounces = self.bounces(path);
        let e = (self.at_diffuse)(hit.p, n, material.diffuse_f(), path.beta, bounces);
        path.l += e.value;
        self.bias += e.bias;
        Next::Stop
    }
}

/// Renders one iteration into `frame` (row-major). Returns `false` if `stop` was raised
/// before it finished. Non-finite samples are replaced by black and counted in `nonfinite`.
pub(crate) fn render_pass(
    scene: &Scene,
    maps: &Maps,
    pass: &CameraPass,
    stop: &AtomicBool,
    nonfinite: &AtomicU64,
    frame: &mut super::frame::Frame,
) -> bool {
    let width = scene.camera.resolution[0] as usize;
    super::frame::render_pixels(frame, width, stop, nonfinite, |x, y| {
        pixel_radiance(scene, maps, pass, x, y)
    })
}
