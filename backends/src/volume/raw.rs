//! Raw volumes: `nx·ny·nz` little-endian values (`u8`, `u16` or `f32`),
//! `x` fastest, no header. The file's size is checked against the dims
//! before anything is allocated, and every value must be finite.

use std::io::Read;
use std::path::Path;

use super::grid::checked_voxels;
use super::{Volume, VolumeError};

/// The type of a raw volume's values (little-endian).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RawType {
    /// Unsigned bytes.
    U8,
    /// Unsigned 16-bit integers.
    U16,
    /// 32-bit floats.
    F32,
}

impl RawType {
    /// Bytes per value.
    #[must_use]
    pub fn bytes(self) -> usize {
        match self {
            Self::U8 => 1,
            Self::U16 => 2,
            Self::F32 => 4,
        }
    }

    /// Parses `u8`, `u16` or `f32`.
    ///
    /// # Errors
    /// Any other name.
    pub fn parse(s: &str) -> Result<Self, VolumeError> {
        match s {
            "u8" => Ok(Self::U8),
            "u16" => Ok(Self::U16),
            "f32" => Ok(Self::F32),
            _ => Err(VolumeError::new(format!("value type {s:?}: must be u8, u16 or f32"))),
        }
    }
}

/// Reads a raw volume of `dims` values of type `ty`.
///
/// # Errors
/// A missing or unreadable file, a size that does not match the dims
/// (truncated or too long), too many voxels, a non-finite value.
pub fn read_raw(path: &Path, dims: [usize; 3], ty: RawType, spacing: [f64; 3]) -> Result<Volume, VolumeError> {
    let q = |e: String| VolumeError::new(format!("{path:?}: {e}"));
    let n = checked_voxels(dims).map_err(|e| q(e.0))?;
    crate::files::check_regular(path).map_err(|e| q(e.to_string()))?;
    let meta = std::fs::metadata(path).map_err(|e| q(e.to_string()))?;
    let want = (n as u64) * ty.bytes() as u64;
    if meta.len() != want {
        return Err(q(format!(
            "{} bytes, but {}x{}x{} {:?} values need {want}{}",
            meta.len(),
            dims[0],
            dims[1],
            dims[2],
            ty,
            if meta.len() < want { " (truncated?)" } else { "" }
        )));
    }
    let mut bytes = Vec::with_capacity(want as usize);
    std::fs::File::open(path).and_then(|f| f.take(want).read_to_end(&mut bytes)).map_err(|e| q(e.to_string()))?;
    if bytes.len() as u64 != want {
        return Err(q(format!("read {} bytes, expected {want} (changed while reading?)", bytes.len())));
    }
    let data = decode(&bytes, ty);
    let name = path.file_name().map_or_else(|| "volume".to_string(), |s| s.to_string_lossy().into_owned());
    Volume::new(name, dims, spacing, data).map_err(|e| q(e.0))
}

/// Little-endian values of type `ty` as `f32` (a trailing partial value is ignored).
#[must_use]
pub fn decode(bytes: &[u8], ty: RawType) -> Vec<f32> {
    match ty {
        RawType::U8 => bytes.iter().map(|&b| f32::from(b)).collect(),
        RawType::U16 => bytes.chunks_exact(2).map(|c| f32::from(u16::from_le_bytes([c[0], c[1]]))).collect(),
        RawType::F32 => bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_and_refuses() {
        let dir = std::env::temp_dir().join(format!("itgfx-raw-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("v.raw");
        let vals: Vec<u16> = (0..24).collect();
        std::fs::write(&p, vals.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
        let v = read_raw(&p, [2, 3, 4], RawType::U16, [1.0; 3]).unwrap();
        assert_eq!(v.data[23], 23.0);
        let e = read_raw(&p, [2, 3, 5], RawType::U16, [1.0; 3]).unwrap_err();
        assert!(e.0.contains("truncated"), "{e}");
        assert!(read_raw(&p, [2, 3, 3], RawType::U16, [1.0; 3]).is_err());
        let f = dir.join("nan.raw");
        std::fs::write(&f, [f32::NAN.to_le_bytes(), 1.0f32.to_le_bytes()].concat()).unwrap();
        assert!(read_raw(&f, [2, 1, 1], RawType::F32, [1.0; 3]).unwrap_err().0.contains("not finite"));
        assert!(read_raw(&dir.join("none.raw"), [1, 1, 1], RawType::U8, [1.0; 3]).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
