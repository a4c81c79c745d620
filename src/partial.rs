//! Partial renders: what an exact merge or a resume needs — the film's exact sums over a range of
//! iterations, the range, the settings and the scene's fingerprint — and their files.
//!
//! In probabilistic PPM every iteration depends only on (scene, settings, seed, iteration index),
//! and the film's sums are exact integers ([`crate::film`]), so iterations `a..=b` rendered
//! anywhere, in any number of pieces, merge into exactly the film of one render of `a..=b`:
//! [`Partial::merge`] of parts covering `1..=N` gives a bit-identical image to one process
//! rendering `N` iterations, and [`crate::render_partial`] resumed from a partial continues
//! exactly where it stopped. The file format is in `docs/distributed.md`.

use crate::error::{Error, Result};
use crate::film::Film;
use crate::output::{Image, RenderInfo, write_atomically};
use crate::settings::{Progression, RenderOptions, RenderSettings};
use std::io::Write;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"HAZEPART";
/// Format 2 added the kernel-bias sums of photon-mapping films; format 1 files (without them)
/// are still read.
const VERSION: u32 = 2;
/// Largest header accepted when reading (bytes).
const MAX_HEADER: u64 = 1 << 20;

/// A render of a range of iterations, with what merging and resuming need.
#[derive(Clone, Debug)]
pub struct Partial {
    /// How it was made; `info.iterations` is the number of iterations in the range, which starts
    /// at `info.first_iteration`.
    pub info: RenderInfo,
    /// The exact sums of the range's iteration images.
    pub film: Film,
    /// The scene's fingerprint ([`crate::Scene::fingerprint`]).
    pub fingerprint: [u8; 32],
    /// State a method carries between iterations (the original PPM's per-pixel statistics).
    pub(crate) state: Option<Vec<u8>>,
    /// The image file the render that made this partial was writing, if any (the command line
    /// records it, so that a resume continues the same files unless told otherwise).
    pub output: Option<PathBuf>,
    /// With `techniques` on (the combined integrator): each technique's weighted contribution,
    /// named. Held in memory only: not written to partial files, and dropped by a merge.
    pub techniques: Option<Vec<(String, Vec<[f32; 3]>)>>,
}

/// Bytes before the header: magic, version and the header's length.
const PREFIX_BYTES: u64 = 8 + 4 + 8;

/// The most bytes a partial render of `pixels` pixels with a header of `header` bytes can hold:
/// the prefix, the header, the state's length and the state (the original PPM's, the largest),
/// four layers of sums (three i128 a pixel each) and the checksum.
fn most_bytes(pixels: u64, header: u64) -> u64 {
    let state = 8 + crate::integrator::original::STATE_BYTES as u64 * pixels;
    PREFIX_BYTES + header + 8 + state + 4 * 48 * pixels + 32
}

/// [`most_bytes`] for the image size the file's header states, reading only its first bytes; a
/// header it cannot read gives the bound of the largest image, and [`Partial::read`] reports what
/// is wrong with it. `path` must be a regular file ([`crate::input::check_file`]).
fn size_bound(path: &Path) -> Result<u64> {
    use std::io::Read;
    let io = |error: std::io::Error| Error::Io { path: path.to_path_buf(), error };
    let mut prefix = Vec::new();
    let file = std::fs::File::open(path).map_err(io)?;
    file.take(PREFIX_BYTES + MAX_HEADER).read_to_end(&mut prefix).map_err(io)?;
    let at = PREFIX_BYTES as usize;
    let n =
        prefix.get(at - 8..at).map_or(0, |b| u64::from_le_bytes(b.try_into().unwrap_or_default()));
    let n = n.min(MAX_HEADER);
    let table = prefix
        .get(at..at + n as usize)
        .and_then(|h| std::str::from_utf8(h).ok())
        .and_then(|h| h.parse::<toml::Table>().ok());
    let int = |t: &toml::Table, k: &str| t.get(k).and_then(|v| v.as_integer());
    let pixels = table.as_ref().and_then(|t| {
        let (w, h) = (int(t, "width")?, int(t, "height")?);
        (w > 0 && h > 0).then(|| (w as u64).saturating_mul(h as u64))
    });
    Ok(match pixels {
        Some(p) if p <= crate::scene::MAX_PIXELS => most_bytes(p, n),
        _ => most_bytes(crate::scene::MAX_PIXELS, MAX_HEADER),
    })
}

