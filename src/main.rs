//! The `lente` command line: argument parsing and reporting only; the
//! rendering lives in the library.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use std::io::IsTerminal;

use lente::aov::{Aov, AovList};
use lente::denoise::{denoise_film, Denoiser};
use lente::image::io::save_image;
use lente::image::{compare, difference_image, load_image, tonemap, Bitmap, Filter, Tonemap};
use lente::image::{prepare_output, Exposure, Look, MAX_EXPOSURE_STOPS};
use lente::load::{load_scene_with, SceneFile};
use lente::preview::{Checkpointer, PreviewServer, PreviewState};
use lente::progress::ProgressMode;
use lente::render::{render_with_passes, PassInfo, RenderOptions};
use lente::render_file::{save_render, scene_digest, RenderFile, RenderMeta, SampleRange};
use lente::scene::Scene;
use lente::tev::TevStream;

#[derive(Parser)]
#[command(
    name = "lente",
    version,
    about = "A physically based path tracer for Nori and Mitsuba scenes"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to OUT.exr (linear float) and OUT.png (sRGB).
    Render(RenderArgs),
    /// Merge renders of one scene (lente's EXRs, e.g. different --seed)
    /// into one, weighted by their samples: OUT.exr and OUT.png.
    Merge {
        /// Render files written by lente render (two or more).
        #[arg(required = true, num_args = 2..)]
        inputs: Vec<PathBuf>,
        /// Output path without extension (a .exr or .png extension is
        /// dropped).
        #[arg(short, long)]
        output: PathBuf,
        /// Denoise the merged image with Intel Open Image Denoise, guided
        /// by the files' albedo and normal AOVs where they have them.
        #[arg(long)]
        denoise: bool,
        #[command(flatten)]
        look: LookArgs,
    },
    /// Load a scene and print what it contains, without rendering.
    Info {
        /// Scene file (Nori or Mitsuba 3 XML; the dialect is detected).
        scene: PathBuf,
        /// Set a Mitsuba scene parameter ($NAME), overriding its <default>.
        #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
        define: Vec<(String, String)>,
    },
    /// Compare an image with a reference: MSE, relative MSE and PSNR.
    Compare {
        /// The image to measure (.exr, .hdr, .pfm or .png).
        image: PathBuf,
        /// The reference image, of the same size.
        reference: PathBuf,
        /// Also write a false-colour map of the per-pixel luminance error
        /// (blue: none, red: the largest) to this file.
        #[arg(long, value_name = "OUT.png")]
        diff: Option<PathBuf>,
    },
    /// Convert an image between EXR, HDR, PFM and PNG (by extension).
    Convert {
        /// Input image (.exr, .hdr, .pfm or .png).
        input: PathBuf,
        /// Output image (.exr, .hdr, .pfm or .png).
        output: PathBuf,
        /// Scale by 2^STOPS before writing.
        #[arg(
            long,
            value_name = "STOPS",
            default_value_t = 0.0,
            allow_negative_numbers = true
        )]
        exposure: f32,
        /// Tone mapping: clamp, reinhard, aces or filmic. PNG output is always
        /// tone mapped (default clamp); float outputs (EXR, HDR, PFM) only
        /// when this is given.
        #[arg(long)]
        tonemap: Option<Tonemap>,
    },
    /// Measure samples per second on the speed suite (bench/speed/), beside
    /// Mitsuba 3 when its Python is at hand, and BVH rays per second.
    ///
    /// Run it from the repository root (or pass --root). Mitsuba 3 is timed
    /// in the same run through scripts/mitsuba_bench.py with the Python
    /// given by --mitsuba (default: target/mitsuba-venv/bin/python if it
    /// exists, as .ci/run makes it).
    Bench(BenchArgs),
    /// Run Nori test files (t-tests and chi-square tests).
    ///
    /// Runs the <test type="ttest"> and <test type="chi2test"> files with
    /// Nori's parameters and defaults and prints one line per hypothesis
    /// test; the exit status is non-zero if any test fails.
    Test {
        /// Test files (Nori XML).
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// Seed of the random number streams.
        #[arg(long, default_value_t = 0)]
        seed: u64,
    },
    /// Chi-square test of a warp against its pdf (Nori's warptest).
    ///
    /// Warps: square, tent, disk, uniform_sphere, uniform_hemisphere,
    /// cosine_hemisphere, beckmann ALPHA, microfacet_brdf ALPHA [KD]. The exit
    /// status is non-zero if the samples do not follow the pdf.
    Warptest {
        /// The warp.
        name: String,
        /// Its parameters (ALPHA, KD).
        #[arg(allow_negative_numbers = true)]
        params: Vec<String>,
        /// Write the observed (left) and expected (right) histograms here as
        /// a heat-map PNG.
        #[arg(long)]
        png: Option<PathBuf>,
        /// Incidence angle in degrees of microfacet_brdf's wi (Nori: 0).
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        angle: f32,
        /// Seed of the random number streams.
        #[arg(long, default_value_t = 0)]
        seed: u64,
    },
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Scene file (Nori or Mitsuba 3 XML; the dialect is detected). With
    /// --resume it may be left out: the render file names it.
    #[arg(required_unless_present = "resume")]
    scene: Option<PathBuf>,
    /// Continue the render in this EXR (a checkpoint, an interrupted render
    /// or a finished one) up to its target spp or --spp, with its seed,
    /// size and parameters, writing to it (or -o). The result is the same
    /// bit for bit as a render that was never stopped.
    #[arg(long, value_name = "FILE.exr")]
    resume: Option<PathBuf>,
    /// Output path without extension (default: next to the scene file,
    /// with its name). A given .exr or .png extension is dropped; a
    /// folder (existing, or ending in /) gets the scene's name inside it.
    /// Missing folders are created before rendering starts.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Samples per pixel (overrides the scene's sampler).
    #[arg(long)]
    spp: Option<u32>,
    /// Render only samples S0..S1 of every pixel (of the deterministic
    /// sequence a whole render takes): slices rendered anywhere merge with
    /// `lente merge` into the render of all of them.
    #[arg(long, value_name = "S0..S1", value_parser = parse_sample_range, conflicts_with_all = ["spp", "resume"])]
    samples: Option<(u32, u32)>,
    /// Output variables to write into the EXR beside the image, comma-
    /// separated: albedo, normal (both through specular bounces to the
    /// first non-specular hit, as denoisers want them), depth, position;
    /// and Mitsuba's aov-integrator entries NAME:TYPE (first hit; types
    /// albedo, depth, position, uv, geo_normal, sh_normal, prim_index,
    /// shape_index), e.g. dd:depth,nn:sh_normal. A scene's own aov
    /// integrator adds its list.
    #[arg(long, value_name = "LIST")]
    aov: Option<AovList>,
    /// Denoise the image with Intel Open Image Denoise (`pip install
    /// pyoidn`, or LENTE_OIDN_LIB=path/to/libOpenImageDenoise), guided by
    /// the albedo and normal AOVs (added to --aov). The EXR's root layer
    /// and the PNG are denoised; the EXR keeps the noisy image in its
    /// `noisy` layer and the film state, so it can still be continued and
    /// merged.
    #[arg(long)]
    denoise: bool,
    /// Image size as WxH (overrides the scene's camera).
    #[arg(long, value_parser = parse_resolution)]
    resolution: Option<(u32, u32)>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Where to render: cpu; gpu (compute shaders through wgpu: Vulkan,
    /// Metal or DX12; a scene it does not support yet is an error naming
    /// what); auto (the GPU when there is one and it supports the scene,
    /// else the CPU, with a note).
    #[arg(long, value_enum, default_value_t = DeviceArg::Cpu)]
    device: DeviceArg,
    /// Seed of the random number streams (default 0); different seeds
    /// give independent renders.
    #[arg(long)]
    seed: Option<u64>,
    /// No progress report (the same as --progress none).
    #[arg(short, long)]
    quiet: bool,
    /// Progress on stderr: a bar (on a terminal), plain lines (for logs),
    /// or none. auto: the bar on a terminal, plain lines otherwise.
    #[arg(long, value_enum, default_value_t = ProgressArg::Auto)]
    progress: ProgressArg,
    /// Seconds between plain progress lines.
    #[arg(long, value_name = "SECONDS", default_value = "5", value_parser = parse_seconds)]
    progress_every: Duration,
    #[command(flatten)]
    look: LookArgs,
    /// Serve a live preview page on 127.0.0.1:PORT (default 8642; 0 picks
    /// a free port) showing the image pass by pass. Put it after the scene
    /// file or write --preview=PORT.
    #[arg(long, value_name = "PORT", num_args = 0..=1, default_missing_value = "8642")]
    preview: Option<u16>,
    /// Stream the image pass by pass to a running tev viewer at
    /// [HOST:]PORT (default 127.0.0.1:14158, tev's own), over tev's TCP
    /// protocol as pbrt-v4's --display-server does. Rendering never waits
    /// for tev; it connects whenever tev listens.
    #[arg(long, value_name = "[HOST:]PORT", num_args = 0..=1, default_missing_value = "14158", value_parser = lente::tev::parse_address)]
    tev: Option<String>,
    /// With --preview: keep serving the final image this many seconds
    /// after the outputs are written (Ctrl-C ends it early).
    #[arg(long, value_name = "SECONDS", requires = "preview", value_parser = parse_seconds)]
    preview_linger: Option<Duration>,
    /// Write the image in progress to the output files after a pass when
    /// at least SECONDS have passed since the last checkpoint (0: after
    /// every pass).
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    checkpoint: Option<Duration>,
    /// Set a Mitsuba scene parameter ($NAME), overriding its <default>.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    define: Vec<(String, String)>,
}

