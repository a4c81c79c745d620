//! Environment lights: radiance that arrives from infinitely far away, from every direction —
//! a sky, an HDR photograph of one, or a constant.
//!
//! A map is a latitude–longitude image in Mitsuba 3's `envmap` convention (so that the same EXR
//! means the same sky in both renderers): row 0 at the zenith (+y, before the light's rotation),
//! the direction of texture coordinates (u, v) ∈ [0, 1]² being
//!
//!   ω = (sin θ sin φ, cos θ, −sin θ cos φ),  θ = π v,  φ = 2π u,
//!
//! so u = 0.5 looks along +z and u = 0.25 along +x. Radiance is constant over each texel
//! (nearest lookup), which keeps it exactly proportional to the sampling density below.
//!
//! **Sampling.** Next-event estimation and photon emission draw directions from a 2-D
//! piecewise-constant density over the texels, proportional to each texel's luminance times
//! sin θ at its centre (the texel's share of solid angle): pdf(ω) = p(u, v) / (2π² sin θ) per
//! steradian. pbrt-v4 subtracts the map's mean before building its density (directions darker
//! than the mean are left to BSDF sampling under MIS); haze does not, because several of its
//! estimators use next-event estimation alone at some vertices (the path tracer's last vertex,
//! the hybrid's single scattering along a segment's light part when no phase sample follows),
//! where a density that is zero over part of the sky would lose that part's light. A constant
//! environment is sampled uniformly over the sphere.
//!
//! **Photons** leave a disc of radius R perpendicular to their direction, outside the scene's
//! bounding sphere (centre c, radius R) on the side the light comes from: a direction ω is drawn
//! as above, the photon travels along −ω from c + R ω + R (x s + y t), (x, y) uniform on the unit
//! disc. Every point of the scene is reached from every direction, and the photon carries
//! L(ω) π R² / pdf(ω): the environment's power is Φ = π R² ∫ L dω.
//!
//! **Choosing it among lights.** Next-event estimation weighs the environment, beside the other
//! lights, by the irradiance it brings a receiver (`LightTree`): ∫ L max(0, n · ω) dω at a
//! surface of normal n, from a table over 32 × 16 normals, and ∫ L dω in a medium; never less
//! than a hundredth of the mean over normals, so that no receiver misses it where the table's
//! coarse normals would say zero.

use crate::error::{Error, Result};
use crate::math::{
    Frame, Rgb, latlong_direction as direction_of, latlong_uv as uv_of, luminance,
    sample_concentric_disc, sample_uniform_sphere,
};
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;
use std::path::Path;
use std::sync::Arc;

/// The largest environment map haze reads, in texels (16384 × 8192).
pub const MAX_MAP_TEXELS: u64 = 1 << 27;

/// A latitude–longitude radiance image (module docs for the convention).
#[derive(Clone, PartialEq)]
pub struct EnvMap {
    width: u32,
    height: u32,
    /// Row-major, row 0 at the zenith.
    texels: Vec<Rgb>,
    /// SHA-256 of the size and texels, for the scene's fingerprint.
    digest: [u8; 32],
}

impl std::fmt::Debug for EnvMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let hex: String = self.digest.iter().map(|b| format!("{b:02x}")).collect();
        write!(f, "EnvMap({}×{}, sha256 {hex})", self.width, self.height)
    }
}

