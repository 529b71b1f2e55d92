//! End to end: `lente render --preview 0` watched in headless Chromium.
//!
//! Chromium is started with `--remote-debugging-port=0` (it listens on
//! 127.0.0.1 only and writes the port to `DevToolsActivePort` in its
//! profile folder) and driven over the Chrome DevTools Protocol with the
//! small WebSocket client below: open the preview page, wait for the image,
//! read its pixels through a canvas, check that it updates, that the status
//! shows samples/s, that the exposure slider and the Save button work, and
//! that a closed and reopened page picks up where the render is.
//!
//! Without Chromium the test is skipped, unless `CI` is set: then it fails
//! (`.ci/run` installs Debian's `chromium`).

use std::fs::File;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::cli_util::*;
use serde_json::{json, Value};

/// The Chromium binary: `$LENTE_CHROMIUM`, or `chromium` /
/// `chromium-browser` on the PATH.
fn find_chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("LENTE_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    for dir in std::env::split_paths(&path) {
        for name in ["chromium", "chromium-browser"] {
            let p = dir.join(name);
            if p.is_file() {
                return Some(p);
            }
        }
    }
    None
}

/// Headless Chromium with DevTools on a free loopback port; killed on drop.
struct Browser {
    child: Child,
    port: u16,
    ws_path: String,
}

