//! Render settings, each defined once.
//!
//! Every setting is one entry of the `render_settings!` list below: its key, type, default,
//! documentation, command-line flag and range check. From that list come
//!
//! - [`RenderSettings`], the settings a render uses (every field set);
//! - [`RenderOptions`], the same keys all optional: the scene file's `[render]` table (serde, unknown
//!   keys rejected), the command line's overrides (clap, with the `cli` feature) and the
//!   `--series KEY=VALUE` lists of `haze converge` ([`RenderOptions::parse_assignments`]);
//! - [`RenderSettings::apply`], which lays options over settings (scene defaults, then the file,
//!   then the command line);
//! - [`RenderSettings::validate`], which runs every range check and names the offending key;
//! - [`RenderSettings::entries`], the key/value list written into every EXR header.
//!
//! Adding a setting is one entry here plus the code that uses it.
//!
//! ```toml
//! [render]
//! iterations = 64           # stop after this many iterations …
//! time_limit = 60           # … or after this many seconds, whichever comes first
//! # target_error = 0.02     # … or once the estimated relative error is this (docs/error.md)
//! photons = 200000          # light paths emitted per iteration
//! alpha = 0.7               # radius reduction α in (0, 1)
//! radius_fraction = 0.01    # initial radius relative to the scene's bounding-box diagonal …
//! # radius = 0.02           # … or absolute, in scene units (give one of the two)
//! kernel = "epanechnikov"   # "constant", "epanechnikov" or "biweight"
//! max_bounces = 64          # most scattering events on a whole light-to-camera path (pass-through
//!                           # interfaces are not events)
//! seed = 0
//! volume_estimate = "beam"  # in-scattering estimate in media: "beam" or "point"
//! volume_alpha = 0.5        # α of the volume schedule r³(i+1)/r³(i) = (i+α)/(i+1)
//! volume_radius_fraction = 0.005  # initial volume radius (or `volume_radius`, absolute)
//! volume_dimension = 3      # dimension d of the volume schedule (3; 2 for experiments)
//! integrator = "auto"       # "combined" (or "hybrid" where media emit), "combined", "hybrid", "photons" or "path"
//! progression = "probabilistic"  # or "original": Hachisuka 2008 per-pixel statistics (surfaces only)
//! beam_cell_budget = 64     # thin volume photons in cells denser than this (unbiased; off if absent)
//! emission_nee_distance = 2  # emitting media's light on surfaces from ≥ this far by next-event estimation (hybrid; off if absent)
//! photon_guiding = "visibility"  # emit photons towards what the camera sees, or "off"
//! photon_splitting = "auto" # "off" or "importance": split light paths where the camera looks, in media
//! ```

use crate::choices::choices;
pub use crate::estimate::kernel::Kernel;
use crate::region::Region;
use serde::{Deserialize, Serialize};

choices! {
    /// Which integrator renders.
    pub enum Integrator ("integrator") {
        /// The default: the combined integrator, or the hybrid in a scene whose media emit (the
        /// combined integrator's light paths start at lights only, so there the light of
        /// emitting media would reach surfaces through eye paths alone: docs/performance.md,
        /// "The default integrator").
        Auto = "auto",
        /// Light sampling where it wins, photons where they must: direct light by
        /// next-event estimation at diffuse surfaces and along eye segments in media (MIS with
        /// BSDF sampling, equiangular and transmittance distances); photons only for light that
        /// interacted at least once on its way (through glass, after scattering).
        Hybrid = "hybrid",
        /// Probabilistic progressive photon mapping alone: photons carry all light, direct light
        /// included (the method of Knaus & Zwicker 2011, for comparisons).
        PhotonMapping = "photons",
        /// The unbiased volumetric path tracer with next-event estimation (reference and baseline).
        Path = "path",
        /// Every estimator at once, weighed by multiple importance sampling: eye paths that
        /// reach lights, next-event estimation, and photon merging on surfaces, at points and
        /// along beams in media (UPBP's techniques without connections and photon beams;
        /// docs/theory.md). The default in scenes whose media do not emit.
        Combined = "combined",
    }
}

impl Integrator {
    /// True for the integrators that trace photons.
    pub fn uses_photons(self) -> bool {
        self != Integrator::Path
    }

    /// The integrator that renders a scene, given whether its media emit: `Auto` is the
    /// combined integrator, or the hybrid where media emit; any other choice is itself.
    pub fn resolve(self, emitting_media: bool) -> Integrator {
        match self {
            Integrator::Auto if emitting_media => Integrator::Hybrid,
            Integrator::Auto => Integrator::Combined,
            chosen => chosen,
        }
    }
}

