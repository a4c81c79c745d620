//! Walking a ray through a uniform grid of unit cells (Amanatides & Woo 1987), shared by the
//! beam-query grid and the majorant grid of heterogeneous media.

use glam::{IVec3, Vec3};

/// Calls `f(cell, t_in, t_out)` for each cell of the grid [0, dims) (cell k spans [k, k + 1) on
/// each axis) that the ray o + t d crosses for t ∈ [0, t_max), in order, with the interval of t
/// spent in it; consecutive intervals share their end points exactly, so they partition the part
/// of [0, t_max) inside the grid. `d` need not be unit length: t is the caller's parameter.
/// Stops early when `f` returns `false`.
pub fn walk(o: Vec3, d: Vec3, t_max: f32, dims: IVec3, mut f: impl FnMut(IVec3, f32, f32) -> bool) {
    let inv = |x: f32| if x.abs() < 1e-30 { 1e30 } else { 1.0 / x };
    let inv_d = Vec3::new(inv(d.x), inv(d.y), inv(d.z));
    let t1 = (Vec3::ZERO - o) * inv_d;
    let t2 = (dims.as_vec3() - o) * inv_d;
    let t_start = t1.min(t2).max_element().max(0.0);
    let t_end = t1.max(t2).min_element().min(t_max);
    if t_start.partial_cmp(&t_end) != Some(std::cmp::Ordering::Less) {
        return;
    }
    let mut cell = (o + d * t_start).floor().as_ivec3().clamp(IVec3::ZERO, dims - 1);
    let step = IVec3::new(
        if d.x >= 0.0 { 1 } else { -1 },
        if d.y >= 0.0 { 1 } else { -1 },
        if d.z >= 0.0 { 1 } else { -1 },
    );
    let delta = inv_d.abs();
    let mut next = Vec3::ZERO;
    for a in 0..3 {
        let edge = (cell[a] + if step[a] > 0 { 1 } else { 0 }) as f32;
        next[a] = if d[a].abs() < 1e-30 { f32::INFINITY } else { (edge - o[a]) * inv_d[a] };
    }
    let mut t_in = t_start;
    loop {
        let t_out = next.min_element().min(t_end);
        if t_out > t_in && !f(cell, t_in, t_out) {
            return;
        }
        if t_out >= t_end {
            return;
        }
        // Step along the axis whose boundary comes first; leaving the grid ends the walk.
        let axis = if next.x <= next.y && next.x <= next.z {
            0
        } else if next.y <= next.z {
            1
        } else {
            2
        };
        cell[axis] += step[axis];
        next[axis] += delta[axis];
        if cell[axis] < 0 || cell[axis] >= dims[axis] {
            return;
        }
        t_in = t_out;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intervals_partition_the_segment_inside_the_grid() {
        let dims = IVec3::new(7, 5, 9);
        for (o, d) in [
            (Vec3::new(-1.0, 2.5, 4.5), Vec3::new(1.0, 0.3, -0.2)),
            (Vec3::new(3.5, 2.5, 4.5), Vec3::new(0.0, 0.0, 1.0)),
            (Vec3::new(6.9, 0.1, 8.9), Vec3::new(-2.0, 1.0, -3.0)),
        ] {
            let mut last = None::<f32>;
            walk(o, d, 100.0, dims, |cell, a, b| {
                assert!(a < b);
                if let Some(l) = last {
                    assert_eq!(l, a, "gap or overlap");
                }
                last = Some(b);
                let mid = o + d * (0.5 * (a + b));
                assert_eq!(mid.floor().as_ivec3(), cell, "midpoint outside its cell");
                true
            });
            assert!(last.is_some());
        }
    }
}
