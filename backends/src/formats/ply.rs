//! Stanford PLY meshes (ASCII, binary little and big endian): the vertex
//! element's `x y z` and the face element's index list; each face is one
//! patch, triangulated in its plane as an OBJ polygon is
//! ([`crate::obj::polygon`]). Every other property and element is skipped
//! with one warning `ply-property-ignored`.
//!
//! A small reader of our own rather than a crate: the header states every
//! size, so the least number of bytes the body can take is computed from it
//! and checked against the file's length (and the triangle and patch counts
//! against [`Limits`]) before anything is allocated; a header that lies is
//! one error line, never an allocation of its claim.

use glam::DVec3;

use crate::obj::polygon;
use crate::obj::{MAX_VERTICES, Warnings, rescale_exponent, scale_by};
use crate::scene::{Limits, Scene, SceneError};

/// Largest PLY file read, in bytes.
pub const MAX_PLY_BYTES: u64 = 1 << 30;

fn err(path: &str, message: impl Into<String>) -> SceneError {
    SceneError::Obj { path: path.to_string(), message: message.into() }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    /// `Some(count type)` for a list.
    list: Option<Scalar>,
    ty: Scalar,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// Whether `bytes` start like a PLY file.
#[must_use]
pub fn is_ply(bytes: &[u8]) -> bool {
    bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n")
}

/// The header: format, elements and the body's offset.
fn header(path: &str, bytes: &[u8]) -> Result<(Format, Vec<Element>, usize), SceneError> {
    if !is_ply(bytes) {
        return Err(err(path, "not a PLY file (does not start with \"ply\")"));
    }
    let mut pos = 0;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut line_no = 0;
    loop {
        line_no += 1;
        let Some(nl) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(err(path, "header has no end_header line"));
        };
        let raw = &bytes[pos..pos + nl];
        pos += nl + 1;
        let Ok(line) = std::str::from_utf8(raw) else {
            return Err(err(path, format!("header line {line_no} is not text")));
        };
        let words: Vec<&str> = line.split_whitespace().collect();
        let bad = |m: String| err(path, format!("header line {line_no}: {m}"));
        match words.as_slice() {
            ["ply"] if line_no == 1 => {}
            ["format", f, v] => {
                if *v != "1.0" {
                    return Err(bad(format!("format version {v} (only 1.0 exists)")));
                }
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    _ => return Err(bad(format!("unknown format {f:?}"))),
                });
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["element", name, count] => {
                let count: u64 = count.parse().map_err(|_| bad(format!("element count {count:?} is not a count")))?;
                elements.push(Element { name: (*name).to_string(), count, props: Vec::new() });
            }
            ["property", "list", ct, it, name] => {
                let e = elements.last_mut().ok_or_else(|| bad("property before any element".into()))?;
                let ct =
                    Scalar::parse(ct).filter(|s| s.integer()).ok_or_else(|| bad(format!("list count type {ct:?}")))?;
                let ty = Scalar::parse(it).ok_or_else(|| bad(format!("unknown type {it:?}")))?;
                e.props.push(Property { name: (*name).to_string(), list: Some(ct), ty });
            }
            ["property", ty, name] => {
                let e = elements.last_mut().ok_or_else(|| bad("property before any element".into()))?;
                let ty = Scalar::parse(ty).ok_or_else(|| bad(format!("unknown type {ty:?}")))?;
                e.props.push(Property { name: (*name).to_string(), list: None, ty });
            }
            ["end_header"] => break,
            _ => {
                return Err(bad(format!(
                    "not a PLY header statement: {:?}",
                    line.chars().take(60).collect::<String>()
                )));
            }
        }
    }
    let format = format.ok_or_else(|| err(path, "header has no format line"))?;
    Ok((format, elements, pos))
}

/// Reads values of a body, ASCII or binary, with bounds checked on every read.
struct Body<'a> {
    bytes: &'a [u8],
    pos: usize,
    format: Format,
    path: &'a str,
}

