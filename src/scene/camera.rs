//! Cameras: a perspective camera with an optional thin lens (depth of field) and an orthographic
//! camera for measurement scenes.
//!
//! ```toml
//! [camera]
//! type = "perspective"      # or "orthographic" (with `height`, the view's height in world units)
//! position = [0, 1, 3.9]
//! look_at = [0, 1, 0]
//! up = [0, 1, 0]            # default
//! fov = 39.3                # vertical field of view, degrees
//! resolution = [512, 512]
//! aperture = 0.02           # lens radius; 0 (default) is a pinhole
//! focus_distance = 3.9      # default: distance from position to look_at
//! ```

use super::describe::MediumRef;
use crate::math::sample_concentric_disc;
use glam::{Vec2, Vec3};

/// Largest image: 64 Mpixel (the film holds 48 bytes per pixel).
pub const MAX_PIXELS: u64 = 1 << 26;

/// A camera as the scene file's `[camera]` table describes it.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    /// Eye position (lens centre).
    pub position: Vec3,
    /// The point looked at (must differ from `position`).
    pub look_at: Vec3,
    /// The up direction (not parallel to the view direction).
    pub up: Vec3,
    /// Image width and height in pixels (1 to [`MAX_PIXELS`] pixels in all).
    pub resolution: [u32; 2],
    /// How the camera projects.
    pub lens: Lens,
    /// The medium around the camera (vacuum if `None`).
    pub medium: Option<MediumRef>,
}

/// A camera's projection as described.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lens {
    /// Pinhole or thin lens.
    Perspective {
        /// Vertical field of view in degrees, in (0, 180).
        fov: f32,
        /// Lens radius (0: a pinhole).
        aperture: f32,
        /// Distance to the plane in focus (default: from `position` to `look_at`).
        focus_distance: Option<f32>,
    },
    /// Parallel rays.
    Orthographic {
        /// Height of the view in scene units.
        height: f32,
    },
}

impl CameraDesc {
    /// A pinhole camera at `position` looking at `look_at` with a vertical field of view of
    /// `fov` degrees; 512 × 512 pixels and up = +y until said otherwise.
    pub fn perspective(position: impl Into<Vec3>, look_at: impl Into<Vec3>, fov: f32) -> Self {
        let lens = Lens::Perspective { fov, aperture: 0.0, focus_distance: None };
        Self::with_lens(position.into(), look_at.into(), lens)
    }

    /// An orthographic camera whose view is `height` scene units high.
    pub fn orthographic(position: impl Into<Vec3>, look_at: impl Into<Vec3>, height: f32) -> Self {
        Self::with_lens(position.into(), look_at.into(), Lens::Orthographic { height })
    }

    fn with_lens(position: Vec3, look_at: Vec3, lens: Lens) -> Self {
        Self { position, look_at, up: Vec3::Y, resolution: [512, 512], lens, medium: None }
    }

    /// Sets the image size in pixels.
    pub fn resolution(mut self, width: u32, height: u32) -> Self {
        self.resolution = [width, height];
        self
    }

    /// Sets the up direction.
    pub fn up(mut self, up: impl Into<Vec3>) -> Self {
        self.up = up.into();
        self
    }

    /// A thin lens of radius `aperture` focused at `focus_distance` (perspective cameras).
    pub fn aperture(mut self, aperture: f32, focus_distance: Option<f32>) -> Self {
        if let Lens::Perspective { aperture: a, focus_distance: f, .. } = &mut self.lens {
            (*a, *f) = (aperture, focus_distance);
        }
        self
    }

    /// The medium the camera sits in.
    pub fn medium(mut self, m: impl Into<MediumRef>) -> Self {
        self.medium = Some(m.into());
        self
    }
}

/// Checks a camera resolution: 1 to [`MAX_PIXELS`] pixels in all.
pub fn check_resolution(resolution: [u32; 2]) -> Result<(), String> {
    let pixels = resolution[0] as u64 * resolution[1] as u64;
    if resolution[0] == 0 || resolution[1] == 0 || pixels > MAX_PIXELS {
        return Err(format!("needs 1 to {MAX_PIXELS} pixels in all, got {resolution:?}"));
    }
    Ok(())
}

/// How the camera projects.
#[derive(Clone, Debug)]
pub enum Projection {
    /// Pinhole or thin lens.
    Perspective {
        /// tan(fov / 2).
        tan_half_fov: f32,
        /// Lens radius (0: pinhole).
        lens_radius: f32,
        /// Distance to the plane in focus.
        focus_distance: f32,
    },
    /// Parallel rays.
    Orthographic {
        /// Height of the view in world units.
        height: f32,
    },
}

/// A camera ray: origin and unit direction.
#[derive(Clone, Copy, Debug)]
pub struct CameraRay {
    /// Origin.
    pub o: Vec3,
    /// Unit direction.
    pub d: Vec3,
}

/// A camera.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Projection.
    pub projection: Projection,
    /// Eye position (lens centre).
    pub position: Vec3,
    /// Viewing direction (unit).
    pub forward: Vec3,
    /// Image right (unit).
    pub right: Vec3,
    /// Image up (unit).
    pub up: Vec3,
    /// Image width and height in pixels.
    pub resolution: [u32; 2],
}

