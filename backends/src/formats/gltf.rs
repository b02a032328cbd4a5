//! glTF 2.0 scenes (`.gltf` with `data:` URIs or external buffers, and
//! `.glb`) through the `gltf` crate's document model; buffers and
//! accessors are read here, every range checked against the data.
//!
//! * Geometry: the default scene's (else the first scene's) node tree with
//!   each node's transform composed onto its parent's; a transform with a
//!   negative determinant mirrors, so its triangles' winding is reversed to
//!   keep the front side. `TRIANGLES`, `TRIANGLE_STRIP` and `TRIANGLE_FAN`
//!   primitives, indexed or not; points and lines give a warning. Each
//!   triangle is one patch; each primitive is a group, as an OBJ `g` is
//!   (patch names `node/mesh#primitive/k`).
//! * Materials: `baseColorFactor` is the diffuse reflectance,
//!   `emissiveFactor × KHR_materials_emissive_strength` the emitted
//!   radiance; metallic 1 with roughness 0 is an ideal mirror of
//!   reflectance `baseColorFactor`; any other metallic or roughness than
//!   (0, 1), textures and transparency give warning
//!   `gltf-material-approximated` (the surface is diffuse, untextured,
//!   opaque). A primitive without a material gets the default grey.
//! * Camera: the first perspective camera met in the node tree (depth
//!   first, children in order) becomes [`Scene::camera`], in scene units.
//! * Refused with one line: no triangles, a missing external buffer, a URI
//!   outside the file's folder, sparse accessors, Draco compression or any
//!   other required extension.

use glam::{DMat4, DVec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::buffer::Source;
use gltf::mesh::Mode;

use crate::camera::Camera;
use crate::obj::polygon;
use crate::obj::{Warnings, rescale_exponent, scale_by};
use crate::scene::{Limits, Material, Scene, SceneError};

/// Largest `.gltf`, `.glb` or external buffer file read, in bytes.
pub const MAX_GLTF_BYTES: u64 = 1 << 30;

/// Most node instances visited (node trees may share subtrees).
const MAX_NODE_VISITS: usize = 1 << 20;
/// Deepest node nesting followed.
const MAX_DEPTH: usize = 256;

const DRACO: &str = "KHR_draco_mesh_compression";

fn err(path: &str, message: impl Into<String>) -> SceneError {
    let m: String = message.into();
    SceneError::Obj { path: path.to_string(), message: m.replace(['\n', '\r'], " ") }
}

/// Whether `bytes` are a binary glTF (`.glb`).
#[must_use]
pub fn is_glb(bytes: &[u8]) -> bool {
    bytes.starts_with(b"glTF")
}

/// Decodes standard base64 (with or without `=` padding).
fn base64(s: &str) -> Option<Vec<u8>> {
    let s = s.trim_end_matches('=');
    let mut out = Vec::with_capacity(s.len() / 4 * 3 + 3);
    let (mut acc, mut bits) = (0u32, 0);
    for c in s.bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return None,
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    Some(out)
}

/// `%XX` escapes of a URI decoded.
fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let h = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(h, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The relative path a buffer URI names, refused when it would leave the
/// file's folder (absolute, `..`, a drive or another scheme).
///
/// # Errors
/// A message naming the URI.
pub fn relative_uri(uri: &str) -> Result<std::path::PathBuf, String> {
    use std::path::Component;
    let path = percent_decode(uri).ok_or_else(|| format!("URI {uri:?} has a bad %-escape"))?;
    if path.contains(':') || path.starts_with('/') || path.starts_with('\\') {
        return Err(format!("URI {uri:?} is outside the file's folder (absolute, or another scheme); refused"));
    }
    let p = std::path::PathBuf::from(&path);
    if p.components().any(|c| !matches!(c, Component::Normal(_) | Component::CurDir)) || path.contains('\\') {
        return Err(format!("URI {uri:?} is outside the file's folder; refused"));
    }
    Ok(p)
}

/// Reads a glTF or GLB file; external buffers are read from its folder.
///
/// # Errors
/// As [`parse_gltf`], and unreadable files.
pub fn load_gltf(path: &std::path::Path) -> Result<Scene, SceneError> {
    let bytes = crate::obj::read_limited(path, MAX_GLTF_BYTES)?;
    let dir = path.parent().unwrap_or(std::path::Path::new("")).to_path_buf();
    let shown = path.display().to_string();
    parse_gltf(&shown, &bytes, |uri| {
        let rel = relative_uri(uri)?;
        let p = dir.join(rel);
        crate::obj::read_limited(&p, MAX_GLTF_BYTES).map_err(|e| match e {
            SceneError::Obj { message, .. } => format!("external buffer {uri:?}: {message}"),
            other => other.to_string(),
        })
    })
}

/// One buffer view range of an accessor: data, first byte, stride, count.
struct Span<'a> {
    data: &'a [u8],
    stride: usize,
    count: usize,
    ty: DataType,
}

impl Span<'_> {
    fn get(&self, i: usize, c: usize) -> f64 {
        let size = component_size(self.ty);
        let o = i * self.stride + c * size;
        let b = &self.data[o..o + size];
        match self.ty {
            DataType::I8 => f64::from(b[0] as i8),
            DataType::U8 => f64::from(b[0]),
            DataType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            DataType::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
            DataType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            DataType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        }
    }
}