impl Body<'_> {
    fn eof(&self, what: &str) -> SceneError {
        err(self.path, format!("file ends inside the {what} (the header promises more data than there is)"))
    }

    fn word(&mut self, what: &str) -> Result<&str, SceneError> {
        let b = self.bytes;
        while self.pos < b.len() && b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < b.len() && !b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        if start == self.pos {
            return Err(self.eof(what));
        }
        std::str::from_utf8(&b[start..self.pos]).map_err(|_| err(self.path, format!("{what}: not ASCII text")))
    }

    fn read(&mut self, ty: Scalar, what: &str) -> Result<f64, SceneError> {
        if self.format == Format::Ascii {
            let path = self.path;
            let w = self.word(what)?;
            let v: f64 = if ty.integer() {
                w.parse::<i64>().map(|i| i as f64).map_err(|_| err(path, format!("{what}: {w:?} is not an integer")))?
            } else {
                w.parse().map_err(|_| err(path, format!("{what}: {w:?} is not a number")))?
            };
            return Ok(v);
        }
        let n = ty.size();
        let Some(s) = self.bytes.get(self.pos..self.pos + n) else { return Err(self.eof(what)) };
        self.pos += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(s);
        if self.format == Format::Big {
            a[..n].reverse();
        }
        Ok(match ty {
            Scalar::I8 => f64::from(a[0] as i8),
            Scalar::U8 => f64::from(a[0]),
            Scalar::I16 => f64::from(i16::from_le_bytes([a[0], a[1]])),
            Scalar::U16 => f64::from(u16::from_le_bytes([a[0], a[1]])),
            Scalar::I32 => f64::from(i32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Scalar::U32 => f64::from(u32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Scalar::F32 => f64::from(f32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Scalar::F64 => f64::from_le_bytes(a),
        })
    }
}

/// Least bytes one instance of `e` takes in the body: binary sizes (lists
/// empty, or of 3 entries for the face list), or two bytes per ASCII value.
fn least_bytes(e: &Element, format: Format, face_list: Option<usize>) -> u64 {
    e.props
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let entries = if Some(i) == face_list { 3 } else { 0 };
            match (format, p.list) {
                (Format::Ascii, None) => 2,
                (Format::Ascii, Some(_)) => 2 + 2 * entries,
                (_, None) => p.ty.size() as u64,
                (_, Some(c)) => c.size() as u64 + entries * p.ty.size() as u64,
            }
        })
        .sum()
}

/// Reads a PLY file.
///
/// # Errors
/// As [`parse_ply`], and unreadable or too large files.
pub fn load_ply(path: &std::path::Path) -> Result<Scene, SceneError> {
    let bytes = crate::obj::read_limited(path, MAX_PLY_BYTES)?;
    parse_ply(&path.display().to_string(), &bytes)
}

