//! Reading a density grid from an OpenVDB file: the header and descriptors checked before
//! vdb-rs sees them, then two passes over the tree by haze's own reader (`vdbscan.rs`) — a
//! census of bounds, voxels and bricks, then the copy into the dense or bricks layout
//! (module docs of `grid`).

use super::super::blocks::Blocked;
use super::super::vdbscan::{Input, Sink, check_header, leaf_voxel, leaf_voxels};
use super::{
    BRICK, BRICK_VOXELS, Bricks, CONSTANT, DensityGrid, EMPTY, Layout, MAX_BRICKS, MAX_FILE_BYTES,
    MAX_VOXELS, SMALL, Storage,
};
use crate::error::{Error, Result, quote};
use glam::{IVec3, Vec3};
use std::io::{Read, Seek};
use std::path::Path;

fn volume_error(path: &Path, message: impl Into<String>) -> Error {
    Error::Volume { path: path.to_path_buf(), message: message.into() }
}

impl DensityGrid {
    /// Reads float grid `name` from the OpenVDB file at `path`, in the layout that suits it.
    #[cfg(test)]
    pub fn load(path: &Path, name: &str) -> Result<DensityGrid> {
        Self::load_with(path, name, Layout::Auto)
    }

    /// Reads float grid `name` from the OpenVDB file at `path` in layout `layout`, streaming
    /// the file (it is never held in memory whole).
    pub fn load_with(path: &Path, name: &str, layout: Layout) -> Result<DensityGrid> {
        crate::input::check_file(path, MAX_FILE_BYTES, "an OpenVDB file")?;
        let header = std::fs::File::open(path)
            .map_err(|error| Error::Io { path: path.to_path_buf(), error })?;
        let input = Input::File(path);
        let read = read_header(std::io::BufReader::new(header), input, path, name)?;
        build(&read, path, name, layout)
    }

    /// Reads float grid `name` from the bytes of an OpenVDB file (`path` names it in messages).
    pub fn from_bytes(bytes: &[u8], path: &Path, name: &str) -> Result<DensityGrid> {
        Self::from_bytes_with(bytes, path, name, Layout::Auto)
    }

    /// [`Self::from_bytes`] in layout `layout`.
    pub fn from_bytes_with(
        bytes: &[u8],
        path: &Path,
        name: &str,
        layout: Layout,
    ) -> Result<DensityGrid> {
        let read = read_header(std::io::Cursor::new(bytes), Input::Memory(bytes), path, name)?;
        build(&read, path, name, layout)
    }
}

/// The header of the OpenVDB file `input` (read by vdb-rs from `reader`, after haze has checked
/// it), grid `name` checked, and its transform.
fn read_header<'a, R: Read + Seek>(
    mut reader: R,
    input: Input<'a>,
    path: &Path,
    name: &str,
) -> Result<ReadGrid<'a>> {
    let err = |m: String| volume_error(path, m);
    let mut magic = [0u8; 4];
    if reader.read_exact(&mut magic).is_err() || magic != [0x20, 0x42, 0x44, 0x56] {
        return Err(err("not an OpenVDB file (bad magic number)".into()));
    }
    reader.rewind().map_err(|e| err(format!("cannot read: {e}")))?;
    let found = check_header(input, name).map_err(err)?;
    let opened =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| vdb_rs::VdbReader::new(reader)));
    let vdb = match opened {
        Ok(Ok(v)) => v,
        Ok(Err(e)) => {
            return Err(err(format!("cannot read the file header: {}", quote(&e.to_string()))));
        }
        Err(_) => return Err(err("cannot read the file header (corrupt or unsupported)".into())),
    };
    // `NAME[k]`: component k of vector grid NAME, unless a grid has that very name. A grid
    // haze's reader did not find is refused here with the file's grids.
    let (grid, component) = found.as_ref().map_or((name, None), |f| (f.grid.as_str(), f.component));
    check_names(&vdb, path, grid)?;
    let gd = check_grid(&vdb, path, grid, component)?;
    let Some(t) = found.as_ref().map(|f| &f.transform) else {
        return Err(err(format!("grid `{name}`: not found by haze's reader (corrupt name?)")));
    };
    let Some((translation, voxel_size)) = t.place else {
        return Err(err(format!(
            "grid `{name}` has an `{}` transform; haze reads uniform-scale and scale-translate \
             maps only (resample the grid, or place it with the medium's `transform`)",
            quote(&t.map)
        )));
    };
    let translation = Vec3::from(translation.map(|x| x as f32));
    let voxel_size = Vec3::from(voxel_size.map(|x| x as f32));
    if !(voxel_size.min_element() > 0.0 && voxel_size.is_finite() && translation.is_finite()) {
        return Err(err(format!("grid `{name}`: invalid voxel size {voxel_size}")));
    }
    let expected = match gd.meta_data.0.get("file_voxel_count") {
        Some(vdb_rs::MetadataValue::I64(n)) => Some(*n as u64),
        _ => None,
    };
    let (grid, component) = (grid.to_string(), component.unwrap_or(0));
    Ok(ReadGrid { input, grid, component, translation, voxel_size, expected })
}