/// How the PNG shows the linear image (render, merge).
#[derive(clap::Args)]
struct LookArgs {
    /// Exposure of the PNG in stops (2^STOPS), or auto (the image's
    /// log-average luminance to middle grey). The EXR stays linear.
    #[arg(
        long,
        value_name = "STOPS|auto",
        default_value = "0",
        allow_negative_numbers = true
    )]
    exposure: Exposure,
    /// Tone mapping of the PNG: clamp, reinhard, aces or filmic.
    #[arg(long, default_value = "clamp")]
    tonemap: Tonemap,
}

impl LookArgs {
    fn look(&self) -> Look {
        Look {
            exposure: self.exposure,
            tonemap: self.tonemap,
        }
    }
}

/// `--device` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum DeviceArg {
    Cpu,
    Gpu,
    Auto,
}

/// `--progress` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum ProgressArg {
    Auto,
    Bar,
    Plain,
    None,
}

fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WxH (e.g. 640x480), found '{s}'"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in '{s}'"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in '{s}'"))?;
    if w == 0 || h == 0 || w > 65536 || h > 65536 {
        return Err(format!("resolution '{s}' out of range (1..65536)"));
    }
    if let Some(message) = lente::limits::check_image_size(w.into(), h.into()) {
        return Err(format!("resolution '{s}': {message}"));
    }
    Ok((w, h))
}