choices! {
    /// How the radius shrinks from one iteration to the next.
    pub enum Progression ("progression") {
        /// Probabilistic PPM (Knaus & Zwicker 2011): one global radius per iteration from the
        /// schedule; the image is the mean of the iterations.
        Probabilistic = "probabilistic",
        /// The original PPM (Hachisuka, Ogaki & Jensen 2008): every pixel keeps its own radius,
        /// photon count and flux, updated after each photon pass. A comparison mode for the surface
        /// estimate: scenes with media are refused.
        Original = "original",
    }
}

choices! {
    /// How in-scattered radiance is estimated along eye paths in media.
    pub enum VolumeEstimate ("volume estimate") {
        /// The beam radiance estimate (Jarosz et al. 2008): every volume photon whose kernel disc
        /// the eye segment crosses, with a 2-D kernel.
        Beam = "beam",
        /// The point estimate (Jensen & Christensen 1998): a 3-D kernel density estimate at a
        /// collision sampled along the eye segment.
        Point = "point",
    }
}

choices! {
    /// Where the photon pass emits its photons.
    pub enum PhotonGuiding ("photon guiding") {
        /// Towards the light paths the camera sees (the default): a pilot pass at the start of
        /// a render finds which emitted photons reach what the camera gathers, and every
        /// iteration then emits half its photons by that and half as without guiding (docs/theory.md, "Photons where the camera looks").
        Visibility = "visibility",
        /// Photons leave every light in proportion to its power, uniformly over its emission.
        Off = "off",
    }
}

choices! {
    /// Whether light paths are split and ended by their worth to the image, in media.
    pub enum PhotonSplitting ("photon splitting") {
        /// Light paths go on as they are.
        Off = "off",
        /// The combined integrator splits by importance, before its light-path pilot, where the
        /// light paths run long (more than 32 photons stored per path at the scene's count:
        /// dense, bright media); the other integrators do not split (the default).
        Auto = "auto",
        /// By importance (docs/theory.md, "Light paths split by importance"): a pilot of eye
        /// random walks estimates what a light path at each point of a grid adds to the image,
        /// and at every collision in a medium a path worth more than twice the average emitted
        /// path is split into copies and one worth less than half plays Russian roulette.
        Importance = "importance",
    }
}

choices! {
    /// Whether the combined integrator weighs point–point merges at the eye's collisions in
    /// media.
    pub enum PointMerges ("point merges") {
        /// Off where the eye paths end at their first merge (`merges = "last"`, or the
        /// light-path pilot's choice of it: dense, bright media), on elsewhere (the default).
        Auto = "auto",
        /// Always: every volume merge of UPBP's set.
        On = "on",
        /// Never: the beam alone merges in media.
        Off = "off",
    }
}

choices! {
    /// A technique of the combined integrator, for `only`.
    pub enum Technique ("technique") {
        /// The eye path reaches an area light.
        Hit = "hit",
        /// Next-event estimation at an eye vertex.
        Nee = "nee",
        /// Merging with surface photons.
        Surface = "surface",
        /// Point–point merging at an eye collision in a medium.
        Point = "point",
        /// Point–beam merging along an eye segment in a medium (the beam radiance estimate).
        Beam = "beam",
    }
}

choices! {
    /// Where the combined integrator's eye paths merge with photons.
    pub enum Merges ("merges") {
        /// At the eye path's first vertex that is not specular, and along its segments up to it
        /// in media: a photon-mapping estimate without a final gather (the default).
        First = "first",
        /// At every vertex of the eye path and along every segment in a medium: UPBP's set of
        /// merging techniques. Each iteration costs more; less noisy per iteration in dense,
        /// bright or strongly anisotropic media (docs/performance.md, "Where the eye merges").
        Everywhere = "everywhere",
        /// At the first vertex only, where the eye path ends: its merges carry all the light
        /// but the direct light, which they share with next-event estimation there — photon
        /// mapping with the direct light weighed by MIS, the cheapest eye path (docs/performance.md,
        /// "Where the eye merges").
        Last = "last",
    }
}

choices! {
    /// How the combined integrator sets its light paths per iteration.
    pub enum PhotonBudget ("photon_budget") {
        /// A pilot before the first iteration weighs 1, 1/2, 1/4 and 1/8 of `photons`, and none
        /// where the eye's techniques alone can carry the light, and picks the count that
        /// reaches a given error soonest (the default; docs/theory.md, "How many light paths").
        Pilot = "pilot",
        /// `photons`, as set.
        Fixed = "fixed",
    }
}

