//! Denoising with Intel Open Image Denoise (OIDN), the official library
//! loaded at run time, so that a plain `cargo build` needs no OIDN and
//! users without it lose only `--denoise`.
//!
//! The library is looked for, in order: `LENTE_OIDN_LIB` (the library file
//! or its folder), the system's loader (`libOpenImageDenoise.so.2` on
//! Linux), and the `pyoidn` wheel of the `python3` on `PATH` (`pip install
//! pyoidn` ships Intel's build of the library).
//!
//! The filter is OIDN's `RT` with the HDR beauty, and the albedo and normal
//! AOVs when there are any. The auxiliary images are noisy too (depth of
//! field, rough surfaces), so they are first denoised on their own and the
//! beauty filter is told they are clean (`cleanAux`): OIDN's recommended
//! highest-quality mode.

use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::path::{Path, PathBuf};

use crate::aov::{Aov, AovList};
use crate::color::Rgb;
use crate::image::{Bitmap, Film};

/// The environment variable naming the library (or its folder).
pub const LIBRARY_VARIABLE: &str = "LENTE_OIDN_LIB";

/// Why denoising could not run.
#[derive(Debug, thiserror::Error)]
pub enum DenoiseError {
    #[error(
        "Intel Open Image Denoise was not found (tried: {tried}); install it with \
         `pip install pyoidn` (it ships Intel's library) or a system package, or set \
         {LIBRARY_VARIABLE} to the path of libOpenImageDenoise"
    )]
    NotFound { tried: String },
    #[error("cannot load Open Image Denoise from {path}: {message}")]
    Load { path: String, message: String },
    #[error("Open Image Denoise failed: {0}")]
    Oidn(String),
    #[error("cannot denoise: {0}")]
    Input(String),
}

#[cfg(target_os = "windows")]
const SYSTEM_NAMES: &[&str] = &["OpenImageDenoise.dll"];
#[cfg(target_os = "macos")]
const SYSTEM_NAMES: &[&str] = &["libOpenImageDenoise.2.dylib", "libOpenImageDenoise.dylib"];
#[cfg(not(any(target_os = "windows", target_os = "macos")))]
const SYSTEM_NAMES: &[&str] = &["libOpenImageDenoise.so.2", "libOpenImageDenoise.so"];

/// OIDN's enums, as its C header numbers them.
const DEVICE_TYPE_DEFAULT: c_int = 0;
const FORMAT_FLOAT3: c_int = 3;
const ERROR_NONE: c_int = 0;

type Handle = *mut c_void;

/// The C functions lente calls, copied out of the loaded library (which
/// the struct keeps loaded).
struct Api {
    new_device: unsafe extern "C" fn(c_int) -> Handle,
    commit_device: unsafe extern "C" fn(Handle),
    release_device: unsafe extern "C" fn(Handle),
    device_error: unsafe extern "C" fn(Handle, *mut *const c_char) -> c_int,
    set_device_int: unsafe extern "C" fn(Handle, *const c_char, c_int),
    get_device_int: unsafe extern "C" fn(Handle, *const c_char) -> c_int,
    new_filter: unsafe extern "C" fn(Handle, *const c_char) -> Handle,
    set_image: unsafe extern "C" fn(
        Handle,
        *const c_char,
        *mut c_void,
        c_int,
        usize,
        usize,
        usize,
        usize,
        usize,
    ),
    set_bool: unsafe extern "C" fn(Handle, *const c_char, bool),
    commit_filter: unsafe extern "C" fn(Handle),
    execute_filter: unsafe extern "C" fn(Handle),
    release_filter: unsafe extern "C" fn(Handle),
}

/// A loaded Open Image Denoise.
pub struct Denoiser {
    api: Api,
    path: PathBuf,
    _library: libloading::Library,
}

/// What one denoising takes: the beauty and, optionally, the auxiliary
/// images (same size). OIDN accepts albedo alone or albedo with normal.
pub struct DenoiseInput<'a> {
    pub color: &'a Bitmap,
    pub albedo: Option<&'a Bitmap>,
    pub normal: Option<&'a Bitmap>,
}