fn parse_sample_range(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected S0..S1 with S0 < S1 (e.g. 0..512), found '{s}'");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let a: u32 = a.trim().parse().map_err(|_| bad())?;
    let b: u32 = b.trim().parse().map_err(|_| bad())?;
    if a >= b {
        return Err(bad());
    }
    Ok((a, b))
}

fn parse_seconds(s: &str) -> Result<Duration, String> {
    let secs: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("expected a number of seconds, found '{s}'"))?;
    if !(0.0..=1e9).contains(&secs) {
        return Err(format!("'{s}' seconds is out of range (0..1e9)"));
    }
    Duration::try_from_secs_f64(secs).map_err(|e| format!("'{s}': {e}"))
}

fn parse_define(s: &str) -> Result<(String, String), String> {
    let (name, value) = s
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=VALUE, found '{s}'"))?;
    let name = name.trim();
    if name.is_empty() {
        return Err(format!("empty parameter name in '{s}'"));
    }
    Ok((name.to_string(), value.to_string()))
}

/// Restores the default action of SIGPIPE (Rust ignores it), so that
/// `lente compare a.exr b.exr | head` ends quietly as other command-line
/// tools do, instead of panicking on the closed pipe.
#[cfg(unix)]
fn quit_quietly_on_closed_pipe() {
    extern "C" {
        fn signal(signum: i32, handler: usize) -> usize;
    }
    const SIGPIPE: i32 = 13;
    const SIG_DFL: usize = 0;
    // SAFETY: setting a signal's action to the default is async-safe and
    // done before any thread starts.
    unsafe {
        signal(SIGPIPE, SIG_DFL);
    }
}

#[cfg(not(unix))]
fn quit_quietly_on_closed_pipe() {}