impl EnvMap {
    /// A map from `width` × `height` texels (row-major, row 0 at the zenith). Errors say what is
    /// wrong: a size that does not match, an empty or oversized map, a negative or non-finite
    /// texel (with its position).
    pub fn new(
        width: u32,
        height: u32,
        texels: Vec<[f32; 3]>,
    ) -> std::result::Result<Self, String> {
        let n = width as u64 * height as u64;
        if n == 0 {
            return Err(format!("a {width} × {height} map has no texels"));
        }
        if n > MAX_MAP_TEXELS {
            return Err(format!(
                "{width} × {height} texels, more than haze reads ({MAX_MAP_TEXELS})"
            ));
        }
        if texels.len() as u64 != n {
            return Err(format!("{} texels for a {width} × {height} map", texels.len()));
        }
        if let Some(i) = texels.iter().position(|t| t.iter().any(|c| !c.is_finite() || *c < 0.0)) {
            let (x, y) = (i % width as usize, i / width as usize);
            return Err(format!(
                "texel ({x}, {y}) is {:?}: radiance must be finite and non-negative",
                texels[i]
            ));
        }
        use sha2::Digest;
        let mut h = sha2::Sha256::new();
        h.update(b"haze environment map 1\n");
        h.update(width.to_le_bytes());
        h.update(height.to_le_bytes());
        for t in &texels {
            for c in t {
                h.update(c.to_le_bytes());
            }
        }
        let texels = texels.into_iter().map(Rgb::from).collect();
        Ok(Self { width, height, texels, digest: h.finalize().into() })
    }

    /// Reads the first RGB layer of an OpenEXR file. Errors name the file. A file larger than
    /// the largest map uncompressed (16 bytes a texel: float RGBA) and 1 MiB of header is
    /// refused unread.
    pub fn load(path: &Path) -> Result<Self> {
        let most = 16 * MAX_MAP_TEXELS + (1 << 20);
        Self::from_bytes(&crate::input::read_bounded(path, most, "an environment map")?, path)
    }

    /// [`Self::load`] on an OpenEXR file's bytes (`path` names it in errors).
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        let (w, h, texels) =
            crate::input::rgb_exr_from_bytes(bytes, path, MAX_MAP_TEXELS, "an environment map")?;
        Self::new(w, h, texels)
            .map_err(|message| Error::Image { path: path.to_path_buf(), message })
    }

    /// The daylight sky of `params` (`sky.rs`: Preetham et al.'s dome over a Lambertian ground)
    /// as a map `width` texels wide and half as high, and the sun's irradiance on a plane facing
    /// it. With `sun_in_map` the sun is also folded into the map — its irradiance spread over
    /// the solid angle of the texel it lies in, as in an HDR photograph whose solar disc is
    /// smaller than a texel — so that the map alone lights a scene; else it is left to a
    /// directional light. Errors: the parameters outside the model's limits
    /// ([`SkyParams::check`](super::sky::SkyParams::check), naming the field), a width outside
    /// [`WIDTHS`](super::sky::WIDTHS).
    pub fn sky(
        params: &super::sky::SkyParams,
        width: u32,
        sun_in_map: bool,
    ) -> std::result::Result<(Self, Rgb), String> {
        params.check().map_err(|(field, m)| format!("{field}: {m}"))?;
        let widths = super::sky::WIDTHS;
        if !widths.contains(&width) {
            let (lo, hi) = (widths.start(), widths.end());
            return Err(format!("a sky's map is {lo} to {hi} texels wide, not {width}"));
        }
        let (mut texels, w, h, sun) = super::sky::render(params, width);
        if sun_in_map && params.sun.y >= 0.0 {
            let uv = uv_of(params.sun.normalize());
            let x = ((uv.x * w as f32) as u32).min(w - 1);
            let y = ((uv.y * h as f32) as u32).min(h - 1);
            let (v0, v1) = (y as f32 / h as f32, (y + 1) as f32 / h as f32);
            let solid = 2.0 * PI / w as f32 * ((PI * v0).cos() - (PI * v1).cos());
            let t = &mut texels[(y * w + x) as usize];
            *t = (Rgb::from(*t) + sun / solid).to_array();
        }
        Ok((Self::new(w, h, texels)?, sun))
    }

    /// The map with every texel multiplied by `s`; an error if that makes a texel negative or
    /// not finite.
    pub fn scaled(self, s: f32) -> std::result::Result<Self, String> {
        let texels = self.texels.iter().map(|t| (*t * s).to_array()).collect();
        Self::new(self.width, self.height, texels)
    }

    /// Writes the map as a one-layer RGB OpenEXR file (ZIP-compressed), atomically.
    pub fn write_exr(&self, path: &Path) -> Result<()> {
        use exr::prelude::*;
        let w = self.width as usize;
        let channels = SpecificChannels::rgb(|p: exr::math::Vec2<usize>| {
            let t = self.texels[p.y() * w + p.x()];
            (t.x, t.y, t.z)
        });
        let size = (w, self.height as usize);
        let layer =
            Layer::new(size, LayerAttributes::named("sky"), Encoding::SMALL_LOSSLESS, channels);
        let image = Image::from_layer(layer);
        crate::atomic::write_atomically(path, |out| {
            image.write().to_buffered(out).map_err(|e| e.to_string())
        })
    }

    /// The radiance of the texel at column `x`, row `y` (row 0 at the zenith).
    pub fn texel(&self, x: u32, y: u32) -> [f32; 3] {
        self.at(x.min(self.width - 1), y.min(self.height - 1)).to_array()
    }

    /// Width and height in texels.
    pub fn size(&self) -> [u32; 2] {
        [self.width, self.height]
    }

    /// The texel at column `x`, row `y`.
    fn at(&self, x: u32, y: u32) -> Rgb {
        self.texels[(y * self.width + x) as usize]
    }

    /// The texel holding texture coordinates `uv`.
    fn lookup(&self, uv: Vec2) -> (u32, u32) {
        let x = ((uv.x * self.width as f32) as u32).min(self.width - 1);
        let y = ((uv.y * self.height as f32) as u32).min(self.height - 1);
        (x, y)
    }
}

