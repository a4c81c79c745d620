//! haze's reader of OpenVDB float trees, and the structural checks that keep vdb-rs 0.6 safe on the
//! header it still reads.
//!
//! vdb-rs allocates whatever a count or a length in the file asks for before it reads the bytes
//! that count promises, so a single corrupt byte can make it request 10¹⁷ bytes and the process
//! abort (no panic, nothing to catch). haze lets vdb-rs read only the header and the grid
//! descriptors, after [`check_header`] has walked them checking every count and length against
//! the bytes that remain, and reads the grid's tree itself ([`for_each_value`]): transform, tree
//! topology and leaf data, every count and length checked against the file and every
//! decompressed size against the node it fills, allocating from no count (at most a node's worth
//! of bytes at a time). Files it refuses get a message naming the offset. Only the versions and
//! layouts haze accepts are read (file format 222 and later, float trees `5_4_3`).
//!
//! The tree is read straight from the file ([`Input::File`], through a buffered reader: the file
//! is never held in memory whole) or from its bytes in memory ([`Input::Memory`], for the fuzz
//! targets and tests), with the same code.
//!
//! Why not vdb-rs for the tree: it holds the whole tree in memory while haze copies it (the
//! loading peak was 2.1× the final grid), drops root-level tiles, and misreads half-float grids
//! (`saveFloatAsHalf`, type `Tree_float_5_4_3_HalfFloat`), which store every node's values as
//! 16-bit floats but, unlike full floats, write nothing at all for a node with no value to store
//! (OpenVDB's `HalfWriter` returns early on a count of zero), while vdb-rs 0.6 still reads a block
//! size there and loses its place in the file (an error, or with an unlucky size an abort).
//! Compressed blocks are decoded here — zip through flate2, Blosc through c-blosc (the library
//! vdb-rs links) after the block's header has been validated against the bytes it came in and the
//! size the node needs.

use std::io::Read;
use std::path::Path;

/// The byte offset and what is wrong there.
pub(crate) type ScanError = String;

/// File format version from which node masks are compressed (and compression is per grid).
const NODE_MASK_COMPRESSION: u32 = 222;
const ZIP: u32 = 0x1;
const ACTIVE_MASK: u32 = 0x2;
const BLOSC: u32 = 0x4;

/// Where an OpenVDB file's bytes are read from.
#[derive(Clone, Copy)]
pub(crate) enum Input<'a> {
    /// The whole file in memory.
    Memory(&'a [u8]),
    /// The file itself, read as needed.
    File(&'a Path),
}

/// What a [`Cursor`] reads from.
enum Source<'a> {
    Memory(&'a [u8]),
    File(std::io::BufReader<std::fs::File>),
}

struct Cursor<'a> {
    source: Source<'a>,
    /// The file's length.
    len: u64,
    pos: u64,
}

