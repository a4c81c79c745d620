//! Tests of the density grid: loading, both layouts and their lookups against the voxels of the file.

#![cfg(test)]

use super::super::vdbscan::Input;
use super::*;
use std::path::Path;

/// A corrupt file with two root nodes at one origin, a 128³ tile of 1 in the first and a leaf
/// with a voxel of 2 at the origin in the second (tests/fuzz-corpus/vdb/tile-overlap.vdb:
/// pyopenvdb wrote the tile at the origin and the voxel at (4096, 0, 0), then the second root
/// node's origin was patched to (0, 0, 0)): the bricks layout stores it as the dense one does,
/// the voxel over the tile, instead of indexing its pool with the tile's table entry.
#[test]
fn a_voxel_in_a_tile_is_stored_alike_in_both_layouts() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-corpus/vdb/tile-overlap.vdb");
    let dense = DensityGrid::load_with(&path, "density", Layout::Dense).unwrap();
    let bricks = DensityGrid::load_with(&path, "density", Layout::Bricks).unwrap();
    assert!(matches!(*bricks.storage, Storage::Bricks(_)));
    for (i, v) in [(IVec3::ZERO, 2.0), (IVec3::new(1, 0, 0), 1.0), (IVec3::splat(127), 1.0)] {
        assert_eq!((dense.voxel(i), bricks.voxel(i)), (v, v), "voxel {i}");
    }
    assert_eq!(bricks.voxel(IVec3::splat(128)), 0.0);
}

/// The libm-free floor is `f32::floor`, bit for bit but for the sign of a zero: at and
/// around integers, over the range a grid index takes, at the limits of exactness and
/// beyond, and for non-finite values.
#[test]
fn floor_without_libm_is_floor() {
    let mut xs = vec![0.0f32, -0.0, 0.5, -0.5, 1.0, -1.0, 8_388_607.5, -8_388_607.5];
    xs.extend([8_388_608.0, -8_388_608.0, 3e9, -3e9, f32::MAX, f32::MIN]);
    xs.extend([f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE, -f32::MIN_POSITIVE]);
    for k in -3000..3000 {
        let x = k as f32 * 0.37;
        // The floats beside x and below k (x ≠ 0: one step of the bit pattern away from 0).
        let (up, down) =
            (|v: f32| f32::from_bits(v.to_bits() + 1), |v: f32| f32::from_bits(v.to_bits() - 1));
        let kf = k as f32;
        xs.extend([x, kf]);
        if x != 0.0 {
            xs.extend([up(x), down(x), down(kf)]);
        }
    }
    for x in xs {
        let (got, want) = (floor(Vec3::splat(x)).x, x.floor());
        assert!(got == want && (got != 0.0 || want == 0.0), "floor({x}) = {got}, not {want}");
    }
    assert!(floor(Vec3::splat(f32::NAN)).x.is_nan());
}

use crate::testing::temp_dir;
use std::path::PathBuf;

fn media(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("media").join(name)
}

#[test]
fn good_grids_load_with_their_values() {
    let b = DensityGrid::load(&media("box.vdb"), "density").unwrap();
    assert_eq!(b.dims, IVec3::splat(16));
    let (lo, hi) = b.active_box;
    assert_eq!((lo, hi), (IVec3::ZERO, IVec3::splat(15)));
    assert_eq!(b.active_voxels, 16 * 16 * 16);
    assert_eq!(b.max_density, 1.0);
    assert_eq!(b.voxel(IVec3::new(3, 15, 7)), 1.0);
    assert!((b.voxel_size - Vec3::splat(1.0 / 16.0)).abs().max_element() < 1e-7);
    assert_eq!(b.translation, Vec3::ZERO);

    let g = DensityGrid::load(&media("gradient.vdb"), "density").unwrap();
    assert_eq!(g.dims, IVec3::new(32, 16, 16));
    for i in 0..32 {
        assert_eq!(g.voxel(IVec3::new(i, 3, 5)), (i as f32 + 0.5) / 32.0);
    }
    // Trilinear interpolation between voxel centres; zero outside.
    let q = Vec3::new(10.25, 3.0, 5.0);
    assert!((g.density_index(q) - (10.25 + 0.5) / 32.0).abs() < 1e-6);
    assert_eq!(g.voxel(IVec3::new(40, 0, 0)), 0.0);

    let h = DensityGrid::load(&media("holes.vdb"), "density").unwrap();
    assert_eq!(h.voxel(IVec3::new(5, 5, 5)), 8.0);
    assert_eq!(h.voxel(IVec3::new(21, 30, 30)), 40.0);
    assert_eq!(h.voxel(IVec3::new(25, 25, 25)), 0.0);
    assert_eq!(h.max_density, 40.0);

    let c = DensityGrid::load(&media("cloud.vdb"), "density").unwrap();
    assert!(c.max_density > 0.5 && c.max_density <= 1.0);
    assert!((c.translation - Vec3::splat(-1.0)).abs().max_element() < 1e-6);
}