/// A piecewise-constant density over [0, 1]² on a grid of cells: rows by their sums, then a
/// cell within the row.
#[derive(Clone, Debug)]
struct Distribution2D {
    width: usize,
    height: usize,
    /// Cumulative row sums, normalised (last = 1).
    rows: Vec<f32>,
    /// Per row, cumulative cell weights normalised within the row.
    cells: Vec<f32>,
    /// Each cell's density over [0, 1]²: weight · width · height / total.
    density: Vec<f32>,
}

impl Distribution2D {
    /// `None` if every weight is zero.
    fn new(weights: &[f64], width: usize, height: usize) -> Option<Self> {
        let total: f64 = weights.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let mut cells = Vec::with_capacity(weights.len());
        let mut rows = Vec::with_capacity(height);
        let mut running = 0.0f64;
        for row in weights.chunks(width) {
            let sum: f64 = row.iter().sum();
            let mut acc = 0.0f64;
            for w in row {
                acc += w;
                cells.push(if sum > 0.0 { (acc / sum) as f32 } else { 0.0 });
            }
            running += sum;
            rows.push((running / total) as f32);
        }
        let scale = (width * height) as f64 / total;
        let density = weights.iter().map(|w| (w * scale) as f32).collect();
        Some(Self { width, height, rows, cells, density })
    }

    /// The cell a cumulative table `cdf` assigns to `u`, and where `u` falls within it.
    fn find(cdf: &[f32], u: f32) -> (usize, f32) {
        let i = cdf.partition_point(|&c| c <= u).min(cdf.len() - 1);
        let lo = if i == 0 { 0.0 } else { cdf[i - 1] };
        let width = cdf[i] - lo;
        let frac = if width > 0.0 { ((u - lo) / width).clamp(0.0, ONE_BELOW) } else { 0.5 };
        (i, frac)
    }

    /// A point of [0, 1]² and its density.
    fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (y, fy) = Self::find(&self.rows, u.y);
        let row = &self.cells[y * self.width..(y + 1) * self.width];
        let (x, fx) = Self::find(row, u.x);
        let uv =
            Vec2::new((x as f32 + fx) / self.width as f32, (y as f32 + fy) / self.height as f32);
        (uv, self.density[y * self.width + x])
    }
}

/// The largest f32 below 1.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// Columns and rows of the irradiance table over normals (module docs).
const TABLE: (usize, usize) = (32, 16);

/// What the light tree needs to weigh an environment at a receiver: its irradiance by normal
/// (module docs).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct EnvImportance {
    /// Irradiance ∫ L max(0, n · ω) dω (mean channel) for normals at the centres of a world-space
    /// latitude–longitude grid of `TABLE` cells.
    table: Vec<f32>,
    /// ∫ L dω (mean channel): a medium receiver's.
    fluence: f32,
    /// The least importance at a surface.
    floor: f32,
}