fn component_size(t: DataType) -> usize {
    match t {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

fn dims(d: Dimensions) -> usize {
    match d {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 | Dimensions::Mat2 => 4,
        Dimensions::Mat3 => 9,
        Dimensions::Mat4 => 16,
    }
}

/// The bytes of an accessor, bounds-checked.
fn span<'a>(
    name: &str,
    acc: &gltf::Accessor<'_>,
    buffers: &'a [Option<Vec<u8>>],
    draco: bool,
) -> Result<Span<'a>, SceneError> {
    let i = acc.index();
    if acc.sparse().is_some() {
        return Err(err(name, format!("accessor {i} is sparse; sparse accessors are not supported")));
    }
    let Some(view) = acc.view() else {
        return Err(err(
            name,
            if draco {
                format!("accessor {i} has no buffer view (Draco-compressed, {DRACO}); Draco is not supported")
            } else {
                format!("accessor {i} has no buffer view")
            },
        ));
    };
    let elem = component_size(acc.data_type()) * dims(acc.dimensions());
    let stride = view.stride().unwrap_or(elem);
    if stride < elem {
        return Err(err(name, format!("accessor {i}: byteStride {stride} is below its element size {elem}")));
    }
    let Some(data) = &buffers[view.buffer().index()] else {
        return Err(err(name, format!("accessor {i}: its buffer was not loaded")));
    };
    let range = view.offset().checked_add(view.length()).filter(|&e| e <= data.len()).map(|e| view.offset()..e);
    let Some(range) = range else {
        return Err(err(
            name,
            format!(
                "buffer view {} passes the end of buffer {} ({} bytes)",
                view.index(),
                view.buffer().index(),
                data.len()
            ),
        ));
    };
    let data = &data[range];
    let count = acc.count();
    let need = if count == 0 {
        Some(acc.offset())
    } else {
        (count - 1).checked_mul(stride).and_then(|x| x.checked_add(elem)).and_then(|x| x.checked_add(acc.offset()))
    };
    if need.is_none_or(|n| n > data.len()) {
        return Err(err(
            name,
            format!("accessor {i}: {count} elements do not fit its buffer view ({} bytes)", data.len()),
        ));
    }
    Ok(Span { data: &data[acc.offset()..], stride, count, ty: acc.data_type() })
}