impl Camera {
    /// The camera a description asks for, or the key (`camera.fov`, …) and what is wrong with it.
    pub(crate) fn from_desc(d: &CameraDesc) -> Result<Camera, (String, String)> {
        let err = |k: &str, m: String| Err((format!("camera.{k}"), m));
        for (k, v) in [("position", d.position), ("look_at", d.look_at), ("up", d.up)] {
            if !v.is_finite() {
                return err(k, format!("must be finite, got {v}"));
            }
            if v.abs().max_element() > super::describe::MAX_COORDINATE {
                return err(k, format!("{v} lies outside ±{}", super::describe::MAX_COORDINATE));
            }
        }
        let dist = (d.look_at - d.position).length();
        if dist == 0.0 {
            return err("look_at", "must differ from position".into());
        }
        if (d.look_at - d.position).normalize().cross(d.up).length() < 1e-6 {
            return err("up", "must not be parallel to the viewing direction".into());
        }
        if let Err(m) = check_resolution(d.resolution) {
            return err("resolution", m);
        }
        let projection = match d.lens {
            Lens::Perspective { fov, aperture, focus_distance } => {
                if !(fov > 0.0 && fov < 180.0) {
                    return err("fov", format!("must lie in (0, 180) degrees, got {fov}"));
                }
                if !(aperture.is_finite() && aperture >= 0.0) {
                    return err(
                        "aperture",
                        format!("must be a non-negative radius, got {aperture}"),
                    );
                }
                let focus_distance = focus_distance.unwrap_or(dist);
                if !(focus_distance.is_finite() && focus_distance > 0.0) {
                    return err(
                        "focus_distance",
                        format!("must be positive, got {focus_distance}"),
                    );
                }
                Projection::Perspective {
                    tan_half_fov: (fov.to_radians() * 0.5).tan(),
                    lens_radius: aperture,
                    focus_distance,
                }
            }
            Lens::Orthographic { height } => {
                if !(height.is_finite() && height > 0.0) {
                    return err("height", format!("must be positive, got {height}"));
                }
                Projection::Orthographic { height }
            }
        };
        Ok(Camera::new(projection, d.position, d.look_at, d.up, d.resolution))
    }

    /// Builds a camera looking from `position` at `look_at`. The caller validates that the two
    /// points differ and `up` is not parallel to the view direction.
    pub(crate) fn new(
        projection: Projection,
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        resolution: [u32; 2],
    ) -> Self {
        let forward = (look_at - position).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        Self { projection, position, forward, right, up, resolution }
    }

    /// Width / height.
    pub fn aspect(&self) -> f32 {
        self.resolution[0] as f32 / self.resolution[1] as f32
    }

    /// The ray through continuous pixel position `pixel` (x right, y down, in pixels), with
    /// `lens` a uniform sample for the aperture.
    pub fn generate_ray(&self, pixel: Vec2, lens: Vec2) -> CameraRay {
        let [w, h] = self.resolution;
        let sx = 2.0 * pixel.x / w as f32 - 1.0;
        let sy = 1.0 - 2.0 * pixel.y / h as f32;
        match self.projection {
            Projection::Perspective { tan_half_fov, lens_radius, focus_distance } => {
                let d = (self.forward
                    + self.right * (sx * tan_half_fov * self.aspect())
                    + self.up * (sy * tan_half_fov))
                    .normalize();
                if lens_radius <= 0.0 {
                    return CameraRay { o: self.position, d };
                }
                let focus = self.position + d * (focus_distance / d.dot(self.forward));
                let l = sample_concentric_disc(lens) * lens_radius;
                let o = self.position + self.right * l.x + self.up * l.y;
                CameraRay { o, d: (focus - o).normalize() }
            }
            Projection::Orthographic { height } => {
                let o = self.position
                    + self.right * (sx * 0.5 * height * self.aspect())
                    + self.up * (sy * 0.5 * height);
                CameraRay { o, d: self.forward }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_forward_and_corners_match_fov() {
        let cam = Camera::new(
            Projection::Perspective {
                tan_half_fov: (45f32.to_radians() / 2.0).tan(),
                lens_radius: 0.0,
                focus_distance: 1.0,
            },
            Vec3::ZERO,
            -Vec3::Z,
            Vec3::Y,
            [200, 100],
        );
        let r = cam.generate_ray(Vec2::new(100.0, 50.0), Vec2::ZERO);
        assert!((r.d - -Vec3::Z).length() < 1e-6);
        let top = cam.generate_ray(Vec2::new(100.0, 0.0), Vec2::ZERO);
        assert!((top.d.angle_between(-Vec3::Z).to_degrees() - 22.5).abs() < 1e-3);
        assert!(top.d.y > 0.0);
        let right = cam.generate_ray(Vec2::new(200.0, 50.0), Vec2::ZERO);
        assert!(right.d.x > 0.0);
    }

    #[test]
    fn thin_lens_rays_meet_on_the_focus_plane() {
        let cam = Camera::new(
            Projection::Perspective { tan_half_fov: 0.5, lens_radius: 0.1, focus_distance: 3.0 },
            Vec3::ZERO,
            -Vec3::Z,
            Vec3::Y,
            [64, 64],
        );
        let px = Vec2::new(10.0, 20.0);
        let a = cam.generate_ray(px, Vec2::new(0.1, 0.9));
        let b = cam.generate_ray(px, Vec2::new(0.8, 0.3));
        let pa = a.o + a.d * (3.0 / -a.d.z);
        let pb = b.o + b.d * (3.0 / -b.d.z);
        assert!((pa - pb).length() < 1e-4);
    }
}