impl EnvImportance {
    /// The importance at a receiver with normal `n` (`None`: in a medium).
    pub(crate) fn at(&self, n: Option<Vec3>) -> f32 {
        let Some(n) = n else { return self.fluence };
        let uv = uv_of(n);
        let x = ((uv.x * TABLE.0 as f32) as usize).min(TABLE.0 - 1);
        let y = ((uv.y * TABLE.1 as f32) as usize).min(TABLE.1 - 1);
        self.table[y * TABLE.0 + x].max(self.floor)
    }
}

/// An environment light, ready to render (module docs).
#[derive(Clone, Debug)]
pub struct Environment {
    /// The radiance image (a constant environment: `None`).
    map: Option<Arc<EnvMap>>,
    /// The constant radiance, or the map's multiplier.
    scale: Rgb,
    /// Local (map) directions to world and back.
    to_world: Mat3,
    to_local: Mat3,
    /// Over the map's texels (`None`: uniform over the sphere).
    distribution: Option<Distribution2D>,
    /// ∫ L dω per channel.
    integral: Rgb,
    /// Whether camera rays that leave the scene see it.
    pub visible: bool,
    /// The scene's bounding sphere, for photon emission.
    centre: Vec3,
    radius: f32,
    pub(crate) importance: EnvImportance,
}

