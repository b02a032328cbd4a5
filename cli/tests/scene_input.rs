//! Scene input through the binary (issue 9): each bad OBJ, MTL or built-in
//! spec is one line on stderr and exit 2, or loads with the right numbers.

use std::path::PathBuf;
use std::process::Command;

mod common;
use common::itgfx;

fn tmp(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("itgfx-scene-input-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn json(args: &[&str]) -> serde_json::Value {
    let out = itgfx(args);
    assert!(out.status.success(), "itgfx {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    let mut v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v.as_object_mut().unwrap().remove("seconds");
    v.as_object_mut().unwrap().remove("scene");
    v
}

/// Exit 2 with one line on stderr containing `what`.
fn refused(args: &[&str], what: &str) {
    let out = itgfx(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "itgfx {args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(what), "itgfx {args:?}: {err}");
}

fn path(p: &std::path::Path) -> &str {
    p.to_str().unwrap()
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 4 2\nf 1 3 4\nf 2 4 3\n";

#[test]
fn byte_order_mark_gives_the_same_channel() {
    let plain = tmp("plain.obj", TRI);
    let bom = tmp("bom.obj", &format!("\u{feff}{TRI}"));
    let a = json(&["complexity", path(&plain), "--lines", "2000", "--json"]);
    assert_eq!(a["patches"], 4);
    assert_eq!(a, json(&["complexity", path(&bom), "--lines", "2000", "--json"]));
}

#[test]
fn offset_and_scaled_tetrahedra_give_the_same_channel() {
    let t = |s: f64, o: f64| {
        let v = [[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]];
        let mut text = String::new();
        for p in v {
            text += &format!("v {:e} {:e} {:e}\n", p[0] * s + o, p[1] * s + o, p[2] * s + o);
        }
        text + "f 1 3 2\nf 1 4 3\nf 1 2 4\nf 2 3 4\n"
    };
    let origin = json(&["complexity", path(&tmp("t0.obj", &t(1.0, 0.0))), "--lines", "3000", "--json"]);
    // Offset by 1e8: the tracer's normalised f32 coordinates are the same bits.
    let far = json(&["complexity", path(&tmp("t8.obj", &t(1.0, 1e8))), "--lines", "3000", "--json"]);
    assert_eq!(far, origin);
    // Scaled by 1e39 or 1e300 (not powers of two): the same lines hit the
    // same patches; areas agree to f64 rounding.
    for (name, s) in [("t39.obj", 1e39), ("t300.obj", 1e300)] {
        let got = json(&["complexity", path(&tmp(name, &t(s, 0.0))), "--lines", "3000", "--json"]);
        for (k, v) in origin.as_object().unwrap() {
            match (v.as_f64(), v.is_u64()) {
                (Some(a), false) => {
                    let b = got[k].as_f64().unwrap();
                    assert!((a - b).abs() <= 1e-12 * a.abs().max(1.0), "{name} {k}: {a} vs {b}");
                }
                _ => assert_eq!(&got[k], v, "{name} {k}"),
            }
        }
    }
}

#[test]
fn bad_polygons_and_materials_are_one_line_errors() {
    let quad = "v 0 0 0\nv 2 2 0\nv 2 0 0\nv 0 1 0\n";
    for (name, text, what) in [
        ("bowtie.obj", format!("{quad}f 1 2 3 4\n"), "line 5: face 1 is self-intersecting"),
        ("nomtl.obj", format!("mtllib gone.mtl\n{TRI}"), "gone.mtl: mtllib gone.mtl:"),
        ("zero.obj", format!("mtllib /dev/zero\n{TRI}"), "mtllib /dev/zero: is a device, not a regular file"),
        ("usemtl.obj", format!("usemtl none\n{TRI}"), "line 1: usemtl \"none\": no such material"),
    ] {
        let p = tmp(name, &text);
        refused(&["complexity", path(&p), "--lines", "10000"], what);
    }
    let p = tmp("red.obj", &format!("mtllib red.mtl\nusemtl red\n{TRI}"));
    tmp("red.mtl", "newmtl red\nKd 1.2 0 0\n");
    refused(&["complexity", path(&p), "--lines", "10000"], "red.mtl: line 2: Kd value 1.2 is outside [0, 1]");
}

#[test]
fn concave_and_non_planar_faces_load_with_a_warning_for_the_second() {
    // A closed prism over a concave arrow: the caps are concave pentagons.
    let pts = [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (1.0, 0.2), (0.0, 2.0)];
    let mut text = String::new();
    for z in [0.0, 1.0] {
        for (x, y) in pts {
            text += &format!("v {x} {y} {z}\n");
        }
    }
    text += "f 5 4 3 2 1\nf 6 7 8 9 10\n";
    for i in 1..=5 {
        let j = i % 5 + 1;
        text += &format!("f {i} {j} {} {}\n", j + 5, i + 5);
    }
    let p = tmp("prism.obj", &text);
    let out = itgfx(&["complexity", path(&p), "--lines", "10000", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.stderr.is_empty(), "{}", String::from_utf8_lossy(&out.stderr));
    let bent = tmp("bent.obj", &text.replacen("v 2 2 1", "v 2 2 1.3", 1));
    let out = itgfx(&["complexity", path(&bent), "--lines", "10000", "--json"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("warning: non-planar-face:"), "{err}");
}

/// A FIFO is not read (issue 24): with no writer `open()` would wait for
/// ever, so every input must be a regular file; refused at once.
#[cfg(unix)]
#[test]
fn obj_from_a_fifo_does_not_hang() {
    let p = std::env::temp_dir().join(format!("itgfx-scene-input-fifo-{}.obj", std::process::id()));
    let _ = std::fs::remove_file(&p);
    assert!(Command::new("mkfifo").arg(&p).status().unwrap().success());
    let out = common::no_hang(&["complexity", path(&p), "--lines", "1000", "--json"]);
    let _ = std::fs::remove_file(&p);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("FIFO, not a regular file") && err.lines().count() == 1, "{err}");
}

#[test]
fn built_in_parameters_and_sizes_are_checked_first() {
    for (spec, what) in [
        ("cube:3", "cube:3: too many parameters (syntax: cube)"),
        ("tetrahedron:1", "tetrahedron:1: too many parameters"),
        ("torus:2,8", "torus:2,8: U must be an integer in 3..=4096"),
        ("sphere:4096,4096", "sphere:4096,4096: 0 triangles and 16777216 patches"),
        ("torus:4096,4096", "torus:4096,4096: 33554432 triangles"),
        ("table-chairs:256", "table-chairs:256: 22806528 triangles"),
    ] {
        refused(&["complexity", spec, "--lines", "10000"], what);
    }
    refused(
        &["complexity", "cube-enclosure:10", "--subdivide", "1024", "--lines", "10000"],
        "cube-enclosure:10 subdivided 1024 x 1024: 1258291200 triangles and 629145600 patches",
    );
    // The typed CLI refuses this before the scene is built (its range is 1..=64).
    refused(&["viewpoints", "geosphere:2", "--subdivide", "2000"], "--subdivide must be in 1..=64");
}