fn main() -> ExitCode {
    quit_quietly_on_closed_pipe();
    // A panic inside a third-party image decoder is caught and reported as
    // that file's error, without the default report beside it.
    lente::image::io::quiet_panics_in_guarded_decoders();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => cmd_render(args),
        Command::Merge {
            inputs,
            output,
            denoise,
            look,
        } => cmd_merge(&inputs, &output, denoise, look.look()),
        Command::Info { scene, define } => cmd_info(&scene, &define),
        Command::Compare {
            image,
            reference,
            diff,
        } => cmd_compare(&image, &reference, diff.as_deref()),
        Command::Convert {
            input,
            output,
            exposure,
            tonemap,
        } => cmd_convert(&input, &output, exposure, tonemap),
        Command::Test { files, seed } => cmd_test(&files, seed),
        Command::Bench(args) => cmd_bench(args),
        Command::Warptest {
            name,
            params,
            png,
            angle,
            seed,
        } => cmd_warptest(&name, &params, png.as_deref(), angle, seed),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// `lente bench`'s options.
#[derive(clap::Args)]
struct BenchArgs {
    /// Samples per pixel of every render.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Thread counts to measure at, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    threads: Vec<usize>,
    /// Timed renders per scene and thread count; the fastest counts.
    #[arg(long, default_value_t = 3)]
    repeat: u32,
    /// Only these suite scenes (comma-separated names).
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// The repository root (where bench/speed/ is).
    #[arg(long, default_value = ".")]
    root: PathBuf,
    /// A Python with the mitsuba wheel.
    #[arg(long, value_name = "PYTHON", conflicts_with = "no_mitsuba")]
    mitsuba: Option<PathBuf>,
    /// Do not measure Mitsuba 3.
    #[arg(long)]
    no_mitsuba: bool,
    /// Embree 3's library, for its ray queries beside lente's (a path,
    /// or a name for the system's loader; Debian: libembree3-3).
    #[arg(long, value_name = "LIB", default_value = lente::bench::embree::DEFAULT_LIBRARY)]
    embree: PathBuf,
    /// Only the ray queries (lente's and Embree's), no renders.
    #[arg(long)]
    rays_only: bool,
}

fn cmd_bench(args: BenchArgs) -> Result<()> {
    let BenchArgs {
        spp,
        threads,
        repeat,
        scenes,
        root,
        mitsuba,
        no_mitsuba,
        embree,
        rays_only,
    } = args;
    if spp == 0 || repeat == 0 || threads.is_empty() || threads.contains(&0) {
        bail!("--spp, --repeat and every --threads value must be at least 1");
    }
    if !root.join("bench/speed").is_dir() {
        bail!(
            "{} has no bench/speed/: run from the repository root or pass --root",
            root.display()
        );
    }
    let default_python = root.join("target/mitsuba-venv/bin/python");
    let mitsuba_python = match (no_mitsuba, mitsuba) {
        (true, _) => None,
        (false, Some(p)) => Some(p),
        (false, None) => default_python.is_file().then_some(default_python),
    };
    let opts = lente::bench::BenchOptions {
        root,
        spp,
        threads,
        repeat,
        only: scenes,
        mitsuba_python,
        embree_library: embree,
        rays_only,
    };
    Ok(lente::bench::run(&opts)?)
}

/// Parses a scene file with `-D` parameters, printing its warnings.
fn load(path: &Path, defines: &[(String, String)]) -> Result<SceneFile> {
    let (file, warnings) = load_scene_with(path, defines)?;
    for w in warnings {
        eprintln!("{}", w.report());
    }
    Ok(file)
}

/// The outputs' path without extension: `-o` as given (less a .exr or
/// .png extension), inside it with the scene's name when it is a folder
/// (existing, or written with a trailing slash), else next to the scene.
fn output_base(scene: &Path, output: Option<PathBuf>) -> PathBuf {
    match output {
        Some(dir)
            if dir.is_dir()
                || dir
                    .as_os_str()
                    .to_string_lossy()
                    .ends_with(['/', std::path::MAIN_SEPARATOR]) =>
        {
            let stem = scene.file_stem().unwrap_or(std::ffi::OsStr::new("render"));
            dir.join(stem)
        }
        Some(p) => {
            let ext = p
                .extension()
                .and_then(|e| e.to_str())
                .map(|e| e.to_ascii_lowercase());
            match ext.as_deref() {
                Some("exr") | Some("png") => p.with_extension(""),
                _ => p,
            }
        }
        None => scene.with_extension(""),
    }
}

fn with_ext(base: &Path, ext: &str) -> PathBuf {
    let mut s = base.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// Where a continued render starts: the file's film, seed and samples.
struct Resumed {
    path: PathBuf,
    file: RenderFile,
}

/// The render on the GPU if `device` asks for it (None: render on the
/// CPU). `auto` falls back to the CPU, saying why.
fn render_on_gpu(
    device: DeviceArg,
    scene: &Scene,
    job: &lente::render::RenderJob,
    opts: &RenderOptions,
    cancel: &AtomicBool,
    quiet: bool,
    on_pass: impl FnMut(&PassInfo),
) -> Result<Option<lente::render::RenderOutput>> {
    if device == DeviceArg::Cpu {
        return Ok(None);
    }
    #[cfg(feature = "gpu")]
    let attempt = lente::gpu::render_with_passes(scene, job, opts, cancel, on_pass)
        .map_err(anyhow::Error::from);
    #[cfg(not(feature = "gpu"))]
    let attempt = {
        let _ = (scene, job, opts, cancel, on_pass);
        Err(anyhow::anyhow!(
            "this lente was built without the GPU backend (cargo feature `gpu`)"
        ))
    };
    match attempt {
        Ok(out) => Ok(Some(out)),
        Err(e) if device == DeviceArg::Auto => {
            if !quiet {
                eprintln!("note: rendering on the CPU: {e}");
            }
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

fn cmd_render(args: RenderArgs) -> Result<()> {
    let RenderArgs {
        scene: scene_arg,
        resume,
        output,
        spp,
        samples,
        aov,
        denoise,
        resolution,
        threads,
        device,
        seed,
        quiet,
        progress,
        progress_every,
        look,
        preview,
        tev,
        preview_linger,
        checkpoint,
        define,
    } = args;
    let look = look.look();
    if let Some(0) = spp {
        bail!("--spp must be at least 1");
    }
    if let Some(0) = threads {
        bail!("--threads must be at least 1");
    }
    // Before hours of rendering, not after.
    let denoiser = denoise.then(Denoiser::load).transpose()?;
    let resumed = match resume {
        Some(path) => {
            let file = RenderFile::load(&path)?;
            Some(Resumed { path, file })
        }
        None => None,
    };
    let scene_path = match (scene_arg, &resumed) {
        (Some(s), _) => s,
        (None, Some(r)) => PathBuf::from(&r.file.meta.scene),
        (None, None) => bail!("a scene file is needed (or --resume FILE.exr)"),
    };
    let define = match &resumed {
        Some(r) if !define.is_empty() && define != r.file.meta.params => bail!(
            "-D cannot change a continued render's parameters: {} was rendered with {:?}",
            r.path.display(),
            r.file.meta.params
        ),
        Some(r) => r.file.meta.params.clone(),
        None => define,
    };
    let SceneFile {
        scene: mut desc,
        mut job,
    } = load(&scene_path, &define)?;
    let scene_bytes = std::fs::read(&scene_path)
        .with_context(|| format!("cannot read {}", scene_path.display()))?;
    let digest = scene_digest(&scene_bytes, &define);
    // Samples first..spp are rendered with `seed`, on top of `film`.
    let seed_arg = seed;
    // The scene's AOVs (Mitsuba's aov integrator) and --aov's.
    let asked_aovs = job
        .aovs
        .union(&aov.clone().unwrap_or_default())
        .map_err(anyhow::Error::msg)?;
    let mut aovs = asked_aovs.clone();
    // Denoisers need uncorrelated pixel noise: a one-pixel box filter.
    let mut box_filter = denoise && resumed.is_none();
    if denoise && resumed.is_none() {
        aovs = aovs.with(&[Aov::Albedo, Aov::Normal]);
    }
    let (mut seed, mut first, mut range_start, mut film, mut prior_seconds) =
        (seed.unwrap_or(0), 0, 0, None, 0.0);
    if let Some(Resumed { path, file }) = &resumed {
        let m = &file.meta;
        if m.scene_digest != digest {
            bail!(
                "{} changed since {} was rendered (or -D differs): continuing would mix two \
                 scenes; render it again instead",
                scene_path.display(),
                path.display()
            );
        }
        match m.ranges[..] {
            [] => {}
            [r] => {
                if seed_arg.is_some_and(|s| s != r.seed) {
                    bail!(
                        "{} was rendered with seed {}, not {seed}: a continued render keeps \
                         its seed",
                        path.display(),
                        r.seed
                    );
                }
                (seed, first, range_start) = (r.seed, r.end, r.start);
            }
            _ => bail!(
                "{} holds samples of several renders ({}): only a single render can be \
                 continued; render more with another --seed and merge",
                path.display(),
                m.ranges
                    .iter()
                    .map(|r| format!("seed {}: {}..{}", r.seed, r.start, r.end))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
        let size = (file.film.width as u32, file.film.height as u32);
        if resolution.is_some_and(|r| r != size) {
            bail!(
                "{} is {}x{}: a continued render keeps its size",
                path.display(),
                size.0,
                size.1
            );
        }
        desc.camera.set_resolution(size.0, size.1);
        job.spp = spp.unwrap_or(m.spp_target);
        if job.spp <= first {
            bail!(
                "{} already holds samples up to {first} (its target: {} spp): ask for more \
                 with --spp N",
                path.display(),
                m.spp_target
            );
        }
        if aov.is_some() && asked_aovs != m.aovs {
            bail!(
                "{} was rendered with the AOVs '{}': a continued render keeps them",
                path.display(),
                m.aovs
            );
        }
        aovs = m.aovs.clone();
        box_filter = m.box_filter;
        if denoise && !aovs.aovs().contains(&Aov::Albedo) {
            eprintln!(
                "warning: {} has no albedo and normal AOVs: denoising the colour alone",
                path.display()
            );
        }
        film = Some(file.film.clone());
        prior_seconds = m.render_seconds;
    }
    if resumed.is_none() {
        if let Some((w, h)) = resolution {
            desc.camera.set_resolution(w, h);
        }
        if let Some(spp) = spp {
            job.spp = spp;
        }
        if let Some((s0, s1)) = samples {
            (first, range_start, job.spp) = (s0, s0, s1);
        }
    }
    let spp = job.spp;
    let meta = RenderMeta {
        scene: std::fs::canonicalize(&scene_path)
            .unwrap_or_else(|_| scene_path.clone())
            .to_string_lossy()
            .into_owned(),
        scene_digest: digest,
        params: define.clone(),
        ranges: vec![SampleRange {
            seed,
            start: range_start,
            end: first,
        }],
        spp_target: spp,
        render_seconds: prior_seconds,
        version: lente::render_file::VERSION.to_string(),
        aovs: aovs.clone(),
        denoiser: None,
        box_filter,
    };
    if box_filter && job.filter != (Filter::Box { radius: 0.5 }) {
        if !quiet {
            eprintln!(
                "note: --denoise renders with a one-pixel box filter instead of the scene's \
                 {} filter (denoisers need pixels whose noise is independent)",
                job.filter
            );
        }
        job.filter = Filter::Box { radius: 0.5 };
    }
    let scene = Scene::new(desc)?;
    let output = output.or_else(|| resumed.as_ref().map(|r| r.path.clone()));
    let base = output_base(&scene_path, output);
    let exr = with_ext(&base, "exr");
    let png = with_ext(&base, "png");
    let (width, height) = (scene.camera.width(), scene.camera.height());
    lente::render::check_memory(width, height, lente::limits::available_memory())
        .map_err(anyhow::Error::msg)?;
    // Before hours of rendering, not after.
    prepare_output(&exr)?;
    prepare_output(&png)?;

    let preview = match preview {
        Some(port) => {
            let state = PreviewState::new(width as usize, height as usize, spp, &base);
            state.set_meta(meta.clone());
            let server = PreviewServer::start(port, state.clone())?;
            eprintln!("preview: {}", server.url());
            Some((state, server))
        }
        None => None,
    };
    let tev = tev.map(|address| {
        let name = exr.file_name().unwrap_or_default().to_string_lossy();
        TevStream::start(&address, &name, width as usize, height as usize)
    });
    let mut checkpointer =
        checkpoint.map(|every| Checkpointer::new(every, &base, look, meta.clone()));

    let cancel = Arc::new(AtomicBool::new(false));
    // Set by a second Ctrl-C: units in flight stop where they are.
    let hurry = Arc::new(AtomicBool::new(false));
    // Set while lingering after the render: Ctrl-C then just ends it.
    let lingering = Arc::new(AtomicBool::new(false));
    let stop_linger = Arc::new(AtomicBool::new(false));
    {
        let cancel = cancel.clone();
        let lingering = lingering.clone();
        let stop_linger = stop_linger.clone();
        let presses = AtomicUsize::new(0);
        let hurry = hurry.clone();
        // A second Ctrl-C abandons the tiles in flight and gives the writes
        // one second before quitting.
        let _ = ctrlc::set_handler(move || {
            if lingering.load(Ordering::SeqCst) {
                stop_linger.store(true, Ordering::SeqCst);
                return;
            }
            if presses.fetch_add(1, Ordering::SeqCst) > 0 {
                if hurry.swap(true, Ordering::SeqCst) {
                    std::process::exit(130);
                }
                eprintln!("\ninterrupted again: writing what is done (one second, then quitting)");
                std::thread::spawn(|| {
                    std::thread::sleep(Duration::from_secs(1));
                    std::process::exit(130);
                });
                return;
            }
            eprintln!("\ninterrupted: finishing the tiles in flight, then writing the partial image (Ctrl-C again: stop at once and write it)");
            cancel.store(true, Ordering::SeqCst);
        });
    }
    let progress = match progress {
        _ if quiet => ProgressMode::Off,
        ProgressArg::None => ProgressMode::Off,
        ProgressArg::Bar => ProgressMode::Bar,
        ProgressArg::Auto if std::io::stderr().is_terminal() => ProgressMode::Bar,
        ProgressArg::Plain | ProgressArg::Auto => ProgressMode::Plain {
            every: progress_every,
        },
    };
    let opts = RenderOptions {
        seed,
        progress,
        abandon: Some(hurry),
        first_sample: first,
        film,
        aovs,
        rows: None,
    };
    let threads = threads.unwrap_or_else(rayon::current_num_threads);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the worker threads")?;
    // The pass callback only reads the film: the image is the same bit for
    // bit with or without a preview or checkpoints.
    let mut on_pass = |info: &PassInfo| {
        // Normalised once for the page and tev.
        let image = (preview.is_some() || tev.is_some()).then(|| Arc::new(info.film.to_bitmap()));
        if let (Some((state, _)), Some(image)) = (&preview, &image) {
            state.publish_image(info, image.clone());
        }
        if let (Some(tev), Some(image)) = (&tev, &image) {
            tev.publish(image.clone());
        }
        if let Some(c) = checkpointer.as_mut() {
            match c.after_pass(info) {
                Ok(Some(spp)) if !quiet => {
                    let (exr, png) = c.paths();
                    eprintln!(
                        "checkpoint: wrote {} and {} ({spp} spp)",
                        exr.display(),
                        png.display()
                    );
                }
                Ok(_) => {}
                Err(e) => eprintln!("warning: checkpoint failed: {e}"),
            }
        }
    };
    let gpu_out = render_on_gpu(device, &scene, &job, &opts, &cancel, quiet, &mut on_pass)?;
    let where_ = match &gpu_out {
        Some(_) => "on the GPU".to_string(),
        None => format!("{threads} threads"),
    };
    let out = match gpu_out {
        Some(out) => out,
        None => pool.install(|| render_with_passes(&scene, &job, &opts, &cancel, &mut on_pass)),
    };

    let secs = out.elapsed.as_secs_f64();
    let mut written = meta.progressed(out.spp, secs);
    let noisy = out.image;
    let (image, denoise_error) = match &denoiser {
        Some(d) => match denoise_film(d, &out.film, &opts.aovs, Some(threads)) {
            Ok((image, description)) => {
                written.denoiser = Some(description);
                (image, None)
            }
            Err(e) => (noisy, Some(e)),
        },
        None => (noisy, None),
    };
    let image = Arc::new(image);
    save_render(&exr, &written, &out.film, &image)?;
    look.save_png(&png, &image)?;
    if let Some(tev) = tev {
        if !tev.finish(image.clone(), Duration::from_secs(5)) {
            eprintln!("warning: tev did not take the final image within 5 s");
        }
    }
    let auto_note = match look.exposure {
        Exposure::Auto => format!(
            " (exposure auto: {:+.2} stops)",
            look.exposure.stops_for(&image)
        ),
        Exposure::Stops(_) => String::new(),
    };
    println!(
        "{}x{} pixels, {} spp{}{}, {}, {:.2} s, {:.3} M samples/s",
        width,
        height,
        written.spp(),
        match written.ranges[..] {
            [r] if r.start > 0 => format!(" (samples {}..{})", r.start, r.end),
            _ if resumed.is_some() => format!(" ({} of them now)", out.spp - first),
            _ => String::new(),
        },
        if out.cancelled {
            " (interrupted: partial image)"
        } else {
            ""
        },
        where_,
        secs,
        out.samples as f64 / secs.max(1e-9) / 1e6,
    );
    println!("wrote {} and {}{auto_note}", exr.display(), png.display());
    if let Some(d) = &written.denoiser {
        println!("denoised: {d}");
    }
    if let Some(e) = denoise_error {
        bail!("{e} (the outputs hold the noisy image)");
    }

    if let Some((state, server)) = preview {
        // From here on Ctrl-C ends the lingering, not the render.
        lingering.store(true, Ordering::SeqCst);
        state.finish(out.cancelled, vec![exr, png]);
        let linger = preview_linger.unwrap_or(Duration::ZERO);
        if linger.is_zero() {
            eprintln!("preview: render done");
        } else {
            eprintln!(
                "preview: render done; serving the final image at {} for {:.0} s (Ctrl-C to quit)",
                server.url(),
                linger.as_secs_f64()
            );
            let until = Instant::now() + linger;
            while Instant::now() < until && !stop_linger.load(Ordering::SeqCst) {
                std::thread::sleep(Duration::from_millis(50));
            }
        }
        server.stop();
    }
    Ok(())
}

fn cmd_merge(inputs: &[PathBuf], output: &Path, denoise: bool, look: Look) -> Result<()> {
    let denoiser = denoise.then(Denoiser::load).transpose()?;
    let mut files = Vec::with_capacity(inputs.len());
    for path in inputs {
        files.push((path.as_path(), RenderFile::load(path)?));
    }
    let mut merged = RenderFile::merge(&files).map_err(anyhow::Error::msg)?;
    let base = output_base(Path::new("merged"), Some(output.to_path_buf()));
    let (exr, png) = (with_ext(&base, "exr"), with_ext(&base, "png"));
    prepare_output(&exr)?;
    prepare_output(&png)?;
    let image = match &denoiser {
        Some(d) => {
            let (image, description) = denoise_film(d, &merged.film, &merged.meta.aovs, None)?;
            merged.meta.denoiser = Some(description);
            image
        }
        None => merged.image(),
    };
    merged.save(&exr, &image)?;
    look.save_png(&png, &image)?;
    println!(
        "merged {} renders: {}x{} pixels, {} spp, {:.2} s of rendering",
        files.len(),
        image.width,
        image.height,
        merged.meta.spp(),
        merged.meta.render_seconds
    );
    println!("wrote {} and {}", exr.display(), png.display());
    if let Some(d) = &merged.meta.denoiser {
        println!("denoised: {d}");
    }
    Ok(())
}

fn cmd_compare(image: &Path, reference: &Path, diff: Option<&Path>) -> Result<()> {
    if let Some(d) = diff {
        check_image_extension(d)?;
    }
    let a = load_bitmap(image)?;
    let b = load_bitmap(reference)?;
    let c = compare(&a, &b).with_context(|| {
        format!(
            "cannot compare {} with {}",
            image.display(),
            reference.display()
        )
    })?;
    println!("MSE           {:.6e}", c.mse);
    println!("relative MSE  {:.6e}", c.relative_mse);
    if c.psnr.is_finite() {
        println!("PSNR          {:.2} dB", c.psnr);
    } else {
        println!("PSNR          inf dB (identical)");
    }
    if let Some(d) = diff {
        save_image(d, &difference_image(&a, &b))?;
        println!("wrote {}", d.display());
    }
    Ok(())
}

fn cmd_convert(input: &Path, output: &Path, exposure: f32, op: Option<Tonemap>) -> Result<()> {
    if !exposure.is_finite() || exposure.abs() > MAX_EXPOSURE_STOPS {
        bail!("--exposure must be a number of stops between -64 and 64, found {exposure}");
    }
    check_image_extension(output)?;
    let image = load_bitmap(input)?;
    let is_png = output
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    let converted = match (op, is_png) {
        (Some(op), _) => tonemap(&image, exposure, op),
        (None, true) => tonemap(&image, exposure, Tonemap::Clamp),
        (None, false) if exposure == 0.0 => image,
        (None, false) => {
            let scale = exposure.exp2();
            let mut image = image;
            for p in &mut image.pixels {
                *p *= scale;
            }
            if image.pixels.iter().any(|p| !p.is_finite()) {
                bail!(
                    "--exposure {exposure} overflows the float range for {}",
                    input.display()
                );
            }
            image
        }
    };
    save_image(output, &converted)?;
    println!(
        "wrote {} ({}x{})",
        output.display(),
        converted.width,
        converted.height
    );
    Ok(())
}

/// Loads an image, printing its warnings.
fn load_bitmap(path: &Path) -> Result<Bitmap> {
    let (image, warnings) = load_image(path)?;
    for w in warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(image)
}

/// Fails early, before any work, on an output name whose format is unknown.
fn check_image_extension(path: &Path) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("exr" | "hdr" | "pfm" | "png") => Ok(()),
        Some(e) => bail!(
            "{}: unsupported image extension '.{e}' (supported: .exr, .hdr, .pfm, .png)",
            path.display()
        ),
        None => bail!(
            "{}: no file extension to tell the image format (supported: .exr, .hdr, .pfm, .png)",
            path.display()
        ),
    }
}

fn cmd_info(scene_path: &Path, defines: &[(String, String)]) -> Result<()> {
    let SceneFile { scene: desc, job } = load(scene_path, defines)?;
    let spp = job.spp;
    let scene = Scene::new(desc)?;
    let c = &scene.camera.params;
    println!("scene       {}", scene_path.display());
    println!("integrator  {}", job.integrator.name());
    println!("image       {}x{}, {} spp", c.width, c.height, spp);
    if c.projection == lente::camera::Projection::Orthographic {
        // The sensor plane spans x in [-1, 1] before to_world.
        let plane = c.to_world.vector(lente::math::Vec3::X).length() * 2.0;
        println!(
            "camera      orthographic, {plane:.4} x {:.4} world units",
            plane * c.height as f32 / c.width as f32
        );
    } else {
        println!("camera      fov {:.3} deg (horizontal)", c.fov_x_deg);
    }
    let orthographic = c.projection == lente::camera::Projection::Orthographic;
    if orthographic {
        // No lens.
    } else if c.lens_radius > 0.0 {
        let aperture = match c.aperture {
            lente::camera::Aperture::Circular => "circular".to_string(),
            lente::camera::Aperture::Polygon { blades, rotation } => {
                format!("{blades} blades, rotated {:.1} deg", rotation.to_degrees())
            }
        };
        println!(
            "thin lens   lens radius {}, focal distance {}, aperture {aperture}",
            c.lens_radius, c.focal_distance
        );
    } else {
        println!("thin lens   none (pinhole)");
    }
    println!(
        "shapes      {} ({} triangles)",
        scene.geometry.len(),
        scene.triangle_count()
    );
    let names: Vec<&str> = scene.emitters.iter().map(|e| e.name()).collect();
    println!("emitters    {} [{}]", names.len(), names.join(", "));
    let b = scene.bounds;
    if b.is_empty() {
        println!("bounds      empty");
    } else {
        println!(
            "bounds      ({:.4}, {:.4}, {:.4}) to ({:.4}, {:.4}, {:.4})",
            b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
        );
    }
    println!(
        "bvh         {} primitives, {} levels, built in {:.1} ms",
        scene.bvh.primitive_count(),
        scene.bvh.depth(),
        scene.bvh.build_time.as_secs_f64() * 1e3
    );
    Ok(())
}

fn cmd_test(files: &[PathBuf], seed: u64) -> Result<()> {
    use lente::load::nori_testfile::load_test;
    use lente::verify::run_test_file;
    let (mut passed, mut total, mut broken) = (0usize, 0usize, 0usize);
    for path in files {
        let file = match load_test(path) {
            Ok((file, warnings)) => {
                for w in warnings {
                    eprintln!("{}", w.report());
                }
                file
            }
            Err(e) => {
                eprintln!("error: {}", e.report());
                broken += 1;
                continue;
            }
        };
        let start = std::time::Instant::now();
        let outcomes = run_test_file(&file, seed, |o| println!("{o}"));
        match outcomes {
            Ok(outcomes) => {
                let ok = outcomes.iter().filter(|o| o.passed).count();
                println!(
                    "{}: passed {ok}/{} tests in {:.1} s",
                    path.display(),
                    outcomes.len(),
                    start.elapsed().as_secs_f64()
                );
                passed += ok;
                total += outcomes.len();
            }
            Err(e) => {
                eprintln!("error: {e}");
                broken += 1;
            }
        }
    }
    if files.len() > 1 {
        println!("passed {passed}/{total} tests in {} files", files.len());
    }
    if broken > 0 {
        bail!("{broken} test file(s) could not be run");
    }
    if passed < total {
        bail!("{} of {total} tests failed", total - passed);
    }
    Ok(())
}

fn cmd_warptest(
    name: &str,
    params: &[String],
    png: Option<&Path>,
    angle: f32,
    seed: u64,
) -> Result<()> {
    use lente::verify::warptest::{heat_map, run_warp_test, Warp, SIGNIFICANCE};
    let warp = Warp::parse(name, params, angle)?;
    let start = std::time::Instant::now();
    let out = run_warp_test(&warp, seed);
    let r = &out.result;
    println!(
        "{} {}: {}x{} cells, {} samples{}: chi2 = {:.2}, dof = {}, p = {:.4e} {} {SIGNIFICANCE} ({:.1} s)",
        if out.passed { "PASS" } else { "FAIL" },
        warp.describe(),
        out.hist.rows,
        out.hist.cols,
        out.samples,
        if out.invalid > 0 {
            format!(" ({} outside the domain)", out.invalid)
        } else {
            String::new()
        },
        r.statistic,
        r.dof,
        r.p_value,
        if out.passed { ">" } else { "<=" },
        start.elapsed().as_secs_f64()
    );
    if let Some(path) = png {
        save_image(path, &heat_map(&out.hist))?;
        println!("wrote {} (observed left, expected right)", path.display());
    }
    if !out.passed {
        bail!("the samples of {} do not follow its pdf", warp.describe());
    }
    Ok(())
}
