//! The Python module `haze` (feature `python`, built by maturin from pyproject.toml; the Python
//! side, its stub and its documentation are in `src/python/haze/`, the guide is
//! docs/python.md).
//!
//! A render runs as a job of a worker pool (`pools.rs`) with the GIL released; the calling
//! thread waits for it, taking the GIL every [`POLL`] to look for Ctrl-C (`KeyboardInterrupt`:
//! the render stops at once, dropping the iteration under way) and to call the progress
//! callback, at most every [`CALLBACK_EVERY`].
//! Layers reach NumPy without a copy: each array owns the buffer the renderer filled.

mod convert;
mod image;
mod pools;

use crate::output::RenderInfo;
use crate::partial::Partial;
use crate::progress::Status;
use crate::render::{Start, render_partial};
use crate::settings::{RenderOptions, RenderSettings};
use crate::{Error, Scene};
use convert::{SceneError, scene_error, settings_dict, to_py_err};
use image::{PyImage, PyPartial, PyProgress};
use pools::{off_gil, pool};
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyRange};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

/// How often the waiting thread looks for Ctrl-C.
const POLL: Duration = Duration::from_millis(50);
/// The shortest time between two calls of a progress callback.
const CALLBACK_EVERY: Duration = Duration::from_millis(250);

/// A scene, loaded and checked (see the package's documentation).
#[pyclass(module = "haze", name = "Scene", frozen)]
struct PyScene {
    scene: Arc<Scene>,
    /// The scene file, for a scene loaded from one.
    file: Option<PathBuf>,
}

/// An error of a scene given as a dict: without line numbers, which would count lines of the
/// TOML text made from the dict.
fn without_line(e: Error) -> Error {
    match e {
        Error::Parse { path, message, .. } => Error::Parse { path, line: None, message },
        Error::Invalid { path, key, message, .. } => {
            Error::Invalid { path, line: None, key, message }
        }
        other => other,
    }
}

#[pymethods]
impl PyScene {
    /// Loads a scene file (docs/scene-format.md); relative paths in it resolve against the
    /// file's directory.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let scene = off_gil(py, None, || Scene::load(&path))?.map_err(to_py_err)?;
        Ok(Self { scene: Arc::new(scene), file: Some(path) })
    }

    /// A scene from the text of a scene file; relative paths resolve against `base_dir` (the
    /// working directory by default); `name` names the text in error messages.
    #[staticmethod]
    #[pyo3(signature = (text, base_dir = None, name = "<string>"))]
    fn from_toml(
        py: Python<'_>,
        text: &str,
        base_dir: Option<PathBuf>,
        name: &str,
    ) -> PyResult<Self> {
        let base = base_dir.unwrap_or_else(|| PathBuf::from("."));
        let scene = off_gil(py, None, || Scene::from_toml(text, Path::new(name), &base))?
            .map_err(to_py_err)?;
        Ok(Self { scene: Arc::new(scene), file: None })
    }

    /// A scene from a dict with the keys of a scene file (`camera`, `render`, `materials`,
    /// `media`, `shapes`, `lights`); relative paths resolve against `base_dir` (the working
    /// directory by default). Errors name the key, e.g. `<dict>: media.fog.sigma_s: …`.
    #[staticmethod]
    #[pyo3(signature = (scene, base_dir = None))]
    fn from_dict(
        py: Python<'_>,
        scene: &Bound<'_, PyDict>,
        base_dir: Option<PathBuf>,
    ) -> PyResult<Self> {
        let table = convert::table(scene, "")?;
        let text = toml::to_string(&table).map_err(|e| scene_error(format!("<dict>: {e}")))?;
        let base = base_dir.unwrap_or_else(|| PathBuf::from("."));
        let scene = off_gil(py, None, || Scene::from_toml(&text, Path::new("<dict>"), &base))?
            .map_err(|e| to_py_err(without_line(e)))?;
        Ok(Self { scene: Arc::new(scene), file: None })
    }

    /// (width, height) of the camera's image in pixels.
    #[getter]
    fn resolution(&self) -> (u32, u32) {
        let [w, h] = self.scene.camera.resolution;
        (w, h)
    }

    /// The scene's render settings (its `[render]` table over the defaults), as a dict.
    #[getter]
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        settings_dict(py, &self.scene.settings)
    }

    /// The scene file's path, or None for a scene made from text or a dict.
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.file.clone()
    }

    fn __repr__(&self) -> String {
        let [w, h] = self.scene.camera.resolution;
        let from =
            self.scene.source.as_ref().map_or(String::new(), |p| format!(" from {}", p.display()));
        format!("<haze.Scene {w}x{h}{from}>")
    }
}

