//! The Python module's results: an image whose layers are NumPy arrays made from the render's
//! own buffers (no copy), a partial render for splitting work, and the progress a callback sees.

use super::convert::{scene_error, to_py_err};
use super::pools::off_gil;
use crate::film::ErrorEstimate;
use crate::output::{Image, RenderInfo};
use crate::partial::Partial;
use numpy::ndarray::Array3;
use numpy::{PyArray3, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::path::PathBuf;

/// One RGB layer as an (H, W, 3) float32 array that owns the layer's buffer (moved, not
/// copied), and the buffer's address (for the test that shows it was not copied).
fn layer<'py>(
    py: Python<'py>,
    v: Vec<[f32; 3]>,
    w: u32,
    h: u32,
) -> PyResult<(Py<PyArray3<f32>>, usize)> {
    let flat = v.into_flattened();
    let address = flat.as_ptr() as usize;
    let a = Array3::from_shape_vec((h as usize, w as usize, 3), flat)
        .map_err(|e| scene_error(format!("an image layer does not match its size: {e}")))?;
    Ok((PyArray3::from_owned_array(py, a).unbind(), address))
}

/// A layer's pixels back from its array: (H, W, 3) float32 as made, whatever the user did with
/// the values.
fn pixels(
    py: Python<'_>,
    a: &Py<PyArray3<f32>>,
    w: u32,
    h: u32,
    name: &str,
) -> PyResult<Vec<[f32; 3]>> {
    let a = a.bind(py);
    if a.shape() != [h as usize, w as usize, 3] {
        return Err(scene_error(format!(
            "Image.{name} was reshaped to {:?}; it must stay ({h}, {w}, 3)",
            a.shape()
        )));
    }
    let ro = a.try_readonly()?;
    // In logical order, whatever the array's strides.
    let values: Vec<f32> = ro.as_array().iter().copied().collect();
    Ok(values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

/// An image's figures: its relative noise, kernel bias and error estimate.
struct Summary {
    relative_noise: Option<f64>,
    kernel_bias: Option<(f64, Option<f64>)>,
    error: Option<ErrorEstimate>,
}

impl Summary {
    fn of(image: &Image) -> Self {
        let s = &image.info.settings;
        Summary {
            relative_noise: image.relative_noise(None),
            kernel_bias: image.relative_bias(None),
            error: image.error_estimate(s.target_confidence, s.target_region),
        }
    }
}

/// A rendered image (see the package's documentation).
#[pyclass(module = "haze", name = "Image", frozen)]
pub struct PyImage {
    rgb: Py<PyArray3<f32>>,
    variance: Option<Py<PyArray3<f32>>>,
    bias: Option<Py<PyArray3<f32>>>,
    bias_variance: Option<Vec<[f32; 3]>>,
    techniques: Option<Vec<(String, Vec<[f32; 3]>)>>,
    info: RenderInfo,
    width: u32,
    height: u32,
    relative_noise: Option<f64>,
    kernel_bias: Option<(f64, Option<f64>)>,
    error: Option<ErrorEstimate>,
    addresses: [usize; 3],
}

impl PyImage {
    /// The image's layers handed to NumPy, with its summary (made off the GIL: [`Summary::of`]).
    fn new(py: Python<'_>, image: Image, summary: Summary) -> PyResult<Self> {
        let (w, h) = (image.width, image.height);
        let (rgb, a0) = layer(py, image.pixels, w, h)?;
        let variance = image.variance.map(|v| layer(py, v, w, h)).transpose()?;
        let bias = image.bias.map(|v| layer(py, v, w, h)).transpose()?;
        let addresses =
            [a0, variance.as_ref().map_or(0, |v| v.1), bias.as_ref().map_or(0, |v| v.1)];
        Ok(Self {
            rgb,
            variance: variance.map(|v| v.0),
            bias: bias.map(|v| v.0),
            bias_variance: image.bias_variance,
            techniques: image.techniques,
            info: image.info,
            width: w,
            height: h,
            relative_noise: summary.relative_noise,
            kernel_bias: summary.kernel_bias,
            error: summary.error,
            addresses,
        })
    }

    /// The image as the library's type again, its layers copied from the arrays.
    fn to_image(&self, py: Python<'_>) -> PyResult<Image> {
        let (w, h) = (self.width, self.height);
        let opt = |a: &Option<Py<PyArray3<f32>>>, name| {
            a.as_ref().map(|a| pixels(py, a, w, h, name)).transpose()
        };
        Ok(Image {
            width: w,
            height: h,
            pixels: pixels(py, &self.rgb, w, h, "rgb")?,
            variance: opt(&self.variance, "variance")?,
            bias: opt(&self.bias, "bias")?,
            bias_variance: self.bias_variance.clone(),
            techniques: self.techniques.clone(),
            info: self.info.clone(),
        })
    }
}

#[pymethods]
impl PyImage {
    /// Linear RGB radiance, float32 of shape (height, width, 3), top row first.
    #[getter]
    fn rgb(&self, py: Python<'_>) -> Py<PyArray3<f32>> {
        self.rgb.clone_ref(py)
    }

    /// Each pixel's estimated variance of the mean (as `rgb`), or None (fewer than two
    /// iterations).
    #[getter]
    fn variance(&self, py: Python<'_>) -> Option<Py<PyArray3<f32>>> {
        self.variance.as_ref().map(|a| a.clone_ref(py))
    }

    /// Each pixel's estimated kernel bias (as `rgb`), or None (the path tracer has none).
    #[getter]
    fn bias(&self, py: Python<'_>) -> Option<Py<PyArray3<f32>>> {
        self.bias.as_ref().map(|a| a.clone_ref(py))
    }

    /// (width, height) in pixels.
    #[getter]
    fn resolution(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Iterations averaged.
    #[getter]
    fn iterations(&self) -> u64 {
        self.info.iterations
    }

    /// The first iteration's index (1 unless a range was rendered).
    #[getter]
    fn first_iteration(&self) -> u64 {
        self.info.first_iteration
    }

    /// Seconds spent rendering.
    #[getter]
    fn elapsed(&self) -> f64 {
        self.info.elapsed
    }

    /// Light paths traced in all.
    #[getter]
    fn light_paths(&self) -> u64 {
        self.info.light_paths
    }

    /// The estimated relative noise of the whole image (√ of the mean variance over the mean),
    /// or None without a variance layer.
    #[getter]
    fn relative_noise(&self) -> Option<f64> {
        self.relative_noise
    }

    /// The estimated kernel bias relative to the image's mean, and its standard error: a pair,
    /// or None (the path tracer, or a black image).
    #[getter]
    fn kernel_bias(&self) -> Option<(f64, Option<f64>)> {
        self.kernel_bias
    }

    /// The estimated relative error (the figure `target_error` stops on: the upper confidence
    /// limit of the relative RMSE from noise and kernel bias), or None.
    #[getter]
    fn error(&self) -> Option<f64> {
        self.error.as_ref().map(|e| e.upper)
    }

    /// The render's settings, as a dict of the scene file's `[render]` keys.
    #[getter]
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        super::convert::settings_dict(py, &self.info.settings)
    }

    /// Writes the image: OpenEXR with its error layers and a PNG preview beside it (as the
    /// command line), or a PNG alone for a `.png` path; returns the paths written. The layers
    /// are read from the arrays as they are now.
    #[pyo3(signature = (path, exposure = 1.0))]
    fn write(&self, py: Python<'_>, path: PathBuf, exposure: f32) -> PyResult<Vec<PathBuf>> {
        let image = self.to_image(py)?;
        off_gil(py, None, || image.write(&path, exposure))?.map_err(to_py_err)
    }

    /// The addresses of the buffers the renderer produced for rgb, variance and bias (0 where
    /// absent): the arrays' data pointers equal them (no copy was made).
    fn _buffer_addresses(&self) -> [usize; 3] {
        self.addresses
    }

    fn __repr__(&self) -> String {
        let noise = self.relative_noise.map_or("-".into(), |n| format!("{:.2} %", 100.0 * n));
        format!(
            "<haze.Image {}x{}, {} iterations in {:.2} s, relative noise {noise}>",
            self.width, self.height, self.info.iterations, self.info.elapsed
        )
    }
}

/// A range of a render's iterations, to merge with the other ranges (see the package's
/// documentation).
#[pyclass(module = "haze", name = "Partial", frozen)]
pub struct PyPartial {
    pub(super) part: Partial,
}

impl PyPartial {
    /// Merges Partial objects and `.hpr` files (see `merge`).
    pub(super) fn merge_parts(py: Python<'_>, parts: Vec<Bound<'_, PyAny>>) -> PyResult<Self> {
        let mut list = Vec::with_capacity(parts.len());
        for p in parts {
            match p.cast::<PyPartial>() {
                Ok(p) => list.push(p.get().part.clone()),
                Err(_) => {
                    let path: PathBuf = p.extract().map_err(|_| {
                        scene_error(
                            "haze.merge: parts must be haze.Partial objects or paths to .hpr files",
                        )
                    })?;
                    list.push(off_gil(py, None, || Partial::read(&path))?.map_err(to_py_err)?);
                }
            }
        }
        let part = off_gil(py, None, || Partial::merge(list))?.map_err(scene_error)?;
        Ok(Self { part })
    }

    /// The image of these iterations, made on the pool of `threads` workers off the GIL.
    pub(super) fn image_on(&self, py: Python<'_>, threads: Option<usize>) -> PyResult<PyImage> {
        let (image, summary) = off_gil(py, threads, || {
            let image = self.part.image();
            let summary = Summary::of(&image);
            (image, summary)
        })?;
        PyImage::new(py, image, summary)
    }
}

#[pymethods]
impl PyPartial {
    /// Reads a partial render (`.hpr`) written by `Partial.write` or `haze render A..B`.
    #[staticmethod]
    fn read(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        off_gil(py, None, || Partial::read(&path))?.map(|part| Self { part }).map_err(to_py_err)
    }

    /// Merges partial renders of one scene (Partial objects or `.hpr` paths) into one partial
    /// render of the union of their ranges; refuses parts of other scenes or settings.
    #[staticmethod]
    fn merge(py: Python<'_>, parts: Vec<Bound<'_, PyAny>>) -> PyResult<Self> {
        Self::merge_parts(py, parts)
    }

    /// The image of these iterations.
    fn image(&self, py: Python<'_>) -> PyResult<PyImage> {
        self.image_on(py, None)
    }

    /// Writes the partial render (`.hpr`), for `haze merge` or `Partial.read`.
    fn write(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        off_gil(py, None, || self.part.write(&path))?.map_err(to_py_err)
    }

    /// The first iteration's index.
    #[getter]
    fn first_iteration(&self) -> u64 {
        self.part.info.first_iteration
    }

    /// The last iteration's index.
    #[getter]
    fn last_iteration(&self) -> u64 {
        self.part.last_iteration()
    }

    /// Iterations rendered.
    #[getter]
    fn iterations(&self) -> u64 {
        self.part.info.iterations
    }

    fn __repr__(&self) -> String {
        let i = &self.part.info;
        format!(
            "<haze.Partial iterations {}..{} ({} in all)>",
            i.first_iteration,
            self.part.last_iteration(),
            i.iterations
        )
    }
}

/// What a progress callback receives, after an iteration.
#[pyclass(module = "haze", name = "Progress", frozen, get_all)]
#[derive(Clone)]
pub struct PyProgress {
    /// Iterations finished in this call.
    pub iteration: u64,
    /// Iterations this call renders at most, or None (a time limit alone).
    pub total: Option<u64>,
    /// Seconds since the render started.
    pub elapsed: f64,
    /// The time limit in seconds, or None.
    pub time_limit: Option<f64>,
    /// The estimated relative error so far (as `Image.error`), or None.
    pub error: Option<f64>,
}

#[pymethods]
impl PyProgress {
    fn __repr__(&self) -> String {
        let total = self.total.map_or("?".into(), |t| t.to_string());
        let error = self.error.map_or("-".into(), |e| format!("{:.2} %", 100.0 * e));
        format!("<haze.Progress {}/{total}, {:.2} s, error {error}>", self.iteration, self.elapsed)
    }
}
