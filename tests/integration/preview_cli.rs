//! `lente render --preview` and `--checkpoint` from the outside, without a
//! browser: the image is unchanged by watching it, the HTTP endpoints
//! answer (and refuse what they should), a busy port is a clear error, and
//! checkpoints appear while the render runs.

use std::time::Duration;

use crate::cli_util::*;
use lente::image::load_image;

fn status(port: u16) -> serde_json::Value {
    let r = http(port, "GET", "/status");
    assert_eq!(r.status, 200, "{}", r.text());
    assert_eq!(
        r.header("content-type").as_deref(),
        Some("application/json")
    );
    serde_json::from_slice(&r.body).unwrap_or_else(|e| panic!("{e}: {}", r.text()))
}

#[test]
fn preview_and_checkpoints_leave_the_image_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 40, 24, 40);
    let scene = scene.to_str().unwrap();
    let plain = dir.path().join("plain");
    let out = run(&[
        "render",
        scene,
        "-o",
        plain.to_str().unwrap(),
        "--threads",
        "2",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));

    let watched = dir.path().join("watched");
    let mut r = Running::spawn(&[
        "render",
        scene,
        "-o",
        watched.to_str().unwrap(),
        "--threads",
        "1",
        "--checkpoint",
        "0",
        "--preview",
        "0",
        "--preview-linger",
        "0.2",
    ]);
    let port = r.preview_port();
    // Poll while it renders: reading snapshots must not disturb anything.
    while r.is_running() {
        let req = format!("GET /image.png?exposure=3 HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n");
        let _ = try_http_raw(port, req.as_bytes());
        std::thread::sleep(Duration::from_millis(5));
    }
    let (st, stdout) = r.wait(Duration::from_secs(10));
    assert!(st.success(), "{}", r.stderr_text());
    assert!(stdout.contains("40 spp"), "{stdout}");
    let err = r.stderr_text();
    assert!(err.contains("checkpoint: wrote"), "{err}");
    assert!(err.contains("preview: render done; serving"), "{err}");

    let a = std::fs::read(dir.path().join("plain.png")).unwrap();
    let b = std::fs::read(dir.path().join("watched.png")).unwrap();
    assert!(a == b, "PNG files differ with --preview/--checkpoint");
    // The EXRs' channels (image and film state) are the same; their headers
    // differ in the render time.
    let channels = |name: &str| {
        lente::image::load_exr_channels(&dir.path().join(name))
            .unwrap()
            .channels
    };
    assert!(
        channels("plain.exr") == channels("watched.exr"),
        "EXR channels differ with --preview/--checkpoint"
    );
    let (a, _) = load_image(&dir.path().join("plain.exr")).unwrap();
    let (b, _) = load_image(&dir.path().join("watched.exr")).unwrap();
    assert_eq!((a.width, a.height), (40, 24));
    assert!(a.pixels == b.pixels);
    assert!(a.mean().x > 0.0, "the image is black");
}