fn part_err(path: &Path, message: impl Into<String>) -> Error {
    Error::Output { path: path.to_path_buf(), message: message.into() }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Settings that must agree between the parts of one render: all but the stop conditions.
fn merge_key(s: &RenderSettings) -> Vec<(String, String)> {
    // When to stop is not what is rendered.
    let when = ["iterations", "time_limit", "target_error", "target_confidence", "target_region"];
    s.entries().into_iter().filter(|(k, _)| !when.contains(&k.as_str())).collect()
}

impl Partial {
    /// The last iteration of the range (`first_iteration − 1` if it is empty).
    pub fn last_iteration(&self) -> u64 {
        self.info.first_iteration + self.info.iterations - 1
    }

    /// The image of the range: the mean of its iterations.
    pub fn image(&self) -> Image {
        let mut image = Image::from_film(&self.film, self.info.clone());
        image.techniques = self.techniques.clone();
        image
    }

    /// Checks that `other` is a piece of the same render: same scene fingerprint, image size and
    /// settings (all but the stop conditions: `iterations`, `time_limit` and the target error's
    /// keys). The error names the first difference.
    pub fn check_compatible(&self, other: &Partial) -> std::result::Result<(), String> {
        let size = [other.film.width(), other.film.height()];
        self.check_matches(&other.fingerprint, size, &other.info.settings)
    }

    /// Checks that this is a piece of a render of the scene with `fingerprint` at `size` with
    /// `settings` (all but `iterations` and `time_limit` must agree), as a resume needs. The
    /// error names the first difference, this partial's value first. A partial records the
    /// integrator that rendered it, never `auto`: resolve `settings` first
    /// ([`crate::RenderSettings::resolved`]), as [`crate::render_partial`] does.
    pub fn check_matches(
        &self,
        fingerprint: &[u8; 32],
        size: [u32; 2],
        settings: &RenderSettings,
    ) -> std::result::Result<(), String> {
        // The size first: it is part of the fingerprint too, and the likelier difference.
        let own = [self.film.width(), self.film.height()];
        if own != size {
            return Err(format!(
                "image sizes differ: {}x{} and {}x{}",
                own[0], own[1], size[0], size[1]
            ));
        }
        if &self.fingerprint != fingerprint {
            return Err("renders of different scenes (or of a scene, mesh or volume file that \
                 changed in between): their fingerprints differ"
                .into());
        }
        let (ka, kb) = (merge_key(&self.info.settings), merge_key(settings));
        for ((k, va), (_, vb)) in ka.iter().zip(&kb) {
            if va != vb {
                return Err(format!("settings differ: render.{k} = {va} and {vb}"));
            }
        }
        if ka.len() != kb.len() {
            return Err("settings differ".into());
        }
        Ok(())
    }

    /// Merges the parts of one render into the partial of the union of their ranges. The parts
    /// may come in any order; they must be compatible ([`Self::check_compatible`]), their ranges
    /// disjoint and without gaps (the error names every gap or overlap). The result is exact: its
    /// film equals that of one render of the whole range.
    pub fn merge(mut parts: Vec<Partial>) -> std::result::Result<Partial, String> {
        if parts.is_empty() {
            return Err("nothing to merge".into());
        }
        if parts[0].info.settings.progression == Progression::Original {
            return Err("the original PPM keeps per-pixel statistics that cannot be merged \
                 (progression = \"original\"); its renders can only be resumed"
                .into());
        }
        for p in &parts[1..] {
            parts[0].check_compatible(p)?;
        }
        parts.retain(|p| p.info.iterations > 0);
        if parts.is_empty() {
            return Err("every part is empty".into());
        }
        parts.sort_by_key(|p| p.info.first_iteration);
        let mut problems = Vec::new();
        // The furthest iteration covered so far, and the part that reached it.
        let (mut end, mut by) = (parts[0].last_iteration(), 0);
        for (k, p) in parts.iter().enumerate().skip(1) {
            let next = p.info.first_iteration;
            if next <= end {
                let q = &parts[by];
                problems.push(format!(
                    "iterations {}..{} and {}..{} overlap",
                    q.info.first_iteration,
                    q.last_iteration(),
                    next,
                    p.last_iteration()
                ));
            } else if next > end + 1 {
                problems.push(format!("iterations {}..{} are missing", end + 1, next - 1));
            }
            if p.last_iteration() > end {
                (end, by) = (p.last_iteration(), k);
            }
        }
        if !problems.is_empty() {
            return Err(problems.join("; "));
        }
        let several = parts.len() > 1;
        let mut it = parts.into_iter();
        let mut out = it.next().expect("non-empty");
        if several {
            out.techniques = None;
        }
        for p in it {
            out.film.merge(&p.film);
            let (i, j) = (&mut out.info, &p.info);
            i.iterations += j.iterations;
            i.light_paths += j.light_paths;
            i.elapsed += j.elapsed;
            i.nonfinite_samples += j.nonfinite_samples;
            i.truncated_trackings += j.truncated_trackings;
            // The radius of the last iteration: the later part's.
            i.radius = j.radius;
            i.volume_radius = j.volume_radius;
        }
        out.info.settings.iterations = Some(out.last_iteration());
        Ok(out)
    }

    /// Writes the partial-render file (atomically).
    pub fn write(&self, path: &Path) -> Result<()> {
        let header = self.header().map_err(|e| part_err(path, format!("not written: {e}")))?;
        let ([sum, sum_sq], bias) = self.film.sums();
        let [bias_sum, bias_sq] = bias.unwrap_or([&[], &[]]);
        let state = self.state.as_deref().unwrap_or(&[]);
        write_atomically(path, |w| {
            let mut put = |b: &[u8]| w.write_all(b).map_err(|e| e.to_string());
            put(MAGIC)?;
            put(&VERSION.to_le_bytes())?;
            put(&(header.len() as u64).to_le_bytes())?;
            put(header.as_bytes())?;
            put(&(state.len() as u64).to_le_bytes())?;
            put(state)?;
            for px in sum.iter().chain(sum_sq).chain(bias_sum).chain(bias_sq) {
                for c in px {
                    put(&c.to_le_bytes())?;
                }
            }
            put(&self.checksum(&header, state))
        })
    }

    /// A digest of the header, state and sums, stored last: a truncated or altered file is
    /// refused.
    fn checksum(&self, header: &str, state: &[u8]) -> [u8; 32] {
        use sha2::Digest;
        let mut h = sha2::Sha256::new();
        h.update(header.as_bytes());
        h.update(state);
        let ([sum, sum_sq], bias) = self.film.sums();
        let [bias_sum, bias_sq] = bias.unwrap_or([&[], &[]]);
        for px in sum.iter().chain(sum_sq).chain(bias_sum).chain(bias_sq) {
            for c in px {
                h.update(c.to_le_bytes());
            }
        }
        h.finalize().into()
    }

    fn header(&self) -> std::result::Result<String, String> {
        let i = &self.info;
        let mut t = toml::Table::new();
        let mut put = |k: &str, v: toml::Value| {
            t.insert(k.into(), v);
        };
        put("format", "haze partial render".into());
        put("fingerprint", hex(&self.fingerprint).into());
        put("width", (self.film.width() as i64).into());
        put("height", (self.film.height() as i64).into());
        put("first_iteration", (i.first_iteration as i64).into());
        put("iterations", (i.iterations as i64).into());
        put("light_paths", (i.light_paths as i64).into());
        put("initial_radius", i.initial_radius.into());
        put("radius", i.radius.into());
        put("volume_initial_radius", i.volume_initial_radius.into());
        put("volume_radius", i.volume_radius.into());
        put("elapsed_seconds", i.elapsed.into());
        put("nonfinite_samples", (i.nonfinite_samples as i64).into());
        put("truncated_trackings", (i.truncated_trackings as i64).into());
        put("saturated_values", (self.film.saturated() as i64).into());
        put("bias_sums", self.film.has_bias().into());
        if let Some(scene) = i.scene.as_ref().and_then(|p| p.to_str()) {
            put("scene", scene.into());
        }
        if let Some(output) = self.output.as_ref().and_then(|p| p.to_str()) {
            put("output", output.into());
        }
        let settings = toml::Table::try_from(&i.settings).map_err(|e| e.to_string())?;
        put("settings", toml::Value::Table(settings));
        toml::to_string(&t).map_err(|e| e.to_string())
    }

    /// Reads a partial-render file, checking its structure and checksum.
    pub fn read(path: &Path) -> Result<Partial> {
        // Past the largest partial render (18.8 GB), or past the most one of the image size its
        // header states can hold, a file is refused before it is read.
        let largest = most_bytes(crate::scene::MAX_PIXELS, MAX_HEADER);
        crate::input::check_file(path, largest, "a partial render")?;
        let what = "a partial render of the size its header states";
        let bytes = crate::input::read_bounded(path, size_bound(path)?, what)?;
        Self::from_bytes(&bytes, path)
    }

    /// A partial render from a file's bytes (`path` names it in errors), checked as [`read`]
    /// checks a file.
    ///
    /// [`read`]: Self::read
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Partial> {
        let err = |m: String| part_err(path, m);
        let mut r = Bytes { bytes, at: 0, path };
        if r.take(8, "magic")? != MAGIC {
            return Err(err("not a haze partial render (bad magic number)".into()));
        }
        let version = u32_of(r.take(4, "version")?);
        if version != VERSION && version != 1 {
            return Err(err(format!(
                "partial render format {version}; this haze reads formats 1 to {VERSION}"
            )));
        }
        let n = u64_of(r.take(8, "header")?);
        if n > MAX_HEADER {
            return Err(err(format!("header of {n} bytes (corrupt file)")));
        }
        let header = std::str::from_utf8(r.take(n, "header")?)
            .map_err(|_| err("header is not UTF-8 (corrupt file)".into()))?
            .to_string();
        let n = u64_of(r.take(8, "state")?);
        let state = r.take(n, "state")?.to_vec();
        let h = Header::parse(&header, path)?;
        let (width, height) = (h.int("width")?, h.int("height")?);
        let pixels = width.checked_mul(height).filter(|&p| p > 0 && p <= crate::scene::MAX_PIXELS);
        let pixels =
            pixels.ok_or_else(|| err(format!("header: impossible size {width}x{height}")))?;
        let sum = r.sums(pixels, "sums")?;
        let sum_sq = r.sums(pixels, "sums of squares")?;
        let has_bias = match h.t.get("bias_sums") {
            None if version == 1 => false,
            Some(toml::Value::Boolean(b)) => *b,
            _ => return Err(err("header: `bias_sums` missing or not true/false".into())),
        };
        let bias = if has_bias {
            Some([r.sums(pixels, "bias sums")?, r.sums(pixels, "bias sums of squares")?])
        } else {
            None
        };
        let stored: [u8; 32] = r.take(32, "checksum")?.try_into().unwrap_or_default();
        if r.at != bytes.len() {
            return Err(err(format!("{} bytes after the end (corrupt file)", bytes.len() - r.at)));
        }
        let settings = h.settings()?;
        let fingerprint = h.fingerprint()?;
        let info = h.info(settings)?;
        let film = Film::from_sums(
            width as u32,
            height as u32,
            [sum, sum_sq],
            bias,
            info.iterations,
            h.int("saturated_values")?,
        );
        let output = h.t.get("output").and_then(|v| v.as_str()).map(PathBuf::from);
        let state = (!state.is_empty()).then_some(state);
        let part = Partial { info, film, fingerprint, state, output, techniques: None };
        if part.checksum(&header, part.state.as_deref().unwrap_or(&[])) != stored {
            return Err(err("checksum mismatch: the file is corrupt".into()));
        }
        Ok(part)
    }
}

fn u32_of(b: &[u8]) -> u32 {
    u32::from_le_bytes(b.try_into().unwrap_or_default())
}

fn u64_of(b: &[u8]) -> u64 {
    u64::from_le_bytes(b.try_into().unwrap_or_default())
}

/// A partial render's bytes, read from the front; every read past the end is an error naming
/// the part it was reading.
struct Bytes<'a> {
    bytes: &'a [u8],
    at: usize,
    path: &'a Path,
}