fn expect_error(path: &Path, grid: &str, needles: &[&str]) {
    let msg = match DensityGrid::load(path, grid) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e) => e.to_string(),
    };
    assert!(msg.contains(&path.display().to_string()), "`{msg}` does not name the file");
    for n in needles {
        assert!(msg.contains(n), "`{msg}` does not mention `{n}`");
    }
}

/// Every voxel of `half` is that of `full` rounded to a 16-bit float (OpenVDB and the `half`
/// crate both round to nearest even), in the same box and transform.
fn assert_half_of(half: &DensityGrid, full: &DensityGrid) {
    assert_voxels_of(half, full, |v| half::f16::from_f32(v).to_f32());
}

/// `got` has `want`'s box, placement and active voxels, and every voxel of the box is
/// `round` of `want`'s, bit for bit.
fn assert_voxels_of(got: &DensityGrid, want: &DensityGrid, round: fn(f32) -> f32) {
    assert_eq!((got.origin, got.dims), (want.origin, want.dims));
    assert_eq!((got.translation, got.voxel_size), (want.translation, want.voxel_size));
    assert_eq!(got.active_voxels, want.active_voxels);
    let (lo, hi) = want.active_box;
    let mut nonzero = 0;
    for z in lo.z..=hi.z {
        for y in lo.y..=hi.y {
            for x in lo.x..=hi.x {
                let p = IVec3::new(x, y, z);
                let want = round(want.voxel(p));
                assert_eq!(got.voxel(p).to_bits(), want.to_bits(), "voxel {p}");
                nonzero += (want > 0.0) as usize;
            }
        }
    }
    assert!(nonzero > 500, "{nonzero} voxels compared");
}

/// The components of a 3-vector grid (`albedo[k]` of media/vector.vdb, as Houdini and
/// Blender write colour) read as the float grids they were made from (albedo.vdb's
/// `albedo.r`, `.g`, `.b`): every voxel bit for bit in full floats, rounded to half in
/// half/vector.vdb (6 bytes a value). A decoder that took the wrong component or stride fails
/// it; vector grids without a component and components of float grids are refused by name.
#[test]
fn vector_grids_read_component_by_component() {
    for (k, channel) in ["albedo.r", "albedo.g", "albedo.b"].iter().enumerate() {
        let float = DensityGrid::load(&media("albedo.vdb"), channel).unwrap();
        let name = format!("albedo[{k}]");
        let full = DensityGrid::load(&media("vector.vdb"), &name).unwrap();
        assert_eq!(full.active_voxels, 4096);
        assert_voxels_of(&full, &float, |v| v);
        let half = DensityGrid::load(&media("half/vector.vdb"), &name).unwrap();
        assert_half_of(&half, &float);
    }
    expect_error(&media("vector.vdb"), "albedo", &["vector grid", "`albedo[0]`"]);
    expect_error(&media("vector.vdb"), "density[1]", &["not a vector grid"]);
    expect_error(&media("vector.vdb"), "albedo[3]", &["no grid named `albedo[3]`"]);
    expect_error(&media("bad/vector.vdb"), "density", &["vector grid"]);
}

#[test]
fn half_float_grids_are_their_full_float_sources_rounded() {
    // vdb-rs 0.6 fails on every one of these (it reads a block size where OpenVDB wrote
    // none); haze decodes them itself.
    let cloud = DensityGrid::load(&media("cloud.vdb"), "density").unwrap();
    for codec in ["zip", "blosc", "none"] {
        let h = DensityGrid::load(&media(&format!("half/cloud-{codec}.vdb")), "density");
        assert_half_of(&h.unwrap(), &cloud);
    }
    // Tiles (a 128³ internal-node tile and leaf-level tiles) stored as half floats.
    for layout in [Layout::Dense, Layout::Bricks] {
        let full = DensityGrid::load_with(&media("tiles.vdb"), "density", layout).unwrap();
        let h = DensityGrid::load_with(&media("half/tiles-blosc.vdb"), "density", layout);
        let h = h.unwrap();
        assert_eq!(h.layout(), layout);
        assert_half_of(&h, &full);
    }
    // pyopenvdb's saveFloatAsHalf with the library's default codec.
    let cube = DensityGrid::load(&media("half/cube.vdb"), "density").unwrap();
    assert_eq!((cube.active_voxels, cube.max_density), (512, 0.5));
    assert_eq!(cube.voxel(IVec3::new(7, 0, 3)), 0.5);
}

