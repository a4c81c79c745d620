//! The photon pass: light paths from the lights, through specular and diffuse bounces and through
//! media, leaving photons on diffuse surfaces and at real collisions in media.
//!
//! Paths are traced in parallel in fixed chunks; each path draws from its own random stream
//! (seed, iteration, path index), and chunks are concatenated in order, so the photon lists are the
//! same whatever the thread count.

use super::guide::{EmissionGuide, Guided, guided};
use super::importance::{Fate, Importance};
use super::{Photon, VolumePhoton};
use crate::accel::Hit;
use crate::estimate::mis::{
    Emitted, Kernels, LightMis, SHARE_SATURATES, Site, collision_share, crossing_share,
};
use crate::math::{Rgb, offset_origin};
use crate::medium::Medium;
use crate::rng::{Purpose, Sampler};
use crate::scene::Scene;
use crate::scene::light::{Emission, EmissionPdfs, Light, LightSampler, Receiver};
use crate::scene::material::{Material, Transport};
use crate::scene::step::{Travel, Traveller, Vertex, step};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Light paths per parallel work item, at most: small enough that a pass has many more items than
/// threads (rayon steals items one at a time, so no thread waits long on another's last one),
/// large enough that an item's bookkeeping is negligible. The photons do not depend on it.
const CHUNK: u64 = 1024;
/// Work items per thread in a pass too small for [`CHUNK`]-path items to give each thread
/// several (a pilot's few thousand paths: dense-fog's light paths scatter hundreds of times, and
/// four items of 1024 paths left a processor idle for a third of the combined integrator's
/// pilot) …
const CHUNKS_PER_THREAD: usize = 8;
/// … of at least this many paths.
const CHUNK_MIN: usize = 16;

/// The light paths of each work item of a pass of `paths`.
fn chunk_len(paths: u64) -> u64 {
    let piece = crate::buffers::piece(paths as usize, CHUNKS_PER_THREAD, CHUNK_MIN) as u64;
    piece.min(CHUNK)
}

/// Settings of one photon pass.
#[derive(Clone, Copy, Debug)]
pub struct PhotonPass {
    /// Render seed.
    pub seed: u64,
    /// Iteration number (1-based; 0 is the guiding pilot).
    pub iteration: u64,
    /// Index of the first light path (its random stream; 0 but in the pilot's later rounds).
    pub first_path: u64,
    /// Light paths to emit.
    pub paths: u64,
    /// Maximum scattering events per path (pass-through interfaces are not events): a photon is
    /// stored at each of its first `max_bounces` scattering vertices at most.
    pub max_bounces: u32,
    /// Store no photon at a light path's first event (light straight from the light), which the
    /// hybrid integrator estimates by next-event estimation instead …
    pub skip_direct: bool,
    /// … and for light paths from emitting media, none at a first event on a surface at least
    /// this far from the point of emission (infinite: all are stored), which next-event
    /// estimation covers (in media photons carry it all).
    pub media_near: f32,
    /// Record each path's light and guided uniforms, and each photon's path (the guiding pilot).
    pub record: bool,
    /// With the combined estimator's kernels: give each photon its weight record
    /// ([`Photons::surface_mis`]) and emit from the lights alone (the combined estimator's eye
    /// paths gather the light of emitting media themselves).
    pub mis: Option<Kernels>,
}

/// A stored photon's record for the combined estimator's weights (`estimate/mis.rs`).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PhotonMis {
    /// The light's side of the path, relative to merging here.
    pub light: LightMis,
    /// The medium's mean extinction at a volume photon (0 on a surface).
    pub sigma: f32,
    /// Unit direction towards where the light came from.
    pub wi: Vec3,
}

/// Photons left by a pass.
#[derive(Default)]
pub struct Photons {
    /// On diffuse surfaces.
    pub surface: Vec<Photon>,
    /// In media.
    pub volume: Vec<VolumePhoton>,
    /// With `PhotonPass::record`: the light path of each surface photon …
    pub(crate) surface_path: Vec<u32>,
    /// … of each volume photon …
    pub(crate) volume_path: Vec<u32>,
    /// … and each path's light and guided pair of uniforms.
    pub(crate) paths: Vec<(u32, Vec2)>,
    /// With `PhotonPass::mis`: each surface photon's weight record …
    pub(crate) surface_mis: Vec<PhotonMis>,
    /// … and each volume photon's.
    pub(crate) volume_mis: Vec<PhotonMis>,
    /// The work the pass counted ([`crate::work`]): of its light paths, tracing included,
    /// storing not.
    pub(crate) work: crate::work::Work,
    /// The photons of each work item of the last pass, kept so that their buffers are reused.
    items: Vec<Photons>,
}