impl Environment {
    /// An environment of radiance `scale` × the map's (or `scale` alone without a map), rotated
    /// by `to_world` (a rotation), around a scene of bounds `(lo, hi)`.
    pub(crate) fn new(
        map: Option<Arc<EnvMap>>,
        scale: Rgb,
        to_world: Mat3,
        visible: bool,
        (lo, hi): (Vec3, Vec3),
    ) -> Self {
        let centre = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length() * 1.01).max(1e-3);
        let (distribution, integral) = match &map {
            None => (None, scale * 4.0 * PI),
            Some(m) => texel_distribution(m, scale),
        };
        let mut env = Self {
            map,
            scale,
            to_world,
            to_local: to_world.transpose(),
            distribution,
            integral,
            visible,
            centre,
            radius,
            importance: EnvImportance { table: Vec::new(), fluence: 0.0, floor: 0.0 },
        };
        env.importance = env.irradiance_table();
        env
    }

    /// Radiance arriving from world direction `w` (pointing away from the scene).
    #[inline]
    pub fn radiance(&self, w: Vec3) -> Rgb {
        match &self.map {
            None => self.scale,
            Some(m) => {
                let (x, y) = m.lookup(uv_of(self.to_local * w));
                m.at(x, y) * self.scale
            }
        }
    }

    /// A direction towards the environment from two uniforms, and its density per steradian;
    /// `None` where the density is zero (a sample on a pole).
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let Some(d) = &self.distribution else {
            return Some((sample_uniform_sphere(u), 1.0 / (4.0 * PI)));
        };
        let (uv, p) = d.sample(u);
        let local = direction_of(uv);
        let sin_t = (PI * uv.y).sin();
        if !(sin_t > 0.0 && p > 0.0) {
            return None;
        }
        let w = (self.to_world * local).normalize();
        Some((w, p / (2.0 * PI * PI * sin_t)))
    }

    /// The density per steradian with which [`Self::sample`] draws world direction `w`.
    pub fn pdf(&self, w: Vec3) -> f32 {
        let Some(d) = &self.distribution else { return 1.0 / (4.0 * PI) };
        let local = (self.to_local * w).normalize();
        let sin_t = (local.x * local.x + local.z * local.z).sqrt();
        if sin_t <= 0.0 {
            return 0.0;
        }
        let uv = uv_of(local);
        let x = ((uv.x * d.width as f32) as usize).min(d.width - 1);
        let y = ((uv.y * d.height as f32) as usize).min(d.height - 1);
        d.density[y * d.width + x] / (2.0 * PI * PI * sin_t)
    }

    /// Emitted power, π R² ∫ L dω (W).
    pub fn power(&self) -> Rgb {
        self.integral * (PI * self.radius * self.radius)
    }

    /// The area of the emitting disc, π R².
    pub(crate) fn disc_area(&self) -> f32 {
        PI * self.radius * self.radius
    }

    /// A photon: origin on the disc (from `u_pos`), direction (from `u_dir`), power carried.
    pub(crate) fn sample_emission(&self, u_pos: Vec2, u_dir: Vec2) -> (Vec3, Vec3, Rgb) {
        let Some((w, pdf)) = self.sample(u_dir) else { return (self.centre, -Vec3::Y, Rgb::ZERO) };
        let frame = Frame::new(w);
        let disc = sample_concentric_disc(u_pos) * self.radius;
        let p = self.centre + w * self.radius + frame.s * disc.x + frame.t * disc.y;
        (p, -w, self.radiance(w) * (self.disc_area() / pdf))
    }

    /// The table of irradiance by normal (module docs), from the radiance at 4 × 4 points of
    /// each cell of a 64 × 32 world-space latitude–longitude grid.
    fn irradiance_table(&self) -> EnvImportance {
        const COARSE: (usize, usize) = (64, 32);
        let mut dirs = Vec::with_capacity(COARSE.0 * COARSE.1);
        for y in 0..COARSE.1 {
            for x in 0..COARSE.0 {
                let mut l = 0.0f64;
                for k in 0..16 {
                    let uv = Vec2::new(
                        (x as f32 + ((k % 4) as f32 + 0.5) / 4.0) / COARSE.0 as f32,
                        (y as f32 + ((k / 4) as f32 + 0.5) / 4.0) / COARSE.1 as f32,
                    );
                    l += luminance(self.radiance(direction_of(uv))) as f64 / 16.0;
                }
                let (v0, v1) = (y as f64 / COARSE.1 as f64, (y + 1) as f64 / COARSE.1 as f64);
                let pi = std::f64::consts::PI;
                let solid = 2.0 * pi / COARSE.0 as f64 * ((pi * v0).cos() - (pi * v1).cos());
                let centre = Vec2::new(
                    (x as f32 + 0.5) / COARSE.0 as f32,
                    (y as f32 + 0.5) / COARSE.1 as f32,
                );
                dirs.push((direction_of(centre), l * solid));
            }
        }
        let table: Vec<f32> = (0..TABLE.0 * TABLE.1)
            .map(|i| {
                let uv = Vec2::new(
                    ((i % TABLE.0) as f32 + 0.5) / TABLE.0 as f32,
                    ((i / TABLE.0) as f32 + 0.5) / TABLE.1 as f32,
                );
                let n = direction_of(uv);
                dirs.iter().map(|(w, e)| e * n.dot(*w).max(0.0) as f64).sum::<f64>() as f32
            })
            .collect();
        let mean = table.iter().map(|&e| e as f64).sum::<f64>() / table.len() as f64;
        EnvImportance { table, fluence: luminance(self.integral), floor: (0.01 * mean) as f32 }
    }
}