impl<'a> Bytes<'a> {
    fn take(&mut self, n: u64, what: &str) -> Result<&'a [u8]> {
        let end = (self.at as u64).checked_add(n).filter(|&e| e <= self.bytes.len() as u64);
        let end = end.ok_or_else(|| {
            part_err(self.path, format!("truncated partial render (in its {what})"))
        })?;
        let s = &self.bytes[self.at..end as usize];
        self.at = end as usize;
        Ok(s)
    }

    /// One layer of per-pixel sums: three i128 per pixel.
    fn sums(&mut self, pixels: u64, what: &str) -> Result<Vec<[i128; 3]>> {
        let raw = self.take(pixels * 48, what)?;
        Ok(raw
            .chunks_exact(48)
            .map(|px| {
                let c = |k: usize| {
                    i128::from_le_bytes(px[16 * k..16 * k + 16].try_into().unwrap_or_default())
                };
                [c(0), c(1), c(2)]
            })
            .collect())
    }
}

/// A partial render's TOML header, each field read with an error naming it.
struct Header<'a> {
    t: toml::Table,
    path: &'a Path,
}

impl<'a> Header<'a> {
    fn parse(header: &str, path: &'a Path) -> Result<Self> {
        // toml's own Display is a multi-line diagnostic: one line, with the header's line.
        let t: toml::Table = header.parse().map_err(|e: toml::de::Error| {
            let line = e.span().map(|s| header[..s.start.min(header.len())].lines().count().max(1));
            let at = line.map(|l| format!(" line {l}:")).unwrap_or_default();
            let message = e.message().trim().replace('\n', " ");
            part_err(path, format!("header:{at} {message} (corrupt file)"))
        })?;
        Ok(Header { t, path })
    }