impl<'a> Cursor<'a> {
    fn open(input: Input<'a>) -> Result<Cursor<'a>, ScanError> {
        match input {
            Input::Memory(bytes) => {
                Ok(Cursor { source: Source::Memory(bytes), len: bytes.len() as u64, pos: 0 })
            }
            Input::File(path) => {
                let file = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
                let len = file.metadata().map_err(|e| format!("cannot read: {e}"))?.len();
                let source = Source::File(std::io::BufReader::with_capacity(1 << 16, file));
                Ok(Cursor { source, len, pos: 0 })
            }
        }
    }

    fn remaining(&self) -> u64 {
        self.len.saturating_sub(self.pos)
    }

    fn fail<T>(&self, what: &str) -> Result<T, ScanError> {
        Err(format!("corrupt file at byte {:#x}: {what}", self.pos))
    }

    fn check(&self, n: u64, what: &str) -> Result<(), ScanError> {
        if n > self.remaining() {
            return self.fail(&format!(
                "{what} needs {n} bytes but only {} remain (truncated or corrupt)",
                self.remaining()
            ));
        }
        Ok(())
    }

    /// Reads `out.len()` bytes (checked against what remains).
    fn read(&mut self, out: &mut [u8], what: &str) -> Result<(), ScanError> {
        self.check(out.len() as u64, what)?;
        match &mut self.source {
            Source::Memory(bytes) => {
                let at = self.pos as usize;
                out.copy_from_slice(&bytes[at..at + out.len()]);
            }
            Source::File(f) => f.read_exact(out).map_err(|e| {
                format!("cannot read {} bytes at byte {:#x} ({what}): {e}", out.len(), self.pos)
            })?,
        }
        self.pos += out.len() as u64;
        Ok(())
    }

    /// `n` bytes (checked against what remains: a corrupt count allocates at most the rest of
    /// the file, and callers bound the counts they take).
    fn take(&mut self, n: u64, what: &str) -> Result<Vec<u8>, ScanError> {
        self.check(n, what)?;
        let mut out = vec![0; n as usize];
        self.read(&mut out, what)?;
        Ok(out)
    }

    /// `n` bytes into `out` (its allocation reused).
    fn take_into(&mut self, n: u64, what: &str, out: &mut Vec<u8>) -> Result<(), ScanError> {
        self.check(n, what)?;
        out.clear();
        out.resize(n as usize, 0);
        self.read(out, what)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], ScanError> {
        let mut out = [0; N];
        self.read(&mut out, what)?;
        Ok(out)
    }

    /// Passes over `n` bytes (checked against what remains).
    fn skip(&mut self, n: u64, what: &str) -> Result<(), ScanError> {
        self.check(n, what)?;
        self.seek(self.pos + n, what)
    }

    fn u8(&mut self, what: &str) -> Result<u8, ScanError> {
        Ok(self.array::<1>(what)?[0])
    }

    fn u32(&mut self, what: &str) -> Result<u32, ScanError> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    fn u64(&mut self, what: &str) -> Result<u64, ScanError> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }

    fn i64(&mut self, what: &str) -> Result<i64, ScanError> {
        Ok(self.u64(what)? as i64)
    }

    fn seek(&mut self, pos: u64, what: &str) -> Result<(), ScanError> {
        if pos > self.len {
            return self.fail(&format!("{what} points to byte {pos:#x}, past the end of the file"));
        }
        if let Source::File(f) = &mut self.source {
            // Relative seeks keep the buffer where they land within it.
            let delta = pos as i64 - self.pos as i64;
            f.seek_relative(delta).map_err(|e| format!("cannot seek to byte {pos:#x}: {e}"))?;
        }
        self.pos = pos;
        Ok(())
    }

    /// A length-prefixed string.
    fn name(&mut self, what: &str) -> Result<Vec<u8>, ScanError> {
        let len = self.u32(what)?;
        self.take(len as u64, what)
    }

    /// A length-prefixed string passed over.
    fn skip_name(&mut self, what: &str) -> Result<(), ScanError> {
        let len = self.u32(what)?;
        self.skip(len as u64, what)
    }

    /// A mask of `bits` bits (64-bit words): its set-bit count and its bytes.
    fn mask(&mut self, bits: usize, what: &str) -> Result<(usize, Vec<u8>), ScanError> {
        let words = self.take((bits / 8) as u64, what)?;
        Ok((words.iter().map(|b| b.count_ones() as usize).sum(), words))
    }
}

/// The set bits of a little-endian mask.
fn ones(words: &[u8]) -> impl Iterator<Item = usize> + '_ {
    words
        .iter()
        .enumerate()
        .flat_map(|(i, &b)| (0..8).filter(move |k| b & (1 << k) != 0).map(move |k| i * 8 + k))
}

/// One grid descriptor.
struct Descriptor {
    grid_type: Vec<u8>,
    grid_pos: u64,
    block_pos: u64,
    compression: u32,
    /// Values stored as 16-bit half floats (the type's suffix or the grid's metadata says so).
    half: bool,
}

