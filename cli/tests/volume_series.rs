//! `itgfx volume` end to end for time series (`--time`), the camera path
//! between two objects (`--path-between`), fuzzy object membership
//! (`phantom:N,W`) and JSON transfer functions.

mod common;

use common::{fails, itgfx, json, s, temp};
use serde_json::Value;

fn run(args: &[&str]) -> Value {
    json(&itgfx(args))
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn dir3(v: &Value) -> [f64; 3] {
    let d: Vec<f64> = v.as_array().unwrap().iter().map(f).collect();
    [d[0], d[1], d[2]]
}

fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
    dot.clamp(-1.0, 1.0).acos().to_degrees()
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()).max(1e-300)
}

#[test]
fn beat_series_static_view_and_dynamic_path() {
    let args = ["volume", "--time", "hydrogen-beat:12,4", "--viewpoints", "42", "--size", "16", "--json"];
    let r = run(&args);
    assert_eq!(r["frames"], 4);
    let frames = r["frame_measures"].as_array().unwrap();
    let views = r["views"].as_array().unwrap();
    let vmi = |frame: usize, view: usize| f(&views[view]["VMI"][frame]);
    // The static view is the least VMI averaged over the frames.
    let means: Vec<f64> = (0..42).map(|v| (0..4).map(|k| vmi(k, v)).sum::<f64>() / 4.0).collect();
    let stat = r["static_view"].as_u64().unwrap() as usize;
    assert!(means.iter().all(|&m| m >= means[stat]), "static view {stat} is not the least mean");
    assert!(close(f(&r["static_mean_VMI"]), means[stat], 1e-12));
    // The dynamic path: one view per frame, turns within the limit, between the bounds.
    let path = r["path"].as_array().unwrap();
    assert_eq!(path.len(), 4);
    let max_turn = f(&r["max_turn_deg"]);
    assert!(max_turn > 30.0 && max_turn < 33.0, "one neighbour step at 42 views: {max_turn}");
    for w in path.windows(2) {
        assert!(angle(dir3(&w[0]["direction"]), dir3(&w[1]["direction"])) <= max_turn + 1e-9);
    }
    let (path_mean, lower) = (f(&r["path_mean_VMI"]), f(&r["per_frame_best_mean_VMI"]));
    assert!(lower <= path_mean + 1e-12 && path_mean <= means[stat] + 1e-12, "{lower} {path_mean}");
    let total: f64 = path.iter().map(|p| f(&p["VMI"])).sum();
    assert!(close(total / 4.0, path_mean, 1e-12));
    // Each frame's best view is its least VMI.
    for (k, fr) in frames.iter().enumerate() {
        let b = fr["best_view"].as_u64().unwrap() as usize;
        assert!((0..42).all(|v| vmi(k, v) >= vmi(k, b)));
        assert!(f(&fr["I_VZ"]) > 0.0);
    }
    // Frame 2 is frame 0 turned by π about z; the 42 views and the grid are symmetric
    // under (x, y) → (−x, −y): the VMI of a view in frame 0 is that of the turned view in frame 2.
    for v in 0..42 {
        let d = dir3(&views[v]["direction"]);
        let turned = (0..42).find(|&u| angle(dir3(&views[u]["direction"]), [-d[0], -d[1], d[2]]) < 1e-6).unwrap();
        assert!(close(vmi(0, v), vmi(2, turned), 1e-6), "view {v}: {} vs {}", vmi(0, v), vmi(2, turned));
    }
    // No turn allowed: the path is the static view; any turn: every frame's best.
    let still = run(&[&args[..], &["--max-turn", "0"]].concat());
    assert!(still["path"].as_array().unwrap().iter().all(|p| p["view"].as_u64().unwrap() as usize == stat));
    assert_eq!(still["path_mean_VMI"], r["static_mean_VMI"]);
    let free = run(&[&args[..], &["--max-turn", "180"]].concat());
    for (p, fr) in free["path"].as_array().unwrap().iter().zip(frames) {
        assert!(close(f(&p["VMI"]), f(&fr["best_VMI"]), 1e-12));
    }
}