fn material(name: &str, m: &gltf::Material<'_>, warnings: &mut Warnings) -> Result<Material, SceneError> {
    let label = m.name().map_or_else(|| format!("material {}", m.index().unwrap_or(0)), ToString::to_string);
    let pbr = m.pbr_metallic_roughness();
    let base = pbr.base_color_factor();
    let emissive = m.emissive_factor();
    let strength = m.emissive_strength().unwrap_or(1.0);
    let (metallic, roughness) = (pbr.metallic_factor(), pbr.roughness_factor());
    let rgb = [f64::from(base[0]), f64::from(base[1]), f64::from(base[2])];
    if !rgb.iter().all(|x| (0.0..=1.0).contains(x)) {
        return Err(err(name, format!("{label:?}: baseColorFactor {rgb:?} is outside [0, 1]")));
    }
    let e = emissive.map(|x| f64::from(x) * f64::from(strength));
    if !e.iter().all(|x| (0.0..=Material::MAX_EMITTANCE).contains(x)) {
        return Err(err(
            name,
            format!(
                "{label:?}: emission {e:?} is outside [0, {:e}] (Material::MAX_EMITTANCE)",
                Material::MAX_EMITTANCE
            ),
        ));
    }
    let mirror = metallic == 1.0 && roughness == 0.0;
    let textured = pbr.base_color_texture().is_some() || m.emissive_texture().is_some();
    if !mirror && (metallic != 0.0 || roughness != 1.0)
        || textured
        || m.alpha_mode() != gltf::material::AlphaMode::Opaque
    {
        warnings.add("gltf-material-approximated", || {
            format!(
                "{name}: {label:?}: metallic {metallic}, roughness {roughness}{}: read as diffuse, untextured and opaque (only metallic 1 roughness 0, a mirror, is not)",
                if textured { ", textured" } else { "" }
            )
        });
    }
    Ok(Material { name: label, reflectance: rgb, emittance: e, mirror })
}

/// A node matrix (column-major `f32`) in `f64`.
fn matrix(m: [[f32; 4]; 4]) -> DMat4 {
    DMat4::from_cols_array_2d(&m.map(|c| c.map(f64::from)))
}