/// The iterations of a render call: a count (from iteration 1), a range of indices (a partial
/// render), or the scene's own.
enum Iterations {
    Scene,
    Count(u64),
    Range(u64, u64),
}

fn parse_iterations(v: Option<&Bound<'_, PyAny>>) -> PyResult<Iterations> {
    let Some(v) = v else { return Ok(Iterations::Scene) };
    if let Ok(r) = v.cast::<PyRange>() {
        let (start, stop, step): (i64, i64, i64) = (
            r.getattr("start")?.extract()?,
            r.getattr("stop")?.extract()?,
            r.getattr("step")?.extract()?,
        );
        if step != 1 || start < 1 || stop <= start {
            return Err(scene_error(format!(
                "iterations: a range of iteration indices needs step 1, a start of at least 1 and \
                 an end past it (indices count from 1, as on the command line: range(1, 9) is \
                 1..8), got range({start}, {stop}, {step})"
            )));
        }
        return Ok(Iterations::Range(start as u64, stop as u64 - 1));
    }
    match v.extract::<i64>() {
        Ok(n) if n >= 1 => Ok(Iterations::Count(n as u64)),
        _ => {
            Err(scene_error(format!("iterations: must be a positive integer or a range, got {v}")))
        }
    }
}

/// The settings of a render call: the scene's, then the keyword arguments as a `[render]` table.
fn render_settings(scene: &Scene, table: &toml::Table) -> PyResult<RenderSettings> {
    let options = read_options(table)?;
    options.check_pairs().map_err(|e| scene_error(format!("render setting {e}")))?;
    let settings = scene.settings.with(&options);
    settings.validate().map_err(|e| scene_error(format!("render setting {e}")))?;
    Ok(settings)
}

/// Render options from a table of keyword arguments; an error names the key.
fn read_options(table: &toml::Table) -> PyResult<RenderOptions> {
    let read = |t: toml::Table| toml::Value::Table(t).try_into::<RenderOptions>();
    read(table.clone()).map_err(|e| {
        // The error does not say which key: find the first that fails alone.
        let key = table
            .iter()
            .find(|(k, v)| read(toml::Table::from_iter([((*k).clone(), (*v).clone())])).is_err());
        match key {
            Some((k, _)) => scene_error(format!("render setting {k}: {}", e.message())),
            None => scene_error(format!("render setting: {}", e.message())),
        }
    })
}

/// What the worker thread tells the waiting one.
enum Report {
    Progress(PyProgress),
    Done(Box<crate::Result<Partial>>),
}

/// The progress a callback sees, from a render's information and its error estimate.
fn progress_of(info: &RenderInfo, error: Option<f64>) -> PyProgress {
    let s = &info.settings;
    PyProgress {
        iteration: info.iterations,
        total: s.iterations.map(|last| (last + 1).saturating_sub(info.first_iteration)),
        elapsed: info.elapsed,
        time_limit: s.time_limit,
        error,
    }
}

