//! Streaming the image in progress to a running [tev](https://github.com/Tom94/tev)
//! viewer over its TCP protocol, as pbrt-v4's `--display-server` does.
//!
//! Every packet is a little-endian `u32` length (the whole packet's, these
//! four bytes included), a type byte and its payload. lente sends
//! *create image* (type 4: name, size, channel names) once per connection
//! and *update image* (type 6, version 3: a rectangle of float pixels with
//! per-channel offsets and strides) in tiles of at most 128x128 pixels.
//!
//! A background thread does the sending, so a slow or absent viewer never
//! holds up rendering: it keeps only the newest image, connects when tev
//! is listening (tev may be started after the render), and says once on
//! stderr when it cannot reach it or loses it.

use std::io::Write;
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::image::Bitmap;

/// tev's default port.
pub const DEFAULT_PORT: u16 = 14158;

/// Tiles sent per update packet, at most this many pixels a side (as tev's
/// own Python client does: packets of a typical size).
pub const TILE: usize = 128;

const CREATE_IMAGE: u8 = 4;
const UPDATE_IMAGE_V3: u8 = 6;

/// How long a connection attempt may take, and how long to wait before the
/// next one after a failure.
const CONNECT_TIMEOUT: Duration = Duration::from_millis(500);
const RETRY_EVERY: Duration = Duration::from_secs(1);
/// Fewest seconds between two updates (the last one is sent regardless).
const MIN_INTERVAL: Duration = Duration::from_millis(250);

/// Parses `[HOST:]PORT` (HOST defaults to 127.0.0.1; `[::1]:PORT` for IPv6).
pub fn parse_address(s: &str) -> Result<String, String> {
    let s = s.trim();
    let (host, port) = match s.rsplit_once(':') {
        Some((h, p)) if !h.is_empty() => (h.to_string(), p),
        Some((_, p)) => ("127.0.0.1".to_string(), p),
        None => ("127.0.0.1".to_string(), s),
    };
    let port: u16 = port
        .parse()
        .map_err(|_| format!("'{s}' is not [HOST:]PORT (tev listens on {DEFAULT_PORT})"))?;
    Ok(format!("{host}:{port}"))
}

/// The bytes of a packet of `kind` with `payload`.
fn packet(kind: u8, payload: &[u8]) -> Vec<u8> {
    let len = u32::try_from(payload.len() + 5).unwrap_or(u32::MAX);
    let mut p = Vec::with_capacity(payload.len() + 5);
    p.extend_from_slice(&len.to_le_bytes());
    p.push(kind);
    p.extend_from_slice(payload);
    p
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    // tev reads NUL-terminated strings: a NUL inside would cut it short.
    out.extend(s.bytes().filter(|&b| b != 0));
    out.push(0);
}

fn put_i32(out: &mut Vec<u8>, v: usize) {
    out.extend_from_slice(&(i32::try_from(v).unwrap_or(i32::MAX)).to_le_bytes());
}

/// *create image*: a blank `width` x `height` image named `name` with
/// `channels`, which tev shows (grabbing focus).
pub fn create_image_packet(name: &str, width: usize, height: usize, channels: &[&str]) -> Vec<u8> {
    let mut p = vec![1u8]; // grab focus
    put_str(&mut p, name);
    put_i32(&mut p, width);
    put_i32(&mut p, height);
    put_i32(&mut p, channels.len());
    for c in channels {
        put_str(&mut p, c);
    }
    packet(CREATE_IMAGE, &p)
}

/// *update image* packets (version 3) carrying all of `image` as channels
/// `R`, `G`, `B` of the image `name`, one per tile of at most [`TILE`]
/// pixels a side.
pub fn update_image_packets(name: &str, image: &Bitmap) -> Vec<Vec<u8>> {
    let mut packets = Vec::new();
    for y0 in (0..image.height).step_by(TILE) {
        for x0 in (0..image.width).step_by(TILE) {
            let (w, h) = (TILE.min(image.width - x0), TILE.min(image.height - y0));
            let mut p = Vec::with_capacity(64 + name.len() + 12 * w * h);
            p.push(0); // do not grab focus
            put_str(&mut p, name);
            put_i32(&mut p, 3);
            for c in ["R", "G", "B"] {
                put_str(&mut p, c);
            }
            for v in [x0, y0, w, h] {
                put_i32(&mut p, v);
            }
            // Interleaved RGB: channel c at offset c, stride 3.
            for offset in 0..3i64 {
                p.extend_from_slice(&offset.to_le_bytes());
            }
            for _ in 0..3 {
                p.extend_from_slice(&3i64.to_le_bytes());
            }
            for y in y0..y0 + h {
                for px in &image.pixels[y * image.width + x0..y * image.width + x0 + w] {
                    for v in [px.x, px.y, px.z] {
                        p.extend_from_slice(&v.to_le_bytes());
                    }
                }
            }
            packets.push(packet(UPDATE_IMAGE_V3, &p));
        }
    }
    packets
}

