//! What an iteration makes: its frame of pixel estimates, rendered in runs of pixels, and the
//! seconds each step took.

use crate::estimate::Estimate;
use crate::math::Rgb;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

/// One iteration's image and the kernel bias of its photon estimates (zero for the path tracer),
/// row-major, top row first.
pub(crate) struct Frame {
    /// Radiance.
    pub value: Vec<Rgb>,
    /// The estimated kernel bias of `value` ([`Estimate`]).
    pub bias: Vec<Rgb>,
}

impl Frame {
    /// A black frame of `pixels` pixels.
    pub(crate) fn new(pixels: usize) -> Self {
        let black = || crate::buffers::filled(pixels, Rgb::ZERO);
        Frame { value: black(), bias: black() }
    }
}

/// Seconds one iteration spent in each step (zero for steps the method does not have).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepTimes {
    /// The photon-guiding pilot, which runs once, before the first iteration's photon pass (zero
    /// in every other iteration).
    pub pilot: f64,
    /// Tracing light paths (the photon pass without the map builds).
    pub photon_trace: f64,
    /// Building the surface photon map.
    pub surface_map: f64,
    /// Building the volume photon map (beam map or point grid).
    pub volume_map: f64,
    /// The camera pass: eye paths with their estimates (for the path tracer, the whole iteration).
    pub camera: f64,
    /// Adding the iteration's image to the film.
    pub film: f64,
    /// With the `profile` feature, the part of `camera` spent in volume estimates (thread time
    /// divided by the thread count); `None` without it.
    pub volume_estimates: Option<f64>,
    /// The processor time of each step.
    pub processor: ProcessorTimes,
}

/// Processor seconds each step took: the time the process's threads ran, all together, so that
/// a step that kept N threads busy shows about N times its wall-clock seconds. Against the wall
/// clock it tells threads that wait (processor time below N × wall) from threads that work
/// slower side by side (more processor time than on one thread). It counts every thread of the
/// process, the render's and any other (a caller's, the OpenEXR writer's pool). Zero where the
/// platform has no process clock ([`processor_seconds`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProcessorTimes {
    /// The pilot ([`StepTimes::pilot`]).
    pub pilot: f64,
    /// Tracing light paths.
    pub photon_trace: f64,
    /// Building the surface photon map.
    pub surface_map: f64,
    /// Building the volume photon map.
    pub volume_map: f64,
    /// The camera pass.
    pub camera: f64,
    /// Adding the iteration's image to the film.
    pub film: f64,
}

/// Seconds of processor time the process has used so far, all its threads together — every
/// thread of the process, not only the render's (0 where the platform has no process clock, or
/// where the system refuses it, as a sandbox may).
pub fn processor_seconds() -> f64 {
    #[cfg(any(
        target_os = "linux",
        target_os = "android",
        target_os = "macos",
        target_os = "ios",
        target_os = "freebsd"
    ))]
    {
        use rustix::time::{ClockId, DynamicClockId, clock_gettime_dynamic};
        clock_gettime_dynamic(DynamicClockId::Known(ClockId::ProcessCPUTime))
            .map_or(0.0, |t| t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9)
    }
    #[cfg(not(any(
        target_os = "linux",
        target_os = "android",
        target_os = "macos",
        target_os = "ios",
        target_os = "freebsd"
    )))]
    {
        0.0
    }
}

/// Wall-clock and processor time ([`processor_seconds`]) since it was started: what each step
/// of [`StepTimes`] is timed with.
#[derive(Clone, Copy, Debug)]
pub struct Stopwatch {
    wall: Instant,
    processor: f64,
}

impl Stopwatch {
    /// Starts now.
    pub fn start() -> Self {
        Stopwatch { wall: Instant::now(), processor: processor_seconds() }
    }

    /// Wall-clock seconds and processor seconds since the start.
    pub fn lap(&self) -> (f64, f64) {
        let wall = self.wall.elapsed().as_secs_f64();
        (wall, (processor_seconds() - self.processor).max(0.0))
    }
}