/// The grid types of float and 3-vector trees, and the suffix OpenVDB appends for half floats.
const FLOAT_TREE: &[u8] = b"Tree_float_5_4_3";
const VEC3_TREE: &[u8] = b"Tree_vec3s_5_4_3";
const HALF_SUFFIX: &[u8] = b"_HalfFloat";

impl Descriptor {
    /// Floats per value: 1 for a float tree, 3 for a vector tree, `None` for other types.
    fn components(&self) -> Option<usize> {
        match self.grid_type.strip_suffix(HALF_SUFFIX).unwrap_or(&self.grid_type) {
            FLOAT_TREE => Some(1),
            VEC3_TREE => Some(3),
            _ => None,
        }
    }

    /// Bytes of a value as stored in nodes' blocks (half or full floats) and as stored in full
    /// (background, tiles of the root, inactive values).
    fn value_bytes(&self) -> (usize, usize) {
        let k = self.components().unwrap_or(1);
        (k * if self.half { 2 } else { 4 }, 4 * k)
    }
}

/// Metadata: returns whether `is_saved_as_half_float` is true.
fn metadata(c: &mut Cursor) -> Result<bool, ScanError> {
    let count = c.u32("metadata count")?;
    let mut half = false;
    for _ in 0..count {
        // Each entry takes at least 12 bytes: a corrupt count runs out of file quickly.
        let name = c.name("metadata name")?;
        let ty = c.name("metadata type")?;
        let len = c.u32("metadata length")? as u64;
        let size = match ty.as_slice() {
            b"bool" => 1,
            b"int32" | b"float" => 4,
            b"int64" => 8,
            b"vec3i" => 12,
            _ => len, // strings and unknown types: `len` bytes
        };
        if name == b"is_saved_as_half_float" && ty == b"bool" {
            // vdb-rs keeps the last entry of a name: so does this.
            half = c.u8("metadata value")? != 0;
        } else {
            if name == b"is_saved_as_half_float" {
                half = false;
            }
            c.skip(size, "metadata value")?;
        }
    }
    Ok(half)
}

/// A grid found by [`check_header`]: its name in the file, the component asked for (`None`: the
/// grid's own values), and its transform.
pub(crate) struct Found {
    pub grid: String,
    pub component: Option<usize>,
    pub transform: Transform,
}

/// Checks the file header and every grid descriptor (what vdb-rs reads of the file), and finds
/// grid `name` — or, if no grid has that name and it ends in `[0]`, `[1]` or `[2]`, component k
/// of the grid named by the rest — with its transform; `None` if there is none.
pub(crate) fn check_header(input: Input, name: &str) -> Result<Option<Found>, ScanError> {
    let (mut c, found) = locate(input, name)?;
    if let Some(d) = found {
        let transform = read_transform(&mut c, &d)?;
        return Ok(Some(Found { grid: name.to_string(), component: None, transform }));
    }
    let (base, Some(k)) = split_component(name) else { return Ok(None) };
    let (mut c, found) = locate(input, base)?;
    let Some(d) = found else { return Ok(None) };
    let transform = read_transform(&mut c, &d)?;
    Ok(Some(Found { grid: base.to_string(), component: Some(k), transform }))
}

/// A grid name and the component its suffix `[0]`, `[1]` or `[2]` names, if it has one.
fn split_component(name: &str) -> (&str, Option<usize>) {
    for (k, suffix) in ["[0]", "[1]", "[2]"].iter().enumerate() {
        match name.strip_suffix(suffix) {
            Some(base) if !base.is_empty() => return (base, Some(k)),
            _ => {}
        }
    }
    (name, None)
}

