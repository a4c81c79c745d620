//! Photon entries grouped into buckets — the cells of a grid or the bins of an image plane — built
//! by a parallel counting sort whose result does not depend on the thread count, and scanned four
//! at a time against a query ray.

use super::VolumePhoton;
use glam::{IVec3, Vec3, Vec4};
use rayon::prelude::*;

/// An inclusive box of buckets (empty when a coordinate of the first corner exceeds the second's).
pub(super) type Span = (IVec3, IVec3);

/// The empty span.
pub(super) const NO_SPAN: Span = (IVec3::ONE, IVec3::ZERO);

/// Bands filled in parallel: up to this many bands of whole z-slices where a grid has
/// [`BANDS_PER_THREAD`] slices per thread, else bands of rows (a row: the buckets of one y and z),
/// this many or [`BANDS_PER_THREAD`] per thread, whichever is more (fewer where the grid has
/// fewer rows). Each band reads only the photons that reach it, so more bands cost little; the
/// entries do not depend on the number of bands.
const BANDS: usize = 64;
/// Bands per thread: photons gather unevenly, so a thread needs several bands to even out.
const BANDS_PER_THREAD: usize = 8;
/// Photon lists by band made in parallel: this many per thread …
const LISTS_PER_THREAD: usize = 8;
/// … of at least this many photons each (a band reads every list, so lists are not made
/// smaller). The entries do not depend on the number of lists.
const LIST_MIN: usize = 1 << 11;

/// Photon entries grouped by bucket (a grid cell or a view bin): `start[b]..start[b + 1]` are
/// bucket b's entries, each the photon's position (read by every test) and its index.
#[derive(Default)]
pub(super) struct Entries {
    pub(super) start: Vec<u32>,
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    idx: Vec<u32>,
    /// Scratch, per work item of photons: the photons grouped by the bands they reach, and
    /// where each band's group starts.
    by_band: Vec<(Vec<u32>, Vec<u32>)>,
}

/// A query ray, splatted for four-wide tests.
pub(super) struct Lanes {
    o: Vec3,
    d: Vec3,
    r2: f32,
    ox: Vec4,
    oy: Vec4,
    oz: Vec4,
    dx: Vec4,
    dy: Vec4,
    dz: Vec4,
}

impl Lanes {
    pub(super) fn new(o: Vec3, d: Vec3, r: f32) -> Self {
        Self {
            o,
            d,
            r2: r * r,
            ox: Vec4::splat(o.x),
            oy: Vec4::splat(o.y),
            oz: Vec4::splat(o.z),
            dx: Vec4::splat(d.x),
            dy: Vec4::splat(d.y),
            dz: Vec4::splat(d.z),
        }
    }
}

/// The rows `r0..=r1` of a grid (row y + dims.y·z holds the buckets of that y and z), the
/// z-slices `z0..=z1` they lie in, and whether they are those slices whole.
#[derive(Clone, Copy)]
struct Rows {
    r0: i32,
    r1: i32,
    z0: i32,
    z1: i32,
    whole: bool,
}

/// Calls `f(bucket)` for every bucket of `span` that lies in `rows` of a grid of `dims` numbered
/// x-fastest.
#[inline(always)]
fn each_in_rows(span: &Span, dims: IVec3, rows: Rows, mut f: impl FnMut(usize)) {
    let (a, b) = span;
    let Rows { r0, r1, z0, z1, whole } = rows;
    for z in a.z.max(z0)..=b.z.min(z1) {
        let first = dims.y * z;
        let (y0, y1) = if whole { (a.y, b.y) } else { (a.y.max(r0 - first), b.y.min(r1 - first)) };
        for y in y0..=y1 {
            let row = (dims.x * (first + y)) as usize;
            for x in a.x..=b.x {
                f(row + x as usize);
            }
        }
    }
}

/// How a grid of `dims` is cut into bands: `count` bands of `rows` rows each (the last perhaps
/// fewer), whole z-slices (up to [`BANDS`] bands of them) where there are slices enough for
/// [`BANDS_PER_THREAD`] per thread, else rows, [`BANDS`] bands or [`BANDS_PER_THREAD`] per thread.
struct Bands {
    dims: IVec3,
    rows: usize,
    whole: bool,
    count: usize,
}

impl Bands {
    fn new(dims: IVec3) -> Self {
        let (y, slices) = (dims.y as usize, dims.z as usize);
        let want = BANDS_PER_THREAD * rayon::current_num_threads();
        let rows = if slices >= want {
            y * slices.div_ceil(BANDS)
        } else {
            (y * slices).div_ceil(want.max(BANDS))
        };
        Bands { dims, rows, whole: rows % y == 0, count: (y * slices).div_ceil(rows) }
    }

