//! A physical daylight sky and its sun, after Preetham, Shirley and Smits, "A Practical Analytic
//! Model for Daylight" (SIGGRAPH 1999).
//!
//! **The sky dome.** The model gives the luminance Y and the CIE chromaticities x, y of the clear
//! sky in the direction at zenith angle θ, at angle γ from the sun, as the zenith's values times
//! a ratio of Perez et al.'s all-weather function,
//!
//!   F(θ, γ) = (1 + A e^{B / cos θ}) (1 + C e^{D γ} + E cos² γ),   Y(θ, γ) = Y_z F(θ, γ) / F(0, θ_s),
//!
//! whose five coefficients per quantity are linear in the turbidity T (the paper's table 2), with
//! the zenith luminance Y_z = (4.0453 T − 4.9710) tan χ − 0.2155 T + 2.4192 kcd/m²,
//! χ = (4/9 − T/120)(π − 2θ_s), and the zenith chromaticities cubic in θ_s and quadratic in T
//! (its appendix). Luminance in kcd/m² becomes haze's radiance through 1000/683 (lm/W at
//! 555 nm): a photometric watt, the unit in which the sun below is measured too, so the two agree.
//! The model is fitted for turbidity 2 to 10 and the sun above the horizon; haze accepts
//! turbidity 1.7 to 10 and elevations 0° to 90°.
//!
//! **The ground.** Below the horizon the Perez function is not defined (1 / cos θ); there the
//! environment is the ground: a Lambertian plane of albedo `ground_albedo` lit by the sky and the
//! sun, radiance ρ E / π with E the horizontal irradiance of the sky dome (integrated over the
//! rendered map) plus the sun's E_sun sin(elevation).
//!
//! **The sun** is a directional light (the solar disc's 0.53° is left as a point in direction)
//! whose irradiance is the extraterrestrial solar spectrum — a 5778 K blackbody scaled to the solar
//! constant, 1361 W/m² — attenuated along the air mass m of its elevation (Kasten and Young's
//! formula) by Rayleigh scattering, τ_R = exp(−0.008735 λ^−4.08 m), and by aerosols after
//! Ångström, τ_a = exp(−β λ^−1.3 m) with β = 0.04608 T − 0.04586 (λ in µm; the paper's appendix).
//! The paper's ozone, water-vapour and mixed-gas absorption bands are left out (they take tables
//! of absorption coefficients): the sun comes out a few per cent too bright and slightly too
//! blue in those bands. Its colour is the spectrum's CIE XYZ converted to linear sRGB, in the same
//! photometric units as the sky.
//!
//! Preetham's model is known to be too dark towards the horizon at low sun and too saturated at
//! high turbidity; Hosek and Wilkie's 2012 model fixes that with fitted data tables, which haze
//! does not carry (docs/scene-format.md says so).

use crate::math::Rgb;
use crate::medium::blackbody::{cie_xyz, planck, xyz_to_srgb};
use glam::Vec3;
use std::f64::consts::PI;

/// What describes a sky: the direction towards the sun, the turbidity, the ground's albedo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyParams {
    /// Unit direction towards the sun (y up).
    pub sun: Vec3,
    /// Atmospheric turbidity (1.7 … 10): 2 very clear, 3 clear, 6 hazy, 10 thin fog.
    pub turbidity: f32,
    /// Albedo of the ground below the horizon (0 … 1).
    pub ground_albedo: Rgb,
}

/// Turbidities the model accepts.
pub const TURBIDITY: (f32, f32) = (1.7, 10.0);

/// Widths of a sky's map, in texels (its height is half).
pub const WIDTHS: std::ops::RangeInclusive<u32> = 16..=8192;

/// Refuses a sun elevation outside [0, 90] degrees (beyond 90 the direction would wrap over to
/// the opposite azimuth): the message, for the caller to prefix with its key or flag.
pub fn check_elevation(elevation: f32) -> Result<(), String> {
    if (0.0..=90.0).contains(&elevation) {
        return Ok(());
    }
    Err(format!("must lie in [0, 90] degrees (the sun above the horizon), got {elevation}"))
}

/// The unit direction towards a sun `elevation` degrees above the horizon and `azimuth` degrees
/// from +z towards +x.
pub fn sun_towards(elevation: f32, azimuth: f32) -> Vec3 {
    let (e, a) = (elevation.to_radians(), azimuth.to_radians());
    Vec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos())
}