/// The header and descriptors, with a cursor and the descriptor of grid `grid` if there is one.
fn locate<'a>(input: Input<'a>, grid: &str) -> Result<(Cursor<'a>, Option<Descriptor>), ScanError> {
    let mut c = Cursor::open(input)?;
    c.skip(8, "magic number")?;
    let version = c.u32("file version")?;
    if version < NODE_MASK_COMPRESSION {
        return Err(format!(
            "OpenVDB file format {version} is older than haze reads (222, OpenVDB 3 and later)"
        ));
    }
    c.skip(8, "library version")?;
    if c.u8("grid offsets flag")? != 1 {
        return c.fail("the file has no grid offsets (not supported)");
    }
    c.skip(36, "file UUID")?;
    metadata(&mut c)?;
    let grid_count = c.u32("grid count")?;
    let mut found = None;
    for _ in 0..grid_count {
        let start = c.pos;
        let name = c.name("grid name")?;
        let grid_type = c.name("grid type")?;
        c.skip_name("grid instance parent")?;
        let grid_pos = c.u64("grid position")?;
        let block_pos = c.u64("grid data position")?;
        let end_pos = c.u64("grid end position")?;
        c.seek(grid_pos, "a grid position")?;
        let compression = c.u32("grid compression")?;
        if compression & !(ZIP | ACTIVE_MASK | BLOSC) != 0 {
            return c.fail(&format!("unknown compression flags {compression:#x}"));
        }
        let half = metadata(&mut c)? || grid_type.ends_with(HALF_SUFFIX);
        c.seek(block_pos, "a grid data position")?;
        if end_pos <= start {
            // Descriptors follow each other: a grid's end before its own descriptor would make
            // a corrupt grid count loop over the same bytes up to 2³² times.
            return c.fail(&format!("grid end position {end_pos:#x} is before its descriptor"));
        }
        c.seek(end_pos, "a grid end position")?;
        let d = Descriptor { grid_type, grid_pos, block_pos, compression, half };
        // vdb-rs decodes names byte by byte as Latin-1 and keeps the last grid of a name.
        if name.iter().map(|&b| b as char).eq(grid.chars()) {
            found = Some(d);
        }
    }
    Ok((c, found))
}

/// How a node's values are stored.
#[derive(Clone, Copy)]
enum Codec {
    Raw,
    Zip,
    Blosc,
}

/// What the walk hands its visitor: a node of `log2` dimension (5 or 4: internal, 3: leaf; 0: a
/// root tile) at voxel `origin`, its value mask and its stored values.
struct Node<'b> {
    origin: [i32; 3],
    log2: u32,
    /// The value mask's words (active values and tiles).
    active: &'b [u8],
    /// The child mask's words (internal nodes; empty for leaves).
    children: &'b [u8],
    values: Values<'b>,
}

/// A node's values as stored: `count` values of `size` bytes (the active ones, or all `n`), each
/// `size / scalar` floats of `scalar` bytes.
struct Values<'b> {
    n: usize,
    count: usize,
    size: usize,
    scalar: usize,
    codec: Codec,
    block: &'b [u8],
}

/// Voxel offset of child `i` of a node of `log2` dimension whose children span `child` voxels.
fn child_origin(origin: [i32; 3], log2: u32, i: usize, child: i32) -> [i32; 3] {
    let m = (1usize << log2) - 1;
    let (x, y, z) = (i >> (2 * log2), (i >> log2) & m, i & m);
    // Wrapping: a corrupt origin near the ends of i32 must not panic (the grid's box is checked
    // by the caller).
    let at = |o: i32, k: usize| o.wrapping_add((k as i32).wrapping_mul(child));
    [at(origin[0], x), at(origin[1], y), at(origin[2], z)]
}

/// The origin of a root child or tile: three little-endian i32.
fn origin_of(b: &[u8]) -> [i32; 3] {
    std::array::from_fn(|k| i32::from_le_bytes(b[4 * k..4 * k + 4].try_into().unwrap_or_default()))
}