impl Photons {
    fn clear(&mut self) {
        self.surface.clear();
        self.volume.clear();
        self.surface_path.clear();
        self.volume_path.clear();
        self.paths.clear();
        self.surface_mis.clear();
        self.volume_mis.clear();
        self.work = crate::work::Work::default();
    }

    /// Makes these photons the work items' `items`, in order, copying in parallel.
    fn gather(&mut self, items: &[Photons]) {
        concat(&mut self.surface, items, |p| &p.surface);
        concat(&mut self.volume, items, |p| &p.volume);
        concat(&mut self.surface_path, items, |p| &p.surface_path);
        concat(&mut self.volume_path, items, |p| &p.volume_path);
        concat(&mut self.paths, items, |p| &p.paths);
        concat(&mut self.surface_mis, items, |p| &p.surface_mis);
        concat(&mut self.volume_mis, items, |p| &p.volume_mis);
        self.work = items.iter().map(|p| p.work).sum();
    }
}

/// Sets `out` to the concatenation of `field` of each of `items`, copying the parts in parallel.
/// `out` keeps its earlier contents where it is long enough (they are all overwritten), so that a
/// pass of about as many photons as the last one writes each element once.
fn concat<T: Copy + Default + Send + Sync>(
    out: &mut Vec<T>,
    items: &[Photons],
    field: impl Fn(&Photons) -> &Vec<T>,
) {
    let total = items.iter().map(|p| field(p).len()).sum();
    crate::buffers::scratch(out, total, T::default());
    let mut rest = &mut out[..];
    let mut parts = Vec::with_capacity(items.len());
    for item in items {
        let src = field(item);
        let (part, tail) = rest.split_at_mut(src.len());
        parts.push((part, &src[..]));
        rest = tail;
    }
    parts.into_par_iter().with_max_len(1).for_each(|(part, src)| part.copy_from_slice(src));
}

/// Russian roulette after an event that turned throughput `before` into `after`: survive with
/// probability min(1, max(after)/max(before)), so survivors keep about their power.
#[inline]
fn roulette(before: Rgb, after: Rgb, u: f32) -> Option<Rgb> {
    let q = (after.max_element() / before.max_element()).min(1.0);
    if q > 0.0 && u < q { Some(after / q) } else { None }
}

/// Photons a pass stores before it thins any: a light path's first `STORE_BUDGET / paths` events
/// (at least [`MIN_ALWAYS_STORED`]) store theirs (see [`stored`]).
const STORE_BUDGET: f32 = 1_048_576.0;

/// The fewest events after which a light path may stop storing every photon.
const MIN_ALWAYS_STORED: f32 = 32.0;

/// Events after which the light paths of a pass of `paths` stop storing every photon.
fn always_stored(paths: u64) -> f32 {
    (STORE_BUDGET / paths.max(1) as f32).max(MIN_ALWAYS_STORED)
}

/// Whether to store the photon a light path leaves at an event when it has had `bounces` events
/// before, and the factor its power is multiplied by. The first A = [`always_stored`] events of a
/// path always store theirs; later ones with probability q = A / (bounces + 1), power divided by
/// q — unbiased (the decision is independent of everything else), and a path of K events stores
/// about A · (1 + ln(K / A)) photons instead of K. A pass of M paths stores every photon until
/// its paths average 2²⁰ / M events (A = 2²⁰ / M, at least 32), and at most about
/// 2²⁰ · (1 + ln(K M / 2²⁰)) photons under a bounce limit K: memory per iteration stays bounded
/// whatever the medium. Thinning is a source of noise: in `scenes/dense-fog.toml` (an albedo-0.999
/// random walk of ~1000 events) the photons that reach the camera's side of the fog come from
/// paths hundreds of events long, and with A = 32 each stored one stood for ~16 (relative RMSE
/// at 10 s, 96x96, 125 paths, three seeds, 2 cores: 518–606 % with A = 32, 252–265 % with
/// A = 256, 191–202 % storing every photon — what the budget gives there; docs/performance.md,
/// "Thinning by a budget").
/// `surface`: the event is at a surface (else a medium collision).
fn stored(path: &mut LightPath, pass: &PhotonPass, x: Vec3, surface: bool) -> Option<f32> {
    if pass.skip_direct && path.bounces == 0 {
        match path.emitted_at {
            None => return None,
            Some(o) if surface && (x - o).length_squared() >= pass.media_near * pass.media_near => {
                return None;
            }
            Some(_) => {}
        }
    }
    let q = (always_stored(pass.paths) / (path.bounces as f32 + 1.0)).min(1.0);
    if q >= 1.0 {
        Some(1.0)
    } else if path.s.next_f32() < q {
        Some(1.0 / q)
    } else {
        None
    }
}

