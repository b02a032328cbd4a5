//! Wavefront OBJ scenes: each polygon is one patch, `g`/`o` names prefix
//! patch names, `usemtl` materials come from the `mtllib` files (see
//! [`mtl`]).
//!
//! The file is read once into memory, with a size limit (only regular
//! files: a FIFO or a device is refused before it is opened), then parsed
//! from the buffer in `f64`: coordinates are never cut to `f32` here (the
//! tracer normalises the scene to the unit sphere before it converts).
//! A UTF-8 byte-order mark is skipped. Errors name the file and the line.
//!
//! Polygons are triangulated in their own plane ([`polygon`]): convex ones
//! as a fan, concave ones by ear clipping; self-intersecting polygons are
//! errors. A face farther from planar than [`polygon::PLANAR_TOLERANCE`]
//! (relative to its size) is triangulated in its best-fit plane and
//! reported as warning `non-planar-face` in [`Scene::warnings`].
//! `vt`, `vn`, `vp` and `s` do not change patches and are skipped; `l` and
//! `p` and any other statement give warning `obj-statement-ignored`.

pub mod mtl;
pub mod polygon;

use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

use glam::DVec3;

use crate::scene::{Limits, Material, Scene, SceneError};

/// Largest OBJ file read, in bytes (1 GiB: about 2^24 triangles of text,
/// the [`Limits::MAX_TRIANGLES`] cap).
pub const MAX_OBJ_BYTES: u64 = 1 << 30;

/// Largest MTL file read, and most MTL bytes of one OBJ, in bytes.
pub const MAX_MTL_BYTES: u64 = 16 << 20;

/// Coordinates whose magnitude passes `2^RESCALE_EXPONENT` (or whose
/// extent is below `2^-RESCALE_EXPONENT`) are rescaled by a power of two
/// (exact), so that areas (squares of lengths) stay finite and non-zero in `f64`.
pub const RESCALE_EXPONENT: i32 = 100;

fn err(path: &str, message: String) -> SceneError {
    SceneError::Obj { path: path.to_string(), message }
}

/// Named warnings, the first of each name kept with a count of the rest.
#[derive(Default)]
pub struct Warnings {
    list: Vec<(&'static str, String, usize)>,
}

impl Warnings {
    /// Records warning `name`; the message is only made for the first.
    pub fn add(&mut self, name: &'static str, message: impl FnOnce() -> String) {
        if let Some(w) = self.list.iter_mut().find(|w| w.0 == name) {
            w.2 += 1;
        } else {
            self.list.push((name, message(), 0));
        }
    }