/// Walks the topology and leaf data of a float grid (after its transform), checking every count
/// and length, and hands every node to `visit`.
fn walk(
    c: &mut Cursor,
    d: &Descriptor,
    visit: &mut dyn FnMut(Node) -> Result<(), ScanError>,
) -> Result<(), ScanError> {
    if read_transform(c, d)?.place.is_none() {
        return Ok(()); // refused by name by the caller
    }
    if c.u32("buffer count")? != 1 {
        return c.fail("multi-buffer trees are not supported");
    }
    let full = d.value_bytes().1;
    c.skip(full as u64, "background value")?;
    let tiles = c.u32("root tile count")?;
    let roots = c.u32("root child count")?;
    // Root tiles: origin, full-size value, active flag.
    let record = 12 + full + 1;
    c.check(tiles as u64 * record as u64, "root tiles")?;
    let mut t = [0u8; 12 + 12 + 1];
    for _ in 0..tiles {
        let t = &mut t[..record];
        c.read(t, "root tile")?;
        if t[record - 1] != 0 {
            let (size, scalar) = (full, 4);
            let block = &t[12..12 + full];
            let values = Values { n: 1, count: 1, size, scalar, codec: Codec::Raw, block };
            visit(Node { origin: origin_of(t), log2: 0, active: &[1], children: &[], values })?;
        }
    }
    // Topology: per root child, a 32³ internal node, its 16³ children, their 8³ leaves' masks.
    let mut leaves: Vec<[i32; 3]> = Vec::new(); // leaf origins, in file order
    let mut block = Vec::new(); // a node's stored values, the allocation reused
    for _ in 0..roots {
        let origin5 = origin_of(&c.array::<12>("root child origin")?);
        let children5 = node(c, d, 5, origin5, &mut block, visit)?;
        for i in ones(&children5) {
            let origin4 = child_origin(origin5, 5, i, 128);
            let children4 = node(c, d, 4, origin4, &mut block, visit)?;
            let count = ones(&children4).count();
            c.skip(count as u64 * 64, "leaf masks")?;
            // Bounded: each leaf's data takes at least 65 bytes of the file.
            leaves.extend(ones(&children4).map(|k| child_origin(origin4, 4, k, 8)));
        }
    }
    // Data: per leaf, its value mask and its 512 values.
    c.seek(d.block_pos, "the grid data position")?;
    for origin in leaves {
        let (active, words) = c.mask(512, "leaf value mask")?;
        let values = values(c, d, 512, active, &mut block)?;
        visit(Node { origin, log2: 3, active: &words, children: &[], values })?;
    }
    Ok(())
}

/// An internal node of `log2` dimension (masks and values), handed to `visit`: returns its child
/// mask.
fn node(
    c: &mut Cursor,
    d: &Descriptor,
    log2: u32,
    origin: [i32; 3],
    block: &mut Vec<u8>,
    visit: &mut dyn FnMut(Node) -> Result<(), ScanError>,
) -> Result<Vec<u8>, ScanError> {
    let n = 1usize << (3 * log2);
    let (_, children) = c.mask(n, "child mask")?;
    let (active, words) = c.mask(n, "value mask")?;
    let values = values(c, d, n, active, block)?;
    visit(Node { origin, log2, active: &words, children: &children, values })?;
    Ok(children)
}

