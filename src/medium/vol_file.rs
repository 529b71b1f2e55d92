//! Mitsuba's `.vol` voxel grids (`render/volumegrid.cpp`, the format of
//! Mitsuba 0.6 kept by Mitsuba 3): the bytes 'VOL', version 3, encoding 1
//! (float32), the resolution in x, y and z, the channel count, the data's
//! bounding box (6 floats: min then max), then the values, little-endian,
//! x fastest: `data[((z * yres + y) * xres + x) * channels + c]`.
//!
//! The header's sizes are checked against the bytes present before
//! anything is allocated, so a file can ask for no more memory than its
//! own size; every value must be finite.

use std::path::{Path, PathBuf};

use crate::math::{Aabb, Vec3};

/// The bytes before the values.
const HEADER_BYTES: usize = 48;

/// A voxel grid as the file stores it.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeGrid {
    /// Voxels along x, y and z (each at least 1).
    pub res: [usize; 3],
    /// Values per voxel: 1, 3 or 6 as Mitsuba writes them.
    pub channels: usize,
    /// The box the file says its data spans (read by `use_grid_bbox`).
    pub bbox: Aabb,
    /// `res[0] * res[1] * res[2] * channels` values, x fastest.
    pub data: Vec<f32>,
}

impl VolumeGrid {
    /// The largest value over all voxels and channels (0 for none above).
    pub fn max(&self) -> f32 {
        self.data.iter().fold(0.0f32, |m, &v| m.max(v))
    }

    /// The smallest value over all voxels and channels.
    pub fn min(&self) -> f32 {
        self.data.iter().fold(f32::INFINITY, |m, &v| m.min(v))
    }
}

/// Why a `.vol` file was not read.
#[derive(Debug, thiserror::Error)]
pub enum VolError {
    #[error("cannot read '{path}'")]
    Read {
        path: PathBuf,
        source: crate::limits::ReadError,
    },
    #[error("'{path}' is not a Mitsuba volume grid: {message}")]
    Malformed { path: PathBuf, message: String },
}

/// Reads and parses a `.vol` file.
pub fn load_vol(path: &Path) -> Result<VolumeGrid, VolError> {
    let bytes = crate::limits::read_file(path, crate::limits::MAX_DATA_FILE_BYTES, "volume files")
        .map_err(|source| VolError::Read {
            path: path.to_path_buf(),
            source,
        })?;
    parse_vol(&bytes).map_err(|message| VolError::Malformed {
        path: path.to_path_buf(),
        message,
    })
}

/// Parses a `.vol` file's bytes; the error says what is wrong.
pub fn parse_vol(bytes: &[u8]) -> Result<VolumeGrid, String> {
    if bytes.len() < HEADER_BYTES {
        return Err(format!(
            "it is {} bytes, shorter than the {HEADER_BYTES}-byte header",
            bytes.len()
        ));
    }
    if &bytes[..3] != b"VOL" {
        return Err("it does not start with 'VOL'".into());
    }
    if bytes[3] != 3 {
        return Err(format!(
            "format version {}; Mitsuba and lente read version 3",
            bytes[3]
        ));
    }
    let int = |at: usize| i32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    let float = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    let encoding = int(4);
    if encoding != 1 {
        return Err(format!(
            "data encoding {encoding}; only encoding 1 (float32) is read"
        ));
    }
    let (xres, yres, zres, channels) = (int(8), int(12), int(16), int(20));
    if xres < 1 || yres < 1 || zres < 1 {
        return Err(format!(
            "resolution {xres} x {yres} x {zres} has an empty axis"
        ));
    }
    if !matches!(channels, 1 | 3 | 6) {
        return Err(format!("{channels} channels; a grid has 1, 3 or 6"));
    }
    let values = (xres as u64)
        .checked_mul(yres as u64)
        .and_then(|n| n.checked_mul(zres as u64))
        .and_then(|n| n.checked_mul(channels as u64));
    let available = ((bytes.len() - HEADER_BYTES) / 4) as u64;
    let Some(values) = values.filter(|&n| n <= available) else {
        return Err(format!(
            "its header gives {xres} x {yres} x {zres} voxels of {channels} channels, but the \
             file holds {available} values"
        ));
    };
    let b: Vec<f32> = (0..6).map(|i| float(24 + 4 * i)).collect();
    let bbox = Aabb {
        min: Vec3::new(b[0], b[1], b[2]),
        max: Vec3::new(b[3], b[4], b[5]),
    };
    let mut data = Vec::with_capacity(values as usize);
    for (i, chunk) in bytes[HEADER_BYTES..]
        .chunks_exact(4)
        .take(values as usize)
        .enumerate()
    {
        let v = f32::from_le_bytes(chunk.try_into().unwrap());
        if !v.is_finite() {
            let voxel = i / channels as usize;
            let (x, y, z) = (
                voxel % xres as usize,
                voxel / xres as usize % yres as usize,
                voxel / (xres as usize * yres as usize),
            );
            return Err(format!(
                "voxel ({x}, {y}, {z}) channel {} is {v}",
                i % channels as usize
            ));
        }
        data.push(v);
    }
    Ok(VolumeGrid {
        res: [xres as usize, yres as usize, zres as usize],
        channels: channels as usize,
        bbox,
        data,
    })
}

