//! Mitsuba 3 scene files: the `scene.xml` that `render --export-scene`
//! writes ([`scene_xml`]), and reading that subset back ([`parse_mitsuba`]),
//! so a round trip gives the same triangles, materials and camera.
//!
//! The subset, written and read:
//! * `<shape type="obj">` or `"ply"` with `<string name="filename">`
//!   (relative to the XML's folder), an optional `flip_normals`, and one
//!   BSDF (inline or `<ref id>` to a top-level `<bsdf id>`);
//! * BSDFs `twosided` around `diffuse` (`reflectance` rgb or float:
//!   [`Material::reflectance`]) or `conductor` with `material` `none`
//!   (`specular_reflectance`: a mirror); a bare `diffuse` or `conductor`
//!   is read the same, since itgfx reflects on both sides;
//! * `<emitter type="area">` with `radiance` inside a shape:
//!   [`Material::emittance`] (itgfx's emission is one-sided as Mitsuba's);
//! * `<sensor type="perspective">` with `fov`, `fov_axis` (x, y, diagonal,
//!   smaller, larger; the film's `width` and `height` convert to the
//!   vertical field of view) and a `to_world` of one `lookat` or `matrix`:
//!   [`Scene::camera`];
//! * `<default name value>` parameters and `$name` references.
//!
//! Shape transforms, other shape and BSDF types are refused with one line;
//! integrators, samplers, films, filters and other emitters are read past
//! (other emitters with warning `mitsuba-element-ignored`).
//!
//! Each shape's file is read by its own reader (one patch per polygon, as
//! ever); the shape's BSDF and emitter replace any material the file names.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use glam::{DMat4, DVec3, DVec4};

use crate::camera::Camera;
use crate::obj::Warnings;
use crate::scene::{Material, Scene, SceneError};

/// Largest Mitsuba XML file read, in bytes.
pub const MAX_XML_BYTES: u64 = 16 << 20;