/// A node's compressed values (vdb-rs `read_compressed`, OpenVDB `readCompressedValues`): `n`
/// values, `active` of them active, their bytes read into `block`.
fn values<'b>(
    c: &mut Cursor,
    d: &Descriptor,
    n: usize,
    active: usize,
    block: &'b mut Vec<u8>,
) -> Result<Values<'b>, ScanError> {
    let meta = c.u8("node metadata")?;
    if meta > 6 {
        return c.fail(&format!("invalid node metadata {meta}"));
    }
    // 2: one inactive value; 4: mask and one; 5: mask and two (full-size floats, even in
    // half-float grids).
    let inactive = match meta {
        2 | 4 => 1,
        5 => 2,
        _ => 0,
    };
    let (size, full) = d.value_bytes();
    c.skip(inactive * full as u64, "inactive values")?;
    if matches!(meta, 3..=5) {
        c.skip((n / 8) as u64, "selection mask")?;
    }
    let count = if d.compression & ACTIVE_MASK != 0 && meta != 6 { active } else { n };
    let scalar = if d.half { 2 } else { 4 };
    let bytes = (count * size) as u64;
    let compressed = d.compression & (BLOSC | ZIP) != 0;
    // The stored length: OpenVDB writes nothing for an empty half-float block (see the module's
    // text); uncompressed blocks are the values; compressed ones say their size (≤ 0: stored
    // uncompressed).
    let (codec, length) = if d.half && count == 0 {
        (Codec::Raw, 0)
    } else if !compressed {
        (Codec::Raw, bytes)
    } else {
        let stored = c.i64("compressed size")?;
        if stored <= 0 {
            // A stored block holds exactly the node's values: any other size is corrupt.
            if stored.unsigned_abs() != bytes {
                return c.fail(&format!("stored block of {} bytes for {count} values", -stored));
            }
            (Codec::Raw, bytes)
        } else if stored as u64 > 2 * bytes + 1024 {
            // Zip and Blosc expand incompressible data by well under 1 %: a block more than
            // twice its node's size (plus headers) is corrupt, and not read into memory.
            return c.fail(&format!("a compressed block of {stored} bytes for {count} values"));
        } else if d.compression & BLOSC != 0 {
            (Codec::Blosc, stored as u64)
        } else {
            (Codec::Zip, stored as u64)
        }
    };
    let at = c.pos;
    c.take_into(length, "values", block)?;
    let block: &'b [u8] = block;
    if matches!(codec, Codec::Blosc) && count > 0 {
        check_blosc_header(block, at, count, bytes)?;
    }
    Ok(Values { n, count, size, scalar, codec, block })
}

/// Checks the 16-byte Blosc header of a block read at byte `at` for `count` values of `bytes`
/// bytes in all: decompressed size at 4..8, compressed size at 12..16, which c-blosc 1.x trusts
/// over the buffer's real length (a larger one made it read past the buffer: found by the `vdb`
/// fuzz target). Zip streams are bounded by their decoder.
fn check_blosc_header(block: &[u8], at: u64, count: usize, bytes: u64) -> Result<(), ScanError> {
    let word = |k: usize| {
        block.get(k..k + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap_or_default()))
    };
    // Offsets name the block's size field, as before the block was read.
    let fail = |what: String| format!("corrupt file at byte {:#x}: {what}", at - 8);
    if word(12).is_none_or(|n| n < 16 || n as usize > block.len()) {
        return Err(fail(match word(12) {
            Some(n) => format!("a Blosc block of {} bytes says it holds {n}", block.len()),
            None => format!("a Blosc block of {} bytes has no complete header", block.len()),
        }));
    }
    if word(4) != Some(bytes as u32) {
        return Err(fail(match word(4) {
            Some(n) => format!(
                "a compressed block says it expands to {n} bytes, but its {count} values need {bytes}"
            ),
            None => format!("a compressed block has no complete header ({count} values)"),
        }));
    }
    Ok(())
}

/// A grid's transform: its map's name and, for the maps haze reads (uniform scale,
/// scale-translate), its translation and voxel size.
pub(crate) struct Transform {
    pub map: String,
    pub place: Option<([f64; 3], [f64; 3])>,
}