/// What the render thread hands the sender.
#[derive(Default)]
struct Slot {
    /// The newest image not sent yet.
    pending: Option<Arc<Bitmap>>,
    /// No more images will come: send the pending one and stop.
    closing: bool,
    /// The sender has stopped.
    done: bool,
}

struct Shared {
    slot: Mutex<Slot>,
    wake: Condvar,
}

fn lock(m: &Mutex<Slot>) -> MutexGuard<'_, Slot> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// A stream of one render's images to tev.
pub struct TevStream {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
}

impl TevStream {
    /// Starts streaming to tev at `address` (`HOST:PORT`) an image `name`
    /// of `width` x `height`; nothing is sent until [`Self::publish`].
    pub fn start(address: &str, name: &str, width: usize, height: usize) -> TevStream {
        let shared = Arc::new(Shared {
            slot: Mutex::new(Slot::default()),
            wake: Condvar::new(),
        });
        let sender = Sender {
            address: address.to_string(),
            name: name.to_string(),
            size: (width, height),
            stream: None,
            warned: false,
            next_attempt: Instant::now(),
        };
        let s = shared.clone();
        let thread = std::thread::Builder::new()
            .name("tev".into())
            .spawn(move || sender.run(&s))
            .ok();
        TevStream { shared, thread }
    }

    /// Hands over the newest image (an older one not sent yet is dropped).
    pub fn publish(&self, image: Arc<Bitmap>) {
        lock(&self.shared.slot).pending = Some(image);
        self.shared.wake.notify_all();
    }

    /// Sends `image` as the last one, waiting at most `timeout` for it to
    /// go out; returns whether it did.
    pub fn finish(mut self, image: Arc<Bitmap>, timeout: Duration) -> bool {
        {
            let mut slot = lock(&self.shared.slot);
            slot.pending = Some(image);
            slot.closing = true;
        }
        self.shared.wake.notify_all();
        let until = Instant::now() + timeout;
        let mut slot = lock(&self.shared.slot);
        while !slot.done {
            let left = until.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return false;
            }
            slot = self
                .shared
                .wake
                .wait_timeout(slot, left)
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
        drop(slot);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        true
    }
}

impl Drop for TevStream {
    fn drop(&mut self) {
        // Not finished (an error path): stop the sender without waiting.
        lock(&self.shared.slot).closing = true;
        self.shared.wake.notify_all();
    }
}

/// The sending thread's state.
struct Sender {
    address: String,
    name: String,
    size: (usize, usize),
    stream: Option<TcpStream>,
    warned: bool,
    next_attempt: Instant,
}

impl Sender {
    fn run(mut self, shared: &Shared) {
        let mut last_sent: Option<Instant> = None;
        loop {
            let (image, closing) = {
                let mut slot = lock(&shared.slot);
                while slot.pending.is_none() && !slot.closing {
                    slot = shared.wake.wait(slot).unwrap_or_else(|e| e.into_inner());
                }
                (slot.pending.take(), slot.closing)
            };
            if let Some(image) = image {
                if !closing {
                    // Let quick passes pile up into one update.
                    if let Some(t) = last_sent {
                        std::thread::sleep(MIN_INTERVAL.saturating_sub(t.elapsed()));
                    }
                    // A newer image may have come meanwhile.
                    let newer = lock(&shared.slot).pending.take();
                    self.send(&newer.unwrap_or(image), closing);
                } else {
                    self.send(&image, closing);
                }
                last_sent = Some(Instant::now());
            }
            if closing {
                let mut slot = lock(&shared.slot);
                if slot.pending.is_none() {
                    slot.done = true;
                    shared.wake.notify_all();
                    return;
                }
            }
        }
    }