/// The bytes of a `.vol` file holding `grid` (tests and tools write
/// grids with it).
pub fn encode_vol(grid: &VolumeGrid) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_BYTES + 4 * grid.data.len());
    out.extend_from_slice(b"VOL\x03");
    let ints = [
        1,
        grid.res[0] as i32,
        grid.res[1] as i32,
        grid.res[2] as i32,
        grid.channels as i32,
    ];
    for i in ints {
        out.extend_from_slice(&i.to_le_bytes());
    }
    for f in grid
        .bbox
        .min
        .to_array()
        .into_iter()
        .chain(grid.bbox.max.to_array())
    {
        out.extend_from_slice(&f.to_le_bytes());
    }
    for v in &grid.data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> VolumeGrid {
        VolumeGrid {
            res: [2, 3, 1],
            channels: 1,
            bbox: Aabb {
                min: Vec3::new(-1.0, 0.0, 2.0),
                max: Vec3::new(1.0, 3.0, 4.0),
            },
            data: vec![0.0, 1.0, 2.0, 3.0, 4.5, 5.0],
        }
    }

    #[test]
    fn round_trips_and_reports_max() {
        let g = grid();
        let parsed = parse_vol(&encode_vol(&g)).unwrap();
        assert_eq!(parsed, g);
        assert_eq!(parsed.max(), 5.0);
        assert_eq!(parsed.min(), 0.0);
    }

    /// Every way a header can lie is one message, never a panic or a
    /// large allocation.
    #[test]
    fn malformed_files_are_refused() {
        let good = encode_vol(&grid());
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (good[..40].to_vec(), "shorter than"),
            ([b"VOX".as_slice(), &good[3..]].concat(), "'VOL'"),
            ([b"VOL\x02".as_slice(), &good[4..]].concat(), "version 2"),
            (
                {
                    let mut b = good.clone();
                    b[4] = 2;
                    b
                },
                "encoding 2",
            ),
            (
                {
                    let mut b = good.clone();
                    b[8..12].copy_from_slice(&i32::MAX.to_le_bytes());
                    b
                },
                "holds 6 values",
            ),
            (
                {
                    let mut b = good.clone();
                    b[12..16].copy_from_slice(&0i32.to_le_bytes());
                    b
                },
                "empty axis",
            ),
            (
                {
                    let mut b = good.clone();
                    b[20..24].copy_from_slice(&2i32.to_le_bytes());
                    b
                },
                "2 channels",
            ),
            (
                {
                    let mut b = good.clone();
                    let at = HEADER_BYTES + 4 * 3;
                    b[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
                    b
                },
                "voxel (1, 1, 0) channel 0 is NaN",
            ),
        ];
        for (bytes, want) in cases {
            let e = parse_vol(&bytes).unwrap_err();
            assert!(e.contains(want), "{e:?} should say {want:?}");
        }
    }
}