/// Refuses grids that share a name (vdb-rs would keep only one), and names suffixed by OpenVDB
/// for that reason.
fn check_names<R: Read + Seek>(vdb: &vdb_rs::VdbReader<R>, path: &Path, name: &str) -> Result<()> {
    let err = |m: String| volume_error(path, m);
    let names = vdb.available_grids();
    if (vdb.header.grid_count as usize) > names.len() {
        return Err(err(format!(
            "{} grids but only {} distinct names: two grids share a name, and vdb-rs would \
             keep only one; rename them",
            vdb.header.grid_count,
            names.len()
        )));
    }
    // OpenVDB writes grids that share a name as NAME\x1e0, NAME\x1e1, …; vdb-rs does not
    // strip the suffix.
    let suffixed: Vec<&String> = names
        .iter()
        .filter(|n| n.split('\u{1e}').next() == Some(name) && n.contains('\u{1e}'))
        .collect();
    if !suffixed.is_empty() {
        return Err(err(format!(
            "{} grids share the name `{name}`; rename them so that the grid to render is unique",
            suffixed.len()
        )));
    }
    Ok(())
}

/// The descriptor of grid `name`, refused if it is an instance or not of the type asked for: a
/// float grid, or with a `component`, a 3-vector grid.
fn check_grid<R: Read + Seek>(
    vdb: &vdb_rs::VdbReader<R>,
    path: &Path,
    name: &str,
    component: Option<usize>,
) -> Result<vdb_rs::GridDescriptor> {
    let err = |m: String| volume_error(path, m);
    let Some(gd) = vdb.grid_descriptors.get(name).cloned() else {
        let mut names = vdb.available_grids();
        names.sort();
        let names = names.iter().take(20).map(|n| format!("`{}`", quote(n))).collect::<Vec<_>>();
        let more = if vdb.grid_descriptors.len() > 20 { ", …" } else { "" };
        return Err(err(format!(
            "no grid named `{}` (the file has {}{more})",
            quote(name),
            names.join(", ")
        )));
    };
    let ty = gd.grid_type.strip_suffix("_HalfFloat").unwrap_or(&gd.grid_type);
    match (ty, component) {
        ("Tree_float_5_4_3", None) | ("Tree_vec3s_5_4_3", Some(_)) => {}
        ("Tree_vec3s_5_4_3", None) => {
            return Err(err(format!(
                "grid `{name}` is a vector grid ({}); name one of its components as \
                 `{name}[0]`, `{name}[1]` or `{name}[2]`, or give a float grid",
                quote(&gd.grid_type)
            )));
        }
        (_, None) => {
            return Err(err(format!(
                "grid `{name}` is of type {}, not a float grid (Tree_float_5_4_3)",
                quote(&gd.grid_type)
            )));
        }
        (_, Some(_)) => {
            return Err(err(format!(
                "grid `{name}` is of type {}, not a vector grid (Tree_vec3s_5_4_3) with \
                 components",
                quote(&gd.grid_type)
            )));
        }
    }
    if !gd.instance_parent.is_empty() {
        return Err(err(format!("grid `{name}` is an instance of another grid; not supported")));
    }
    Ok(gd)
}

/// A grid to read: where its file's bytes are, its translation and voxel size, and the
/// active-voxel count the file states.
struct ReadGrid<'a> {
    input: Input<'a>,
    /// The grid's name in the file, and the component read (0 for a float grid).
    grid: String,
    component: usize,
    translation: Vec3,
    voxel_size: Vec3,
    expected: Option<u64>,
}