impl SkyParams {
    /// The model's limits, checked: the sun a finite direction at or above the horizon, the
    /// turbidity in [`TURBIDITY`], the ground's albedo in [0, 1]. The error names the field
    /// (`sun_direction`, `turbidity`, `ground_albedo`) and says what is wrong.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let sun = self.sun;
        if !(sun.is_finite() && sun.length_squared() > 0.0 && sun.y >= 0.0) {
            let m = format!(
                "the sun must be at or above the horizon (elevation 0 to 90 degrees), got {sun}"
            );
            return Err(("sun_direction", m));
        }
        let (lo, hi) = TURBIDITY;
        if !(self.turbidity >= lo && self.turbidity <= hi) {
            let m = format!("must lie in [{lo}, {hi}] (the model's range), got {}", self.turbidity);
            return Err(("turbidity", m));
        }
        let a = self.ground_albedo;
        if !(a.is_finite() && a.min_element() >= 0.0 && a.max_element() <= 1.0) {
            return Err(("ground_albedo", format!("must lie in [0, 1], got {a}")));
        }
        Ok(())
    }
}

/// Perez coefficients A … E for one quantity at turbidity `t`.
fn perez(t: f64, rows: [[f64; 2]; 5]) -> [f64; 5] {
    rows.map(|[a, b]| a * t + b)
}

/// The paper's table 2: (slope, intercept) in T of A … E for Y, x and y.
const PEREZ_Y: [[f64; 2]; 5] =
    [[0.1787, -1.4630], [-0.3554, 0.4275], [-0.0227, 5.3251], [0.1206, -2.5771], [-0.0670, 0.3703]];
const PEREZ_X: [[f64; 2]; 5] = [
    [-0.0193, -0.2592],
    [-0.0665, 0.0008],
    [-0.0004, 0.2125],
    [-0.0641, -0.8989],
    [-0.0033, 0.0452],
];
const PEREZ_Y_CHROMA: [[f64; 2]; 5] = [
    [-0.0167, -0.2608],
    [-0.0950, 0.0092],
    [-0.0079, 0.2102],
    [-0.0441, -1.6537],
    [-0.0109, 0.0529],
];

/// The zenith chromaticities' matrices: x_z = [T² T 1] M [θ³ θ² θ 1]ᵀ.
const ZENITH_X: [[f64; 4]; 3] = [
    [0.00166, -0.00375, 0.00209, 0.0],
    [-0.02903, 0.06377, -0.03202, 0.00394],
    [0.11693, -0.21196, 0.06052, 0.25886],
];
const ZENITH_Y: [[f64; 4]; 3] = [
    [0.00275, -0.00610, 0.00317, 0.0],
    [-0.04214, 0.08970, -0.04153, 0.00516],
    [0.15346, -0.26756, 0.06670, 0.26688],
];

fn zenith_chroma(m: &[[f64; 4]; 3], t: f64, theta_s: f64) -> f64 {
    let tt = [t * t, t, 1.0];
    let th = [theta_s.powi(3), theta_s.powi(2), theta_s, 1.0];
    (0..3).map(|i| tt[i] * (0..4).map(|j| m[i][j] * th[j]).sum::<f64>()).sum()
}

/// The Perez function at zenith angle `theta` (cos given) and sun angle `gamma`.
fn f(c: &[f64; 5], cos_theta: f64, gamma: f64) -> f64 {
    let [a, b, cc, d, e] = *c;
    (1.0 + a * (b / cos_theta.max(1e-3)).exp())
        * (1.0 + cc * (d * gamma).exp() + e * gamma.cos().powi(2))
}

/// The sky dome of one set of parameters, ready to evaluate.
pub(crate) struct Dome {
    sun: Vec3,
    coeffs: [[f64; 5]; 3],
    /// Zenith Y (kcd/m²), x, y over F(0, θ_s).
    zenith: [f64; 3],
}

