//! Light sources and their photon emission.
//!
//! Units: point and spot lights are given by their emitted **power** Φ in watts (RGB);
//! directional lights by the **irradiance** E in W/m² on a plane perpendicular to their direction;
//! area lights are shapes with an `emission` **radiance** L in W/(m²·sr), emitted on the side their
//! normal points to (power Φ = π L A).
//!
//! ```toml
//! [[lights]]
//! type = "point"
//! position = [0, 1.9, 0]
//! power = [50, 50, 50]
//!
//! [[lights]]
//! type = "spot"             # smooth falloff from falloff_start to cone_angle (half-angles, degrees)
//! position = [0, 2, 0]
//! look_at = [0, 0, 0]
//! power = 100
//! cone_angle = 30
//! falloff_start = 25        # default: cone_angle (a hard edge)
//!
//! [[lights]]
//! type = "directional"
//! direction = [0.3, -1, 0.2]  # the direction light travels
//! irradiance = [3, 3, 3]
//! ```

use crate::math::{
    Frame, Rgb, luminance, sample_concentric_disc, sample_cosine_hemisphere, sample_triangle,
    sample_uniform_cone, sample_uniform_sphere, smoothstep,
};
use crate::rng::Sampler;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// The surface of an area light, in world space.
#[derive(Clone, Debug)]
pub enum Emitter {
    /// Triangles with a cumulative area table for sampling by area.
    Triangles {
        /// Vertices of each triangle.
        triangles: Vec<[Vec3; 3]>,
        /// Cumulative areas (last entry = total area).
        cdf: Vec<f32>,
    },
    /// An analytic sphere, emitting outward.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
    },
}

impl Emitter {
    /// Total area.
    pub fn area(&self) -> f32 {
        match self {
            Emitter::Triangles { cdf, .. } => cdf.last().copied().unwrap_or(0.0),
            Emitter::Sphere { radius, .. } => 4.0 * PI * radius * radius,
        }
    }

    /// Uniform point by area: position and outward normal.
    pub fn sample_point(&self, u_pick: f32, u: Vec2) -> (Vec3, Vec3) {
        match self {
            Emitter::Triangles { triangles, cdf } => {
                let target = u_pick * self.area();
                let i = cdf.partition_point(|&c| c <= target).min(triangles.len() - 1);
                let [a, b, c] = triangles[i];
                let w = sample_triangle(u);
                let p = a * w.x + b * w.y + c * (1.0 - w.x - w.y);
                (p, (b - a).cross(c - a).normalize())
            }
            Emitter::Sphere { center, radius } => {
                let n = sample_uniform_sphere(u);
                (*center + n * *radius, n)
            }
        }
    }
}

/// A light source.
#[derive(Clone, Debug)]
pub enum Light {
    /// Isotropic point light; `intensity` = Φ / 4π in W/sr.
    Point {
        /// Position.
        position: Vec3,
        /// Radiant intensity (W/sr).
        intensity: Rgb,
    },
    /// Spot light: I(θ) = I₀ · smoothstep(cos θ_max, cos θ_start, cos θ).
    Spot {
        /// Position.
        position: Vec3,
        /// Frame whose `n` is the spot's axis.
        frame: Frame,
        /// On-axis intensity I₀ (W/sr).
        intensity: Rgb,
        /// cos of the cone's half-angle.
        cos_max: f32,
        /// cos of the angle where the falloff starts.
        cos_start: f32,
    },
    /// Parallel light from outside the scene.
    Directional {
        /// Unit direction light travels.
        direction: Vec3,
        /// Irradiance on a perpendicular plane (W/m²).
        irradiance: Rgb,
        /// Centre of the scene's bounding sphere.
        center: Vec3,
        /// Radius of the scene's bounding sphere.
        radius: f32,
    },
    /// A shape that emits radiance `radiance` from its front side.
    Area {
        /// Index of the emitting shape.
        shape: u32,
        /// Emitted radiance (W/(m²·sr)).
        radiance: Rgb,
        /// Its surface.
        emitter: Emitter,
    },
}