/// Hands `sink` every active voxel and tile of the grid (leaves whole), decoded from the file as
/// it is read (no copy of the file or the tree).
fn for_each_item(read: &ReadGrid, path: &Path, name: &str, sink: &mut dyn Sink) -> Result<()> {
    // The callers' arithmetic on what a corrupt file says (origins near the ends of i32) could
    // panic: contained, and reported.
    let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        super::super::vdbscan::for_each_value(read.input, &read.grid, read.component, sink)
    }));
    match run {
        Ok(r) => r.map_err(|e| volume_error(path, format!("grid `{name}`: {e}"))),
        Err(_) => {
            Err(volume_error(path, format!("grid `{name}`: corrupt data (the reader failed)")))
        }
    }
}

/// True if a leaf at `origin` lies in one brick (as every leaf of a well-formed file does:
/// OpenVDB aligns them to multiples of 8).
fn aligned(origin: [i32; 3]) -> bool {
    origin.iter().all(|o| o & (BRICK - 1) == 0)
}

/// What the first pass over a grid's voxels finds.
struct Census {
    lo: IVec3,
    hi: IVec3,
    /// Active voxels, tiles counted voxel by voxel.
    voxels: u64,
    max: f32,
    /// The first value that is negative or not finite, with its index.
    bad: Option<(IVec3, f32)>,
    /// Bricks holding single voxels (tiles become constant bricks) …
    stored: std::collections::HashSet<IVec3>,
    /// … the last of which (to skip a lookup for each voxel of a brick).
    last_brick: Option<IVec3>,
}

impl Census {
    /// Nothing counted yet.
    fn empty() -> Self {
        Census {
            lo: IVec3::MAX,
            hi: IVec3::MIN,
            voxels: 0,
            max: 0.0,
            bad: None,
            stored: Default::default(),
            last_brick: None,
        }
    }

    /// Counts one voxel (edge 1) or tile.
    fn add(&mut self, p: IVec3, edge: i32, v: f32) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p + IVec3::splat(edge - 1));
        self.voxels += (edge as u64).pow(3);
        if !v.is_finite() || v < 0.0 {
            self.bad.get_or_insert((p, v));
        }
        self.max = self.max.max(v);
        // Tiles become constant bricks (their table entries only).
        if edge < BRICK && self.last_brick != Some(p >> 3) {
            self.last_brick = Some(p >> 3);
            self.stored.insert(p >> 3);
        }
    }
}

impl Sink for Census {
    fn item(&mut self, origin: [i32; 3], edge: i32, v: f32) {
        self.add(IVec3::from(origin), edge, v);
    }

    /// A leaf in one brick at once: what [`Census::add`] finds voxel by voxel.
    fn leaf(&mut self, origin: [i32; 3], active: &[u64; 8], values: &[f32; 512]) {
        let count: u32 = active.iter().map(|w| w.count_ones()).sum();
        if count == 0 {
            return;
        }
        if !aligned(origin) {
            for i in leaf_voxels(active) {
                self.add(IVec3::from(leaf_voxel(origin, i)), 1, values[i]);
            }
            return;
        }
        // Bit 64x + 8y + z: x is the word, y the byte within it, z the bit within that. Each
        // axis's occupied coordinates as the bits of a byte, and their first and last.
        let any = active.iter().fold(0, |a, w| a | w).to_le_bytes();
        let x_bits = active.iter().enumerate().fold(0u8, |a, (x, &w)| a | ((w != 0) as u8) << x);
        let y_bits = any.iter().enumerate().fold(0u8, |a, (y, &b)| a | ((b != 0) as u8) << y);
        let z_bits = any.iter().fold(0u8, |a, b| a | b);
        let range = |bits: u8| (bits.trailing_zeros() as i32, 7 - bits.leading_zeros() as i32);
        let ((x0, x1), (y0, y1), (z0, z1)) = (range(x_bits), range(y_bits), range(z_bits));
        let o = IVec3::from(origin);
        self.lo = self.lo.min(o + IVec3::new(x0, y0, z0));
        self.hi = self.hi.max(o + IVec3::new(x1, y1, z1));
        self.voxels += count as u64;
        // Inactive voxels' values are zero: every value can be read, without the mask.
        let bad = |v: f32| !v.is_finite() || v < 0.0;
        if values.iter().any(|&v| bad(v)) {
            let first = leaf_voxels(active).find(|&i| bad(values[i]));
            if let Some(i) = first {
                self.bad.get_or_insert((IVec3::from(leaf_voxel(origin, i)), values[i]));
            }
        }
        let mut lanes = [self.max; 8];
        for run in values.chunks_exact(8) {
            for (m, &v) in lanes.iter_mut().zip(run) {
                *m = m.max(v);
            }
        }
        self.max = lanes.iter().fold(self.max, |a, &b| a.max(b));
        self.last_brick = Some(o >> 3);
        self.stored.insert(o >> 3);
    }
}

