//! A structural pre-scan of an OpenVDB file, run over its bytes before vdb-rs 0.6 sees them, and
//! haze's own reader for the grids vdb-rs cannot read: float grids saved as 16-bit half floats.
//!
//! vdb-rs allocates whatever a count or a length in the file asks for before it reads the bytes
//! that count promises, so a single corrupt byte can make it request 10¹⁷ bytes and the process
//! abort (no panic, nothing to catch). This scan walks the same structure in the same order —
//! header, metadata, grid descriptors, and for the grid to be read its transform, tree topology
//! and leaf data — checking every count and length against the bytes that remain and every
//! decompressed size against the node it fills, without allocating from any of them. Files it
//! accepts are ones on which vdb-rs allocates at most a small multiple of the file's size; files
//! it refuses get a message naming the offset. Only what vdb-rs reads is scanned, and only for the
//! versions and layouts haze accepts (file format 222 and later, float trees `5_4_3`).
//!
//! Half-float grids (`saveFloatAsHalf`, type `Tree_float_5_4_3_HalfFloat`) store every node's
//! values as 16-bit floats but, unlike full floats, write nothing at all for a node with no value
//! to store (OpenVDB's `HalfWriter` returns early on a count of zero), while vdb-rs 0.6 still reads
//! a block size there and loses its place in the file (an error, or with an unlucky size an
//! abort). [`for_each_half`] decodes such grids itself with the same walk: zip blocks through
//! flate2, Blosc blocks through c-blosc (the library vdb-rs links), after the block's header has
//! been validated against the bytes it came in and the size the node needs.
/// The byte offset and what is wrong there.
pub(crate) type ScanError = String;

/// File format version from which node masks are compressed (and compression is per grid).
const NODE_MASK_COMPRESSION: u32 = 222;
const ZIP: u32 = 0x1;
const ACTIVE_MASK: u32 = 0x2;
const BLOSC: u32 = 0x4;

struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.pos)
    }

    fn fail<T>(&self, what: &str) -> Result<T, ScanError> {
        Err(format!("corrupt file at byte {:#x}: {what}", self.pos))
    }

    fn take(&mut self, n: u64, what: &str) -> Result<&'a [u8], ScanError> {
        if n > self.remaining() as u64 {
            return self.fail(&format!(
                "{what} needs {n} bytes but only {} remain (truncated or corrupt)",
                self.remaining()
            ));
        }
        let s = &self.bytes[self.pos..self.pos + n as usize];
        self.pos += n as usize;
        Ok(s)
    }

    fn u8(&mut self, what: &str) -> Result<u8, ScanError> {
        Ok(self.take(1, what)?[0])
    }

    fn u32(&mut self, what: &str) -> Result<u32, ScanError> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().unwrap_or_default()))
    }

    fn u64(&mut self, what: &str) -> Result<u64, ScanError> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().unwrap_or_default()))
    }

    fn i64(&mut self, what: &str) -> Result<i64, ScanError> {
        Ok(self.u64(what)? as i64)
    }

    fn seek(&mut self, pos: u64, what: &str) -> Result<(), ScanError> {
        if pos > self.bytes.len() as u64 {
            return self.fail(&format!("{what} points to byte {pos:#x}, past the end of the file"));
        }
        self.pos = pos as usize;
        Ok(())
    }

    /// A length-prefixed string.
    fn name(&mut self, what: &str) -> Result<&'a [u8], ScanError> {
        let len = self.u32(what)?;
        self.take(len as u64, what)
    }

    /// 64-bit mask words for `bits` bits, returned as set-bit count and the words.
    fn mask(&mut self, bits: usize, what: &str) -> Result<(usize, &'a [u8]), ScanError> {
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
struct Descriptor<'a> {
    grid_type: &'a [u8],
    grid_pos: u64,
    block_pos: u64,
    compression: u32,
    /// Values stored as 16-bit half floats (the type's suffix or the grid's metadata says so).
    half: bool,
}

/// The grid type of a float tree, and the suffix OpenVDB appends to it for half-float grids.
const FLOAT_TREE: &[u8] = b"Tree_float_5_4_3";
const HALF_SUFFIX: &[u8] = b"_HalfFloat";