    /// Sends `image`, connecting first if need be (at most one attempt per
    /// second, unless this is the last image).
    fn send(&mut self, image: &Bitmap, last: bool) {
        if self.stream.is_none() && (last || Instant::now() >= self.next_attempt) {
            self.connect();
        }
        let Some(stream) = self.stream.as_mut() else {
            return;
        };
        let result = update_image_packets(&self.name, image)
            .iter()
            .try_for_each(|p| stream.write_all(p));
        if let Err(e) = result {
            self.stream = None;
            self.warn(&format!("lost tev at {}: {e}", self.address));
        }
    }

    fn connect(&mut self) {
        self.next_attempt = Instant::now() + RETRY_EVERY;
        let attempt = || -> std::io::Result<TcpStream> {
            let addrs: Vec<SocketAddr> = self.address.to_socket_addrs()?.collect();
            let mut last = std::io::Error::other("no address");
            for a in addrs {
                match TcpStream::connect_timeout(&a, CONNECT_TIMEOUT) {
                    Ok(mut s) => {
                        s.set_nodelay(true)?;
                        s.set_write_timeout(Some(Duration::from_secs(10)))?;
                        let (w, h) = self.size;
                        s.write_all(&create_image_packet(&self.name, w, h, &["R", "G", "B"]))?;
                        return Ok(s);
                    }
                    Err(e) => last = e,
                }
            }
            Err(last)
        };
        match attempt() {
            Ok(s) => {
                self.stream = Some(s);
                self.warned = false;
            }
            Err(e) => self.warn(&format!(
                "cannot reach tev at {}: {e} (rendering goes on; lente connects when tev \
                 listens)",
                self.address
            )),
        }
    }

    /// One warning until the next successful connection.
    fn warn(&mut self, message: &str) {
        if !self.warned {
            eprintln!("warning: {message}");
            self.warned = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::Rgb;

    #[test]
    fn addresses_default_to_localhost() {
        assert_eq!(parse_address("14158").unwrap(), "127.0.0.1:14158");
        assert_eq!(parse_address(":9").unwrap(), "127.0.0.1:9");
        assert_eq!(parse_address("host:1").unwrap(), "host:1");
        assert_eq!(parse_address("[::1]:2").unwrap(), "[::1]:2");
        assert!(parse_address("host:port").is_err());
        assert!(parse_address("70000").is_err());
    }

    #[test]
    fn packets_follow_tevs_layout() {
        let p = create_image_packet("a", 3, 2, &["R", "G", "B"]);
        assert_eq!(
            u32::from_le_bytes(p[0..4].try_into().unwrap()) as usize,
            p.len()
        );
        assert_eq!(&p[4..8], &[4, 1, b'a', 0]);
        assert_eq!(i32::from_le_bytes(p[8..12].try_into().unwrap()), 3);
        assert_eq!(i32::from_le_bytes(p[12..16].try_into().unwrap()), 2);
        assert_eq!(i32::from_le_bytes(p[16..20].try_into().unwrap()), 3);
        assert_eq!(&p[20..], b"R\0G\0B\0");

        let mut image = Bitmap::new(130, 2);
        image.pixels[129] = Rgb::new(1.0, 2.0, 3.0);
        let packets = update_image_packets("a", &image);
        assert_eq!(packets.len(), 2, "two tiles across");
        let q = &packets[1];
        assert_eq!(
            u32::from_le_bytes(q[0..4].try_into().unwrap()) as usize,
            q.len()
        );
        assert_eq!(&q[4..7], &[6, 0, b'a']);
        let header = 4 + 1 + 1 + 2 + 4 + 6 + 16 + 48;
        let ints: Vec<i32> = (0..4)
            .map(|k| i32::from_le_bytes(q[18 + 4 * k..22 + 4 * k].try_into().unwrap()))
            .collect();
        assert_eq!(ints, [128, 0, 2, 2], "x, y, width, height");
        assert_eq!(q.len(), header + 2 * 2 * 3 * 4);
        let first = f32::from_le_bytes(q[header + 12..header + 16].try_into().unwrap());
        assert_eq!(first, 1.0, "pixel (129, 0) is the tile's second");
    }
}