/// A photon leaving a light.
#[derive(Clone, Copy, Debug)]
pub struct Emission {
    /// Origin.
    pub p: Vec3,
    /// Unit direction.
    pub d: Vec3,
    /// Surface normal at the origin for area lights (used to offset the ray), else zero.
    pub n: Vec3,
    /// Power carried: emitted radiance × cos / (pdf of position × pdf of direction), in W.
    pub beta: Rgb,
}

impl Light {
    /// Total emitted power Φ (W), per channel.
    pub fn power(&self) -> Rgb {
        match self {
            Light::Point { intensity, .. } => *intensity * 4.0 * PI,
            Light::Spot { intensity, cos_max, cos_start, .. } => {
                *intensity * spot_solid_angle(*cos_max, *cos_start)
            }
            Light::Directional { irradiance, radius, .. } => *irradiance * PI * radius * radius,
            Light::Area { radiance, emitter, .. } => *radiance * PI * emitter.area(),
        }
    }

    /// Samples an emitted photon from three pairs of uniforms.
    pub fn sample_emission(&self, u_pick: f32, u_pos: Vec2, u_dir: Vec2) -> Emission {
        match self {
            Light::Point { position, .. } => Emission {
                p: *position,
                d: sample_uniform_sphere(u_dir),
                n: Vec3::ZERO,
                beta: self.power(),
            },
            Light::Spot { position, frame, intensity, cos_max, cos_start } => {
                let local = sample_uniform_cone(u_dir, *cos_max);
                let falloff = smoothstep(*cos_max, *cos_start, local.z);
                let inv_pdf = 2.0 * PI * (1.0 - cos_max);
                Emission {
                    p: *position,
                    d: frame.to_world(local),
                    n: Vec3::ZERO,
                    beta: *intensity * falloff * inv_pdf,
                }
            }
            Light::Directional { direction, center, radius, .. } => {
                let frame = Frame::new(*direction);
                let disc = sample_concentric_disc(u_pos) * *radius;
                let p =
                    *center + frame.to_world(Vec3::new(disc.x, disc.y, 0.0)) - *direction * *radius;
                Emission { p, d: *direction, n: Vec3::ZERO, beta: self.power() }
            }
            Light::Area { emitter, .. } => {
                let (p, n) = emitter.sample_point(u_pick, u_pos);
                let d = Frame::new(n).to_world(sample_cosine_hemisphere(u_dir));
                Emission { p, d, n, beta: self.power() }
            }
        }
    }

    /// Intensity of a spot light towards local cos θ (W/sr).
    pub fn spot_intensity(&self, cos_theta: f32) -> Rgb {
        match self {
            Light::Spot { intensity, cos_max, cos_start, .. } => {
                *intensity * smoothstep(*cos_max, *cos_start, cos_theta)
            }
            _ => Rgb::ZERO,
        }
    }
}

/// Light arriving at a point from a sampled point of a light ([`Light::sample_li`]).
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the point towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point of the light (infinite for a directional light); for area
    /// lights slightly shortened, so that a shadow ray stops short of the emitter's surface.
    pub dist: f32,
    /// Incident radiance times the geometry term divided by the sampling pdf (area lights), or
    /// the irradiance-like contribution of a delta light (intensity / d², or the irradiance).
    pub value: Rgb,
    /// Solid-angle density of `wi` at the point (area lights); `None` for delta lights, which
    /// no other strategy can sample.
    pub pdf: Option<f32>,
}

impl Light {
    /// Samples light arriving at `p`: a direction towards the light, the distance, and what it
    /// brings (see [`LightSample`]). Area lights are sampled uniformly by area and converted to
    /// solid angle; `None` if the sampled point faces away from `p` or coincides with it.
    pub fn sample_li(&self, p: Vec3, s: &mut Sampler) -> Option<LightSample> {
        match self {
            Light::Point { position, intensity } => {
                let v = *position - p;
                let d2 = v.length_squared();
                (d2 > 0.0).then(|| {
                    let dist = d2.sqrt();
                    LightSample { wi: v / dist, dist, value: *intensity / d2, pdf: None }
                })
            }
            Light::Spot { position, frame, .. } => {
                let v = *position - p;
                let d2 = v.length_squared();
                if d2 <= 0.0 {
                    return None;
                }
                let dist = d2.sqrt();
                let wi = v / dist;
                let value = self.spot_intensity(frame.n.dot(-wi)) / d2;
                Some(LightSample { wi, dist, value, pdf: None })
            }
            Light::Directional { direction, irradiance, .. } => Some(LightSample {
                wi: -*direction,
                dist: f32::INFINITY,
                value: *irradiance,
                pdf: None,
            }),
            Light::Area { radiance, emitter, .. } => {
                let (q, n) = emitter.sample_point(s.next_f32(), s.next_2d());
                let v = q - p;
                let d2 = v.length_squared();
                if d2 <= 0.0 {
                    return None;
                }
                let dist = d2.sqrt();
                let wi = v / dist;
                let cos_l = n.dot(-wi);
                if cos_l <= 0.0 {
                    return None;
                }
                let dist = dist * (1.0 - 1e-4);
                let area = emitter.area();
                Some(LightSample {
                    wi,
                    dist,
                    value: *radiance * (cos_l * area / d2),
                    pdf: Some(d2 / (cos_l * area)),
                })
            }
        }
    }
}

