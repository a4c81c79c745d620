//! Ray sets for measuring the accelerator alone (`haze bench rays`): the queries every part of
//! haze makes — closest hits and occlusion — on rays like the ones it casts, and the geometry and
//! rays written out so that another ray tracer (Embree, through `benches/embree/rays.c`) can
//! trace exactly the same ones.
//!
//! Three sets, each a pure function of the scene, the count and the seed:
//! - **camera**: one ray per pixel in scanline order, jittered within the pixel (repeated over
//!   the image until there are enough) — coherent;
//! - **incoherent**: origins uniform in the scene's bounding box, directions uniform on the
//!   sphere, unbounded — what photon paths and path-traced bounces look like;
//! - **shadow**: from points on surfaces (where incoherent rays first hit, moved off the surface)
//!   to a point sampled on a light chosen uniformly, bounded just short of it (unbounded towards
//!   a directional light).

use crate::error::Result;
use crate::math::{offset_origin, sample_uniform_sphere};
use crate::rng::{Purpose, Sampler};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use std::io::Write;
use std::path::Path;

/// A query: the ray `o + t d` for 0 < t < `t_max` (`d` unit length).
#[derive(Clone, Copy, Debug)]
pub struct QueryRay {
    /// Origin.
    pub o: Vec3,
    /// Unit direction.
    pub d: Vec3,
    /// End of the ray (may be infinite).
    pub t_max: f32,
}

/// A named set of rays.
#[derive(Clone, Debug)]
pub struct RaySet {
    /// `camera`, `incoherent` or `shadow`.
    pub name: &'static str,
    /// The rays.
    pub rays: Vec<QueryRay>,
}

/// The three ray sets of `count` rays each for `scene` (module docs).
pub fn ray_sets(scene: &Scene, count: usize, seed: u64) -> Vec<RaySet> {
    let mut s = Sampler::new(seed, Purpose::Benchmark, 0, 0);
    let [w, h] = scene.camera.resolution;
    let pixels = (w as usize * h as usize).max(1);
    let camera = (0..count)
        .map(|i| {
            let k = i % pixels;
            let pixel = Vec2::new((k % w as usize) as f32, (k / w as usize) as f32) + s.next_2d();
            let r = scene.camera.generate_ray(pixel, s.next_2d());
            QueryRay { o: r.o, d: r.d, t_max: f32::INFINITY }
        })
        .collect();
    let (lo, hi) = scene.bounds;
    let random_ray = |s: &mut Sampler| QueryRay {
        o: lo + (hi - lo) * Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()),
        d: sample_uniform_sphere(s.next_2d()),
        t_max: f32::INFINITY,
    };
    let incoherent = (0..count).map(|_| random_ray(&mut s)).collect();
    let mut shadow = Vec::with_capacity(count);
    if !scene.lights.is_empty() {
        // Surface points: the first hits of random rays (bounded tries, for scenes that are
        // mostly empty space).
        let mut tries = 0usize;
        while shadow.len() < count && tries < 64 * count.max(1) {
            tries += 1;
            let r = random_ray(&mut s);
            let Some(hit) = scene.accel.intersect(r.o, r.d, r.t_max) else { continue };
            let light = &scene.lights
                [((s.next_f32() * scene.lights.len() as f32) as usize).min(scene.lights.len() - 1)];
            let Some(ls) = light.sample_li(hit.p, &mut s) else { continue };
            let o = offset_origin(hit.p, hit.ng, ls.wi);
            shadow.push(QueryRay { o, d: ls.wi, t_max: ls.dist });
        }
    }
    vec![
        RaySet { name: "camera", rays: camera },
        RaySet { name: "incoherent", rays: incoherent },
        RaySet { name: "shadow", rays: shadow },
    ]
}

/// Closest-hit queries for every ray of `rays`; returns how many hit.
pub fn closest_hits(scene: &Scene, rays: &[QueryRay]) -> usize {
    rays.iter().filter(|r| scene.accel.intersect(r.o, r.d, r.t_max).is_some()).count()
}

/// Occlusion queries for every ray of `rays`; returns how many are blocked.
pub fn occlusions(scene: &Scene, rays: &[QueryRay]) -> usize {
    rays.iter().filter(|r| scene.accel.occluded(r.o, r.d, r.t_max)).count()
}

/// Triangles (three vertices each) and spheres (centre, radius) of the scene's geometry.
pub fn geometry(scene: &Scene) -> (Vec<[Vec3; 3]>, Vec<(Vec3, f32)>) {
    scene.accel.primitives()
}

/// Writes the scene's geometry and `sets` to `path` in the format `benches/embree/rays.c`
/// reads (described there).
pub fn export(path: &Path, scene: &Scene, sets: &[RaySet]) -> Result<()> {
    let (tris, spheres) = geometry(scene);
    let mut b: Vec<u8> = Vec::new();
    let u32s = |b: &mut Vec<u8>, v: usize| b.extend_from_slice(&(v as u32).to_le_bytes());
    let floats = |b: &mut Vec<u8>, xs: &[f32]| xs.iter().for_each(|x| b.extend(x.to_le_bytes()));
    b.extend_from_slice(b"HZRB");
    u32s(&mut b, 1);
    u32s(&mut b, tris.len());
    for t in &tris {
        for v in t {
            floats(&mut b, &v.to_array());
        }
    }
    u32s(&mut b, spheres.len());
    for (c, r) in &spheres {
        floats(&mut b, &[c.x, c.y, c.z, *r]);
    }
    u32s(&mut b, sets.len());
    for set in sets {
        u32s(&mut b, set.name.len());
        b.extend_from_slice(set.name.as_bytes());
        u32s(&mut b, set.rays.len());
        for r in &set.rays {
            floats(&mut b, &[r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.t_max]);
        }
    }
    crate::atomic::write_atomically(path, |w| w.write_all(&b).map_err(|e| e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ray is occluded exactly when it has a closest hit, on every set of every kind of scene
    /// (triangles, spheres, pass-through interfaces); the sets are a function of the seed.
    #[test]
    fn occlusion_agrees_with_closest_hits_and_sets_repeat() {
        let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        for name in ["cornell-fog.toml", "glass-caustic.toml", "volumetric-caustic.toml"] {
            let scene = Scene::load(scenes.join(name)).unwrap();
            let sets = ray_sets(&scene, 2000, 3);
            assert_eq!(sets.len(), 3);
            for set in &sets {
                assert_eq!(set.rays.len(), 2000, "{name} {}", set.name);
                for r in &set.rays {
                    let hit = scene.accel.intersect(r.o, r.d, r.t_max).is_some();
                    assert_eq!(hit, scene.accel.occluded(r.o, r.d, r.t_max), "{name} {r:?}");
                }
                assert_eq!(closest_hits(&scene, &set.rays), occlusions(&scene, &set.rays));
            }
            let again = ray_sets(&scene, 2000, 3);
            for (a, b) in sets.iter().zip(&again) {
                assert!(a.rays.iter().zip(&b.rays).all(|(x, y)| x.o == y.o && x.d == y.d));
            }
            // Camera rays of a closed room all hit; incoherent rays from inside it too.
            if name == "cornell-fog.toml" {
                assert_eq!(closest_hits(&scene, &sets[0].rays), 2000);
            }
        }
    }
}