/// The grid's transform, read from its start.
fn read_transform(c: &mut Cursor, d: &Descriptor) -> Result<Transform, ScanError> {
    c.seek(d.grid_pos, "the grid position")?;
    c.u32("grid compression")?;
    metadata(c)?;
    let map: String = c.name("transform name")?.iter().map(|&b| b as char).collect();
    // Uniform scale: scale values, voxel size, inverse scale, inverse scale², inverse twice
    // scale; scale-translate: the translation first. Other maps have other layouts (vdb-rs
    // would panic on them): the caller refuses them by name.
    let translated = match map.as_str() {
        "UniformScaleMap" => false,
        "UniformScaleTranslateMap" | "ScaleTranslateMap" => true,
        _ => return Ok(Transform { map, place: None }),
    };
    let mut vec = || -> Result<[f64; 3], ScanError> {
        let v: [u8; 24] = c.array("transform")?;
        Ok(std::array::from_fn(|j| {
            f64::from_le_bytes(v[8 * j..8 * j + 8].try_into().unwrap_or_default())
        }))
    };
    let translation = if translated { vec()? } else { [0.0; 3] };
    vec()?; // scale values
    let voxel_size = vec()?;
    c.skip(3 * 24, "transform")?;
    let place = Some((translation, voxel_size));
    Ok(Transform { map, place })
}

/// What [`for_each_value`] hands a grid's values to.
pub(crate) trait Sink {
    /// `edge`³ voxels from `origin` holding `v`: a tile, or one voxel (edge 1).
    fn item(&mut self, origin: [i32; 3], edge: i32, v: f32);

    /// A leaf node's 8³ voxels from `origin`: bit i of `active` (i = 64x + 8y + z, words
    /// little-endian) marks voxel (x, y, z) active, with its value `values[i]` (the values of
    /// inactive voxels are zero, whatever the file holds). By default each active voxel is an
    /// item, in index order; a sink that takes a leaf at once saves the call per voxel.
    fn leaf(&mut self, origin: [i32; 3], active: &[u64; 8], values: &[f32; 512]) {
        for i in leaf_voxels(active) {
            self.item(leaf_voxel(origin, i), 1, values[i]);
        }
    }
}

impl<F: FnMut([i32; 3], i32, f32)> Sink for F {
    fn item(&mut self, origin: [i32; 3], edge: i32, v: f32) {
        self(origin, edge, v)
    }
}

/// The active voxels of a leaf's mask, in index order.
pub(crate) fn leaf_voxels(active: &[u64; 8]) -> impl Iterator<Item = usize> + '_ {
    active.iter().enumerate().flat_map(|(w, &bits)| {
        let mut bits = bits;
        std::iter::from_fn(move || {
            (bits != 0).then(|| {
                let k = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                64 * w + k
            })
        })
    })
}

/// Voxel `i` (= 64x + 8y + z) of the leaf at `origin`.
#[inline]
pub(crate) fn leaf_voxel(origin: [i32; 3], i: usize) -> [i32; 3] {
    let xyz = [(i >> 6) as i32, ((i >> 3) & 7) as i32, (i & 7) as i32];
    std::array::from_fn(|a| origin[a].wrapping_add(xyz[a]))
}

