//! A strict reader of the NRRD subset volume tools write for one scalar
//! volume in one file: magic `NRRD0001`..`NRRD0005`, then `field: value`
//! lines (`#` comments), a blank line, and the raw data.
//!
//! Required: `dimension: 3`, `sizes: X Y Z`, `type:` one of
//! `uchar`/`unsigned char`/`uint8`/`uint8_t`, `ushort`/`unsigned short`/
//! `uint16`/`uint16_t`, `float`; `encoding: raw`; `endian: little` when values
//! take more than one byte. Optional: `spacings: a b c`, or instead
//! `space directions: (x,y,z) (x,y,z) (x,y,z)` with each axis along one
//! coordinate axis (each voxel edge's length is the norm of its direction;
//! a rotated or sheared grid is refused). Anything else that
//! changes the meaning of the data (`data file`, `byte skip`, `line skip`,
//! other encodings or types, `kinds` other than `domain`/`space`) is refused,
//! never guessed. The header is read (at most 64 KiB) and the data size
//! checked against the file's length before the data are allocated.

use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use super::grid::checked_voxels;
use super::raw::RawType;
use super::{Volume, VolumeError};

/// Longest header accepted.
const MAX_HEADER: u64 = 64 << 10;

/// Reads an NRRD volume.
///
/// # Errors
/// One line naming the file and the field at fault.
pub fn read_nrrd(path: &Path) -> Result<Volume, VolumeError> {
    let q = |e: String| VolumeError::new(format!("{path:?}: {e}"));
    let file = crate::files::open_regular(path).map_err(|e| q(e.to_string()))?;
    let len = file.metadata().map_err(|e| q(e.to_string()))?.len();
    let mut reader = BufReader::new(file.take(MAX_HEADER));
    let mut header_bytes = 0u64;
    let mut line = Vec::new();
    let mut next = |reader: &mut BufReader<std::io::Take<std::fs::File>>| -> Result<Option<String>, VolumeError> {
        line.clear();
        let n = reader.read_until(b'\n', &mut line).map_err(|e| q(format!("header: {e}")))?;
        header_bytes += n as u64;
        if n == 0 {
            return Ok(None);
        }
        let text = std::str::from_utf8(&line).ok().filter(|t| t.ends_with('\n'));
        let Some(text) = text else {
            return Err(q("header longer than 64 KiB, not text, or without its blank line".into()));
        };
        Ok(Some(text.trim_end_matches(['\n', '\r']).to_string()))
    };
    let magic = next(&mut reader)?.unwrap_or_default();
    if !magic.starts_with("NRRD000") || !matches!(magic.as_bytes().get(7), Some(b'1'..=b'5')) || magic.len() != 8 {
        return Err(q(format!("not an NRRD file (magic {:?})", magic.chars().take(16).collect::<String>())));
    }
    let (mut dims, mut ty, mut encoding, mut endian, mut spacing, mut dimension) = (None, None, None, None, None, None);
    let mut directions = None;
    loop {
        let Some(l) = next(&mut reader)? else {
            return Err(q("header without the blank line before the data".into()));
        };
        if l.is_empty() {
            break;
        }
        if l.starts_with('#') {
            continue;
        }
        if l.contains(":=") {
            continue; // key/value pairs: comments for the data's meaning
        }
        let Some((field, value)) = l.split_once(':') else {
            return Err(q(format!("header line {l:?} is not 'field: value'")));
        };
        let (field, value) = (field.trim().to_ascii_lowercase(), value.trim());
        match field.as_str() {
            "dimension" => dimension = Some(value.to_string()),
            "sizes" => dims = Some(value.to_string()),
            "type" => ty = Some(value.to_string()),
            "encoding" => encoding = Some(value.to_string()),
            "endian" => endian = Some(value.to_string()),
            "spacings" => spacing = Some(value.to_string()),
            "space directions" => directions = Some(value.to_string()),
            "content" | "space" | "space origin" | "centers" | "centerings" | "units" | "space units" | "labels"
            | "min" | "max" | "old min" | "old max" | "measurement frame" => {}
            "kinds" => {
                if value.split_whitespace().any(|k| !matches!(k, "domain" | "space")) {
                    return Err(q(format!("kinds {value:?}: only a scalar volume (domain/space axes) is read")));
                }
            }
            _ => return Err(q(format!("field {field:?} is not supported (one scalar volume, raw, in one file)"))),
        }
    }
    if dimension.as_deref() != Some("3") {
        return Err(q(format!("dimension {:?}: a volume has dimension 3", dimension.unwrap_or_default())));
    }
    let sizes: Vec<usize> = dims
        .ok_or_else(|| q("no sizes".into()))?
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()
        .map_err(|_| q("sizes: not three positive integers".into()))?;
    let d: [usize; 3] = sizes.try_into().map_err(|_| q("sizes: not three positive integers".into()))?;
    let ty = match ty.as_deref().unwrap_or("") {
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => RawType::U8,
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => RawType::U16,
        "float" => RawType::F32,
        t => return Err(q(format!("type {t:?}: uchar, ushort or float are read"))),
    };
    if encoding.as_deref() != Some("raw") {
        return Err(q(format!("encoding {:?}: only raw is read", encoding.unwrap_or_default())));
    }
    if ty.bytes() > 1 && endian.as_deref() != Some("little") {
        return Err(q(format!("endian {:?}: only little-endian data are read", endian.unwrap_or_default())));
    }
    let spacing = match (spacing, directions) {
        (Some(_), Some(_)) => return Err(q("both spacings and space directions: NRRD allows one".into())),
        (None, Some(d)) => direction_spacing(&d).map_err(q)?,
        (None, None) => [1.0; 3],
        (Some(s), None) => {
            let v: Vec<f64> = s
                .split_whitespace()
                .map(str::parse)
                .collect::<Result<_, _>>()
                .map_err(|_| q(format!("spacings {s:?}: not three numbers")))?;
            <[f64; 3]>::try_from(v).map_err(|_| q(format!("spacings {s:?}: not three numbers")))?
        }
    };
    let n = checked_voxels(d).map_err(|e| q(e.0))?;
    let want = n as u64 * ty.bytes() as u64;
    let have = len.saturating_sub(header_bytes);
    if have != want {
        return Err(q(format!(
            "{have} bytes of data, but {}x{}x{} {:?} values need {want}{}",
            d[0],
            d[1],
            d[2],
            ty,
            if have < want { " (truncated?)" } else { "" }
        )));
    }
    let mut bytes = Vec::with_capacity(want as usize);
    let mut file = std::fs::File::open(path).map_err(|e| q(e.to_string()))?;
    std::io::copy(&mut (&mut file).take(header_bytes), &mut std::io::sink()).map_err(|e| q(e.to_string()))?;
    file.take(want).read_to_end(&mut bytes).map_err(|e| q(e.to_string()))?;
    if bytes.len() as u64 != want {
        return Err(q("the file changed while it was read".into()));
    }
    let data = super::raw::decode(&bytes, ty);
    let name = path.file_name().map_or_else(|| "volume".to_string(), |s| s.to_string_lossy().into_owned());
    Volume::new(name, d, spacing, data).map_err(|e| q(e.0))
}

