//! A render's settings resolved once against its scene. [`Plan::new`] is the one place where a
//! render's settings are checked, alone and against the scene (the keys and their combinations,
//! the initial radii against the scene's size, the target region against the image, the method
//! against the scene's media; where a render starts — a range, a resume — is checked against
//! them in `render.rs`), and where everything derived from them is worked out: the light paths
//! per iteration, both radius schedules, the hybrid's choices, the volume estimate and the beam
//! map's thinning budget. The methods ([`crate::integrator`]) read the plan and nothing else of
//! the settings.
//!
//! The radii of an iteration come from [`Plan::radii`] alone; the photon maps are built with
//! them and keep them, and the surface, point and beam estimates read their radius from the map
//! they query, so a map and its gathers cannot disagree (the original PPM's per-pixel radii,
//! each at most the radius its map was built for, are its own).

use crate::error::{Error, Result};
use crate::estimate::kernel::Kernel;
use crate::estimate::radius::radius;
use crate::scene::Scene;
use crate::settings::{
    Integrator, Merges, PhotonBudget, PhotonGuiding, PhotonSplitting, PointMerges, Progression,
    RenderSettings, Techniques, VolumeEstimate,
};

/// The smallest initial radius accepted, relative to the scene's bounding-box diagonal: below it
/// positions in f32 cannot resolve the kernel and the photon density needed is absurd, so the
/// image would come out black.
pub const MIN_RADIUS_FRACTION: f64 = 1e-5;

/// A radius schedule of probabilistic PPM: r_{i+1}^d / r_i^d = (i + α)/(i + 1) from r_1
/// ([`crate::estimate::radius`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Schedule {
    /// r_1, in scene units.
    pub initial: f64,
    /// α in (0, 1).
    pub alpha: f64,
    /// The kernel's dimension d.
    pub dimension: u32,
}

impl Schedule {
    /// r_i, for iteration `i` ≥ 1.
    pub fn radius(&self, i: u64) -> f64 {
        radius(i, self.initial, self.alpha, self.dimension)
    }
}

/// The radii of one iteration: the surface schedule's and the volume schedule's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Radii {
    pub surface: f64,
    pub volume: f64,
}

/// Which method renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum MethodKind {
    /// Probabilistic PPM, alone or with light sampling (the hybrid).
    PhotonMapping,
    /// The original PPM's per-pixel statistics (comparison mode, scenes without media).
    Original,
    /// The reference path tracer.
    Path,
    /// Eye paths, next-event estimation and photon merging combined by MIS.
    Combined,
}

/// A render's settings, checked and resolved against its scene.
#[derive(Clone, Debug)]
pub(crate) struct Plan {
    pub method: MethodKind,
    /// Seed of every random stream.
    pub seed: u64,
    /// Light paths per iteration.
    pub paths: u64,
    pub max_bounces: u32,
    /// Light sampling for direct light, photons for the rest (the hybrid integrator).
    pub hybrid: bool,
    /// Next-event estimates per eye vertex in the hybrid.
    pub direct_samples: u32,
    /// The hybrid's light of emitting media from points at least this far from the receiver is
    /// estimated by next-event estimation, nearer light by photons (infinite: all by photons; so
    /// without emitting media or without the hybrid).
    pub media_near: f32,
    pub kernel: Kernel,
    pub estimate: VolumeEstimate,
    pub beam_cell_budget: Option<u32>,
    /// Guide photon emission by a pilot pass: asked for, probabilistic PPM, and no emitting
    /// media (their photons are not guided, and with them in the scene nothing is).
    pub guiding: bool,
    /// Split light paths by importance (photon mapping and the combined integrator, in scenes
    /// with media).
    pub splitting: bool,
    /// Let the combined integrator turn splitting on, before its light-path pilot, where light
    /// paths run long (`PhotonSplitting::Auto`).
    pub splitting_auto: bool,
    /// The surface schedule (dimension 2) …
    pub surface: Schedule,
    /// … and the volume schedule, for both volume estimates.
    pub volume: Schedule,
    /// Keep each technique's contribution (the combined integrator).
    pub techniques: bool,
    /// Count only these techniques, each with weight 1 (the combined integrator).
    pub only: Option<Techniques>,
    /// Where the combined integrator's eye paths merge (`Merges::First` where not set).
    pub merges: Merges,
    /// The settings leave where the eye merges open: the combined integrator's pilot may
    /// end the eye paths at their first merge (`Merges::Last`) where their deeper vertices cost
    /// most of an iteration.
    pub merges_open: bool,
    /// Whether the combined integrator weighs point–point merges (`PointMerges`).
    pub point_merges: PointMerges,
    /// Let a pilot choose the light paths per iteration among fractions of `paths` (the
    /// combined integrator, with every technique counting).
    pub budget_pilot: bool,
}