#[test]
fn a_series_of_one_volume_is_that_volume() {
    let single = run(&["volume", "hydrogen:2,1,1,12", "--viewpoints", "12", "--size", "16", "--json"]);
    let r = run(&[
        "volume",
        "--time",
        "hydrogen:2,1,1,12,hydrogen:2,1,1,12",
        "--viewpoints",
        "12",
        "--size",
        "16",
        "--json",
    ]);
    for fr in r["frame_measures"].as_array().unwrap() {
        assert_eq!(fr["I_VZ"], single["I_VZ"]);
        assert_eq!(fr["best_view"], single["best_view"]);
    }
    assert_eq!(r["static_view"], single["best_view"]);
    for (a, b) in r["views"].as_array().unwrap().iter().zip(single["views"].as_array().unwrap()) {
        assert_eq!(a["VMI"][1], b["VMI"]);
    }
}

#[test]
fn series_from_files_pictures_and_bad_input() {
    let dir = temp("volume-series", "files");
    // Three raw frames of a moving blob, written as NRRD files, read by a pattern.
    let n = 10;
    for k in 0..3 {
        let mut bytes = Vec::new();
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let c = [2.0 + 2.0 * k as f64, 5.0, 5.0];
                    let r2 = (x as f64 - c[0]).powi(2) + (y as f64 - c[1]).powi(2) + (z as f64 - c[2]).powi(2);
                    bytes.push((255.0 * (-r2 / 6.0).exp()) as u8);
                }
            }
        }
        let head = format!("NRRD0004\ntype: uchar\ndimension: 3\nsizes: {n} {n} {n}\nencoding: raw\n\n");
        std::fs::write(dir.join(format!("f{k}.nrrd")), [head.as_bytes(), &bytes].concat()).unwrap();
    }
    let out = dir.join("out");
    let pattern = dir.join("f*.nrrd");
    let r = run(&["volume", "--time", s(&pattern), "--viewpoints", "12", "--out", s(&out), "--json"]);
    assert_eq!(r["frames"], 3);
    for name in ["path.png", "static.png", "frames-best.png", "series.json"] {
        assert!(out.join(name).metadata().unwrap().len() > 100, "{name}");
    }
    let saved: Value = serde_json::from_slice(&std::fs::read(out.join("series.json")).unwrap()).unwrap();
    assert_eq!(saved["static_view"], r["static_view"]);
    let list = format!("{},{}", s(&dir.join("f0.nrrd")), s(&dir.join("f2.nrrd")));
    assert_eq!(run(&["volume", "--time", &list, "--viewpoints", "12", "--json"])["frames"], 2);

    let other = dir.join("g.nrrd");
    let head = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n\n";
    std::fs::write(&other, [head.as_bytes(), &[7u8; 64][..]].concat()).unwrap();
    let mismatch = format!("{},{}", s(&dir.join("f0.nrrd")), s(&other));
    let one = s(&dir.join("f0.nrrd")).to_string();
    let none = s(&dir.join("nothing*.nrrd")).to_string();
    let missing = format!("{},{}", s(&dir.join("f0.nrrd")), s(&dir.join("absent.nrrd")));
    fn t(spec: &str) -> Vec<&str> {
        vec!["volume", "--time", spec]
    }
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (t(&mismatch), "frame 1"),
        (t(&one), "at least 2 frames"),
        (t(&none), "no file matches"),
        (t(&missing), "frame 1"),
        (t("hydrogen-beat:12,1"), "T = 1"),
        (t("hydrogen-beat:2"), "N = 2"),
        (t("sphere:8,"), "frame 1 is empty"),
        ([t("hydrogen-beat:8,2"), vec!["sphere:8"]].concat(), "--time takes no VOLUME"),
        ([t("hydrogen-beat:8,2"), vec!["--focus", "left"]].concat(), "--focus"),
        ([t("hydrogen-beat:8,2"), vec!["--iso", "0.5"]].concat(), "--iso"),
        ([t("hydrogen-beat:8,2"), vec!["--max-turn", "200"]].concat(), "--max-turn"),
        ([t("hydrogen-beat:8,2"), vec!["--max-turn", "NaN"]].concat(), "--max-turn"),
        (vec!["volume", "sphere:8", "--max-turn", "10"], "--max-turn is for a time series"),
    ];
    for (args, needle) in &cases {
        fails(args, needle);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn path_between_two_objects() {
    let dir = temp("volume-series", "between");
    let out = dir.join("out");
    let args = [
        "volume",
        "phantom:16",
        "--viewpoints",
        "42",
        "--size",
        "24",
        "--path-between",
        "left,right",
        "--path-steps",
        "5",
    ];
    let r = run(&[&args[..], &["--json", "--out", s(&out), "--image", "64"]].concat());
    for name in ["path-between.png", "tour.png", "objects.png"] {
        assert!(out.join(name).metadata().unwrap().len() > 100, "{name}");
        assert!(r["wrote"].as_array().unwrap().iter().any(|w| w.as_str().unwrap().ends_with(name)), "{name}");
    }
    let p = &r["path_between"][0];
    let objects = r["objects"].as_array().unwrap();
    let (from, to) = (&objects[2], &objects[3]);
    assert_eq!((from["name"].as_str(), to["name"].as_str()), (Some("left"), Some("right")));
    assert_eq!(p["from_view"], from["characteristic_view"]);
    assert_eq!(p["to_view"], to["characteristic_view"]);
    let steps = p["steps"].as_array().unwrap();
    assert_eq!(steps.len(), 5);
    let (a, b) = (dir3(&from["characteristic_direction"]), dir3(&to["characteristic_direction"]));
    assert!(angle(dir3(&steps[0]["direction"]), a) < 1e-6 && angle(dir3(&steps[4]["direction"]), b) < 1e-6);
    let total = angle(a, b);
    assert!(close(f(&p["angle_deg"]), total, 1e-9));
    for w in steps.windows(2) {
        assert!((angle(dir3(&w[0]["direction"]), dir3(&w[1]["direction"])) - total / 4.0).abs() < 1e-6);
    }
    // The ends are sphere viewpoints: their measures are the sphere's.
    let views = r["views"].as_array().unwrap();
    for (step, view) in [
        (&steps[0], &views[p["from_view"].as_u64().unwrap() as usize]),
        (&steps[4], &views[p["to_view"].as_u64().unwrap() as usize]),
    ] {
        assert!(close(f(&step["VMI"]), f(&view["VMI"]), 1e-9), "{step} {view}");
        assert!(close(f(&step["object_VMI"]), f(&view["object_VMI"]), 1e-9));
        assert!(close(f(&step["VE"]), f(&view["H_Z_given_v"]), 1e-9));
    }
    // The camera leaves A for B: A's share of what is seen falls, B's rises.
    assert!(f(&steps[0]["p_from"]) > f(&steps[4]["p_from"]));
    assert!(f(&steps[4]["p_to"]) > f(&steps[0]["p_to"]));
    // The exploration path stays.
    assert!(r["exploration_path"].as_array().unwrap().len() > 1);
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["volume", "phantom:8", "--path-between", "left,nose"], "not a label"),
        (vec!["volume", "phantom:8", "--path-between", "left,left"], "the same object twice"),
        (vec!["volume", "phantom:8", "--path-between", "3,left"], "the same object twice"),
        (vec!["volume", "phantom:8", "--path-between", "left"], "two labels"),
        (vec!["volume", "sphere:8", "--path-between", "a,b"], "no labelled objects"),
        (vec!["volume", "phantom:8", "--path-between", "left,right", "--path-steps", "1"], "--path-steps"),
        (vec!["volume", "phantom:8", "--path-steps", "4"], "--path-steps is for --path-between"),
    ];
    for (args, needle) in &cases {
        fails(args, needle);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn fuzzy_membership() {
    let base = ["--viewpoints", "12", "--size", "24", "--json", "--focus", "left"];
    let crisp = run(&[&["volume", "phantom:16"][..], &base].concat());
    let width0 = run(&[&["volume", "phantom:16,0"][..], &base].concat());
    for key in ["I_VZ", "object_I_VO", "objects", "best_focus_view"] {
        assert_eq!(crisp[key], width0[key], "{key}");
    }
    for (a, b) in crisp["views"].as_array().unwrap().iter().zip(width0["views"].as_array().unwrap()) {
        assert_eq!(a, b);
    }
    let fuzzy = run(&[&["volume", "phantom:16,2"][..], &base].concat());
    assert_ne!(fuzzy["object_I_VO"], crisp["object_I_VO"]);
    // I(V;O) = Σ_o p(o) I(o;V) with the membership-weighted channel too; p(O) sums to 1.
    let objects = fuzzy["objects"].as_array().unwrap();
    let sum_p: f64 = objects.iter().map(|o| f(&o["p_o"])).sum();
    let weighted: f64 = objects.iter().map(|o| f(&o["p_o"]) * f(&o["I_o_V"])).sum();
    assert!((sum_p - 1.0).abs() < 1e-12);
    assert!(close(weighted, f(&fuzzy["object_I_VO"]), 1e-9));
    // --focus takes the fuzzy object's membership as importance.
    assert!(fuzzy["best_focus_view"].as_u64().is_some());
    fails(&["volume", "phantom:16,9"], "W = 9");
    fails(&["volume", "phantom:300,1"], "N <= 256");
}

#[test]
fn json_transfer_functions() {
    let dir = temp("volume-series", "tf");
    let text = dir.join("a.tf");
    std::fs::write(&text, "0 0 0 0 0\n0.2 0 0.1 0.2 0.9\n1 0.7 1 0.5 0.1\n").unwrap();
    let js = dir.join("a.json");
    std::fs::write(
        &js,
        r#"{"points": [{"value": 0, "opacity": 0, "colour": [0, 0, 0]},
                       {"value": 0.2, "opacity": 0, "colour": [0.1, 0.2, 0.9]},
                       {"value": 1, "opacity": 0.7, "colour": [1, 0.5, 0.1]}]}"#,
    )
    .unwrap();
    let go = |tf: &str| run(&["volume", "sphere:12", "--viewpoints", "12", "--size", "16", "--tf", tf, "--json"]);
    assert_eq!(go(s(&text))["I_VZ"], go(s(&js))["I_VZ"]);
    let bad = [
        ("empty.json", "", "JSON"),
        ("nopoints.json", r#"{"points": []}"#, "no control point"),
        (
            "order.json",
            r#"{"points": [{"value": 0.6, "opacity": 1, "colour": [1, 1, 1]}, {"value": 0.3, "opacity": 1, "colour": [1, 1, 1]}]}"#,
            "increase strictly",
        ),
        ("range.json", r#"{"points": [{"value": 0.5, "opacity": 2, "colour": [1, 1, 1]}]}"#, "in [0, 1]"),
        ("nan.json", r#"{"points": [{"value": NaN, "opacity": 1, "colour": [1, 1, 1]}]}"#, "JSON"),
        ("extra.json", r#"{"points": [{"value": 0.5, "opacity": 1, "colour": [1, 1, 1], "x": 0}]}"#, "unknown field"),
        ("brace", r#"{"points": 3}"#, "JSON"),
    ];
    for (name, body, needle) in bad {
        let p = dir.join(name);
        std::fs::write(&p, body).unwrap();
        fails(&["volume", "sphere:8", "--tf", s(&p)], needle);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
