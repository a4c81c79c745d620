//! Surface materials: a closed set, sampled by the light and camera passes.
//!
//! ```toml
//! [materials.white]
//! type = "diffuse"          # Lambertian; albedo = RGB reflectance in [0, 1]
//! albedo = [0.73, 0.73, 0.73]
//!
//! [materials.chrome]
//! type = "mirror"           # perfect specular reflection
//! reflectance = 0.95        # optional, default 1
//!
//! [materials.glass]
//! type = "dielectric"       # smooth interface with Fresnel reflection and refraction
//! ior = 1.5                 # index inside the shape relative to outside
//!
//! [materials.boundary]
//! type = "interface"        # no scattering: marks a medium boundary
//! ```

use crate::math::{Frame, Rgb, fresnel_dielectric, reflect, refract, sample_cosine_hemisphere};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// A material.
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// Lambertian reflector: f = albedo / π.
    Diffuse {
        /// Reflectance, each channel in [0, 1].
        albedo: Rgb,
    },
    /// Perfect mirror.
    Mirror {
        /// Reflectance, each channel in [0, 1].
        reflectance: Rgb,
    },
    /// Smooth dielectric (glass, water).
    Dielectric {
        /// Index of refraction of the inside relative to the outside (> 0).
        ior: f32,
    },
    /// Index-matched boundary: rays pass straight through.
    Interface,
}

/// Most pass-through interfaces one path (or shadow ray) crosses. Crossings are not scattering
/// events and do not count towards `max_bounces`; this bound keeps stacked or coincident
/// interfaces from making a path's work unbounded.
pub const MAX_CROSSINGS: u32 = 256;

/// Which quantity a path carries; refraction scales radiance but not power (Veach 1997, §5.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transport {
    /// Eye paths.
    Radiance,
    /// Light paths (photons).
    Importance,
}

/// A sampled scattering direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// New direction (unit, pointing away from the surface).
    pub wi: Vec3,
    /// f · |cos| / pdf, including the shading-normal correction for light paths.
    pub weight: Rgb,
    /// Solid-angle density of `wi` ([`Material::pdf`]); zero for a delta (specular) direction.
    pub pdf: f32,
}

/// The geometric and shading normals turned to the side of `wo`.
#[inline]
fn facing(wo: Vec3, ng: Vec3, ns: Vec3) -> (Vec3, Vec3) {
    if wo.dot(ng) >= 0.0 { (ng, ns) } else { (-ng, -ns) }
}

impl Material {
    /// A Lambertian reflector of the given albedo (each channel in [0, 1]).
    pub fn diffuse(albedo: impl super::IntoRgb) -> Self {
        Material::Diffuse { albedo: albedo.into_rgb() }
    }

    /// A perfect mirror of the given reflectance.
    pub fn mirror(reflectance: impl super::IntoRgb) -> Self {
        Material::Mirror { reflectance: reflectance.into_rgb() }
    }

    /// Smooth glass (or water) whose inside has index `ior` relative to the outside.
    pub fn dielectric(ior: f32) -> Self {
        Material::Dielectric { ior }
    }

    /// True for materials on which photons are stored and radiance is estimated.
    pub fn is_diffuse(&self) -> bool {
        matches!(self, Material::Diffuse { .. })
    }

    /// True for materials that scatter only into delta directions (mirror, glass,
    /// pass-through), which [`Self::eval`] and [`Self::pdf`] cannot see.
    pub fn is_specular(&self) -> bool {
        !self.is_diffuse()
    }

    /// The BRDF value of a diffuse material (zero for specular ones).
    pub fn diffuse_f(&self) -> Rgb {
        match self {
            Material::Diffuse { albedo } => *albedo * FRAC_1_PI,
            _ => Rgb::ZERO,
        }
    }

    /// f(wo, wi) · |cos θ_i| for scattering from `wo` into `wi` (both unit, pointing away from
    /// the surface), with the geometric normal `ng` and shading normal `ns` as in [`Self::sample`];
    /// the cosine is taken with the shading normal. For light paths ([`Transport::Importance`])
    /// the adjoint BSDF with Veach's shading-normal correction (1997, eq. 5.17). Zero for delta
    /// materials and where `wi` lies below the surface on `wo`'s side.
    pub fn eval(&self, wo: Vec3, wi: Vec3, ng: Vec3, ns: Vec3, mode: Transport) -> Rgb {
        let Material::Diffuse { albedo } = self else { return Rgb::ZERO };
        let (ng, ns) = facing(wo, ng, ns);
        if wi.dot(ng) <= 0.0 {
            return Rgb::ZERO;
        }
        let f = *albedo * FRAC_1_PI;
        match mode {
            Transport::Radiance => f * wi.dot(ns).max(0.0),
            Transport::Importance => {
                f * (wo.dot(ns) * wi.dot(ng)).abs() / wo.dot(ng).abs().max(1e-6)
            }
        }
    }