    /// One line per name: `"name: message (and N more)"`.
    #[must_use]
    pub fn finish(self) -> Vec<String> {
        self.list
            .into_iter()
            .map(|(n, m, more)| if more > 0 { format!("{n}: {m} (and {more} more)") } else { format!("{n}: {m}") })
            .collect()
    }
}

/// Reads a whole file once, refusing more than `limit` bytes.
///
/// # Errors
/// [`SceneError::Obj`] for unreadable files, anything but a regular file
/// ([`crate::files::open_regular`]: a FIFO would hang), and files larger
/// than `limit` (or growing past it while read).
pub fn read_limited(path: &Path, limit: u64) -> Result<Vec<u8>, SceneError> {
    let shown = path.display().to_string();
    let file = crate::files::open_regular(path).map_err(|e| err(&shown, e.to_string()))?;
    let meta = file.metadata().map_err(|e| err(&shown, e.to_string()))?;
    if meta.len() > limit {
        return Err(err(&shown, format!("file is {} bytes, over the limit of {limit} bytes", meta.len())));
    }
    let mut buf = Vec::new();
    file.take(limit + 1).read_to_end(&mut buf).map_err(|e| err(&shown, e.to_string()))?;
    if buf.len() as u64 > limit {
        return Err(err(&shown, format!("more than {limit} bytes (still growing); refusing to read on")));
    }
    Ok(buf)
}

/// Reads an OBJ file into a scene (one patch per polygon); `mtllib` files
/// are read relative to the OBJ's directory.
///
/// # Errors
/// [`SceneError::Obj`] with the file and line for unreadable or too large
/// files, bad numbers, non-finite coordinates, bad indices, degenerate or
/// self-intersecting polygons, a missing MTL file or material, or no faces;
/// [`SceneError::TooLarge`] past [`Limits`].
pub fn load_obj(path: &Path) -> Result<Scene, SceneError> {
    let bytes = read_limited(path, MAX_OBJ_BYTES)?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    parse_obj(&path.display().to_string(), &bytes, |lib| mtl_file(&dir, lib))
}

/// The shown path and bytes of `mtllib` file `name` next to the OBJ in `dir`.
fn mtl_file(dir: &Path, name: &str) -> Result<(String, Vec<u8>), SceneError> {
    let p = dir.join(name);
    let shown = p.display().to_string();
    let bytes = read_limited(&p, MAX_MTL_BYTES).map_err(|e| match e {
        SceneError::Obj { message, .. } => err(&shown, format!("mtllib {name}: {message}")),
        other => other,
    })?;
    Ok((shown, bytes))
}

/// Most vertices read: three per triangle of the [`Limits::MAX_TRIANGLES`]
/// cap (a triangle soup such as [`write_obj`] writes).
pub const MAX_VERTICES: u64 = 3 * Limits::MAX_TRIANGLES;

/// One face as read: its line, its vertex indices (`indices[start..start + len]`),
/// group and `usemtl` (index into the names used).
struct Face {
    line: usize,
    start: usize,
    len: usize,
    group: usize,
    material: Option<usize>,
}

/// Warning `duplicate-face` for every face on the same vertices, wound
/// the same way, as an earlier one. Kept, not refused: both faces are
/// traced, and a line meeting the pair crosses one or the other by
/// rounding, which splits the counts of one surface between two patches
/// (visibility measures change; nothing breaks). The same vertices wound
/// the other way are the two sides of one surface (e.g. a lamp's front and
/// a mirror's back) and pass. By 16 bytes a face: a hash of the indices
/// rotated to start at the smallest, sorted, equal hashes compared in full.
fn duplicate_faces(name: &str, faces: &[Face], indices: &[u32], warnings: &mut Warnings) {
    use std::hash::{Hash, Hasher};
    let sorted = |f: &Face| {
        let mut v = indices[f.start..f.start + f.len].to_vec();
        let first = v.iter().enumerate().min_by_key(|&(_, &i)| i).map_or(0, |(k, _)| k);
        v.rotate_left(first);
        v
    };
    let mut keys: Vec<(u64, u32)> = faces
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let mut h = std::collections::hash_map::DefaultHasher::new();
            sorted(f).hash(&mut h);
            (h.finish(), i as u32)
        })
        .collect();
    keys.sort_unstable();
    for run in keys.chunk_by(|a, b| a.0 == b.0).filter(|r| r.len() > 1) {
        for (k, &(_, later)) in run.iter().enumerate().skip(1) {
            let g = &faces[later as usize];
            if let Some(&(_, first)) = run[..k].iter().find(|&&(_, e)| sorted(&faces[e as usize]) == sorted(g)) {
                warnings.add("duplicate-face", || {
                    format!(
                        "{name}: line {}: face {} has the vertices of face {} (line {}); both are kept",
                        g.line,
                        later + 1,
                        first + 1,
                        faces[first as usize].line
                    )
                });
            }
        }
    }
}

fn decode<'a>(path: &str, bytes: &'a [u8]) -> Result<&'a str, SceneError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    std::str::from_utf8(bytes).map_err(|e| err(path, format!("not UTF-8 text (byte {})", e.valid_up_to())))
}

/// Parses OBJ text (`name` for messages); `mtl(lib)` returns the shown path
/// and bytes of the `mtllib` file `lib`.
///
/// # Errors
/// As [`load_obj`].
pub fn parse_obj(
    name: &str,
    bytes: &[u8],
    mtl: impl FnMut(&str) -> Result<(String, Vec<u8>), SceneError>,
) -> Result<Scene, SceneError> {
    parse(name, bytes, mtl, false)
}

/// As [`load_obj`], but a face with no area is left out with a warning
/// (`degenerate-face-dropped`, counted) instead of refusing the file, and
/// the scene is not [validated](Scene::validate) for tiny triangles: for
/// measuring another program's output as it is (`itgfx simplify
/// --evaluate`; meshoptimizer's simplified meshes have such faces).
///
/// # Errors
/// As [`load_obj`], faces with no area apart.
pub fn load_obj_dropping_degenerate(path: &Path) -> Result<Scene, SceneError> {
    let bytes = read_limited(path, MAX_OBJ_BYTES)?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    parse(&path.display().to_string(), &bytes, |lib| mtl_file(&dir, lib), true)
}

