//! The `lente` command line: argument parsing and reporting only; the
//! rendering lives in the library.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use std::io::IsTerminal;

use lente::image::io::save_image;
use lente::render::{render, RenderOptions};
use lente::scene::{load_scene, Scene, SceneDesc};

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
    Render {
        /// Scene file (Nori XML).
        scene: PathBuf,
        /// Output path without extension (default: next to the scene file,
        /// with its name). A given .exr or .png extension is dropped.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Samples per pixel (overrides the scene's sampler).
        #[arg(long)]
        spp: Option<u32>,
        /// Image size as WxH (overrides the scene's camera).
        #[arg(long, value_parser = parse_resolution)]
        resolution: Option<(u32, u32)>,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Seed of the random number streams; different seeds give
        /// independent renders.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// No progress bar.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Load a scene and print what it contains, without rendering.
    Info {
        /// Scene file (Nori XML).
        scene: PathBuf,
    },
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
    Ok((w, h))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render {
            scene,
            output,
            spp,
            resolution,
            threads,
            seed,
            quiet,
        } => cmd_render(&scene, output, spp, resolution, threads, seed, quiet),
        Command::Info { scene } => cmd_info(&scene),
        Command::Test { files, seed } => cmd_test(&files, seed),
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

/// Parses a scene file, printing its warnings.
fn load(path: &Path) -> Result<SceneDesc> {
    let (desc, warnings) = load_scene(path).map_err(|e| anyhow::anyhow!("{e}"))?;
    for w in warnings {
        eprintln!("{w}");
    }
    Ok(desc)
}

fn build(desc: SceneDesc) -> Result<Scene> {
    Scene::new(desc).map_err(|e| anyhow::anyhow!("{e}"))
}

/// OUT without extension: the given path minus .exr/.png, or the scene
/// file's path minus its extension.
fn output_base(scene: &Path, output: Option<PathBuf>) -> PathBuf {
    match output {
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

fn cmd_render(
    scene_path: &Path,
    output: Option<PathBuf>,
    spp: Option<u32>,
    resolution: Option<(u32, u32)>,
    threads: Option<usize>,
    seed: u64,
    quiet: bool,
) -> Result<()> {
    if let Some(0) = spp {
        bail!("--spp must be at least 1");
    }
    if let Some(0) = threads {
        bail!("--threads must be at least 1");
    }
    let mut desc = load(scene_path)?;
    if let Some((w, h)) = resolution {
        desc.camera.width = w;
        desc.camera.height = h;
    }
    let spp = spp.unwrap_or(desc.spp);
    let scene = build(desc)?;
    let base = output_base(scene_path, output);

    let cancel = Arc::new(AtomicBool::new(false));
    {
        let cancel = cancel.clone();
        let presses = AtomicUsize::new(0);
        // A second Ctrl-C quits at once.
        let _ = ctrlc::set_handler(move || {
            if presses.fetch_add(1, Ordering::SeqCst) > 0 {
                std::process::exit(130);
            }
            eprintln!("\ninterrupted: finishing the tiles in flight, then writing the partial image (Ctrl-C again to quit)");
            cancel.store(true, Ordering::SeqCst);
        });
    }
    let opts = RenderOptions {
        spp,
        seed,
        progress: !quiet && std::io::stderr().is_terminal(),
    };
    let threads = threads.unwrap_or_else(rayon::current_num_threads);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the worker threads")?;
    let out = pool.install(|| render(&scene, &opts, &cancel));

    let exr = with_ext(&base, "exr");
    let png = with_ext(&base, "png");
    save_image(&exr, &out.image)?;
    save_image(&png, &out.image)?;
    let secs = out.elapsed.as_secs_f64();
    println!(
        "{}x{} pixels, {} spp{}, {} threads, {:.2} s, {:.3} M samples/s",
        scene.camera.width(),
        scene.camera.height(),
        out.spp,
        if out.cancelled {
            " (interrupted: partial image)"
        } else {
            ""
        },
        threads,
        secs,
        out.samples as f64 / secs.max(1e-9) / 1e6,
    );
    println!("wrote {} and {}", exr.display(), png.display());
    Ok(())
}

fn cmd_info(scene_path: &Path) -> Result<()> {
    let desc = load(scene_path)?;
    let spp = desc.spp;
    let scene = build(desc)?;
    let c = &scene.camera.params;
    println!("scene       {}", scene_path.display());
    println!("integrator  {}", scene.integrator.name());
    println!("image       {}x{}, {} spp", c.width, c.height, spp);
    println!("camera      fov {:.3} deg (horizontal)", c.fov_x_deg);
    if c.lens_radius > 0.0 {
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
        "bvh         {} primitives, built in {:.1} ms",
        scene.bvh.primitive_count(),
        scene.bvh.build_time.as_secs_f64() * 1e3
    );
    Ok(())
}

fn cmd_test(files: &[PathBuf], seed: u64) -> Result<()> {
    use lente::scene::nori_test::load_test;
    use lente::verify::run_test_file;
    let (mut passed, mut total, mut broken) = (0usize, 0usize, 0usize);
    for path in files {
        let file = match load_test(path) {
            Ok((file, warnings)) => {
                for w in warnings {
                    eprintln!("{w}");
                }
                file
            }
            Err(e) => {
                eprintln!("error: {e}");
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
    let warp = Warp::parse(name, params, angle).map_err(|e| anyhow::anyhow!(e))?;
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