/// Parses a glTF or GLB file held in memory (`name` for messages);
/// `external(uri)` returns the bytes of an external buffer (or why not).
///
/// # Errors
/// [`SceneError::Obj`] naming the file, for the refusals listed in the
/// module's documentation, malformed JSON or GLB, accessors out of range,
/// bad values, or degenerate triangles; [`SceneError::TooLarge`] past
/// [`Limits`].
#[allow(clippy::too_many_lines)]
pub fn parse_gltf(
    name: &str,
    bytes: &[u8],
    mut external: impl FnMut(&str) -> Result<Vec<u8>, String>,
) -> Result<Scene, SceneError> {
    let raw = gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| err(name, format!("not glTF 2.0: {e}")))?;
    let blob = raw.blob;
    let root = raw.document.into_json();
    for ext in &root.extensions_required {
        if ext == DRACO {
            return Err(err(name, format!("requires {DRACO}: Draco-compressed meshes are not supported")));
        }
        if ext != "KHR_materials_emissive_strength" {
            return Err(err(name, format!("requires extension {ext}, which is not supported")));
        }
    }
    // gltf-json 1.4's validation indexes the accessors by each primitive's
    // attributes before it checks that they exist: checked here first.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(a) = prim.attributes.values().find(|a| a.value() >= root.accessors.len()) {
                return Err(err(name, format!("mesh {m} primitive {p}: accessor {} does not exist", a.value())));
            }
        }
    }
    let draco = root.extensions_used.iter().any(|e| e == DRACO);
    let doc = gltf::Document::from_json(root).map_err(|e| err(name, format!("invalid glTF: {e}")))?;
    let mut warnings = Warnings::default();
    // Buffers, only those that an accessor of a triangle primitive uses.
    let mut needed = vec![false; doc.buffers().len()];
    for mesh in doc.meshes() {
        for p in mesh.primitives() {
            for acc in p.get(&gltf::Semantic::Positions).into_iter().chain(p.indices()) {
                if let Some(v) = acc.view() {
                    needed[v.buffer().index()] = true;
                }
            }
        }
    }
    let mut buffers: Vec<Option<Vec<u8>>> = Vec::with_capacity(needed.len());
    for b in doc.buffers() {
        if !needed[b.index()] {
            buffers.push(None);
            continue;
        }
        let data = match b.source() {
            Source::Bin => blob.clone().ok_or_else(|| {
                err(name, format!("buffer {} is the GLB's binary chunk, which is missing", b.index()))
            })?,
            Source::Uri(uri) if uri.starts_with("data:") => {
                let Some((_, payload)) = uri.split_once(";base64,") else {
                    return Err(err(name, format!("buffer {}: only base64 data: URIs are read", b.index())));
                };
                base64(payload)
                    .ok_or_else(|| err(name, format!("buffer {}: bad base64 in its data: URI", b.index())))?
            }
            Source::Uri(uri) => external(uri).map_err(|m| err(name, format!("buffer {}: {m}", b.index())))?,
        };
        if data.len() < b.length() {
            return Err(err(
                name,
                format!("buffer {} has {} bytes, its byteLength says {}", b.index(), data.len(), b.length()),
            ));
        }
        buffers.push(Some(data));
    }
    let Some(gscene) = doc.default_scene().or_else(|| doc.scenes().next()) else {
        return Err(err(name, "no scene (a glTF with no triangles)"));
    };
    let mut scene = Scene::named(name);
    let mut mat_index: Vec<Option<usize>> = vec![None; doc.materials().len()];
    let mut camera: Option<(DVec3, DVec3, DVec3, f64)> = None;
    let mut stack: Vec<(gltf::Node<'_>, DMat4, usize)> = gscene.nodes().map(|n| (n, DMat4::IDENTITY, 0)).collect();
    stack.reverse();
    let mut visits = 0usize;
    let mut triangles = 0u64;
    let mut read: Vec<(String, [DVec3; 3], usize)> = Vec::new();
    while let Some((node, parent, depth)) = stack.pop() {
        visits += 1;
        if visits > MAX_NODE_VISITS || depth > MAX_DEPTH {
            return Err(err(
                name,
                format!("node tree deeper than {MAX_DEPTH} or over {MAX_NODE_VISITS} node visits (a cycle?)"),
            ));
        }
        let world = parent * matrix(node.transform().matrix());
        if !world.is_finite() {
            return Err(err(name, format!("node {}: its transform is not finite", node.index())));
        }
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child, world, depth + 1));
        }
        if camera.is_none()
            && let Some(c) = node.camera()
        {
            match c.projection() {
                gltf::camera::Projection::Perspective(p) => {
                    let eye = world.transform_point3(DVec3::ZERO);
                    let forward = world.transform_vector3(DVec3::NEG_Z);
                    let up = world.transform_vector3(DVec3::Y);
                    camera = Some((eye, forward, up, f64::from(p.yfov()).to_degrees()));
                }
                gltf::camera::Projection::Orthographic(_) => warnings.add("gltf-camera-ignored", || {
                    format!("{name}: camera {}: orthographic cameras are not used", c.index())
                }),
            }
        }
        let Some(mesh) = node.mesh() else { continue };
        let flip = world.determinant() < 0.0;
        let group = match (node.name(), mesh.name()) {
            (Some(n), Some(m)) => format!("{n}/{m}"),
            (Some(n), None) => format!("{n}/mesh{}", mesh.index()),
            (None, Some(m)) => format!("node{}/{m}", node.index()),
            (None, None) => format!("node{}/mesh{}", node.index(), mesh.index()),
        };
        for prim in mesh.primitives() {
            let pi = prim.index();
            let mode = prim.mode();
            if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
                warnings.add("gltf-primitive-ignored", || {
                    format!("{name}: {group}#{pi}: {mode:?} primitives are not surfaces; skipped")
                });
                continue;
            }
            let Some(pos) = prim.get(&gltf::Semantic::Positions) else {
                return Err(err(name, format!("{group}#{pi}: primitive has no POSITION")));
            };
            if pos.dimensions() != Dimensions::Vec3 || pos.data_type() != DataType::F32 {
                return Err(err(name, format!("{group}#{pi}: POSITION must be float VEC3")));
            }
            let ps = span(name, &pos, &buffers, draco)?;
            let idx = match prim.indices() {
                Some(a) => {
                    if a.dimensions() != Dimensions::Scalar
                        || !matches!(a.data_type(), DataType::U8 | DataType::U16 | DataType::U32)
                    {
                        return Err(err(name, format!("{group}#{pi}: indices must be unsigned integer scalars")));
                    }
                    Some(span(name, &a, &buffers, draco)?)
                }
                None => None,
            };
            let n = idx.as_ref().map_or(ps.count, |s| s.count);
            let tris = match mode {
                Mode::Triangles => n / 3,
                _ => n.saturating_sub(2),
            };
            triangles += tris as u64;
            Limits::check(name, triangles, triangles)?;
            let vertex = |k: usize| -> Result<DVec3, SceneError> {
                let i = match &idx {
                    Some(s) => s.get(k, 0) as usize,
                    None => k,
                };
                if i >= ps.count {
                    return Err(err(name, format!("{group}#{pi}: index {i} is out of range (0..{})", ps.count)));
                }
                let v = DVec3::new(ps.get(i, 0), ps.get(i, 1), ps.get(i, 2));
                if !v.is_finite() {
                    return Err(err(name, format!("{group}#{pi}: vertex {i} is not finite")));
                }
                Ok(world.transform_point3(v))
            };
            let m = match prim.material().index() {
                None => 0,
                Some(k) => match mat_index[k] {
                    Some(j) => j,
                    None => {
                        let j = scene.materials.len();
                        scene.materials.push(material(name, &prim.material(), &mut warnings)?);
                        mat_index[k] = Some(j);
                        j
                    }
                },
            };
            for t in 0..tris {
                let (a, b, c) = match mode {
                    Mode::Triangles => (3 * t, 3 * t + 1, 3 * t + 2),
                    Mode::TriangleStrip if t % 2 == 1 => (t + 1, t, t + 2),
                    Mode::TriangleStrip => (t, t + 1, t + 2),
                    _ => (0, t + 1, t + 2),
                };
                let mut tri = [vertex(a)?, vertex(b)?, vertex(c)?];
                if flip {
                    tri.swap(1, 2);
                }
                polygon::triangulate(&tri).map_err(|m| err(name, format!("{group}#{pi}: triangle {t} {m}")))?;
                read.push((format!("{group}#{pi}/{t}"), tri, m));
            }
        }
    }
    if read.is_empty() {
        return Err(err(name, "no triangles in the scene"));
    }
    let k = rescale_exponent(read.iter().flat_map(|r| r.1));
    if k != 0 {
        for r in &mut read {
            r.1 = r.1.map(|v| scale_by(v, k));
        }
        if let Some(c) = &mut camera {
            c.0 = scale_by(c.0, k);
        }
        warnings.add("rescaled", || {
            format!("{name}: coordinates multiplied by 2^{k} so that areas stay finite and non-zero in f64")
        });
    }
    scene.triangles.reserve(read.len());
    for (patch, tri, m) in read {
        scene.add_triangles(patch, &[tri], m);
    }
    if let Some((eye, forward, up, fov)) = camera {
        scene.camera = Some(
            Camera::look_at(eye, eye + forward, up, fov).map_err(|e| err(name, format!("the first camera: {e}")))?,
        );
    }
    scene.warnings = warnings.finish();
    scene.validate()?;
    Ok(scene)
}
