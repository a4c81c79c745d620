//! Render settings: the `[render]` table of a scene file, overridable from the command line.
//!
//! ```toml
//! [render]
//! iterations = 64           # stop after this many iterations …
//! time_limit = 60           # … or after this many seconds, whichever comes first
//! photons = 200000          # light paths emitted per iteration
//! alpha = 0.7               # radius reduction α in (0, 1)
//! radius_fraction = 0.01    # initial radius relative to the scene's bounding-box diagonal …
//! # radius = 0.02           # … or absolute, in scene units (give one of the two)
//! kernel = "epanechnikov"   # "constant", "epanechnikov" or "biweight"
//! max_depth = 16            # maximum scattering events on light and eye paths (pass-through
//!                           # interfaces are not events)
//! seed = 0
//! volume_estimate = "beam"  # in-scattering estimate in media: "beam" or "point"
//! volume_alpha = 0.5        # α of the volume schedule r³(i+1)/r³(i) = (i+α)/(i+1)
//! volume_radius_fraction = 0.005  # initial volume radius (or `volume_radius`, absolute)
//! volume_dimension = 3      # dimension d of the volume schedule (3; 2 for experiments)
//! integrator = "ppm"        # "ppm" (photon mapping) or "path" (reference path tracer)
//! progression = "probabilistic"  # or "original": Hachisuka 2008 per-pixel statistics (surfaces only)
//! beam_cell_budget = 64     # thin volume photons in cells denser than this (unbiased; off if absent)
//! ```

use crate::estimate::kernel::Kernel;

/// Gives an enum of named choices `name()` (as written in scene files and on the command line)
/// and `FromStr`, whose error lists the choices.
macro_rules! named_choices {
    ($ty:ident, $what:literal, { $($variant:ident => $name:literal),+ $(,)? }) => {
        impl $ty {
            /// Name as written in scene files and on the command line.
            pub fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $name,)+
                }
            }
        }

        impl std::str::FromStr for $ty {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, Self::Err> {
                $(if s == $name {
                    return Ok($ty::$variant);
                })+
                let names = [$($name),+];
                Err(format!("unknown {} `{s}`; expected {}", $what, $crate::settings::one_of(&names)))
            }
        }
    };
}
pub(crate) use named_choices;

/// `"a"`, `"a" or "b"`, `"a", "b" or "c"`, …
pub(crate) fn one_of(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
    match quoted.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    }
}

/// Initial photon-gathering radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Radius {
    /// In scene units.
    Absolute(f64),
    /// As a fraction of the diagonal of the scene's bounding box.
    Fraction(f64),
}

/// Which integrator renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Integrator {
    /// Probabilistic progressive photon mapping (the default).
    PhotonMapping,
    /// The unbiased volumetric path tracer with next-event estimation (reference and baseline).
    Path,
}

named_choices!(Integrator, "integrator", { PhotonMapping => "ppm", Path => "path" });

/// How the radius shrinks from one iteration to the next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progression {
    /// Probabilistic PPM (Knaus & Zwicker 2011): one global radius per iteration from the schedule,
    /// the image is the mean of the iterations.
    Probabilistic,
    /// The original PPM (Hachisuka, Ogaki & Jensen 2008): every pixel keeps its own radius, photon
    /// count and flux, updated after each photon pass. A comparison mode for the surface estimate:
    /// scenes with media are refused.
    Original,
}

named_choices!(Progression, "progression", {
    Probabilistic => "probabilistic",
    Original => "original",
});

/// How in-scattered radiance is estimated along eye paths in media.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumeEstimate {
    /// The beam radiance estimate (Jarosz et al. 2008): every volume photon whose kernel disc the
    /// eye segment crosses, with a 2-D kernel.
    Beam,
    /// The point estimate (Jensen & Christensen 1998): a 3-D kernel density estimate at a
    /// collision sampled along the eye segment.
    Point,
}

named_choices!(VolumeEstimate, "volume estimate", { Beam => "beam", Point => "point" });