/// [`parse_obj`], leaving faces with no area out where `drop_degenerate`
/// (see [`load_obj_dropping_degenerate`]).
#[allow(clippy::too_many_lines)]
fn parse(
    name: &str,
    bytes: &[u8],
    mut mtl: impl FnMut(&str) -> Result<(String, Vec<u8>), SceneError>,
    drop_degenerate: bool,
) -> Result<Scene, SceneError> {
    let text = decode(name, bytes)?;
    let mut warnings = Warnings::default();
    let mut verts: Vec<DVec3> = Vec::new();
    let mut faces: Vec<Face> = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    let mut groups: Vec<String> = vec!["unnamed_object".into()];
    let mut group = 0usize;
    // `usemtl` names with the line of their first use.
    let mut used: Vec<(String, usize)> = Vec::new();
    let mut used_index: HashMap<String, usize> = HashMap::new();
    let mut material: Option<usize> = None;
    let mut mtl_bytes = 0u64;
    let mut materials: Vec<Material> = vec![Material::default()];
    let mut by_name: HashMap<String, usize> = HashMap::new();
    let (mut triangles, mut patches) = (0u64, 0u64);
    let budget = crate::memory::budget();
    for (ln, raw) in text.lines().enumerate() {
        let line = ln + 1;
        let mut it = raw.split_whitespace();
        let Some(key) = it.next() else { continue };
        match key {
            "v" => {
                let c: Vec<&str> = it.collect();
                if c.len() < 3 {
                    return Err(err(name, format!("line {line}: vertex needs 3 coordinates, found {}", c.len())));
                }
                let mut p = [0.0; 3];
                for (k, s) in c[..3].iter().enumerate() {
                    let v: f64 = s
                        .parse()
                        .map_err(|_| err(name, format!("line {line}: vertex coordinate {s:?} is not a number")))?;
                    if !v.is_finite() {
                        return Err(err(name, format!("line {line}: vertex coordinate {s:?} is not finite")));
                    }
                    p[k] = v;
                }
                if verts.len() as u64 >= MAX_VERTICES {
                    return Err(err(
                        name,
                        format!("line {line}: more than {MAX_VERTICES} vertices (3 per triangle of the limit)"),
                    ));
                }
                verts.push(DVec3::from_array(p));
            }
            "f" => {
                let n = faces.len() + 1;
                let idx: Vec<&str> = it.collect();
                if idx.len() < 3 {
                    return Err(err(
                        name,
                        format!("line {line}: face {n} has {} vertices, needs at least 3", idx.len()),
                    ));
                }
                if idx.len() > polygon::MAX_FACE_VERTICES {
                    return Err(err(
                        name,
                        format!(
                            "line {line}: face {n} has {} vertices, at most {} are supported",
                            idx.len(),
                            polygon::MAX_FACE_VERTICES
                        ),
                    ));
                }
                triangles += idx.len() as u64 - 2;
                patches += 1;
                Limits::check_within(budget, name, triangles, patches)?;
                let start = indices.len();
                for s in &idx {
                    let first = s.split('/').next().unwrap_or("");
                    let i: i64 = first.parse().map_err(|_| {
                        err(name, format!("line {line}: face {n}: vertex index {s:?} is not an integer"))
                    })?;
                    let count = verts.len() as i64;
                    let k = if i < 0 { count.saturating_add(i) } else { i - 1 };
                    if i == 0 || k < 0 || k >= count {
                        return Err(err(
                            name,
                            format!(
                                "line {line}: face {n}: vertex index {i} is out of range (1..={count} defined so far)"
                            ),
                        ));
                    }
                    indices.push(k as u32);
                }
                faces.push(Face { line, start, len: idx.len(), group, material });
            }
            "g" | "o" => {
                let g = it.collect::<Vec<_>>().join(" ");
                groups.push(if g.is_empty() { "unnamed_object".into() } else { g });
                group = groups.len() - 1;
            }
            "usemtl" => {
                let m = it.collect::<Vec<_>>().join(" ");
                material = Some(*used_index.entry(m).or_insert_with_key(|m| {
                    used.push((m.clone(), line));
                    used.len() - 1
                }));
            }
            "mtllib" => {
                for lib in it {
                    let (shown, bytes) = mtl(lib)?;
                    mtl_bytes += bytes.len() as u64;
                    if mtl_bytes > MAX_MTL_BYTES {
                        return Err(err(
                            name,
                            format!("line {line}: mtllib files together pass {MAX_MTL_BYTES} bytes"),
                        ));
                    }
                    let t = decode(&shown, &bytes)?;
                    for m in mtl::parse_mtl(&shown, t, &mut warnings)? {
                        by_name.insert(m.name.clone(), materials.len());
                        materials.push(m);
                    }
                }
            }
            "vt" | "vn" | "vp" | "s" => {}
            k if k.starts_with('#') => {}
            k => warnings.add("obj-statement-ignored", || {
                format!("{name}: line {line}: {k:?} is not read (only v, f, g, o, usemtl, mtllib are)")
            }),
        }
    }
    if faces.is_empty() {
        return Err(err(name, "no faces (f lines) found".into()));
    }
    Limits::check(name, triangles, patches)?;
    // From the vertices faces use: unused ones do not count for the scene's size.
    let k = rescale_exponent(indices.iter().map(|&i| verts[i as usize]));
    if k != 0 {
        for v in &mut verts {
            *v = scale_by(*v, k);
        }
        warnings.add("rescaled", || {
            format!("{name}: coordinates multiplied by 2^{k} so that areas stay finite and non-zero in f64")
        });
    }
    duplicate_faces(name, &faces, &indices, &mut warnings);
    let mut scene = Scene { name: name.to_string(), materials, ..Scene::default() };
    scene.triangles.reserve(triangles as usize);
    let mut in_group = vec![0usize; groups.len()];
    for (f, face) in faces.iter().enumerate() {
        let material = match face.material.map(|u| &used[u]) {
            None => 0,
            Some((m, l)) => *by_name
                .get(m)
                .ok_or_else(|| err(name, format!("line {l}: usemtl {m:?}: no such material in the mtllib files")))?,
        };
        let poly: Vec<DVec3> = indices[face.start..face.start + face.len].iter().map(|&i| verts[i as usize]).collect();
        let t = match polygon::triangulate(&poly) {
            Err(m) if drop_degenerate && m == polygon::DEGENERATE => {
                warnings.add("degenerate-face-dropped", || {
                    format!("{name}: line {}: face {} has no area: left out", face.line, f + 1)
                });
                continue;
            }
            t => t.map_err(|m| err(name, format!("line {}: face {} {m}", face.line, f + 1)))?,
        };
        if t.deviation > polygon::PLANAR_TOLERANCE {
            warnings.add("non-planar-face", || {
                format!(
                    "{name}: line {}: face {} is {:.2e} of its size off its plane (tolerance {:e}); triangulated in that plane",
                    face.line,
                    f + 1,
                    t.deviation,
                    polygon::PLANAR_TOLERANCE
                )
            });
        }
        let g = &mut in_group[face.group];
        scene.add_triangles(format!("{}/{g}", groups[face.group]), &t.triangles, material);
        *g += 1;
    }
    scene.warnings = warnings.finish();
    if !drop_degenerate {
        scene.validate()?;
    }
    Ok(scene)
}