/// Chooses lights in proportion to their power, and knows which shapes are area lights.
pub struct LightSampler {
    cdf: Vec<f32>,
    total: f32,
    /// For each shape, the index of its area light and that light's area, if it emits.
    area_lights: Vec<Option<(usize, f32)>>,
}

impl LightSampler {
    /// The distribution over `lights` (mean-channel power), for a scene of `shapes` shapes.
    pub fn new(lights: &[Light], shapes: usize) -> Self {
        let mut total = 0.0;
        let cdf = lights
            .iter()
            .map(|l| {
                total += luminance(l.power());
                total
            })
            .collect();
        let mut area_lights = vec![None; shapes];
        for (i, l) in lights.iter().enumerate() {
            if let Light::Area { shape, emitter, .. } = l {
                area_lights[*shape as usize] = Some((i, emitter.area()));
            }
        }
        Self { cdf, total, area_lights }
    }

    /// The area light of shape `shape` and its area, if the shape emits.
    pub fn area_light(&self, shape: u32) -> Option<(usize, f32)> {
        self.area_lights.get(shape as usize).copied().flatten()
    }

    /// True if no light emits anything.
    pub fn is_empty(&self) -> bool {
        self.total <= 0.0
    }

    /// The probability that [`Self::pick`] returns light `i`.
    pub fn prob(&self, i: usize) -> f32 {
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        (self.cdf[i] - lo) / self.total
    }

    /// A light index and its probability.
    pub fn pick(&self, u: f32) -> (usize, f32) {
        let target = u * self.total;
        let i = self.cdf.partition_point(|&c| c <= target).min(self.cdf.len() - 1);
        (i, self.prob(i))
    }

    /// The density with which next-event estimation from `from` (choosing a light with
    /// [`Self::pick`], then [`Light::sample_li`]) picks the direction towards the point `to` of
    /// the emitting shape `shape`, whose surface there has the cosine `cos_l` with that direction:
    /// P(light) · d² / (|cos_l| · area), per solid angle. Zero if the shape does not emit.
    pub fn pdf_li(&self, shape: u32, from: Vec3, to: Vec3, cos_l: f32) -> f32 {
        let Some((li, area)) = self.area_light(shape) else { return 0.0 };
        let cos_l = cos_l.abs();
        if cos_l <= 0.0 || area <= 0.0 {
            return 0.0;
        }
        self.prob(li) * (to - from).length_squared() / (cos_l * area)
    }
}

/// ∫ smoothstep(cos_max, cos_start, cos θ) dω over the sphere: the full cone up to the falloff
/// start, plus half of the falloff band (smoothstep integrates to half its interval).
pub fn spot_solid_angle(cos_max: f32, cos_start: f32) -> f32 {
    2.0 * PI * ((1.0 - cos_start) + 0.5 * (cos_start - cos_max))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spot_solid_angle_matches_quadrature() {
        let (cmax, cstart) = (30f32.to_radians().cos(), 20f32.to_radians().cos());
        let n = 200_000;
        let mut sum = 0.0f64;
        for i in 0..n {
            let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
            sum += smoothstep(cmax, cstart, c as f32) as f64 * 2.0 / n as f64;
        }
        let quad = 2.0 * std::f64::consts::PI * sum;
        assert!((quad - spot_solid_angle(cmax, cstart) as f64).abs() < 1e-4);
    }
}
