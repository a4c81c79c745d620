//! Small geometric helpers: orthonormal frames, reflection and refraction, and the sampling
//! routines shared by the light and camera passes.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// RGB radiometric quantity (radiance, power, throughput …), linear, per channel.
pub type Rgb = Vec3;

/// The standard normal quantile Φ⁻¹(p), p in (0, 1): Acklam's rational approximation
/// (relative error below 1.2·10⁻⁹), for confidence limits in the core library (the lab's
/// statistics crate is optional).
#[allow(clippy::excessive_precision)]
pub fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383577518672690e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] =
        [7.784695709041462e-3, 3.224671290700398e-1, 2.445134137142996, 3.754408661907416];
    let poly = |k: &[f64], x: f64| k.iter().fold(0.0, |acc, &c| acc * x + c);
    let tail = |q: f64| poly(&C, q) / (poly(&D, q) * q + 1.0);
    const LOW: f64 = 0.02425;
    if p <= 0.0 {
        f64::NEG_INFINITY
    } else if p >= 1.0 {
        f64::INFINITY
    } else if p < LOW {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - LOW {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        poly(&A, r) * q / (poly(&B, r) * r + 1.0)
    }
}

/// Mean of the three channels, used for Russian roulette and for choosing lights by power.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

/// An orthonormal frame around a unit vector `n` (Duff et al. 2017, "Building an orthonormal
/// basis, revisited").
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// First tangent.
    pub s: Vec3,
    /// Second tangent.
    pub t: Vec3,
    /// The normal.
    pub n: Vec3,
}

impl Frame {
    /// Builds a frame whose third axis is `n` (unit length).
    pub fn new(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { s, t, n }
    }

    /// Local coordinates to world.
    #[inline]
    pub fn to_world(self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }

    /// World coordinates to local.
    #[inline]
    #[cfg(test)]
    pub fn to_local(self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
}

/// Mirror reflection of `wo` (pointing away from the surface) about `n`.
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

/// Refraction of `wo` (pointing away from the surface, on the side `n` points to) into the other
/// side; `eta` = η_incident / η_transmitted. `None` on total internal reflection.
#[inline]
pub fn refract(wo: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = wo.dot(n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-wo * eta + n * (eta * cos_i - cos_t)).normalize())
}

/// Unpolarised Fresnel reflectance of a smooth dielectric interface. `cos_i` is the cosine on the
/// incident side (positive), `eta` = η_incident / η_transmitted.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_s = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_p = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_s * r_s + r_p * r_p)
}

/// Cosine-weighted direction on the hemisphere around +z; pdf = cos θ / π.
#[inline]
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = sample_concentric_disc(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`sample_cosine_hemisphere`] with respect to solid angle.
#[cfg(test)]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * std::f32::consts::FRAC_1_PI
}