impl Plan {
    /// The plan for rendering `scene` with `settings`, or the first thing wrong with them (the
    /// error names the setting).
    pub fn new(scene: &Scene, settings: &RenderSettings) -> Result<Self> {
        settings.validate().map_err(|e| Error::Settings(e.to_string()))?;
        let diagonal = scene.diagonal() as f64;
        let surface = Schedule {
            initial: settings.initial_radius(diagonal),
            alpha: settings.alpha,
            dimension: 2,
        };
        let volume = Schedule {
            initial: settings.initial_volume_radius(diagonal),
            alpha: settings.volume_alpha,
            dimension: settings.volume_dimension,
        };
        let integrator = settings.integrator.resolve(scene.has_emissive_media());
        if integrator.uses_photons() {
            check_radii(diagonal, &surface, &volume)?;
        }
        if let Some(r) = settings.target_region {
            let [w, h] = scene.camera.resolution;
            r.check_within(w, h).map_err(|m| Error::Settings(format!("target_region: {m}")))?;
        }
        let method = match (integrator, settings.progression) {
            (Integrator::Path, _) => MethodKind::Path,
            (Integrator::Combined, Progression::Probabilistic) => MethodKind::Combined,
            (Integrator::Combined, Progression::Original) => {
                return Err(Error::Settings(
                    "progression: \"original\" is a comparison mode of photon mapping (integrator = \"photons\"); the combined integrator runs on the probabilistic schedule".into(),
                ));
            }
            (_, Progression::Probabilistic) => MethodKind::PhotonMapping,
            (_, Progression::Original) => MethodKind::Original,
        };
        check_method(scene, settings, method)?;
        let hybrid = integrator == Integrator::Hybrid;
        // Light paths may be split (asked for, or where they run long): probabilistic PPM in a
        // scene with media; the original PPM, a comparison mode, stays the classic method.
        let splits = matches!(method, MethodKind::PhotonMapping | MethodKind::Combined)
            && settings.progression == Progression::Probabilistic
            && scene.has_media();
        Ok(Self {
            method,
            seed: settings.seed,
            paths: settings.photons,
            max_bounces: settings.max_bounces,
            hybrid,
            direct_samples: settings.direct_samples,
            media_near: match settings.emission_nee_distance {
                Some(d) if hybrid && scene.has_emissive_media() => d as f32,
                _ => f32::INFINITY,
            },
            kernel: settings.kernel,
            estimate: settings.volume_estimate,
            beam_cell_budget: settings.beam_cell_budget,
            splitting: splits && settings.photon_splitting == PhotonSplitting::Importance,
            splitting_auto: splits
                && settings.photon_splitting == PhotonSplitting::Auto
                && method == MethodKind::Combined,
            guiding: settings.photon_guiding == PhotonGuiding::Visibility
                && method == MethodKind::PhotonMapping
                && settings.progression == Progression::Probabilistic
                && !scene.has_emissive_media(),
            surface,
            volume,
            techniques: settings.techniques,
            only: settings.only,
            // A choice of the combined integrator's, which the others ignore (a scene can set
            // it for the combined integrator and still be rendered with another).
            merges: settings.merges.unwrap_or(Merges::First),
            merges_open: settings.merges.is_none(),
            point_merges: settings.point_merges,
            // Each technique alone is a check of that technique at the count asked for.
            budget_pilot: method == MethodKind::Combined
                && settings.photon_budget != Some(PhotonBudget::Fixed)
                && settings.only.is_none(),
        })
    }

    /// The radii of iteration `i` ≥ 1: what the photon maps of the iteration are built with and
    /// so what their gathers use.
    pub fn radii(&self, i: u64) -> Radii {
        Radii { surface: self.surface.radius(i), volume: self.volume.radius(i) }
    }

    /// This plan with `paths` light paths per iteration (the memory estimate's pilot).
    pub fn with_paths(&self, paths: u64) -> Self {
        Self { paths, ..self.clone() }
    }
}

/// The settings that only some methods take, or that a scene rules out, against `method`.
fn check_method(scene: &Scene, settings: &RenderSettings, method: MethodKind) -> Result<()> {
    let refuse = |m: &str| Err(Error::Settings(m.into()));
    let combined = method == MethodKind::Combined;
    if method == MethodKind::Original && !scene.media.is_empty() {
        return refuse(
            "progression: \"original\" is a comparison mode for the surface estimate; this scene has media (use \"probabilistic\")",
        );
    }
    if settings.techniques && !combined {
        return refuse(
            "techniques: only the combined integrator (integrator = \"combined\") weighs techniques against each other",
        );
    }
    if settings.only.is_some() && !combined {
        return refuse(
            "only: only the combined integrator (integrator = \"combined\") has techniques to choose from",
        );
    }
    if settings.merges == Some(Merges::Last) && combined && scene.has_emissive_media() {
        return refuse(
            "merges: \"last\" ends every eye path at its first merge, and the light paths leave the light of emitting media to the eye paths: use \"first\" or \"everywhere\" in a scene whose media emit",
        );
    }
    Ok(())
}

/// Refuses initial radii too small for the scene (see [`MIN_RADIUS_FRACTION`]).
fn check_radii(diagonal: f64, surface: &Schedule, volume: &Schedule) -> Result<()> {
    for (key, r) in [("radius", surface.initial), ("volume_radius", volume.initial)] {
        if r < MIN_RADIUS_FRACTION * diagonal {
            return Err(Error::Settings(format!(
                "{key}: an initial radius of {r:e} is below {MIN_RADIUS_FRACTION:e} of the \
                 scene's size (diagonal {diagonal:.4}); no photon would be found and the image \
                 would be black"
            )));
        }
    }
    Ok(())
}
