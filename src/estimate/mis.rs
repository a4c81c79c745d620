//! The weights of the combined estimator (`integrator/combined.rs`): multiple importance sampling
//! (balance heuristic) over every technique that can make a light path x₀ … x_k (x₀ on a light,
//! x_k the camera):
//!
//! - the eye path reaches the light (H): the eye samples x_{k−1} … x₀;
//! - next-event estimation (N) at x₁: the eye samples x_{k−1} … x₁, x₀ is sampled from x₁;
//! - merging at a scattering vertex x_j (1 ≤ j < k) with a photon of the light path x₀ … x_j:
//!   on a diffuse surface with the r² kernel (M_s), at a medium collision of the eye path with
//!   the r³ kernel (point–point, M_p), and along the eye segment that leads to x_j with the
//!   kernel disc around it (the beam radiance estimate, point–beam, M_b).
//!
//! With p→_i the density of x_i sampled from x_{i−1} (the light's direction) and p←_i from
//! x_{i+1} (the eye's), in area measure on surfaces and volume measure in media, the techniques'
//! densities are H = Π_{i<k} p←_i, N = p^N₀ Π_{0<i<k} p←_i, and for merges at x_j
//! K_j Π_{i≤j} p→_i Π_{j≤i<k} p←_i with K = N_L π r_s² (surfaces) or N_L 4/3 π r_v³ (points),
//! and N_L π r_v² Π_{i≤j} p→_i · b_j · Π_{j<i<k} p←_i for the beam, where b_j = p←_j / (σ_t(x_j)
//! T) is the eye's density of x_j without the free-flight distance it does not sample (N_L is
//! the number of light paths of the iteration, r_s and r_v the iteration's radii). Every weight
//! is a ratio of these sums, computed as in vertex connection and merging (Georgiev et al. 2012)
//! and UPBP (Křivánek et al. 2014) by one number carried along each subpath (a light path's
//! [`LightMis`], an eye path's carry): O(1) work per vertex. docs/theory.md derives them.
//!
//! The densities entering the weights are functions of the path alone, the same whichever
//! technique evaluates them, so the weights of a path sum to one and the combination is
//! unbiased whatever they are; they are the exact densities except that (i) transmittance
//! along a segment, which the sampling of its two ends shares, is left out where a technique
//! does not sample a distance (next-event estimation, the beam), and (ii) the medium's
//! extinction is the mean over the colour channels (the hero channel of spectral tracking does
//! not enter the weights). Russian roulette and photon thinning are not in them either.

/// A carried quantity is kept below this, so that sums stay finite on long paths.
const CARRY_MAX: f32 = 1e30;

/// The kernels' acceptance of each merging technique in iteration i, N_L · (area or volume)
/// (balance heuristic: the densities enter the weights as they are).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Kernels {
    /// N_L π r_s².
    pub surface: f32,
    /// N_L 4/3 π r_v³.
    pub point: f32,
    /// N_L π r_v².
    pub beam: f32,
    /// Merges at every eye vertex (UPBP's set), or only at an eye path's first vertex that is
    /// not specular (and along its segments up to there).
    pub deep: bool,
}

impl Kernels {
    /// The constants for `paths` light paths at the surface and volume radii `rs` and `rv`.
    pub(crate) fn new(paths: u64, rs: f64, rv: f64, deep: bool) -> Self {
        let n = paths as f64;
        let pi = std::f64::consts::PI;
        Self {
            surface: (n * pi * rs * rs) as f32,
            point: (n * 4.0 / 3.0 * pi * rv * rv * rv) as f32,
            beam: (n * pi * rv * rv) as f32,
            deep,
        }
    }

    /// The merges at a vertex of a light path, as the eye paths that could merge there see
    /// them: [`Self::at`] with merges at every eye vertex; none with merges at the first only
    /// (every light vertex before the one an eye path merges at lies deeper in that eye path).
    #[inline]
    pub(crate) fn at_light(&self, site: Site) -> f32 {
        if self.deep { self.at(site) } else { 0.0 }
    }

