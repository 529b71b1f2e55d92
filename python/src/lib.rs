//! `lente._lente`: the native half of the Python package (the Python half,
//! `python/lente/__init__.py`, wraps it in the documented API).
//!
//! Renders run with the GIL released on a thread of their own, while the
//! calling thread waits in slices of 50 ms: between slices it takes the
//! GIL to report progress and to check for Ctrl-C (Python only raises
//! `KeyboardInterrupt` on the main thread, so the check cannot happen on
//! the render's threads). An interrupt cancels the render at the end of
//! the tiles in flight and is raised once the render thread has returned.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Mutex;
use std::time::Duration;

use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyReadonlyArrayDyn};
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use lente::aov::AovList;
use lente::color::Rgb;
use lente::image::{Bitmap, Film};
use lente::load::{load_scene_with, SceneFile};
use lente::progress::ProgressMode;
use lente::render::{render_with_passes, RenderJob, RenderOptions};
use lente::scene::Scene;

pyo3::create_exception!(
    _lente,
    SceneError,
    pyo3::exceptions::PyException,
    "A scene file lente cannot read; the message names file:line:col."
);
pyo3::create_exception!(
    _lente,
    RenderError,
    pyo3::exceptions::PyException,
    "A render or image operation that failed."
);

/// A loaded scene, ready to render.
#[pyclass(module = "lente._lente", frozen)]
struct NativeScene {
    scene: Scene,
    job: RenderJob,
    path: PathBuf,
    params: Vec<(String, String)>,
    warnings: Vec<String>,
}

/// Loads a Nori or Mitsuba 3 scene file with `params` (Mitsuba `$name`s).
#[pyfunction]
fn load(py: Python<'_>, path: PathBuf, params: Vec<(String, String)>) -> PyResult<NativeScene> {
    let loaded = py.detach(|| -> Result<_, String> {
        let (SceneFile { scene, job }, warnings) =
            load_scene_with(&path, &params).map_err(|e| e.to_string())?;
        let scene = Scene::new(scene).map_err(|e| format!("{}: {e}", path.display()))?;
        Ok((scene, job, warnings))
    });
    let (scene, job, warnings) = loaded.map_err(SceneError::new_err)?;
    Ok(NativeScene {
        scene,
        job,
        path,
        params,
        warnings: warnings.iter().map(|w| w.to_string()).collect(),
    })
}

/// Image rows x columns x 3 from a bitmap.
fn image_array(b: &Bitmap) -> Array3<f32> {
    Array3::from_shape_fn((b.height, b.width, 3), |(y, x, c)| b.get(x, y)[c])
}

#[pymethods]
impl NativeScene {
    #[getter]
    fn width(&self) -> u32 {
        self.scene.camera.width()
    }

    #[getter]
    fn height(&self) -> u32 {
        self.scene.camera.height()
    }

    /// The scene's own samples per pixel.
    #[getter]
    fn spp(&self) -> u32 {
        self.job.spp
    }

    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    #[getter]
    fn params(&self) -> Vec<(String, String)> {
        self.params.clone()
    }