/// A light path in flight.
struct LightPath<'a> {
    /// Its index in the pass.
    index: u32,
    s: Sampler,
    /// The current ray, the medium it travels in, the interfaces crossed.
    ray: Travel,
    beta: Rgb,
    /// Scattering events so far (medium collisions and surface scatterings; pass-through
    /// interfaces are not events).
    bounces: u32,
    /// What splitting by importance has divided its throughput by so far, less what roulette
    /// multiplied back (1 for a path never split): roulette never takes a copy above the
    /// unsplit path's throughput ([`Importance::decide`]).
    split: f32,
    /// Where a medium emitted it (`None` for a light's): in the hybrid its first event stores a
    /// photon if it is a medium collision or lies nearer than `PhotonPass::media_near`, the light
    /// next-event estimation leaves to photons.
    emitted_at: Option<Vec3>,
    /// The combined estimator's weight quantities (with `PhotonPass::mis`).
    mis: Option<PathMis<'a>>,
}

/// A light path's weight quantities for the combined estimator (`estimate/mis.rs`).
#[derive(Clone)]
struct PathMis<'a> {
    lights: &'a LightSampler,
    kernels: Kernels,
    /// How it left the light, until its first vertex.
    start: Option<Start>,
    /// The record at its current vertex …
    here: LightMis,
    /// … and what it carries to the next, once its segment there is known ([`Left`]).
    carry: f32,
    /// The vertex left, until the path arrives at the next.
    left: Option<Left>,
    /// The eye's density of the crossings between the two over free flight's (as the eye, going
    /// the other way, would make them): the product of the homogeneous media's crossing shares
    /// (`mis::crossing_share`).
    crossed: f32,
}

/// A vertex the light path left, whose carry waits for its segment to the next: the eye path
/// that samples the vertex comes back along that segment, and its density of the vertex is the
/// product of its crossings on the way times, for a collision in a homogeneous medium, its
/// collision share ([`collision_share`]) — of the eye's segment from the end of the light's
/// first piece (the next vertex, or the surface where the medium's segment ends) to the surface
/// behind the collision, `back` away (in `homogeneous` until that piece is traced).
#[derive(Clone, Copy)]
struct Left {
    site: Site,
    p_rev: f32,
    /// The cosine (or σ, times the share once known) towards the next vertex.
    gamma_out: f32,
    p_out: f32,
    /// σ and `back`, for a collision in a homogeneous medium whose first piece is not traced.
    homogeneous: Option<(f32, f32)>,
}

/// How `light`, picked for emission with probability `p_light`, emits from a point of normal `n`
/// in direction `d`, for the combined estimator's weights.
/// Also the densities of the origin and direction ([`EmissionPdfs`]). An environment light's
/// "cosine" is 1: an eye path reaches it by a direction, whatever point of its disc the light
/// path left (`estimate/mis.rs` measures its vertex by direction).
pub(crate) fn emitted(p_light: f32, light: &Light, n: Vec3, d: Vec3) -> (Emitted, EmissionPdfs) {
    let pdfs = light.pdf_emission(n, d);
    let cos = match light {
        Light::Area { .. } => n.dot(d).abs(),
        Light::Environment(_) => 1.0,
        _ => 0.0,
    };
    (Emitted { emit: p_light * pdfs.pos * pdfs.dir, cos }, pdfs)
}

/// Next-event estimation's density of the point `x0` of `light` (emitted with densities
/// `pdfs`) from the receiver at `x1`, times their squared distance, the light chosen there with
/// probability `pick`: the `nee` of [`LightMis::first`] (a directional light: per area of its
/// emitting rectangle, 1 / `pos`, instead of the squared distance; an environment light, whose
/// vertex is a direction: `pick` times next-event estimation's density of the direction, which
/// is the emission's `dir`).
pub(crate) fn nee_density(light: &Light, pick: f32, pdfs: EmissionPdfs, x0: Vec3, x1: Vec3) -> f32 {
    match light {
        Light::Directional { .. } => pick,
        Light::Environment(_) => pick * pdfs.dir,
        _ => pick * pdfs.pos * (x1 - x0).length_squared(),
    }
}