    /// The point and the beam technique at a medium vertex of mean extinction `sigma`, relative
    /// to the eye's density of the vertex: (K_p, K_b / σ).
    #[inline]
    pub(crate) fn medium(&self, sigma: f32) -> (f32, f32) {
        (self.point, self.beam / sigma.max(f32::MIN_POSITIVE))
    }

    /// The merging techniques at a vertex, summed: c = K_s on a diffuse surface, K_p + K_b / σ
    /// in a medium, 0 at a specular vertex.
    #[inline]
    pub(crate) fn at(&self, site: Site) -> f32 {
        match site {
            Site::Surface => self.surface,
            Site::Medium(sigma) => {
                let (p, b) = self.medium(sigma);
                p + b
            }
            Site::Specular => 0.0,
        }
    }
}

/// The eye's density of a collision in a homogeneous medium over free flight's: 1 − e^{−σ l}, on
/// an eye segment of length `l` to the next surface in a medium of mean extinction `sigma` (the
/// combined integrator's eye path collides there with probability (1 − T)², T = e^{−σ l}, at a
/// distance drawn ∝ T: density (1 − T) σ T(t) against free flight's σ T(t)). The light path
/// computes the same factor for its vertex from the eye's segment through it: the piece it
/// travels to its next vertex or surface and the distance back to the surface behind it.
#[inline]
pub(crate) fn collision_share(sigma: f32, l: f32) -> f32 {
    // 0 where nothing collides: no extinction, even over an infinite segment (0 · ∞ is NaN).
    let x = sigma * l;
    if x > 0.0 { -(-x).exp_m1() } else { 0.0 }
}

/// The optical depth σ l past which [`collision_share`] is exactly 1 in `f32` (e^{−18} is below
/// half of `f32`'s spacing under 1): a light path looks for the surface behind a collision no
/// farther than this over σ, and a segment that long or longer gives the same share.
pub(crate) const SHARE_SATURATES: f32 = 18.0;

/// The eye's density of crossing such a segment without a collision over free flight's:
/// (1 − P) / T = 2 − T, with P = (1 − T)² ([`collision_share`]). A vertex the eye reaches past
/// such crossings has its density times their product (a collision's also times its share);
/// grids (free flight) and vacuum cross with 1.
#[inline]
pub(crate) fn crossing_share(sigma: f32, l: f32) -> f32 {
    1.0 + collision_share(sigma, l)
}

/// What a vertex is, for the techniques that can merge there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Site {
    /// A diffuse surface.
    Surface,
    /// A medium collision, with the eye's density factor of it there: the medium's mean
    /// extinction σ, times [`collision_share`] in a homogeneous medium.
    Medium(f32),
    /// A mirror or glass: nothing merges or connects there.
    Specular,
}

/// A light path's weight record at its vertex x_j: the techniques on the light's side of x_j
/// (merges at x₁ … x_{j−1}, next-event estimation, the eye reaching the light), relative to
/// merging at x_j, are `u` · p_E + `v`, where p_E is the solid-angle density with which the eye,
/// arriving at x_j, would sample the direction the light came from (known only when an eye path
/// merges there).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct LightMis {
    pub u: f32,
    pub v: f32,
}

/// How a light path left the light, for the weights at its first vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Emitted {
    /// p→₀ times the direction's density: P(light) · p(origin) · p(direction) (a delta's
    /// density is 1).
    pub emit: f32,
    /// |cos| between the light's normal and the direction: an area light, which an eye path
    /// can reach (0 for the others).
    pub cos: f32,
}

impl LightMis {
    /// At the first vertex x₁, reached with `gamma` (the cosine there against the direction
    /// from the light, or σ in a medium): `nee` is next-event estimation's density of x₀ from
    /// x₁ times the squared distance, P(light | x₁) · p(origin) · |x₁ − x₀|² (a directional
    /// light: P(light | x₁) · p(origin) · area of its emitting rectangle), 0 where it cannot
    /// connect (a specular x₁).
    #[inline]
    pub(crate) fn first(e: Emitted, nee: f32, gamma: f32) -> Self {
        let d = e.emit * gamma;
        Self { u: clamp(e.cos / d), v: clamp(nee / d) }
    }