/// haze's reader against vdb-rs 0.6 as an oracle, on every full-float grid of every bundled
/// file (zip and Blosc, leaves and tiles at both internal levels): the same active voxels
/// and tiles with the same values, bit for bit — and the same from a file as from its bytes
/// in memory. A decoder that misplaced or misread one value would fail it.
#[test]
fn the_reader_reads_every_value_as_vdb_rs_does() {
    let mut grids = 0;
    for file in ["albedo", "box", "cloud", "cumulus", "fire", "gradient", "holes", "tiles"] {
        let path = media(&format!("{file}.vdb"));
        let bytes = std::fs::read(&path).unwrap();
        let mut vdb = vdb_rs::VdbReader::new(std::io::Cursor::new(&bytes[..])).unwrap();
        let mut names = vdb.available_grids();
        names.sort();
        for name in names {
            if vdb.grid_descriptors[&name].grid_type != "Tree_float_5_4_3" {
                continue;
            }
            grids += 1;
            let grid = vdb.read_grid::<f32>(&name).unwrap();
            let mut oracle: Vec<([i32; 3], i32, u32)> = grid
                .iter()
                .map(|(p, v, level)| {
                    ([p.x as i32, p.y as i32, p.z as i32], level.scale() as i32, v.to_bits())
                })
                .collect();
            oracle.sort();
            for input in [Input::File(&path), Input::Memory(&bytes)] {
                let mut ours = Vec::new();
                let mut push = |p: [i32; 3], edge: i32, v: f32| ours.push((p, edge, v.to_bits()));
                super::super::vdbscan::for_each_value(input, &name, 0, &mut push).unwrap();
                ours.sort();
                assert_eq!(ours.len(), oracle.len(), "{file}.vdb `{name}`");
                assert!(ours == oracle, "{file}.vdb `{name}`: values differ");
            }
        }
    }
    assert!(grids >= 10, "only {grids} grids compared");
}

#[test]
fn files_vdb_rs_would_crash_on_or_misread_are_clear_errors() {
    expect_error(&media("bad/vector.vdb"), "density", &["is a vector grid"]);
    expect_error(&media("bad/affine.vdb"), "density", &["AffineMap"]);
    expect_error(&media("bad/duplicate.vdb"), "density", &["share the name"]);
    // One active root-level tile (4096³ voxels, which vdb-rs drops): read, and too large.
    expect_error(&media("bad/root-tile.vdb"), "density", &["4096×4096×4096 voxels"]);
    expect_error(
        &media("bad/far-apart.vdb"),
        "density",
        &["dense copy", "2048³ voxels for bricks"],
    );
    expect_error(&media("box.vdb"), "smoke", &["no grid named `smoke`", "density"]);
    expect_error(&media("no-such-file.vdb"), "density", &["No such file"]);

    let dir = temp_dir("vdb");
    for file in ["half/cloud-blosc.vdb", "half/cloud-zip.vdb"] {
        let good = std::fs::read(media(file)).unwrap();
        for cut in [200, good.len() / 3, good.len() - 100] {
            let p = dir.join(format!("truncated-half-{cut}.vdb"));
            std::fs::write(&p, &good[..cut]).unwrap();
            expect_error(&p, "density", &["corrupt file at byte"]);
        }
    }
    let good = std::fs::read(media("cloud.vdb")).unwrap();
    for cut in [12, 200, good.len() / 3, good.len() - 100] {
        let p = dir.join(format!("truncated-{cut}.vdb"));
        std::fs::write(&p, &good[..cut]).unwrap();
        expect_error(&p, "density", &[]);
    }
    let mut corrupt = good.clone();
    for (i, b) in corrupt.iter_mut().enumerate().skip(400).step_by(97) {
        *b ^= (i as u8).wrapping_mul(31) | 1;
    }
    let p = dir.join("corrupt.vdb");
    std::fs::write(&p, &corrupt).unwrap();
    // Flipped bytes may or may not be detectable; the load must simply not crash the process.
    let _ = DensityGrid::load(&p, "density");
    let p = dir.join("text.vdb");
    std::fs::write(&p, "not a volume at all").unwrap();
    expect_error(&p, "density", &["not an OpenVDB file"]);
    expect_error(&dir, "density", &["is a directory"]);
    expect_error(Path::new("/dev/zero"), "density", &["not a regular file"]);
}

