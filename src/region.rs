//! Rectangles of pixels: the part of an image that a noise figure, a target error or a
//! comparison counts.

/// Share of an image's pixels, the ones with the largest variance, that its noise figure and
/// its target error leave out ([`Region::counted`]): a light seen directly, or its image through
/// glass, can hold more variance than every other pixel together, and one such pixel would rule
/// a mean (docs/error.md).
pub const NOISIEST_SHARE: f64 = 0.001;

/// A rectangle of pixels, [x0, x1) × [y0, y1); in scene files `[x0, y0, x1, y1]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(into = "[u32; 4]", try_from = "[u32; 4]")]
pub struct Region {
    /// Left column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// One past the right column.
    pub x1: u32,
    /// One past the bottom row.
    pub y1: u32,
}

impl From<Region> for [u32; 4] {
    fn from(r: Region) -> Self {
        [r.x0, r.y0, r.x1, r.y1]
    }
}

impl TryFrom<[u32; 4]> for Region {
    type Error = String;
    fn try_from([x0, y0, x1, y1]: [u32; 4]) -> std::result::Result<Self, String> {
        if x0 < x1 && y0 < y1 {
            Ok(Region { x0, y0, x1, y1 })
        } else {
            Err(format!("region [{x0}, {y0}, {x1}, {y1}] is empty: need x0 < x1 and y0 < y1"))
        }
    }
}

impl Region {
    /// The whole of a `width` × `height` image.
    pub fn whole(width: u32, height: u32) -> Self {
        Region { x0: 0, y0: 0, x1: width, y1: height }
    }

    /// The indices of this region's pixels ([`Self::indices`]) but the [`NOISIEST_SHARE`] of them
    /// with the largest `variance(pixel)` (none below 1 / [`NOISIEST_SHARE`] pixels; ties by
    /// index): the pixels that the image's noise figures and its target error count. Each
    /// pixel's variance is worked out once, in parallel (in the selection's comparisons, a whole
    /// image's took 5–7 ms on one thread at 640×400).
    pub fn counted(
        self,
        width: u32,
        height: u32,
        variance: impl Fn(usize) -> f64 + Sync,
    ) -> impl Iterator<Item = usize> {
        use rayon::prelude::*;
        let mut all: Vec<usize> = self.indices(width, height).collect();
        let left_out = (all.len() as f64 * NOISIEST_SHARE) as usize;
        let mut out = vec![false; all.len()];
        if left_out > 0 {
            let mut order: Vec<usize> = (0..all.len()).collect();
            let keys: Vec<f64> = all.par_iter().map(|&i| variance(i)).collect();
            let key = |k: usize| keys[k];
            // Largest first; NaN (never written) counts as largest.
            order.select_nth_unstable_by(left_out - 1, |&a, &b| {
                key(b).partial_cmp(&key(a)).unwrap_or(std::cmp::Ordering::Equal).then(a.cmp(&b))
            });
            order[..left_out].iter().for_each(|&k| out[k] = true);
        }
        let mut k = 0;
        all.retain(|_| {
            k += 1;
            !out[k - 1]
        });
        all.into_iter()
    }

    /// The row-major indices of this region's pixels in a `width` × `height` image (clipped to
    /// it), row by row.
    pub fn indices(self, width: u32, height: u32) -> impl Iterator<Item = usize> {
        (self.y0..self.y1.min(height)).flat_map(move |y| {
            (self.x0..self.x1.min(width)).map(move |x| y as usize * width as usize + x as usize)
        })
    }

    /// `Ok` if the region lies within a `width` × `height` image; `Err` naming the image if not.
    pub fn check_within(&self, width: u32, height: u32) -> std::result::Result<(), String> {
        if self.x1 > width || self.y1 > height {
            Err(format!(
                "region {},{},{},{} lies outside the {width}x{height} image",
                self.x0, self.y0, self.x1, self.y1
            ))
        } else {
            Ok(())
        }
    }
}

impl std::str::FromStr for Region {
    type Err = String;
    /// Parses `X0,Y0,X1,Y1`.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let v: Vec<u32> = s
            .split(',')
            .map(|t| t.trim().parse::<u32>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| format!("`{s}` is not a region X0,Y0,X1,Y1 in whole pixels"))?;
        match v[..] {
            [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok(Region { x0, y0, x1, y1 }),
            [_, _, _, _] => Err(format!("region `{s}` is empty: need X0 < X1 and Y0 < Y1")),
            _ => Err(format!("`{s}` is not a region X0,Y0,X1,Y1")),
        }
    }
}