/// A set of the combined integrator's techniques, written with `+` between them
/// (`surface+point`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(into = "String", try_from = "String")]
pub struct Techniques(u8);

impl Techniques {
    /// The set of `list`.
    pub fn of(list: &[Technique]) -> Self {
        Self(list.iter().fold(0, |bits, &t| bits | Self::bit(t)))
    }

    fn bit(t: Technique) -> u8 {
        1 << t as u8
    }

    /// Whether `t` is in the set.
    pub fn contains(self, t: Technique) -> bool {
        self.0 & Self::bit(t) != 0
    }

    /// The techniques in the set, in [`Technique::ALL`]'s order.
    pub fn iter(self) -> impl Iterator<Item = Technique> {
        Technique::ALL.iter().copied().filter(move |&t| self.contains(t))
    }
}

impl std::fmt::Display for Techniques {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> = self.iter().map(Technique::name).collect();
        f.write_str(&names.join("+"))
    }
}

impl std::str::FromStr for Techniques {
    type Err = String;
    /// Parses `T+T+…`, each T a [`Technique`]'s name, at least one, none twice.
    fn from_str(s: &str) -> Result<Self, String> {
        let mut set = Techniques(0);
        for name in s.split('+').map(str::trim) {
            let t: Technique = name.parse()?;
            if set.contains(t) {
                return Err(format!("technique `{t}` is named twice in `{s}`"));
            }
            set.0 |= Self::bit(t);
        }
        Ok(set)
    }
}

impl From<Techniques> for String {
    fn from(t: Techniques) -> String {
        t.to_string()
    }
}

impl TryFrom<String> for Techniques {
    type Error = String;
    fn try_from(s: String) -> Result<Self, String> {
        s.parse()
    }
}

/// Most light paths per iteration: each stores photons of 48 bytes, several per path.
pub const MAX_PHOTONS: u64 = 50_000_000;

/// Iterations rendered when neither an iteration count nor a time limit is given.
pub const DEFAULT_ITERATIONS: u64 = 64;

/// Parses a duration such as `90`, `90s`, `1.5m`, `1h` or `500ms` into seconds.
pub fn parse_duration(s: &str) -> Result<f64, String> {
    let s = s.trim();
    let (num, unit) = match s.find(|c: char| c.is_ascii_alphabetic()) {
        Some(i) => (&s[..i], &s[i..]),
        None => (s, "s"),
    };
    let scale = match unit {
        "ms" => 1e-3,
        "s" => 1.0,
        "m" | "min" => 60.0,
        "h" => 3600.0,
        _ => return Err(format!("unknown unit `{unit}` (use ms, s, m or h)")),
    };
    let v: f64 = num.trim().parse().map_err(|_| format!("`{s}` is not a duration such as 60s"))?;
    if !(v.is_finite() && v > 0.0) {
        return Err(format!("`{s}` must be a positive duration"));
    }
    Ok(v * scale)
}

/// Parses a fraction (0.02) or a percentage (2%).
pub fn parse_fraction_or_percent(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let (num, scale) = match t.strip_suffix('%') {
        Some(n) => (n.trim(), 0.01),
        None => (t, 1.0),
    };
    let v: f64 =
        num.parse().map_err(|_| format!("`{s}` is not a fraction (0.02) or a percentage (2%)"))?;
    Ok(v * scale)
}

// Range checks: each takes the value and says what is wrong with it.

fn seed_range(v: &u64) -> Result<(), String> {
    if *v <= i64::MAX as u64 {
        Ok(())
    } else {
        Err(format!("must lie in 0..={} (a TOML integer), got {v}", i64::MAX))
    }
}

fn any<T>(_: &T) -> Result<(), String> {
    Ok(())
}

fn iteration_count(v: &u64) -> Result<(), String> {
    if (1..=i64::MAX as u64).contains(v) {
        Ok(())
    } else {
        Err(format!("must lie in 1..={} (a TOML integer), got {v}", i64::MAX))
    }
}

fn at_least_one<T: Into<u64> + Copy>(v: &T) -> Result<(), String> {
    if (*v).into() >= 1 { Ok(()) } else { Err("must be at least 1".into()) }
}

fn photon_count(v: &u64) -> Result<(), String> {
    match *v {
        0 => Err("must be at least 1".into()),
        n if n > MAX_PHOTONS => {
            Err(format!("at most {MAX_PHOTONS} per iteration (photon memory), got {n}"))
        }
        _ => Ok(()),
    }
}