/// The exponent `k` such that multiplying by `2^k` brings the coordinates'
/// magnitude near 1 when it is above `2^RESCALE_EXPONENT`, or, for tiny
/// scenes, their extent near 1 when it is below `2^-RESCALE_EXPONENT` (but
/// never the magnitude above `2^RESCALE_EXPONENT`); else 0.
pub(crate) fn rescale_exponent(used: impl Iterator<Item = DVec3>) -> i32 {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for v in used {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    let magnitude = lo.abs().max(hi.abs()).max_element();
    let extent = (hi * 0.5 - lo * 0.5).max_element() * 2.0;
    let e = |x: f64| x.log2().floor() as i32;
    if magnitude > 2f64.powi(RESCALE_EXPONENT) {
        -e(magnitude)
    } else if extent > 0.0 && extent < 2f64.powi(-RESCALE_EXPONENT) {
        (-e(extent)).min(RESCALE_EXPONENT - e(magnitude))
    } else {
        0
    }
}

/// `v · 2^k` in two exact steps (`2^k` alone may not be a normal number).
pub(crate) fn scale_by(v: DVec3, k: i32) -> DVec3 {
    v * 2f64.powi(k / 2) * 2f64.powi(k - k / 2)
}

/// Writes a scene as OBJ (one `f` per triangle, one group per patch run), so
/// built-in scenes can be given to other tracers.
///
/// # Errors
/// I/O errors.
pub fn write_obj(scene: &Scene, out: &mut impl std::io::Write) -> std::io::Result<()> {
    writeln!(out, "# {} — written by itgfx; {} patches", scene.name, scene.patches.len())?;
    for t in &scene.triangles {
        for v in t {
            writeln!(out, "v {} {} {}", v.x, v.y, v.z)?;
        }
    }
    let mut last = u32::MAX;
    for (i, &p) in scene.triangle_patch.iter().enumerate() {
        if p != last {
            writeln!(out, "g patch{p}")?;
            last = p;
        }
        writeln!(out, "f {} {} {}", 3 * i + 1, 3 * i + 2, 3 * i + 3)?;
    }
    Ok(())
}