/// How to render.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Stop after this many iterations (`None`: only the time limit stops the render).
    pub iterations: Option<u64>,
    /// Stop after this many seconds of rendering.
    pub time_limit: Option<f64>,
    /// Light paths emitted per iteration.
    pub photons: u64,
    /// Radius reduction parameter α ∈ (0, 1) of the surface schedule.
    pub alpha: f64,
    /// Initial surface radius.
    pub radius: Radius,
    /// Density-estimation kernel.
    pub kernel: Kernel,
    /// Maximum number of scattering events on a path: medium collisions and surface scatterings;
    /// crossing a pass-through interface is not one.
    pub max_depth: u32,
    /// Seed of every random stream.
    pub seed: u64,
    /// In-scattering estimator in media.
    pub volume_estimate: VolumeEstimate,
    /// Radius reduction α of the volume schedule.
    pub volume_alpha: f64,
    /// Initial volume radius.
    pub volume_radius: Radius,
    /// Dimension d of the volume schedule r^d(i+1)/r^d(i) = (i+α)/(i+1): 3 (default) or 2.
    pub volume_dimension: u32,
    /// The integrator.
    pub integrator: Integrator,
    /// Probabilistic (global schedule) or original (per-pixel statistics) progression.
    pub progression: Progression,
    /// If set, volume photons in thinning cells (cubes holding ~4 photons on average) holding more
    /// than this many photons are thinned by Russian roulette (kept with probability
    /// budget/count, power divided by it), which bounds the cost of a beam query where photons are
    /// dense without changing the expected image.
    pub beam_cell_budget: Option<u32>,
    /// Measure the time the camera pass spends in volume estimates and report it in
    /// [`Status::volume_estimate_seconds`](crate::progress::Status) (for benchmarks: two clock
    /// reads per estimate). Not a scene-file key.
    pub time_volume_estimate: bool,
}

/// Most light paths per iteration: each stores photons of 48 bytes, several per path.
pub const MAX_PHOTONS: u64 = 50_000_000;

/// Iterations rendered when neither an iteration count nor a time limit is given.
pub const DEFAULT_ITERATIONS: u64 = 64;

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            iterations: Some(DEFAULT_ITERATIONS),
            time_limit: None,
            photons: 100_000,
            alpha: 2.0 / 3.0,
            radius: Radius::Fraction(0.01),
            kernel: Kernel::Epanechnikov,
            max_depth: 16,
            seed: 0,
            volume_estimate: VolumeEstimate::Beam,
            volume_alpha: 0.5,
            volume_radius: Radius::Fraction(0.005),
            volume_dimension: 3,
            integrator: Integrator::PhotonMapping,
            progression: Progression::Probabilistic,
            beam_cell_budget: None,
            time_volume_estimate: false,
        }
    }
}

/// A rejected setting: the key (as in the scene file) and the reason.
#[derive(Clone, Debug, PartialEq)]
pub struct SettingError {
    /// Key within `[render]`, e.g. `alpha`.
    pub key: &'static str,
    /// Why it was rejected.
    pub message: String,
}

fn err(key: &'static str, message: impl Into<String>) -> Result<(), SettingError> {
    Err(SettingError { key, message: message.into() })
}

fn check_radius(r: Radius, abs: &'static str, frac: &'static str) -> Result<(), SettingError> {
    match r {
        Radius::Absolute(r) if !(r.is_finite() && r > 0.0) => {
            err(abs, format!("must be a positive length, got {r}"))
        }
        Radius::Fraction(f) if !(f.is_finite() && f > 0.0 && f <= 1.0) => {
            err(frac, format!("must lie in (0, 1], got {f}"))
        }
        _ => Ok(()),
    }
}