    /// At the next vertex, reached with `gamma`, from the carry of the vertex before
    /// ([`Self::carry`]).
    #[inline]
    pub(crate) fn arrive(carry: f32, gamma: f32) -> Self {
        Self { u: clamp(carry / gamma), v: 0.0 }
    }

    /// The light's side, relative to merging here, given the eye's density `p_eye` of the
    /// direction the light came from.
    #[inline]
    pub(crate) fn sum(self, p_eye: f32) -> f32 {
        self.u * p_eye + self.v
    }

    /// What the light path carries to its next vertex after scattering here: `c` the merging
    /// techniques here ([`Kernels::at`]), `p_rev` the eye's density of the direction the light
    /// came from given the one it leaves by, `gamma_out` the cosine (or σ) of the latter and
    /// `p_out` its density.
    #[inline]
    pub(crate) fn carry(self, c: f32, p_rev: f32, gamma_out: f32, p_out: f32) -> f32 {
        clamp(gamma_out / p_out * (c + self.sum(p_rev)))
    }
}

/// What an eye path carries after scattering at a vertex: `prev` the carry it arrived with (0
/// from the camera), `c` the merging techniques here, `p_rev` the light's density of the
/// direction the eye came from given the one it leaves by, `gamma_in` and `gamma_out` the
/// cosines (or σ) of the arriving and leaving directions, `p_out` the density of the latter.
/// The eye's side of a later vertex, relative to merging there, is built from it.
#[inline]
pub(crate) fn eye_carry(
    prev: f32,
    c: f32,
    p_rev: f32,
    gamma_in: f32,
    gamma_out: f32,
    p_out: f32,
) -> f32 {
    clamp(gamma_out / p_out * (c + p_rev * prev / gamma_in))
}

/// The sum over every technique of a path merged at x_j, relative to Λ_j (the light's density of
/// x₀ … x_j over the eye's of x₀ … x_{j−1}): the light's side `light.sum(p_eye)`, the merges at
/// x_j, `c`, and the eye's side from its carry `carry` (after the vertex before x_j), the
/// light's density `p_light` of the eye's arriving direction given the light's, and the eye's
/// cosine (or σ) `gamma_in` at x_j. A merging technique's weight is its constant over this sum.
#[inline]
pub(crate) fn merge_total(
    light: LightMis,
    p_eye: f32,
    c: f32,
    carry: f32,
    p_light: f32,
    gamma_in: f32,
) -> f32 {
    light.sum(p_eye) + c + p_light * carry / gamma_in
}

/// A technique's weight from its own density and the sum of all, relative to the same thing;
/// zero where the sum is not finite (a density that overflowed dwarfs this one).
#[inline]
pub(crate) fn weight(own: f32, total: f32) -> f32 {
    let w = own / total;
    if w.is_finite() { w.clamp(0.0, 1.0) } else { 0.0 }
}

/// The weight of next-event estimation from x₁ to x₀: `hit` the eye's density of the direction
/// to x₀ over next-event estimation's solid-angle density of it (0 if the eye cannot reach the
/// light: a point, spot or directional light); `e` and `nee` as in [`LightMis::first`]; `c` the
/// merges at x₁; `gamma_light` the cosine (or σ) at x₁ towards x₀; `p_light` the light's
/// density at x₁ of the direction to the eye given the one from x₀; `carry`, `gamma_in` the
/// eye's arriving carry and cosine.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn nee_weight(
    hit: f32,
    e: Emitted,
    nee: f32,
    c: f32,
    gamma_light: f32,
    p_light: f32,
    carry: f32,
    gamma_in: f32,
) -> f32 {
    let merges = e.emit * gamma_light * (c + p_light * carry / gamma_in) / nee;
    weight(1.0, 1.0 + hit + merges)
}