fn err(path: &str, message: impl Into<String>) -> SceneError {
    let m: String = message.into();
    SceneError::Obj { path: path.to_string(), message: m.replace(['\n', '\r'], " ") }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

fn triple(v: impl Into<[f64; 3]>) -> String {
    let [a, b, c] = v.into();
    format!("{a:?}, {b:?}, {c:?}")
}

/// Mitsuba 3 XML for a scene whose triangles of material `k` are in the
/// shape file `shapes[i].0` (OBJ or PLY, by extension, relative to the
/// XML) for `shapes[i].1 == k`: `twosided` `diffuse` or `conductor`
/// (mirrors), `area` emitters, a `perspective` sensor with `box` filter,
/// `independent` sampler of `spp` samples and the `path` integrator with
/// `max_depth` -1. Numbers are written exactly (shortest round-trip form).
#[must_use]
pub fn scene_xml(scene: &Scene, shapes: &[(String, usize)], camera: &Camera, size: (u32, u32), spp: u32) -> String {
    let mut x = String::new();
    let (lo, hi) = scene.bounds();
    let far = 4.0 * ((hi - lo).length() + (camera.eye - (lo + hi) * 0.5).length());
    let _ = writeln!(x, "<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    let _ = writeln!(
        x,
        "<!-- {}: written by the export-scene option of itgfx render -->",
        escape(&scene.name).replace("--", "- -")
    );
    let _ = writeln!(x, "<scene version=\"3.0.0\">");
    let _ = writeln!(
        x,
        "    <integrator type=\"path\">\n        <integer name=\"max_depth\" value=\"-1\"/>\n    </integrator>"
    );
    let _ = writeln!(x, "    <sensor type=\"perspective\">");
    let _ = writeln!(x, "        <string name=\"fov_axis\" value=\"y\"/>");
    let _ = writeln!(x, "        <float name=\"fov\" value=\"{:?}\"/>", camera.fov_y.to_degrees());
    let _ = writeln!(x, "        <float name=\"near_clip\" value=\"{:?}\"/>", far * 1e-6);
    let _ = writeln!(x, "        <float name=\"far_clip\" value=\"{far:?}\"/>");
    let _ = writeln!(
        x,
        "        <transform name=\"to_world\">\n            <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n        </transform>",
        triple(camera.eye),
        triple(camera.eye + camera.forward),
        triple(camera.up)
    );
    let _ = writeln!(
        x,
        "        <sampler type=\"independent\">\n            <integer name=\"sample_count\" value=\"{spp}\"/>\n        </sampler>"
    );
    let _ = writeln!(
        x,
        "        <film type=\"hdrfilm\">\n            <integer name=\"width\" value=\"{}\"/>\n            <integer name=\"height\" value=\"{}\"/>\n            <string name=\"pixel_format\" value=\"rgb\"/>\n            <rfilter type=\"box\"/>\n        </film>",
        size.0, size.1
    );
    let _ = writeln!(x, "    </sensor>");
    let mut ids: Vec<String> = Vec::new();
    for (file, k) in shapes {
        let m = &scene.materials[*k];
        let mut id = if m.name.is_empty() { format!("material-{k}") } else { m.name.clone() };
        if ids.contains(&id) {
            id = format!("{id}-{k}");
        }
        ids.push(id.clone());
        let kind = if file.to_ascii_lowercase().ends_with(".ply") { "ply" } else { "obj" };
        let _ = writeln!(x, "    <shape type=\"{kind}\" id=\"{}\">", escape(&id));
        let _ = writeln!(x, "        <string name=\"filename\" value=\"{}\"/>", escape(file));
        let _ = writeln!(x, "        <boolean name=\"face_normals\" value=\"true\"/>");
        let _ = writeln!(x, "        <bsdf type=\"twosided\">");
        if m.mirror {
            let _ = writeln!(
                x,
                "            <bsdf type=\"conductor\">\n                <string name=\"material\" value=\"none\"/>\n                <rgb name=\"specular_reflectance\" value=\"{}\"/>\n            </bsdf>",
                triple(m.reflectance)
            );
        } else {
            let _ = writeln!(
                x,
                "            <bsdf type=\"diffuse\">\n                <rgb name=\"reflectance\" value=\"{}\"/>\n            </bsdf>",
                triple(m.reflectance)
            );
        }
        let _ = writeln!(x, "        </bsdf>");
        if m.emittance.iter().any(|&e| e > 0.0) {
            let _ = writeln!(
                x,
                "        <emitter type=\"area\">\n            <rgb name=\"radiance\" value=\"{}\"/>\n        </emitter>",
                triple(m.emittance)
            );
        }
        let _ = writeln!(x, "    </shape>");
    }
    let _ = writeln!(x, "</scene>");
    x
}

/// Reads a Mitsuba 3 scene file; shape files are read relative to its folder.
///
/// # Errors
/// As [`parse_mitsuba`], and unreadable files.
pub fn load_mitsuba(path: &Path) -> Result<Scene, SceneError> {
    let bytes = crate::obj::read_limited(path, MAX_XML_BYTES)?;
    let shown = path.display().to_string();
    let text =
        std::str::from_utf8(&bytes).map_err(|e| err(&shown, format!("not UTF-8 text (byte {})", e.valid_up_to())))?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    parse_mitsuba(&shown, text, |ty, file| {
        let p = dir.join(file);
        if ty == "ply" { super::ply::load_ply(&p) } else { crate::obj::load_obj(&p) }
    })
}

/// The parsed `value` attributes of a node's children by `name`.
struct Values<'a, 'i> {
    path: &'a str,
    defaults: &'a HashMap<String, String>,
    node: roxmltree::Node<'a, 'i>,
}

impl<'a> Values<'a, '_> {
    fn raw(&self, n: roxmltree::Node<'_, '_>, attr: &str) -> Result<Option<String>, SceneError> {
        let Some(v) = n.attribute(attr) else { return Ok(None) };
        if let Some(p) = v.strip_prefix('$') {
            return self
                .defaults
                .get(p)
                .cloned()
                .map(Some)
                .ok_or_else(|| err(self.path, format!("${p}: no <default name=\"{p}\"> given")));
        }
        Ok(Some(v.to_string()))
    }

    fn child(&self, tags: &[&str], name: &str) -> Option<roxmltree::Node<'a, '_>> {
        self.node
            .children()
            .find(|c| c.is_element() && tags.contains(&c.tag_name().name()) && c.attribute("name") == Some(name))
    }

    fn string(&self, name: &str) -> Result<Option<String>, SceneError> {
        match self.child(&["string", "boolean", "integer", "float"], name) {
            Some(c) => self.raw(c, "value"),
            None => Ok(None),
        }
    }

    fn number(&self, name: &str) -> Result<Option<f64>, SceneError> {
        let Some(s) = self.string(name)? else { return Ok(None) };
        s.trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .map(Some)
            .ok_or_else(|| err(self.path, format!("{name}: {s:?} is not a finite number")))
    }

    fn colour(&self, name: &str) -> Result<Option<[f64; 3]>, SceneError> {
        let Some(c) = self.child(&["rgb", "float"], name) else {
            if let Some(c) = self.child(&["texture", "spectrum"], name) {
                return Err(err(
                    self.path,
                    format!("{name}: <{}> is not read, only <rgb> or <float>", c.tag_name().name()),
                ));
            }
            return Ok(None);
        };
        let s = self.raw(c, "value")?.ok_or_else(|| err(self.path, format!("{name}: no value")))?;
        let v = numbers(self.path, name, &s)?;
        match v.as_slice() {
            [a] => Ok(Some([*a; 3])),
            [a, b, c] => Ok(Some([*a, *b, *c])),
            _ => Err(err(self.path, format!("{name}: {s:?} needs 1 or 3 numbers"))),
        }
    }
}