fn seconds(v: &f64) -> Result<(), String> {
    if v.is_finite() && *v > 0.0 {
        Ok(())
    } else {
        Err(format!("must be a positive number of seconds, got {v}"))
    }
}

fn open_unit(v: &f64) -> Result<(), String> {
    if *v > 0.0 && *v < 1.0 {
        Ok(())
    } else {
        Err(format!("must lie strictly between 0 and 1, got {v}"))
    }
}

fn length(v: &f64) -> Result<(), String> {
    if v.is_finite() && *v > 0.0 {
        Ok(())
    } else {
        Err(format!("must be a positive length, got {v}"))
    }
}

fn fraction(v: &f64) -> Result<(), String> {
    if v.is_finite() && *v > 0.0 && *v <= 1.0 {
        Ok(())
    } else {
        Err(format!("must lie in (0, 1], got {v}"))
    }
}

fn bounce_limit(v: &u32) -> Result<(), String> {
    if (1..=u16::MAX as u32).contains(v) {
        Ok(())
    } else {
        Err(format!("must lie in 1..={}, got {v}", u16::MAX))
    }
}

fn direct_count(v: &u32) -> Result<(), String> {
    if (1..=256).contains(v) { Ok(()) } else { Err(format!("must lie in 1..=256, got {v}")) }
}

fn dimension(v: &u32) -> Result<(), String> {
    if (1..=3).contains(v) { Ok(()) } else { Err(format!("must be 1, 2 or 3, got {v}")) }
}

/// The type of a settings field: the value, or an optional value.
macro_rules! field_type {
    ($t:ty) => { $t };
    ($t:ty, optional) => { Option<$t> };
}

/// A value assigned to a settings field.
macro_rules! field_value {
    ($v:expr) => {
        $v
    };
    ($v:expr, optional) => {
        Some($v)
    };
}

/// Runs a range check on a settings field (on the value, if an optional one is set).
macro_rules! field_check {
    ($v:expr, $check:expr) => {
        $check(&$v)
    };
    ($v:expr, $check:expr, optional) => {
        match &$v {
            Some(v) => $check(v),
            None => Ok(()),
        }
    };
}