impl StepTimes {
    /// The whole iteration.
    pub fn total(&self) -> f64 {
        self.pilot
            + self.photon_trace
            + self.surface_map
            + self.volume_map
            + self.camera
            + self.film
    }
}

/// Pixels a camera pass hands out at a time.
const RUN: usize = 128;

/// Fills `frame` (row-major, `width` pixels a row) with `radiance(x, y)` in parallel over runs
/// of pixels.
/// Non-finite samples (value or bias) become black without bias and are counted in `nonfinite`.
/// Returns `false` if `stop` was raised before every pixel was done.
pub(crate) fn render_pixels(
    frame: &mut Frame,
    width: usize,
    stop: &AtomicBool,
    nonfinite: &AtomicU64,
    radiance: impl Fn(u32, u32) -> Estimate + Sync,
) -> bool {
    let mut nothing = vec![(); frame.value.len()];
    render_pixels_with(frame, &mut nothing, width, stop, nonfinite, |x, y| (radiance(x, y), ()))
}

/// [`render_pixels`], where `radiance(x, y)` also gives something of its own per pixel, kept in
/// `extra` (its default where the pixel's estimate was not finite).
pub(crate) fn render_pixels_with<T: Send + Default>(
    frame: &mut Frame,
    extra: &mut [T],
    width: usize,
    stop: &AtomicBool,
    nonfinite: &AtomicU64,
    radiance: impl Fn(u32, u32) -> (Estimate, T) + Sync,
) -> bool {
    // Runs of RUN pixels (a run may end in the next row) handed out one at a time from one
    // shared iterator (`par_bridge`), the next to whichever thread is free. Rayon's indexed
    // split (a range in halves, split further as threads steal) left threads asleep while
    // another worked through a stretch: cornell-fog's path tracer, timed run by run, had a
    // thread idle up to 10 ms in a pass of 0.23 s. Stretches of runs, largest first (guided
    // self-scheduling), were tried and dropped: where the cost gathers in a part of the image
    // (fire's flames) the first stretch held most of it, and fire's camera pass ran 91 % busy.
    // The wait at the end of a pass is at most one run (there, about half a millisecond).
    let runs = frame.value.chunks_mut(RUN).zip(frame.bias.chunks_mut(RUN));
    let runs = runs.zip(extra.chunks_mut(RUN)).enumerate().par_bridge();
    runs.for_each(|(k, ((run, bias), more))| {
        if stop.load(Ordering::Relaxed) {
            return;
        }
        for (j, ((px, b), m)) in run.iter_mut().zip(bias).zip(more).enumerate() {
            // Pixel by pixel: in a pathological medium one pixel can take milliseconds, and a
            // stopped iteration is discarded anyway.
            if stop.load(Ordering::Relaxed) {
                return;
            }
            let p = k * RUN + j;
            let (e, own) = radiance((p % width) as u32, (p / width) as u32);
            (*px, *b, *m) = if e.value.is_finite() && e.bias.is_finite() {
                (e.value, e.bias, own)
            } else {
                nonfinite.fetch_add(1, Ordering::Relaxed);
                (Rgb::ZERO, Rgb::ZERO, T::default())
            };
        }
    });
    !stop.load(Ordering::Relaxed)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A thread that works for 30 ms of wall-clock time uses processor time the process clock
    /// sees (other tests' threads can only add to it).
    #[cfg(any(
        target_os = "linux",
        target_os = "android",
        target_os = "macos",
        target_os = "ios",
        target_os = "freebsd"
    ))]
    #[test]
    fn the_processor_clock_counts_work() {
        let clock = Stopwatch::start();
        let mut x = 1u64;
        while clock.lap().0 < 0.03 {
            for _ in 0..10_000 {
                x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
            }
        }
        let (wall, processor) = clock.lap();
        assert!(wall >= 0.03 && processor > 0.0, "wall {wall} s, processor {processor} s");
    }
}