fn numbers(path: &str, what: &str, s: &str) -> Result<Vec<f64>, SceneError> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|w| !w.is_empty())
        .map(|w| {
            w.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| err(path, format!("{what}: {w:?} is not a finite number")))
        })
        .collect()
}

fn point(path: &str, what: &str, s: Option<&str>) -> Result<DVec3, SceneError> {
    let s = s.ok_or_else(|| err(path, format!("lookat needs {what}")))?;
    match numbers(path, what, s)?.as_slice() {
        [a, b, c] => Ok(DVec3::new(*a, *b, *c)),
        _ => Err(err(path, format!("lookat {what} {s:?} needs 3 numbers"))),
    }
}

/// A BSDF node (after `<ref>`) as a material.
fn bsdf(
    path: &str,
    defaults: &HashMap<String, String>,
    node: roxmltree::Node<'_, '_>,
    named: &HashMap<String, roxmltree::Node<'_, '_>>,
    depth: usize,
) -> Result<Material, SceneError> {
    let node = if node.tag_name().name() == "ref" {
        let id = node.attribute("id").unwrap_or_default();
        *named.get(id).ok_or_else(|| err(path, format!("<ref id={id:?}>: no <bsdf id={id:?}> at the top level")))?
    } else {
        node
    };
    let v = Values { path, defaults, node };
    let name = node.attribute("id").unwrap_or_default().to_string();
    let ty = node.attribute("type").unwrap_or_default();
    let mut m = Material { name, reflectance: [0.5; 3], emittance: [0.0; 3], mirror: false };
    match ty {
        "twosided" if depth == 0 => {
            let inner: Vec<_> =
                node.children().filter(|c| c.is_element() && matches!(c.tag_name().name(), "bsdf" | "ref")).collect();
            let [inner] = inner.as_slice() else {
                return Err(err(
                    path,
                    format!("twosided BSDF {:?}: needs exactly one inner BSDF (one for both sides)", m.name),
                ));
            };
            let name = m.name;
            m = bsdf(path, defaults, *inner, named, depth + 1)?;
            if !name.is_empty() {
                m.name = name;
            }
        }
        "diffuse" => m.reflectance = v.colour("reflectance")?.unwrap_or([0.5; 3]),
        "conductor" => {
            let material = v.string("material")?.unwrap_or_else(|| "none".into());
            if material != "none" {
                return Err(err(
                    path,
                    format!("conductor material {material:?}: only \"none\" (an ideal mirror) is read"),
                ));
            }
            m.reflectance = v.colour("specular_reflectance")?.unwrap_or([1.0; 3]);
            m.mirror = true;
        }
        t => return Err(err(path, format!("BSDF type {t:?} is not read (only twosided, diffuse, conductor)"))),
    }
    if !m.reflectance.iter().all(|r| (0.0..=1.0).contains(r)) {
        return Err(err(path, format!("BSDF {:?}: reflectance {:?} is outside [0, 1]", m.name, m.reflectance)));
    }
    Ok(m)
}