/// The one list of render settings (see the module documentation). Each entry:
///
/// ```text
/// /// doc (also the `--help` text)
/// [clap arguments]
/// key: type [, optional] = default, check;
/// ```
///
/// An `optional` setting has type `Option<type>` in [`RenderSettings`] (absent: no limit or off).
macro_rules! render_settings {
    ($(
        $(#[doc = $doc:literal])+
        [$($cli:tt)*]
        $key:ident : $ty:ty $(, $opt:ident)? = $default:expr, $check:expr;
    )+) => {
        /// How to render: every setting (see the module documentation for where each comes
        /// from). Start from [`RenderSettings::default`] or a scene's `settings`.
        #[derive(Clone, Debug, PartialEq, Serialize)]
        pub struct RenderSettings {
            $(
                $(#[doc = $doc])+
                pub $key: field_type!($ty $(, $opt)?),
            )+
        }

        impl Default for RenderSettings {
            fn default() -> Self {
                Self { $($key: $default,)+ }
            }
        }

        /// The render settings, each optional: the scene file's `[render]` table and the command
        /// line's overrides. [`RenderSettings::apply`] lays them over settings.
        #[derive(Clone, Debug, Default, PartialEq, Deserialize)]
        #[serde(deny_unknown_fields)]
        #[cfg_attr(feature = "cli", derive(clap::Args))]
        pub struct RenderOptions {
            $(
                $(#[doc = $doc])+
                #[serde(default)]
                #[cfg_attr(feature = "cli", arg($($cli)*))]
                pub $key: Option<$ty>,
            )+
        }

        impl RenderOptions {
            /// The keys, in the order of the list.
            pub const KEYS: &'static [&'static str] = &[$(stringify!($key)),+];
        }

        impl RenderSettings {
            /// Sets every setting that `options` gives (see [`Self::apply`] for the two pairs of
            /// keys that interact).
            fn apply_each(&mut self, options: &RenderOptions) {
                $(
                    if let Some(v) = &options.$key {
                        self.$key = field_value!(v.clone() $(, $opt)?);
                    }
                )+
            }

            /// Runs every setting's own range check.
            fn check_each(&self) -> Result<(), SettingError> {
                $(
                    field_check!(self.$key, $check $(, $opt)?)
                        .map_err(|message| SettingError { key: stringify!($key), message })?;
                )+
                Ok(())
            }
        }
    };
}

render_settings! {
    /// Stop after this many iterations (photon-mapping passes) to average; given a time limit
    /// alone (`time_limit`, `--time`), a later layer drops the count and renders until the time
    /// is up. On the command line `A..B` renders iterations A to B as a partial render, for
    /// `haze merge` (docs/distributed.md).
    [short = 'n', long, value_name = "N"]
    iterations: u64, optional = Some(DEFAULT_ITERATIONS), iteration_count;

    /// Time budget in seconds (on the command line a duration: 90, 90s, 1.5m, 1h); with an
    /// iteration count, the render stops at whichever comes first.
    [short = 't', long = "time", value_name = "DURATION", value_parser = parse_duration]
    time_limit: f64, optional = None, seconds;

    /// Stop once the image's estimated relative error reaches this (a fraction; on the command
    /// line also a percentage such as 2%): the upper confidence limit, at `target_confidence`,
    /// of the image's estimated relative RMSE from its noise and, for photon mapping, its
    /// estimated kernel bias (docs/error.md). It stops a render early and never extends it:
    /// the iteration count (the scene's, or -n) and a time limit still end the render when the
    /// target is out of reach; to render past the scene's count, give -n or -t as the bound.
    [long, value_name = "E", value_parser = parse_fraction_or_percent]
    target_error: f64, optional = None, open_unit;

    /// Confidence of `target_error`'s upper limit (default 0.95).
    [long, value_name = "C"]
    target_confidence: f64 = 0.95, open_unit;

    /// Measure `target_error` over the pixels X0,Y0,X1,Y1 only (X1, Y1 exclusive; in the scene
    /// file `[x0, y0, x1, y1]`) instead of the whole image.
    [long, value_name = "X0,Y0,X1,Y1"]
    target_region: Region, optional = None, any;

    /// Light paths emitted per iteration.
    [short = 'p', long, value_name = "N"]
    photons: u64 = 100_000, photon_count;

    /// Radius reduction α in (0, 1) of the surface schedule r²(i+1)/r²(i) = (i+α)/(i+1).
    [short = 'a', long, value_name = "A"]
    alpha: f64 = 2.0 / 3.0, open_unit;

    /// Initial gathering radius in scene units; when set, it replaces `radius_fraction`.
    [short = 'r', long, value_name = "R", conflicts_with = "radius_fraction"]
    radius: f64, optional = None, length;

    /// Initial gathering radius as a fraction of the scene's bounding-box diagonal.
    [long, value_name = "F"]
    radius_fraction: f64 = 0.01, fraction;

    /// Density-estimation kernel.
    [short = 'k', long, value_name = "KERNEL"]
    kernel: Kernel = Kernel::Epanechnikov, any;

    /// Most scattering events along a whole path from the light to the camera — medium
    /// collisions, diffuse and specular surface events (crossing a pass-through interface is not
    /// one): every mode renders the same image under the same limit. 1 is single scattering.
    /// pbrt-v4's maxdepth B, Mitsuba 3 volpath's max_depth B + 1, Tungsten's max_bounces B + 1 +
    /// the pass-through surfaces crossed (docs/scene-format.md).
    [long, value_name = "B"]
    max_bounces: u32 = 64, bounce_limit;

    /// Seed of every random stream: the same scene, seed and iteration count give the same
    /// image, whatever the number of threads (0 to 2⁶³ − 1: TOML's integers).
    [short = 's', long, value_name = "S"]
    seed: u64 = 0, seed_range;

    /// In-scattering estimate along eye paths in media.
    [long, value_name = "KIND"]
    volume_estimate: VolumeEstimate = VolumeEstimate::Beam, any;

    /// Radius reduction α of the volume schedule r^d(i+1)/r^d(i) = (i+α)/(i+1), for both
    /// estimates.
    [long, value_name = "A"]
    volume_alpha: f64 = 0.5, open_unit;

    /// Initial volume radius in scene units; when set, it replaces `volume_radius_fraction`.
    [long, value_name = "R", conflicts_with = "volume_radius_fraction"]
    volume_radius: f64, optional = None, length;

    /// Initial volume radius as a fraction of the scene's bounding-box diagonal.
    [long, value_name = "F"]
    volume_radius_fraction: f64 = 0.005, fraction;

    /// Dimension d of the volume radius schedule: 3 (what both estimates should use); 2 or 1 for
    /// experiments.
    [long, value_name = "D"]
    volume_dimension: u32 = 3, dimension;

    /// Integrator: `auto` (the default: `combined`, or `hybrid` in a scene whose media emit),
    /// every estimator weighed by multiple importance sampling, the hybrid of light sampling and
    /// photons, photon mapping alone, or the unbiased reference path tracer.
    [long, value_name = "NAME"]
    integrator: Integrator = Integrator::Auto, any;

    /// Probabilistic PPM (one radius per iteration, image = mean of iterations), or the original
    /// PPM's per-pixel statistics (a comparison mode for surfaces only).
    [long, value_name = "KIND"]
    progression: Progression = Progression::Probabilistic, any;

    /// Next-event estimates of direct light per eye-path vertex (a diffuse surface, or a segment
    /// in a medium) and iteration, in the hybrid: more lowers the direct light's noise at the
    /// cost of the camera pass, without more photons or photon queries.
    [long, value_name = "N"]
    direct_samples: u32 = 1, direct_count;

    /// Where photons are emitted: `visibility` (towards what the camera sees, from a pilot pass)
    /// or `off` (by power, uniformly).
    [long, value_name = "KIND"]
    photon_guiding: PhotonGuiding = PhotonGuiding::Visibility, any;

    /// Split and end light paths by their worth to the image at collisions in media:
    /// `importance` (from a pilot of eye random walks), `off`, or `auto` (the default: the
    /// combined integrator splits where one photon pass finds light paths running long, more
    /// than 32 photons stored per path; the other integrators do not split). Photon mapping and
    /// the combined integrator; unbiased either way.
    [long, value_name = "KIND"]
    photon_splitting: PhotonSplitting = PhotonSplitting::Auto, any;

    /// Thin volume photons in thinning cells (cubes holding ~4 photons on average) holding more
    /// than this many: each is kept with probability budget/count and its power divided by it —
    /// unbiased, and it bounds the cost of beam queries where photons crowd. Off if absent.
    [long, value_name = "B"]
    beam_cell_budget: u32, optional = None, at_least_one;

    /// Next-event estimation towards emitting media (hybrid): light from their points at least
    /// this far (scene units) from a lit diffuse surface is sampled directly, nearer light (and
    /// in media all of it) is left to photons. Off if absent: photons carry it all (it wins on
    /// wide surfaces lit by a compact fire, scenes/campfire.toml; on the bundled room fire it
    /// wins on the walls and loses near the fire; docs/theory.md).
    [long, value_name = "D"]
    emission_nee_distance: f64, optional = None, length;

    /// With the combined integrator, also write what each technique contributes, weighted, as
    /// EXR layers that sum to the image (`technique_hit`, `technique_nee`, `technique_surface`,
    /// `technique_point`, `technique_beam`, and `technique_emitted` for emitting media). Kept by
    /// a render in one process only: a range or a resumed render refuses it.
    [long, value_name = "BOOL", num_args = 0..=1, default_missing_value = "true"]
    techniques: bool = false, any;

    /// With the combined integrator, count only these techniques (`hit`, `nee`, `surface`,
    /// `point`, `beam`, joined by `+`), each with weight 1: one technique alone, to check it
    /// against a reference. A set whose techniques sample disjoint sets of paths that together
    /// hold every path renders the whole image: `hit` (area lights), `nee` (when no light is
    /// seen directly or through glass), `surface+point` or `surface+beam` (when none is seen at
    /// all); any other set leaves light out or counts it twice. Emitting media's light, which
    /// only the eye paths gather, is always counted.
    [long, value_name = "T+T"]
    only: Techniques, optional = None, any;

    /// With the combined integrator, where eye paths merge with photons: `first`, at their
    /// first vertex that is not specular, `everywhere`, at every vertex (UPBP's set of
    /// techniques), or `last`, at the first, where the eye path ends. Unset, `first`, or `last`
    /// where the light-path pilot finds the eye's deeper vertices costing most of an iteration.
    /// The other integrators ignore it.
    [long, value_name = "WHERE"]
    merges: Merges, optional = None, any;

    /// With the combined integrator, whether point–point merges at the eye's collisions in
    /// media are weighed with the beam's: `auto` (the default), off where the eye paths end at
    /// their first merge and on elsewhere; `on`; or `off`, the beam alone. Where the eye ends at
    /// its first merge the point merge adds the noise of where its collision falls to light the
    /// beam gathers along the same segment (dense-fog: 0.83× the relative RMSE at equal time
    /// without it; docs/performance.md, "Point merges"). With `only`, point merges count where
    /// it names them. The other integrators ignore it.
    [long, value_name = "WHEN"]
    point_merges: PointMerges = PointMerges::Auto, any;

    /// With the combined integrator, how its light paths per iteration are set: `pilot` (the
    /// default), a pilot before the first iteration picks 1, 1/2, 1/4 or 1/8 of `photons`, or
    /// none where the eye's techniques alone carry all the light; or `fixed`, `photons` as set.
    /// The other integrators ignore it.
    [long, value_name = "HOW"]
    photon_budget: PhotonBudget, optional = None, any;
}

/// A rejected setting: the key (as in the scene file) and the reason.
#[derive(Clone, Debug, PartialEq)]
pub struct SettingError {
    /// Key within `[render]`, e.g. `alpha`.
    pub key: &'static str,
    /// Why it was rejected.
    pub message: String,
}

impl std::fmt::Display for SettingError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.key, self.message)
    }
}