    /// Buckets in a band (the last perhaps fewer).
    fn buckets(&self) -> usize {
        self.dims.x as usize * self.rows
    }

    /// The rows of band `k`.
    fn of(&self, k: usize) -> Rows {
        let (r0, r1) = ((k * self.rows) as i32, ((k + 1) * self.rows) as i32 - 1);
        Rows { r0, r1, z0: r0 / self.dims.y, z1: r1 / self.dims.y, whole: self.whole }
    }

    /// Calls `f(k)` for every band k that `span` reaches, in order: the bands of its rows, which
    /// are consecutive where the bands are whole z-slices, the span covers every y or it lies in
    /// one z-slice, else in each of its z-slices those of its rows there.
    #[inline(always)]
    fn each(&self, span: &Span, mut f: impl FnMut(usize)) {
        let (a, b) = span;
        if a.x > b.x || a.y > b.y || a.z > b.z {
            return;
        }
        let (rows, dims) = (self.rows as u32, self.dims);
        let band = |y: i32, z: i32| (y + dims.y * z) as u32 / rows;
        if self.whole || b.y - a.y + 1 == dims.y || a.z == b.z {
            (band(a.y, a.z)..=band(b.y, b.z)).for_each(|k| f(k as usize));
            return;
        }
        let mut next = 0;
        for z in a.z..=b.z {
            let (k0, k1) = (band(a.y, z), band(b.y, z));
            (k0.max(next)..=k1).for_each(|k| f(k as usize));
            next = k1 + 1;
        }
    }
}

/// The projection t = v·d of the offset `v` from a ray's origin onto its direction `d`, and the
/// squared distance |v − t d|² from the ray, in the same operations as the four-wide scan.
///
/// The distance is computed from the offset to the foot of the perpendicular, never as
/// |v|² − t²: that difference cancels catastrophically in f32 when the distance is small against
/// t, and with d one rounding off unit length (|d|² − 1 ~ 10⁻⁷) it is off by 2(|d|² − 1)·t², which
/// at t = 3 is ~7 % of r² for r = 0.004 — a bias whose sign followed the rounding of the view
/// direction. |v − t d|² has no cancellation, and for |d| ≠ 1 it differs from the true distance
/// only by (|d|² − 1)²-order terms.
#[inline(always)]
pub(super) fn distance2(v: Vec3, d: Vec3) -> (f32, f32) {
    let t = v.x * d.x + v.y * d.y + v.z * d.z;
    let (px, py, pz) = (v.x - t * d.x, v.y - t * d.y, v.z - t * d.z);
    (t, px * px + py * py + pz * pz)
}

impl Entries {
    /// Fills the buckets, a grid of `dims` numbered x-fastest, by a counting sort: photon i
    /// enters every bucket of `spans[i]`. Each bucket lists its photons in index order, so the
    /// result does not depend on the thread count. Bands of rows are counted and scattered in
    /// parallel, each reading the photons that reach it (listed first, in parallel).
    pub(super) fn fill(&mut self, dims: IVec3, photons: &[VolumePhoton], spans: &[Span]) {
        let buckets = dims.element_product() as usize;
        let bands = Bands::new(dims);
        let band = bands.buckets();
        self.list_by_band(spans, &bands);
        let by_band = &self.by_band;
        // The photons that reach band k, in index order.
        let reaching = move |k: usize| {
            by_band.iter().flat_map(move |(list, at)| &list[at[k] as usize..at[k + 1] as usize])
        };
        crate::buffers::fill(&mut self.start, buckets + 1, 0);
        // Bands, of uneven photon counts, are handed out one at a time to whichever thread is
        // free (`par_bridge`; `integrator::frame::render_pixels_with` says why).
        self.start[1..].chunks_mut(band).enumerate().par_bridge().for_each(|(k, count)| {
            let rows = bands.of(k);
            for &i in reaching(k) {
                each_in_rows(&spans[i as usize], dims, rows, |b| count[b - k * band] += 1);
            }
        });
        // The counts' running sum, band by band in parallel from each band's offset (up to four
        // million cells: serial, it took milliseconds on one thread).
        let totals: Vec<u32> = self.start[1..].par_chunks(band).map(|c| c.iter().sum()).collect();
        let offsets = totals.iter().scan(0u32, |sum, &t| Some(std::mem::replace(sum, *sum + t)));
        let offsets: Vec<u32> = offsets.collect();
        self.start[1..].par_chunks_mut(band).zip(offsets).for_each(|(counts, mut sum)| {
            for c in counts {
                sum += *c;
                *c = sum;
            }
        });
        // Scatter the photon indices, each band into its own part of the entries.
        crate::buffers::scratch(&mut self.idx, self.start[buckets] as usize, 0);
        let mut parts = Vec::with_capacity(bands.count);
        let mut rest = &mut self.idx[..];
        for k in 0..bands.count {
            let (lo, hi) = (k * band, ((k + 1) * band).min(buckets));
            let (part, tail) = rest.split_at_mut((self.start[hi] - self.start[lo]) as usize);
            parts.push((k, part));
            rest = tail;
        }
        let start = &self.start;
        parts.into_iter().par_bridge().for_each(|(k, out)| {
            let lo = k * band;
            let hi = (lo + band).min(buckets);
            let mut cursor: Vec<u32> = start[lo..hi].iter().map(|&s| s - start[lo]).collect();
            let rows = bands.of(k);
            for &i in reaching(k) {
                each_in_rows(&spans[i as usize], dims, rows, |b| {
                    let c = &mut cursor[b - lo];
                    out[*c as usize] = i;
                    *c += 1;
                });
            }
        });
        // Gather the positions (sequential writes, in parallel).
        let n = self.idx.len();
        for v in [&mut self.x, &mut self.y, &mut self.z] {
            crate::buffers::scratch(v, n, 0.0);
        }
        const CHUNK: usize = 1 << 14;
        self.idx
            .par_chunks(CHUNK)
            .zip(self.x.par_chunks_mut(CHUNK))
            .zip(self.y.par_chunks_mut(CHUNK))
            .zip(self.z.par_chunks_mut(CHUNK))
            .for_each(|(((idx, x), y), z)| {
                for (k, &i) in idx.iter().enumerate() {
                    let p = photons[i as usize].p;
                    (x[k], y[k], z[k]) = (p.x, p.y, p.z);
                }
            });
    }