/// The first pass over a grid's tree: its bounds, active voxels, largest value and the bricks
/// it stores; refused if its values or its count are wrong.
fn census(read: &ReadGrid, path: &Path, name: &str) -> Result<Census> {
    let err = |m: String| volume_error(path, m);
    let mut c = Census::empty();
    for_each_item(read, path, name, &mut c)?;
    if let Some(n) = read.expected {
        if n != c.voxels {
            return Err(err(format!(
                "grid `{name}`: the file states {n} active voxels but its tree holds {} \
                 (corrupt?)",
                c.voxels
            )));
        }
    }
    if c.voxels == 0 {
        return Err(err(format!("grid `{name}` has no active voxels")));
    }
    if let Some((p, v)) = c.bad {
        return Err(err(format!(
            "grid `{name}` has a value of {v} at index {p}; its values (densities, temperatures) \
             must be finite and non-negative"
        )));
    }
    Ok(c)
}

/// The copy of the grid in `layout` (chosen by [`Layout::Auto`]'s rule when asked), checked: no
/// voxel missing, values finite and non-negative, within the layouts' limits.
fn build(read: &ReadGrid, path: &Path, name: &str, layout: Layout) -> Result<DensityGrid> {
    let err = |m: String| volume_error(path, m);
    let mut c = census(read, path, name)?;
    // In 64 bits: far-apart voxels would overflow i32 extents and their u64 product.
    let extent = (c.hi.as_i64vec3() - c.lo.as_i64vec3()) + glam::I64Vec3::ONE;
    let dense_voxels = (extent.x as u128) * (extent.y as u128) * (extent.z as u128);
    // Bricks from the multiple of BRICK at or below the lowest index.
    let brick_lo: IVec3 = (c.lo >> 3) << 3;
    let brick_count = ((c.hi.as_i64vec3() - brick_lo.as_i64vec3()) / BRICK as i64) + 1;
    let table = (brick_count.x as u128) * (brick_count.y as u128) * (brick_count.z as u128);
    let brick_bytes = 4 * (table + c.stored.len() as u128 * 512);
    let dense_fits = dense_voxels <= MAX_VOXELS as u128;
    let bricks_fit = table <= MAX_BRICKS as u128;
    let chosen = match layout {
        Layout::Auto
            if dense_fits && (4 * dense_voxels <= SMALL || 4 * dense_voxels <= 2 * brick_bytes) =>
        {
            Layout::Dense
        }
        Layout::Auto if bricks_fit => Layout::Bricks,
        Layout::Auto if dense_fits => Layout::Dense,
        other => other,
    };
    let (origin, dims, storage) = match chosen {
        Layout::Dense | Layout::Auto => {
            if !dense_fits {
                return Err(err(format!(
                    "grid `{name}` spans {}×{}×{} voxels, more than haze's limit of {MAX_VOXELS} \
                     for a dense copy{}",
                    extent.x,
                    extent.y,
                    extent.z,
                    if bricks_fit { "" } else { " and of 2048³ voxels for bricks" }
                )));
            }
            let dims = extent.as_ivec3();
            let data = fill_dense(read, path, name, c.lo, dims, dense_voxels as usize)?;
            (c.lo, dims, Storage::Dense(data))
        }
        Layout::Bricks => {
            if !bricks_fit {
                return Err(err(format!(
                    "grid `{name}` spans {}×{}×{} voxels, more than haze's limit of 2048³ voxels \
                     for its brick table",
                    extent.x, extent.y, extent.z
                )));
            }
            let stored = c.stored.len();
            drop(std::mem::take(&mut c.stored));
            let b = fill_bricks(read, path, name, brick_lo, brick_count.as_ivec3(), stored)?;
            let dims = (c.hi - brick_lo) + IVec3::ONE;
            (brick_lo, dims, Storage::Bricks(b))
        }
    };
    Ok(DensityGrid {
        origin,
        dims,
        storage: std::sync::Arc::new(storage),
        translation: read.translation,
        voxel_size: read.voxel_size,
        max_density: c.max,
        active_voxels: c.voxels,
        active_box: (c.lo, c.hi),
    })
}