/// Voxel edge lengths from `space directions` (one vector per axis, each
/// along one coordinate axis, no two along the same one): their norms.
fn direction_spacing(value: &str) -> Result<[f64; 3], String> {
    let what = "space directions";
    let mut vectors = Vec::new();
    let mut rest = value.trim();
    while !rest.is_empty() {
        let inner = rest.strip_prefix('(').and_then(|r| r.split_once(')'));
        let Some((inner, after)) = inner else {
            return Err(format!("{what} {value:?}: want three vectors (x,y,z)"));
        };
        let v: Vec<f64> = inner
            .split(',')
            .map(|c| c.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect::<Option<_>>()
            .ok_or_else(|| format!("{what}: ({inner}) is not a number per component"))?;
        vectors.push(v);
        rest = after.trim_start();
    }
    if vectors.len() != 3 || vectors.iter().any(|v| v.len() != 3) {
        return Err(format!("{what} {value:?}: want three vectors (x,y,z), one per axis"));
    }
    let mut out = [0.0; 3];
    let mut used = [false; 3];
    for (i, v) in vectors.iter().enumerate() {
        let norm = v.iter().map(|c| c * c).sum::<f64>().sqrt();
        if !(norm > 1e-12) {
            return Err(format!("{what}: axis {i} has no length"));
        }
        // Along one coordinate axis, up to rounding in the writer's output.
        let along: Vec<usize> = (0..3).filter(|&k| v[k].abs() > 1e-9 * norm).collect();
        let &[k] = along.as_slice() else {
            return Err(format!(
                "{what}: axis {i} ({}) is not along a coordinate axis (a rotated grid is not read)",
                value_list(v)
            ));
        };
        if used[k] {
            return Err(format!("{what}: two axes along the same coordinate axis"));
        }
        used[k] = true;
        out[i] = norm;
    }
    Ok(out)
}

fn value_list(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(",")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, header: &str, data: &[u8]) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, [header.as_bytes(), data].concat()).unwrap();
        p
    }

    /// Issue 24: `space directions` was ignored (every voxel a unit cube).
    #[test]
    fn space_directions_give_the_spacing() {
        assert_eq!(direction_spacing("(0.5,0,0) (0,2,0) (0,0,3)").unwrap(), [0.5, 2.0, 3.0]);
        // Flipped and permuted axes: the edge lengths still.
        assert_eq!(
            direction_spacing(" ( 0, -2, 0 )(4,0,0) (0,0,1e-17)").unwrap_err(),
            "space directions: axis 2 has no length"
        );
        assert_eq!(direction_spacing("(0,-2,0) (4,0,0) (0,0,1)").unwrap(), [2.0, 4.0, 1.0]);
        for (bad, needle) in [
            ("(1,1,0) (0,1,0) (0,0,1)", "not along a coordinate axis"),
            ("(1,0,0) (1,0,0) (0,0,1)", "same coordinate axis"),
            ("(1,0,0) (0,1,0)", "three"),
            ("(1,0,0) (0,1,0) none", "three"),
            ("(1,0) (0,1) (1,1)", "three"),
            ("(1,0,0) (0,1,0) (0,0,x)", "not a number"),
            ("(1,0,0) (0,inf,0) (0,0,1)", "not a number"),
        ] {
            let e = direction_spacing(bad).unwrap_err();
            assert!(e.contains(needle), "{bad}: {e}");
        }
    }

    #[test]
    fn reads_the_subset_and_refuses_the_rest() {
        let dir = std::env::temp_dir().join(format!("itgfx-nrrd-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let head = "NRRD0004\n# comment\ntype: ushort\ndimension: 3\nsizes: 2 2 1\nendian: little\n\
                    encoding: raw\nspacings: 1 2 3\nkinds: domain domain domain\n\n";
        let data: Vec<u8> = [1u16, 2, 3, 400].iter().flat_map(|v| v.to_le_bytes()).collect();
        let v = read_nrrd(&write(&dir, "a.nrrd", head, &data)).unwrap();
        assert_eq!((v.dims, v.spacing, v.data[3]), ([2, 2, 1], [1.0, 2.0, 3.0], 400.0));
        let e = read_nrrd(&write(&dir, "b.nrrd", head, &data[..6])).unwrap_err();
        assert!(e.0.contains("truncated"), "{e}");
        for (bad, needle) in [
            (head.replace("encoding: raw", "encoding: gzip"), "encoding"),
            (head.replace("endian: little", "endian: big"), "endian"),
            (head.replace("dimension: 3", "dimension: 2"), "dimension"),
            (head.replace("type: ushort", "type: double"), "type"),
            (head.replace("# comment", "data file: x.raw"), "data file"),
            (head.replace("NRRD0004", "NRRD9"), "magic"),
            (head.replace("\n\n", "\n"), "blank line"),
        ] {
            let e = read_nrrd(&write(&dir, "c.nrrd", &bad, &data)).unwrap_err();
            assert!(e.0.contains(needle), "{needle}: {e}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