    /// Lists, per work item of photons, the photons that reach each of `bands` (in index order),
    /// in parallel.
    fn list_by_band(&mut self, spans: &[Span], bands: &Bands) {
        let chunk = crate::buffers::piece(spans.len(), LISTS_PER_THREAD, LIST_MIN);
        self.by_band.resize_with(spans.len().div_ceil(chunk), Default::default);
        let work = spans.chunks(chunk).zip(&mut self.by_band).enumerate();
        work.par_bridge().for_each(|(c, (spans, (list, at)))| {
            at.clear();
            at.resize(bands.count + 1, 0);
            for span in spans {
                bands.each(span, |k| at[k + 1] += 1);
            }
            for k in 0..bands.count {
                at[k + 1] += at[k];
            }
            list.resize(at[bands.count] as usize, 0);
            let mut cursor = at[..bands.count].to_vec();
            for (j, span) in spans.iter().enumerate() {
                bands.each(span, |k| {
                    list[cursor[k] as usize] = (c * chunk + j) as u32;
                    cursor[k] += 1;
                });
            }
        });
    }

    /// Calls `f(index, t_p, d²)` for every entry of bucket `b` within the radius of the ray whose
    /// projection t_p onto it satisfies t_p ≥ `t_lo`, t_p < `t_hi` and t_p > 0.
    #[inline(always)]
    pub(super) fn scan(
        &self,
        b: usize,
        ray: &Lanes,
        t_lo: f32,
        t_hi: f32,
        mut f: impl FnMut(u32, f32, f32),
    ) {
        let (s, e) = (self.start[b] as usize, self.start[b + 1] as usize);
        let (xs, ys, zs) = (&self.x[s..e], &self.y[s..e], &self.z[s..e]);
        let (lo, hi, r2) = (Vec4::splat(t_lo.max(0.0)), Vec4::splat(t_hi), Vec4::splat(ray.r2));
        // Four entries at a time (SSE through glam's Vec4), the rare hits one by one.
        let mut j = 0;
        while j + 4 <= xs.len() {
            let vx = Vec4::from_slice(&xs[j..j + 4]) - ray.ox;
            let vy = Vec4::from_slice(&ys[j..j + 4]) - ray.oy;
            let vz = Vec4::from_slice(&zs[j..j + 4]) - ray.oz;
            let t = vx * ray.dx + vy * ray.dy + vz * ray.dz;
            // The offset from the foot of the perpendicular, not |v|² − t²: that difference of
            // two large numbers cancels in f32, and with a direction whose length differs from 1
            // by ~10⁻⁷ it is off by ~2·10⁻⁷ t², a sizeable part of a small r² (see `distance2`).
            let (px, py, pz) = (vx - t * ray.dx, vy - t * ray.dy, vz - t * ray.dz);
            let d2 = px * px + py * py + pz * pz;
            let mut mask = (d2.cmplt(r2) & t.cmpge(lo) & t.cmplt(hi)).bitmask();
            while mask != 0 {
                let k = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if t[k] > 0.0 {
                    f(self.idx[s + j + k], t[k], d2[k]);
                }
            }
            j += 4;
        }
        for k in j..xs.len() {
            let (t, d2) = distance2(Vec3::new(xs[k], ys[k], zs[k]) - ray.o, ray.d);
            if d2 < ray.r2 && t >= t_lo && t < t_hi && t > 0.0 {
                f(self.idx[s + k], t, d2);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, Sampler};

    /// The entries list, bucket by bucket, exactly the photons whose span covers the bucket, in
    /// index order, whatever the number of threads (which sets the bands and lists): grids
    /// with many z-slices (bands of whole slices), few (bands of rows) and one row per slice
    /// (the view bins' layout), with spans of every shape, empty ones and the whole grid.
    #[test]
    fn buckets_list_their_photons_in_order_on_any_thread_count() {
        let mut s = Sampler::new(11, Purpose::Other, 0, 0);
        for dims in [IVec3::new(5, 7, 90), IVec3::new(6, 9, 3), IVec3::new(40, 1, 30)] {
            let n = 5000;
            let photons: Vec<VolumePhoton> = (0..n)
                .map(|_| VolumePhoton {
                    p: Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()),
                    ..Default::default()
                })
                .collect();
            let mut coord = |axis: usize| (s.next_f32() * dims[axis] as f32) as i32;
            let spans: Vec<Span> = (0..n)
                .map(|i| match i % 50 {
                    0 => NO_SPAN,
                    1 => (IVec3::ZERO, dims - 1),
                    _ => {
                        let a = IVec3::new(coord(0), coord(1), coord(2));
                        let b = IVec3::new(coord(0), coord(1), coord(2));
                        // Mostly small spans, some long ones along each axis.
                        let reach = IVec3::new(i % 3, i % 4, i % 5);
                        (a.min(b), a.min(b) + (a.max(b) - a.min(b)).min(reach))
                    }
                })
                .collect();
            let (mut start, mut idx) = (vec![0u32], Vec::new());
            for z in 0..dims.z {
                for y in 0..dims.y {
                    for x in 0..dims.x {
                        let c = IVec3::new(x, y, z);
                        let inside = |(a, b): &Span| c.cmpge(*a).all() && c.cmple(*b).all();
                        idx.extend((0..n as u32).filter(|&i| inside(&spans[i as usize])));
                        start.push(idx.len() as u32);
                    }
                }
            }
            for threads in [1, 2, 5, 16, 64] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let mut entries = Entries::default();
                pool.install(|| entries.fill(dims, &photons, &spans));
                assert_eq!(entries.start, start, "dims {dims}, {threads} threads");
                assert_eq!(entries.idx, idx, "dims {dims}, {threads} threads");
                let x: Vec<f32> = idx.iter().map(|&i| photons[i as usize].p.x).collect();
                assert_eq!(entries.x, x, "dims {dims}, {threads} threads");
            }
        }
    }

