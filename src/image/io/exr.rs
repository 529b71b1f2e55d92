//! OpenEXR through the `exr` crate.
//!
//! Reading takes the first layer (part) that has `R`, `G` and `B` channels,
//! or else a `Y` channel (read as grey). Channels named with a prefix
//! (`diffuse.R`) count as well, the unprefixed set first. Alpha and any other
//! channels are ignored. Writing produces one 32-bit float RGB layer with
//! ZIP compression.
//!
//! [`encode_channels`] and [`decode_channels`] write and read any named
//! 32-bit channels with text attributes in the header: lente's render
//! files (beauty, film state, AOVs and the render's metadata).

use super::Malformed;
use std::io::Cursor;

use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, ReadChannels,
    ReadLayers, SpecificChannels, Vec2, WritableImage,
};

use super::RawImage;
use crate::image::Bitmap;

type AnyLayer = Layer<AnyChannels<FlatSamples>>;

fn samples_as_f32(samples: &FlatSamples) -> Vec<f32> {
    match samples {
        FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::U32(v) => v.iter().map(|&u| u as f32).collect(),
    }
}

/// The channels to read from one layer: indices of R, G, B, or of Y.
enum Pick {
    Rgb([usize; 3]),
    Y(usize),
}

fn pick_channels(layer: &AnyLayer) -> Option<Pick> {
    let list = &layer.channel_data.list;
    let names: Vec<String> = list.iter().map(|c| c.name.to_string()).collect();
    // Prefixes in order of first appearance, the empty prefix first.
    let mut prefixes: Vec<&str> = vec![""];
    for name in &names {
        if let Some(dot) = name.rfind('.') {
            let prefix = &name[..=dot];
            if !prefixes.contains(&prefix) {
                prefixes.push(prefix);
            }
        }
    }
    let find = |prefix: &str, suffix: &str| {
        names.iter().position(|n| {
            n.strip_prefix(prefix)
                .is_some_and(|rest| rest.eq_ignore_ascii_case(suffix))
        })
    };
    for prefix in prefixes {
        if let (Some(r), Some(g), Some(b)) =
            (find(prefix, "R"), find(prefix, "G"), find(prefix, "B"))
        {
            return Some(Pick::Rgb([r, g, b]));
        }
        if let Some(y) = find(prefix, "Y") {
            return Some(Pick::Y(y));
        }
    }
    None
}

fn channel_values(layer: &AnyLayer, index: usize, pixels: usize) -> Result<Vec<f32>, Malformed> {
    let channel: &AnyChannel<FlatSamples> = &layer.channel_data.list[index];
    let values = samples_as_f32(&channel.sample_data);
    if values.len() != pixels {
        return Err(Malformed::from(format!(
            "OpenEXR channel '{}' is subsampled ({}x{}), which is not supported",
            channel.name, channel.sampling.0, channel.sampling.1
        )));
    }
    Ok(values)
}

/// Checks every layer's header before the crate allocates its pixels: a
/// data window that is empty or larger than the image bound, or channels
/// that together need more than 16 bytes per pixel of the bound (RGBA in
/// f32), is an error. The crate allocates all layers' samples at once, so
/// their sum is bounded. So is each block: the crate reads a block into a
/// buffer as large as the block's declared byte count, up to the size of
/// a whole uncompressed block, before it finds the file too short (a
/// 600-byte file with huge tiles made it take 1.9 GB). A tile may not need
/// more bytes than its layer's samples or 16 MiB, whichever is more; a
/// block of scan lines is at most 32 of the layer's rows, so at most 32
/// times its samples.
fn check_headers(bytes: &[u8]) -> Result<(), Malformed> {
    let meta = guarded("header", || {
        exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false)
    })?;
    let budget = crate::limits::max_image_pixels().saturating_mul(16);
    let mut total: u64 = 0;
    for header in &meta.headers {
        let size = header.layer_size;
        super::check_size(size.width(), size.height())?;
        let pixels = size.width() as u64 * size.height() as u64;
        let bytes_per_pixel: u64 = header
            .channels
            .list
            .iter()
            .map(|c| c.sample_type.bytes_per_sample() as u64)
            .sum();
        let layer_bytes = pixels.saturating_mul(bytes_per_pixel);
        if let exr::meta::BlockDescription::Tiles(tiles) = header.blocks {
            // The crate's own product (`max_block_byte_size`), saturating
            // rather than wrapping for tile sizes near the field's limit.
            let tile = tiles.tile_size;
            let tile_bytes = (tile.width() as u64)
                .saturating_mul(tile.height() as u64)
                .saturating_mul(bytes_per_pixel);
            if tile_bytes > layer_bytes.max(MAX_TILE_BYTES_BEYOND_LAYER) {
                return Err(Malformed::from(format!(
                    "OpenEXR tiles of {}x{} pixels need {tile_bytes} bytes, more than \
                     the {}x{} layer they tile",
                    tile.width(),
                    tile.height(),
                    size.width(),
                    size.height()
                )));
            }
        }
        total = total.saturating_add(layer_bytes);
        if total > budget {
            return Err(Malformed::from(format!(
                "OpenEXR layers and channels need more than {budget} bytes of samples \
                 (the last: {}x{} with {} channels)",
                size.width(),
                size.height(),
                header.channels.list.len()
            )));
        }
    }
    Ok(())
}