    fn err(&self, m: String) -> crate::Error {
        part_err(self.path, m)
    }

    /// A whole number, at least 0.
    fn int(&self, k: &str) -> Result<u64> {
        let t = &self.t;
        t.get(k).and_then(|v| v.as_integer()).filter(|&v| v >= 0).map(|v| v as u64).ok_or_else(
            || match t.get(k) {
                None => self.err(format!("header: `{k}` missing")),
                Some(v) => self.err(format!(
                    "header: `{k}` is {}; it must be a whole number, at least 0",
                    crate::error::quote(&v.to_string())
                )),
            },
        )
    }

    /// A number that must be finite and non-negative (radii, seconds): an integer is taken.
    fn float(&self, k: &str) -> Result<f64> {
        let v = match self.t.get(k) {
            None => return Err(self.err(format!("header: `{k}` missing"))),
            Some(toml::Value::Float(f)) => *f,
            Some(toml::Value::Integer(i)) => *i as f64,
            Some(other) => {
                let kind = other.type_str();
                return Err(self.err(format!("header: `{k}` is a {kind}, not a number")));
            }
        };
        if !(v.is_finite() && v >= 0.0) {
            return Err(
                self.err(format!("header: `{k}` is {v}; it must be finite and non-negative"))
            );
        }
        Ok(v)
    }