/// Parses a PLY file (`name` for messages) into a scene: one patch per face.
///
/// # Errors
/// [`SceneError::Obj`] naming the file for a bad header, a header whose
/// counts do not fit the file, bad or non-finite values, indices out of
/// range, degenerate or self-intersecting faces, or no faces;
/// [`SceneError::TooLarge`] past [`Limits`].
#[allow(clippy::too_many_lines)]
pub fn parse_ply(name: &str, bytes: &[u8]) -> Result<Scene, SceneError> {
    let (format, elements, start) = header(name, bytes)?;
    let vi =
        elements.iter().position(|e| e.name == "vertex").ok_or_else(|| err(name, "no vertex element in the header"))?;
    let fi =
        elements.iter().position(|e| e.name == "face").ok_or_else(|| err(name, "no face element (a point cloud?)"))?;
    let coord = |n: &str| -> Result<usize, SceneError> {
        elements[vi]
            .props
            .iter()
            .position(|p| p.name == n && p.list.is_none())
            .ok_or_else(|| err(name, format!("vertex element has no scalar property {n}")))
    };
    let xyz = [coord("x")?, coord("y")?, coord("z")?];
    let face_list = elements[fi]
        .props
        .iter()
        .position(|p| p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index"))
        .ok_or_else(|| err(name, "face element has no vertex_indices list"))?;
    if !elements[fi].props[face_list].ty.integer() {
        return Err(err(name, "face vertex_indices are not integers"));
    }
    let mut ignored: Vec<String> = Vec::new();
    for (k, e) in elements.iter().enumerate() {
        for (i, p) in e.props.iter().enumerate() {
            let used = (k == vi && xyz.contains(&i)) || (k == fi && i == face_list);
            if !used {
                ignored.push(format!("{}.{}", e.name, p.name));
            }
        }
        if k != vi && k != fi && e.props.is_empty() && e.count > 0 {
            ignored.push(e.name.clone());
        }
    }
    // Sizes against the file before any allocation.
    let body = (bytes.len() - start) as u64;
    let mut least = 0u64;
    for (k, e) in elements.iter().enumerate() {
        let per = least_bytes(e, format, (k == fi).then_some(face_list));
        least = least.saturating_add(e.count.saturating_mul(per));
    }
    if format == Format::Ascii {
        // The last value needs no separator after it.
        least = least.saturating_sub(1);
    }
    if least > body {
        return Err(err(
            name,
            format!("the header's element counts need at least {least} bytes of data, the file has {body}"),
        ));
    }
    let (nv, nf) = (elements[vi].count, elements[fi].count);
    if nv > MAX_VERTICES {
        return Err(err(name, format!("{nv} vertices, more than the {MAX_VERTICES} read")));
    }
    let budget = crate::memory::budget();
    Limits::check_within(budget, name, nf, nf)?;
    let mut warnings = Warnings::default();
    if !ignored.is_empty() {
        warnings.add("ply-property-ignored", || {
            format!("{name}: only vertex x y z and the face list are read; ignored: {}", ignored.join(" "))
        });
    }
    let mut r = Body { bytes, pos: start, format, path: name };
    let mut verts: Vec<DVec3> = Vec::with_capacity(nv as usize);
    let mut faces: Vec<(usize, usize)> = Vec::with_capacity(nf as usize);
    let mut indices: Vec<u32> = Vec::new();
    let mut triangles = 0u64;
    for (k, e) in elements.iter().enumerate() {
        for n in 0..e.count {
            let mut p = [0.0; 3];
            for (i, prop) in e.props.iter().enumerate() {
                let what = format!("{} {n} property {}", e.name, prop.name);
                let Some(ct) = prop.list else {
                    let v = r.read(prop.ty, &what)?;
                    if k == vi
                        && let Some(c) = xyz.iter().position(|&j| j == i)
                    {
                        if !v.is_finite() {
                            return Err(err(name, format!("vertex {n}: coordinate {v} is not finite")));
                        }
                        p[c] = v;
                    }
                    continue;
                };
                let len = r.read(ct, &what)?;
                if !(len >= 0.0) {
                    return Err(err(name, format!("{what}: negative list length {len}")));
                }
                let len = len as usize;
                let face = k == fi && i == face_list;
                if face {
                    if len < 3 {
                        return Err(err(name, format!("face {n} has {len} vertices, needs at least 3")));
                    }
                    if len > polygon::MAX_FACE_VERTICES {
                        return Err(err(
                            name,
                            format!(
                                "face {n} has {len} vertices, at most {} are supported",
                                polygon::MAX_FACE_VERTICES
                            ),
                        ));
                    }
                    triangles += len as u64 - 2;
                    Limits::check_within(budget, name, triangles, nf)?;
                    faces.push((indices.len(), len));
                }
                for _ in 0..len {
                    let v = r.read(prop.ty, &what)?;
                    if face {
                        if !(v >= 0.0 && v < nv as f64) {
                            return Err(err(name, format!("face {n}: vertex index {v} is out of range (0..{nv})")));
                        }
                        indices.push(v as u32);
                    }
                }
            }
            if k == vi {
                verts.push(DVec3::from_array(p));
            }
        }
    }
    if faces.is_empty() {
        return Err(err(name, "no faces"));
    }
    let k = rescale_exponent(indices.iter().map(|&i| verts[i as usize]));
    if k != 0 {
        for v in &mut verts {
            *v = scale_by(*v, k);
        }
        warnings.add("rescaled", || {
            format!("{name}: coordinates multiplied by 2^{k} so that areas stay finite and non-zero in f64")
        });
    }
    let mut scene = Scene::named(name);
    scene.triangles.reserve(triangles as usize);
    scene.triangle_patch.reserve(triangles as usize);
    scene.patches.reserve(faces.len());
    for (f, &(s, len)) in faces.iter().enumerate() {
        let poly: Vec<DVec3> = indices[s..s + len].iter().map(|&i| verts[i as usize]).collect();
        let t = polygon::triangulate(&poly).map_err(|m| err(name, format!("face {f} {m}")))?;
        if t.deviation > polygon::PLANAR_TOLERANCE {
            warnings.add("non-planar-face", || {
                format!(
                    "{name}: face {f} is {:.2e} of its size off its plane (tolerance {:e}); triangulated in that plane",
                    t.deviation,
                    polygon::PLANAR_TOLERANCE
                )
            });
        }
        scene.add_triangles(format!("face/{f}"), &t.triangles, 0);
    }
    scene.warnings = warnings.finish();
    scene.validate()?;
    Ok(scene)
}

/// Writes a scene's triangles as binary little-endian PLY (one face per
/// triangle, vertices as `double`, so coordinates are exact).
///
/// # Errors
/// I/O errors.
pub fn write_ply(scene: &Scene, out: &mut impl std::io::Write) -> std::io::Result<()> {
    let n = scene.triangles.len();
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment {} written by itgfx\nelement vertex {}\n\
         property double x\nproperty double y\nproperty double z\nelement face {n}\n\
         property list uchar uint vertex_indices\nend_header\n",
        scene.name.replace(['\n', '\r'], " "),
        3 * n
    )?;
    let mut buf = Vec::with_capacity(n * 72);
    for t in &scene.triangles {
        for v in t {
            for c in v.to_array() {
                buf.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    for i in 0..n as u32 {
        buf.push(3);
        for k in 0..3 {
            buf.extend_from_slice(&(3 * i + k).to_le_bytes());
        }
    }
    out.write_all(&buf)
}
