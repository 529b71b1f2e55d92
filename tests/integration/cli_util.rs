//! Helpers for tests that run the `lente` binary: temp folders, a small
//! Cornell box scene file, a child process that is killed on drop and
//! whose stderr is collected, and a minimal HTTP client for 127.0.0.1.
#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Output, Stdio};

use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant};

pub const LENTE: &str = env!("CARGO_BIN_EXE_lente");

/// Writes a Nori scene file for the project's Cornell box (meshes read
/// from `scenes/cbox`) at `width` x `height` and `spp` samples per pixel;
/// returns its path.
pub fn write_cbox(dir: &tempfile::TempDir, width: u32, height: u32, spp: u32) -> PathBuf {
    let meshes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cbox");
    let mesh = |name: &str, bsdf: &str| {
        format!(
            "  <mesh type=\"obj\">\n    <string name=\"filename\" value=\"{}\"/>\n    {bsdf}\n  </mesh>\n",
            meshes.join(name).display()
        )
    };
    let grey = "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0.725, 0.71, 0.68\"/></bsdf>";
    let mut xml = format!(
        "<?xml version=\"1.0\"?>\n<scene>\n  <integrator type=\"path_mis\"/>\n  \
         <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"{spp}\"/></sampler>\n  \
         <camera type=\"perspective\">\n    <float name=\"fov\" value=\"39\"/>\n    \
         <transform name=\"toWorld\"><lookat target=\"0, 1, 0\" origin=\"0, 1, 3.9\" up=\"0, 1, 0\"/></transform>\n    \
         <integer name=\"width\" value=\"{width}\"/>\n    <integer name=\"height\" value=\"{height}\"/>\n  </camera>\n"
    );
    xml += &mesh("floor.obj", grey);
    xml += &mesh("ceiling.obj", grey);
    xml += &mesh("back.obj", grey);
    xml += &mesh(
        "left.obj",
        "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0.63, 0.065, 0.05\"/></bsdf>",
    );
    xml += &mesh(
        "right.obj",
        "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0.14, 0.45, 0.091\"/></bsdf>",
    );
    xml += &mesh(
        "light.obj",
        "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0\"/></bsdf>\n    \
         <emitter type=\"area\"><color name=\"radiance\" value=\"17, 12, 4\"/></emitter>",
    );
    xml += "  <mesh type=\"sphere\"><point name=\"center\" value=\"-0.42, 0.38, -0.3\"/>\
            <float name=\"radius\" value=\"0.38\"/><bsdf type=\"mirror\"/></mesh>\n";
    xml += "  <mesh type=\"sphere\"><point name=\"center\" value=\"0.45, 0.38, 0.35\"/>\
            <float name=\"radius\" value=\"0.38\"/><bsdf type=\"dielectric\"/></mesh>\n";
    xml += "</scene>\n";
    let path = dir.path().join("cbox.xml");
    std::fs::write(&path, xml).unwrap();
    path
}

/// Runs `lente` with `args` to completion and checks that it succeeded.
pub fn run_ok(args: &[&str]) -> Output {
    let out = run(args);
    assert!(out.status.success(), "{}", dump(&out));
    out
}

/// Runs `lente` with `args` to completion and checks that it failed with
/// `message` in its error output.
pub fn run_fails_with(args: &[&str], message: &str) -> Output {
    let out = run(args);
    assert!(!out.status.success(), "{}", dump(&out));
    assert!(text(&out.stderr).contains(message), "{}", dump(&out));
    out
}

/// Runs `lente` with `args` to completion.
pub fn run(args: &[&str]) -> Output {
    Command::new(LENTE)
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("cannot run lente")
}

