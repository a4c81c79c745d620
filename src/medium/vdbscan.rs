//! A structural pre-scan of an OpenVDB file, run over its bytes before vdb-rs 0.6 sees them.
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
    half: bool,
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
/// grid vdb-rs will be asked to read (other grids are refused by name and type later, with their
/// own messages).
pub(crate) fn scan(bytes: &[u8], grid: &str) -> Result<(), ScanError> {
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
        let half = metadata(&mut c)?;
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
    match found {
        Some(d) if d.grid_type == b"Tree_float_5_4_3" && !d.half => scan_grid(&mut c, &d),
        _ => Ok(()),
    }
}

/// The transform, topology and leaf data of a float grid.
fn scan_grid(c: &mut Cursor, d: &Descriptor) -> Result<(), ScanError> {
    c.seek(d.grid_pos, "the grid position")?;
    c.u32("grid compression")?;
    metadata(c)?;
    let map = c.name("transform name")?;
    let vectors = match map {
        b"UniformScaleMap" => 5,
        b"UniformScaleTranslateMap" | b"ScaleTranslateMap" => 6,
        _ => return Ok(()), // refused by name later (vdb-rs would panic on it)
    };
    c.take(vectors * 24, "transform")?;
    if c.u32("buffer count")? != 1 {
        return c.fail("multi-buffer trees are not supported");
    }
    c.take(4, "background value")?;
    let tiles = c.u32("root tile count")?;
    let roots = c.u32("root child count")?;
    c.take(tiles as u64 * 17, "root tiles")?;
    // Topology: per root child, a 32³ internal node, its 16³ children, their 8³ leaves' masks.
    let mut leaves: Vec<u32> = Vec::new(); // leaves per 16³ node, in file order
    for _ in 0..roots {
        c.take(12, "root child origin")?;
        let children5 = node(c, d, 5)?;
        for _ in 0..children5 {
            let children4 = node(c, d, 4)?;
            c.take(children4 as u64 * 64, "leaf masks")?;
            leaves.push(children4 as u32);
        }
    }
    // Data: per leaf, its value mask and its 512 values.
    c.seek(d.block_pos, "the grid data position")?;
    for n in leaves {
        for _ in 0..n {
            let (active, _) = c.mask(512, "leaf value mask")?;
            values(c, d, 512, active)?;
        }
    }
    Ok(())
}

/// An internal node of `log2` dimension (masks and values); returns its number of children.
fn node(c: &mut Cursor, d: &Descriptor, log2: u32) -> Result<usize, ScanError> {
    let n = 1usize << (3 * log2);
    let (_, child_words) = c.mask(n, "child mask")?;
    let (active, _) = c.mask(n, "value mask")?;
    values(c, d, n, active)?;
    Ok(ones(child_words).count())
}

/// A node's compressed values (vdb-rs `read_compressed`): `n` values, `active` of them active.
fn values(c: &mut Cursor, d: &Descriptor, n: usize, active: usize) -> Result<(), ScanError> {
    let meta = c.u8("node metadata")?;
    if meta > 6 {
        return c.fail(&format!("invalid node metadata {meta}"));
    }
    // 2: one inactive value; 4: mask and one; 5: mask and two.
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
    let bytes = (count * 4) as u64;
    if d.compression & (BLOSC | ZIP) == 0 {
        c.take(bytes, "values")?;
        return Ok(());
    }
    let size = c.i64("compressed size")?;
    if size <= 0 {
        // Stored uncompressed: vdb-rs reads |size| / 4 values, so anything but the node's count
        // would leave it reading other bytes than this scan checked, or short of values.
        if size.unsigned_abs() != bytes {
            return c.fail(&format!("stored block of {} bytes for {count} values", -size));
        }
        c.take(bytes, "values")?;
        return Ok(());
    }
    let block = c.take(size as u64, "compressed values")?;
    if d.compression & BLOSC != 0 && count > 0 {
        // The 16-byte Blosc header: decompressed size at 4..8, compressed size at 12..16, which
        // c-blosc 1.x trusts over the buffer's real length (a larger one made it read past the
        // buffer: found by the `vdb` fuzz target). Zip streams are bounded by their decoder.
        let word = |k: usize| {
            block.get(k..k + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap_or_default()))
        };
        if word(12).is_none_or(|n| n < 16 || n as usize > block.len()) {
            return c.fail(&match word(12) {
                Some(n) => format!("a Blosc block of {} bytes says it holds {n}", block.len()),
                None => format!("a Blosc block of {} bytes has no complete header", block.len()),
            });
        }
        if word(4) != Some(bytes as u32) {
            return c.fail(&match word(4) {
                Some(n) => format!(
                    "a compressed block says it expands to {n} bytes, but its {count} values need {bytes}"
                ),
                None => format!("a compressed block has no complete header ({count} values)"),
            });
        }
    }
    Ok(())
}
