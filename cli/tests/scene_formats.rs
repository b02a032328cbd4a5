//! Scene files other than OBJ (issue 25): the same mesh as OBJ, binary PLY
//! and GLB gives the same scene and viewpoint channels; a glTF furnace
//! renders to its closed-form radiance; `render --export-scene`'s
//! `scene.xml` reads back to the same triangles, materials and camera; and
//! each refused file is one line on stderr and exit 2.

mod common;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use glam::DVec3;
use itgfx_backends::formats;
use itgfx_backends::render::views::default_camera;
use itgfx_backends::scene::{Scene, built_in};

fn itgfx(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_itgfx")).args(args).output().expect("run itgfx")
}

fn dir(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("itgfx-scene-formats-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn json(args: &[&str]) -> serde_json::Value {
    let out = itgfx(args);
    assert!(out.status.success(), "itgfx {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    let mut v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let o = v.as_object_mut().unwrap();
    for k in ["seconds", "scene", "mesh", "wrote"] {
        o.remove(k);
    }
    o.retain(|k, _| !k.contains("per_s") && !k.ends_with("seconds"));
    v
}

/// Exit 2 with one line on stderr containing `what`.
fn refused(args: &[&str], what: &str) {
    let out = itgfx(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "itgfx {args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(what), "itgfx {args:?}: wanted {what:?} in {err}");
}

/// The triangles of a scene with coordinates rounded to `f32`, which GLB
/// stores exactly.
fn soup(scene: &Scene) -> Vec<[[f32; 3]; 3]> {
    scene.triangles.iter().map(|t| t.map(|v| v.as_vec3().to_array())).collect()
}

fn write_obj(tris: &[[[f32; 3]; 3]]) -> String {
    let mut o = String::new();
    for t in tris {
        for v in t {
            let _ = writeln!(o, "v {:?} {:?} {:?}", f64::from(v[0]), f64::from(v[1]), f64::from(v[2]));
        }
    }
    for i in 0..tris.len() {
        let _ = writeln!(o, "f {} {} {}", 3 * i + 1, 3 * i + 2, 3 * i + 3);
    }
    o
}

/// Binary PLY, little or big endian: vertices as `double` with an extra
/// `nx` property (ignored with a note) and polygon faces as `uchar`/`int` lists.
fn write_ply(verts: &[[f64; 3]], faces: &[Vec<u32>], big: bool) -> Vec<u8> {
    let mut b = format!(
        "ply\nformat binary_{}_endian 1.0\ncomment test\nelement vertex {}\nproperty double x\nproperty double y\n\
         property double z\nproperty float nx\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        if big { "big" } else { "little" },
        verts.len(),
        faces.len()
    )
    .into_bytes();
    let put = |bytes: &mut Vec<u8>, mut x: Vec<u8>| {
        if big {
            x.reverse();
        }
        bytes.extend_from_slice(&x);
    };
    for v in verts {
        for c in v {
            put(&mut b, c.to_le_bytes().to_vec());
        }
        put(&mut b, 7.5f32.to_le_bytes().to_vec());
    }
    for f in faces {
        b.push(u8::try_from(f.len()).unwrap());
        for &i in f {
            put(&mut b, (i as i32).to_le_bytes().to_vec());
        }
    }
    b
}

fn soup_ply(tris: &[[[f32; 3]; 3]], big: bool) -> Vec<u8> {
    let verts: Vec<[f64; 3]> = tris.iter().flatten().map(|v| v.map(f64::from)).collect();
    let faces: Vec<Vec<u32>> = (0..tris.len() as u32).map(|i| vec![3 * i, 3 * i + 1, 3 * i + 2]).collect();
    write_ply(&verts, &faces, big)
}

/// A glTF JSON document for one mesh node of `tris` (non-indexed when
/// `indexed` is false), its buffer `uri` (`None`: the GLB chunk), plus
/// `extra` JSON fields and `node_extra` node fields.
fn gltf_json(tris: &[[[f32; 3]; 3]], indexed: bool, uri: Option<&str>, extra: &str) -> (String, Vec<u8>) {
    let mut bin = Vec::new();
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for v in tris.iter().flatten() {
        for k in 0..3 {
            bin.extend_from_slice(&v[k].to_le_bytes());
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    let pos_len = bin.len();
    let n = 3 * tris.len();
    if indexed {
        for i in 0..n as u32 {
            bin.extend_from_slice(&i.to_le_bytes());
        }
    }
    let uri = uri.map_or(String::new(), |u| format!(",\"uri\":\"{u}\""));
    let (indices, views, accessors) = if indexed {
        (
            ",\"indices\":1",
            format!(
                "{{\"buffer\":0,\"byteLength\":{pos_len}}},{{\"buffer\":0,\"byteOffset\":{pos_len},\"byteLength\":{}}}",
                4 * n
            ),
            format!(",{{\"bufferView\":1,\"componentType\":5125,\"count\":{n},\"type\":\"SCALAR\"}}"),
        )
    } else {
        ("", format!("{{\"buffer\":0,\"byteLength\":{pos_len}}}"), String::new())
    };
    let doc = format!(
        "{{\"asset\":{{\"version\":\"2.0\"}},\"scene\":0,\"scenes\":[{{\"nodes\":[0]}}],\"nodes\":[{{\"mesh\":0}}],\
         \"meshes\":[{{\"primitives\":[{{\"attributes\":{{\"POSITION\":0}}{indices}}}]}}],\
         \"buffers\":[{{\"byteLength\":{}{uri}}}],\"bufferViews\":[{views}],\
         \"accessors\":[{{\"bufferView\":0,\"componentType\":5126,\"count\":{n},\"type\":\"VEC3\",\"min\":{lo:?},\"max\":{hi:?}}}{accessors}]{extra}}}",
        bin.len()
    );
    (doc, bin)
}

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b);
    out
}

fn base64(data: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in data.chunks(3) {
        let n =
            (u32::from(c[0]) << 16) | (u32::from(*c.get(1).unwrap_or(&0)) << 8) | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                out.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// The scene channel (`complexity`) and viewpoint channel (`viewpoints`)
/// of a scene file, without names and times.
fn channels(file: &Path) -> (serde_json::Value, serde_json::Value) {
    let c = json(&["complexity", s(file), "--lines", "20000", "--seed", "5", "--json"]);
    let v = json(&["viewpoints", s(file), "--viewpoints", "12", "--estimator", "grid", "--resolution", "32", "--json"]);
    assert!(c["I_S"].as_f64().unwrap() > 0.0 && v["I_VO"].as_f64().unwrap() > 0.0, "{c} {v}");
    (c, v)
}

/// The same triangles as OBJ, binary PLY (both byte orders) and GLB
/// (indexed and not) in `d`, named `base.*`.
fn write_all(d: &Path, base: &str, tris: &[[[f32; 3]; 3]]) -> [PathBuf; 5] {
    let p = |e: &str| d.join(format!("{base}{e}"));
    std::fs::write(p(".obj"), write_obj(tris)).unwrap();
    std::fs::write(p(".ply"), soup_ply(tris, false)).unwrap();
    std::fs::write(p("-be.ply"), soup_ply(tris, true)).unwrap();
    let (j, bin) = gltf_json(tris, true, None, "");
    std::fs::write(p(".glb"), glb(&j, &bin)).unwrap();
    let (j, flat) = gltf_json(tris, false, None, "");
    std::fs::write(p("-flat.glb"), glb(&j, &flat)).unwrap();
    [p(".obj"), p(".ply"), p("-be.ply"), p(".glb"), p("-flat.glb")]
}

#[test]
fn obj_ply_and_glb_give_the_same_channels() {
    let d = dir("same");
    // Built-ins exported to each format, coordinates rounded to f32 (GLB's):
    // an enclosure with objects (the scene channel's natural input) and an
    // object seen from outside (the viewpoint channel's).
    for name in ["cornell-box", "torus:12,8"] {
        let [obj, rest @ ..] = write_all(&d, name, &soup(&built_in(name).unwrap()));
        let want = channels(&obj);
        for f in rest {
            assert_eq!(channels(&f), want, "{} against {}", f.display(), obj.display());
        }
    }
    // A real mesh: the file itself against a binary PLY of the same
    // polygons (quads and triangles, triangulated alike), and its triangles
    // (rounded to f32) as OBJ against GLB.
    // From the shared data beside the workspace (a missing copy fails).
    let mesh = common::shared_mesh("suzanne.obj");
    let text = std::fs::read_to_string(&mesh).unwrap();
    let mut verts = Vec::new();
    let mut faces = Vec::new();
    for l in text.lines() {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.first() {
            Some(&"v") => verts.push([1, 2, 3].map(|k| w[k].parse::<f64>().unwrap())),
            Some(&"f") => {
                faces.push(w[1..].iter().map(|x| x.split('/').next().unwrap().parse::<u32>().unwrap() - 1).collect())
            }
            _ => {}
        }
    }
    assert!(faces.iter().any(|f: &Vec<u32>| f.len() == 4), "suzanne has quads");
    std::fs::write(d.join("suzanne.ply"), write_ply(&verts, &faces, true)).unwrap();
    assert_eq!(channels(&d.join("suzanne.ply")), channels(&mesh), "suzanne: PLY against OBJ");
    let tris = soup(&formats::load(&mesh).unwrap());
    std::fs::write(d.join("suzanne-t.obj"), write_obj(&tris)).unwrap();
    let (j, bin) = gltf_json(&tris, true, None, "");
    std::fs::write(d.join("suzanne.glb"), glb(&j, &bin)).unwrap();
    assert_eq!(channels(&d.join("suzanne.glb")), channels(&d.join("suzanne-t.obj")), "suzanne: GLB against OBJ");
}

/// The inside of the unit cube as triangles facing inwards.
fn inside_cube() -> Vec<[[f32; 3]; 3]> {
    let mut s = Scene::named("cube");
    s.add_box("c", DVec3::ZERO, DVec3::ONE, 1, true, 0);
    soup(&s)
}

#[test]
fn gltf_furnace_renders_to_two() {
    let d = dir("furnace");
    // Emission 1 (0.5 x strength 2), reflectance 0.5: L = E / (1 - rho) = 2.
    let tris = inside_cube();
    let (j, bin) =
        gltf_json(&tris, true, Some(&format!("data:application/octet-stream;base64,{}", base64(&tris_bin(&tris)))), "");
    let _ = bin;
    let j = j.replace(
        "\"nodes\":[{\"mesh\":0}]",
        "\"nodes\":[{\"children\":[1,2]},{\"mesh\":0},{\"camera\":0,\"translation\":[0.5,0.5,0.5],\"rotation\":[0,0.7071068,0,0.7071068]}],\
         \"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":1.2,\"znear\":0.01}}],\
         \"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5,1],\"metallicFactor\":0,\"roughnessFactor\":1},\
         \"emissiveFactor\":[0.5,0.5,0.5],\"extensions\":{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":2}}}],\
         \"extensionsUsed\":[\"KHR_materials_emissive_strength\"]",
    );
    let j = j.replace("\"attributes\":{\"POSITION\":0}", "\"attributes\":{\"POSITION\":0},\"material\":0");
    let f = d.join("furnace.gltf");
    std::fs::write(&f, &j).unwrap();
    let v = json(&["render", s(&f), "--size", "16x16", "--spp", "32", "--out", s(&d.join("out")), "--json"]);
    for (k, want) in [0.5, 0.5, 0.5].iter().enumerate() {
        assert!((v["camera_eye"][k].as_f64().unwrap() - want).abs() < 1e-6, "the file's camera: {v}");
    }
    // Rotated a quarter turn about y: looking along -x.
    assert!((v["camera_forward"][0].as_f64().unwrap() + 1.0).abs() < 1e-6, "{v}");
    assert!((v["camera_fov_y"].as_f64().unwrap() - 1.2f64.to_degrees()).abs() < 1e-4, "{v}");
    for c in v["mean_radiance"].as_array().unwrap() {
        let c = c.as_f64().unwrap();
        assert!((c / 2.0 - 1.0).abs() < 0.02, "furnace radiance {c}, want 2 within 2%: {v}");
    }
    // radiosity reads the same file (and its camera), and writes mesh.ply,
    // which the PLY reader takes back (its radiosity and colour properties
    // ignored with a note).
    let out = d.join("rad");
    let r = json(&["radiosity", s(&f), "--size", "16", "--out", s(&out), "--json"]);
    assert!((r["balance"].as_f64().unwrap() - 1.0).abs() < 0.01, "{r}");
    let c = json(&["complexity", s(&out.join("mesh.ply")), "--lines", "2000", "--json"]);
    assert_eq!(c["patches"], r["elements"], "{c}");
    refused(&["radiosity", s(&f), "--camera", "1,2,3"], "--camera");
}

/// The positions and `u32` indices as [`gltf_json`] lays them out.
fn tris_bin(tris: &[[[f32; 3]; 3]]) -> Vec<u8> {
    let mut b: Vec<u8> = tris.iter().flatten().flatten().flat_map(|x| x.to_le_bytes()).collect();
    for i in 0..3 * tris.len() as u32 {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

#[test]
fn export_scene_xml_reads_back_the_same_scene() {
    for name in ["cornell-box", "mirror-room"] {
        let d = dir(&format!("xml-{name}"));
        let out = d.join("out");
        json(&["render", name, "--size", "8x8", "--spp", "1", "--out", s(&out), "--export-scene", "--json"]);
        let back = formats::load(&out.join("scene.xml")).unwrap();
        let orig = built_in(name).unwrap();
        // Triangles grouped by material in the export, in order within each.
        let mut want: Vec<(usize, [DVec3; 3])> = orig
            .triangles
            .iter()
            .enumerate()
            .map(|(t, tri)| (orig.patches[orig.triangle_patch[t] as usize].material, *tri))
            .collect();
        want.sort_by_key(|w| w.0);
        assert_eq!(back.triangles.len(), want.len(), "{name}");
        for (t, (m, tri)) in want.iter().enumerate() {
            assert_eq!(back.triangles[t], *tri, "{name}: triangle {t}");
            let (a, b) = (&orig.materials[*m], &back.materials[back.patches[back.triangle_patch[t] as usize].material]);
            assert_eq!(
                (a.reflectance, a.emittance, a.mirror, &a.name),
                (b.reflectance, b.emittance, b.mirror, &b.name),
                "{name}"
            );
        }
        assert!(orig.materials.iter().any(|m| m.emittance.iter().any(|&e| e > 0.0)));
        let (a, b) = (default_camera(&orig), back.camera.expect("the sensor's camera"));
        for (x, y) in [(a.eye, b.eye), (a.forward, b.forward), (a.up, b.up), (a.right, b.right)] {
            assert!((x - y).length() < 1e-12, "{name}: camera {a:?} read back as {b:?}");
        }
        assert!((a.fov_y - b.fov_y).abs() < 1e-12);
        // And it renders the same image mean through the binary.
        let r1 = json(&["render", name, "--size", "8x8", "--spp", "4", "--out", s(&d.join("a")), "--json"]);
        let r2 = json(&[
            "render",
            s(&out.join("scene.xml")),
            "--size",
            "8x8",
            "--spp",
            "4",
            "--out",
            s(&d.join("b")),
            "--json",
        ]);
        assert_eq!(r1["mean_radiance"], r2["mean_radiance"], "{name}");
    }
}

#[test]
fn ply_headers_that_lie_and_other_bad_ply_are_one_line() {
    let d = dir("badply");
    let put = |n: &str, b: &[u8]| {
        let p = d.join(n);
        std::fs::write(&p, b).unwrap();
        p
    };
    let tri = [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]];
    let good = soup_ply(&tri, false);
    let ok = put("ok.ply", &good);
    json(&["complexity", s(&ok), "--lines", "1000", "--json"]);
    // Claims four billion vertices in a file of a few hundred bytes.
    let text = String::from_utf8_lossy(&good).replace("element vertex 3", "element vertex 4000000000");
    let lie = put("lie.ply", text.as_bytes());
    refused(&["complexity", s(&lie)], "at least");
    let text = String::from_utf8_lossy(&good).replace("element face 1", "element face 900000000");
    refused(&["viewpoints", s(&put("lie2.ply", text.as_bytes()))], "at least");
    refused(&["render", s(&put("ascii.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")), "--out", s(&d)], "out of range");
    refused(&["complexity", s(&put("trunc.ply", &good[..good.len() - 3]))], "at least");
    let ascii = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n";
    refused(&["complexity", s(&put("trunc-ascii.ply", ascii))], "file ends");
    refused(&["complexity", s(&put("noheader.ply", b"ply\nformat ascii 1.0\nelement vertex 3\n"))], "end_header");
    // Wrong extension, found by its magic.
    let p = put("mesh.dat", &good);
    json(&["complexity", s(&p), "--lines", "1000", "--json"]);
}

#[test]
fn refused_gltf_files_are_one_line() {
    let d = dir("badgltf");
    let tris = inside_cube();
    let data = tris_bin(&tris);
    let put = |n: &str, b: &[u8]| {
        let p = d.join(n);
        std::fs::write(&p, b).unwrap();
        p
    };
    // External buffer beside the file: read.
    put("cube.bin", &data);
    let (j, _) = gltf_json(&tris, true, Some("cube.bin"), "");
    json(&["complexity", s(&put("ext.gltf", j.as_bytes())), "--lines", "1000", "--json"]);
    let (j, _) = gltf_json(&tris, true, Some("missing.bin"), "");
    refused(&["complexity", s(&put("missing.gltf", j.as_bytes()))], "missing.bin");
    let (j, _) = gltf_json(&tris, true, Some("../cube.bin"), "");
    refused(&["complexity", s(&put("outside.gltf", j.as_bytes()))], "outside the file's folder");
    let (j, _) = gltf_json(&tris, true, Some("/etc/passwd"), "");
    refused(&["render", s(&put("absolute.gltf", j.as_bytes())), "--out", s(&d)], "outside the file's folder");
    let (j, bin) = gltf_json(&tris, true, None, "");
    let sparse = j.replacen(
        "\"type\":\"VEC3\"",
        "\"type\":\"VEC3\",\"sparse\":{\"count\":1,\"indices\":{\"bufferView\":1,\"componentType\":5125},\"values\":{\"bufferView\":0}}",
        1,
    );
    refused(&["viewpoints", s(&put("sparse.glb", &glb(&sparse, &bin)))], "sparse");
    let (j, bin) = gltf_json(
        &tris,
        true,
        None,
        ",\"extensionsUsed\":[\"KHR_draco_mesh_compression\"],\"extensionsRequired\":[\"KHR_draco_mesh_compression\"]",
    );
    refused(&["simplify", s(&put("draco.glb", &glb(&j, &bin))), "--out", s(&d), "--target", "50%"], "Draco");
    let (j, bin) = gltf_json(&tris, true, None, "");
    let points = j.replace("\"attributes\":{\"POSITION\":0}", "\"attributes\":{\"POSITION\":0},\"mode\":0");
    refused(&["complexity", s(&put("points.glb", &glb(&points, &bin)))], "no triangles");
    let mut short = glb(&j, &bin);
    short.truncate(short.len() - 40);
    refused(&["complexity", s(&put("short.glb", &short))], "short.glb");
    refused(&["complexity", s(&put("junk.gltf", b"{\"asset\":"))], "junk.gltf");
}

#[test]
fn ascii_ply_polygons_match_obj_and_extra_properties_give_one_note() {
    use itgfx_backends::formats::ply::parse_ply;
    use itgfx_backends::obj::parse_obj;
    // A concave L-shaped hexagon and a quad, with colours and an extra element.
    let ply = "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nelement vertex 8\r\nproperty float x\r\nproperty float y\r\n\
               property float z\r\nproperty uchar red\r\nelement face 2\r\nproperty list uchar int vertex_indices\r\n\
               property uchar green\r\nelement edge 1\r\nproperty int vertex1\r\nproperty int vertex2\r\nend_header\r\n\
               0 0 0 1\n2 0 0 1\n2 1 0 1\n1 1 0 1\n1 2 0 1\n0 2 0 1\n0 0 1 1\n2 0 1 1\n6 0 1 2 3 4 5 9\n4 0 6 7 1 9\n0 1\n";
    let obj = "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 1\nv 2 0 1\nf 1 2 3 4 5 6\nf 1 7 8 2\n";
    let a = parse_ply("t.ply", ply.as_bytes()).unwrap();
    let b = parse_obj("t.obj", obj.as_bytes(), |_| unreachable!()).unwrap();
    assert_eq!(a.triangles, b.triangles);
    assert_eq!(a.triangle_patch, b.triangle_patch);
    assert_eq!(a.areas(), b.areas());
    assert_eq!(a.patches.len(), 2);
    assert_eq!(a.warnings.len(), 1, "{:?}", a.warnings);
    for w in ["vertex.red", "face.green", "edge.vertex1"] {
        assert!(a.warnings[0].contains(w), "{:?}", a.warnings);
    }
    // Same file in binary: equal triangles.
    let verts: Vec<[f64; 3]> = obj
        .lines()
        .filter(|l| l.starts_with("v "))
        .map(|l| {
            let w: Vec<f64> = l[2..].split(' ').map(|x| x.parse().unwrap()).collect();
            [w[0], w[1], w[2]]
        })
        .collect();
    let bin = write_ply(&verts, &[vec![0, 1, 2, 3, 4, 5], vec![0, 6, 7, 1]], false);
    assert_eq!(parse_ply("t.ply", &bin).unwrap().triangles, a.triangles);
    // Lies and bad values, each one line.
    for (text, what) in [
        (ply.replace("element vertex 8", "element vertex 80000000"), "at least"),
        (ply.replace("format ascii 1.0", "format ascii 2.0"), "version"),
        (ply.replace("6 0 1 2 3 4 5 9", "6 0 1 2.5 3 4 5 9"), "not an integer"),
        (ply.replace("2 1 0 1", "2 nan 0 1"), "not finite"),
        (ply.replace("6 0 1 2 3 4 5 9", "2 0 1 9"), "needs at least 3"),
        (ply.replace("property float x\r\n", ""), "no scalar property x"),
    ] {
        let e = parse_ply("t.ply", text.as_bytes()).unwrap_err().to_string();
        assert!(e.contains(what) && !e.contains('\n'), "{what}: {e}");
    }
}

/// Seeded mutations of valid files (bytes overwritten, bit flips, cuts,
/// digits changed) through the PLY and glTF readers in-process: each is a
/// scene or a one-line error, never a panic. The fuzz targets do the same
/// without a seed file; this runs in every test run.
#[test]
fn mutated_files_are_scenes_or_one_line_errors() {
    use itgfx_backends::formats::gltf::{parse_gltf, relative_uri};
    use itgfx_backends::formats::ply::parse_ply;
    let tris = inside_cube();
    let (j, bin) = gltf_json(&tris, true, None, "");
    let glb_bytes = glb(&j, &bin);
    let (text, _) = gltf_json(&tris, true, Some("b.bin"), ",\"materials\":[{\"emissiveFactor\":[1,1,1]}]");
    let text = text.replace("\"attributes\":{\"POSITION\":0}", "\"attributes\":{\"POSITION\":0},\"material\":0");
    let ascii = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
                 element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";
    let inputs: [(&str, Vec<u8>); 4] = [
        ("glb", glb_bytes),
        ("gltf", text.into_bytes()),
        ("ply", soup_ply(&tris, true)),
        ("ply", ascii.as_bytes().to_vec()),
    ];
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    // ITGFX_MUTATIONS raises the count per input for a longer local run.
    let n: usize = std::env::var("ITGFX_MUTATIONS").ok().and_then(|v| v.parse().ok()).unwrap_or(1500);
    let (mut ok, mut refused) = (0, 0);
    for (kind, base) in &inputs {
        for _ in 0..n {
            let mut b = base.clone();
            for _ in 0..1 + next() % 4 {
                let i = (next() % b.len() as u64) as usize;
                match next() % 5 {
                    0 => b[i] = next() as u8,
                    1 => b[i] ^= 1 << (next() % 8),
                    2 => b.truncate(i.max(1)),
                    3 if b[i].is_ascii_digit() => b[i] = b'0' + (next() % 10) as u8,
                    _ => b[i] = b"9-.e0 \n"[(next() % 7) as usize],
                }
            }
            let r = if *kind == "ply" {
                parse_ply("m.ply", &b)
            } else {
                parse_gltf("m.gltf", &b, |uri| relative_uri(uri).map(|_| bin.clone()))
            };
            match r {
                Ok(s) => {
                    s.validate().unwrap();
                    ok += 1;
                }
                Err(e) => {
                    assert!(!e.to_string().contains('\n'), "{e}");
                    refused += 1;
                }
            }
        }
    }
    assert!(ok > 100 && refused > 100, "{ok} read, {refused} refused");
}