/// A tile may need this many bytes even when its layer needs fewer (tiles
/// of up to 1024 x 1024 RGBA f32 on a small image).
const MAX_TILE_BYTES_BEYOND_LAYER: u64 = 1 << 24;

/// Runs one call into the exr crate: its errors, and any panic of its on
/// hostile input (caught so it cannot take lente down), become messages.
fn guarded<T>(part: &str, f: impl FnOnce() -> exr::error::Result<T>) -> Result<T, Malformed> {
    super::catching_panics(
        || f().map_err(|e| Malformed::from(format!("cannot decode OpenEXR: {e}"))),
        || format!("cannot decode OpenEXR: the decoder failed on this file's {part}"),
    )
}

/// Every layer's channels and attributes, the headers checked first.
/// Decoded on the calling thread: the crate's parallel decoder runs blocks
/// on a rayon pool without a panic handler, where a panic of its on a
/// hostile block aborts the process before [`guarded`] can catch it.
fn read_layers(
    bytes: &[u8],
) -> Result<Image<exr::image::Layers<AnyChannels<FlatSamples>>>, Malformed> {
    check_headers(bytes)?;
    guarded("pixels", || {
        exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .non_parallel()
            .from_buffered(Cursor::new(bytes))
    })
}

pub(super) fn decode(bytes: &[u8]) -> Result<RawImage, Malformed> {
    let image = read_layers(bytes)?;
    for layer in &image.layer_data {
        let Some(pick) = pick_channels(layer) else {
            continue;
        };
        let (width, height) = (layer.size.width(), layer.size.height());
        let pixels = width * height;
        return Ok(match pick {
            Pick::Rgb(idx) => {
                let [r, g, b] = idx.map(|i| channel_values(layer, i, pixels));
                let (r, g, b) = (r?, g?, b?);
                let mut data = Vec::with_capacity(pixels * 3);
                for i in 0..pixels {
                    data.extend_from_slice(&[r[i], g[i], b[i]]);
                }
                RawImage {
                    width,
                    height,
                    channels: 3,
                    data,
                }
            }
            Pick::Y(i) => RawImage {
                width,
                height,
                channels: 1,
                data: channel_values(layer, i, pixels)?,
            },
        });
    }
    let found: Vec<String> = image
        .layer_data
        .iter()
        .flat_map(|l| l.channel_data.list.iter().map(|c| c.name.to_string()))
        .collect();
    Err(Malformed::from(format!(
        "no OpenEXR layer has R, G, B or Y channels (found: {})",
        if found.is_empty() {
            "none".to_string()
        } else {
            found.join(", ")
        }
    )))
}

/// One layer of 32-bit float R, G, B; ZIP compression, increasing
/// scanlines; written to `out` as it is encoded.
pub(super) fn encode(
    image: &Bitmap,
    out: impl std::io::Write + std::io::Seek,
) -> Result<(), Malformed> {
    let w = image.width;
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let p = image.pixels[pos.y() * w + pos.x()];
        (p.x, p.y, p.z)
    });
    let layer = Layer::new(
        (image.width, image.height),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    write_layer(&Image::from_layer(layer), out)
}