/// The second pass for the dense layout: every voxel of the `dims` box from `lo`, zero where the
/// tree has none.
fn fill_dense(
    read: &ReadGrid,
    path: &Path,
    name: &str,
    lo: IVec3,
    dims: IVec3,
    voxels: usize,
) -> Result<Vec<f32>> {
    let mut fill = DenseFill { data: vec![0.0f32; voxels], lo, dims };
    for_each_item(read, path, name, &mut fill)?;
    Ok(fill.data)
}

/// The dense copy being filled: voxels x fastest over the `dims` box from `lo`.
struct DenseFill {
    data: Vec<f32>,
    lo: IVec3,
    dims: IVec3,
}

impl DenseFill {
    /// The index of voxel `p`.
    #[inline]
    fn index(&self, p: IVec3) -> usize {
        let q = p - self.lo;
        (q.x + self.dims.x * (q.y + self.dims.y * q.z)) as usize
    }
}

impl Sink for DenseFill {
    fn item(&mut self, origin: [i32; 3], edge: i32, v: f32) {
        let p = IVec3::from(origin);
        for z in 0..edge {
            for y in 0..edge {
                let row = self.index(p + IVec3::new(0, y, z));
                self.data[row..row + edge as usize].fill(v);
            }
        }
    }

    fn leaf(&mut self, origin: [i32; 3], active: &[u64; 8], values: &[f32; 512]) {
        for i in leaf_voxels(active) {
            let at = self.index(IVec3::from(leaf_voxel(origin, i)));
            self.data[at] = values[i];
        }
    }
}

/// The second pass for the bricks layout: the table of `count` bricks from `brick_lo`, tiles as
/// constant bricks, `stored` bricks of voxels in the pool.
fn fill_bricks(
    read: &ReadGrid,
    path: &Path,
    name: &str,
    brick_lo: IVec3,
    count: IVec3,
    stored: usize,
) -> Result<Bricks> {
    // Blocks of the table aligned to 8 bricks in index space, as OpenVDB's tiles of 128³
    // voxels and more are: such a tile fills whole blocks.
    let offset = (brick_lo >> 3) & 7;
    let bricks = Bricks {
        table: Blocked::new(count, offset, EMPTY),
        constants: Vec::new(),
        pool: Vec::with_capacity(stored * BRICK_VOXELS),
    };
    let mut fill = BrickFill { b: bricks, brick_lo };
    for_each_item(read, path, name, &mut fill)?;
    Ok(fill.b)
}

/// The bricks being filled, their table from brick `brick_lo` (in voxels).
struct BrickFill {
    b: Bricks,
    brick_lo: IVec3,
}

impl BrickFill {
    /// The stored brick `k`, made now if it has none: zeros, or a constant brick's value (a voxel
    /// in a brick a tile covers, as two root nodes at one origin in a corrupt file give: the brick
    /// becomes the tile's value with the voxel written over it, as the dense layout stores it).
    fn stored(&mut self, k: IVec3) -> usize {
        let b = &mut self.b;
        let e = b.table.get(k);
        if e != EMPTY && e & CONSTANT == 0 {
            return e as usize * BRICK_VOXELS;
        }
        let fill = if e == EMPTY { 0.0 } else { b.constants[(e & !CONSTANT) as usize] };
        let at = b.pool.len();
        b.table.set(k, (at / BRICK_VOXELS) as u32);
        b.pool.resize(at + BRICK_VOXELS, fill);
        at
    }
}

impl Sink for BrickFill {
    fn item(&mut self, origin: [i32; 3], edge: i32, v: f32) {
        let q = IVec3::from(origin) - self.brick_lo;
        if edge < BRICK {
            let at = self.stored(q >> 3);
            let l = q & (BRICK - 1);
            self.b.pool[at + (l.x + 8 * (l.y + 8 * l.z)) as usize] = v;
            return;
        }
        // A tile: whole bricks of one value, stored once; whole blocks of the table where it
        // covers them.
        let b = &mut self.b;
        let n = edge / BRICK;
        let entry = CONSTANT | b.constants.len() as u32;
        b.constants.push(v);
        let first = q >> 3;
        let step = if n % 8 == 0 && b.table.starts_block(first) { 8 } else { 1 };
        for z in (0..n).step_by(step) {
            for y in (0..n).step_by(step) {
                for x in (0..n).step_by(step) {
                    let k = first + IVec3::new(x, y, z);
                    if step == 8 {
                        b.table.fill_block(k, entry);
                    } else {
                        b.table.set(k, entry);
                    }
                }
            }
        }
    }