impl Descriptor<'_> {
    fn is_float_tree(&self) -> bool {
        self.grid_type == FLOAT_TREE || self.grid_type.strip_suffix(HALF_SUFFIX) == Some(FLOAT_TREE)
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
        let size = match ty {
            b"bool" => 1,
            b"int32" | b"float" => 4,
            b"int64" => 8,
            b"vec3i" => 12,
            _ => len, // strings and unknown types: `len` bytes
        };
        let value = c.take(size, "metadata value")?;
        if name == b"is_saved_as_half_float" {
            // vdb-rs keeps the last entry of a name: so does this.
            half = ty == b"bool" && value[0] != 0;
        }
    }
    Ok(half)
}

/// Checks the file header and every grid descriptor, then the grid named `grid` if it is a float
/// grid (other grids are refused by name and type later, with their own messages).
pub(crate) fn scan(bytes: &[u8], grid: &str) -> Result<(), ScanError> {
    let (mut c, found) = locate(bytes, grid)?;
    match found {
        Some(d) if d.is_float_tree() => walk(&mut c, &d, &mut |_| Ok(())).map(|_| ()),
        _ => Ok(()),
    }
}

/// Whether grid `grid` of the (scanned) file is a float grid stored as half floats.
pub(crate) fn is_half(bytes: &[u8], grid: &str) -> Result<bool, ScanError> {
    Ok(locate(bytes, grid)?.1.is_some_and(|d| d.half && d.is_float_tree()))
}

/// The header and descriptors, with a cursor and the descriptor of grid `grid` if there is one.
fn locate<'a>(
    bytes: &'a [u8],
    grid: &str,
) -> Result<(Cursor<'a>, Option<Descriptor<'a>>), ScanError> {
    let mut c = Cursor { bytes, pos: 0 };
    c.take(8, "magic number")?;
    let version = c.u32("file version")?;
    if version < NODE_MASK_COMPRESSION {
        return Err(format!(
            "OpenVDB file format {version} is older than haze reads (222, OpenVDB 3 and later)"
        ));
    }
    c.take(8, "library version")?;
    if c.u8("grid offsets flag")? != 1 {
        return c.fail("the file has no grid offsets (not supported)");
    }
    c.take(36, "file UUID")?;
    metadata(&mut c)?;
    let grid_count = c.u32("grid count")?;
    let mut found = None;
    for _ in 0..grid_count {
        let start = c.pos as u64;
        let name = c.name("grid name")?;
        let grid_type = c.name("grid type")?;
        c.name("grid instance parent")?;
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

/// What the walk hands its visitor: a node of `log2` dimension (5 or 4: internal, 3: leaf) at
/// voxel `origin`, its value mask and its stored values.
struct Node<'a> {
    origin: [i32; 3],
    log2: u32,
    /// The value mask's words (active values and tiles).
    active: &'a [u8],
    /// The child mask's words (internal nodes; empty for leaves).
    children: &'a [u8],
    values: Values<'a>,
}

/// A node's values as stored: `count` values of `size` bytes (the active ones, or all `n`).
struct Values<'a> {
    n: usize,
    count: usize,
    size: usize,
    codec: Codec,
    block: &'a [u8],
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

/// Walks the transform, topology and leaf data of a float grid, checking every count and length,
/// and hands every node to `visit`; returns the transform's name and vectors.
fn walk<'a>(
    c: &mut Cursor<'a>,
    d: &Descriptor<'a>,
    visit: &mut dyn FnMut(Node<'a>) -> Result<(), ScanError>,
) -> Result<(&'a [u8], &'a [u8]), ScanError> {
    let (map, transform) = read_transform(c, d)?;
    if transform.is_empty() {
        return Ok((map, transform)); // refused by name later (vdb-rs would panic on it)
    }
    if c.u32("buffer count")? != 1 {
        return c.fail("multi-buffer trees are not supported");
    }
    c.take(4, "background value")?;
    let tiles = c.u32("root tile count")?;
    let roots = c.u32("root child count")?;
    // Root tiles: origin, full-size value, active flag.
    let root_tiles = c.take(tiles as u64 * 17, "root tiles")?;
    for t in root_tiles.chunks_exact(17) {
        let word =
            |k: usize| i32::from_le_bytes(t[4 * k..4 * k + 4].try_into().unwrap_or_default());
        if t[16] != 0 {
            let values = Values { n: 1, count: 1, size: 4, codec: Codec::Raw, block: &t[12..16] };
            let (origin, log2) = ([word(0), word(1), word(2)], 0);
            visit(Node { origin, log2, active: &[1], children: &[], values })?;
        }
    }
    // Topology: per root child, a 32³ internal node, its 16³ children, their 8³ leaves' masks.
    let mut leaves: Vec<[i32; 3]> = Vec::new(); // leaf origins, in file order
    for _ in 0..roots {
        let o = c.take(12, "root child origin")?;
        let word =
            |k: usize| i32::from_le_bytes(o[4 * k..4 * k + 4].try_into().unwrap_or_default());
        let origin5 = [word(0), word(1), word(2)];
        let (children5, node5) = node(c, d, 5, origin5)?;
        visit(node5)?;
        for i in ones(children5) {
            let origin4 = child_origin(origin5, 5, i, 128);
            let (children4, node4) = node(c, d, 4, origin4)?;
            visit(node4)?;
            let count = ones(children4).count();
            c.take(count as u64 * 64, "leaf masks")?;
            leaves.extend(ones(children4).map(|k| child_origin(origin4, 4, k, 8)));
        }
    }
    // Data: per leaf, its value mask and its 512 values.
    c.seek(d.block_pos, "the grid data position")?;
    for origin in leaves {
        let (active, words) = c.mask(512, "leaf value mask")?;
        let values = values(c, d, 512, active)?;
        visit(Node { origin, log2: 3, active: words, children: &[], values })?;
    }
    Ok((map, transform))
}

/// An internal node of `log2` dimension (masks and values): its child mask and the node.
fn node<'a>(
    c: &mut Cursor<'a>,
    d: &Descriptor<'a>,
    log2: u32,
    origin: [i32; 3],
) -> Result<(&'a [u8], Node<'a>), ScanError> {
    let n = 1usize << (3 * log2);
    let (_, children) = c.mask(n, "child mask")?;
    let (active, words) = c.mask(n, "value mask")?;
    let values = values(c, d, n, active)?;
    Ok((children, Node { origin, log2, active: words, children, values }))
}