#[test]
fn preview_endpoints() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 32, 16, 24);
    let base = dir.path().join("img");
    let mut r = Running::spawn(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        base.to_str().unwrap(),
        "--preview=0",
        "--preview-linger",
        "600",
    ]);
    let port = r.preview_port();

    let page = http(port, "GET", "/");
    assert_eq!(page.status, 200);
    assert!(page
        .header("content-type")
        .unwrap()
        .starts_with("text/html"));
    for needle in [
        "<img id=\"view\"",
        "id=\"exposure\"",
        "id=\"save\"",
        "/status",
    ] {
        assert!(page.text().contains(needle), "page lacks {needle}");
    }

    // The render finishes and stays served (lingering).
    let s = wait_for("the render to finish", Duration::from_secs(120), || {
        let s = status(port);
        (s["state"] == "done").then_some(s)
    });
    assert_eq!(s["spp"], 24);
    assert_eq!(s["spp_total"], 24);
    assert_eq!(s["percent"], 100.0);
    assert_eq!(s["width"], 32);
    assert_eq!(s["height"], 16);
    assert!(s["samples_per_second"].as_f64().unwrap() > 0.0, "{s}");
    assert!(s["pass"].as_u64().unwrap() >= 3, "{s}");
    let outputs: Vec<&str> = s["outputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(outputs.len(), 2);
    assert!(outputs[0].ends_with("img.exr"), "{outputs:?}");

    let img = http(port, "GET", "/image.png?exposure=0&v=1");
    assert_eq!(img.status, 200);
    assert_eq!(img.header("content-type").as_deref(), Some("image/png"));
    assert_eq!(&img.body[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR: width and height, big-endian, at bytes 16..24.
    assert_eq!(&img.body[16..24], &[0, 0, 0, 32, 0, 0, 0, 16]);
    // The final pass at exposure 0 is what the render wrote as PNG.
    let written = std::fs::read(dir.path().join("img.png")).unwrap();
    let p = dir.path().join("served.png");
    std::fs::write(&p, &img.body).unwrap();
    let (served, _) = load_image(&p).unwrap();
    let (file, _) = load_image(&dir.path().join("img.png")).unwrap();
    assert!(served.pixels == file.pixels);
    assert!(!written.is_empty());
    let brighter = http(port, "GET", "/image.png?exposure=2");
    assert_eq!(brighter.status, 200);
    assert_ne!(brighter.body, img.body);
    assert_eq!(http(port, "HEAD", "/image.png").body.len(), 0);

    // Save: EXR + PNG named after the sample count.
    let saved = http(port, "POST", "/save?exposure=1");
    assert_eq!(saved.status, 200, "{}", saved.text());
    let j: serde_json::Value = serde_json::from_slice(&saved.body).unwrap();
    assert_eq!(j["ok"], true);
    assert_eq!(j["spp"], 24);
    let exr = j["exr"].as_str().unwrap();
    assert_eq!(
        exr,
        dir.path().join("img-preview-24spp.exr").to_str().unwrap()
    );
    let (a, _) = load_image(std::path::Path::new(exr)).unwrap();
    let (b, _) = load_image(&dir.path().join("img.exr")).unwrap();
    assert!(a.pixels == b.pixels);
    assert!(dir.path().join("img-preview-24spp.png").exists());

    // What must be refused, without taking the server down.
    assert_eq!(http(port, "GET", "/nothing").status, 404);
    assert_eq!(http(port, "GET", "/save").status, 405);
    assert_eq!(http(port, "GET", "/image.png?exposure=bright").status, 400);
    assert_eq!(http_raw(port, b"garbage\r\n\r\n").status, 400);
    assert_eq!(http_raw(port, b"GET / HTTP/2.0\r\n\r\n").status, 505);
    let huge = format!("GET /{} HTTP/1.1\r\n\r\n", "a".repeat(40_000));
    assert_eq!(http_raw(port, huge.as_bytes()).status, 431);
    let rebind = http_raw(
        port,
        b"GET /status HTTP/1.1\r\nHost: attacker.example:8642\r\n\r\n",
    );
    assert_eq!(rebind.status, 403);
    let csrf = http_raw(
        port,
        format!(
            "POST /save HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nOrigin: http://attacker.example\r\nContent-Length: 0\r\n\r\n"
        )
        .as_bytes(),
    );
    assert_eq!(csrf.status, 403);
    // A client that connects and says nothing, or hangs up mid-request.
    drop(std::net::TcpStream::connect(("127.0.0.1", port)).unwrap());
    {
        use std::io::Write;
        let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
        s.write_all(b"GET /sta").unwrap();
    }
    assert_eq!(status(port)["state"], "done");

    // Ctrl-C ends the lingering at once, successfully.
    r.interrupt();
    let (st, _) = r.wait(Duration::from_secs(10));
    assert!(st.success(), "{st:?}: {}", r.stderr_text());
}

#[test]
fn busy_port_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 8, 8, 1);
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port();
    let out = run(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        dir.path().join("x").to_str().unwrap(),
        "--preview",
        &port.to_string(),
    ]);
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains(&format!("127.0.0.1:{port}")), "{err}");
    assert!(err.contains("already in use"), "{err}");
    assert!(!dir.path().join("x.exr").exists());
}

#[test]
fn bad_flags_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 8, 8, 1);
    let scene = scene.to_str().unwrap();
    for args in [
        vec!["--preview-linger", "1"], // needs --preview
        vec!["--checkpoint", "-1"],
        vec!["--checkpoint", "soon"],
        vec!["--preview", "70000"],
        vec!["--preview=0", "--preview-linger", "NaN"],
    ] {
        let mut all = vec!["render", scene, "-o", "/nonexistent/x"];
        all.extend(&args);
        let out = run(&all);
        assert!(!out.status.success(), "{args:?} was accepted");
        assert!(!text(&out.stderr).contains("panicked"), "{args:?}");
    }
}

#[test]
fn checkpoints_appear_while_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 64, 64, 2048);
    let base = dir.path().join("cp");
    let exr = dir.path().join("cp.exr");
    let mut r = Running::spawn(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        base.to_str().unwrap(),
        "--checkpoint",
        "0",
    ]);
    // The first checkpoint follows the first pass (1 spp), long before the
    // render's end.
    // The EXR and the PNG are written one after the other: wait for both.
    let png = dir.path().join("cp.png");
    wait_for("a checkpoint file", Duration::from_secs(60), || {
        (exr.exists() && png.exists()).then_some(())
    });
    assert!(
        r.is_running(),
        "the render ended before its first checkpoint"
    );
    let (mid, _) = load_image(&exr).unwrap();
    assert_eq!((mid.width, mid.height), (64, 64));
    r.interrupt(); // no need to wait for 2048 spp
    let (st, stdout) = r.wait(Duration::from_secs(60));
    assert!(st.success(), "{}", r.stderr_text());
    let err = r.stderr_text();
    let spps: Vec<u32> = err
        .lines()
        .filter_map(|l| l.strip_prefix("checkpoint: wrote "))
        .filter_map(|l| l.rsplit_once('(')?.1.strip_suffix(" spp)")?.parse().ok())
        .collect();
    assert!(!spps.is_empty(), "{err}");
    assert!(spps.windows(2).all(|w| w[0] < w[1]), "{spps:?}");
    assert_eq!(spps[0], 1, "{spps:?}");
    assert!(*spps.last().unwrap() < 2048);
    assert!(stdout.contains("wrote "), "{stdout}");
    // No temporary files left behind by the atomic writes.
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}
