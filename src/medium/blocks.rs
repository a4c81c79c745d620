//! Values over a box of cells stored by blocks of [`BLOCK`]³ cells: a block whose cells all hold
//! one value costs that value, other blocks a page of 512 values. A grid's brick table and its
//! majorants are such boxes, and where a grid holds large constant regions (OpenVDB tiles) most of
//! their blocks are uniform: one constant 2048³ region of tiles takes a few kilobytes instead of
//! 64 MB for each.

use glam::IVec3;

/// Cells along each axis of a block.
pub(crate) const BLOCK: i32 = 8;
const PAGE: usize = (BLOCK * BLOCK * BLOCK) as usize;

/// A top-level entry: the flag and an index into `uniform`, or the index of a page.
const UNIFORM: u32 = 1 << 31;

/// Per-cell values of type `T` over `count` cells (x fastest), in blocks (module docs).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Blocked<T> {
    count: IVec3,
    /// Cell c lies in block (c + offset) / [`BLOCK`] (so that blocks can align with something
    /// other than the box's first cell).
    offset: IVec3,
    blocks: IVec3,
    top: Vec<u32>,
    uniform: Vec<T>,
    pages: Vec<T>,
}

#[inline]
fn local(c: IVec3) -> usize {
    let l = c & (BLOCK - 1);
    (l.x + BLOCK * (l.y + BLOCK * l.z)) as usize
}

impl<T: Copy + PartialEq + Send + Sync> Blocked<T> {
    /// `count` cells all holding `fill`, blocked from cell −`offset` (each component in
    /// 0..[`BLOCK`]).
    pub(crate) fn new(count: IVec3, offset: IVec3, fill: T) -> Self {
        let blocks = (count + offset + IVec3::splat(BLOCK - 1)) / BLOCK;
        let n = blocks.as_i64vec3().element_product() as usize;
        let top = vec![UNIFORM; n];
        Self { count, offset, blocks, top, uniform: vec![fill], pages: Vec::new() }
    }

    /// `count` cells holding `f(cell)`, computed block by block in parallel; uniform blocks are
    /// stored as one value.
    pub(crate) fn from_fn(count: IVec3, f: impl Fn(IVec3) -> T + Sync) -> Self {
        use rayon::prelude::*;
        let blocks = (count + IVec3::splat(BLOCK - 1)) / BLOCK;
        let n = blocks.as_i64vec3().element_product() as usize;
        let made: Vec<Result<T, Vec<T>>> = (0..n)
            .into_par_iter()
            .map(|k| {
                let k = k as i32;
                let b = IVec3::new(k % blocks.x, k / blocks.x % blocks.y, k / blocks.x / blocks.y);
                let mut page = Vec::with_capacity(PAGE);
                for z in 0..BLOCK {
                    for y in 0..BLOCK {
                        for x in 0..BLOCK {
                            let c = b * BLOCK + IVec3::new(x, y, z);
                            // Cells past the box (the last block's spare ones) repeat a cell of
                            // the box, so that they never make a block look mixed: the nearest
                            // cell of the box, which lies in this block and was computed first.
                            let inside = c.min(count - IVec3::ONE);
                            page.push(if inside == c { f(c) } else { page[local(inside)] });
                        }
                    }
                }
                let first = page[0];
                if page.iter().all(|&v| v == first) { Ok(first) } else { Err(page) }
            })
            .collect();
        let (top, uniform, pages) = (Vec::with_capacity(n), Vec::new(), Vec::new());
        let mut me = Self { count, offset: IVec3::ZERO, blocks, top, uniform, pages };
        for m in made {
            match m {
                Ok(v) => {
                    me.top.push(UNIFORM | me.uniform.len() as u32);
                    me.uniform.push(v);
                }
                Err(page) => {
                    me.top.push((me.pages.len() / PAGE) as u32);
                    me.pages.extend_from_slice(&page);
                }
            }
        }
        me
    }

    /// Cells along each axis.
    pub(crate) fn count(&self) -> IVec3 {
        self.count
    }

    #[inline]
    fn block_index(&self, c: IVec3) -> usize {
        let b: IVec3 = (c + self.offset) >> 3;
        (b.x + self.blocks.x * (b.y + self.blocks.y * b.z)) as usize
    }

