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

pub(crate) mod environment;
pub(crate) mod media;
mod sampler;
pub mod sky;
mod tree;

pub use environment::{EnvMap, Environment};
pub(crate) use sampler::LightSampler;
pub use sky::SkyParams;
pub(crate) use tree::{Receiver, Segment};

use crate::math::{
    Frame, Rgb, sample_cosine_hemisphere, sample_triangle, sample_uniform_cone,
    sample_uniform_sphere, smoothstep,
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
    /// Parallel light from outside the scene. Its photons start on the rectangle `corner + u
    /// edge_s + v edge_t` (u, v ∈ [0, 1]), perpendicular to `direction` and upstream of the whole
    /// scene: the cross-section of the scene's bounds ([`Light::directional`]).
    Directional {
        /// Unit direction light travels.
        direction: Vec3,
        /// Irradiance on a perpendicular plane (W/m²).
        irradiance: Rgb,
        /// A corner of the emitting rectangle.
        corner: Vec3,
        /// Its two edges from `corner`, perpendicular to `direction` and to each other.
        edge_s: Vec3,
        edge_t: Vec3,
    },
    /// Radiance from infinitely far away in every direction: a constant, a map, a sky
    /// (`environment.rs`).
    Environment(Box<Environment>),
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
    /// Power carried: emitted radiance × cos / (pdf of position × pdf of direction), in W. The
    /// densities of the origin and direction drawn are [`Light::pdf_emission`]'s, evaluated
    /// where a method asks for them.
    pub beta: Rgb,
}

/// The densities with which a light emits from a point in a direction, given the light (the
/// light sampler's pick is not in them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissionPdfs {
    /// Density per unit area of the origin on the light's surface (on a directional light's
    /// emitting rectangle); 1 for point and spot lights, whose origin is fixed (a delta).
    pub pos: f32,
    /// Density per steradian of the direction; 1 for a directional light, whose direction is
    /// fixed (a delta).
    pub dir: f32,
}