/// Writes an image of one layer to `out` as it is encoded.
fn write_layer<'c, C>(
    image: &'c Image<Layer<C>>,
    out: impl std::io::Write + std::io::Seek,
) -> Result<(), Malformed>
where
    C: exr::image::write::channels::WritableChannels<'c>,
{
    image
        .write()
        .to_buffered(out)
        .map_err(|e| Malformed::from(format!("cannot encode OpenEXR: {e}")))
}

/// One image of named float channels and text header attributes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Channels {
    pub width: usize,
    pub height: usize,
    /// (name, one value per pixel in row-major order).
    pub channels: Vec<(String, Vec<f32>)>,
    /// (name, UTF-8 text), in the order written.
    pub attributes: Vec<(String, String)>,
}

impl Channels {
    /// The values of channel `name`, if present.
    pub fn channel(&self, name: &str) -> Option<&[f32]> {
        self.channels
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    /// The text of attribute `name`, if present.
    pub fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}

/// Text as the header stores it: the UTF-8 bytes as they are (the crate's
/// checked constructor takes Latin-1 only).
fn text(s: &str) -> exr::meta::attribute::Text {
    exr::meta::attribute::Text::from_slice_unchecked(s.as_bytes())
}

/// A channel to write: its name and its value at each pixel (row-major
/// index), computed while the file is written, so saving a render makes
/// no copy of its film or image (a copy per channel was 28 bytes per pixel
/// at the peak of a render's memory).
pub struct OutChannel<'a> {
    pub name: String,
    pub value: Box<dyn Fn(usize) -> f32 + Sync + 'a>,
}

impl<'a> OutChannel<'a> {
    pub fn new(name: impl Into<String>, value: impl Fn(usize) -> f32 + Sync + 'a) -> Self {
        OutChannel {
            name: name.into(),
            value: Box::new(value),
        }
    }
}

/// An image of named float channels given per pixel, and text attributes:
/// what `encode_channels` writes.
pub struct OutChannels<'a> {
    pub width: usize,
    pub height: usize,
    pub channels: Vec<OutChannel<'a>>,
    /// (name, UTF-8 text).
    pub attributes: Vec<(String, String)>,
}

/// [`OutChannels`] in the file's channel order (sorted by name).
struct SortedChannels<'c, 'a> {
    image: &'c OutChannels<'a>,
    order: Vec<usize>,
}

impl<'s> exr::image::write::channels::WritableChannels<'s> for SortedChannels<'_, '_> {
    fn infer_channel_list(&self) -> exr::meta::attribute::ChannelList {
        exr::meta::attribute::ChannelList::new(
            self.order
                .iter()
                .map(|&i| {
                    exr::meta::attribute::ChannelDescription::named(
                        text(&self.image.channels[i].name),
                        exr::meta::attribute::SampleType::F32,
                    )
                })
                .collect(),
        )
    }

    fn infer_level_modes(&self) -> (exr::meta::attribute::LevelMode, exr::math::RoundingMode) {
        (
            exr::meta::attribute::LevelMode::Singular,
            exr::math::RoundingMode::Down,
        )
    }

    type Writer = SortedChannelsWriter<'s>;

    fn create_writer(&'s self, _header: &exr::meta::header::Header) -> Self::Writer {
        SortedChannelsWriter {
            values: self
                .order
                .iter()
                .map(|&i| &*self.image.channels[i].value)
                .collect(),
            width: self.image.width,
        }
    }
}

struct SortedChannelsWriter<'s> {
    values: Vec<&'s (dyn Fn(usize) -> f32 + Sync)>,
    width: usize,
}

impl exr::image::write::channels::ChannelsWriter for SortedChannelsWriter<'_> {
    fn extract_uncompressed_block(
        &self,
        header: &exr::meta::header::Header,
        block: exr::block::BlockIndex,
    ) -> Vec<u8> {
        exr::block::UncompressedBlock::collect_block_data_from_lines(
            &header.channels,
            block,
            |line| {
                let value = self.values[line.location.channel];
                let start = line.location.position.y() * self.width + line.location.position.x();
                line.write_samples(|i| value(start + i))
                    .expect("a line's bytes hold its samples");
            },
        )
    }
}