/// The sensor's camera.
fn sensor(path: &str, defaults: &HashMap<String, String>, node: roxmltree::Node<'_, '_>) -> Result<Camera, SceneError> {
    let v = Values { path, defaults, node };
    if node.attribute("type") != Some("perspective") {
        return Err(err(
            path,
            format!("sensor type {:?}: only perspective is read", node.attribute("type").unwrap_or("")),
        ));
    }
    let fov = v.number("fov")?.ok_or_else(|| err(path, "perspective sensor without fov"))?;
    let (mut w, mut h) = (768.0, 576.0);
    if let Some(film) = node.children().find(|c| c.has_tag_name("film")) {
        let f = Values { path, defaults, node: film };
        w = f.number("width")?.unwrap_or(w);
        h = f.number("height")?.unwrap_or(h);
    }
    if !(w > 0.0 && h > 0.0) {
        return Err(err(path, "film width and height must be positive"));
    }
    let t = (fov.to_radians() / 2.0).tan();
    let axis = v.string("fov_axis")?.unwrap_or_else(|| "x".into());
    let ty = match axis.as_str() {
        "y" => t,
        "x" => t * h / w,
        "diagonal" => t * h / w.hypot(h),
        "smaller" => t * if w < h { h / w } else { 1.0 },
        "larger" => t * if w > h { h / w } else { 1.0 },
        a => return Err(err(path, format!("fov_axis {a:?} is not one of x, y, diagonal, smaller, larger"))),
    };
    let fov_y = if axis == "y" { fov } else { 2.0 * ty.atan().to_degrees() };
    let Some(tw) = node.children().find(|c| c.has_tag_name("transform") && c.attribute("name") == Some("to_world"))
    else {
        return Err(err(path, "sensor has no to_world transform"));
    };
    let ops: Vec<_> = tw.children().filter(roxmltree::Node::is_element).collect();
    let [op] = ops.as_slice() else {
        return Err(err(path, "sensor to_world: only one <lookat> or <matrix> is read"));
    };
    let (eye, target, up) = match op.tag_name().name() {
        "lookat" => (
            point(path, "origin", op.attribute("origin"))?,
            point(path, "target", op.attribute("target"))?,
            point(path, "up", op.attribute("up"))?,
        ),
        "matrix" => {
            let s = op.attribute("value").unwrap_or_default();
            let m = numbers(path, "matrix", s)?;
            let Ok(rows) = <[f64; 16]>::try_from(m.as_slice()) else {
                return Err(err(path, "sensor matrix needs 16 numbers"));
            };
            // Row-major in the file; the camera looks along +z with +y up.
            let m = DMat4::from_cols_array(&rows).transpose();
            let eye = (m * DVec4::new(0.0, 0.0, 0.0, 1.0)).truncate();
            (eye, eye + m.transform_vector3(DVec3::Z), m.transform_vector3(DVec3::Y))
        }
        o => return Err(err(path, format!("sensor to_world: <{o}> is not read (only lookat or matrix)"))),
    };
    Camera::look_at(eye, target, up, fov_y).map_err(|e| err(path, format!("sensor: {e}")))
}

