//! Bakes the procedural sky to a PFM file so it can be looked at:
//!
//! ```text
//! cargo run --release --example bake_sky -- sky.pfm [turbidity] [elevation_deg] [azimuth_deg] [width]
//! ```
//!
//! (A tiny PFM writer is inlined here; the real image I/O lives in
//! `lente::image`.)

use lente::emitter::sky::{bake_sky, SkyParams};
use std::io::Write;

fn main() -> std::io::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args.first().map_or("sky.pfm", |s| s.as_str());
    let num = |i: usize, default: f32| -> f32 {
        args.get(i)
            .map(|s| s.parse().unwrap_or_else(|_| panic!("not a number: {s}")))
            .unwrap_or(default)
    };
    let params = SkyParams {
        turbidity: num(1, 3.0),
        sun_elevation_deg: num(2, 45.0),
        sun_azimuth_deg: num(3, 0.0),
        resolution: num(4, 1024.0) as usize,
        ..SkyParams::default()
    };
    let bmp = bake_sky(&params);
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    // PFM: header, then little-endian f32 RGB rows from the bottom up.
    write!(out, "PF\n{} {}\n-1.0\n", bmp.width, bmp.height)?;
    for y in (0..bmp.height).rev() {
        for x in 0..bmp.width {
            for c in bmp.get(x, y).to_array() {
                out.write_all(&c.to_le_bytes())?;
            }
        }
    }
    out.flush()?;
    eprintln!("wrote {path} ({}x{}, {params:?})", bmp.width, bmp.height);
    Ok(())
}