impl Browser {
    fn start(binary: &Path, profile: &Path, log: &Path) -> Browser {
        let log_file = File::create(log).unwrap();
        let child = Command::new(binary)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--disable-dev-shm-usage",
                "--remote-debugging-address=127.0.0.1",
                "--remote-debugging-port=0",
                "--window-size=900,700",
            ])
            .arg(format!("--user-data-dir={}", profile.display()))
            .arg("about:blank")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(log_file)
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {}: {e}", binary.display()));
        let mut browser = Browser {
            child,
            port: 0,
            ws_path: String::new(),
        };
        let file = profile.join("DevToolsActivePort");
        let end = Instant::now() + Duration::from_secs(60);
        loop {
            // Two lines: the port and the browser's WebSocket path.
            if let Ok(s) = std::fs::read_to_string(&file) {
                let mut lines = s.lines();
                if let (Some(port), Some(path)) = (lines.next(), lines.next()) {
                    if let Ok(port) = port.trim().parse() {
                        browser.port = port;
                        browser.ws_path = path.trim().to_string();
                        return browser;
                    }
                }
            }
            let exited = browser.child.try_wait().ok().flatten();
            if exited.is_some() || Instant::now() > end {
                let log = std::fs::read_to_string(log).unwrap_or_default();
                panic!("Chromium did not open its DevTools port ({exited:?}); its log:\n{log}");
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let end = Instant::now() + Duration::from_secs(5);
        while Instant::now() < end {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A Chrome DevTools Protocol connection: JSON messages over a WebSocket
/// (RFC 6455: client frames masked, server frames not).
struct Cdp {
    ws: TcpStream,
    next_id: u64,
}

impl Cdp {
    fn connect(port: u16, path: &str) -> Cdp {
        let mut ws = TcpStream::connect(("127.0.0.1", port)).expect("connect to DevTools");
        ws.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
        ws.set_nodelay(true).unwrap();
        let request = format!(
            "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n\
             Connection: Upgrade\r\nSec-WebSocket-Key: bGVudGUgcHJldmlldyB0ZQ==\r\n\
             Sec-WebSocket-Version: 13\r\n\r\n"
        );
        ws.write_all(request.as_bytes()).unwrap();
        let mut head = Vec::new();
        let mut byte = [0u8; 1];
        while !head.ends_with(b"\r\n\r\n") {
            ws.read_exact(&mut byte).expect("WebSocket handshake");
            head.push(byte[0]);
            assert!(head.len() < 8192, "handshake answer too long");
        }
        let head = String::from_utf8_lossy(&head);
        assert!(
            head.starts_with("HTTP/1.1 101"),
            "WebSocket upgrade refused: {head}"
        );
        Cdp { ws, next_id: 1 }
    }

    fn send_frame(&mut self, opcode: u8, payload: &[u8]) {
        let mut frame = vec![0x80 | opcode];
        let n = payload.len();
        if n < 126 {
            frame.push(0x80 | n as u8);
        } else if n <= 0xffff {
            frame.push(0x80 | 126);
            frame.extend((n as u16).to_be_bytes());
        } else {
            frame.push(0x80 | 127);
            frame.extend((n as u64).to_be_bytes());
        }
        let mask = [0x6c, 0x65, 0x6e, 0x74];
        frame.extend(mask);
        frame.extend(payload.iter().enumerate().map(|(i, b)| b ^ mask[i % 4]));
        self.ws.write_all(&frame).expect("WebSocket write");
    }

    fn read_exact(&mut self, n: usize) -> Vec<u8> {
        let mut buf = vec![0u8; n];
        self.ws.read_exact(&mut buf).expect("WebSocket read");
        buf
    }

    /// The next whole text message.
    fn recv(&mut self) -> String {
        let mut message = Vec::new();
        loop {
            let h = self.read_exact(2);
            let fin = h[0] & 0x80 != 0;
            let opcode = h[0] & 0x0f;
            let masked = h[1] & 0x80 != 0;
            let len = match h[1] & 0x7f {
                126 => u16::from_be_bytes(self.read_exact(2).try_into().unwrap()) as usize,
                127 => u64::from_be_bytes(self.read_exact(8).try_into().unwrap()) as usize,
                n => n as usize,
            };
            let mask = if masked {
                self.read_exact(4)
            } else {
                vec![0; 4]
            };
            let mut data = self.read_exact(len);
            for (i, b) in data.iter_mut().enumerate() {
                *b ^= mask[i % 4];
            }
            match opcode {
                0x8 => panic!("DevTools closed the connection"),
                0x9 => self.send_frame(0xA, &data),
                0xA => {}
                _ => {
                    message.extend(data);
                    if fin {
                        return String::from_utf8(message).expect("UTF-8 message");
                    }
                }
            }
        }
    }

    /// Calls `method`, skipping events until its answer.
    fn call(
        &mut self,
        session: Option<&str>,
        method: &str,
        params: Value,
    ) -> Result<Value, String> {
        let id = self.next_id;
        self.next_id += 1;
        let mut msg = json!({ "id": id, "method": method, "params": params });
        if let Some(s) = session {
            msg["sessionId"] = json!(s);
        }
        self.send_frame(0x1, msg.to_string().as_bytes());
        loop {
            let answer: Value = serde_json::from_str(&self.recv()).expect("JSON from DevTools");
            if answer["id"] == id {
                if let Some(e) = answer.get("error") {
                    return Err(format!("{method}: {e}"));
                }
                return Ok(answer["result"].clone());
            }
        }
    }

    /// Opens `url` in a new tab; returns (target id, session id).
    fn open(&mut self, url: &str) -> (String, String) {
        let t = self
            .call(None, "Target.createTarget", json!({ "url": url }))
            .unwrap();
        let target = t["targetId"].as_str().unwrap().to_string();
        let s = self
            .call(
                None,
                "Target.attachToTarget",
                json!({ "targetId": target, "flatten": true }),
            )
            .unwrap();
        (target, s["sessionId"].as_str().unwrap().to_string())
    }

    /// Evaluates JavaScript in the page (awaiting promises); the value.
    fn eval(&mut self, session: &str, expr: &str) -> Result<Value, String> {
        let r = self.call(
            Some(session),
            "Runtime.evaluate",
            json!({ "expression": expr, "awaitPromise": true, "returnByValue": true }),
        )?;
        if let Some(e) = r.get("exceptionDetails") {
            return Err(format!("exception: {e}"));
        }
        Ok(r["result"]["value"].clone())
    }
}

/// What the page shows: the image's source, pass and size, a hash and sum
/// of its pixels (drawn into a canvas), and the status and save texts.
const PROBE: &str = r#"(() => {
  const img = document.getElementById("view");
  const out = { src: img.src, pass: Number(img.dataset.pass), w: img.naturalWidth,
                h: img.naturalHeight, shown_w: img.getBoundingClientRect().width,
                hash: 0, sum: 0, grey: 0,
                status: document.getElementById("status").textContent,
                saved: document.getElementById("saved").textContent };
  if (img.complete && img.naturalWidth > 0) {
    const c = document.createElement("canvas");
    c.width = img.naturalWidth;
    c.height = img.naturalHeight;
    const g = c.getContext("2d");
    g.drawImage(img, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    let h = 0, s = 0, grey = 0;
    for (let i = 0; i < d.length; i++) {
      h = (Math.imul(h, 31) + d[i]) | 0;
      if (i % 4 != 3) s += d[i];
      if (i % 4 == 0 && Math.min(d[i], d[i + 1], d[i + 2]) > 8) grey++;
    }
    out.hash = h;
    out.sum = s;
    out.grey = grey;
  }
  return JSON.stringify(out);
})()"#;

#[derive(Debug, Clone)]
struct Shown {
    src: String,
    pass: i64,
    w: u64,
    h: u64,
    /// Its width on screen (CSS pixels).
    shown_w: f64,
    hash: i64,
    sum: u64,
    /// Pixels with no channel near zero (none in the false-colour view,
    /// whose colours all lack one primary).
    grey: u64,
    status: String,
    saved: String,
}

fn probe(cdp: &mut Cdp, session: &str) -> Result<Shown, String> {
    let v = cdp.eval(session, PROBE)?;
    let v: Value = serde_json::from_str(v.as_str().ok_or("probe gave no string")?)
        .map_err(|e| e.to_string())?;
    Ok(Shown {
        src: v["src"].as_str().unwrap_or("").to_string(),
        pass: v["pass"].as_i64().unwrap_or(-1),
        w: v["w"].as_u64().unwrap_or(0),
        h: v["h"].as_u64().unwrap_or(0),
        shown_w: v["shown_w"].as_f64().unwrap_or(0.0),
        hash: v["hash"].as_i64().unwrap_or(0),
        sum: v["sum"].as_u64().unwrap_or(0),
        grey: v["grey"].as_u64().unwrap_or(0),
        status: v["status"].as_str().unwrap_or("").to_string(),
        saved: v["saved"].as_str().unwrap_or("").to_string(),
    })
}

/// Probes until `ok` holds (errors while the page loads are retried).
fn probe_until(cdp: &mut Cdp, session: &str, what: &str, ok: impl Fn(&Shown) -> bool) -> Shown {
    let end = Instant::now() + Duration::from_secs(60);
    loop {
        let last = match probe(cdp, session) {
            Ok(s) if ok(&s) => return s,
            Ok(s) => format!("{s:?}"),
            Err(e) => e,
        };
        if Instant::now() > end {
            panic!("timed out waiting for {what}; last seen: {last:?}");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn preview_page_in_headless_chromium() {
    let Some(chromium) = find_chromium() else {
        if std::env::var_os("CI").is_some() {
            panic!("chromium is not installed (CI is set): apt-get install chromium");
        }
        eprintln!(
            "SKIPPED preview_page_in_headless_chromium: no chromium on the PATH \
             (apt-get install chromium, or set LENTE_CHROMIUM)"
        );
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    // Far more samples than the test waits for: it interrupts the render.
    let scene = write_cbox(&dir, 64, 64, 1_000_000);
    let base = dir.path().join("cbox");
    let mut lente = Running::spawn(&[
        "render",
        "--preview",
        "0",
        scene.to_str().unwrap(),
        "-o",
        base.to_str().unwrap(),
    ]);
    let port = lente.preview_port();
    let url = format!("http://127.0.0.1:{port}/");

    let profile = dir.path().join("profile");
    std::fs::create_dir_all(&profile).unwrap();
    let browser = Browser::start(&chromium, &profile, &dir.path().join("chromium.log"));
    let mut cdp = Cdp::connect(browser.port, &browser.ws_path);
    let (target, page) = cdp.open(&url);

    // The image appears, at the render's size.
    let first = probe_until(&mut cdp, &page, "the first image", |s| {
        s.w > 0 && s.pass >= 0 && s.sum > 0
    });
    assert_eq!((first.w, first.h), (64, 64), "{first:?}");
    assert!(
        first.src.contains("/image.png?exposure=0&tonemap=clamp&v="),
        "{first:?}"
    );

    // It updates: a later pass with different pixels.
    let later = probe_until(&mut cdp, &page, "a newer image", |s| {
        s.pass > first.pass && s.hash != first.hash && s.w == 64
    });
    assert_ne!(later.src, first.src);

    // The status shows progress, a rate and an ETA.
    let st = probe_until(&mut cdp, &page, "a status with a rate", |s| {
        s.status.contains(" samples/s") && !s.status.contains("? samples/s")
    });
    assert!(st.status.contains("/ 1000000 spp"), "{:?}", st.status);
    assert!(st.status.contains("ETA"), "{:?}", st.status);

    // Exposure +2 stops: the image is fetched again, brighter.
    let before = probe(&mut cdp, &page).unwrap();
    cdp.eval(
        &page,
        r#"(() => { const e = document.getElementById("exposure");
                   e.value = "2"; e.dispatchEvent(new Event("input")); })()"#,
    )
    .unwrap();
    let bright = probe_until(&mut cdp, &page, "the brighter image", |s| {
        s.src.contains("exposure=2&") && s.w == 64
    });
    assert!(
        bright.sum as f64 > 1.5 * before.sum as f64,
        "exposure +2 did not brighten: {} -> {}",
        before.sum,
        bright.sum
    );
    assert!(cdp
        .eval(&page, "document.getElementById('ev').textContent")
        .unwrap()
        .as_str()
        .unwrap()
        .contains("+2.00 EV"));

    // Auto exposure and a tone map: fetched with both, the slider off and
    // the EV display showing the stops auto chose; then back.
    let set = |cdp: &mut Cdp, tonemap: &str, auto: bool| {
        let js = format!(
            r#"(() => {{ const t = document.getElementById("tonemap");
                        t.value = "{tonemap}"; t.dispatchEvent(new Event("change"));
                        const a = document.getElementById("auto");
                        a.checked = {auto}; a.dispatchEvent(new Event("change")); }})()"#
        );
        cdp.eval(&page, &js).unwrap();
    };
    set(&mut cdp, "aces", true);
    let mapped = probe_until(&mut cdp, &page, "the auto-exposed ACES image", |s| {
        s.src.contains("exposure=auto&tonemap=aces&") && s.w == 64
    });
    assert!(mapped.sum > 0, "{mapped:?}");
    let disabled = cdp
        .eval(&page, "document.getElementById('exposure').disabled")
        .unwrap();
    assert_eq!(disabled, Value::Bool(true));
    set(&mut cdp, "clamp", false);
    probe_until(&mut cdp, &page, "the image back at +2 EV, clamped", |s| {
        s.src.contains("exposure=2&tonemap=clamp&") && s.w == 64
    });

    // Zoom: fit shows the 64-pixel image 6x (384 px); 1:1, +, the wheel
    // (x1.25 about the mouse) and fit again.
    let click = |cdp: &mut Cdp, id: &str| {
        cdp.eval(&page, &format!("document.getElementById('{id}').click()"))
            .unwrap();
    };
    let width_is = |cdp: &mut Cdp, w: f64, what: &str| {
        probe_until(cdp, &page, what, |s| (s.shown_w - w).abs() < 0.5)
    };
    width_is(&mut cdp, 384.0, "the fitted image");
    click(&mut cdp, "zoom-1");
    width_is(&mut cdp, 64.0, "the image at 1:1");
    click(&mut cdp, "zoom-in");
    width_is(&mut cdp, 128.0, "the image at 200 %");
    let zoom_text = |cdp: &mut Cdp| {
        cdp.eval(&page, "document.getElementById('zoom').textContent")
            .unwrap()
            .as_str()
            .unwrap()
            .to_string()
    };
    assert_eq!(zoom_text(&mut cdp), "200 %");
    cdp.eval(
        &page,
        r#"(() => { const r = document.getElementById("view").getBoundingClientRect();
                   document.getElementById("frame").dispatchEvent(new WheelEvent("wheel",
                     { deltaY: -100, clientX: r.left + 10, clientY: r.top + 10,
                       bubbles: true, cancelable: true })); })()"#,
    )
    .unwrap();
    width_is(&mut cdp, 160.0, "the image wheel-zoomed to 250 %");

    // Pixel readout: the mouse over image pixel (10, 20) at 250 % shows
    // its linear value, as /pixel gives it.
    cdp.eval(
        &page,
        r#"(() => { const r = document.getElementById("view").getBoundingClientRect();
                   document.getElementById("frame").dispatchEvent(new MouseEvent("mousemove",
                     { clientX: r.left + 2.5 * 10 + 1, clientY: r.top + 2.5 * 20 + 1,
                       bubbles: true })); })()"#,
    )
    .unwrap();
    let readout = wait_for("the pixel readout", Duration::from_secs(30), || {
        let t = cdp
            .eval(&page, "document.getElementById('pixel').textContent")
            .ok()?;
        let t = t.as_str()?.to_string();
        t.starts_with("(10, 20)").then_some(t)
    });
    let value = |name: &str| -> f64 {
        let rest = readout.split(&format!(" {name} ")).nth(1).unwrap();
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    let (r, g, b, l) = (value("R"), value("G"), value("B"), value("L"));
    assert!(l > 0.0, "{readout}");
    assert!(
        (l - (0.2126 * r + 0.7152 * g + 0.0722 * b)).abs() < 1e-3,
        "{readout}"
    );
    let direct = http(port, "GET", "/pixel?x=10&y=20");
    assert_eq!(direct.status, 200);
    screenshot(&mut cdp, &page, "preview-zoom.png");
    click(&mut cdp, "zoom-fit");
    width_is(&mut cdp, 384.0, "the image fitted again");
    assert_eq!(zoom_text(&mut cdp), "fit");

    // False colour: fetched with view=false, every pixel on the colour
    // scale (one primary off), the legend shown; then back.
    let coloured = probe_until(&mut cdp, &page, "a colourful normal image", |s| {
        s.grey > 100
    });
    cdp.eval(
        &page,
        r#"(() => { const f = document.getElementById("falsecolour");
                   f.checked = true; f.dispatchEvent(new Event("change")); })()"#,
    )
    .unwrap();
    let zones = probe_until(&mut cdp, &page, "the false-colour image", |s| {
        s.src.contains("&view=false&") && s.w == 64
    });
    assert_eq!(zones.grey, 0, "{zones:?} (normal view: {})", coloured.grey);
    let legend_hidden = cdp
        .eval(&page, "document.getElementById('legend').hidden")
        .unwrap();
    assert_eq!(legend_hidden, Value::Bool(false));
    screenshot(&mut cdp, &page, "preview-falsecolour.png");
    cdp.eval(
        &page,
        r#"(() => { const f = document.getElementById("falsecolour");
                   f.checked = false; f.dispatchEvent(new Event("change")); })()"#,
    )
    .unwrap();
    probe_until(&mut cdp, &page, "the normal view again", |s| {
        !s.src.contains("view=false") && s.w == 64
    });

    // Save writes EXR + PNG next to the output and says where.
    cdp.eval(&page, "document.getElementById('save').click()")
        .unwrap();
    let saved = probe_until(&mut cdp, &page, "the save report", |s| {
        s.saved.starts_with("saved ")
    });
    let spp: u32 = saved.saved["saved ".len()..]
        .split(' ')
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{:?}", saved.saved));
    let exr = dir.path().join(format!("cbox-preview-{spp}spp.exr"));
    let png = dir.path().join(format!("cbox-preview-{spp}spp.png"));
    assert!(
        saved.saved.contains(exr.to_str().unwrap()),
        "{:?}",
        saved.saved
    );
    // A render file of the samples so far (it can be continued).
    let file = lente::render_file::RenderFile::load(&exr).unwrap();
    assert_eq!((file.film.width, file.film.height), (64, 64));
    assert_eq!(file.meta.spp(), spp);
    assert!(png.exists());

    screenshot(&mut cdp, &page, "preview.png");

    // Closed and reopened: the new page shows the render where it is now
    // (and remembers the exposure).
    cdp.call(None, "Target.closeTarget", json!({ "targetId": target }))
        .unwrap();
    let (_, page) = cdp.open(&url);
    let again = probe_until(&mut cdp, &page, "the image after reopening", |s| {
        s.w == 64 && s.pass > later.pass
    });
    assert!(again.src.contains("exposure=2&"), "{again:?}");

    let _ = cdp.call(None, "Browser.close", json!({}));
    drop(cdp);
    drop(browser);

    // Ctrl-C: the render stops and writes the partial image.
    assert!(lente.is_running(), "{}", lente.stderr_text());
    lente.interrupt();
    let (status, stdout) = lente.wait(Duration::from_secs(60));
    assert!(status.success(), "{}", lente.stderr_text());
    assert!(stdout.contains("interrupted"), "{stdout}");
    assert!(dir.path().join("cbox.exr").exists());
}

/// With `LENTE_E2E_SCREENSHOTS=DIR`, saves the page as DIR/NAME (how the
/// screenshots in docs/images are made).
fn screenshot(cdp: &mut Cdp, page: &str, name: &str) {
    if let Some(dir) = std::env::var_os("LENTE_E2E_SCREENSHOTS") {
        let shot = cdp
            .call(Some(page), "Page.captureScreenshot", json!({}))
            .unwrap();
        let bytes = base64_decode(shot["data"].as_str().unwrap());
        std::fs::write(Path::new(&dir).join(name), bytes).unwrap();
    }
}

fn base64_decode(s: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => Some(c - b'A'),
        b'a'..=b'z' => Some(c - b'a' + 26),
        b'0'..=b'9' => Some(c - b'0' + 52),
        b'+' => Some(62),
        b'/' => Some(63),
        _ => None,
    };
    let mut out = Vec::new();
    let (mut acc, mut bits) = (0u32, 0);
    for v in s.bytes().filter_map(value) {
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    out
}