/// A node's compressed values (vdb-rs `read_compressed`, OpenVDB `readCompressedValues`): `n`
/// values, `active` of them active.
fn values<'a>(
    c: &mut Cursor<'a>,
    d: &Descriptor<'a>,
    n: usize,
    active: usize,
) -> Result<Values<'a>, ScanError> {
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
    c.take(inactive * 4, "inactive values")?;
    if matches!(meta, 3..=5) {
        c.take((n / 8) as u64, "selection mask")?;
    }
    let count = if d.compression & ACTIVE_MASK != 0 && meta != 6 { active } else { n };
    let size = if d.half { 2 } else { 4 };
    let bytes = (count * size) as u64;
    let none = |codec| Values { n, count, size, codec, block: &[] };
    if d.half && count == 0 {
        // OpenVDB writes nothing for an empty half-float block (see the module's text).
        return Ok(none(Codec::Raw));
    }
    if d.compression & (BLOSC | ZIP) == 0 {
        let block = c.take(bytes, "values")?;
        return Ok(Values { block, ..none(Codec::Raw) });
    }
    let size_at = c.pos;
    let stored = c.i64("compressed size")?;
    if stored <= 0 {
        // Stored uncompressed: vdb-rs reads |size| / 4 values, so anything but the node's count
        // would leave it reading other bytes than this scan checked, or short of values.
        if stored.unsigned_abs() != bytes {
            return c.fail(&format!("stored block of {} bytes for {count} values", -stored));
        }
        let block = c.take(bytes, "values")?;
        return Ok(Values { block, ..none(Codec::Raw) });
    }
    let block = c.take(stored as u64, "compressed values")?;
    if d.compression & BLOSC != 0 {
        if count > 0 {
            // The 16-byte Blosc header: decompressed size at 4..8, compressed size at 12..16,
            // which c-blosc 1.x trusts over the buffer's real length (a larger one made it read
            // past the buffer: found by the `vdb` fuzz target). Zip streams are bounded by their
            // decoder.
            let word = |k: usize| {
                block.get(k..k + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap_or_default()))
            };
            let at = Cursor { bytes: c.bytes, pos: size_at };
            if word(12).is_none_or(|n| n < 16 || n as usize > block.len()) {
                return at.fail(&match word(12) {
                    Some(n) => format!("a Blosc block of {} bytes says it holds {n}", block.len()),
                    None => {
                        format!("a Blosc block of {} bytes has no complete header", block.len())
                    }
                });
            }
            if word(4) != Some(bytes as u32) {
                return at.fail(&match word(4) {
                    Some(n) => format!(
                        "a compressed block says it expands to {n} bytes, but its {count} values need {bytes}"
                    ),
                    None => format!("a compressed block has no complete header ({count} values)"),
                });
            }
        }
        return Ok(Values { block, ..none(Codec::Blosc) });
    }
    Ok(Values { block, ..none(Codec::Zip) })
}