    /// True if cell `c` is the first of its block.
    pub(crate) fn starts_block(&self, c: IVec3) -> bool {
        (c + self.offset) & (BLOCK - 1) == IVec3::ZERO
    }

    /// The value of cell `c` (inside the box).
    #[inline]
    pub(crate) fn get(&self, c: IVec3) -> T {
        let e = self.top[self.block_index(c)];
        if e & UNIFORM != 0 {
            self.uniform[(e & !UNIFORM) as usize]
        } else {
            self.pages[e as usize * PAGE + local(c + self.offset)]
        }
    }

    /// Sets cell `c` (inside the box) to `v`; a uniform block of another value becomes a page.
    pub(crate) fn set(&mut self, c: IVec3, v: T) {
        let k = self.block_index(c);
        let e = self.top[k];
        if e & UNIFORM != 0 {
            let u = self.uniform[(e & !UNIFORM) as usize];
            if u == v {
                return;
            }
            self.top[k] = (self.pages.len() / PAGE) as u32;
            self.pages.extend(std::iter::repeat_n(u, PAGE));
        }
        let p = self.top[k] as usize;
        self.pages[p * PAGE + local(c + self.offset)] = v;
    }

    /// Sets every cell of the block holding cell `c` to `v` (a page it had is left unused). A
    /// tile fills its blocks one after another: they share one uniform value.
    pub(crate) fn fill_block(&mut self, c: IVec3, v: T) {
        let k = self.block_index(c);
        if self.uniform.last() != Some(&v) {
            self.uniform.push(v);
        }
        self.top[k] = UNIFORM | (self.uniform.len() - 1) as u32;
    }

    /// Bytes held: the top level, the uniform values and the pages.
    pub(crate) fn bytes(&self) -> usize {
        4 * self.top.len() + std::mem::size_of::<T>() * (self.uniform.len() + self.pages.len())
    }

    /// Every stored value (uniform blocks' and pages'), for bounds over the whole box.
    #[cfg(test)]
    pub(crate) fn stored(&self) -> impl Iterator<Item = T> + '_ {
        self.uniform.iter().chain(self.pages.iter()).copied()
    }

    /// Feeds every cell's value in order (x fastest) to `feed`, as a dense array would.
    pub(crate) fn for_each_cell(&self, mut feed: impl FnMut(T)) {
        for z in 0..self.count.z {
            for y in 0..self.count.y {
                for x in 0..self.count.x {
                    feed(self.get(IVec3::new(x, y, z)));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box of 20 × 9 × 17 cells set cell by cell, block by block and from a function reads
    /// back what was written, and uniform blocks take no page.
    #[test]
    fn blocks_read_back_what_was_written() {
        let count = IVec3::new(20, 9, 17);
        let f = |c: IVec3| {
            if c.x < 8 && c.y < 8 { 7u32 } else { (c.x + 100 * c.y + 10_000 * c.z) as u32 }
        };
        let made = Blocked::from_fn(count, f);
        let mut set = Blocked::new(count, IVec3::new(3, 0, 7), 0u32);
        for z in 0..count.z {
            for y in 0..count.y {
                for x in 0..count.x {
                    set.set(IVec3::new(x, y, z), f(IVec3::new(x, y, z)));
                }
            }
        }
        for z in 0..count.z {
            for y in 0..count.y {
                for x in 0..count.x {
                    let c = IVec3::new(x, y, z);
                    assert_eq!((made.get(c), set.get(c)), (f(c), f(c)), "{c}");
                }
            }
        }
        // Blocks (0, 0, k) hold 7 only (the last one's cells past z = 16 repeat z = 16): 3 of the
        // 3 × 2 × 3 blocks take no page.
        assert_eq!(made.pages.len() / PAGE, 3 * 2 * 3 - 3);
        // The brick table of a 2048³-voxel box (256³ bricks): one block filled by a tile.
        let mut one = Blocked::new(IVec3::splat(256), IVec3::ZERO, 0.0f32);
        one.fill_block(IVec3::new(70, 0, 9), 2.0);
        assert_eq!((one.get(IVec3::new(64, 7, 15)), one.get(IVec3::new(63, 0, 0))), (2.0, 0.0));
        assert!(one.bytes() < 200_000, "{} bytes", one.bytes());
    }
}