/// How a light path left its light.
#[derive(Clone, Copy)]
struct Start {
    light: usize,
    /// Its origin, and the densities of the origin and direction.
    x0: Vec3,
    pdfs: EmissionPdfs,
    e: Emitted,
}

impl<'a> PathMis<'a> {
    /// Starts the quantities of a light path that left light `li` (`light`, picked with
    /// probability `p_light`) as `e`.
    fn new(
        lights: &'a LightSampler,
        kernels: Kernels,
        li: usize,
        light: &Light,
        e: &Emission,
    ) -> Self {
        let (emitted, pdfs) = emitted(lights.emission_prob(li), light, e.n, e.d);
        let start = Some(Start { light: li, x0: e.p, pdfs, e: emitted });
        let here = LightMis::default();
        Self { lights, kernels, start, here, carry: 0.0, left: None, crossed: 1.0 }
    }

    /// Arrives at a vertex, with the cosine (or σ) `gamma` against the arriving direction; `r`:
    /// where next-event estimation there connects from, as the eye paths' receiver (None at a
    /// specular vertex).
    fn arrive(&mut self, scene: &Scene, gamma: f32, r: Option<Receiver>) {
        let crossed = std::mem::replace(&mut self.crossed, 1.0);
        self.here = match self.start.take() {
            Some(st) => {
                let nee = r.map_or(0.0, |r| {
                    let pick = self.lights.prob(&r, st.light);
                    nee_density(&scene.lights[st.light], pick, st.pdfs, st.x0, r.p)
                });
                // The eye reaches the light past the crossings.
                let e = Emitted { cos: st.e.cos * crossed, ..st.e };
                LightMis::first(e, nee, gamma)
            }
            None => {
                if let Some(l) = self.left.take() {
                    let c = self.kernels.at_light(l.site);
                    self.carry = self.here.carry(c, l.p_rev, l.gamma_out * crossed, l.p_out);
                }
                LightMis::arrive(self.carry, gamma)
            }
        };
    }

    /// Leaves the vertex (a `site`) by a direction of density `p_out` and cosine (or σ)
    /// `gamma_out`; `p_rev`: the eye's density of the direction the light came from, given it;
    /// `homogeneous`: σ and the distance to the surface behind, for a collision in a
    /// homogeneous medium ([`Left`]).
    fn leave(
        &mut self,
        site: Site,
        p_rev: f32,
        gamma_out: f32,
        p_out: f32,
        homogeneous: Option<(f32, f32)>,
    ) {
        self.left = Some(Left { site, p_rev, gamma_out, p_out, homogeneous });
        self.crossed = 1.0;
    }

    /// The path traced a piece of its segment, `length` long, in `m` from `o` (up to its next
    /// vertex, or to the surface the medium's segment ends at).
    fn piece(&mut self, m: &Medium, o: Vec3, length: f32) {
        let Medium::Homogeneous(_) = m else { return };
        match self.left.as_mut().and_then(|l| l.homogeneous.take().map(|h| (l, h))) {
            // The first piece from a collision: the eye's segment through it is known.
            Some((l, (sigma, back))) => {
                let eye = sigma * collision_share(sigma, length + back);
                (l.site, l.gamma_out) = (Site::Medium(eye), eye);
            }
            None => self.crossed *= crossing_share(m.mean_sigma_t(o), length),
        }
    }
}

