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

use crate::math::sample_concentric_disc;
use glam::{Vec2, Vec3};

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
    /// Builds a camera looking from `position` at `look_at`. The caller validates that the two
    /// points differ and `up` is not parallel to the view direction.
    pub fn new(
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