    /// What the reader warned about.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    /// Renders samples `s0..s1` of every pixel (the whole render: 0..spp)
    /// of rows `y0..y1` (`rows`; default all) with `threads` threads; `progress(spp_done, spp_total)` is called
    /// after each pass. Returns a dict: `image` (H x W x 3 float32),
    /// `aovs` (channel name -> H x W float32), and the film state that
    /// merges exactly: `sums` (H x W x 3), `weights` (H x W), `aov_sums`
    /// (channel name -> H x W); `spp`, `seconds`.
    #[pyo3(signature = (s0, s1, seed, threads, aovs, progress, rows=None))]
    // The arguments are the Python method's, one for one.
    #[allow(clippy::too_many_arguments)]
    fn render<'py>(
        &self,
        py: Python<'py>,
        s0: u32,
        s1: u32,
        seed: u64,
        threads: Option<usize>,
        aovs: &str,
        progress: Option<Py<PyAny>>,
        rows: Option<(u32, u32)>,
    ) -> PyResult<Bound<'py, PyDict>> {
        if let Some((y0, y1)) = rows {
            if y1 <= y0 || y1 > self.scene.camera.height() {
                return Err(PyValueError::new_err(format!(
                    "rows {y0}..{y1}: need 0 <= y0 < y1 <= {}",
                    self.scene.camera.height()
                )));
            }
        }
        if s1 <= s0 {
            return Err(PyValueError::new_err(format!(
                "samples {s0}..{s1}: the end must be after the start"
            )));
        }
        if threads == Some(0) {
            return Err(PyValueError::new_err("threads must be at least 1"));
        }
        let aov_list: AovList = aovs.parse().map_err(PyValueError::new_err)?;
        let aov_list = self
            .job
            .aovs
            .union(&aov_list)
            .map_err(PyValueError::new_err)?;
        let job = RenderJob {
            spp: s1,
            aovs: aov_list.clone(),
            ..self.job.clone()
        };
        let mut opts = RenderOptions::new(seed);
        opts.progress = ProgressMode::Off;
        opts.first_sample = s0;
        opts.aovs = aov_list.clone();
        opts.rows = rows;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.unwrap_or(0))
            .build()
            .map_err(|e| RenderError::new_err(e.to_string()))?;
        let cancel = AtomicBool::new(false);
        let done = AtomicU32::new(s0);
        let finished = AtomicBool::new(false);
        let output = Mutex::new(None);
        let mut interrupted = None;
        let mut reported = s0;
        std::thread::scope(|scope| -> PyResult<()> {
            scope.spawn(|| {
                // A panic in the render must still end the wait below (it
                // then reports "stopped without a result"), not hang it.
                let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    pool.install(|| {
                        render_with_passes(&self.scene, &job, &opts, &cancel, |info| {
                            done.store(info.spp_done, Ordering::Relaxed);
                        })
                    })
                }));
                *output.lock().unwrap_or_else(|e| e.into_inner()) = out.ok();
                finished.store(true, Ordering::Release);
            });
            loop {
                let over = py.detach(|| {
                    std::thread::sleep(Duration::from_millis(50));
                    finished.load(Ordering::Acquire)
                });
                let now = done.load(Ordering::Relaxed);
                if now != reported {
                    reported = now;
                    if let Some(cb) = &progress {
                        if let Err(e) = cb.call1(py, (now, s1)) {
                            // A failing callback stops the render too.
                            cancel.store(true, Ordering::Relaxed);
                            interrupted.get_or_insert(e);
                        }
                    }
                }
                if over {
                    return Ok(());
                }
                if interrupted.is_none() {
                    if let Err(e) = py.check_signals() {
                        cancel.store(true, Ordering::Relaxed);
                        interrupted = Some(e);
                    }
                }
            }
        })?;
        if let Some(e) = interrupted {
            return Err(e);
        }
        let out = output
            .into_inner()
            .unwrap_or_else(|e| e.into_inner())
            .ok_or_else(|| RenderError::new_err("the render thread stopped without a result"))?;
        if out.cancelled {
            return Err(PyKeyboardInterrupt::new_err("render cancelled"));
        }
        film_dict(py, &out.film, &aov_list, out.elapsed.as_secs_f64(), s1 - s0)
    }
}