/// The grid's transform: its map's name and vectors (none for maps haze does not read).
fn read_transform<'a>(
    c: &mut Cursor<'a>,
    d: &Descriptor<'a>,
) -> Result<(&'a [u8], &'a [u8]), ScanError> {
    c.seek(d.grid_pos, "the grid position")?;
    c.u32("grid compression")?;
    metadata(c)?;
    let map = c.name("transform name")?;
    let vectors = match map {
        b"UniformScaleMap" => 5,
        b"UniformScaleTranslateMap" | b"ScaleTranslateMap" => 6,
        _ => 0,
    };
    Ok((map, c.take(vectors * 24, "transform")?))
}

/// The translation and voxel size of half-float grid `grid` (uniform-scale or scale-translate
/// maps; the caller refuses others first).
pub(crate) fn half_transform(bytes: &[u8], grid: &str) -> Result<([f64; 3], [f64; 3]), ScanError> {
    let (mut c, Some(d)) = locate(bytes, grid)? else {
        return Err(format!("no grid named `{grid}`"));
    };
    let (map, v) = read_transform(&mut c, &d)?;
    let vec = |k: usize| -> [f64; 3] {
        std::array::from_fn(|j| {
            let at = 24 * k + 8 * j;
            f64::from_le_bytes(v[at..at + 8].try_into().unwrap_or_default())
        })
    };
    match map {
        // Scale values, voxel size, …
        b"UniformScaleMap" => Ok(([0.0; 3], vec(1))),
        // Translation, scale values, voxel size, …
        _ if !v.is_empty() => Ok((vec(0), vec(2))),
        _ => Err("unsupported transform".into()),
    }
}

/// Calls `f(first voxel, edge length in voxels, value)` for every active voxel and tile (root
/// tiles included) of half-float grid `grid`, decoding the file's bytes; the walk checks every
/// count and length as [`scan`] does.
pub(crate) fn for_each_half(
    bytes: &[u8],
    grid: &str,
    f: &mut dyn FnMut([i32; 3], i32, f32),
) -> Result<(), ScanError> {
    let (mut c, Some(d)) = locate(bytes, grid)? else {
        return Err(format!("no grid named `{grid}`"));
    };
    let mut values = Vec::new();
    let mut raw = Vec::new();
    walk(&mut c, &d, &mut |node| {
        // Edge of a value: a voxel in a leaf, a tile of the node's children above.
        let edge = match node.log2 {
            3 => 1,
            4 => 8,
            5 => 128,
            _ => 4096,
        };
        decode(&node.values, &mut raw, &mut values)?;
        let dim = 1i32 << node.log2;
        let is_child = |i: usize| node.children.get(i / 8).is_some_and(|b| b & (1 << (i % 8)) != 0);
        for (k, i) in ones(node.active).enumerate() {
            if is_child(i) {
                continue;
            }
            // All values stored, or only the active ones, in order.
            let v = if node.values.count == node.values.n { values[i] } else { values[k] };
            let origin = if node.log2 == 0 {
                node.origin
            } else {
                let i = i as i32;
                let xyz = [i / (dim * dim), (i / dim) % dim, i % dim];
                std::array::from_fn(|a| node.origin[a].wrapping_add(xyz[a] * edge))
            };
            f(origin, edge, v);
        }
        Ok(())
    })?;
    Ok(())
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
    match v.size {
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