impl Denoiser {
    /// Finds and loads the library (see the module's doc for where).
    pub fn load() -> Result<Denoiser, DenoiseError> {
        let mut tried = Vec::new();
        if let Some(value) = std::env::var_os(LIBRARY_VARIABLE) {
            let path = PathBuf::from(value);
            let file = if path.is_dir() {
                SYSTEM_NAMES
                    .iter()
                    .map(|n| path.join(n))
                    .find(|p| p.exists())
                    .unwrap_or_else(|| path.join(SYSTEM_NAMES[0]))
            } else {
                path
            };
            // An explicit choice that fails is an error, not a fallback.
            return Denoiser::open(&file);
        }
        tried.push(format!("{LIBRARY_VARIABLE} (not set)"));
        for name in SYSTEM_NAMES {
            if let Ok(d) = Denoiser::open(Path::new(name)) {
                return Ok(d);
            }
        }
        tried.push(format!("the system's {}", SYSTEM_NAMES[0]));
        match pyoidn_folder() {
            Some(dir) => {
                for name in SYSTEM_NAMES {
                    let file = dir.join(name);
                    if file.exists() {
                        return Denoiser::open(&file);
                    }
                }
                tried.push(format!("{} (no library in it)", dir.display()));
            }
            None => tried.push("pyoidn in python3 (not installed)".to_string()),
        }
        Err(DenoiseError::NotFound {
            tried: tried.join(", "),
        })
    }

    /// Loads the library at `path` (a bare name goes to the system's
    /// loader).
    pub fn open(path: &Path) -> Result<Denoiser, DenoiseError> {
        let err = |message: String| DenoiseError::Load {
            path: path.display().to_string(),
            message,
        };
        // SAFETY: loading runs the library's initialisers; OIDN's are
        // plain C++ static constructors with no requirements on the caller.
        let library = unsafe { libloading::Library::new(path) }.map_err(|e| err(e.to_string()))?;
        macro_rules! symbol {
            ($name:literal) => {
                // SAFETY: the type is the function's C signature in OIDN 2's
                // header (oidn.h); the pointer is used only while `library`
                // (moved into the Denoiser) stays loaded.
                *unsafe { library.get(concat!($name, "\0").as_bytes()) }
                    .map_err(|e| err(format!("{}: {e}", $name)))?
            };
        }
        let api = Api {
            new_device: symbol!("oidnNewDevice"),
            commit_device: symbol!("oidnCommitDevice"),
            release_device: symbol!("oidnReleaseDevice"),
            device_error: symbol!("oidnGetDeviceError"),
            set_device_int: symbol!("oidnSetDeviceInt"),
            get_device_int: symbol!("oidnGetDeviceInt"),
            new_filter: symbol!("oidnNewFilter"),
            set_image: symbol!("oidnSetSharedFilterImage"),
            set_bool: symbol!("oidnSetFilterBool"),
            commit_filter: symbol!("oidnCommitFilter"),
            execute_filter: symbol!("oidnExecuteFilter"),
            release_filter: symbol!("oidnReleaseFilter"),
        };
        Ok(Denoiser {
            api,
            path: path.to_path_buf(),
            _library: library,
        })
    }

