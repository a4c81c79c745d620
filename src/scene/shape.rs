//! Shapes: triangle meshes (inline or Wavefront OBJ), rectangles, boxes and spheres (analytic, or
//! tessellated with interpolated normals), each placed by a transform.
//!
//! ```toml
//! [[shapes]]
//! type = "rectangle"        # size = [w, h] (default [1, 1]) in the xy-plane, centred, normal +z
//! size = [2, 2]
//! material = "white"
//! emission = [10, 10, 10]   # optional: makes the shape an area light (radiance, front side)
//! transform = { rotate = [-90, 0, 0], translate = [0, 0, 0] }
//!
//! [[shapes]]
//! type = "box"              # size = [x, y, z] (default [1, 1, 1]), centred at the origin
//! [[shapes]]
//! type = "sphere"           # center (default origin), radius; tessellate = N for an icosphere
//! [[shapes]]
//! type = "mesh"             # vertices = [[x,y,z], …], triangles = [[i,j,k], …], normals optional
//! [[shapes]]
//! type = "obj"              # file = "bunny.obj", relative to the scene file
//! [[shapes]]
//! type = "ply"              # file = "bunny.ply" (ASCII or binary), relative to the scene file
//! ```
//!
//! Transforms apply scale, then rotation (degrees about x, then y, then z), then translation.

use crate::error::{Error, Result};
use glam::{Affine3A, Mat3, Quat, Vec3};
use std::path::Path;

/// A triangle mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals, if any (same length as `positions`).
    pub normals: Option<Vec<Vec3>>,
    /// Triangles as vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// Applies an affine transform (normals by the inverse transpose).
    pub fn transformed(mut self, m: &Affine3A) -> Self {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        let nm = Mat3::from(m.matrix3).inverse().transpose();
        if let Some(ns) = &mut self.normals {
            for n in ns {
                *n = (nm * *n).normalize_or_zero();
            }
        }
        if m.matrix3.determinant() < 0.0 {
            // A mirroring transform flips winding; keep geometric normals outward.
            for t in &mut self.triangles {
                t.swap(1, 2);
            }
        }
        self
    }

    /// Vertices of every triangle.
    pub fn triangle_vertices(&self) -> impl Iterator<Item = [Vec3; 3]> + '_ {
        self.triangles.iter().map(|t| t.map(|i| self.positions[i as usize]))
    }
}

/// The transform matrix: translate · rotate_z · rotate_y · rotate_x · scale.
pub fn affine(scale: Vec3, rotate_deg: Vec3, translate: Vec3) -> Affine3A {
    let r = Quat::from_rotation_z(rotate_deg.z.to_radians())
        * Quat::from_rotation_y(rotate_deg.y.to_radians())
        * Quat::from_rotation_x(rotate_deg.x.to_radians());
    Affine3A::from_scale_rotation_translation(scale, r, translate)
}