impl RenderOptions {
    /// Rejects a pair of keys that exclude each other (`radius` and `radius_fraction`, or
    /// `volume_radius` and `volume_radius_fraction`) given together in one set of options.
    pub fn check_pairs(&self) -> Result<(), SettingError> {
        if self.radius.is_some() && self.radius_fraction.is_some() {
            return Err(SettingError {
                key: "radius",
                message: "give `radius` or `radius_fraction`, not both".into(),
            });
        }
        if self.volume_radius.is_some() && self.volume_radius_fraction.is_some() {
            return Err(SettingError {
                key: "volume_radius",
                message: "give `volume_radius` or `volume_radius_fraction`, not both".into(),
            });
        }
        Ok(())
    }

    /// Parses `KEY=VALUE` assignments separated by commas, with the keys and values of the
    /// scene file's `[render]` table (strings may go unquoted), e.g. `alpha=0.5,kernel=constant`.
    pub fn parse_assignments(list: &str) -> Result<RenderOptions, String> {
        let mut text = String::new();
        for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (key, value) =
                item.split_once('=').ok_or_else(|| format!("`{item}` is not KEY=VALUE"))?;
            let (key, value) = (key.trim(), value.trim());
            if !Self::KEYS.contains(&key) {
                return Err(format!(
                    "unknown render setting `{key}`; the settings are {}",
                    Self::KEYS.join(", ")
                ));
            }
            // A bare word is a string.
            let quoted = value.parse::<f64>().is_err() && !value.starts_with('"');
            let value = if quoted { format!("\"{value}\"") } else { value.to_string() };
            text.push_str(&format!("{key} = {value}\n"));
        }
        let options: RenderOptions = toml::from_str(&text).map_err(|e| e.message().to_string())?;
        options.check_pairs().map_err(|e| e.to_string())?;
        Ok(options)
    }
}