/// Where photons are emitted: by power and uniformly, or by a guide.
#[derive(Clone, Copy)]
pub(crate) enum Emitting<'a> {
    ByPower(&'a LightSampler),
    Guided(&'a EmissionGuide),
}

/// Traces one light path, storing its photons in `out`. With emitting media in the scene
/// (`p_media` > 0) the path starts in one of them with probability `p_media`, their share of the
/// total power, and a light's photon carries its power over the lights' share; without, nothing
/// is drawn for that choice.
fn trace_path(
    scene: &Scene,
    emitting: Emitting,
    p_media: f32,
    pass: &PhotonPass,
    importance: Option<&Importance>,
    index: u64,
    out: &mut Photons,
) {
    let mut s = Sampler::new(pass.seed, Purpose::Photon, pass.iteration, index);
    let mut p_lights = 1.0;
    if p_media > 0.0 {
        if s.next_f32() < p_media {
            if pass.record {
                // Keeps the paths' numbering; no guide learns from media (see `ppm.rs`).
                out.paths.push((u32::MAX, Vec2::ZERO));
            }
            let Some(e) = scene.emissive_media.sample(scene, &mut s) else { return };
            let path = LightPath {
                index: index as u32,
                s,
                ray: Travel::new(e.p, e.d, Some(e.medium)),
                beta: e.beta / p_media,
                bounces: 0,
                split: 1.0,
                emitted_at: Some(e.p),
                mis: None,
            };
            follow(scene, pass, importance, index, path, out);
            return;
        }
        p_lights = 1.0 - p_media;
    }
    let u_light = s.next_f32();
    let (li, guided_pick) = match emitting {
        Emitting::ByPower(lights) => (lights.pick_emission(u_light).0, false),
        Emitting::Guided(g) => g.pick(u_light),
    };
    let light = &scene.lights[li];
    let (u_pick, mut u_pos, mut u_dir) = (s.next_f32(), s.next_2d(), s.next_2d());
    let u = match guided(light) {
        Guided::Position => &mut u_pos,
        Guided::Direction => &mut u_dir,
    };
    // The density of the light and its uniforms: by power and uniform, or the guide's mixture.
    let p_light = match emitting {
        Emitting::ByPower(lights) => lights.emission_prob(li),
        Emitting::Guided(g) => {
            let (v, density) = g.place(li, *u, guided_pick);
            *u = v;
            density
        }
    };
    if pass.record {
        out.paths.push((li as u32, *u));
    }
    let e = light.sample_emission(u_pick, u_pos, u_dir);
    let beta: Rgb = e.beta / (p_light * p_lights);
    if beta.max_element() <= 0.0 {
        return;
    }
    let o = if e.n == Vec3::ZERO { e.p } else { offset_origin(e.p, e.n, e.d) };
    let medium = scene.light_media[li];
    let (ray, bounces, emitted_at) = (Travel::new(o, e.d, medium), 0, None);
    let mis = match (pass.mis, emitting) {
        // Without emitting media (the combined estimator emits from lights alone) p_lights is
        // 1 and the light's probability is the sampler's.
        (Some(k), Emitting::ByPower(lights)) => Some(PathMis::new(lights, k, li, light, &e)),
        _ => None,
    };
    let path =
        LightPath { index: index as u32, s, ray, beta, bounces, split: 1.0, emitted_at, mis };
    follow(scene, pass, importance, index, path, out);
}

/// Follows a light path from its start to its end, and then each copy it split into
/// ([`Importance`]) from where it was made, storing their photons in `out`.
fn follow(
    scene: &Scene,
    pass: &PhotonPass,
    importance: Option<&Importance>,
    root: u64,
    path: LightPath<'_>,
    out: &mut Photons,
) {
    let mut tracing = Tracing { pass, importance, path, out, copies: Vec::new(), made: 0, root };
    loop {
        while step(scene, &mut tracing) != Vertex::Stop {}
        // The next copy that scatters on (one that ends at once is done).
        loop {
            let Some((copy, from)) = tracing.copies.pop() else { return };
            tracing.path = copy;
            let m = &scene.media[from.medium as usize];
            if tracing.scatter(scene, m, from) != Vertex::Stop {
                break;
            }
        }
    }
}

/// Where a copy of a light path made at a collision goes on from: the collision in medium
/// `medium` at `p`, reached along `d`, the throughputs before the free flight there and after
/// its scattering weight (each already divided by the split's factor), and σ̄ there.
#[derive(Clone, Copy)]
struct From {
    medium: u32,
    p: Vec3,
    d: Vec3,
    before: Rgb,
    survival: Rgb,
    sigma: f32,
}

/// A light path on its way, the pass it belongs to and the photons it leaves; with importance,
/// the copies it has split into that wait to be followed, how many it has made, and its random
/// stream's key (each copy's stream is keyed by it and the copy's number).
struct Tracing<'a> {
    pass: &'a PhotonPass,
    importance: Option<&'a Importance>,
    path: LightPath<'a>,
    out: &'a mut Photons,
    copies: Vec<(LightPath<'a>, From)>,
    made: u32,
    root: u64,
}

impl<'a> Tracing<'a> {
    /// A collision's fate by importance ([`Importance::decide`]): `None` if the path ends there,
    /// else the factor its throughputs are divided by, the copies beyond this one waiting in
    /// `copies`.
    fn split(&mut self, from: From) -> Option<f32> {
        let Some(imp) = self.importance else { return Some(1.0) };
        let path = &mut self.path;
        match imp.decide(path.beta, from.p, self.made, path.split, path.s.next_f32()) {
            Fate::Keep => Some(1.0),
            Fate::Survive(q) => {
                path.split *= q;
                Some(q)
            }
            Fate::End => None,
            Fate::Split(n, f) => {
                path.split *= f;
                let scaled = From { before: from.before / f, survival: from.survival / f, ..from };
                for _ in 1..n {
                    self.made += 1;
                    let key = (self.root << 11) | u64::from(self.made);
                    let s = Sampler::new(self.pass.seed, Purpose::Split, self.pass.iteration, key);
                    let p = &self.path;
                    let copy = LightPath {
                        index: p.index,
                        s,
                        ray: p.ray,
                        beta: p.beta,
                        bounces: p.bounces,
                        split: p.split,
                        emitted_at: p.emitted_at,
                        mis: p.mis.clone(),
                    };
                    self.copies.push((copy, scaled));
                }
                Some(f)
            }
        }
    }

    /// Scatters the path at the collision `from` in `m`: samples the phase function, plays the
    /// albedo's Russian roulette and sets the next ray.
    fn scatter(&mut self, scene: &Scene, m: &Medium, from: From) -> Vertex {
        let From { p, d, before, survival, sigma, .. } = from;
        let path = &mut self.path;
        let ps = m.phase().sample(d, path.s.next_2d());
        // The scattering weight is σ_s times the phase sample's value over its pdf (1 for exact
        // sampling); the path survives with the albedo (the throughput before the flight against
        // after the scattering), so absorbing and dense media end paths where they absorb light.
        let survival = survival * (ps.value / ps.pdf);
        let Some(b) = roulette(before, survival, path.s.next_f32()) else {
            return Vertex::Stop;
        };
        if let Some(mis) = &mut path.mis {
            // The phase function is symmetric: the eye's reverse density is the same. The eye's
            // density factor of this collision is free flight's, σ, in a grid; in a homogeneous
            // medium its share of it needs the eye's segment through here.
            let homogeneous = matches!(m, Medium::Homogeneous(_)).then(|| {
                // Past SHARE_SATURATES / σ the share is 1 whatever lies behind: a ray bounded
                // there costs far less in a dense medium, and gives the same weights.
                let reach = if sigma > 0.0 { SHARE_SATURATES / sigma } else { f32::INFINITY };
                let behind = scene.intersect(p, -ps.wi, reach);
                (sigma, behind.map_or(f32::INFINITY, |h| h.t))
            });
            mis.leave(Site::Medium(sigma), ps.pdf, sigma, ps.pdf, homogeneous);
        }
        (path.beta, path.ray.o, path.ray.d) = (b, p, ps.wi);
        Vertex::Scattered
    }
}

impl Traveller for Tracing<'_> {
    fn travel(&mut self) -> &mut Travel {
        &mut self.path.ray
    }

    /// A collision stores a volume photon and scatters the path.
    fn in_medium(
        &mut self,
        scene: &Scene,
        id: u32,
        t_max: f32,
        _end: Option<&Hit>,
    ) -> Option<Vertex> {
        let Tracing { pass, path, out, .. } = self;
        let m = &scene.media[id as usize];
        let Travel { o, d, .. } = path.ray;
        let flight = m.sample_free_flight(o, d, t_max, &mut path.s);
        if let Some(mis) = &mut path.mis {
            mis.piece(m, o, if flight.scattered { flight.t } else { t_max });
        }
        let before = path.beta;
        path.beta *= flight.weight;
        if !flight.scattered {
            return (path.beta.max_element() <= 0.0).then_some(Vertex::Stop);
        }
        let p = o + d * flight.t;
        let sigma_s = m.sigma_s(p);
        // The combined estimator's weights: σ̄ is the density's factor at a collision.
        let sigma = match &mut path.mis {
            Some(mis) => {
                let sigma = m.mean_sigma_t(p);
                mis.arrive(scene, sigma, Some(Receiver::medium(p)));
                sigma
            }
            None => 0.0,
        };
        // The collision's survival weight T/p(t) · σ_s: the albedo σ_s/σ_t for a grey medium.
        let survival = path.beta * sigma_s;
        // Power convention (see `VolumePhoton`): β after the free-flight pdf, before σ_s. Where
        // σ_s = 0 the photon could only ever be weighted by zero: skip it.
        if sigma_s.max_element() > 0.0 {
            if let Some(scale) = stored(path, pass, p, false) {
                let bounces = path.bounces as u16;
                let beta = path.beta * scale;
                out.volume.push(VolumePhoton { p, d, beta, medium: id as u16, bounces });
                if pass.record {
                    out.volume_path.push(path.index);
                }
                if let Some(mis) = &path.mis {
                    out.volume_mis.push(PhotonMis { light: mis.here, sigma, wi: -d });
                }
            }
        }
        path.bounces += 1;
        if path.bounces >= pass.max_bounces {
            return Some(Vertex::Stop);
        }
        let from = From { medium: id, p, d, before, survival, sigma };
        let Some(f) = self.split(from) else { return Some(Vertex::Stop) };
        let from = From { before: before / f, survival: survival / f, ..from };
        Some(self.scatter(scene, m, from))
    }

    /// A diffuse surface stores a photon, and the path scatters.
    fn at_surface(&mut self, scene: &Scene, hit: &Hit, material: &Material) -> Vertex {
        let Tracing { pass, path, out, .. } = self;
        let wo = -path.ray.d;
        let n = if wo.dot(hit.ng) >= 0.0 { hit.ng } else { -hit.ng };
        let diffuse = material.is_diffuse();
        if let Some(mis) = &mut path.mis {
            // The eye's receiver there: off the surface on the lit side.
            let r = diffuse.then(|| Receiver::surface(offset_origin(hit.p, n, n), n));
            mis.arrive(scene, wo.dot(n), r);
        }
        if diffuse {
            // Power convention (see `Photon`): store the path throughput as it arrives.
            if let Some(scale) = stored(path, pass, hit.p, true) {
                let (beta, bounces) = (path.beta * scale, path.bounces as u16);
                out.surface.push(Photon { p: hit.p, n, beta, bounces });
                if pass.record {
                    out.surface_path.push(path.index);
                }
                if let Some(mis) = &path.mis {
                    out.surface_mis.push(PhotonMis { light: mis.here, sigma: 0.0, wi: wo });
                }
            }
        }
        path.bounces += 1;
        if path.bounces >= pass.max_bounces {
            return Vertex::Stop;
        }
        let u = path.s.next_2d();
        let u_lobe = path.s.next_f32();
        let Some(bs) = material.sample(wo, hit.ng, hit.ns, u, u_lobe, Transport::Importance) else {
            return Vertex::Stop;
        };
        let Some(b) = roulette(path.beta, path.beta * bs.weight, path.s.next_f32()) else {
            return Vertex::Stop;
        };
        if let Some(mis) = &mut path.mis {
            let gamma_out = bs.wi.dot(hit.ng).abs();
            if diffuse {
                let p_rev = material.pdf(bs.wi, wo, hit.ng, hit.ns);
                mis.leave(Site::Surface, p_rev, gamma_out, bs.pdf, None);
            } else {
                // A delta's densities are 1 both ways.
                mis.leave(Site::Specular, 1.0, gamma_out, 1.0, None);
            }
        }
        path.beta = b;
        path.ray.leave(scene, hit, bs.wi);
        Vertex::Scattered
    }
}