/// A w × h rectangle in the xy-plane, centred, facing +z.
pub fn rectangle(w: f32, h: f32) -> Mesh {
    let (x, y) = (0.5 * w, 0.5 * h);
    Mesh {
        positions: vec![
            Vec3::new(-x, -y, 0.0),
            Vec3::new(x, -y, 0.0),
            Vec3::new(x, y, 0.0),
            Vec3::new(-x, y, 0.0),
        ],
        normals: None,
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// An axis-aligned box of the given size, centred, with outward faces.
pub fn cuboid(size: Vec3) -> Mesh {
    let h = 0.5 * size;
    let mut mesh = Mesh::default();
    // Each face: outward normal axis and the two in-plane axes ordered so (u × v) = normal.
    let faces = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (-Vec3::X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (-Vec3::Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (-Vec3::Z, Vec3::Y, Vec3::X),
    ];
    for (n, u, v) in faces {
        let base = mesh.positions.len() as u32;
        for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            mesh.positions.push((n + u * a + v * b) * h);
        }
        mesh.triangles.push([base, base + 1, base + 2]);
        mesh.triangles.push([base, base + 2, base + 3]);
    }
    mesh
}

/// An icosphere: an icosahedron subdivided `level` times and projected onto the sphere, with
/// normals interpolated from the true sphere normals.
pub fn icosphere(center: Vec3, radius: f32, level: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut midpoints = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, positions: &mut Vec<Vec3>| -> u32 {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = mid(a, b, &mut positions);
            let bc = mid(b, c, &mut positions);
            let ca = mid(c, a, &mut positions);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    let normals = positions.clone();
    Mesh {
        positions: positions.iter().map(|&p| center + p * radius).collect(),
        normals: Some(normals),
        triangles,
    }
}

/// Largest OBJ file read (bytes).
pub const MAX_OBJ_BYTES: u64 = 2 << 30;

/// Loads every object of a Wavefront OBJ file as one triangle mesh. Material libraries
/// (`mtllib`) are never opened: haze takes materials from the scene file.
pub(crate) fn load_obj(path: &Path) -> Result<Mesh> {
    load_mesh(path, "an OBJ file", obj_from_bytes)
}

/// Reads the mesh file `path` (`what` it is, for messages; at most [`MAX_OBJ_BYTES`]) and parses
/// its bytes with `parse`.
fn load_mesh(path: &Path, what: &str, parse: fn(&[u8], &Path) -> Result<Mesh>) -> Result<Mesh> {
    if !path.exists() {
        return Err(Error::Mesh { path: path.to_path_buf(), message: "no such file".into() });
    }
    parse(&crate::input::read_bounded(path, MAX_OBJ_BYTES, what)?, path)
}

/// Parses the bytes of a Wavefront OBJ file (`path` names it in messages) as one triangle mesh.
pub(crate) fn obj_from_bytes(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let mesh_err = |message: String| Error::Mesh { path: path.to_path_buf(), message };
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    let (models, _) =
        tobj::load_obj_buf(&mut &bytes[..], &opts, |_| Err(tobj::LoadError::OpenFileFailed))
            .map_err(|e| mesh_err(e.to_string()))?;
    let mut mesh = Mesh::default();
    let mut all_normals = true;
    let mut normals = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32;
        let count = m.positions.len() / 3;
        mesh.positions.extend(m.positions.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        if m.normals.len() == m.positions.len() {
            normals.extend(m.normals.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        } else {
            all_normals = false;
        }
        for t in m.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= count) {
                return Err(mesh_err(format!(
                    "face index out of range in object `{}`",
                    model.name
                )));
            }
            mesh.triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    if mesh.triangles.is_empty() {
        return Err(mesh_err("contains no faces".into()));
    }
    if all_normals {
        // Zero-length normals in the file would give NaN shading normals: ignore the normals then.
        if normals.iter().all(|n| n.is_finite() && n.length_squared() > 0.0) {
            mesh.normals = Some(normals.iter().map(|n| n.normalize()).collect());
        }
    }
    Ok(mesh)
}

/// Loads the mesh of a PLY file, ASCII or binary ([`ply_from_bytes`]).
pub(crate) fn load_ply(path: &Path) -> Result<Mesh> {
    load_mesh(path, "a PLY file", ply_from_bytes)
}

/// Parses the bytes of a PLY file (`path` names it in messages) through ply-rs-bw: the `vertex`
/// element's `x`, `y`, `z` (any numeric type) and, where every vertex has them, `nx`, `ny`,
/// `nz`; the `face` element's `vertex_indices` (or `vertex_index`) lists, polygons of more than
/// three vertices split into fans from their first vertex. Other elements and properties are
/// ignored.
pub(crate) fn ply_from_bytes(bytes: &[u8], path: &Path) -> Result<Mesh> {
    use ply_rs_bw::ply::Property;
    let mesh_err = |message: String| Error::Mesh { path: path.to_path_buf(), message };
    let parser = ply_rs_bw::parser::Parser::<ply_rs_bw::ply::DefaultElement>::new();
    let parsed = std::panic::catch_unwind(|| parser.read_ply(&mut &bytes[..]));
    let ply = match parsed {
        Ok(Ok(p)) => p,
        Ok(Err(e)) => {
            let text = e.to_string();
            return Err(mesh_err(format!("not a readable PLY file: {}", text.trim())));
        }
        Err(_) => return Err(mesh_err("not a readable PLY file (the reader failed)".into())),
    };
    let number = |p: Option<&Property>| -> Option<f32> {
        Some(match p? {
            Property::Float(v) => *v,
            Property::Double(v) => *v as f32,
            Property::Char(v) => *v as f32,
            Property::UChar(v) => *v as f32,
            Property::Short(v) => *v as f32,
            Property::UShort(v) => *v as f32,
            Property::Int(v) => *v as f32,
            Property::UInt(v) => *v as f32,
            _ => return None,
        })
    };
    let vertices = ply.payload.get("vertex").map_or(&[][..], |v| &v[..]);
    let mut mesh = Mesh::default();
    let mut normals = Vec::new();
    for (k, v) in vertices.iter().enumerate() {
        let p = [v.get("x"), v.get("y"), v.get("z")].map(number);
        let [Some(x), Some(y), Some(z)] = p else {
            return Err(mesh_err(format!("vertex {k} has no numeric x, y and z")));
        };
        mesh.positions.push(Vec3::new(x, y, z));
        if let [Some(a), Some(b), Some(c)] = [v.get("nx"), v.get("ny"), v.get("nz")].map(number) {
            normals.push(Vec3::new(a, b, c));
        }
    }
    let n = mesh.positions.len();
    let faces = ply.payload.get("face").map_or(&[][..], |f| &f[..]);
    for (k, f) in faces.iter().enumerate() {
        let list = f.get("vertex_indices").or_else(|| f.get("vertex_index"));
        let indices: Vec<i64> = match list {
            Some(Property::ListChar(l)) => l.iter().map(|&i| i as i64).collect(),
            Some(Property::ListUChar(l)) => l.iter().map(|&i| i as i64).collect(),
            Some(Property::ListShort(l)) => l.iter().map(|&i| i as i64).collect(),
            Some(Property::ListUShort(l)) => l.iter().map(|&i| i as i64).collect(),
            Some(Property::ListInt(l)) => l.iter().map(|&i| i as i64).collect(),
            Some(Property::ListUInt(l)) => l.iter().map(|&i| i as i64).collect(),
            _ => return Err(mesh_err(format!("face {k} has no integer vertex_indices list"))),
        };
        if let Some(&bad) = indices.iter().find(|&&i| i < 0 || i as usize >= n) {
            return Err(mesh_err(format!("face {k}: vertex index {bad} out of range (0..{n})")));
        }
        for j in 2..indices.len() {
            mesh.triangles.push([indices[0], indices[j - 1], indices[j]].map(|i| i as u32));
        }
    }
    if mesh.triangles.is_empty() {
        return Err(mesh_err("contains no faces".into()));
    }
    if normals.len() == n && normals.iter().all(|v| v.is_finite() && v.length_squared() > 0.0) {
        mesh.normals = Some(normals.iter().map(|v| v.normalize()).collect());
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn outward(mesh: &Mesh, centre: Vec3) -> bool {
        mesh.triangle_vertices().all(|[a, b, c]| {
            let n = (b - a).cross(c - a);
            n.dot((a + b + c) / 3.0 - centre) > 0.0
        })
    }

    #[test]
    fn closed_shapes_face_outward_even_when_mirrored() {
        assert!(outward(&cuboid(Vec3::new(1.0, 2.0, 3.0)), Vec3::ZERO));
        assert!(outward(&icosphere(Vec3::ONE, 2.0, 2), Vec3::ONE));
        let m = affine(Vec3::new(-1.0, 1.0, 1.0), Vec3::new(10.0, 20.0, 30.0), Vec3::X);
        assert!(outward(&cuboid(Vec3::ONE).transformed(&m), Vec3::X));
    }

    #[test]
    fn rectangle_faces_plus_z_and_rotates_to_floor() {
        let m = affine(Vec3::ONE, Vec3::new(-90.0, 0.0, 0.0), Vec3::ZERO);
        let [a, b, c] = rectangle(2.0, 2.0).transformed(&m).triangle_vertices().next().unwrap();
        let n = (b - a).cross(c - a).normalize();
        assert!((n - Vec3::Y).length() < 1e-5, "{n}");
    }
}