impl RenderSettings {
    /// Lays `options` over these settings: every setting the options give replaces this one's.
    /// Two pairs of keys interact, so that a later layer (the command line over the scene file)
    /// means what it says:
    ///
    /// - a time limit without an iteration count removes the iteration count (render until the
    ///   time is up). A target error does not: it only stops a render early, so an unreachable
    ///   target still ends at the count;
    /// - a radius fraction without an absolute radius removes the absolute radius (likewise for
    ///   the volume radius).
    ///
    /// The result is not validated: call [`Self::validate`].
    pub fn apply(&mut self, options: &RenderOptions) {
        self.apply_each(options);
        if options.time_limit.is_some() && options.iterations.is_none() {
            self.iterations = None;
        }
        if options.radius_fraction.is_some() && options.radius.is_none() {
            self.radius = None;
        }
        if options.volume_radius_fraction.is_some() && options.volume_radius.is_none() {
            self.volume_radius = None;
        }
    }

    /// These settings with `options` applied (see [`Self::apply`]).
    pub fn with(&self, options: &RenderOptions) -> Self {
        let mut s = self.clone();
        s.apply(options);
        s
    }

    /// Checks every setting and the combinations; the error names the offending key.
    pub fn validate(&self) -> Result<(), SettingError> {
        self.check_each()?;
        if self.iterations.is_none() && self.time_limit.is_none() {
            let message = if self.target_error.is_some() {
                "a target error needs an iteration count or a time limit beside it, to end a \
                 render whose target is out of reach"
            } else {
                "give an iteration count or a time limit (or both, and a target error)"
            };
            return Err(SettingError { key: "iterations", message: message.into() });
        }
        if self.target_error.is_some() && self.progression == Progression::Original {
            return Err(SettingError {
                key: "target_error",
                message: "the original PPM keeps no variance estimate to stop on".into(),
            });
        }
        if self.progression == Progression::Original && self.integrator != Integrator::PhotonMapping
        {
            return Err(SettingError {
                key: "progression",
                message: format!(
                    "\"original\" is a comparison mode for photon mapping alone (integrator = \"photons\"), not \"{}\"",
                    self.integrator
                ),
            });
        }
        Ok(())
    }