/// A finished run's status and output, for assertion messages.
pub fn dump(out: &Output) -> String {
    format!(
        "status {:?}\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// A running `lente`, killed on drop, with its stderr lines collected.
pub struct Running {
    pub child: Child,
    lines: mpsc::Receiver<String>,
    pub stderr: Arc<Mutex<Vec<String>>>,
}

impl Running {
    pub fn spawn(args: &[&str]) -> Running {
        let mut child = Command::new(LENTE)
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("cannot start lente");
        let err = child.stderr.take().unwrap();
        let (tx, lines) = mpsc::channel();
        let stderr = Arc::new(Mutex::new(Vec::new()));
        {
            let stderr = stderr.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(err).lines() {
                    let Ok(line) = line else { break };
                    stderr.lock().unwrap().push(line.clone());
                    let _ = tx.send(line);
                }
            });
        }
        Running {
            child,
            lines,
            stderr,
        }
    }

    /// Waits for the stderr line starting with `prefix`; returns the rest.
    pub fn wait_line(&self, prefix: &str, timeout: Duration) -> String {
        let end = Instant::now() + timeout;
        loop {
            let left = end.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) => {
                    if let Some(rest) = line.strip_prefix(prefix) {
                        return rest.to_string();
                    }
                }
                Err(_) => panic!(
                    "no stderr line starting with {prefix:?} within {timeout:?}; stderr so far:\n{}",
                    self.stderr_text()
                ),
            }
        }
    }

    /// The preview's port, from the `preview: http://127.0.0.1:PORT/` line.
    pub fn preview_port(&self) -> u16 {
        let url = self.wait_line("preview: ", Duration::from_secs(60));
        let port = url
            .strip_prefix("http://127.0.0.1:")
            .and_then(|r| r.strip_suffix('/'))
            .and_then(|p| p.parse().ok());
        port.unwrap_or_else(|| panic!("unexpected preview URL line: {url}"))
    }

    pub fn stderr_text(&self) -> String {
        self.stderr.lock().unwrap().join("\n")
    }

    /// Sends SIGINT (as Ctrl-C does).
    pub fn interrupt(&self) {
        let ok = Command::new("kill")
            .args(["-INT", &self.child.id().to_string()])
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        assert!(ok, "cannot send SIGINT to lente");
    }

    /// Waits for the process to exit; returns its status and stdout.
    pub fn wait(&mut self, timeout: Duration) -> (ExitStatus, String) {
        let end = Instant::now() + timeout;
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                let mut out = String::new();
                if let Some(mut o) = self.child.stdout.take() {
                    let _ = o.read_to_string(&mut out);
                }
                // Let the reader thread drain the last stderr lines.
                std::thread::sleep(Duration::from_millis(50));
                return (status, out);
            }
            if Instant::now() > end {
                panic!(
                    "lente did not exit within {timeout:?}; stderr:\n{}",
                    self.stderr_text()
                );
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    pub fn is_running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// An HTTP answer.
pub struct HttpResponse {
    pub status: u16,
    pub head: String,
    pub body: Vec<u8>,
}

impl HttpResponse {
    pub fn text(&self) -> String {
        text(&self.body)
    }

    pub fn header(&self, name: &str) -> Option<String> {
        self.head.lines().find_map(|l| {
            let (n, v) = l.split_once(':')?;
            n.eq_ignore_ascii_case(name).then(|| v.trim().to_string())
        })
    }
}

/// Sends raw bytes to 127.0.0.1:`port` and reads the answer to the end.
pub fn http_raw(port: u16, request: &[u8]) -> HttpResponse {
    try_http_raw(port, request).unwrap_or_else(|e| panic!("HTTP request to port {port}: {e}"))
}

/// Like [`http_raw`], but an error instead of a panic.
pub fn try_http_raw(port: u16, request: &[u8]) -> Result<HttpResponse, String> {
    let mut s = TcpStream::connect(("127.0.0.1", port)).map_err(|e| format!("connect: {e}"))?;
    s.set_read_timeout(Some(Duration::from_secs(30)))
        .map_err(|e| e.to_string())?;
    s.write_all(request).map_err(|e| format!("write: {e}"))?;
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).map_err(|e| format!("read: {e}"))?;
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .ok_or_else(|| format!("no HTTP head in {:?}", text(&raw)))?;
    let head = text(&raw[..split]);
    let status = head
        .split(' ')
        .nth(1)
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| format!("bad status line: {head}"))?;
    Ok(HttpResponse {
        status,
        head,
        body: raw[split + 4..].to_vec(),
    })
}

/// `METHOD path` with the right Host header.
pub fn http(port: u16, method: &str, path: &str) -> HttpResponse {
    http_raw(
        port,
        format!("{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Length: 0\r\n\r\n")
            .as_bytes(),
    )
}

/// Polls `f` every 20 ms until it returns `Some`, or panics after
/// `timeout` with `what`.
pub fn wait_for<T>(what: &str, timeout: Duration, mut f: impl FnMut() -> Option<T>) -> T {
    let end = Instant::now() + timeout;
    loop {
        if let Some(v) = f() {
            return v;
        }
        if Instant::now() > end {
            panic!("timed out after {timeout:?} waiting for {what}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}