    /// Where the library was loaded from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Denoises `input.color` with `threads` CPU threads (None: OIDN's
    /// choice): the image (of its size) and the library's version as
    /// "major.minor.patch".
    pub fn denoise(
        &self,
        input: &DenoiseInput,
        threads: Option<usize>,
    ) -> Result<(Bitmap, String), DenoiseError> {
        let (w, h) = (input.color.width, input.color.height);
        for aux in [input.albedo, input.normal].into_iter().flatten() {
            if (aux.width, aux.height) != (w, h) {
                return Err(DenoiseError::Input(format!(
                    "an auxiliary image is {}x{}, the image {w}x{h}",
                    aux.width, aux.height
                )));
            }
        }
        if input.normal.is_some() && input.albedo.is_none() {
            return Err(DenoiseError::Input(
                "OIDN takes a normal image only with an albedo image".into(),
            ));
        }
        let device = Device::new(&self.api, threads)?;
        // OIDN wants finite values, albedo in [0, 1] and normals in [-1, 1].
        let mut color = flatten(
            input.color,
            |v| if v.is_finite() { v.max(0.0) } else { 0.0 },
        );
        let mut albedo = input.albedo.map(|b| {
            flatten(b, |v| {
                if v.is_finite() {
                    v.clamp(0.0, 1.0)
                } else {
                    0.0
                }
            })
        });
        let mut normal = input.normal.map(|b| {
            flatten(b, |v| {
                if v.is_finite() {
                    v.clamp(-1.0, 1.0)
                } else {
                    0.0
                }
            })
        });
        // The auxiliary images first, each denoised in place on its own.
        for (name, aux) in [("albedo", albedo.as_mut()), ("normal", normal.as_mut())] {
            if let Some(aux) = aux {
                let filter = Filter::new(&device)?;
                filter.image(name, aux, w, h);
                filter.image("output", aux, w, h);
                filter.run()?;
            }
        }
        let mut output = vec![0.0f32; 3 * w * h];
        let filter = Filter::new(&device)?;
        filter.image("color", &mut color, w, h);
        if let Some(a) = albedo.as_mut() {
            filter.image("albedo", a, w, h);
        }
        if let Some(n) = normal.as_mut() {
            filter.image("normal", n, w, h);
        }
        filter.image("output", &mut output, w, h);
        filter.flag("hdr", true);
        filter.flag("cleanAux", albedo.is_some());
        filter.run()?;
        let image = Bitmap {
            width: w,
            height: h,
            pixels: output
                .chunks_exact(3)
                .map(|p| Rgb::new(p[0], p[1], p[2]))
                .collect(),
        };
        let v = device.int("version");
        Ok((
            image,
            format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100),
        ))
    }
}

/// A film's image denoised with its albedo and normal AOVs where it has
/// them: the image and a description of what was done, for the render
/// file's `lente.denoiser`.
pub fn denoise_film(
    denoiser: &Denoiser,
    film: &Film,
    aovs: &AovList,
    threads: Option<usize>,
) -> Result<(Bitmap, String), DenoiseError> {
    let color = film.to_bitmap();
    let aov_bitmap = |aov: Aov| -> Option<Bitmap> {
        let names = aovs.channel_names();
        let first = names.iter().position(|n| *n == aov.channels()[0])?;
        let c: Vec<Vec<f32>> = (0..3).map(|k| film.aov_channel(first + k)).collect();
        Some(Bitmap {
            width: film.width,
            height: film.height,
            pixels: (0..film.width * film.height)
                .map(|i| Rgb::new(c[0][i], c[1][i], c[2][i]))
                .collect(),
        })
    };
    let albedo = aov_bitmap(Aov::Albedo);
    // OIDN takes a normal only beside an albedo.
    let normal = albedo.as_ref().and_then(|_| aov_bitmap(Aov::Normal));
    let input = DenoiseInput {
        color: &color,
        albedo: albedo.as_ref(),
        normal: normal.as_ref(),
    };
    let (image, version) = denoiser.denoise(&input, threads)?;
    let aux = match (&albedo, &normal) {
        (Some(_), Some(_)) => "albedo and normal, prefiltered",
        (Some(_), None) => "albedo, prefiltered",
        _ => "colour only",
    };
    Ok((
        image,
        format!("Open Image Denoise {version} (RT, HDR; {aux})"),
    ))
}

/// An OIDN device, released on drop.
struct Device<'a> {
    api: &'a Api,
    handle: Handle,
}