/// Hands `sink` every active voxel and tile (root tiles included) of grid `grid` (full or half
/// floats) — leaves whole, tiles as items — decoding the file's bytes; every count and length is
/// checked before it is used. The value is the float of a float grid, or component `component`
/// (0, 1, 2) of a vector grid's.
pub(crate) fn for_each_value(
    input: Input,
    grid: &str,
    component: usize,
    sink: &mut dyn Sink,
) -> Result<(), ScanError> {
    let (mut c, Some(d)) = locate(input, grid)? else {
        return Err(format!("no grid named `{grid}`"));
    };
    let k = d.components().ok_or_else(|| format!("grid `{grid}` is not a float or vector grid"))?;
    if component >= k {
        return Err(format!("grid `{grid}` has no component {component}"));
    }
    let mut values = Vec::new();
    let mut raw = Vec::new();
    let mut leaf = [0.0f32; 512];
    walk(&mut c, &d, &mut |node| {
        // Edge of a value: a voxel in a leaf, a tile of the node's children above.
        let edge = match node.log2 {
            3 => 1,
            4 => 8,
            5 => 128,
            _ => 4096,
        };
        decode(&node.values, &mut raw, &mut values)?;
        if node.log2 == 3 {
            let mut active = [0u64; 8];
            for (w, bytes) in active.iter_mut().zip(node.active.chunks(8)) {
                *w = bytes.iter().rev().fold(0, |w, &b| (w << 8) | b as u64);
            }
            if node.values.count == node.values.n {
                // Every value stored: a pass without branches.
                let stored = &values[..512 * k];
                for (i, v) in leaf.iter_mut().enumerate() {
                    let on = (active[i >> 6] >> (i & 63)) & 1 != 0;
                    *v = if on { stored[i * k + component] } else { 0.0 };
                }
            } else {
                leaf.fill(0.0);
                for (n, i) in leaf_voxels(&active).enumerate() {
                    leaf[i] = values[n * k + component];
                }
            }
            sink.leaf(node.origin, &active, &leaf);
            return Ok(());
        }
        let dim = 1i32 << node.log2;
        let is_child = |i: usize| node.children.get(i / 8).is_some_and(|b| b & (1 << (i % 8)) != 0);
        for (n, i) in ones(node.active).enumerate() {
            if is_child(i) {
                continue;
            }
            // All values stored, or only the active ones, in order.
            let at = if node.values.count == node.values.n { i } else { n };
            let v = values[at * k + component];
            let origin = if node.log2 == 0 {
                node.origin
            } else {
                let i = i as i32;
                let xyz = [i / (dim * dim), (i / dim) % dim, i % dim];
                std::array::from_fn(|a| node.origin[a].wrapping_add(xyz[a] * edge))
            };
            sink.item(origin, edge, v);
        }
        Ok(())
    })
}

/// The values of a node, decompressed and widened to `f32`.
fn decode(v: &Values, raw: &mut Vec<u8>, out: &mut Vec<f32>) -> Result<(), ScanError> {
    let bytes = v.count * v.size;
    out.clear();
    if v.count == 0 {
        return Ok(());
    }
    let data: &[u8] = match v.codec {
        Codec::Raw => v.block,
        Codec::Zip => {
            raw.clear();
            raw.resize(bytes, 0);
            let mut z = flate2::read::ZlibDecoder::new(v.block);
            std::io::Read::read_exact(&mut z, raw)
                .map_err(|e| format!("a zip block of {} values: {e}", v.count))?;
            raw
        }
        Codec::Blosc => {
            raw.clear();
            raw.resize(bytes, 0);
            unblosc(v.block, raw)?;
            raw
        }
    };
    if data.len() != bytes {
        return Err(format!("a block of {} bytes for {} values", data.len(), v.count));
    }
    match v.scalar {
        2 => out
            .extend(data.chunks_exact(2).map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32())),
        _ => out.extend(data.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))),
    }
    Ok(())
}

/// Decompresses a Blosc block into `out`, which must be exactly the size its header states.
#[allow(unsafe_code)]
fn unblosc(block: &[u8], out: &mut [u8]) -> Result<(), ScanError> {
    let mut nbytes = 0usize;
    // SAFETY: c-blosc reads the header within `block.len()` bytes of `block` and writes only
    // `nbytes`.
    let valid = unsafe {
        blosc_src::blosc_cbuffer_validate(block.as_ptr().cast(), block.len(), &mut nbytes)
    };
    if valid != 0 || nbytes != out.len() {
        return Err(format!(
            "a Blosc block of {} bytes is not valid for the {} bytes its node needs",
            block.len(),
            out.len()
        ));
    }
    // SAFETY: the block was validated against its length above (which makes decompressing it
    // safe to attempt, c-blosc documents), the buffers do not overlap, and c-blosc writes at most
    // `out.len()` bytes.
    let n = unsafe {
        blosc_src::blosc_decompress_ctx(
            block.as_ptr().cast(),
            out.as_mut_ptr().cast(),
            out.len(),
            1,
        )
    };
    if n < 0 || n as usize != out.len() {
        return Err(format!("a Blosc block of {} bytes is corrupt", block.len()));
    }
    Ok(())
}