/// The dict `render` returns, from a film.
fn film_dict<'py>(
    py: Python<'py>,
    film: &Film,
    aovs: &AovList,
    seconds: f64,
    spp: u32,
) -> PyResult<Bound<'py, PyDict>> {
    let (w, h) = (film.width, film.height);
    let d = PyDict::new(py);
    d.set_item("image", image_array(&film.to_bitmap()).into_pyarray(py))?;
    let data = film.data();
    let sums = Array3::from_shape_fn((h, w, 3), |(y, x, c)| data[y * w + x].0[c]);
    let weights = Array2::from_shape_fn((h, w), |(y, x)| data[y * w + x].1);
    d.set_item("sums", sums.into_pyarray(py))?;
    d.set_item("weights", weights.into_pyarray(py))?;
    let channels = PyDict::new(py);
    let channel_sums = PyDict::new(py);
    let n = aovs.channel_count();
    for (c, name) in aovs.channel_names().iter().enumerate() {
        let values = film.aov_channel(c);
        let a = Array2::from_shape_vec((h, w), values)
            .map_err(|e| RenderError::new_err(e.to_string()))?;
        channels.set_item(name, a.into_pyarray(py))?;
        let sums: Vec<f32> = film.aov_sums().iter().skip(c).step_by(n).copied().collect();
        let s = Array2::from_shape_vec((h, w), sums)
            .map_err(|e| RenderError::new_err(e.to_string()))?;
        channel_sums.set_item(name, s.into_pyarray(py))?;
    }
    d.set_item("aovs", channels)?;
    d.set_item("aov_sums", channel_sums)?;
    d.set_item("spp", spp)?;
    d.set_item("seconds", seconds)?;
    Ok(d)
}

/// Writes an H x W x 3 (or H x W, grey) float array as EXR, HDR, PFM or
/// PNG (by extension; PNG sRGB-encoded and clamped), atomically.
#[pyfunction]
fn write(path: PathBuf, array: PyReadonlyArrayDyn<'_, f32>) -> PyResult<()> {
    let bitmap = bitmap_from(&array, true)?;
    lente::image::io::save_image(Path::new(&path), &bitmap)
        .map_err(|e| RenderError::new_err(e.to_string()))
}

/// The bitmap of an H x W x 3 array; with `any_layout` also of H x W
/// (grey) and H x W x 4 (alpha dropped).
fn bitmap_from(array: &PyReadonlyArrayDyn<'_, f32>, any_layout: bool) -> PyResult<Bitmap> {
    let a = array.as_array();
    let shape = a.shape().to_vec();
    let (h, w, grey) = match shape[..] {
        [h, w, 3] => (h, w, false),
        [h, w] if any_layout => (h, w, true),
        [h, w, 4] if any_layout => (h, w, false),
        _ if any_layout => {
            return Err(PyValueError::new_err(format!(
                "expected an H x W x 3 (or H x W, or H x W x 4) array, not shape {shape:?}"
            )))
        }
        _ => return Err(PyValueError::new_err("expected an H x W x 3 array")),
    };
    let pixels = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            if grey {
                Rgb::splat(a[[y, x]])
            } else {
                Rgb::new(a[[y, x, 0]], a[[y, x, 1]], a[[y, x, 2]])
            }
        })
        .collect();
    Ok(Bitmap {
        width: w,
        height: h,
        pixels,
    })
}

/// Reads an EXR, HDR, PFM or PNG as an H x W x 3 float32 array (PNG
/// decoded from sRGB to linear).
#[pyfunction]
fn read<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, numpy::PyArray3<f32>>> {
    let (bitmap, _) = lente::image::load_image(Path::new(&path))
        .map_err(|e| RenderError::new_err(e.to_string()))?;
    Ok(image_array(&bitmap).into_pyarray(py))
}

/// The PNG bytes of an H x W x 3 float32 image (sRGB, clamped), for
/// Jupyter's `_repr_png_`.
#[pyfunction]
fn png_bytes(array: PyReadonlyArrayDyn<'_, f32>) -> PyResult<Vec<u8>> {
    let bitmap = bitmap_from(&array, false)?;
    lente::image::io::png::encode_scaled(&bitmap, 1.0, false)
        .map_err(|e| RenderError::new_err(e.to_string()))
}

#[pymodule]
fn _lente(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<NativeScene>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(write, m)?)?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(png_bytes, m)?)?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add("RenderError", m.py().get_type::<RenderError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