/// Runs the photon pass into `out` (replacing what it held), emitting photons by power or by a guide.
/// Returns `false` if `stop` was raised before it finished (`out` is then empty). `out` keeps
/// each work item's photons besides the pass's lists, so that the next pass reuses their buffers.
pub(crate) fn trace_photons(
    scene: &Scene,
    lights: &LightSampler,
    guide: Option<&EmissionGuide>,
    importance: Option<&Importance>,
    pass: &PhotonPass,
    stop: &AtomicBool,
    out: &mut Photons,
) -> bool {
    if (lights.is_empty() && scene.emissive_media.is_empty())
        || (pass.mis.is_some() && lights.is_empty())
    {
        out.clear();
        return true;
    }
    // Emitting media's share of the photons: their share of the power (none for the combined
    // estimator).
    let media = if pass.mis.is_some() { 0.0 } else { scene.emissive_media.power() };
    let p_media = if media > 0.0 { media / (media + lights.total_power()) } else { 0.0 };
    let emitting = match guide {
        Some(g) => Emitting::Guided(g),
        None => Emitting::ByPower(lights),
    };
    let chunk = chunk_len(pass.paths);
    let chunks = pass.paths.div_ceil(chunk) as usize;
    let mut items = std::mem::take(&mut out.items);
    items.resize_with(chunks, Photons::default);
    let finished = items.par_iter_mut().enumerate().with_max_len(1).all(|(c, local)| {
        local.clear();
        let c = c as u64;
        let before = crate::work::Work::here();
        for index in c * chunk..((c + 1) * chunk).min(pass.paths) {
            // Path by path, as pixels are (`integrator::render_pixels`).
            if stop.load(Ordering::Relaxed) {
                return false;
            }
            trace_path(scene, emitting, p_media, pass, importance, pass.first_path + index, local);
        }
        local.work = crate::work::Work::here() - before;
        true
    });
    if finished {
        out.gather(&items);
    } else {
        // Nothing of an earlier pass may pass for this one's.
        out.clear();
    }
    out.items = items;
    finished
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A light path's record at a collision holds the eye's density of the collision before
    /// it as the eye computes it: coming back from the later collision along the direction the
    /// light arrived by, to the surface behind the earlier one, its collision share of that
    /// segment (`mis::collision_share`). For consecutive collisions in cornell-fog's fog with
    /// nothing between them, the record's u is the carry from the earlier one over σ,
    /// σ s / p (c + u p + v) / σ with s from the eye's own segment: a light path that measured
    /// the eye's segment wrongly (say without the distance behind the collision) fails it.
    #[test]
    fn a_light_paths_records_hold_the_eyes_collision_share() {
        let scene = Scene::load(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-fog.toml"))
            .expect("the bundled scene loads");
        let lights = LightSampler::new(&scene.lights, scene.shapes.len());
        let kernels = Kernels::new(1000, 0.02, 0.05, true);
        let pass = PhotonPass {
            seed: 3,
            iteration: 1,
            first_path: 0,
            paths: 4000,
            max_bounces: 64,
            skip_direct: false,
            media_near: f32::INFINITY,
            record: true,
            mis: Some(kernels),
        };
        let mut out = Photons::default();
        assert!(trace_photons(
            &scene,
            &lights,
            None,
            None,
            &pass,
            &AtomicBool::new(false),
            &mut out
        ));
        let (mut checked, mut shares) = (0, Vec::new());
        for k in 1..out.volume.len() {
            let (a, b) = (&out.volume[k - 1], &out.volume[k]);
            let same_path = out.volume_path[k - 1] == out.volume_path[k];
            if !same_path || b.bounces != a.bounces + 1 {
                continue;
            }
            let (wi, dist) = ((b.p - a.p).normalize(), (b.p - a.p).length());
            if scene.intersect(a.p, wi, dist).is_some() {
                continue;
            }
            // The eye, from b back along the light's direction, to the next surface.
            let l = scene.intersect(b.p, -wi, f32::INFINITY).map_or(f32::INFINITY, |h| h.t);
            let (ra, rb) = (&out.volume_mis[k - 1], &out.volume_mis[k]);
            let sigma = ra.sigma;
            let s = collision_share(sigma, l);
            let eye = sigma * s;
            let p = scene.media[a.medium as usize].phase().pdf(a.d, wi);
            let c = kernels.at_light(Site::Medium(eye));
            let want = eye / p * (c + ra.light.sum(p)) / rb.sigma;
            assert!(
                (rb.light.u - want).abs() <= 2e-3 * want && rb.light.v == 0.0,
                "collisions {a:?} → {b:?}: u = {} where the eye's share {s} gives {want}",
                rb.light.u
            );
            checked += 1;
            shares.push(s);
        }
        assert!(checked >= 200, "only {checked} pairs of consecutive collisions");
        // The fog is thin enough that the share matters: some are far from 1.
        assert!(shares.iter().any(|&s| s < 0.5), "shares {shares:?}");
    }

    /// A pass's work items are cut per thread (a pilot's few thousand paths into 8 per thread),
    /// and the photons, their paths and the work counted are the same whatever the cut.
    #[test]
    fn a_pass_leaves_the_same_photons_on_any_thread_count() {
        let scene = Scene::load(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-fog.toml"))
            .expect("the bundled scene loads");
        let lights = LightSampler::new(&scene.lights, scene.shapes.len());
        let pass = PhotonPass {
            seed: 5,
            iteration: 2,
            first_path: 100,
            paths: 3000,
            max_bounces: 64,
            skip_direct: false,
            media_near: f32::INFINITY,
            record: true,
            mis: None,
        };
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let mut out = Photons::default();
                let stop = AtomicBool::new(false);
                assert!(trace_photons(&scene, &lights, None, None, &pass, &stop, &mut out));
                let o = &out;
                let all = (&o.surface, &o.volume, &o.surface_path, &o.volume_path, &o.paths);
                (chunk_len(pass.paths), format!("{all:?} {:?}", o.work))
            })
        };
        let (len, one) = on(1);
        assert!(one.len() > 10_000, "too few photons to compare: {one}");
        for threads in [3, 16] {
            let (cut, photons) = on(threads);
            assert!(cut < len, "{threads} threads cut items of {cut} paths, one thread {len}");
            assert!(photons == one, "{threads} threads left other photons than one thread");
        }
    }
}