/// The one-byte corruptions of issue 13 (media/README.md) on which vdb-rs 0.6 asked for
/// 10¹⁷–10¹⁸ bytes and the process aborted.
#[test]
fn corrupt_counts_are_refused_before_anything_is_allocated() {
    // Compressed blocks' lengths of 2⁵⁹ and 6·10¹⁸ bytes: refused before they are read (or
    // allocated).
    let holes = "corrupt file at byte 0x230d: a compressed block of 576460752303423504 bytes";
    expect_error(&media("bad/holes-0x230c.vdb"), "density", &[holes]);
    let cloud = "corrupt file at byte 0x3b3d7: a compressed block of 6845471433603155626 bytes";
    expect_error(&media("bad/cloud-0x3b3d6.vdb"), "density", &[cloud]);
    expect_error(&media("bad/box-0xec.vdb"), "density", &["corrupt file at byte", "remain"]);
    // Found by the `vdb` fuzz target: a Blosc header claiming more compressed bytes than its
    // block holds made c-blosc read past the buffer (AddressSanitizer: heap-buffer-overflow).
    expect_error(&media("bad/blosc-cbytes.vdb"), "density", &["Blosc block of 118 bytes"]);
}

/// Every byte of box.vdb set to 0x00, 0xff and flipped in turn: each load returns (a grid or
/// an error). An abort — what vdb-rs 0.6 does on a bad count — would take the test process
/// down with it, so this test cannot pass by accident.
#[test]
fn single_byte_mutations_of_a_grid_never_abort() {
    // A full-float grid and a half-float one (both read by haze's reader).
    for file in ["box.vdb", "half/cube.vdb"] {
        mutate_every_byte(&media(file));
    }
}

fn mutate_every_byte(path: &Path) {
    let good = std::fs::read(path).unwrap();
    let dir = temp_dir("vdb-mutations");
    let p = dir.join("m.vdb");
    let (mut ok, mut refused) = (0, 0);
    for i in 0..good.len() {
        for v in [0x00, 0xff, good[i] ^ 0x08] {
            if v == good[i] {
                continue;
            }
            let mut m = good.clone();
            m[i] = v;
            std::fs::write(&p, &m).unwrap();
            match DensityGrid::load(&p, "density") {
                Ok(_) => ok += 1,
                Err(_) => refused += 1,
            }
        }
    }
    assert!(refused > 0 && ok + refused > 2 * good.len(), "{ok} loaded, {refused} refused");
}

/// Scaling a grid whose storage is shared (as the scene's list of loaded grids shares it) makes
/// a scaled copy and leaves the other holder's values alone; the copy is, byte for byte, what
/// scaling a grid of its own in place gives — in both layouts, dense and bricks (tiles among
/// them), on one thread and on three.
#[test]
fn a_shared_grid_is_scaled_into_a_copy_of_its_own() {
    let bytes = |g: &DensityGrid| {
        let mut out = Vec::new();
        g.feed_values(&mut |b: &[u8]| out.extend_from_slice(b));
        out
    };
    for (file, layout) in
        [("cloud.vdb", Layout::Dense), ("cloud.vdb", Layout::Bricks), ("tiles.vdb", Layout::Bricks)]
    {
        let k = 3.7f32;
        let original = DensityGrid::load_with(&media(file), "density", layout).unwrap();
        let before = bytes(&original);
        let mut own = original.clone();
        // `own` shares `original`'s storage until it is scaled.
        assert!(std::sync::Arc::ptr_eq(&own.storage, &original.storage));
        let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
        pool(3).install(|| own.scale_values(k));
        assert!(!std::sync::Arc::ptr_eq(&own.storage, &original.storage), "{file}: not copied");
        assert_eq!(bytes(&original), before, "{file}: the shared values changed");
        let mut alone = DensityGrid::load_with(&media(file), "density", layout).unwrap();
        pool(1).install(|| alone.scale_values(k));
        assert_eq!(bytes(&own), bytes(&alone), "{file} ({layout:?})");
        assert_eq!(own.max_density, original.max_density * k);
        let i = original.active_box.0;
        assert_eq!(own.voxel(i), original.voxel(i) * k);
        assert_ne!(bytes(&own), before, "{file}: scaling changed nothing");
    }
}
