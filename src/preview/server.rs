//! The preview's HTTP server: one accept thread on 127.0.0.1 and a short
//! thread per connection (at most [`MAX_CONNECTIONS`] at once).
//!
//! Nobody can lock the page out: a connection gets [`HEAD_DEADLINE`] in
//! all to send its request head (a per-read timeout would let a client
//! trickle one byte at a time), and when every slot is taken the
//! connection that has waited longest for its head is closed to make room
//! for the new one. A browser sends its request at once, so idle or slow
//! sockets, however many, cannot keep it from being served.
//!
//! Routes:
//! - `GET /`: the page;
//! - `GET /status`: progress as JSON (see [`PreviewState::status_json`]);
//! - `GET /image.png?exposure=STOPS`: the latest pass as PNG (any other
//!   parameter, such as a cache-busting `v=PASS`, is ignored);
//! - `POST /save?exposure=STOPS`: writes the latest pass as EXR + PNG and
//!   answers with the paths as JSON.
//!
//! Requests whose `Host` is not this server's loopback address are refused
//! (a guard against DNS rebinding), and so are cross-origin saves.

use std::io::{self, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::http::{read_request, ReadError, Request, Response};
use super::{PreviewState, SaveError, View};
use crate::image::{Exposure, Look, Tonemap};

/// The port used when `--preview` is given without one.
pub const DEFAULT_PORT: u16 = 8642;

/// Connections served at once.
pub const MAX_CONNECTIONS: usize = 64;

/// Time a connection has to send its whole request head.
pub const HEAD_DEADLINE: Duration = Duration::from_secs(2);

/// Time to write a response (a slow reader of a big PNG).
const WRITE_TIMEOUT: Duration = Duration::from_secs(10);

const PAGE: &str = include_str!("page.html");

/// The server could not start.
#[derive(Debug, thiserror::Error)]
pub enum PreviewError {
    #[error("cannot serve the preview on 127.0.0.1:{port}: the port is already in use (choose another with --preview PORT, or --preview 0 for any free port)")]
    PortInUse { port: u16 },
    #[error("cannot serve the preview on 127.0.0.1:{port}: {source}")]
    Bind { port: u16, source: io::Error },
}

/// A running preview server; stopped on [`PreviewServer::stop`] or drop.
pub struct PreviewServer {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl PreviewServer {
    /// Binds 127.0.0.1:`port` (0: any free port) and starts serving `state`.
    pub fn start(port: u16, state: PreviewState) -> Result<PreviewServer, PreviewError> {
        let listener = TcpListener::bind((Ipv4Addr::LOCALHOST, port)).map_err(|e| {
            if e.kind() == io::ErrorKind::AddrInUse {
                PreviewError::PortInUse { port }
            } else {
                PreviewError::Bind { port, source: e }
            }
        })?;
        let addr = listener
            .local_addr()
            .map_err(|e| PreviewError::Bind { port, source: e })?;
        listener
            .set_nonblocking(true)
            .map_err(|e| PreviewError::Bind { port, source: e })?;
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let stop = stop.clone();
            std::thread::Builder::new()
                .name("lente-preview".into())
                .spawn(move || accept_loop(listener, state, stop))
                .map_err(|e| PreviewError::Bind { port, source: e })?
        };
        Ok(PreviewServer {
            addr,
            stop,
            thread: Some(thread),
        })
    }

    pub fn port(&self) -> u16 {
        self.addr.port()
    }

    /// The page's address, e.g. `http://127.0.0.1:8642/`.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// Stops accepting connections (requests in flight finish on their own).
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for PreviewServer {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// A connection being served: a handle to close it with, and whether it is
/// still waiting for its request head.
struct Slot {
    id: u64,
    stream: TcpStream,
    accepted: Instant,
    waiting_for_head: Arc<AtomicBool>,
}

/// The connections being served.
#[derive(Clone, Default)]
struct Slots(Arc<Mutex<Vec<Slot>>>);

impl Slots {
    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Slot>> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Makes room for one more: if all slots are taken, closes the
    /// connection that has waited longest for its head. False if all are
    /// busy answering (the new connection is then dropped).
    fn make_room(&self) -> bool {
        let slots = self.lock();
        if slots.len() < MAX_CONNECTIONS {
            return true;
        }
        let oldest_idle = slots
            .iter()
            .filter(|s| s.waiting_for_head.load(Ordering::SeqCst))
            .min_by_key(|s| s.accepted);
        match oldest_idle {
            Some(slot) => {
                // Its thread's read returns at once and frees the slot.
                let _ = slot.stream.shutdown(std::net::Shutdown::Both);
                true
            }
            None => false,
        }
    }

    fn release(&self, id: u64) {
        self.lock().retain(|s| s.id != id);
    }
}

fn accept_loop(listener: TcpListener, state: PreviewState, stop: Arc<AtomicBool>) {
    let port = listener.local_addr().map(|a| a.port()).unwrap_or(0);
    let slots = Slots::default();
    let next_id = AtomicU64::new(0);
    while !stop.load(Ordering::SeqCst) {
        match listener.accept() {
            Ok((stream, _)) => {
                if !slots.make_room() {
                    continue; // dropped: closed at once
                }
                let Ok(handle) = stream.try_clone() else {
                    continue;
                };
                let id = next_id.fetch_add(1, Ordering::Relaxed);
                let waiting_for_head = Arc::new(AtomicBool::new(true));
                slots.lock().push(Slot {
                    id,
                    stream: handle,
                    accepted: Instant::now(),
                    waiting_for_head: waiting_for_head.clone(),
                });
                let state = state.clone();
                let done = slots.clone();
                let spawned = std::thread::Builder::new()
                    .name("lente-preview-conn".into())
                    .spawn(move || {
                        serve(stream, &state, port, &waiting_for_head);
                        done.release(id);
                    });
                if spawned.is_err() {
                    slots.release(id);
                }
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(_) => {
                // E.g. too many open files: back off rather than spin.
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    }
}

/// A stream whose reads all end by one deadline: each read waits at most
/// the time left, then fails with `TimedOut`.
struct DeadlineReader<'a> {
    stream: &'a TcpStream,
    deadline: Instant,
}

impl io::Read for DeadlineReader<'_> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let left = self.deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(io::ErrorKind::TimedOut.into());
        }
        self.stream.set_read_timeout(Some(left))?;
        (&mut &*self.stream).read(buf)
    }
}

/// Answers one request on `stream`, then closes it.
fn serve(mut stream: TcpStream, state: &PreviewState, port: u16, waiting_for_head: &AtomicBool) {
    // Accepted sockets may inherit the listener's non-blocking mode.
    let _ = stream.set_nonblocking(false);
    let _ = stream.set_write_timeout(Some(WRITE_TIMEOUT));
    let _ = stream.set_nodelay(true);
    let mut reader = DeadlineReader {
        stream: &stream,
        deadline: Instant::now() + HEAD_DEADLINE,
    };
    let read = read_request(&mut reader);
    waiting_for_head.store(false, Ordering::SeqCst);
    let (response, head_only) = match read {
        Ok(req) => (route(&req, state, port), req.method == "HEAD"),
        Err(ReadError::Bad(r)) => (r, false),
        Err(ReadError::Closed) => return,
    };
    let _ = response.write_to(&mut stream, head_only);
    let _ = stream.flush();
    let _ = stream.shutdown(std::net::Shutdown::Write);
}

/// True if `host` (a Host header) names this server.
fn host_allowed(host: &str, port: u16) -> bool {
    let host = host.to_ascii_lowercase();
    ["127.0.0.1", "localhost"]
        .iter()
        .any(|name| host == format!("{name}:{port}") || (port == 80 && host == *name))
}

/// Dispatches a request.
pub(super) fn route(req: &Request, state: &PreviewState, port: u16) -> Response {
    if let Some(host) = req.header("host") {
        if !host_allowed(host, port) {
            return Response::text(403, "unexpected Host header");
        }
    }
    let get = matches!(req.method.as_str(), "GET" | "HEAD");
    let wrong_method = |allow: &str| {
        Response::text(405, &format!("method {} not allowed", req.method))
            .with_header("Allow", allow)
    };
    match req.path.as_str() {
        "/" | "/index.html" => {
            if !get {
                return wrong_method("GET, HEAD");
            }
            Response::new(200, "text/html; charset=utf-8", PAGE)
        }
        "/status" => {
            if !get {
                return wrong_method("GET, HEAD");
            }
            Response::json(200, state.status_json())
        }
        "/image.png" => {
            if !get {
                return wrong_method("GET, HEAD");
            }
            let look = match look_param(req) {
                Ok(l) => l,
                Err(r) => return r,
            };
            let view = match req.param("view") {
                None | Some("image") => View::Image,
                Some("false") => View::FalseColour,
                Some(v) => {
                    return Response::text(400, &format!("bad view '{v}': expected image or false"))
                }
            };
            match state.png(look, view) {
                Ok((pass, bytes)) => Response::new(200, "image/png", bytes.as_slice())
                    .with_header("X-Lente-Pass", pass.to_string()),
                Err(e) => Response::text(500, &e.to_string()),
            }
        }
        "/pixel" => {
            if !get {
                return wrong_method("GET, HEAD");
            }
            let coord = |name: &str| req.param(name).and_then(|v| v.trim().parse::<usize>().ok());
            let (Some(x), Some(y)) = (coord("x"), coord("y")) else {
                return Response::text(400, "expected /pixel?x=X&y=Y (whole pixel coordinates)");
            };
            match state.pixel(x, y) {
                Some((pass, c)) => Response::json(
                    200,
                    serde_json::json!({
                        "x": x,
                        "y": y,
                        "pass": pass,
                        "r": c.x,
                        "g": c.y,
                        "b": c.z,
                        "luminance": crate::color::luminance(c),
                    })
                    .to_string(),
                ),
                None => Response::text(404, &format!("no pixel ({x}, {y}) in the image")),
            }
        }
        "/save" => {
            if req.method != "POST" {
                return wrong_method("POST");
            }
            if let Some(origin) = req.header("origin") {
                let ok = origin
                    .strip_prefix("http://")
                    .is_some_and(|h| host_allowed(h, port));
                if !ok {
                    return Response::text(403, "cross-origin save refused");
                }
            }
            let look = match look_param(req) {
                Ok(l) => l,
                Err(r) => return r,
            };
            match state.save(look) {
                Ok(saved) => Response::json(
                    200,
                    serde_json::json!({
                        "ok": true,
                        "spp": saved.spp,
                        "exr": saved.exr.to_string_lossy(),
                        "png": saved.png.to_string_lossy(),
                    })
                    .to_string(),
                ),
                Err(e) => Response::json(
                    if matches!(e, SaveError::NothingYet) {
                        409
                    } else {
                        500
                    },
                    serde_json::json!({"ok": false, "error": e.to_string()}).to_string(),
                ),
            }
        }
        _ => Response::text(404, "not found"),
    }
}

/// The `exposure` (stops, or `auto`; default 0) and `tonemap` (clamp,
/// reinhard, aces, filmic; default clamp) parameters.
fn look_param(req: &Request) -> Result<Look, Response> {
    let exposure = match req.param("exposure") {
        None => Exposure::Stops(0.0),
        Some(v) if v.trim().eq_ignore_ascii_case("auto") => Exposure::Auto,
        Some(v) => match v.trim().parse::<f32>() {
            Ok(e) if e.is_finite() => Exposure::Stops(e),
            _ => {
                return Err(Response::text(
                    400,
                    &format!("bad exposure '{v}': expected a number of stops or auto"),
                ))
            }
        },
    };
    let tonemap = match req.param("tonemap") {
        None => Tonemap::Clamp,
        Some(v) => v
            .parse()
            .map_err(|e: crate::image::tonemap::UnknownTonemap| {
                Response::text(400, &format!("bad tonemap: {e}"))
            })?,
    };
    Ok(Look { exposure, tonemap })
}

#[cfg(test)]
mod tests {
    use super::super::http::parse_head;
    use super::*;
    use std::io::Read;
    use std::path::Path;

    fn req(raw: &str) -> Request {
        parse_head(raw.as_bytes()).unwrap()
    }

    #[test]
    fn routes() {
        let state = PreviewState::new(2, 2, 4, Path::new("/nonexistent/x"));
        let p = 5000;
        let r = route(&req("GET / HTTP/1.1\r\nHost: 127.0.0.1:5000"), &state, p);
        assert_eq!(r.status, 200);
        assert!(String::from_utf8_lossy(&r.body).contains("<img"));
        assert_eq!(route(&req("GET /status HTTP/1.1"), &state, p).status, 200);
        let r = route(&req("GET /image.png?exposure=1&v=0 HTTP/1.1"), &state, p);
        assert_eq!(r.status, 200);
        assert_eq!(r.content_type, "image/png");
        for bad in ["x", "inf", "NaN", ""] {
            let r = route(
                &req(&format!("GET /image.png?exposure={bad} HTTP/1.1")),
                &state,
                p,
            );
            assert_eq!(r.status, 400, "{bad}");
        }
        let r = route(&req("GET /image.png?view=false HTTP/1.1"), &state, p);
        assert_eq!((r.status, r.content_type), (200, "image/png"));
        let r = route(&req("GET /image.png?view=x HTTP/1.1"), &state, p);
        assert_eq!(r.status, 400);
        let r = route(&req("GET /pixel?x=1&y=0 HTTP/1.1"), &state, p);
        assert_eq!(r.status, 200);
        let v: serde_json::Value = serde_json::from_slice(&r.body).unwrap();
        assert_eq!((v["x"].as_u64(), v["y"].as_u64()), (Some(1), Some(0)));
        assert_eq!(v["r"].as_f64(), Some(0.0));
        for bad in ["x=2&y=0", "x=0&y=2", "x=-1&y=0", "y=0", "x=a&y=1"] {
            let r = route(&req(&format!("GET /pixel?{bad} HTTP/1.1")), &state, p);
            assert!(r.status == 400 || r.status == 404, "{bad}: {}", r.status);
        }
        assert_eq!(route(&req("GET /nope HTTP/1.1"), &state, p).status, 404);
        assert_eq!(route(&req("GET /save HTTP/1.1"), &state, p).status, 405);
        assert_eq!(route(&req("POST /status HTTP/1.1"), &state, p).status, 405);
        // Nothing rendered yet.
        assert_eq!(route(&req("POST /save HTTP/1.1"), &state, p).status, 409);
        let r = route(&req("GET / HTTP/1.1\r\nHost: evil.example:5000"), &state, p);
        assert_eq!(r.status, 403);
        let r = route(
            &req("POST /save HTTP/1.1\r\nOrigin: http://evil.example"),
            &state,
            p,
        );
        assert_eq!(r.status, 403);
        assert!(host_allowed("LOCALHOST:5000", 5000));
        assert!(!host_allowed("127.0.0.1:5001", 5000));
    }

    #[test]
    fn serves_over_tcp_and_reports_a_busy_port() {
        let state = PreviewState::new(2, 2, 4, Path::new("x"));
        let server = PreviewServer::start(0, state.clone()).unwrap();
        assert!(server.url().starts_with("http://127.0.0.1:"));
        let mut s = TcpStream::connect(("127.0.0.1", server.port())).unwrap();
        s.write_all(b"GET /status HTTP/1.1\r\n\r\n").unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).unwrap();
        assert!(out.starts_with("HTTP/1.1 200 OK"), "{out}");
        assert!(out.contains("\"state\":\"rendering\""), "{out}");
        let mut s = TcpStream::connect(("127.0.0.1", server.port())).unwrap();
        s.write_all(b"\x00\x01garbage\r\n\r\n").unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).unwrap();
        assert!(out.starts_with("HTTP/1.1 400"), "{out}");

        match PreviewServer::start(server.port(), state) {
            Err(e @ PreviewError::PortInUse { .. }) => {
                assert!(e.to_string().contains(&server.port().to_string()))
            }
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("bound a busy port"),
        }
        server.stop();
    }

    /// Sends `request` on a new connection and reads the whole answer.
    fn fetch(port: u16, request: &[u8]) -> String {
        let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        s.write_all(request).unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).unwrap();
        out
    }

    #[test]
    fn idle_sockets_cannot_lock_the_page_out() {
        let state = PreviewState::new(2, 2, 4, Path::new("x"));
        let server = PreviewServer::start(0, state).unwrap();
        let port = server.port();
        let idle: Vec<TcpStream> = (0..200)
            .map(|_| TcpStream::connect(("127.0.0.1", port)).unwrap())
            .collect();
        // Slow ones too: a byte now and then, never a whole head.
        let mut slow: Vec<TcpStream> = (0..20)
            .map(|_| TcpStream::connect(("127.0.0.1", port)).unwrap())
            .collect();
        for s in &mut slow {
            let _ = s.write_all(b"G");
        }
        std::thread::sleep(Duration::from_millis(100));
        for _ in 0..3 {
            let start = Instant::now();
            let request = format!("GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n");
            let out = fetch(port, request.as_bytes());
            let took = start.elapsed();
            assert!(out.starts_with("HTTP/1.1 200 OK"), "{out}");
            assert!(took < Duration::from_secs(1), "page took {took:?}");
        }
        drop((idle, slow));
        server.stop();
    }

    #[test]
    fn a_head_must_arrive_within_the_deadline() {
        let state = PreviewState::new(2, 2, 4, Path::new("x"));
        let server = PreviewServer::start(0, state).unwrap();
        let mut s = TcpStream::connect(("127.0.0.1", server.port())).unwrap();
        s.set_read_timeout(Some(HEAD_DEADLINE * 3)).unwrap();
        let start = Instant::now();
        // Trickle bytes more often than any per-read timeout would allow.
        let mut closed = false;
        for _ in 0..40 {
            if s.write_all(b"X").is_err() {
                closed = true;
                break;
            }
            std::thread::sleep(Duration::from_millis(100));
            if start.elapsed() > HEAD_DEADLINE + Duration::from_millis(500) {
                break;
            }
        }
        let mut out = String::new();
        let _ = s.read_to_string(&mut out);
        assert!(
            closed || start.elapsed() < HEAD_DEADLINE * 2,
            "{:?}",
            start.elapsed()
        );
        assert!(!out.contains("200 OK"), "{out}");
        server.stop();
    }

    #[test]
    fn bare_lf_requests_get_an_answer() {
        let state = PreviewState::new(2, 2, 4, Path::new("x"));
        let server = PreviewServer::start(0, state).unwrap();
        let start = Instant::now();
        let out = fetch(server.port(), b"GET /status HTTP/1.1\n\n");
        assert!(out.starts_with("HTTP/1.1 200 OK"), "{out}");
        assert!(start.elapsed() < Duration::from_secs(1));
        server.stop();
    }
}