    /// A leaf in one brick: the brick looked up once, its active voxels copied (the leaf's
    /// voxel i = 64x + 8y + z to the brick's x + 8y + 64z).
    fn leaf(&mut self, origin: [i32; 3], active: &[u64; 8], values: &[f32; 512]) {
        if active.iter().all(|&w| w == 0) {
            return;
        }
        if !aligned(origin) {
            for i in leaf_voxels(active) {
                self.item(leaf_voxel(origin, i), 1, values[i]);
            }
            return;
        }
        let at = self.stored((IVec3::from(origin) - self.brick_lo) >> 3);
        let brick = &mut self.b.pool[at..at + BRICK_VOXELS];
        for i in leaf_voxels(active) {
            brick[(i >> 6) + 8 * ((i >> 3) & 7) + 64 * (i & 7)] = values[i];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hands its sink every leaf voxel by voxel (the trait's own `leaf`), as the reader did
    /// before sinks took leaves whole.
    struct ByVoxel<'a, S: Sink>(&'a mut S);

    impl<S: Sink> Sink for ByVoxel<'_, S> {
        fn item(&mut self, origin: [i32; 3], edge: i32, v: f32) {
            self.0.item(origin, edge, v);
        }
    }

    fn census_of(read: &ReadGrid, path: &Path, name: &str, whole: bool) -> Census {
        let mut c = Census::empty();
        let sink: &mut dyn Sink = if whole { &mut c } else { &mut ByVoxel(&mut c) };
        for_each_item(read, path, name, sink).unwrap();
        c
    }

    /// The census, the dense copy and the bricks of every bundled grid (leaves full and sparse,
    /// tiles, half floats, vector components) are the same whether the sinks take each leaf whole
    /// or voxel by voxel.
    #[test]
    fn leaves_taken_whole_are_their_voxels_one_by_one() {
        let grids = [
            ("cloud.vdb", "density"),
            ("cumulus.vdb", "density"),
            ("holes.vdb", "density"),
            ("fire.vdb", "temperature"),
            ("tiles.vdb", "density"),
            ("vector.vdb", "albedo[1]"),
            ("half/vector.vdb", "albedo[2]"),
            ("half/cloud-blosc.vdb", "density"),
            ("half/tiles-blosc.vdb", "density"),
        ];
        for (file, name) in grids {
            let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("media").join(file);
            let bytes = std::fs::read(&path).unwrap();
            let read =
                read_header(std::io::Cursor::new(&bytes[..]), Input::Memory(&bytes), &path, name)
                    .unwrap_or_else(|e| panic!("{file}: {e}"));
            let (a, b) =
                (census_of(&read, &path, name, true), census_of(&read, &path, name, false));
            assert_eq!((a.lo, a.hi, a.voxels), (b.lo, b.hi, b.voxels), "{file}");
            assert_eq!((a.max.to_bits(), a.bad, &a.stored), (b.max.to_bits(), b.bad, &b.stored));
            let (lo, dims) = (a.lo, a.hi - a.lo + IVec3::ONE);
            let dense = |whole: bool| {
                let n = dims.as_i64vec3().element_product() as usize;
                let mut fill = DenseFill { data: vec![0.0; n], lo, dims };
                let sink: &mut dyn Sink = if whole { &mut fill } else { &mut ByVoxel(&mut fill) };
                for_each_item(&read, &path, name, sink).unwrap();
                fill.data
            };
            let bits = |v: Vec<f32>| v.into_iter().map(f32::to_bits).collect::<Vec<_>>();
            assert!(bits(dense(true)) == bits(dense(false)), "{file}: dense copies differ");
            let brick_lo = (lo >> 3) << 3;
            let count = ((a.hi - brick_lo) >> 3) + IVec3::ONE;
            let bricks = |whole: bool| {
                let b = Bricks {
                    table: Blocked::new(count, (brick_lo >> 3) & 7, EMPTY),
                    constants: Vec::new(),
                    pool: Vec::new(),
                };
                let mut fill = BrickFill { b, brick_lo };
                let sink: &mut dyn Sink = if whole { &mut fill } else { &mut ByVoxel(&mut fill) };
                for_each_item(&read, &path, name, sink).unwrap();
                fill.b
            };
            let (w, v) = (bricks(true), bricks(false));
            assert_eq!(w.table, v.table, "{file}: brick tables differ");
            assert_eq!(bits(w.pool), bits(v.pool), "{file}: brick pools differ");
            assert_eq!(bits(w.constants), bits(v.constants), "{file}");
        }
    }
}