impl RenderSettings {
    /// Checks every setting; the error names the offending key.
    pub fn validate(&self) -> Result<(), SettingError> {
        if self.iterations == Some(0) {
            return err("iterations", "must be at least 1");
        }
        if let Some(t) = self.time_limit {
            if !(t.is_finite() && t > 0.0) {
                return err("time_limit", format!("must be a positive number of seconds, got {t}"));
            }
        }
        if self.iterations.is_none() && self.time_limit.is_none() {
            return err("iterations", "give an iteration count, a time limit, or both");
        }
        if self.photons == 0 {
            return err("photons", "must be at least 1");
        }
        if self.photons > MAX_PHOTONS {
            return err(
                "photons",
                format!(
                    "at most {MAX_PHOTONS} per iteration (photon memory), got {}",
                    self.photons
                ),
            );
        }
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return err("alpha", format!("must lie strictly between 0 and 1, got {}", self.alpha));
        }
        check_radius(self.radius, "radius", "radius_fraction")?;
        check_radius(self.volume_radius, "volume_radius", "volume_radius_fraction")?;
        if !(self.volume_alpha > 0.0 && self.volume_alpha < 1.0) {
            return err(
                "volume_alpha",
                format!("must lie strictly between 0 and 1, got {}", self.volume_alpha),
            );
        }
        if !(1..=3).contains(&self.volume_dimension) {
            return err(
                "volume_dimension",
                format!("must be 1, 2 or 3, got {}", self.volume_dimension),
            );
        }
        if self.max_depth == 0 {
            return err("max_depth", "must be at least 1");
        }
        if self.beam_cell_budget == Some(0) {
            return err("beam_cell_budget", "must be at least 1 photon per cell");
        }
        if self.progression == Progression::Original && self.integrator == Integrator::Path {
            return err(
                "progression",
                "\"original\" applies to photon mapping, not the path tracer",
            );
        }
        Ok(())
    }

    /// Sets the `[render]` key `key` from its textual value (as on the command line or in a
    /// `haze converge --series` list); the error says what was expected. Keys and values are those
    /// of the scene file. The result is not validated as a whole: call [`Self::validate`].
    pub fn set(&mut self, key: &str, value: &str) -> Result<(), String> {
        fn num<T: std::str::FromStr>(key: &str, v: &str) -> Result<T, String> {
            v.trim().parse().map_err(|_| format!("{key}: `{v}` is not a valid number"))
        }
        let v = value.trim();
        match key {
            "iterations" => self.iterations = Some(num(key, v)?),
            "time_limit" => self.time_limit = Some(num(key, v)?),
            "photons" => self.photons = num(key, v)?,
            "alpha" => self.alpha = num(key, v)?,
            "radius" => self.radius = Radius::Absolute(num(key, v)?),
            "radius_fraction" => self.radius = Radius::Fraction(num(key, v)?),
            "kernel" => self.kernel = v.parse()?,
            "max_depth" => self.max_depth = num(key, v)?,
            "seed" => self.seed = num(key, v)?,
            "volume_estimate" => self.volume_estimate = v.parse()?,
            "volume_alpha" => self.volume_alpha = num(key, v)?,
            "volume_radius" => self.volume_radius = Radius::Absolute(num(key, v)?),
            "volume_radius_fraction" => self.volume_radius = Radius::Fraction(num(key, v)?),
            "volume_dimension" => self.volume_dimension = num(key, v)?,
            "integrator" => self.integrator = v.parse()?,
            "progression" => self.progression = v.parse()?,
            "beam_cell_budget" => self.beam_cell_budget = Some(num(key, v)?),
            _ => return Err(format!("unknown render setting `{key}`")),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn named_choices_round_trip_and_list_the_choices() {
        for k in Kernel::ALL {
            assert_eq!(k.name().parse::<Kernel>(), Ok(k));
        }
        for i in [Integrator::PhotonMapping, Integrator::Path] {
            assert_eq!(i.name().parse::<Integrator>(), Ok(i));
        }
        for p in [Progression::Probabilistic, Progression::Original] {
            assert_eq!(p.name().parse::<Progression>(), Ok(p));
        }
        for v in [VolumeEstimate::Beam, VolumeEstimate::Point] {
            assert_eq!(v.name().parse::<VolumeEstimate>(), Ok(v));
        }
        assert_eq!(
            "gauss".parse::<Kernel>(),
            Err("unknown kernel `gauss`; expected \"constant\", \"epanechnikov\" or \"biweight\""
                .to_string())
        );
        assert_eq!(
            "x".parse::<VolumeEstimate>(),
            Err("unknown volume estimate `x`; expected \"beam\" or \"point\"".to_string())
        );
    }
}