    /// These settings with the integrator a scene is rendered with ([`Integrator::resolve`]):
    /// what a render records, so that its output names the integrator that made it.
    pub fn resolved(&self, emitting_media: bool) -> Self {
        Self { integrator: self.integrator.resolve(emitting_media), ..self.clone() }
    }

    /// The initial surface radius for a scene whose bounding-box diagonal is `diagonal`.
    pub fn initial_radius(&self, diagonal: f64) -> f64 {
        self.radius.unwrap_or(self.radius_fraction * diagonal)
    }

    /// The initial volume radius for a scene whose bounding-box diagonal is `diagonal`.
    pub fn initial_volume_radius(&self, diagonal: f64) -> f64 {
        self.volume_radius.unwrap_or(self.volume_radius_fraction * diagonal)
    }

    /// Every setting as (key, value) in the scene file's syntax, absent ones left out: what the
    /// EXR header records.
    pub fn entries(&self) -> Vec<(String, String)> {
        let table = toml::Table::try_from(self).unwrap_or_default();
        RenderOptions::KEYS
            .iter()
            .filter_map(|k| table.get(*k).map(|v| (k.to_string(), v.to_string())))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn choices_round_trip_and_list_the_choices() {
        for k in Kernel::ALL {
            assert_eq!(k.name().parse::<Kernel>(), Ok(*k));
        }
        for i in Integrator::ALL {
            assert_eq!(i.name().parse::<Integrator>(), Ok(*i));
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

    #[test]
    fn options_layer_over_settings() {
        let file: RenderOptions =
            toml::from_str("iterations = 10\nradius = 0.2\nkernel = \"constant\"").unwrap();
        let mut s = RenderSettings::default();
        s.apply(&file);
        assert_eq!((s.iterations, s.radius, s.kernel), (Some(10), Some(0.2), Kernel::Constant));
        // A time limit alone replaces the count; a fraction alone replaces the absolute radius.
        let cli = RenderOptions::parse_assignments("time_limit=5,radius_fraction=0.1").unwrap();
        s.apply(&cli);
        assert_eq!((s.iterations, s.time_limit), (None, Some(5.0)));
        assert_eq!((s.radius, s.radius_fraction), (None, 0.1));
        assert_eq!(s.initial_radius(2.0), 0.2);
        s.validate().unwrap();
        // Unknown keys and values are refused, naming them.
        assert!(RenderOptions::parse_assignments("alpah=1").unwrap_err().contains("alpah"));
        assert!(toml::from_str::<RenderOptions>("alpah = 1").is_err());
        assert!(RenderOptions::parse_assignments("kernel=gauss").unwrap_err().contains("gauss"));
        assert!(RenderOptions::parse_assignments("radius=1,radius_fraction=0.1").is_err());
        let bad = RenderSettings { alpha: 1.5, ..RenderSettings::default() };
        assert_eq!(bad.validate().unwrap_err().key, "alpha");
    }

    #[test]
    fn the_default_integrator_is_combined_unless_media_emit() {
        let s = RenderSettings::default();
        assert_eq!(s.integrator, Integrator::Auto);
        assert_eq!(s.resolved(false).integrator, Integrator::Combined);
        assert_eq!(s.resolved(true).integrator, Integrator::Hybrid);
        // A choice made is kept, wherever media emit.
        for i in Integrator::ALL.iter().copied().filter(|&i| i != Integrator::Auto) {
            assert_eq!(i.resolve(false), i);
            assert_eq!(i.resolve(true), i);
        }
    }

    #[test]
    fn entries_record_every_set_key_in_file_syntax() {
        let s = RenderSettings { beam_cell_budget: Some(8), ..RenderSettings::default() };
        let e = s.entries();
        let get = |k: &str| e.iter().find(|(key, _)| key == k).map(|(_, v)| v.clone());
        assert_eq!(get("kernel").as_deref(), Some("\"epanechnikov\""));
        assert_eq!(get("integrator").as_deref(), Some("\"auto\""));
        assert_eq!(get("beam_cell_budget").as_deref(), Some("8"));
        assert_eq!(get("time_limit"), None);
        // What the header records reads back as the same settings.
        let text: String = e.iter().map(|(k, v)| format!("{k} = {v}\n")).collect();
        let back = RenderSettings::default().with(&toml::from_str(&text).unwrap());
        assert_eq!(back, s);
    }
}