    /// Photons at distance 0.004 from rays with f32-normalised directions, 3 units along them:
    /// `distance2` gives d² to 10⁻³ of r² (the f32 rounding of the point itself is ~10⁻⁴ of r²),
    /// where |v|² − t² was off by several per cent.
    #[test]
    fn distance_to_a_ray_does_not_cancel() {
        let mut s = Sampler::new(7, Purpose::Other, 0, 0);
        let r = 0.004f64;
        let (mut worst, mut worst_naive) = (0.0f64, 0.0f64);
        for _ in 0..2000 {
            let d = crate::math::sample_uniform_sphere(s.next_2d()).normalize();
            let o = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 4.0 - 2.0;
            let (od, dd) = (o.as_dvec3(), d.as_dvec3());
            let unit = dd.normalize();
            let p = (od + unit * 3.0 + unit.any_orthonormal_vector() * r).as_vec3();
            // The exact squared distance of the (rounded) point from the line o + t d.
            let v = p.as_dvec3() - od;
            let exact = (v - unit * v.dot(unit)).length_squared();
            let (_, d2) = distance2(p - o, d);
            let vf = p - o;
            let naive = vf.length_squared() - vf.dot(d).powi(2);
            worst = worst.max((d2 as f64 - exact).abs() / exact);
            worst_naive = worst_naive.max((naive as f64 - exact).abs() / exact);
        }
        assert!(worst < 1e-3, "relative error of d² {worst}");
        assert!(worst_naive > 1e-2, "the naive formula was expected to cancel: {worst_naive}");
    }
}