    /// The render settings, without a goal (a partial's goal is its caller's).
    fn settings(&self) -> Result<RenderSettings> {
        let settings_table = self
            .t
            .get("settings")
            .and_then(|v| v.as_table())
            .cloned()
            .ok_or_else(|| self.err("header: `settings` missing".into()))?;
        let options: RenderOptions = toml::Value::Table(settings_table)
            .try_into()
            .map_err(|e: toml::de::Error| self.err(format!("header: settings: {}", e.message())))?;
        Ok(RenderSettings { iterations: None, time_limit: None, ..Default::default() }
            .with(&options))
    }

    /// The scene's fingerprint, 64 hexadecimal digits.
    fn fingerprint(&self) -> Result<[u8; 32]> {
        let fp = self.t.get("fingerprint").and_then(|v| v.as_str()).unwrap_or_default();
        let mut fingerprint = [0u8; 32];
        if fp.len() != 64 || !fp.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(self.err("header: `fingerprint` missing or invalid".into()));
        }
        for (k, b) in fingerprint.iter_mut().enumerate() {
            *b = u8::from_str_radix(&fp[2 * k..2 * k + 2], 16).unwrap_or_default();
        }
        Ok(fingerprint)
    }

    /// How the partial was rendered, with `settings`.
    fn info(&self, settings: RenderSettings) -> Result<RenderInfo> {
        let first_iteration = self.int("first_iteration")?;
        if first_iteration == 0 {
            return Err(self.err("header: `first_iteration` must be at least 1".into()));
        }
        Ok(RenderInfo {
            settings,
            first_iteration,
            iterations: self.int("iterations")?,
            light_paths: self.int("light_paths")?,
            initial_radius: self.float("initial_radius")?,
            radius: self.float("radius")?,
            volume_initial_radius: self.float("volume_initial_radius")?,
            volume_radius: self.float("volume_radius")?,
            elapsed: self.float("elapsed_seconds")?,
            scene: self.t.get("scene").and_then(|v| v.as_str()).map(PathBuf::from),
            nonfinite_samples: self.int("nonfinite_samples")?,
            truncated_trackings: self.int("truncated_trackings")?,
        })
    }
}