/// Writes one layer of the given 32-bit float channels, the attributes as
/// text, ZIP compression, to `out` as it is encoded (no copy of the file
/// in memory).
pub fn encode_channels(
    image: &OutChannels,
    out: impl std::io::Write + std::io::Seek,
) -> Result<(), Malformed> {
    if image.channels.is_empty() || image.width == 0 || image.height == 0 {
        return Err(Malformed::from(
            "an OpenEXR file needs a channel and a pixel",
        ));
    }
    let mut order: Vec<usize> = (0..image.channels.len()).collect();
    order.sort_by(|&a, &b| image.channels[a].name.cmp(&image.channels[b].name));
    if let Some(w) = order
        .windows(2)
        .find(|w| image.channels[w[0]].name == image.channels[w[1]].name)
    {
        return Err(Malformed::from(format!(
            "channel '{}' is given twice",
            image.channels[w[0]].name
        )));
    }
    let mut attributes = LayerAttributes::default();
    for (name, value) in &image.attributes {
        attributes.other.insert(
            text(name),
            exr::meta::attribute::AttributeValue::Text(text(value)),
        );
    }
    let layer = Layer::new(
        (image.width, image.height),
        attributes,
        Encoding::SMALL_LOSSLESS,
        SortedChannels { image, order },
    );
    write_layer(&Image::from_layer(layer), out)
}

/// The first layer's channels (as 32-bit floats) and the text attributes
/// of its header (other kinds of attributes are skipped).
pub fn decode_channels(bytes: &[u8]) -> Result<Channels, Malformed> {
    let image = read_layers(bytes)?;
    let layer = image
        .layer_data
        .first()
        .ok_or_else(|| Malformed::from("OpenEXR file has no layer"))?;
    let (width, height) = (layer.size.width(), layer.size.height());
    let mut channels = Vec::new();
    for (i, c) in layer.channel_data.list.iter().enumerate() {
        channels.push((
            c.name.to_string(),
            channel_values(layer, i, width * height)?,
        ));
    }
    let mut attributes: Vec<(String, String)> = layer
        .attributes
        .other
        .iter()
        .chain(image.attributes.other.iter())
        .filter_map(|(name, value)| match value {
            exr::meta::attribute::AttributeValue::Text(t) => Some((
                String::from_utf8_lossy(name.bytes()).into_owned(),
                String::from_utf8_lossy(t.bytes()).into_owned(),
            )),
            _ => None,
        })
        .collect();
    attributes.sort();
    Ok(Channels {
        width,
        height,
        channels,
        attributes,
    })
}

#[cfg(test)]
mod tests {
    use exr::prelude::{
        f16, AnyChannel, AnyChannels, Compression, Encoding, FlatSamples, Image, ImageAttributes,
        IntegerBounds, Layer, LayerAttributes, SmallVec, WritableImage,
    };

    use super::super::test_util::test_image;
    use super::super::{load_image, save_image};
    use crate::color::Rgb;
    use crate::image::Bitmap;

    fn encoding(compression: Compression) -> Encoding {
        Encoding {
            compression,
            ..Encoding::SMALL_LOSSLESS
        }
    }

    fn channel(name: &str, values: Vec<f32>, half: bool) -> AnyChannel<FlatSamples> {
        let samples = if half {
            FlatSamples::F16(values.into_iter().map(f16::from_f32).collect())
        } else {
            FlatSamples::F32(values)
        };
        AnyChannel::new(name, samples)
    }

    fn layer(
        img: &Bitmap,
        names: &[&str],
        half: bool,
        compression: Compression,
    ) -> Layer<AnyChannels<FlatSamples>> {
        let list: Vec<AnyChannel<FlatSamples>> = names
            .iter()
            .map(|name| {
                let last = name.rsplit('.').next().unwrap();
                let values = img
                    .pixels
                    .iter()
                    .map(|p| match last {
                        "R" => p.x,
                        "G" => p.y,
                        "B" => p.z,
                        "Y" => crate::color::luminance(*p),
                        "A" => 0.25,
                        _ => 7.0,
                    })
                    .collect();
                channel(name, values, half)
            })
            .collect();
        Layer::new(
            (img.width, img.height),
            match names[0].rsplit_once('.') {
                Some((prefix, _)) => LayerAttributes::named(prefix),
                None => LayerAttributes::default(),
            },
            encoding(compression),
            AnyChannels::sort(SmallVec::from_vec(list)),
        )
    }

