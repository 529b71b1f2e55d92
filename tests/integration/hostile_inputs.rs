//! The attacks of the hardening issue, through the CLI: each ends quickly
//! with one line naming the file and what was wrong (exit status 1 or 2),
//! never a hang, an abort or an unbounded read. The decoders' cases are
//! also replayed byte for byte by tests/fuzz_regressions.rs.

use std::path::Path;
use std::time::Duration;

use crate::cli_util::Running;

/// Runs lente and returns its exit code and stderr; fails if it takes
/// more than 20 s (the attacks used to hang or read forever).
fn run_bounded(args: &[&str]) -> (i32, String) {
    let mut run = Running::spawn(args);
    let (status, _) = run.wait(Duration::from_secs(20));
    let code = status.code().unwrap_or(-1);
    (code, run.stderr_text())
}

fn assert_one_line_error(code: i32, stderr: &str, needles: &[&str]) {
    assert!(code == 1 || code == 2, "exit {code}: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert!(
        lines.iter().any(|l| needles.iter().all(|n| l.contains(n))),
        "no line with {needles:?}: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}

const NORI_SPHERES: &str = r#"<scene>
  <integrator type="normals"/>
  <camera type="perspective"><integer name="width" value="8"/><integer name="height" value="8"/></camera>
  MESHES
</scene>
"#;

const ONE_SPHERE: &str = r#"<mesh type="sphere"><point name="center" value="0, 0, 5"/><float name="radius" value="1"/></mesh>"#;

/// Writes `NORI_SPHERES` with `meshes` as `dir/name`; returns its path.
fn write_scene(dir: &tempfile::TempDir, name: &str, meshes: &str) -> std::path::PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, NORI_SPHERES.replace("MESHES", meshes)).unwrap();
    path
}

#[cfg(unix)]
#[test]
fn device_files_are_refused_as_scenes_and_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let scene_link = dir.path().join("zero.xml");
    std::os::unix::fs::symlink("/dev/zero", &scene_link).unwrap();
    let (code, err) = run_bounded(&["render", scene_link.to_str().unwrap(), "-q"]);
    assert_one_line_error(code, &err, &["zero.xml", "not a regular file"]);

    let mesh_link = dir.path().join("zero.obj");
    std::os::unix::fs::symlink("/dev/zero", &mesh_link).unwrap();
    let mesh = r#"<mesh type="obj"><string name="filename" value="zero.obj"/></mesh>"#;
    let scene = write_scene(&dir, "scene.xml", mesh);
    let (code, err) = run_bounded(&["render", scene.to_str().unwrap(), "-q"]);
    assert_one_line_error(
        code,
        &err,
        &["scene.xml:4:", "zero.obj", "not a regular file"],
    );
}

#[test]
fn shapes_beyond_the_coordinate_range_are_refused_at_their_line() {
    let dir = tempfile::tempdir().unwrap();
    let spheres = r#"<mesh type="sphere"><point name="center" value="3e38, 0, 0"/><float name="radius" value="1"/></mesh>
  <mesh type="sphere"><point name="center" value="-3e38, 0, 0"/><float name="radius" value="1"/></mesh>"#;
    let scene = write_scene(&dir, "far.xml", spheres);
    let (code, err) = run_bounded(&["render", scene.to_str().unwrap(), "-q"]);
    assert_one_line_error(code, &err, &["far.xml:4:", "coordinate range"]);
}

#[test]
fn resolutions_beyond_the_pixel_bound_are_refused_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(&dir, "s.xml", ONE_SPHERE);
    let s = scene.to_str().unwrap();
    let (code, err) = run_bounded(&["render", s, "-q", "--resolution", "65536x65536"]);
    assert_one_line_error(code, &err, &["65536x65536", "pixels"]);
    let big = NORI_SPHERES
        .replace("value=\"8\"", "value=\"60000\"")
        .replace("MESHES", ONE_SPHERE);
    std::fs::write(&scene, big).unwrap();
    let (code, err) = run_bounded(&["render", s, "-q"]);
    assert_one_line_error(code, &err, &["s.xml:3:", "60000", "pixels"]);
}

#[test]
fn hostile_image_headers_fail_at_once() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.png");
    for (file, needle) in [
        ("pfm/zero_width_huge_height.pfm", "empty"),
        ("pfm/huge_header.pfm", "pixels"),
        ("png/huge_header.png", "pixels"),
        ("exr/negative_height_window.exr", "OpenEXR"),
        ("exr/reversed_x_window.exr", "OpenEXR"),
    ] {
        let input = root.join(file);
        let (code, err) = run_bounded(&["convert", input.to_str().unwrap(), out.to_str().unwrap()]);
        let name = Path::new(file).file_name().unwrap().to_str().unwrap();
        assert_one_line_error(code, &err, &[name, needle]);
    }
    assert!(!out.exists());
}

#[test]
fn the_next_render_removes_a_killed_runs_temporary_files() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(&dir, "s.xml", ONE_SPHERE);
    // What a run killed during its final write leaves: its process is gone.
    let mut killed = std::process::Command::new("true").spawn().unwrap();
    let dead_pid = killed.id();
    killed.wait().unwrap();
    let leftovers = [
        format!(".out.exr.tmp-{dead_pid}-0"),
        format!(".out.png.tmp-{dead_pid}-1"),
    ];
    for name in &leftovers {
        std::fs::write(dir.path().join(name), vec![0u8; 4096]).unwrap();
    }
    let base = dir.path().join("out");
    let (code, err) = run_bounded(&[
        "render",
        scene.to_str().unwrap(),
        "-q",
        "-o",
        base.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    if Path::new("/proc/self").exists() {
        for name in &leftovers {
            assert!(!dir.path().join(name).exists(), "{name} is still there");
        }
    }
    assert!(dir.path().join("out.exr").exists() && dir.path().join("out.png").exists());
}

#[test]
fn an_include_bomb_is_stopped_by_the_include_count() {
    // Seven files, each including the next ten times: 10^6 includes.
    let dir = tempfile::tempdir().unwrap();
    for level in 0..7 {
        let body = if level < 6 {
            format!("<include filename=\"l{}.xml\"/>\n", level + 1).repeat(10)
        } else {
            "<shape type=\"sphere\"/>\n".to_string()
        };
        let xml = format!("<scene version=\"3.0.0\">\n{body}</scene>\n");
        std::fs::write(dir.path().join(format!("l{level}.xml")), xml).unwrap();
    }
    let (code, err) = run_bounded(&["info", dir.path().join("l0.xml").to_str().unwrap()]);
    assert_one_line_error(code, &err, &["l5.xml:", "<include> files in all"]);
}