/// Uniform point on the unit disc (Shirley–Chiu concentric map).
pub fn sample_concentric_disc(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, PI / 4.0 * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - PI / 4.0 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Texture coordinates (u, v) ∈ [0, 1]² of the unit direction `w` on a latitude–longitude map in
/// Mitsuba 3's `envmap` convention: v = θ / π from +y, u = φ / 2π with
/// w = (sin θ sin φ, cos θ, −sin θ cos φ) (`scene/light/environment.rs`).
pub fn latlong_uv(w: Vec3) -> Vec2 {
    let mut u = w.x.atan2(-w.z) / (2.0 * PI);
    if u < 0.0 {
        u += 1.0;
    }
    // atan2 rather than acos: exact to the ulp near the poles.
    let sin_t = (w.x * w.x + w.z * w.z).sqrt();
    Vec2::new(u.min(1.0), sin_t.atan2(w.y) / PI)
}

/// The unit direction of texture coordinates `uv` on a latitude–longitude map ([`latlong_uv`]).
pub fn latlong_direction(uv: Vec2) -> Vec3 {
    let (sin_t, cos_t) = (PI * uv.y).sin_cos();
    let (sin_p, cos_p) = (2.0 * PI * uv.x).sin_cos();
    Vec3::new(sin_t * sin_p, cos_t, -sin_t * cos_p)
}

/// Uniform direction on the unit sphere; pdf = 1 / 4π.
#[inline]
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform direction in the cone of directions around +z with cos θ ≥ `cos_max`;
/// pdf = 1 / (2π (1 − cos_max)).
#[inline]
pub fn sample_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let z = 1.0 - u.x * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform point on a triangle as barycentric weights (b0, b1) of its first two vertices
/// (Heitz 2019, "A low-distortion map between triangle and square").
#[inline]
pub fn sample_triangle(u: Vec2) -> Vec2 {
    let (b0, b1) = if u.x < u.y {
        let b0 = u.x / 2.0;
        (b0, u.y - b0)
    } else {
        let b1 = u.y / 2.0;
        (u.x - b1, b1)
    };
    Vec2::new(b0, b1)
}

/// Hermite smoothstep of `x` between `a` and `b`.
#[inline]
pub fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    if a == b {
        return if x < a { 0.0 } else { 1.0 };
    }
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Relative size of the offset that moves a ray origin off the surface it leaves.
pub const RAY_EPSILON: f32 = 1e-5;

/// Distance a ray origin at `p` is moved off its surface: [`RAY_EPSILON`] · (1 + max |p_i|),
/// well above f32 rounding of the hit point (~6e-8 relative) yet small enough that the
/// transmittance lost over it (a factor e^{−σ_t ε} per surface) is negligible.
#[inline]
pub fn ray_offset(p: Vec3) -> f32 {
    RAY_EPSILON * (1.0 + p.abs().max_element())
}

/// Offsets a ray origin off a surface along the geometric normal, on the side `w` points to.
#[inline]
pub fn offset_origin(p: Vec3, ng: Vec3, w: Vec3) -> Vec3 {
    let eps = ray_offset(p);
    if w.dot(ng) >= 0.0 { p + ng * eps } else { p - ng * eps }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{ChiSquare, Domain, Sample};

    #[test]
    fn cosine_hemisphere_matches_its_density() {
        ChiSquare::new("cosine hemisphere", Domain::Sphere, 1).run(
            |s| Some(Sample::Direction(sample_cosine_hemisphere(s.next_2d()))),
            |d| cosine_hemisphere_pdf(d.direction().z.max(0.0)) as f64,
        );
    }

    #[test]
    fn frame_is_orthonormal() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.3, -0.5, 0.8).normalize()] {
            let f = Frame::new(n);
            assert!((f.s.dot(f.t)).abs() < 1e-6 && (f.s.dot(f.n)).abs() < 1e-6);
            assert!((f.s.cross(f.t) - f.n).length() < 1e-5);
            let v = Vec3::new(0.2, 0.4, -0.7);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-6);
        }
    }

    #[test]
    fn refraction_obeys_snell_and_fresnel_limits() {
        let n = Vec3::Z;
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let wt = refract(wo, n, 1.0 / 1.5).unwrap();
        let sin_i = 0.6f32;
        let sin_t = (1.0 - wt.z * wt.z).sqrt();
        assert!((sin_i / sin_t - 1.5).abs() < 1e-5);
        assert!(wt.z < 0.0);
        // Total internal reflection from inside glass at grazing angles.
        assert!(refract(Vec3::new(0.9, 0.0, 0.1).normalize(), n, 1.5).is_none());
        assert_eq!(fresnel_dielectric(0.1, 1.5), 1.0);
        // Normal incidence: ((n1 - n2) / (n1 + n2))^2.
        assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
    }

    #[test]
    fn normal_quantiles_match_statrs() {
        use statrs::distribution::{ContinuousCDF, Normal};
        let n = Normal::new(0.0, 1.0).unwrap();
        for p in [1e-9, 1e-4, 0.0241, 0.025, 0.1, 0.5, 0.8, 0.95, 0.975, 0.999, 1.0 - 1e-7] {
            let (got, want) = (super::normal_quantile(p), n.inverse_cdf(p));
            assert!((got - want).abs() <= 1e-8 * want.abs().max(1.0), "{p}: {got} vs {want}");
        }
    }
}