/// The weight of an eye path that reached an area light: `nee` next-event estimation's
/// solid-angle density from the vertex before over the eye's (0 if that vertex is specular or
/// the camera), `e` the light's emission from x₀ towards it, `carry` the eye's carry after that
/// vertex.
#[inline]
pub(crate) fn hit_weight(nee: f32, e: Emitted, carry: f32) -> f32 {
    if carry == 0.0 && nee == 0.0 {
        return 1.0;
    }
    weight(1.0, 1.0 + nee + e.emit * carry / e.cos)
}

#[inline]
fn clamp(x: f32) -> f32 {
    if x.is_nan() { 0.0 } else { x.min(CARRY_MAX) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, Sampler};

    /// A light path's search for the surface behind a collision stops at SHARE_SATURATES / σ:
    /// every segment at least that deep gives a share of exactly 1 (whatever σ), as an unbounded
    /// search would, and a shallower one (optical depth 16) does not.
    #[test]
    fn the_collision_share_saturates_where_the_search_stops() {
        for sigma in [1e-3_f32, 0.37, 1.0, 60.0, 4.1e3] {
            let reach = SHARE_SATURATES / sigma;
            for l in [reach, reach * 1.0001, reach * 3.0, f32::INFINITY] {
                assert_eq!(collision_share(sigma, l), 1.0, "σ {sigma}, l {l}");
            }
            assert!(collision_share(sigma, 16.0 / sigma) < 1.0, "σ {sigma}");
        }
    }

    /// A vertex of a random abstract path: its site, the cosines (or σ) towards its two
    /// neighbours, and the densities with which a light path (arriving from x_{i−1}) and an eye
    /// path (arriving from x_{i+1}) leave it towards the other.
    #[derive(Clone, Copy, Debug)]
    struct V {
        site: Site,
        /// Cosine (or σ) towards x_{i−1} and towards x_{i+1}.
        g_prev: f32,
        g_next: f32,
        /// The light's density of the direction to x_{i+1}, the eye's to x_{i−1}.
        p_light: f32,
        p_eye: f32,
    }

    /// A path x₀ … x_k: the light's emission, next-event estimation's density of x₀ from x₁
    /// (times the squared distance), the squared distances of the segments, the vertices
    /// x₁ … x_{k−1}.
    struct Path {
        e: Emitted,
        nee: f32,
        d2: Vec<f64>,
        v: Vec<V>,
    }

    fn random_path(s: &mut Sampler, k: usize) -> Path {
        let mut v = Vec::new();
        for _ in 1..k {
            let r = s.next_f32();
            // A collision: the light's density factor is σ (free flight), the eye's σ times
            // its collision share (1 in a grid, 1 − e^{−σ l} in a homogeneous medium), which is
            // the site's, and every vertex's the product of the crossings the eye made on its
            // way there, in [1, 2] each (which the site leaves out: the beam samples them).
            let (sigma, share) = (0.1 + 10.0 * s.next_f32(), (0.02 + s.next_f32()).min(1.0));
            let crossed = 1.0 + 3.0 * s.next_f32();
            let site = if r < 0.4 {
                Site::Surface
            } else if r < 0.8 {
                Site::Medium(sigma * share)
            } else {
                Site::Specular
            };
            let (g_prev, g_next) = match site {
                Site::Medium(eye) => (sigma, eye * crossed),
                _ => (0.05 + s.next_f32(), (0.05 + s.next_f32()) * crossed),
            };
            let (p_light, p_eye) = match site {
                // A delta's density is 1, both ways.
                Site::Specular => (1.0, 1.0),
                _ => (0.05 + 3.0 * s.next_f32(), 0.05 + 3.0 * s.next_f32()),
            };
            v.push(V { site, g_prev, g_next, p_light, p_eye });
        }
        let area = s.next_f32() < 0.7;
        let e =
            Emitted { emit: 0.1 + s.next_f32(), cos: if area { 0.1 + s.next_f32() } else { 0.0 } };
        let nee = 0.1 + s.next_f32();
        let d2 = (0..k).map(|_| 0.1 + 4.0 * s.next_f32() as f64).collect();
        Path { e, nee, d2, v }
    }

    /// Every technique's density for the path, by definition: (technique, density), the
    /// kernels in `k`. x_i for i ≥ 1 is `v[i − 1]`; segment i joins x_i and x_{i+1}; x_k is the
    /// camera, whose first segment the eye samples with density 1 (common to every technique).
    fn densities(p: &Path, k: &Kernels) -> Vec<(&'static str, usize, f64)> {
        let n = p.v.len() + 1; // x_n is the camera
        let vx = |i: usize| p.v[i - 1];
        // p→_i: from x_{i−1} (x₀: the light's emission, with the direction's density).
        let fwd = |i: usize| -> f64 {
            if i == 1 {
                return p.e.emit as f64 * vx(1).g_prev as f64 / p.d2[0];
            }
            vx(i - 1).p_light as f64 * vx(i).g_prev as f64 / p.d2[i - 1]
        };
        let p0 = 1.0; // the emission's origin density is in `emit`
        // p←_i: from x_{i+1}; x_{n−1} from the camera (1).
        let rev = |i: usize| -> f64 {
            if i == n - 1 {
                return 1.0;
            }
            let g = if i == 0 { p.e.cos as f64 } else { vx(i).g_next as f64 };
            vx(i + 1).p_eye as f64 * g / p.d2[i]
        };
        let mut out = Vec::new();
        let eye_from = |j: usize| (j..n).map(rev).product::<f64>();
        let light_to = |j: usize| p0 * (1..=j).map(fwd).product::<f64>();
        if p.e.cos > 0.0 {
            out.push(("hit", 0, eye_from(0)));
        }
        if n > 1 && vx(1).site != Site::Specular {
            // p^N₀ = nee / d², area measure.
            out.push(("nee", 0, p.nee as f64 / p.d2[0] * eye_from(1)));
        }
        for j in (1..n).filter(|&j| merges_at(p, k, j)) {
            let both = light_to(j) * eye_from(j);
            match vx(j).site {
                Site::Surface => out.push(("surface", j, k.surface as f64 * both)),
                Site::Medium(sigma) => {
                    out.push(("point", j, k.point as f64 * both));
                    out.push(("beam", j, k.beam as f64 * both / sigma as f64));
                }
                Site::Specular => {}
            }
        }
        out
    }

    /// Whether the eye path merges at x_j: everywhere, or at its first vertex from the camera
    /// that is not specular only.
    fn merges_at(p: &Path, k: &Kernels, j: usize) -> bool {
        let first = (1..=p.v.len()).rev().find(|&i| p.v[i - 1].site != Site::Specular);
        k.deep || first == Some(j)
    }

    /// The weights of the same techniques by the carried quantities, as the renderer computes
    /// them: the eye's carry from the camera, the light's records from x₀.
    fn recursive(p: &Path, k: &Kernels) -> Vec<(&'static str, usize, f64)> {
        let n = p.v.len() + 1;
        let vx = |i: usize| p.v[i - 1];
        // The light's records at x₁ … x_{n−1}.
        let mut light = vec![LightMis::default(); n];
        let nee_ok = |i: usize| vx(i).site != Site::Specular;
        for i in 1..n {
            light[i] = if i == 1 {
                LightMis::first(p.e, if nee_ok(1) { p.nee } else { 0.0 }, vx(1).g_prev)
            } else {
                let a = vx(i - 1);
                let c = k.at_light(a.site);
                LightMis::arrive(light[i - 1].carry(c, a.p_eye, a.g_next, a.p_light), vx(i).g_prev)
            };
        }
        // The eye's carry arriving at x_i: carry[i] (from the camera: 0 at x_{n−1}).
        // The merges at x_i as the eye path sees them.
        let c_at = |i: usize| if merges_at(p, k, i) { k.at(vx(i).site) } else { 0.0 };
        let mut carry = vec![0.0f32; n + 1];
        for i in (1..n - 1).rev() {
            let b = vx(i + 1);
            carry[i] = eye_carry(carry[i + 1], c_at(i + 1), b.p_light, b.g_next, b.g_prev, b.p_eye);
        }
        let mut out = Vec::new();
        if p.e.cos > 0.0 {
            // The eye reached x₀ from x₁ (its carry after x₁).
            let a = vx(1);
            let after = eye_carry(carry[1], c_at(1), a.p_light, a.g_next, a.g_prev, a.p_eye);
            let nee = if nee_ok(1) { p.nee / (p.e.cos * a.p_eye) } else { 0.0 };
            out.push(("hit", 0, hit_weight(nee, p.e, after) as f64));
        }
        if nee_ok(1) {
            let a = vx(1);
            let hit = if p.e.cos > 0.0 { a.p_eye * p.e.cos / p.nee } else { 0.0 };
            let c = c_at(1);
            let w = nee_weight(hit, p.e, p.nee, c, a.g_prev, a.p_light, carry[1], a.g_next);
            out.push(("nee", 0, w as f64));
        }
        for j in (1..n).filter(|&j| merges_at(p, k, j)) {
            let a = vx(j);
            let c = k.at(a.site);
            let total = merge_total(light[j], a.p_eye, c, carry[j], a.p_light, a.g_next);
            match a.site {
                Site::Surface => out.push(("surface", j, weight(k.surface, total) as f64)),
                Site::Medium(sigma) => {
                    let (kp, kb) = k.medium(sigma);
                    out.push(("point", j, weight(kp, total) as f64));
                    out.push(("beam", j, weight(kb, total) as f64));
                }
                Site::Specular => {}
            }
        }
        out
    }

    /// The eye's shares at the ends of their range: nothing collides without extinction (even
    /// over an infinite segment), everything with it over an infinite one.
    #[test]
    fn shares_at_the_ends_of_their_range() {
        assert_eq!(collision_share(0.0, f32::INFINITY), 0.0);
        assert_eq!(crossing_share(0.0, f32::INFINITY), 1.0);
        assert_eq!(collision_share(0.5, f32::INFINITY), 1.0);
        assert_eq!(crossing_share(0.5, 0.0), 1.0);
        let s = collision_share(0.5, 2.0);
        assert!((s - (1.0 - (-1.0f32).exp())).abs() < 1e-6, "{s}");
    }

    /// For random paths of every length, kind of vertex and light, and both sets of merges (at
    /// every eye vertex, or at the first that is not specular), the weights the carried
    /// quantities give each technique equal its density over the sum of all techniques'
    /// densities (computed by definition), and so sum to one; also without point merges. A wrong density in any technique
    /// (a missing cosine, a reversed direction, a beam without its 1/σ) changes its weight and
    /// fails the comparison.
    #[test]
    fn weights_are_each_techniques_share_of_the_densities() {
        let mut s = Sampler::new(7, Purpose::Other, 0, 0);
        for trial in 0..2000 {
            let k = 2 + trial % 7;
            let p = random_path(&mut s, k);
            let (surface, point) = (0.02 + s.next_f32(), 0.01 + s.next_f32());
            let kernels = Kernels {
                surface,
                // One trial in three without point merges (`point_merges`): their density 0.
                point: if trial % 3 == 2 { 0.0 } else { point },
                beam: 0.05 + s.next_f32(),
                // Both technique sets: merges everywhere (UPBP's) and at the first vertex.
                deep: trial % 2 == 0,
            };
            let exact = densities(&p, &kernels);
            let total: f64 = exact.iter().map(|t| t.2).sum();
            let got = recursive(&p, &kernels);
            assert_eq!(exact.len(), got.len());
            let mut sum = 0.0;
            for (e, g) in exact.iter().zip(&got) {
                assert_eq!((e.0, e.1), (g.0, g.1));
                let want = e.2 / total;
                assert!(
                    (g.2 - want).abs() <= 1e-4 * want.max(1e-3),
                    "trial {trial}: {} at x{}: weight {} by the carried quantities, {} by the densities",
                    e.0,
                    e.1,
                    g.2,
                    want
                );
                sum += g.2;
            }
            // A path of specular vertices from a point light: no technique makes it.
            if !exact.is_empty() {
                assert!((sum - 1.0).abs() < 1e-4, "trial {trial}: the weights sum to {sum}");
            }
        }
    }
}
