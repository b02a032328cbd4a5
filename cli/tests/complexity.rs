//! `itgfx complexity` end to end: JSON keys, determinism across thread
//! counts, OBJ scenes and their errors.

use std::path::PathBuf;
use std::process::{Command, Output};

fn itgfx(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_itgfx")).args(args).output().expect("run itgfx")
}

fn tmp(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("itgfx-complexity-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn json(args: &[&str]) -> serde_json::Value {
    let out = itgfx(args);
    assert!(out.status.success(), "itgfx {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn json_has_the_documented_keys() {
    let v = json(&["complexity", "cube-enclosure:4", "--lines", "20000", "--seed", "3", "--json"]);
    for k in [
        "patches",
        "lines",
        "segments",
        "H_P",
        "H_S",
        "H_J",
        "I_S",
        "I_S_cont",
        "I_S_stderr",
        "I_S_cont_stderr",
        "I_S_corrected",
        "seconds",
        "backend",
        "escaped",
    ] {
        assert!(v.get(k).is_some(), "missing {k} in {v}");
    }
    assert_eq!(v["patches"], 96);
    assert_eq!(v["lines"], 20000);
    assert_eq!(v["backend"], "cpu");
    assert_eq!(v["escaped"], 0);
    // With one block there is no standard error: null, never "nan".
    let v = json(&["complexity", "cube", "--lines", "1000", "--blocks", "1", "--json"]);
    assert!(v["I_S_stderr"].is_null() && v["I_S_corrected"].is_null(), "{v}");
}

#[test]
fn same_seed_same_numbers_for_1_and_2_threads() {
    let strip = |mut v: serde_json::Value| {
        v.as_object_mut().unwrap().remove("seconds");
        v
    };
    for extra in [&[][..], &["--local"][..]] {
        let mut a = vec!["complexity", "cubes-room:8", "--lines", "300000", "--seed", "9", "--json", "--threads", "1"];
        a.extend_from_slice(extra);
        let one = strip(json(&a));
        a[8] = "2";
        let two = strip(json(&a));
        assert_eq!(one, two);
        a[5] = "10";
        assert_ne!(strip(json(&a)), two, "another seed gives other numbers");
    }
}

#[test]
fn obj_scene_equals_built_in() {
    // A unit cube seen from inside, written as OBJ quads: same as cube-enclosure:1.
    let obj = "# cube, faces inwards\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
               g walls\nf 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\n";
    let p = tmp("cube.obj", obj);
    let a = json(&["complexity", p.to_str().unwrap(), "--lines", "100000", "--json"]);
    assert_eq!(a["patches"], 6);
    assert_eq!(a["escaped"], 0, "OBJ polygon winding kept: faces point inwards");
    let b = json(&["complexity", "cube-enclosure:1", "--lines", "100000", "--json"]);
    let d = (a["I_S"].as_f64().unwrap() - b["I_S"].as_f64().unwrap()).abs();
    assert!(d < 3.0 * 1.5 * b["I_S_stderr"].as_f64().unwrap() + 1e-9, "{a} vs {b}");
    let s = json(&["complexity", p.to_str().unwrap(), "--subdivide", "3", "--lines", "10000", "--json"]);
    assert_eq!(s["patches"], 54);
}

/// Bad scenes: one line naming the file and the line, exit code 2.
#[test]
fn bad_scene_files() {
    let cases: &[(&str, &str, &str)] = &[
        ("nan.obj", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n", "line 2: vertex coordinate \"nan\" is not finite"),
        ("word.obj", "v 0 0 0\nv 1 x 0\n", "line 2: vertex coordinate \"x\" is not a number"),
        ("short.obj", "v 0 0\n", "line 1: vertex needs 3 coordinates"),
        ("index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "line 4: face 1: vertex index 9 is out of range"),
        ("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "line 4: face 1 is degenerate"),
        ("empty.obj", "# nothing\nv 0 0 0\n", "no faces"),
    ];
    for (name, text, needle) in cases {
        let p = tmp(name, text);
        let out = itgfx(&["complexity", p.to_str().unwrap(), "--lines", "10"]);
        assert_eq!(out.status.code(), Some(2), "{name}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(name) && err.contains(needle), "{name}: {err}");
    }
    for (args, needle) in [
        (&["complexity", "/nonexistent/scene.obj"][..], "/nonexistent/scene.obj"),
        (&["complexity", "pyramid"][..], "unknown scene"),
        (&["complexity", "cube-enclosure:0"][..], "N must be an integer"),
        (&["complexity", "cube", "--lines", "0"][..], "--lines must be positive"),
        (&["complexity", "cube", "--backend", "gpu"][..], "unknown backend"),
        (&["complexity"][..], "give a scene"),
    ] {
        let out = itgfx(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

/// Shards with disjoint line ranges, merged, give the counts of one run.
#[test]
fn shards_merge_into_one_run() {
    let dir = std::env::temp_dir().join(format!("itgfx-shards-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (a, b) = (dir.join("a.counts"), dir.join("b.counts"));
    for (f, off) in [(&a, "0"), (&b, "60000")] {
        let out = itgfx(&[
            "complexity",
            "cube-enclosure:3",
            "--lines",
            "60000",
            "--offset",
            off,
            "--save-counts",
            f.to_str().unwrap(),
        ]);
        assert!(out.status.success());
    }
    let list = format!("{},{}", a.display(), b.display());
    let merged = json(&["complexity", "cube-enclosure:3", "--merge", &list, "--json"]);
    let single = json(&["complexity", "cube-enclosure:3", "--lines", "120000", "--blocks", "16", "--json"]);
    assert_eq!(merged["segments"], single["segments"]);
    assert_eq!(merged["I_S"], single["I_S"], "integer counts merge exactly");
    assert!((merged["I_S_cont"].as_f64().unwrap() - single["I_S_cont"].as_f64().unwrap()).abs() < 1e-12);
    // A count file for another scene is refused.
    let out = itgfx(&["complexity", "cube-enclosure:4", "--merge", &list]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("the counts are of scene \"cube-enclosure:3\""));
}

#[test]
fn exports_a_ply_and_a_png() {
    let dir = std::env::temp_dir().join(format!("itgfx-export-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (ply, png) = (dir.join("s.ply"), dir.join("s.png"));
    let v = json(&[
        "complexity",
        "cube-enclosure:3",
        "--lines",
        "50000",
        "--export-ply",
        ply.to_str().unwrap(),
        "--image",
        png.to_str().unwrap(),
        "--color-by",
        "delta",
        "--json",
    ]);
    assert_eq!(v["ply"], ply.to_str().unwrap());
    let text = std::fs::read_to_string(&ply).unwrap();
    assert!(text.starts_with("ply\nformat ascii 1.0\n"));
    assert!(text.contains("element face 108\n"), "54 patches x 2 triangles");
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    // No temporary files are left behind.
    assert!(std::fs::read_dir(&dir).unwrap().all(|e| !e.unwrap().file_name().to_string_lossy().contains(".tmp")));
    // An unwritable path is a clear error.
    let out = itgfx(&["complexity", "cube", "--lines", "1000", "--image", "/nonexistent/dir/x.png"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/dir/x.png"));
}