impl Dome {
    pub(crate) fn new(p: &SkyParams) -> Self {
        let t = p.turbidity.clamp(TURBIDITY.0, TURBIDITY.1) as f64;
        let sun = p.sun.normalize();
        let theta_s = (sun.y as f64).clamp(0.0, 1.0).acos();
        let chi = (4.0 / 9.0 - t / 120.0) * (PI - 2.0 * theta_s);
        let y_z = (4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192;
        let x_z = zenith_chroma(&ZENITH_X, t, theta_s);
        let yc_z = zenith_chroma(&ZENITH_Y, t, theta_s);
        let coeffs = [perez(t, PEREZ_Y), perez(t, PEREZ_X), perez(t, PEREZ_Y_CHROMA)];
        let zenith = [y_z, x_z, yc_z];
        let zenith = std::array::from_fn(|k| zenith[k] / f(&coeffs[k], 1.0, theta_s));
        Self { sun, coeffs, zenith }
    }

    /// Radiance (linear sRGB, photometric W/(m²·sr)) of the sky towards `w` (y ≥ 0).
    pub(crate) fn radiance(&self, w: Vec3) -> Rgb {
        let cos_t = (w.y as f64).max(0.0);
        let gamma = (w.dot(self.sun) as f64).clamp(-1.0, 1.0).acos();
        let [lum, x, y] =
            std::array::from_fn(|k| self.zenith[k] * f(&self.coeffs[k], cos_t, gamma));
        let lum = lum.max(0.0) * 1000.0 / 683.0;
        if y <= 0.0 {
            return Rgb::ZERO;
        }
        let xyz = [x * lum / y, lum, (1.0 - x - y) * lum / y];
        let [r, g, b] = xyz_to_srgb(xyz);
        Rgb::new(r.max(0.0) as f32, g.max(0.0) as f32, b.max(0.0) as f32)
    }
}

/// The sun's irradiance on a plane facing it (linear sRGB, photometric W/m²) at turbidity `t`
/// and zenith angle `theta_s` (module docs).
pub(crate) fn sun_irradiance(t: f32, theta_s: f64) -> Rgb {
    let t = t.clamp(TURBIDITY.0, TURBIDITY.1) as f64;
    let elevation_deg = 90.0 - theta_s.to_degrees();
    let m = 1.0 / (theta_s.cos() + 0.15 * (93.885 - theta_s.to_degrees()).powf(-1.253));
    let beta = 0.04608 * t - 0.04586;
    // The solar disc's solid angle times a 5778 K blackbody is the extraterrestrial spectrum
    // (per metre of wavelength); its integral, σ T⁴ (R/AU)², is the solar constant 1361 W/m².
    let disc = (6.957e8f64 / 1.496e11).powi(2) * PI;
    let mut xyz = [0.0f64; 3];
    let step = 1.0; // nm
    let mut lambda = 360.0f64;
    while lambda <= 830.0 {
        let um = lambda * 1e-3;
        let tau = (-0.008735 * um.powf(-4.08) * m).exp() * (-beta * um.powf(-1.3) * m).exp();
        let e = planck(lambda * 1e-9, 5778.0) * disc * tau * 1e-9 * step;
        let c = cie_xyz(lambda);
        for k in 0..3 {
            xyz[k] += e * c[k];
        }
        lambda += step;
    }
    if elevation_deg < 0.0 {
        return Rgb::ZERO;
    }
    let [r, g, b] = xyz_to_srgb(xyz);
    Rgb::new(r.max(0.0) as f32, g.max(0.0) as f32, b.max(0.0) as f32)
}

/// The sky rendered to a latitude–longitude map of `width` × `width / 2` texels (the
/// environment's convention, `environment.rs`), the ground below the horizon included, each texel
/// the mean of 2 × 2 points; and the sun's irradiance.
pub(crate) fn render(p: &SkyParams, width: u32) -> (Vec<[f32; 3]>, u32, u32, Rgb) {
    let (w, h) = (width, width / 2);
    let dome = Dome::new(p);
    let theta_s = (p.sun.normalize().y as f64).clamp(0.0, 1.0).acos();
    let sun = sun_irradiance(p.turbidity, theta_s);
    let mut texels = vec![[0.0f32; 3]; (w * h) as usize];
    let mut horizontal = glam::DVec3::ZERO;
    for y in 0..h / 2 {
        let (v0, v1) = (y as f64 / h as f64, (y + 1) as f64 / h as f64);
        let solid = 2.0 * PI / w as f64 * ((PI * v0).cos() - (PI * v1).cos());
        for x in 0..w {
            let mut l = Rgb::ZERO;
            for k in 0..4 {
                let u = (x as f32 + 0.25 + 0.5 * (k % 2) as f32) / w as f32;
                let v = (y as f32 + 0.25 + 0.5 * (k / 2) as f32) / h as f32;
                l += dome.radiance(crate::math::latlong_direction(glam::Vec2::new(u, v))) * 0.25;
            }
            texels[(y * w + x) as usize] = l.to_array();
            let cos_c = (PI * (y as f64 + 0.5) / h as f64).cos();
            horizontal += l.as_dvec3() * solid * cos_c;
        }
    }
    let e = horizontal.as_vec3() + sun * p.sun.normalize().y.max(0.0);
    let ground = (p.ground_albedo * e / std::f32::consts::PI).to_array();
    for t in &mut texels[(w * (h / 2)) as usize..] {
        *t = ground;
    }
    (texels, w, h, sun)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sun_at(elevation_deg: f32) -> Vec3 {
        let e = elevation_deg.to_radians();
        Vec3::new(0.0, e.sin(), e.cos())
    }

    /// The model's published behaviour: the zenith luminance at a high sun and clear sky lies in
    /// the few-kcd/m² range (the paper's figure 4: about 7 kcd/m² at T = 3, 60° elevation); the
    /// sky is brighter near the sun than opposite it, bluer at the zenith than near the horizon,
    /// and the ground reflects its albedo of the sky's and sun's horizontal irradiance.
    #[test]
    fn the_sky_looks_like_daylight() {
        let p = SkyParams { sun: sun_at(60.0), turbidity: 3.0, ground_albedo: Rgb::splat(0.3) };
        let dome = Dome::new(&p);
        let zenith = dome.radiance(Vec3::Y);
        let y_kcd = crate::math::luminance(zenith) * 683.0 / 1000.0;
        assert!((3.0..15.0).contains(&y_kcd), "zenith {y_kcd} kcd/m²");
        let near_sun = dome.radiance((sun_at(60.0) + Vec3::new(0.0, -0.1, 0.0)).normalize());
        let opposite = dome.radiance(Vec3::new(0.0, 0.5, -0.87).normalize());
        assert!(near_sun.x > 2.0 * opposite.x, "{near_sun} vs {opposite}");
        assert!(zenith.z > zenith.x, "the zenith is blue: {zenith}");
        let horizon = dome.radiance(Vec3::new(1.0, 0.02, 0.0).normalize());
        assert!(horizon.z / horizon.x < zenith.z / zenith.x, "paler at the horizon: {horizon}");
    }

    /// The sun: about 1000 W/m² of solar irradiance at a high sun in clear air reaches the
    /// ground (the photometric watts here are smaller: ~100 klux / 683), less and redder towards
    /// the horizon and in haze; nothing below it.
    #[test]
    fn the_sun_dims_and_reddens_towards_the_horizon() {
        let high = sun_irradiance(2.5, 30f64.to_radians());
        let low = sun_irradiance(2.5, 85f64.to_radians());
        let hazy = sun_irradiance(8.0, 30f64.to_radians());
        let lux = crate::math::luminance(high) * 683.0;
        assert!((70_000.0..130_000.0).contains(&lux), "{lux} lx");
        assert!(crate::math::luminance(low) < 0.5 * crate::math::luminance(high));
        assert!(low.z / low.x < high.z / high.x, "redder low: {low} vs {high}");
        assert!(crate::math::luminance(hazy) < crate::math::luminance(high));
        assert_eq!(sun_irradiance(2.5, 95f64.to_radians()), Rgb::ZERO);
    }

    /// The rendered map: the sky above, the ground below at ρ E / π.
    #[test]
    fn the_map_has_sky_above_and_ground_below() {
        let p = SkyParams { sun: sun_at(30.0), turbidity: 3.0, ground_albedo: Rgb::splat(0.2) };
        let (texels, w, h, sun) = render(&p, 64);
        assert_eq!((w, h), (64, 32));
        assert!(texels.iter().all(|t| t.iter().all(|c| c.is_finite() && *c >= 0.0)));
        let ground = Rgb::from(texels[(w * (h - 1)) as usize]);
        assert!(ground.x > 0.0 && ground == Rgb::from(texels[(w * h / 2) as usize]));
        assert!(sun.x > 0.0);
    }
}