impl<'a> Device<'a> {
    fn new(api: &'a Api, threads: Option<usize>) -> Result<Device<'a>, DenoiseError> {
        // SAFETY: OIDN's C API with the arguments its header documents.
        let handle = unsafe { (api.new_device)(DEVICE_TYPE_DEFAULT) };
        if handle.is_null() {
            return Err(DenoiseError::Oidn("no device could be created".into()));
        }
        let device = Device { api, handle };
        if let Some(n) = threads {
            let n = c_int::try_from(n).unwrap_or(c_int::MAX);
            // SAFETY: as above; the name is a NUL-terminated constant.
            unsafe { (api.set_device_int)(handle, c"numThreads".as_ptr(), n) };
        }
        // SAFETY: as above.
        unsafe { (api.commit_device)(handle) };
        device.check()?;
        Ok(device)
    }

    fn int(&self, name: &str) -> i32 {
        let name = CString::new(name).unwrap_or_default();
        // SAFETY: a live device and a NUL-terminated name.
        unsafe { (self.api.get_device_int)(self.handle, name.as_ptr()) }
    }

    /// The device's pending error, if any, as an error.
    fn check(&self) -> Result<(), DenoiseError> {
        let mut message: *const c_char = std::ptr::null();
        // SAFETY: a live device; OIDN sets `message` to a NUL-terminated
        // string it owns (valid until the next call), or leaves it null.
        let code = unsafe { (self.api.device_error)(self.handle, &mut message) };
        if code == ERROR_NONE {
            return Ok(());
        }
        let text = if message.is_null() {
            format!("error code {code}")
        } else {
            // SAFETY: see above.
            unsafe { CStr::from_ptr(message) }
                .to_string_lossy()
                .into_owned()
        };
        Err(DenoiseError::Oidn(text))
    }
}

impl Drop for Device<'_> {
    fn drop(&mut self) {
        // SAFETY: released once; filters (which borrow the device) are
        // dropped before it.
        unsafe { (self.api.release_device)(self.handle) }
    }
}

/// An `RT` filter on a device, released on drop.
struct Filter<'d, 'a> {
    device: &'d Device<'a>,
    handle: Handle,
}

impl<'d, 'a> Filter<'d, 'a> {
    fn new(device: &'d Device<'a>) -> Result<Filter<'d, 'a>, DenoiseError> {
        // SAFETY: a live device and a NUL-terminated filter type.
        let handle = unsafe { (device.api.new_filter)(device.handle, c"RT".as_ptr()) };
        device.check()?;
        if handle.is_null() {
            return Err(DenoiseError::Oidn("no RT filter".into()));
        }
        Ok(Filter { device, handle })
    }

    /// Points image `name` at `data` (w x h packed RGB floats), which must
    /// outlive the filter's execution.
    fn image(&self, name: &str, data: &mut [f32], w: usize, h: usize) {
        debug_assert_eq!(data.len(), 3 * w * h);
        let name = CString::new(name).unwrap_or_default();
        // SAFETY: `data` holds w*h packed FLOAT3 pixels (strides 0 mean
        // packed) and lives until `run` returns (the callers keep it).
        unsafe {
            (self.device.api.set_image)(
                self.handle,
                name.as_ptr(),
                data.as_mut_ptr().cast(),
                FORMAT_FLOAT3,
                w,
                h,
                0,
                0,
                0,
            )
        }
    }

    fn flag(&self, name: &str, value: bool) {
        let name = CString::new(name).unwrap_or_default();
        // SAFETY: a live filter and a NUL-terminated name.
        unsafe { (self.device.api.set_bool)(self.handle, name.as_ptr(), value) }
    }

    fn run(&self) -> Result<(), DenoiseError> {
        // SAFETY: a live filter whose images were set to live buffers.
        unsafe { (self.device.api.commit_filter)(self.handle) };
        self.device.check()?;
        // SAFETY: as above.
        unsafe { (self.device.api.execute_filter)(self.handle) };
        self.device.check()
    }
}

impl Drop for Filter<'_, '_> {
    fn drop(&mut self) {
        // SAFETY: released once, before its device.
        unsafe { (self.device.api.release_filter)(self.handle) }
    }
}

/// The bitmap as packed RGB floats, each value passed through `f`.
fn flatten(b: &Bitmap, f: impl Fn(f32) -> f32) -> Vec<f32> {
    b.pixels
        .iter()
        .flat_map(|p| [f(p.x), f(p.y), f(p.z)])
        .collect()
}

/// The folder with the library inside the `pyoidn` package of `python3`
/// (found without importing it).
fn pyoidn_folder() -> Option<PathBuf> {
    let script = "import importlib.util as u\n\
                  s = u.find_spec('pyoidn')\n\
                  print(list(s.submodule_search_locations)[0] if s else '')";
    let out = std::process::Command::new("python3")
        .args(["-c", script])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()?;
    let dir = String::from_utf8(out.stdout).ok()?;
    let dir = dir.trim();
    if dir.is_empty() {
        return None;
    }
    let lib = Path::new(dir)
        .join("oidn")
        .join(if cfg!(windows) { "bin" } else { "lib" });
    lib.is_dir().then_some(lib)
}