impl Light {
    /// A directional light travelling along `direction` (unit) with irradiance `irradiance`,
    /// emitting its photons over the cross-section of the box `bounds` (lo, hi): the rectangle,
    /// perpendicular to the direction, that the box's corners project into (grown by 1 %),
    /// placed upstream of the whole box. Anything the light can reach lies in that box — every
    /// surface and medium of the scene — so no light that could reach the camera is left out;
    /// where in that cross-section photons are useful is for the photon pass to find out.
    pub fn directional(direction: Vec3, irradiance: Rgb, (lo, hi): (Vec3, Vec3)) -> Light {
        let frame = Frame::new(direction);
        let centre = 0.5 * (lo + hi);
        let (mut a, mut b) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        let mut upstream = 0.0f32;
        for k in 0..8 {
            let c = Vec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            ) - centre;
            let st = Vec2::new(c.dot(frame.s), c.dot(frame.t));
            (a, b) = (a.min(st), b.max(st));
            upstream = upstream.max(-c.dot(direction));
        }
        let size = (b - a).max(Vec2::splat(1e-3));
        let grow = 0.005 * size.max_element();
        let (a, size) = (a - Vec2::splat(grow), size + Vec2::splat(2.0 * grow));
        let back = (upstream * 1.01).max(1e-3);
        Light::Directional {
            direction,
            irradiance,
            corner: centre + frame.s * a.x + frame.t * a.y - direction * back,
            edge_s: frame.s * size.x,
            edge_t: frame.t * size.y,
        }
    }

    /// Total emitted power Φ (W), per channel.
    pub fn power(&self) -> Rgb {
        match self {
            Light::Point { intensity, .. } => *intensity * 4.0 * PI,
            Light::Spot { intensity, cos_max, cos_start, .. } => {
                *intensity * spot_solid_angle(*cos_max, *cos_start)
            }
            Light::Directional { irradiance, edge_s, edge_t, .. } => {
                *irradiance * edge_s.cross(*edge_t).length()
            }
            Light::Area { radiance, emitter, .. } => *radiance * PI * emitter.area(),
            Light::Environment(env) => env.power(),
        }
    }

    /// Samples an emitted photon from three pairs of uniforms.
    pub fn sample_emission(&self, u_pick: f32, u_pos: Vec2, u_dir: Vec2) -> Emission {
        let (p, d, n, beta) = match self {
            Light::Point { position, .. } => {
                (*position, sample_uniform_sphere(u_dir), Vec3::ZERO, self.power())
            }
            Light::Spot { position, frame, intensity, cos_max, cos_start } => {
                let local = sample_uniform_cone(u_dir, *cos_max);
                let falloff = smoothstep(*cos_max, *cos_start, local.z);
                let inv_pdf = 2.0 * PI * (1.0 - cos_max);
                (*position, frame.to_world(local), Vec3::ZERO, *intensity * falloff * inv_pdf)
            }
            Light::Directional { direction, corner, edge_s, edge_t, .. } => {
                let p = *corner + *edge_s * u_pos.x + *edge_t * u_pos.y;
                (p, *direction, Vec3::ZERO, self.power())
            }
            Light::Area { emitter, .. } => {
                let (p, n) = emitter.sample_point(u_pick, u_pos);
                (p, Frame::new(n).to_world(sample_cosine_hemisphere(u_dir)), n, self.power())
            }
            Light::Environment(env) => {
                let (p, d, beta) = env.sample_emission(u_pos, u_dir);
                (p, d, Vec3::ZERO, beta)
            }
        };
        Emission { p, d, n, beta }
    }

    /// The densities with which [`Self::sample_emission`] emits in direction `d` from a point of
    /// the light whose outward normal is `n` (area lights; any value for the others): uniform
    /// over the sphere for a point light and over its cone for a spot light (the falloff is in
    /// the weight), uniform by area and cosine-weighted for an area light (zero behind it),
    /// uniform over the emitting rectangle for a directional light.
    #[allow(dead_code)] // for the combined estimator's weights; read by the tests now
    pub fn pdf_emission(&self, n: Vec3, d: Vec3) -> EmissionPdfs {
        let (pos, dir) = match self {
            Light::Point { .. } => (1.0, 1.0 / (4.0 * PI)),
            Light::Spot { frame, cos_max, .. } => {
                // A direction drawn at the rim may round a few ulps outside: still inside.
                let inside = frame.n.dot(d) >= *cos_max - 1e-6;
                (1.0, if inside { 1.0 / (2.0 * PI * (1.0 - cos_max)) } else { 0.0 })
            }
            Light::Directional { edge_s, edge_t, .. } => {
                (1.0 / edge_s.cross(*edge_t).length(), 1.0)
            }
            Light::Area { emitter, .. } => (1.0 / emitter.area(), n.dot(d).max(0.0) / PI),
            Light::Environment(env) => (1.0 / env.disc_area(), env.pdf(-d)),
        };
        EmissionPdfs { pos, dir }
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

/// A point of a light: its position, and for an area light the surface normal there.
#[derive(Clone, Copy, Debug)]
pub struct LightPoint {
    /// Position.
    pub p: Vec3,
    /// Outward normal of an area light's surface (`None` for point and spot lights).
    pub n: Option<Vec3>,
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
    /// no other strategy can sample. The reverse decision, the light emitting from the sampled
    /// point towards the receiver, has the densities `pdf_emission(n, −wi)` ([`Light::pdf_emission`],
    /// n the point's normal from [`Light::sample_point`]): evaluated where a method asks for it,
    /// not on every shadow ray.
    pub pdf: Option<f32>,
}

impl Light {
    /// Samples light arriving at `p`: a direction towards the light, the distance, and what it
    /// brings (see [`LightSample`]). Area lights are sampled uniformly by area and converted to
    /// solid angle; `None` if the sampled point faces away from `p` or coincides with it.
    pub fn sample_li(&self, p: Vec3, s: &mut Sampler) -> Option<LightSample> {
        match self.sample_point(s) {
            Some(point) => self.li_from(p, &point),
            None => self.li_from_infinity(s),
        }
    }

    /// A point of the light to connect to: the position of a point or spot light; for an area
    /// light a point sampled uniformly by area, with its normal; `None` for a directional light,
    /// which has no position.
    pub fn sample_point(&self, s: &mut Sampler) -> Option<LightPoint> {
        match self {
            Light::Point { position, .. } | Light::Spot { position, .. } => {
                Some(LightPoint { p: *position, n: None })
            }
            Light::Directional { .. } | Light::Environment(_) => None,
            Light::Area { emitter, .. } => {
                let (q, n) = emitter.sample_point(s.next_f32(), s.next_2d());
                Some(LightPoint { p: q, n: Some(n) })
            }
        }
    }

    /// Light arriving at `p` from the point `point` of this light (from [`Self::sample_point`]).
    pub fn li_from(&self, p: Vec3, point: &LightPoint) -> Option<LightSample> {
        let v = point.p - p;
        let d2 = v.length_squared();
        if d2 <= 0.0 {
            return None;
        }
        let dist = d2.sqrt();
        let wi = v / dist;
        match self {
            Light::Point { intensity, .. } => {
                Some(LightSample { wi, dist, value: *intensity / d2, pdf: None })
            }
            Light::Spot { frame, .. } => {
                let value = self.spot_intensity(frame.n.dot(-wi)) / d2;
                Some(LightSample { wi, dist, value, pdf: None })
            }
            Light::Area { radiance, emitter, .. } => {
                let n = point.n.unwrap_or(-wi);
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
            Light::Directional { .. } | Light::Environment(_) => None,
        }
    }

    /// Radiance the light emits from a point of its surface whose outward normal is `n`, in
    /// direction `w` (pointing away from the light): an area light's radiance on its front side,
    /// zero behind it and for lights without a surface (no ray can reach those).
    #[inline]
    pub fn le(&self, n: Vec3, w: Vec3) -> Rgb {
        match self {
            Light::Area { radiance, .. } if w.dot(n) > 0.0 => *radiance,
            _ => Rgb::ZERO,
        }
    }

    /// Solid-angle density at `from` with which [`Self::sample_li`] samples the direction towards
    /// the point `to` of the light, whose normal makes cosine `cos_l` with the direction back to
    /// `from`: d² / (|cos_l| A) for an area light (uniform by area); zero for point, spot and
    /// directional lights, which no direction sampled otherwise can reach.
    #[inline]
    pub fn pdf_li(&self, from: Vec3, to: Vec3, cos_l: f32) -> f32 {
        let Light::Area { emitter, .. } = self else { return 0.0 };
        let (cos_l, area) = (cos_l.abs(), emitter.area());
        if cos_l <= 0.0 || area <= 0.0 {
            return 0.0;
        }
        (to - from).length_squared() / (cos_l * area)
    }

    /// Light of a directional or environment light, arriving from infinity: an environment's
    /// direction drawn by its density (`None` where that is zero), its radiance over the density.
    fn li_from_infinity(&self, s: &mut Sampler) -> Option<LightSample> {
        match self {
            Light::Directional { direction, irradiance, .. } => Some(LightSample {
                wi: -*direction,
                dist: f32::INFINITY,
                value: *irradiance,
                pdf: None,
            }),
            Light::Environment(env) => {
                let (wi, pdf) = env.sample(s.next_2d())?;
                let value = env.radiance(wi) / pdf;
                Some(LightSample { wi, dist: f32::INFINITY, value, pdf: Some(pdf) })
            }
            _ => None,
        }
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
    use crate::testing::{ChiSquare, Domain, Sample, assert_agrees};
    use glam::DVec2;
    use std::f64::consts::PI as PI64;

    /// A 2 × 1 rectangle in the xy-plane facing +z, centred at `c`, as two triangles.
    pub(super) fn rectangle(c: Vec3) -> Emitter {
        let [a, b, d, e] = [(-1.0, -0.5), (1.0, -0.5), (1.0, 0.5), (-1.0, 0.5)]
            .map(|(x, y)| c + Vec3::new(x, y, 0.0));
        Emitter::Triangles { triangles: vec![[a, b, d], [a, d, e]], cdf: vec![1.0, 2.0] }
    }

    fn area(emitter: Emitter) -> Light {
        Light::Area { shape: 0, radiance: Rgb::splat(1.5), emitter }
    }

    /// Point and area lights (rectangle and sphere) emit with the right densities of position
    /// and direction, and every photon carries the light's power (chi-square tests, 6 in all).
    #[test]
    fn emission_follows_its_densities() {
        const TESTS: usize = 6;
        let point = Light::Point { position: Vec3::ONE, intensity: Rgb::splat(2.0) };
        ChiSquare::new("point light directions", Domain::Sphere, TESTS).run(
            |s| {
                let e = point.sample_emission(s.next_f32(), s.next_2d(), s.next_2d());
                assert_eq!(e.p, Vec3::ONE);
                assert!((e.beta - point.power()).abs().max_element() < 1e-4);
                assert_eq!(
                    point.pdf_emission(e.n, e.d),
                    EmissionPdfs { pos: 1.0, dir: 1.0 / (4.0 * PI) }
                );
                Some(Sample::Direction(e.d))
            },
            |d| point.pdf_emission(Vec3::ZERO, d.direction()).dir as f64,
        );
        let rect = area(rectangle(Vec3::ZERO));
        assert!((rect.power() - Rgb::splat(1.5 * PI * 2.0)).abs().max_element() < 1e-4);
        ChiSquare::new("rectangle emission positions", Domain::Square, TESTS).run(
            |s| {
                let e = rect.sample_emission(s.next_f32(), s.next_2d(), s.next_2d());
                assert!((e.n - Vec3::Z).length() < 1e-6 && e.beta == rect.power());
                let pdfs = rect.pdf_emission(e.n, e.d);
                assert_eq!(pdfs.pos, 0.5, "uniform over an area of 2");
                assert!((pdfs.dir - e.d.z / PI).abs() < 1e-6, "cosine-weighted");
                let uv = DVec2::new((e.p.x as f64 + 1.0) / 2.0, e.p.y as f64 + 0.5);
                Some(Sample::Point(uv))
            },
            // Per unit of the unit square, which maps onto the 2 × 1 rectangle.
            |_| 2.0 * rect.pdf_emission(Vec3::Z, Vec3::Z).pos as f64,
        );
        ChiSquare::new("rectangle emission directions", Domain::Sphere, TESTS).run(
            |s| {
                Some(Sample::Direction(
                    rect.sample_emission(s.next_f32(), s.next_2d(), s.next_2d()).d,
                ))
            },
            |d| rect.pdf_emission(Vec3::Z, d.direction()).dir as f64,
        );
        let sphere = area(Emitter::Sphere { center: Vec3::new(0.0, 0.0, 2.0), radius: 0.5 });
        ChiSquare::new("sphere emission positions", Domain::Sphere, TESTS).run(
            |s| {
                let e = sphere.sample_emission(s.next_f32(), s.next_2d(), s.next_2d());
                assert!(e.n.dot(e.d) >= 0.0, "emitted inwards");
                let pdfs = sphere.pdf_emission(e.n, e.d);
                assert!((pdfs.pos - 1.0 / PI).abs() < 1e-6, "uniform over an area of π");
                assert!((pdfs.dir - e.n.dot(e.d) / PI).abs() < 1e-6, "cosine-weighted");
                Some(Sample::Direction((e.p - Vec3::new(0.0, 0.0, 2.0)) / 0.5))
            },
            // Per steradian of the unit sphere: per unit area times r².
            |_| 0.25 * sphere.pdf_emission(Vec3::Z, Vec3::Z).pos as f64,
        );
        // The spot's directions: uniform in its cone around +z (the falloff is in the weight),
        // and the photons carry its power on average (t-test on batch means).
        let (cos_max, cos_start) = (35f32.to_radians().cos(), 20f32.to_radians().cos());
        let power = 10.0;
        let spot = Light::Spot {
            position: Vec3::ZERO,
            frame: Frame::new(Vec3::Z),
            intensity: Rgb::splat(power / spot_solid_angle(cos_max, cos_start)),
            cos_max,
            cos_start,
        };
        let mut betas = Vec::new();
        ChiSquare::new("spot directions", Domain::Sphere, TESTS).run(
            |s| {
                let e = spot.sample_emission(s.next_f32(), s.next_2d(), s.next_2d());
                betas.push(e.beta.x as f64);
                let cone = 1.0 / (2.0 * PI * (1.0 - cos_max));
                assert_eq!(spot.pdf_emission(e.n, e.d), EmissionPdfs { pos: 1.0, dir: cone });
                Some(Sample::Direction(e.d))
            },
            |d| spot.pdf_emission(Vec3::ZERO, d.direction()).dir as f64,
        );
        let batches: Vec<f64> = betas
            .chunks(betas.len() / 20)
            .map(|c| c.iter().sum::<f64>() / c.len() as f64)
            .collect();
        assert_agrees("spot power", &batches, power as f64, 0.0);
        // The directional light: positions uniform on its cross-section of the bounds, which
        // lies upstream of the box and covers its shadow: every point of the box is reached by
        // the rectangle's rays.
        let direction = Vec3::new(0.3, -1.0, 0.2).normalize();
        let bounds = (Vec3::new(-12.0, 0.0, -12.0), Vec3::new(12.0, 3.0, 12.0));
        let sun = Light::directional(direction, Rgb::splat(3.0), bounds);
        let Light::Directional { corner, edge_s, edge_t, .. } = sun else { unreachable!() };
        let local = |p: Vec3| {
            let v = p - corner;
            (v.dot(edge_s) / edge_s.length_squared(), v.dot(edge_t) / edge_t.length_squared())
        };
        let mut s = Sampler::new(9, crate::rng::Purpose::Other, 0, 0);
        for _ in 0..1000 {
            let p = bounds.0
                + (bounds.1 - bounds.0) * Vec3::new(s.next_f32(), s.next_f32(), s.next_f32());
            let (u, v) = local(p);
            assert!((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v), "{p} not covered");
            assert!((p - corner).dot(direction) > 0.0, "{p} upstream of the light");
        }
        let area = edge_s.cross(edge_t).length();
        assert!((sun.power().x - 3.0 * area).abs() < 1e-3 * sun.power().x);
        ChiSquare::new("directional light positions", Domain::Square, TESTS).run(
            |s| {
                let e = sun.sample_emission(s.next_f32(), s.next_2d(), s.next_2d());
                assert_eq!(e.d, direction);
                assert!((e.p - corner).dot(direction).abs() < 1e-3, "off the rectangle");
                assert_eq!(sun.pdf_emission(e.n, e.d), EmissionPdfs { pos: 1.0 / area, dir: 1.0 });
                let (u, v) = local(e.p);
                Some(Sample::Point(DVec2::new(u as f64, v as f64)))
            },
            // Per unit of the unit square, which maps onto the rectangle.
            |_| (area * sun.pdf_emission(Vec3::ZERO, direction).pos) as f64,
        );
    }

    /// Area lights sampled from a point: the directions' density is d²/(|cos_l| A) per
    /// steradian over the light's front-facing surface, and sample_li's `value` is radiance ×
    /// geometry term / pdf (chi-square for a rectangle and a sphere; the sphere's far side fails).
    #[test]
    fn area_lights_sample_li_with_their_solid_angle_density() {
        let at = Vec3::new(0.2, -0.3, 0.0);
        // Facing down, one unit above `at`'s plane.
        let rect = Light::Area {
            shape: 0,
            radiance: Rgb::splat(2.0),
            emitter: match rectangle(Vec3::new(0.0, 0.0, 1.0)) {
                Emitter::Triangles { triangles, cdf } => Emitter::Triangles {
                    triangles: triangles.into_iter().map(|[a, b, c]| [a, c, b]).collect(),
                    cdf,
                },
                e => e,
            },
        };
        let rect_pdf = |w: Vec3| {
            // Where the ray from `at` along w meets the plane z = 1, if inside the rectangle.
            if w.z <= 0.0 {
                return 0.0;
            }
            let t = 1.0 / w.z as f64;
            let q = at.as_dvec3() + w.as_dvec3() * t;
            if q.x.abs() <= 1.0 && q.y.abs() <= 0.5 { t * t / (w.z as f64 * 2.0) } else { 0.0 }
        };
        ChiSquare::new("rectangle sample_li", Domain::Sphere, 2).run(
            |s| {
                let ls = rect.sample_li(at, s)?;
                let pdf = ls.pdf.expect("area lights have a density");
                assert!((pdf as f64 / rect_pdf(ls.wi) - 1.0).abs() < 1e-3);
                // The light sampler's pdf_li agrees at the sampled point (the distance is
                // shortened by 10⁻⁴), with the one light chosen with probability 1.
                let to = at + ls.wi * (ls.dist / (1.0 - 1e-4));
                let sampler = LightSampler::new(std::slice::from_ref(&rect), 1);
                let (cos_l, from) = (ls.wi.z, Receiver::medium(at));
                let rect_alone = std::slice::from_ref(&rect);
                assert!((sampler.pdf_li(rect_alone, 0, &from, to, cos_l) / pdf - 1.0).abs() < 1e-3);
                // … and so does the light's own, with its radiance on the front side only.
                assert!((rect.pdf_li(at, to, cos_l) / pdf - 1.0).abs() < 1e-3);
                assert_eq!(rect.le(-Vec3::Z, -ls.wi), Rgb::splat(2.0));
                assert_eq!(rect.le(-Vec3::Z, ls.wi), Rgb::ZERO);
                assert!((ls.value.x as f64 - 2.0 / pdf as f64).abs() < 1e-3 * ls.value.x as f64);
                // The reverse decision, the light emitting towards `at` from the point: uniform
                // by area (1/2), cosine-weighted in direction.
                let reverse = rect.pdf_emission(-Vec3::Z, -ls.wi);
                assert!((reverse.dir - cos_l / PI).abs() < 1e-6 && reverse.pos == 0.5);
                Some(Sample::Direction(ls.wi))
            },
            |d| rect_pdf(d.direction()),
        );
        let (c, r) = (Vec3::new(0.0, 0.0, 2.0), 0.5f64);
        let sphere = area(Emitter::Sphere { center: c, radius: r as f32 });
        let sphere_pdf = |w: Vec3| {
            // Nearest intersection of the ray from `at` with the sphere (the front-facing side).
            let (o, w) = ((at - c).as_dvec3(), w.as_dvec3());
            let b = o.dot(w);
            let disc = b * b - (o.length_squared() - r * r);
            if disc < 0.0 {
                return 0.0;
            }
            let t = -b - disc.sqrt();
            if t <= 0.0 {
                return 0.0;
            }
            let n = (o + w * t) / r;
            t * t / ((-n.dot(w)) * 4.0 * PI64 * r * r)
        };
        ChiSquare::new("sphere sample_li", Domain::Sphere, 2).run(
            |s| {
                let ls = sphere.sample_li(at, s)?;
                let q = at + ls.wi * (ls.dist / (1.0 - 1e-4));
                // The reverse decision: uniform over the area π, cosine-weighted.
                let n = (q - c) / r as f32;
                let reverse = sphere.pdf_emission(n, -ls.wi);
                assert!((reverse.pos - 1.0 / PI).abs() < 1e-6);
                assert!((reverse.dir - n.dot(-ls.wi) / PI).abs() < 1e-6, "{reverse:?}");
                Some(Sample::Direction(ls.wi))
            },
            |d| sphere_pdf(d.direction()),
        );
    }

    /// Delta lights: the direction, distance and contribution of sample_li are exact.
    #[test]
    fn delta_lights_sample_li_exactly() {
        let mut s = Sampler::new(3, crate::rng::Purpose::Other, 0, 0);
        let p = Vec3::new(0.5, 0.0, 0.0);
        let point = Light::Point { position: Vec3::new(0.5, 2.0, 0.0), intensity: Rgb::splat(8.0) };
        let ls = point.sample_li(p, &mut s).unwrap();
        assert_eq!((ls.wi, ls.dist, ls.pdf), (Vec3::Y, 2.0, None));
        assert!((ls.value - Rgb::splat(2.0)).abs().max_element() < 1e-6);
        // Reverse decisions: the light emitting towards p, with the densities its emission
        // histograms show.
        let uniform = 1.0 / (4.0 * PI);
        assert_eq!(point.pdf_emission(Vec3::ZERO, -ls.wi), EmissionPdfs { pos: 1.0, dir: uniform });
        let (cos_max, cos_start) = (0.5f32, 0.9f32);
        let spot = Light::Spot {
            position: Vec3::new(0.5, 2.0, 0.0),
            frame: Frame::new(Vec3::new(0.3, -1.0, 0.0).normalize()),
            intensity: Rgb::splat(8.0),
            cos_max,
            cos_start,
        };
        let ls = spot.sample_li(p, &mut s).unwrap();
        let cos = -Vec3::new(0.3, -1.0, 0.0).normalize().y;
        let want = 8.0 * smoothstep(cos_max, cos_start, cos) / 4.0;
        assert!((ls.value.x - want).abs() < 1e-5 && ls.pdf.is_none());
        let cone = 1.0 / (2.0 * PI * (1.0 - cos_max));
        assert_eq!(spot.pdf_emission(Vec3::ZERO, -ls.wi), EmissionPdfs { pos: 1.0, dir: cone });
        assert_eq!(spot.pdf_emission(Vec3::ZERO, Vec3::Y).dir, 0.0, "outside the cone");
        let sun = Light::directional(-Vec3::Y, Rgb::splat(3.0), (-Vec3::ONE, Vec3::ONE));
        let ls = sun.sample_li(p, &mut s).unwrap();
        assert_eq!(
            (ls.wi, ls.dist, ls.value, ls.pdf),
            (Vec3::Y, f32::INFINITY, Rgb::splat(3.0), None)
        );
        let Light::Directional { edge_s, edge_t, .. } = sun else { unreachable!() };
        let pos = 1.0 / edge_s.cross(edge_t).length();
        assert_eq!(sun.pdf_emission(Vec3::ZERO, -ls.wi), EmissionPdfs { pos, dir: 1.0 });
    }

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