/// Runs a render as a job of the worker pool, with the GIL released; the calling thread waits,
/// looking for Ctrl-C and calling `callback` (see the module's documentation). Returns the
/// render's result and the Python error that stopped it, if one did.
fn run(
    py: Python<'_>,
    scene: &Arc<Scene>,
    settings: RenderSettings,
    start: u64,
    threads: Option<usize>,
    callback: Option<&Py<PyAny>>,
) -> PyResult<(crate::Result<Partial>, Option<PyErr>)> {
    let pool = pool(threads)?;
    let stop = Arc::new(AtomicBool::new(false));
    let wants = callback.is_some();
    let (tx, rx) = mpsc::channel();
    let (scene, job_stop) = (scene.clone(), stop.clone());
    pool.spawn(move || {
        let mut last_error = Instant::now();
        let mut on_iteration = |st: &Status<'_>| {
            if wants {
                let due = last_error.elapsed() >= CALLBACK_EVERY;
                if due {
                    last_error = Instant::now();
                }
                let error = if due { st.error_estimate().map(|e| e.upper) } else { None };
                let _ = tx.send(Report::Progress(progress_of(st.info, error)));
            }
        };
        // A panic is a bug; it becomes an exception rather than aborting the interpreter.
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            render_partial(&scene, &settings, Start::At(start), &mut on_iteration, &job_stop)
        }))
        .unwrap_or_else(|_| Err(Error::Settings("internal error: the render panicked".into())));
        let _ = tx.send(Report::Done(Box::new(result)));
    });
    Ok(py.detach(move || wait(&rx, &stop, callback)))
}

/// The calling thread's side of [`run`]: waits for the worker's result.
fn wait(
    rx: &mpsc::Receiver<Report>,
    stop: &AtomicBool,
    callback: Option<&Py<PyAny>>,
) -> (crate::Result<Partial>, Option<PyErr>) {
    let mut raised: Option<PyErr> = None;
    let mut latest: Option<PyProgress> = None;
    // The last error estimate seen, carried into the reports made between two estimates.
    let mut last_error: Option<f64> = None;
    let mut called = Instant::now() - CALLBACK_EVERY;
    loop {
        let done = match rx.recv_timeout(POLL) {
            Ok(Report::Done(result)) => {
                if let (Some(_), Ok(part)) = (callback, result.as_ref()) {
                    let s = &part.info.settings;
                    let error = part.film.error_estimate(s.target_confidence, s.target_region);
                    latest = (part.info.iterations > 0)
                        .then(|| progress_of(&part.info, error.map(|e| e.upper)));
                }
                Some(*result)
            }
            Ok(Report::Progress(p)) => {
                last_error = p.error.or(last_error);
                latest = Some(PyProgress { error: last_error, ..p });
                None
            }
            Err(mpsc::RecvTimeoutError::Timeout) => None,
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                Some(Err(Error::Settings("the render's thread ended without a result".into())))
            }
        };
        if raised.is_none() {
            Python::attach(|py| {
                let due = called.elapsed() >= CALLBACK_EVERY || done.is_some();
                let result = py.check_signals().and_then(|()| match (callback, latest.take()) {
                    (Some(cb), Some(p)) if due => {
                        called = Instant::now();
                        cb.bind(py).call1((p,)).map(|_| ())
                    }
                    (_, p) => {
                        latest = p;
                        Ok(())
                    }
                });
                if let Err(e) = result {
                    stop.store(true, Ordering::Relaxed);
                    raised = Some(e);
                }
            });
        }
        if let Some(result) = done {
            return (result, raised);
        }
    }
}

