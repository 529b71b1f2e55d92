//! `render --tev`: a small fake tev listener takes the packets, parses
//! them as tev does, and rebuilds the image from the updates; the last
//! state must be the written image bit for bit. Without a listener the
//! render goes on and says so once.

use std::io::Read;
use std::net::TcpListener;
use std::time::Duration;

use crate::cli_util::{run_ok, text, write_cbox, LENTE};
use lente::image::load_exr_channels;

/// One packet: its type and payload.
fn read_packet(stream: &mut impl Read) -> Option<(u8, Vec<u8>)> {
    let mut len = [0u8; 4];
    stream.read_exact(&mut len).ok()?;
    let len = u32::from_le_bytes(len) as usize;
    assert!(len >= 5, "packet length {len}");
    let mut body = vec![0u8; len - 4];
    stream.read_exact(&mut body).unwrap();
    Some((body[0], body[1..].to_vec()))
}

/// A cursor over a payload, reading as tev's IpcPacket does.
struct Reader<'a>(&'a [u8]);

impl Reader<'_> {
    fn u8(&mut self) -> u8 {
        let v = self.0[0];
        self.0 = &self.0[1..];
        v
    }
    fn string(&mut self) -> String {
        let end = self.0.iter().position(|&b| b == 0).expect("NUL");
        let s = String::from_utf8(self.0[..end].to_vec()).unwrap();
        self.0 = &self.0[end + 1..];
        s
    }
    fn i32(&mut self) -> i32 {
        let v = i32::from_le_bytes(self.0[..4].try_into().unwrap());
        self.0 = &self.0[4..];
        v
    }
    fn i64(&mut self) -> i64 {
        let v = i64::from_le_bytes(self.0[..8].try_into().unwrap());
        self.0 = &self.0[8..];
        v
    }
    fn f32(&mut self) -> f32 {
        f32::from_bits(self.i32() as u32)
    }
}

#[test]
fn a_fake_tev_receives_the_final_image_exactly() {
    let dir = tempfile::tempdir().unwrap();
    // 200 x 150: tiles of 128 leave partial ones on both axes.
    let scene = write_cbox(&dir, 200, 150, 16);
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let out = dir.path().join("img");
    // The fake tev: takes one connection and collects its packets.
    let viewer = std::thread::spawn(move || {
        let (mut stream, _) = listener.accept().unwrap();
        stream
            .set_read_timeout(Some(Duration::from_secs(60)))
            .unwrap();
        std::iter::from_fn(|| read_packet(&mut stream)).collect::<Vec<_>>()
    });
    let output = std::process::Command::new(LENTE)
        .args(["render", scene.to_str().unwrap(), "-q", "--tev"])
        .arg(port.to_string())
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert!(
        !text(&output.stderr).contains("tev"),
        "{}",
        text(&output.stderr)
    );
    let packets = viewer.join().unwrap();
    let mut packets = packets.into_iter();
    let (kind, payload) = packets.next().expect("a create-image packet");
    assert_eq!(kind, 4, "create image first");
    let mut r = Reader(&payload);
    assert_eq!(r.u8(), 1, "grab focus");
    assert_eq!(r.string(), "img.exr");
    let (w, h) = (r.i32() as usize, r.i32() as usize);
    assert_eq!((w, h), (200, 150));
    assert_eq!(r.i32(), 3);
    assert_eq!([r.string(), r.string(), r.string()], ["R", "G", "B"]);
    assert!(r.0.is_empty());

    let mut image = vec![f32::NAN; 3 * w * h];
    let mut updates = 0;
    for (kind, payload) in packets {
        assert_eq!(kind, 6, "update image (v3)");
        updates += 1;
        let mut r = Reader(&payload);
        r.u8();
        assert_eq!(r.string(), "img.exr");
        let n = r.i32() as usize;
        let names: Vec<String> = (0..n).map(|_| r.string()).collect();
        assert_eq!(names, ["R", "G", "B"]);
        let (x0, y0, tw, th) = (
            r.i32() as usize,
            r.i32() as usize,
            r.i32() as usize,
            r.i32() as usize,
        );
        assert!(x0 + tw <= w && y0 + th <= h && tw <= 128 && th <= 128);
        let offsets: Vec<i64> = (0..n).map(|_| r.i64()).collect();
        let strides: Vec<i64> = (0..n).map(|_| r.i64()).collect();
        let data: Vec<f32> = (0..r.0.len() / 4).map(|_| r.f32()).collect();
        for y in 0..th {
            for x in 0..tw {
                for c in 0..n {
                    let i = (y * tw + x) * strides[c] as usize + offsets[c] as usize;
                    image[((y0 + y) * w + x0 + x) * 3 + c] = data[i];
                }
            }
        }
    }
    assert!(updates >= 4, "{updates} update packets");
    let exr = load_exr_channels(&out.with_extension("exr")).unwrap();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let want = exr.channel(name).unwrap();
        for (i, v) in want.iter().enumerate() {
            assert_eq!(
                image[3 * i + c].to_bits(),
                v.to_bits(),
                "channel {name} pixel {i}"
            );
        }
    }
}

#[test]
fn without_tev_the_render_goes_on_and_says_so_once() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 32, 32, 64);
    // A port nothing listens on: bind, then free it.
    let port = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let out = run_ok(&[
        "render",
        scene.to_str().unwrap(),
        "-q",
        "--tev",
        &format!("127.0.0.1:{port}"),
        "-o",
        dir.path().join("x").to_str().unwrap(),
    ]);
    let stderr = text(&out.stderr);
    assert_eq!(stderr.matches("cannot reach tev").count(), 1, "{stderr}");
    assert!(dir.path().join("x.exr").exists());
    crate::cli_util::run_fails_with(
        &["render", scene.to_str().unwrap(), "--tev", "host:port"],
        "is not [HOST:]PORT",
    );
}