    fn write(path: &std::path::Path, layers: Vec<Layer<AnyChannels<FlatSamples>>>) {
        let size = layers[0].size;
        let image = Image::new(
            ImageAttributes::new(IntegerBounds::from_dimensions(size)),
            SmallVec::from_vec(layers),
        );
        image.write().to_file(path).unwrap();
    }

    fn assert_close(a: &Bitmap, b: &Bitmap, rel: f32, what: &str) {
        assert_eq!((a.width, a.height), (b.width, b.height), "{what}");
        for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
            let tol = rel * p.abs().max(q.abs()) + 1e-6;
            assert!(
                (*p - *q).abs().cmple(tol).all(),
                "{what}: pixel {i}: {p} vs {q}"
            );
        }
    }

    #[test]
    fn exr_round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = test_image(13, 7);
        img.set(12, 6, Rgb::new(1e-30, 3.0e30, 0.1));
        let path = dir.path().join("rt.exr");
        save_image(&path, &img).unwrap();
        let (back, warnings) = load_image(&path).unwrap();
        assert!(warnings.is_empty());
        assert_eq!(back, img);
    }

    #[test]
    fn channels_given_per_pixel_round_trip_exactly() {
        // Names out of order, a size that is not a whole number of ZIP
        // blocks (16 lines), values that are not all finite: every channel
        // reads back bit for bit under its own name.
        let (w, h) = (37usize, 45usize);
        let value = |c: usize, i: usize| match (c + i) % 11 {
            0 => f32::INFINITY,
            1 => -0.0,
            k => (i as f32 * 0.37 + c as f32).sin() * 10f32.powi(k as i32 - 5),
        };
        let names = ["zeta", "R", "lente.film.B", "B", "alpha.1"];
        let image = super::OutChannels {
            width: w,
            height: h,
            channels: names
                .iter()
                .enumerate()
                .map(|(c, n)| super::OutChannel::new(*n, move |i| value(c, i)))
                .collect(),
            attributes: vec![("lente.note".into(), "é 1".into())],
        };
        let mut bytes = std::io::Cursor::new(Vec::new());
        super::encode_channels(&image, &mut bytes).unwrap();
        let back = super::decode_channels(bytes.get_ref()).unwrap();
        assert_eq!((back.width, back.height), (w, h));
        assert_eq!(back.attribute("lente.note"), Some("é 1"));
        for (c, n) in names.iter().enumerate() {
            let got = back.channel(n).unwrap();
            for (i, g) in got.iter().enumerate() {
                assert_eq!(g.to_bits(), value(c, i).to_bits(), "{n} pixel {i}");
            }
        }
        let twice = super::OutChannels {
            width: w,
            height: h,
            channels: vec![
                super::OutChannel::new("R", |_| 0.0),
                super::OutChannel::new("R", |_| 1.0),
            ],
            attributes: vec![],
        };
        let err = super::encode_channels(&twice, std::io::Cursor::new(Vec::new())).unwrap_err();
        assert!(err.0.contains("'R' is given twice"), "{}", err.0);
    }

    #[test]
    fn exr_reads_half_float_rgba_and_compressions() {
        let dir = tempfile::tempdir().unwrap();
        let img = test_image(41, 19);
        let path = dir.path().join("k.exr");
        let cases = [
            (&["R", "G", "B"][..], true, Compression::ZIP16, 1e-3),
            (&["R", "G", "B"][..], false, Compression::ZIP1, 0.0),
            (&["R", "G", "B"][..], false, Compression::PIZ, 0.0),
            (&["R", "G", "B"][..], true, Compression::PIZ, 1e-3),
            (&["R", "G", "B"][..], true, Compression::RLE, 1e-3),
            (&["R", "G", "B"][..], false, Compression::Uncompressed, 0.0),
            (&["R", "G", "B", "A"][..], true, Compression::ZIP16, 1e-3),
            (&["R", "G", "B", "A"][..], false, Compression::ZIP16, 0.0),
            (&["A", "B", "G", "R", "Z"][..], false, Compression::PIZ, 0.0),
            (&["R", "G", "B"][..], true, Compression::DWAB(None), 0.05),
            (&["R", "G", "B"][..], true, Compression::PXR24, 1e-3),
            // Lossy: 6 bits per difference within a 4 x 4 block (7% off
            // on a small value beside larger ones here).
            (&["R", "G", "B"][..], true, Compression::B44, 0.15),
            (&["R", "G", "B"][..], true, Compression::B44A, 0.15),
        ];
        for (names, half, compression, rel) in cases {
            write(&path, vec![layer(&img, names, half, compression)]);
            let what = format!("{names:?} half={half} {compression:?}");
            let (back, _) = load_image(&path).unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_close(&img, &back, rel, &what);
        }
    }

    #[test]
    fn exr_reads_tiles_larger_than_the_image() {
        // 64 x 64 and 1024 x 1024 tiles of RGBA f32 on a 10 x 7 image: the
        // tile bound (16 MiB per tile beyond the layer's size) lets both
        // through; 1025 x 1024 is refused.
        let dir = tempfile::tempdir().unwrap();
        let img = test_image(10, 7);
        let path = dir.path().join("t.exr");
        for (tile, ok) in [(64, true), (1024, true), (1025, false)] {
            let mut layer = layer(&img, &["R", "G", "B", "A"], false, Compression::ZIP1);
            layer.encoding.blocks = exr::prelude::Blocks::Tiles(exr::prelude::Vec2(tile, 1024));
            write(&path, vec![layer]);
            match load_image(&path) {
                Ok((back, _)) => {
                    assert!(ok, "{tile}: read");
                    assert_close(&img, &back, 0.0, "tiled");
                }
                Err(e) => {
                    assert!(!ok, "{tile}: {e}");
                    assert!(e.to_string().contains("tiles of 1025x1024"), "{e}");
                }
            }
        }
    }

    #[test]
    fn exr_reads_luminance_only_as_grey() {
        let dir = tempfile::tempdir().unwrap();
        let img = test_image(10, 6);
        let path = dir.path().join("y.exr");
        for half in [true, false] {
            write(&path, vec![layer(&img, &["Y"], half, Compression::ZIP16)]);
            let (back, _) = load_image(&path).unwrap();
            let grey = Bitmap {
                width: img.width,
                height: img.height,
                pixels: img
                    .pixels
                    .iter()
                    .map(|p| Rgb::splat(crate::color::luminance(*p)))
                    .collect(),
            };
            assert_close(&grey, &back, if half { 1e-3 } else { 0.0 }, "Y");
        }
    }

    #[test]
    fn exr_uses_first_layer_with_colour() {
        let dir = tempfile::tempdir().unwrap();
        let img = test_image(8, 5);
        let path = dir.path().join("l.exr");
        // Layer 1 has only depth; layer 2 has prefixed colour channels.
        write(
            &path,
            vec![
                layer(&img, &["depth.Z"], false, Compression::ZIP16),
                layer(
                    &img,
                    &["diffuse.R", "diffuse.G", "diffuse.B"],
                    false,
                    Compression::ZIP16,
                ),
            ],
        );
        let (back, _) = load_image(&path).unwrap();
        assert_eq!(back, img);
        // No colour anywhere: an error that lists what was found.
        write(&path, vec![layer(&img, &["Z"], false, Compression::ZIP16)]);
        let err = load_image(&path).unwrap_err().to_string();
        assert!(err.contains("l.exr") && err.contains("found: Z"), "{err}");
    }

    #[test]
    fn exr_half_negative_values_warn_once() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = test_image(6, 4);
        for x in 0..6 {
            img.set(x, 1, Rgb::new(-0.5, 0.25, -2.0));
        }
        let path = dir.path().join("n.exr");
        write(
            &path,
            vec![layer(&img, &["R", "G", "B"], true, Compression::PIZ)],
        );
        let (back, warnings) = load_image(&path).unwrap();
        assert_eq!(warnings, ["clamped 12 negative texel values to zero"]);
        assert_eq!(back.get(3, 1), Rgb::new(0.0, 0.25, 0.0));
    }
}