/// Renders `scene` with its settings, overridden by the arguments and by any `[render]` key
/// given as a keyword (photons=, integrator=, alpha=, volume_estimate=, merges=, ...).
///
/// iterations: a count (from iteration 1), or a range of iteration indices counted from 1 as on
///     the command line (range(1, 9) is iterations 1..8), which returns a Partial.
/// time: a time limit in seconds (with no count, the render runs until it).
/// target_error: stop once the estimated relative error (Image.error) is this low; the
///     iteration count or the time limit still bounds the render.
/// threads: worker threads (default: every core).
/// seed: the seed of every random stream; the same scene, seed and iterations give the same
///     image whatever the thread count.
/// progress: called with a haze.Progress from this thread, at most four times a second and
///     once at the end.
///
/// Returns a haze.Image (a haze.Partial for a range). Releases the GIL while rendering. Ctrl-C
/// (seen when called from the main thread) stops the render at once, dropping the iteration
/// under way, and raises KeyboardInterrupt; an exception raised by `progress` stops it the same
/// way and propagates. Either exception carries the finished iterations as its `partial`
/// attribute (a haze.Partial, or None) and their number as `iterations`. Raises
/// haze.SceneError for a bad setting (a keyword given as None leaves the scene's setting), and
/// RuntimeError when a time limit ends before the first iteration.
#[pyfunction]
#[pyo3(signature = (scene, iterations = None, time = None, target_error = None, threads = None, seed = None, progress = None, **settings))]
#[allow(clippy::too_many_arguments)]
fn render(
    py: Python<'_>,
    scene: &PyScene,
    iterations: Option<&Bound<'_, PyAny>>,
    time: Option<f64>,
    target_error: Option<f64>,
    threads: Option<usize>,
    seed: Option<&Bound<'_, PyAny>>,
    progress: Option<Py<PyAny>>,
    settings: Option<&Bound<'_, PyDict>>,
) -> PyResult<Py<PyAny>> {
    if progress.as_ref().is_some_and(|p| !p.bind(py).is_callable()) {
        return Err(pyo3::exceptions::PyTypeError::new_err(
            "progress: must be callable (it receives a haze.Progress)",
        ));
    }
    // The keywords as a `[render]` table; one given as None leaves the scene's setting.
    let mut table = toml::Table::new();
    for (k, v) in settings.map(|d| d.iter()).into_iter().flatten() {
        let key: String = k.extract()?;
        if !v.is_none() {
            table.insert(key.clone(), convert::to_toml(&v, &key)?);
        }
    }
    if let Some(s) = seed.filter(|s| !s.is_none()) {
        table.insert("seed".into(), convert::to_toml(s, "seed")?);
    }
    for (key, value) in [("time_limit", time), ("target_error", target_error)] {
        if let Some(v) = value {
            table.insert(key.into(), toml::Value::Float(v));
        }
    }
    let it = parse_iterations(iterations)?;
    let (start, last) = match it {
        Iterations::Scene => (1, None),
        Iterations::Count(n) => (1, Some(n)),
        Iterations::Range(a, b) => (a, Some(b)),
    };
    if let Some(last) = last {
        table.insert("iterations".into(), toml::Value::Integer(last as i64));
    }
    let settings = render_settings(&scene.scene, &table)?;
    let (result, raised) = run(py, &scene.scene, settings, start, threads, progress.as_ref())?;
    let part = result.map_err(to_py_err)?;
    if let Some(e) = raised {
        return Err(interrupted(py, e, part));
    }
    if part.info.iterations == 0 {
        return Err(pyo3::exceptions::PyRuntimeError::new_err(format!(
            "the time limit ({} s) ended before the first iteration finished (allow more time, \
             or lower the photons or the resolution)",
            part.info.settings.time_limit.unwrap_or(0.0)
        )));
    }
    let part = PyPartial { part };
    if matches!(it, Iterations::Range(..)) {
        return Ok(Py::new(py, part)?.into_any());
    }
    Ok(Py::new(py, part.image_on(py, threads)?)?.into_any())
}

/// The error that stopped a render (Ctrl-C, or an exception of the progress callback), with
/// the iterations finished as its `partial` attribute (a `haze.Partial`, or None if none
/// finished) and their number as `iterations`, so that no finished work is lost.
fn interrupted(py: Python<'_>, e: PyErr, part: Partial) -> PyErr {
    let finished = part.info.iterations;
    let e = if e.is_instance_of::<PyKeyboardInterrupt>(py) {
        PyKeyboardInterrupt::new_err(format!(
            "render stopped after {finished} iterations (the exception's `partial` holds them)"
        ))
    } else {
        e
    };
    let partial =
        if finished > 0 { Py::new(py, PyPartial { part }).ok().map(Py::into_any) } else { None };
    // An exception type that refuses attributes keeps its message alone.
    let _ = e.value(py).setattr("partial", partial);
    let _ = e.value(py).setattr("iterations", finished);
    e
}

/// Merges partial renders (Partial objects or `.hpr` paths) into the image of their union.
#[pyfunction]
fn merge(py: Python<'_>, parts: Vec<Bound<'_, PyAny>>) -> PyResult<PyImage> {
    let merged = PyPartial::merge_parts(py, parts)?;
    merged.image_on(py, None)
}

/// The native part of the `haze` package.
#[pymodule]
#[pyo3(name = "_haze")]
fn haze_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyScene>()?;
    m.add_class::<PyImage>()?;
    m.add_class::<PyPartial>()?;
    m.add_class::<PyProgress>()?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(merge, m)?)?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