    /// The solid-angle density with which [`Self::sample`] picks `wi` given `wo`; zero for delta
    /// materials and where `wi` lies below the surface on `wo`'s side.
    pub fn pdf(&self, wo: Vec3, wi: Vec3, ng: Vec3, ns: Vec3) -> f32 {
        if !self.is_diffuse() {
            return 0.0;
        }
        let (ng, ns) = facing(wo, ng, ns);
        if wi.dot(ng) <= 0.0 { 0.0 } else { wi.dot(ns).max(0.0) * FRAC_1_PI }
    }

    /// Samples a direction given the outgoing direction `wo` (unit, pointing away from the
    /// surface), the geometric normal `ng` (oriented outward, as the shape defines it) and the
    /// shading normal `ns` (same side as `ng`). `u` and `u_lobe` are uniform samples (diffuse
    /// surfaces use only `u`, glass only `u_lobe`). `None` means the path ends: the sampled
    /// direction lies below the surface, or — for light paths, whose shading-normal correction
    /// assumes it — `wo` lies below the shading hemisphere.
    pub fn sample(
        &self,
        wo: Vec3,
        ng: Vec3,
        ns: Vec3,
        u: Vec2,
        u_lobe: f32,
        mode: Transport,
    ) -> Option<BsdfSample> {
        match self {
            Material::Diffuse { albedo } => {
                // Work on the side of wo.
                let (ng, ns) = facing(wo, ng, ns);
                let wi = Frame::new(ns).to_world(sample_cosine_hemisphere(u));
                if wi.dot(ng) <= 0.0 || (mode == Transport::Importance && wo.dot(ns) <= 0.0) {
                    return None;
                }
                let weight = match mode {
                    Transport::Radiance => *albedo,
                    // Adjoint BSDF with shading normals (Veach 1997, eq. 5.17).
                    Transport::Importance => {
                        *albedo * (wo.dot(ns) * wi.dot(ng)).abs()
                            / (wo.dot(ng) * wi.dot(ns)).abs().max(1e-6)
                    }
                };
                let pdf = wi.dot(ns).max(0.0) * FRAC_1_PI;
                Some(BsdfSample { wi, weight, pdf })
            }
            Material::Mirror { reflectance } => {
                let n = if wo.dot(ng) >= 0.0 { ns } else { -ns };
                let wi = reflect(wo, n);
                if wi.dot(ng) * wo.dot(ng) <= 0.0 {
                    return None;
                }
                Some(BsdfSample { wi, weight: *reflectance, pdf: 0.0 })
            }
            Material::Dielectric { ior } => {
                let entering = wo.dot(ng) >= 0.0;
                let n = if entering { ns } else { -ns };
                let eta = if entering { 1.0 / ior } else { *ior };
                let cos_o = wo.dot(n);
                if cos_o <= 0.0 {
                    return None;
                }
                let f = fresnel_dielectric(cos_o, eta);
                if u_lobe < f {
                    return Some(BsdfSample { wi: reflect(wo, n), weight: Rgb::ONE, pdf: 0.0 });
                }
                let wi = refract(wo, n, eta)?;
                let scale = match mode {
                    Transport::Radiance => eta * eta,
                    Transport::Importance => 1.0,
                };
                Some(BsdfSample { wi, weight: Rgb::splat(scale), pdf: 0.0 })
            }
            Material::Interface => Some(BsdfSample { wi: -wo, weight: Rgb::ONE, pdf: 0.0 }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{ChiSquare, Domain, Sample, chi_square_p};

    /// The diffuse material's `sample` draws directions with the density `pdf` gives (failures
    /// are the directions below the surface), and every sample's weight is eval / pdf: with the
    /// shading normal equal to the geometric one or tilted, for eye and light paths, from either
    /// side (chi-square, 4 tests).
    #[test]
    fn diffuse_sample_matches_pdf_and_eval() {
        let m = Material::Diffuse { albedo: Rgb::new(0.2, 0.5, 0.8) };
        let tilted = Vec3::new(0.3, 0.1, 1.0).normalize();
        let cases = [
            (Vec3::new(0.3, -0.2, 0.9).normalize(), Vec3::Z, Transport::Radiance),
            (Vec3::new(0.3, -0.2, 0.9).normalize(), tilted, Transport::Radiance),
            (Vec3::new(-0.5, 0.1, 0.6).normalize(), tilted, Transport::Importance),
            (Vec3::new(0.1, 0.4, -0.7).normalize(), tilted, Transport::Radiance),
        ];
        for (k, (wo, ns, mode)) in cases.into_iter().enumerate() {
            let ng = Vec3::Z;
            let mut test = ChiSquare::new(format!("diffuse {mode:?}, case {k}"), Domain::Sphere, 4);
            test.seed = 30 + k as u64;
            test.run(
                |s| {
                    let bs = m.sample(wo, ng, ns, s.next_2d(), s.next_f32(), mode)?;
                    let (pdf, f) = (m.pdf(wo, bs.wi, ng, ns), m.eval(wo, bs.wi, ng, ns, mode));
                    assert!((bs.pdf - pdf).abs() <= 1e-5 * pdf);
                    let want = f / pdf;
                    assert!(
                        (bs.weight - want).abs().max_element() <= 1e-3 * want.max_element(),
                        "weight {} vs eval/pdf {want}",
                        bs.weight
                    );
                    Some(Sample::Direction(bs.wi))
                },
                |d| m.pdf(wo, d.direction(), ng, ns) as f64,
            );
        }
    }

    /// Delta materials: the mirror reflects with its reflectance, the interface passes straight
    /// through, and neither has a density or a non-delta value.
    #[test]
    fn mirror_and_interface_are_deltas() {
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let mirror = Material::Mirror { reflectance: Rgb::splat(0.9) };
        let bs = mirror.sample(wo, Vec3::Z, Vec3::Z, Vec2::ZERO, 0.0, Transport::Radiance).unwrap();
        assert!((bs.wi - Vec3::new(-0.6, 0.0, 0.8)).length() < 1e-6);
        assert_eq!((bs.weight, bs.pdf), (Rgb::splat(0.9), 0.0));
        assert_eq!(mirror.eval(wo, bs.wi, Vec3::Z, Vec3::Z, Transport::Radiance), Rgb::ZERO);
        assert_eq!(mirror.pdf(wo, bs.wi, Vec3::Z, Vec3::Z), 0.0);
        let bs = Material::Interface
            .sample(wo, Vec3::Z, Vec3::Z, Vec2::ZERO, 0.0, Transport::Importance)
            .unwrap();
        assert_eq!((bs.wi, bs.weight), (-wo, Rgb::ONE));
    }

    /// Glass chooses reflection with the Fresnel probability (chi-square on the two outcomes),
    /// refracts by Snell's law, and scales radiance (not importance) by η².
    #[test]
    fn dielectric_refracts_by_snell_and_splits_by_fresnel() {
        let glass = Material::Dielectric { ior: 1.5 };
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let f = fresnel_dielectric(0.8, 1.0 / 1.5) as f64;
        let mut s = crate::rng::Sampler::new(5, crate::rng::Purpose::Other, 0, 0);
        let mut counts = [0u64; 2];
        for _ in 0..100_000 {
            let bs = glass
                .sample(wo, Vec3::Z, Vec3::Z, s.next_2d(), s.next_f32(), Transport::Radiance)
                .unwrap();
            if bs.wi.z > 0.0 {
                counts[0] += 1;
                assert_eq!(bs.weight, Rgb::ONE);
            } else {
                counts[1] += 1;
                // sin θ_t = sin θ_i / η; radiance scaled by η² = (1/1.5)².
                assert!((bs.wi.x + 0.6 / 1.5).abs() < 1e-5, "{}", bs.wi);
                assert!((bs.weight.x - 1.0 / 2.25).abs() < 1e-5);
            }
        }
        let p = chi_square_p(&counts, &[f, 1.0 - f]);
        assert!(p > crate::testing::SIGNIFICANCE, "p = {p}");
    }

    #[test]
    fn dielectric_splits_by_fresnel_and_conserves_power() {
        let glass = Material::Dielectric { ior: 1.5 };
        let wo = Vec3::new(0.5, 0.0, 0.5f32.sqrt() * 1.2247).normalize();
        let n = 20_000;
        let mut reflected = 0;
        for i in 0..n {
            let u = (i as f32 + 0.5) / n as f32;
            let s =
                glass.sample(wo, Vec3::Z, Vec3::Z, Vec2::ZERO, u, Transport::Importance).unwrap();
            assert_eq!(s.weight, Rgb::ONE);
            if s.wi.z > 0.0 {
                reflected += 1;
            }
        }
        let f = fresnel_dielectric(wo.z, 1.0 / 1.5);
        assert!((reflected as f32 / n as f32 - f).abs() < 1e-3);
    }
}
