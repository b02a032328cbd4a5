//! `itgfx volume` end to end: the channel over voxels, its invariants on
//! symmetric volumes, pictures, and bad input.

use std::path::PathBuf;
use std::process::{Command, Output};

use serde_json::Value;

fn itgfx(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_itgfx")).args(args).output().expect("run itgfx")
}

fn json(args: &[&str]) -> Value {
    let out = itgfx(args);
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("itgfx-volume-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn direction(v: &Value) -> [f64; 3] {
    let d: Vec<f64> = v["direction"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    [d[0], d[1], d[2]]
}

fn views(r: &Value) -> &Vec<Value> {
    r["views"].as_array().unwrap()
}

/// The view whose direction is `d` (within 1e-9).
fn find(r: &Value, d: [f64; 3]) -> &Value {
    views(r)
        .iter()
        .find(|v| direction(v).iter().zip(d).all(|(a, b)| (a - b).abs() < 1e-9))
        .unwrap_or_else(|| panic!("no view at {d:?}"))
}

#[test]
fn hydrogen_symmetries_and_channel_identities() {
    // 2p with m = 1: |psi|^2 ∝ R_21(r)^2 sin^2θ, symmetric under each of
    // x → -x, y → -y, z → -z, as are the voxel grid, the 42 icosahedral
    // viewpoints and the centred pixel grid: mirrored views must agree to
    // rounding (the ray sets are mirror images).
    let r = json(&["volume", "hydrogen:2,1,1,16", "--viewpoints", "42", "--size", "16", "--json", "--base", "e"]);
    assert_eq!(views(&r).len(), 42);
    let i = r["I_VZ"].as_f64().unwrap();
    assert!(i > 0.0);
    let mut weighted = 0.0;
    for v in views(&r) {
        let d = direction(v);
        let vmi = v["VMI"].as_f64().unwrap();
        assert!(vmi >= 0.0);
        // Instability: the mean Jensen–Shannon dissimilarity to the 6 nearest views.
        assert!(v["instability"].as_f64().unwrap() >= 0.0);
        weighted += v["p_v"].as_f64().unwrap() * vmi;
        for axis in 0..3 {
            let mut m = d;
            m[axis] = -m[axis];
            let w = find(&r, m)["VMI"].as_f64().unwrap();
            assert!((w - vmi).abs() <= 1e-9 * vmi.max(1e-3), "{d:?} mirrored in axis {axis}: {vmi} vs {w}");
            let (a, b) = (v["VE_noteworthiness"].as_f64().unwrap(), find(&r, m)["VE_noteworthiness"].as_f64().unwrap());
            assert!(a > 0.0 && (a - b).abs() <= 1e-9 * a, "{d:?} mirrored in axis {axis}: {a} vs {b}");
        }
    }
    // Part V eq. (6): I(V;Z) = Σ p(v) I(v;Z); I(V;Z) <= min(H(V), H(Z)).
    assert!((weighted - i).abs() < 1e-9 * i, "{weighted} vs {i}");
    assert!(i <= r["H_V"].as_f64().unwrap() && i <= r["H_Z"].as_f64().unwrap());
    let h = r["H_Z"].as_f64().unwrap() - r["H_Z_given_V"].as_f64().unwrap();
    assert!((h - i).abs() < 1e-9 * i.max(1.0));
    // The mean VoMI under p(z) is I(V;Z) as well (the reversed channel).
    assert!((r["VoMI_mean_pz"].as_f64().unwrap() - i).abs() < 1e-9 * i);
}

#[test]
fn vmi_is_robust_to_resolution_and_ve_is_not() {
    // Part V/VI (after [VFSG06]): splitting every voxel into 8 equal ones
    // raises VE = H(Z|v) by log2 8 = 3 bits and leaves VMI unchanged. Doubling
    // a built-in's resolution is that split plus finer detail (the object and
    // its optical depth stay the same: opacity is per world unit), so VE must
    // rise by most of 3 bits (> 2) while I(V;Z) moves by under 10%.
    let run = |n: &str, size: &str| {
        json(&["volume", &format!("hydrogen:3,2,0,{n}"), "--viewpoints", "12", "--size", size, "--json"])
    };
    let (a, b) = (run("12", "32"), run("24", "48"));
    let mean = |r: &Value, k: &str| views(r).iter().map(|v| v[k].as_f64().unwrap()).sum::<f64>() / 12.0;
    let ve = mean(&b, "H_Z_given_v") - mean(&a, "H_Z_given_v");
    assert!(ve > 2.0 && ve < 3.2, "VE rose by {ve} bits");
    let (ia, ib) = (a["I_VZ"].as_f64().unwrap(), b["I_VZ"].as_f64().unwrap());
    assert!((ia - ib).abs() < 0.1 * ia, "I(V;Z) {ia} -> {ib}");
    assert!((mean(&a, "VMI") - mean(&b, "VMI")).abs() < 0.1 * ve);
}

#[test]
fn iso_surface_route_runs_beside_the_voxels() {
    // Part VI §2.1: the iso-surface, as a mesh, through the polygonal channel.
    let r = json(&["volume", "hydrogen:3,2,0,16", "--viewpoints", "12", "--size", "32", "--iso", "0.4", "--json"]);
    assert!(r["iso_triangles"].as_u64().unwrap() > 100);
    assert!(r["iso_I_VO"].as_f64().unwrap() > 0.0);
    let rank = r["iso_best_voxel_rank"].as_u64().unwrap();
    assert!(rank < 12);
    let best = r["iso_best_view"].as_u64().unwrap() as usize;
    let iso: Vec<f64> = views(&r).iter().map(|v| v["iso_VMI"].as_f64().unwrap()).collect();
    assert!(iso.iter().all(|&x| x >= iso[best]));
    let out = itgfx(&["volume", "sphere:8", "--iso", "1.5"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--iso"));
}

#[test]
fn opaque_cube_is_best_seen_from_a_corner() {
    // The volume counterpart of Part V's cube: with a step transfer function
    // the cube is an opaque box; views that show three faces (directions far
    // from every axis) beat views along an axis, which show one.
    let r = json(&["volume", "cube:16", "--tf", "step", "--viewpoints", "42", "--size", "24", "--json"]);
    let best = r["best_view_direction"].as_array().unwrap();
    assert!(best.iter().all(|c| c.as_f64().unwrap().abs() > 0.2), "best {best:?}");
    let worst = r["worst_view_direction"].as_array().unwrap();
    assert!(worst.iter().filter(|c| c.as_f64().unwrap().abs() > 0.99).count() == 1, "worst {worst:?}");
}

#[test]
fn phantom_pictures_focus_and_same_numbers_on_one_thread() {
    let dir = temp("phantom");
    let out = dir.join("out");
    let args = [
        "volume",
        "phantom:16",
        "--viewpoints",
        "12",
        "--size",
        "16",
        "--image",
        "32",
        "--focus",
        "left",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ];
    let r = json(&args);
    assert_eq!(r["focus"], "left");
    for name in ["best.png", "worst.png", "best-n.png", "sphere.png", "vomi.png", "colour-vomi.png"] {
        let bytes = std::fs::read(out.join(name)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{name}");
    }
    let saved: Value = serde_json::from_slice(&std::fs::read(out.join("volume.json")).unwrap()).unwrap();
    assert_eq!(saved["I_VZ"], r["I_VZ"]);
    // The focus view sees the focused sphere: its EVMI is the lowest.
    let f = r["best_focus_view"].as_u64().unwrap() as usize;
    let e = views(&r)[f]["EVMI_focus"].as_f64().unwrap();
    assert!(views(&r).iter().all(|v| v["EVMI_focus"].as_f64().unwrap() >= e));
    // The object channel V -> O (Part VI §3.1): I(V;O) = Σ p(o) I(o;V), and
    // each side object is seen best from its own side (left at x = -0.5,
    // right at x = +0.5, the rod at y = -0.45).
    let objects = r["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 5);
    let by_objects: f64 = objects.iter().map(|o| o["p_o"].as_f64().unwrap() * o["I_o_V"].as_f64().unwrap()).sum();
    let total = r["object_I_VO"].as_f64().unwrap();
    assert!(total > 0.0 && (by_objects - total).abs() < 1e-9 * total, "{by_objects} {total}");
    let side = |name: &str, axis: usize| {
        let o = objects.iter().find(|o| o["name"] == name).unwrap();
        o["characteristic_direction"][axis].as_f64().unwrap()
    };
    assert!(side("left", 0) < 0.0 && side("right", 0) > 0.0 && side("rod", 1) < 0.0);
    // Same numbers with one thread.
    let mut one = args.to_vec();
    one.extend(["--threads", "1"]);
    let s = json(&one);
    assert_eq!(s["I_VZ"], r["I_VZ"]);
    assert_eq!(s["views"][3]["VMI"], r["views"][3]["VMI"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn raw_volumes_and_bad_input() {
    let dir = temp("raw");
    // A 6x6x6 u8 ball, read from a raw file.
    let mut bytes = Vec::new();
    for k in 0..6i32 {
        for j in 0..6i32 {
            for i in 0..6i32 {
                let r2 = (2 * i - 5).pow(2) + (2 * j - 5).pow(2) + (2 * k - 5).pow(2);
                bytes.push(if r2 <= 27 { 200u8 } else { 0 });
            }
        }
    }
    let raw = dir.join("ball.raw");
    std::fs::write(&raw, &bytes).unwrap();
    let rs = raw.to_str().unwrap();
    let r = json(&["volume", rs, "--dims", "6,6,6", "--type", "u8", "--viewpoints", "12", "--size", "8", "--json"]);
    assert_eq!(r["voxels"], 216);
    // The same ball as NRRD: the same channel.
    let nrrd = dir.join("ball.nrrd");
    let head = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 6 6 6\nencoding: raw\n\n";
    std::fs::write(&nrrd, [head.as_bytes(), &bytes].concat()).unwrap();
    let n = json(&["volume", nrrd.to_str().unwrap(), "--viewpoints", "12", "--size", "8", "--json"]);
    assert_eq!(n["I_VZ"], r["I_VZ"]);
    let bad_nrrd = dir.join("bad.nrrd");
    std::fs::write(&bad_nrrd, [head.replace("raw", "gzip").as_bytes(), &bytes].concat()).unwrap();
    let short = dir.join("short.raw");
    std::fs::write(&short, &bytes[..100]).unwrap();
    let nan = dir.join("nan.raw");
    std::fs::write(&nan, [1.0f32, f32::NAN].iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
    let zero = dir.join("zero.raw");
    std::fs::write(&zero, [0u8; 8]).unwrap();
    let empty_tf = dir.join("empty.tf");
    std::fs::write(&empty_tf, "# nothing\n").unwrap();
    let clear_tf = dir.join("clear.tf");
    std::fs::write(&clear_tf, "0 0 1 1 1\n1 0 1 1 1\n").unwrap();
    let file = dir.join("file");
    std::fs::write(&file, "x").unwrap();
    let (ss, ns, zs) = (short.to_str().unwrap(), nan.to_str().unwrap(), zero.to_str().unwrap());
    let (es, cs) = (empty_tf.to_str().unwrap(), clear_tf.to_str().unwrap());
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["volume"], "give a volume"),
        (vec!["volume", "/nonexistent/v.raw", "--dims", "2,2,2"], "/nonexistent/v.raw"),
        (vec!["volume", rs], "--dims"),
        (vec!["volume", ss, "--dims", "6,6,6"], "truncated"),
        (vec!["volume", rs, "--dims", "6,6,5"], "216 bytes"),
        (vec!["volume", ns, "--dims", "2,1,1", "--type", "f32"], "not finite"),
        (vec!["volume", zs, "--dims", "2,2,2"], "constant volume"),
        (vec!["volume", rs, "--dims", "6,6"], "--dims"),
        (vec!["volume", bad_nrrd.to_str().unwrap()], "encoding"),
        (vec!["volume", nrrd.to_str().unwrap(), "--dims", "6,6,6"], "NRRD header"),
        (vec!["volume", rs, "--dims", "6,6,6", "--type", "i64"], "--type"),
        (vec!["volume", "sphere:8", "--tf", es], "no control point"),
        (vec!["volume", "sphere:8", "--tf", cs], "opacity 0 everywhere"),
        (vec!["volume", "sphere:8", "--tf", "/nonexistent/tf"], "--tf"),
        (vec!["volume", "sphere:8", "--size", "2"], "--size"),
        (vec!["volume", "sphere:8", "--step", "0"], "--step"),
        (vec!["volume", "sphere:8", "--viewpoints", "50"], "--viewpoints"),
        (vec!["volume", "sphere:8", "--focus", "core"], "no labelled objects"),
        (vec!["volume", "phantom:8", "--focus", "nose"], "not a label"),
        (vec!["volume", "sphere:8", "--dims", "8,8,8"], "raw files"),
        (vec!["volume", "hydrogen:2,2,0,8"], "l < n"),
        (vec!["volume", "hydrogen:2,1,0,2"], "4..=512"),
        (vec!["volume", "teapot"], "not a built-in"),
        (vec!["volume", "sphere:8", "--out", file.to_str().unwrap()], "not a directory"),
    ];
    for (args, needle) in cases {
        let out = itgfx(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The report's text without its timings (`channel_seconds`,
/// `measures_seconds`, `seconds`), which differ from run to run.
fn untimed(out: &Output) -> String {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout.clone()).unwrap();
    let mut kept = String::new();
    for part in text.split(',') {
        if !["\"channel_seconds\":", "\"measures_seconds\":", "\"seconds\":"].iter().any(|k| part.starts_with(k)) {
            kept.push_str(part);
            kept.push(',');
        }
    }
    kept
}

mod common;
use common::fails as refused;

#[test]
fn shards_merge_into_the_single_run_byte_for_byte() {
    let dir = temp("shards");
    let run = ["volume", "phantom:16", "--viewpoints", "12", "--size", "24", "--focus", "left"];
    let single = untimed(&itgfx(&[&run[..], &["--json"]].concat()));
    let file = |i: usize, tag: &str| dir.join(format!("{tag}-{i}.shard")).display().to_string();
    let shard = |spec: &str, i: usize, tag: &str, extra: &[&str]| {
        let s = format!("{i}/3");
        let f = file(i, tag);
        let args = [
            &["volume", spec, "--viewpoints", "12", "--size", "24"][..],
            extra,
            &["--shard", &s, "--save-shard", &f, "--json"],
        ]
        .concat();
        let r = json(&args);
        assert_eq!(r["shard"], s.as_str());
        f
    };
    let files: Vec<String> = (0..3).map(|i| shard("phantom:16", i, "p", &[])).collect();
    // Given in any order, the merge is the single run: every measure, selection and object.
    let list = format!("{},{},{}", files[2], files[0], files[1]);
    let merged = untimed(&itgfx(&[&run[..], &["--merge", &list, "--json"]].concat()));
    assert_eq!(merged, single);
    // Missing, duplicate and foreign shards: one line each.
    let two = format!("{},{}", files[0], files[2]);
    refused(&[&run[..], &["--merge", &two]].concat(), "shard 1/3 missing");
    let dup = format!("{},{},{},{}", files[0], files[1], files[2], files[1]);
    refused(&[&run[..], &["--merge", &dup]].concat(), "are both shard 1/3");
    let other = shard("phantom:12", 1, "q", &[]);
    let foreign = format!("{},{other},{}", files[0], files[2]);
    refused(&[&run[..], &["--merge", &foreign]].concat(), "a shard of another scene");
    let far = shard("phantom:16", 1, "d", &["--distance", "4"]);
    let moved = format!("{},{far},{}", files[0], files[2]);
    refused(&[&run[..], &["--merge", &moved]].concat(), "--distance 3.0 here, 4.0 in the shard");
    let step = shard("phantom:16", 1, "s", &["--tf", "step"]);
    refused(&[&run[..], &["--merge", &format!("{},{step},{}", files[0], files[2])]].concat(), "another scene");
    // Shard runs save rows only: pictures, the iso route and the focus belong to the merge.
    let f = file(0, "x");
    refused(&["volume", "phantom:16", "--shard", "0/2", "--save-shard", &f, "--focus", "left"], "--focus");
    refused(&["volume", "phantom:16", "--viewpoints", "12", "--shard", "0/13", "--save-shard", &f], "more shards");
    std::fs::remove_dir_all(dir).ok();
}