/// The density over a map's texels (luminance × sin θ at the texel's centre) and ∫ L dω.
fn texel_distribution(m: &EnvMap, scale: Rgb) -> (Option<Distribution2D>, Rgb) {
    let (w, h) = (m.width as usize, m.height as usize);
    let pi = std::f64::consts::PI;
    let mut weights = Vec::with_capacity(w * h);
    let mut integral = glam::DVec3::ZERO;
    for y in 0..h {
        let sin_c = (pi * (y as f64 + 0.5) / h as f64).sin();
        let solid = 2.0 * pi / w as f64
            * ((pi * y as f64 / h as f64).cos() - (pi * (y + 1) as f64 / h as f64).cos());
        for x in 0..w {
            let l = m.at(x as u32, y as u32) * scale;
            weights.push(luminance(l) as f64 * sin_c);
            integral += l.as_dvec3() * solid;
        }
    }
    (Distribution2D::new(&weights, w, h), integral.as_vec3())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{ChiSquare, Domain, Sample};

    /// A 16 × 8 sky: dim blue, brighter towards the horizon, a bright sun texel, black below the
    /// horizon but for one dim ground texel row.
    pub(crate) fn test_map() -> EnvMap {
        let (w, h) = (16u32, 8u32);
        let mut t = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let c = if y >= h / 2 {
                    if y == h - 1 { [0.05, 0.04, 0.03] } else { [0.0; 3] }
                } else if (x, y) == (5, 2) {
                    [500.0, 450.0, 400.0]
                } else {
                    [0.2 + 0.1 * y as f32, 0.3 + 0.1 * y as f32, 0.8]
                };
                t.push(c);
            }
        }
        EnvMap::new(w, h, t).unwrap()
    }

    fn rotated() -> Mat3 {
        Mat3::from_euler(glam::EulerRot::XYZ, 0.3, 1.1, -0.2)
    }

    /// The directions drawn follow the density `pdf` reports (chi-square over the sphere), for a
    /// rotated map and for a constant environment; each sample's density is the one `pdf` says.
    #[test]
    fn sampled_directions_follow_the_density() {
        let bounds = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let map = Environment::new(Some(Arc::new(test_map())), Rgb::ONE, rotated(), true, bounds);
        let constant = Environment::new(None, Rgb::splat(0.5), Mat3::IDENTITY, true, bounds);
        for (name, env) in [("map", &map), ("constant", &constant)] {
            let mut test =
                ChiSquare::new(format!("environment {name} directions"), Domain::Sphere, 2);
            // Coarser bins than the default 24 × 48: the map's density jumps at every texel edge
            // (and by 10³ at the sun), so each bin's expected count needs the harness's finest
            // quadrature, whose cost grows with the number of bins.
            test.bins = [12, 24];
            test.run(
                |s| {
                    let (w, pdf) = env.sample(s.next_2d())?;
                    assert!((env.pdf(w) / pdf - 1.0).abs() < 1e-3, "{} vs {pdf}", env.pdf(w));
                    Some(Sample::Direction(w))
                },
                |d| env.pdf(d.direction()) as f64,
            );
        }
    }

    /// The texture convention is Mitsuba's: u = 0.5 looks along −z … +z, u = 0.25 along +x, the
    /// top row at +y; and the lookup round-trips.
    #[test]
    fn directions_and_texture_coordinates_agree() {
        assert!((direction_of(Vec2::new(0.25, 0.5)) - Vec3::X).length() < 1e-6);
        assert!((direction_of(Vec2::new(0.5, 0.5)) - Vec3::Z).length() < 1e-6);
        assert!((direction_of(Vec2::new(0.0, 0.5)) - Vec3::NEG_Z).length() < 1e-6);
        assert!((direction_of(Vec2::new(0.3, 0.0)) - Vec3::Y).length() < 1e-6);
        for (u, v) in [(0.1, 0.2), (0.6, 0.7), (0.9, 0.45), (0.3, 0.99)] {
            let uv = uv_of(direction_of(Vec2::new(u, v)));
            assert!((uv - Vec2::new(u, v)).length() < 1e-5, "{u} {v}: {uv}");
        }
    }

    /// ∫ L dω by the map's texels equals a Monte Carlo estimate by uniform directions; the power
    /// is π R² times it; photons carry it on average (z-tests at the suite's significance).
    #[test]
    fn power_and_photons_agree_with_the_radiance() {
        let bounds = (Vec3::new(-1.0, 0.0, -2.0), Vec3::new(3.0, 1.0, 2.0));
        let env = Environment::new(Some(Arc::new(test_map())), Rgb::ONE, rotated(), true, bounds);
        let n = 400_000;
        let mut s = crate::rng::Sampler::new(4, crate::rng::Purpose::Other, 0, 0);
        let (mut sum, mut sq) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let l = luminance(env.radiance(sample_uniform_sphere(s.next_2d()))) as f64
                * 4.0
                * std::f64::consts::PI;
            sum += l;
            sq += l * l;
        }
        let mean = sum / n as f64;
        let se = ((sq / n as f64 - mean * mean) / n as f64).sqrt();
        let exact = luminance(env.integral) as f64;
        assert!(((mean - exact) / se).abs() < 3.29, "∫ L dω {exact} vs {mean} ± {se}");
        let (mut sum, mut sq) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let (p, d, beta) = env.sample_emission(s.next_2d(), s.next_2d());
            // Outside the bounding sphere, travelling into it.
            assert!((p - env.centre).length() >= env.radius * 0.999);
            assert!((env.centre - p).dot(d) > 0.0);
            let b = luminance(beta) as f64;
            sum += b;
            sq += b * b;
        }
        let mean = sum / n as f64;
        let se = ((sq / n as f64 - mean * mean) / n as f64).sqrt();
        let power = luminance(env.power()) as f64;
        assert!(((mean - power) / se).abs() < 3.29, "power {power} vs photons {mean} ± {se}");
    }

    /// The importance by normal is the irradiance: π L for a constant environment (within the
    /// table's quadrature), and zero-floored, never zero, under a sky black below the horizon.
    #[test]
    fn importance_is_the_irradiance() {
        let bounds = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let constant = Environment::new(None, Rgb::splat(2.0), Mat3::IDENTITY, true, bounds);
        for n in [Vec3::Y, Vec3::X, Vec3::new(0.3, -0.8, 0.5).normalize()] {
            let e = constant.importance.at(Some(n));
            assert!((e / (2.0 * PI) - 1.0).abs() < 0.01, "{n}: {e}");
        }
        assert!((constant.importance.at(None) / (8.0 * PI) - 1.0).abs() < 1e-5);
        let sky =
            Environment::new(Some(Arc::new(test_map())), Rgb::ONE, Mat3::IDENTITY, true, bounds);
        let (up, down) = (sky.importance.at(Some(Vec3::Y)), sky.importance.at(Some(-Vec3::Y)));
        assert!(up > 10.0 * down && down > 0.0, "up {up}, down {down}");
    }

    /// Importance sampling finds a sun texel: on a 256 × 128 map of dim sky (0.1) with one sun
    /// texel 10⁵ times brighter, next-event estimation at a surface facing up (f = cos / π)
    /// chooses the sun with probability its share of the map's L sin θ (to 1 %), and, given
    /// that, its estimate of the sun's part (f L / pdf times that probability) has a per-sample
    /// variance within 2× of an estimator that samples the sun texel alone, uniformly over its
    /// solid angle. The whole estimate's variance is larger by the choice between sun and sky,
    /// whose density leaves out the receiver's cosine (half the sky lies below the surface); that
    /// ratio is printed, as is uniform sampling's, for the record. 200,000 samples each.
    #[test]
    fn a_sun_texel_is_found_by_importance_sampling() {
        let (w, h) = (256u32, 128u32);
        let sun = (70u32, 30u32);
        let mut t = vec![[0.1f32; 3]; (w * h) as usize];
        t[(sun.1 * w + sun.0) as usize] = [1e4; 3];
        let bounds = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let map = Arc::new(EnvMap::new(w, h, t).unwrap());
        let env = Environment::new(Some(map.clone()), Rgb::ONE, Mat3::IDENTITY, true, bounds);
        let f = |d: Vec3| d.y.max(0.0) / PI;
        let n = 200_000;
        let mut s = crate::rng::Sampler::new(8, crate::rng::Purpose::Other, 0, 0);
        let variance = |xs: &[f64]| {
            let m = xs.iter().sum::<f64>() / xs.len() as f64;
            xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (xs.len() - 1) as f64
        };
        let pi = std::f64::consts::PI;
        let sin_c = (pi * (sun.1 as f64 + 0.5) / h as f64).sin();
        let all_weights: f64 = (0..h)
            .map(|y| (pi * (y as f64 + 0.5) / h as f64).sin() * (0.1 * (w - 1) as f64))
            .sum::<f64>()
            + 1e4 * sin_c
            - 0.1 * sin_c;
        let p_sun = 1e4 * sin_c / all_weights;
        let (mut whole, mut given_sun) = (Vec::new(), Vec::new());
        for _ in 0..n {
            let Some((d, pdf)) = env.sample(s.next_2d()) else {
                whole.push(0.0);
                continue;
            };
            let x = (f(d) * luminance(env.radiance(d)) / pdf) as f64;
            whole.push(x);
            if map.lookup(uv_of(d)) == sun {
                given_sun.push(x * p_sun);
            }
        }
        let chosen = given_sun.len() as f64 / n as f64;
        let se = (p_sun * (1.0 - p_sun) / n as f64).sqrt();
        assert!((chosen - p_sun).abs() < 4.0 * se + 1e-4, "sun chosen {chosen} vs {p_sun}");
        // The sun texel alone: cos θ uniform between its rows' bounds, φ uniform in its column.
        let c0 = (PI * sun.1 as f32 / h as f32).cos();
        let c1 = (PI * (sun.1 + 1) as f32 / h as f32).cos();
        let solid = 2.0 * PI / w as f32 * (c0 - c1);
        let alone: Vec<f64> = (0..n)
            .map(|_| {
                let u = s.next_2d();
                let v = (c0 + u.y * (c1 - c0)).acos() / PI;
                let d = direction_of(Vec2::new((sun.0 as f32 + u.x) / w as f32, v));
                (f(d) * 1e4 * solid) as f64
            })
            .collect();
        let uniform: Vec<f64> = (0..n)
            .map(|_| {
                let d = sample_uniform_sphere(s.next_2d());
                (f(d) * luminance(env.radiance(d)) * 4.0 * PI) as f64
            })
            .collect();
        let v_alone = variance(&alone);
        let ratio = variance(&given_sun) / v_alone;
        eprintln!(
            "sun texel: chosen with p = {chosen:.4}; given the sun, variance {ratio:.3}× the sun \
             alone's; the whole estimate {:.0}×, uniform directions {:.0}×",
            variance(&whole) / v_alone,
            variance(&uniform) / v_alone
        );
        assert!(ratio < 2.0, "given the sun: {ratio}× the sun alone's variance");
    }

    /// A photon's emission densities are the ones its weight was made with: uniform over the
    /// disc, the environment's density of the direction it came from.
    #[test]
    fn emission_densities_match_the_photons() {
        let bounds = (Vec3::new(-2.0, 0.0, -1.0), Vec3::new(2.0, 3.0, 1.0));
        let env = Environment::new(Some(Arc::new(test_map())), Rgb::ONE, rotated(), true, bounds);
        let light = super::super::Light::Environment(Box::new(env.clone()));
        let mut s = crate::rng::Sampler::new(2, crate::rng::Purpose::Other, 0, 0);
        for _ in 0..1000 {
            let e = light.sample_emission(0.5, s.next_2d(), s.next_2d());
            if e.beta == Rgb::ZERO {
                continue;
            }
            let pdfs = light.pdf_emission(e.n, e.d);
            assert!((pdfs.pos * env.disc_area() - 1.0).abs() < 1e-5);
            let want = env.radiance(-e.d) / (pdfs.pos * pdfs.dir);
            assert!(((e.beta - want).abs() / want.max(Rgb::splat(1e-6))).max_element() < 1e-3);
        }
    }

    #[test]
    fn bad_maps_are_refused_with_a_reason() {
        assert!(EnvMap::new(0, 4, vec![]).unwrap_err().contains("no texels"));
        assert!(EnvMap::new(2, 2, vec![[0.0; 3]; 3]).unwrap_err().contains("3 texels"));
        let mut t = vec![[0.0; 3]; 4];
        t[3] = [0.0, f32::NAN, 0.0];
        assert!(EnvMap::new(2, 2, t).unwrap_err().contains("texel (1, 1)"));
        let mut t = vec![[0.0; 3]; 4];
        t[1] = [-1.0, 0.0, 0.0];
        assert!(EnvMap::new(2, 2, t).unwrap_err().contains("texel (1, 0)"));
    }
}