/// Parses Mitsuba 3 XML (`name` for messages); `load_shape(type, filename)`
/// reads one shape's file (`type` is `obj` or `ply`).
///
/// # Errors
/// [`SceneError::Obj`] naming the file for XML errors, what the module's
/// documentation lists as refused, bad values, and no shapes; the shape
/// readers' errors.
#[allow(clippy::too_many_lines)]
pub fn parse_mitsuba(
    name: &str,
    text: &str,
    mut load_shape: impl FnMut(&str, &str) -> Result<Scene, SceneError>,
) -> Result<Scene, SceneError> {
    let doc = roxmltree::Document::parse(text).map_err(|e| err(name, format!("not XML: {e}")))?;
    let root = doc.root_element();
    if root.tag_name().name() != "scene" {
        return Err(err(name, format!("root element is <{}>, not <scene>", root.tag_name().name())));
    }
    let mut defaults: HashMap<String, String> = HashMap::new();
    let mut named: HashMap<String, roxmltree::Node<'_, '_>> = HashMap::new();
    for c in root.children().filter(roxmltree::Node::is_element) {
        match c.tag_name().name() {
            "default" => {
                if let (Some(n), Some(v)) = (c.attribute("name"), c.attribute("value")) {
                    defaults.insert(n.to_string(), v.to_string());
                }
            }
            "bsdf" => {
                if let Some(id) = c.attribute("id") {
                    named.insert(id.to_string(), c);
                }
            }
            _ => {}
        }
    }
    let mut warnings = Warnings::default();
    let mut scene = Scene::named(name);
    let mut shapes = 0;
    for c in root.children().filter(roxmltree::Node::is_element) {
        let tag = c.tag_name().name();
        match tag {
            "default" | "bsdf" | "integrator" => {}
            "sensor" => {
                if scene.camera.is_none() {
                    scene.camera = Some(sensor(name, &defaults, c)?);
                }
            }
            "shape" => {
                shapes += 1;
                let ty = c.attribute("type").unwrap_or_default();
                let id = c.attribute("id").map_or_else(|| format!("shape{shapes}"), ToString::to_string);
                if !matches!(ty, "obj" | "ply") {
                    return Err(err(name, format!("shape {id:?}: type {ty:?} is not read (only obj and ply)")));
                }
                let v = Values { path: name, defaults: &defaults, node: c };
                if c.children().any(|t| t.has_tag_name("transform")) {
                    return Err(err(name, format!("shape {id:?}: shape transforms are not read")));
                }
                let file = v.string("filename")?.ok_or_else(|| err(name, format!("shape {id:?} has no filename")))?;
                let flip = v.string("flip_normals")?.is_some_and(|s| s == "true");
                let bsdfs: Vec<_> =
                    c.children().filter(|b| b.is_element() && matches!(b.tag_name().name(), "bsdf" | "ref")).collect();
                let mut m = match bsdfs.as_slice() {
                    [] => Material { name: String::new(), reflectance: [0.5; 3], emittance: [0.0; 3], mirror: false },
                    [b] => bsdf(name, &defaults, *b, &named, 0)?,
                    _ => return Err(err(name, format!("shape {id:?} has more than one BSDF"))),
                };
                for e in c.children().filter(|e| e.has_tag_name("emitter")) {
                    if e.attribute("type") != Some("area") {
                        return Err(err(
                            name,
                            format!("shape {id:?}: emitter {:?}: only area is read", e.attribute("type").unwrap_or("")),
                        ));
                    }
                    let ev = Values { path: name, defaults: &defaults, node: e };
                    m.emittance = ev.colour("radiance")?.unwrap_or([1.0; 3]);
                    if !m.emittance.iter().all(|x| (0.0..=Material::MAX_EMITTANCE).contains(x)) {
                        return Err(err(
                            name,
                            format!(
                                "shape {id:?}: radiance {:?} is outside [0, {:e}] (Material::MAX_EMITTANCE)",
                                m.emittance,
                                Material::MAX_EMITTANCE
                            ),
                        ));
                    }
                }
                if m.name.is_empty() {
                    m.name.clone_from(&id);
                }
                let sub = load_shape(ty, &file)?;
                if sub.sphere.is_some() {
                    return Err(err(name, format!("shape {id:?}: {file:?} is not a mesh")));
                }
                scene.warnings.extend(sub.warnings.iter().cloned());
                let k = scene.materials.len();
                scene.materials.push(m);
                let mut start = 0;
                while start < sub.triangles.len() {
                    let p = sub.triangle_patch[start];
                    let mut end = start;
                    while end < sub.triangles.len() && sub.triangle_patch[end] == p {
                        end += 1;
                    }
                    let mut tris = sub.triangles[start..end].to_vec();
                    if flip {
                        for t in &mut tris {
                            t.swap(1, 2);
                        }
                    }
                    scene.add_triangles(format!("{id}/{}", sub.patches[p as usize].name), &tris, k);
                    start = end;
                }
            }
            "emitter" | "texture" | "medium" => warnings.add("mitsuba-element-ignored", || {
                format!("{name}: <{tag} type={:?}> is not read", c.attribute("type").unwrap_or(""))
            }),
            t => return Err(err(name, format!("<{t}> at the top level is not read"))),
        }
    }
    if scene.triangles.is_empty() {
        return Err(err(name, "no shapes"));
    }
    // The unused default material of Scene::named goes: shapes bring their own.
    scene.materials.remove(0);
    for p in &mut scene.patches {
        p.material -= 1;
    }
    let mut w = warnings.finish();
    scene.warnings.append(&mut w);
    scene.validate()?;
    Ok(scene)
}
