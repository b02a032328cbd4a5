//! End-to-end tests of the `itgfx` binary as a user runs it.

use std::process::{Command, Output};

fn itgfx(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_itgfx")).args(args).output().expect("run itgfx")
}

fn json(args: &[&str]) -> serde_json::Value {
    let out = itgfx(args);
    assert!(out.status.success(), "itgfx {args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("stdout is one JSON object")
}

fn num(v: &serde_json::Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} missing or not a number in {v}"))
}

/// Fails with exit code 2, one stderr line naming `needle`, nothing on stdout.
fn fails_with(args: &[&str], needle: &str) {
    let out = itgfx(args);
    assert_eq!(out.status.code(), Some(2), "itgfx {args:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(err.starts_with("itgfx: ") && err.contains(needle), "{err}");
    assert!(out.stdout.is_empty());
}

#[test]
fn entropy_in_each_base() {
    let v = json(&["measure", "entropy", "0.5", "0.25", "0.25", "--json"]);
    assert!((num(&v, "entropy") - 1.5).abs() < 1e-12);
    let v = json(&["measure", "entropy", "0.5,0.5", "--base", "e", "--json"]);
    assert!((num(&v, "entropy") - 2f64.ln()).abs() < 1e-12);
    let v = json(&["measure", "entropy", "3", "5", "2", "--normalize", "--base", "10", "--json"]);
    let h = -(0.3f64 * 0.3f64.log10() + 0.5 * 0.5f64.log10() + 0.2 * 0.2f64.log10());
    assert!((num(&v, "entropy") - h).abs() < 1e-12);
}

#[test]
fn table_output_is_readable() {
    let out = itgfx(&["measure", "entropy", "0.5", "0.25", "0.25"]);
    assert!(out.status.success());
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(s.contains("entropy") && s.contains("1.500000 bits"), "{s}");
}

#[test]
fn kl_infinity_is_a_json_string() {
    let v = json(&["measure", "kl", "--p", "0.5,0.5", "--q", "1,0", "--json"]);
    assert_eq!(v["kl"], "inf");
    let v = json(&["measure", "kl", "--p", "0.5,0.5", "--q", "0.25,0.75", "--json"]);
    assert!((num(&v, "kl") - (0.5 * 2f64.log2() + 0.5 * (2.0f64 / 3.0).log2())).abs() < 1e-12);
}

#[test]
fn channel_from_csv_file_prints_every_quantity() {
    let dir = std::env::temp_dir().join(format!("itgfx-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let m = dir.join("bsc.csv");
    std::fs::write(&m, "# binary symmetric channel\n0.9,0.1\n0.1,0.9\n").unwrap();
    let v = json(&["measure", "channel", "--input", "0.5,0.5", "--matrix", m.to_str().unwrap(), "--json"]);
    let hb = -(0.1f64 * 0.1f64.log2() + 0.9 * 0.9f64.log2());
    for (k, want) in
        [("h_x", 1.0), ("h_y", 1.0), ("h_y_given_x", hb), ("h_x_given_y", hb), ("mutual_information", 1.0 - hb)]
    {
        assert!((num(&v, k) - want).abs() < 1e-12, "{k}");
    }
    assert!((num(&v, "h_xy") - (1.0 + hb)).abs() < 1e-12);
    assert_eq!(v["input_specific_information"].as_array().unwrap().len(), 2);
}

#[test]
fn js_equals_channel_mi() {
    let js = json(&["measure", "js", "--weights", "0.3,0.7", "--dists", "0.9,0.1;0.2,0.8", "--json"]);
    let ch = json(&["measure", "channel", "--input", "0.3,0.7", "--matrix", "0.9,0.1;0.2,0.8", "--json"]);
    assert!((num(&js, "jensen_shannon") - num(&ch, "mutual_information")).abs() < 1e-12);
}

#[test]
fn other_measures_run() {
    let v = json(&["measure", "divergences", "--p", "0.2,0.8", "--q", "0.5,0.5", "--json"]);
    assert!(num(&v, "hellinger") <= 0.5 * num(&v, "kl") / std::f64::consts::LOG2_E + 1e-12);
    let v = json(&["measure", "huffman", "0.5", "0.25", "0.125", "0.125", "--json"]);
    assert!((num(&v, "expected_length") - 1.75).abs() < 1e-12);
    let v = json(&["measure", "grouping", "--p", "0.5,0.25,0.25", "--groups", "0,1,1", "--json"]);
    assert!((num(&v, "h_in") + num(&v, "h_out") - 1.5).abs() < 1e-12);
    let v = json(&["measure", "markov", "--matrix", "0,1;0.5,0.5", "--json"]);
    assert!((v["stationary_distribution"][0].as_f64().unwrap() - 1.0 / 3.0).abs() < 1e-9);
    let v = json(&["measure", "fano", "--h-cond", "1", "--n", "4", "--pe", "0.5", "--json"]);
    assert_eq!(v["consistent"], "yes");
    let v = json(&["measure", "renyi", "--alpha", "2", "0.5", "0.5", "--json"]);
    assert!((num(&v, "renyi_entropy") - 1.0).abs() < 1e-12);
    let v = json(&["measure", "bottleneck", "--joint", "0.25,0;0.25,0;0,0.5", "--json"]);
    assert_eq!(v["merges"].as_array().unwrap().len(), 2);
}

#[test]
fn bad_input_is_one_line_and_exit_2() {
    fails_with(&["measure", "entropy", "0.5", "-0.5", "1"], "index 1 is negative");
    fails_with(&["measure", "entropy", "0.5", "nan", "0.5"], "index 1 is not finite");
    fails_with(&["measure", "entropy", "0.5", "0.6"], "sum to 1.1");
    fails_with(&["measure", "entropy", "0.5", "abc"], "not a number");
    fails_with(&["measure", "entropy"], "give the probabilities");
    fails_with(&["measure", "kl", "--p", "0.5,0.5", "--q", "1"], "length mismatch");
    fails_with(&["measure", "kl", "--p", "0.5,0.5"], "missing --q");
    fails_with(&["measure", "channel", "--input", "1", "--matrix", "0.5,0.6"], "row 0");
    fails_with(&["measure", "joint", "--matrix", "/nonexistent/m.csv"], "/nonexistent/m.csv");
    fails_with(&["measure", "joint", "--matrix", "0.1,0.2;0.7"], "row has 1 values");
    fails_with(&["measure", "entropy", "1", "--base", "3"], "--base");
    fails_with(&["measure", "entropy", "1", "--bogus", "1"], "unknown option --bogus");
    fails_with(&["measure", "nope"], "unknown measure");
    fails_with(&["frobnicate"], "unknown command");
}

#[test]
fn help_lists_every_measure() {
    let out = itgfx(&["measure", "--help"]);
    assert!(out.status.success());
    let s = String::from_utf8(out.stdout).unwrap();
    for (name, _) in itgfx_cli::measure::MEASURES {
        assert!(s.contains(name), "{name} missing from help");
    }
}
