//! Typed options: unknown options, typos and out-of-range values fail with
//! one line and exit 2 before any tracing or writing; help goes to stdout.

use std::path::PathBuf;
use std::process::{Command, Output};

fn itgfx(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_itgfx")).args(args).output().expect("run itgfx")
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("itgfx-options-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Exit 2, exactly one stderr line containing every needle, empty stdout.
fn fails_with(args: &[&str], needles: &[&str]) {
    let out = itgfx(args);
    assert_eq!(out.status.code(), Some(2), "itgfx {args:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "one line for {args:?}: {err}");
    assert!(err.starts_with("itgfx: "), "{err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: {n:?} not in {err}");
    }
    assert!(out.stdout.is_empty(), "{args:?}");
}

#[test]
fn typo_fails_before_tracing_or_writing() {
    let d = dir("typo");
    let counts = d.join("c.counts");
    let c = counts.to_str().unwrap();
    // Today's default is 1e6 lines: the typo must be refused before any of them.
    let t = std::time::Instant::now();
    fails_with(&["complexity", "cube", "--line", "100", "--save-counts", c], &["--line", "did you mean --lines"]);
    assert!(t.elapsed().as_secs_f64() < 5.0, "refused without tracing");
    assert!(!counts.exists(), "nothing written");
    fails_with(&["viewpoints", "cube", "--viewpoint", "12"], &["--viewpoint", "--viewpoints"]);
    fails_with(&["measure", "entropy", "0.5", "0.5", "--normalise"], &["--normalise", "--normalize"]);
    fails_with(&["measure", "entrpy", "0.5"], &["unknown measure", "entropy"]);
    // An option of another command is unknown here.
    fails_with(&["measure", "entropy", "1", "--lines", "10"], &["unknown option --lines"]);
    fails_with(&["devices", "--lines", "10"], &["unknown option --lines"]);
}

#[test]
fn values_are_range_checked() {
    for (args, needles) in [
        (&["complexity", "cube", "--threads", "0"][..], &["--threads", "1..=1024"][..]),
        (&["complexity", "cube", "--threads", "5000"][..], &["--threads"][..]),
        (&["complexity", "cube", "--blocks", "0"][..], &["--blocks", "1..=1024"][..]),
        (&["complexity", "cube", "--seed=-1"][..], &["--seed"][..]),
        (&["complexity", "cube", "--seed", "1.5"][..], &["--seed", "not a non-negative integer"][..]),
        (&["complexity", "cube", "--subdivide", "2000"][..], &["--subdivide"][..]),
        (&["complexity", "cube", "--lines", "1e19"][..], &["--lines"][..]),
        (&["complexity", "cube", "--color-by", "red"][..], &["--color-by", "delta"][..]),
        (&["viewpoints", "cube", "--subdivide", "2000"][..], &["--subdivide", "1..=64"][..]),
        (&["viewpoints", "cube", "--viewpoints", "50"][..], &["--viewpoints", "2562"][..]),
        (&["viewpoints", "cube", "--distance", "1e6"][..], &["--distance", "1.05..=1000"][..]),
        (&["viewpoints", "cube", "--distance", "nan"][..], &["--distance"][..]),
        (&["viewpoints", "cube", "--capture", "0"][..], &["--capture", "(0, 1]"][..]),
        (&["viewpoints", "cube", "--capture", "1.5"][..], &["--capture"][..]),
        (&["viewpoints", "cube", "--best-n", "0"][..], &["--best-n"][..]),
        (&["viewpoints", "cube", "--resolution", "100000"][..], &["--resolution"][..]),
        (&["viewpoints", "cube", "--base", "3"][..], &["--base"][..]),
        (&["measure", "huffman", "0.5", "0.5", "--block", "0"][..], &["--block"][..]),
        (&["measure", "renyi", "--alpha", "x", "0.5", "0.5"][..], &["--alpha"][..]),
        (&["complexity", "cube", "--lines"][..], &["--lines"][..]),
    ] {
        fails_with(args, needles);
    }
}

#[test]
fn counts_accept_exponent_notation() {
    let out = itgfx(&["complexity", "cube", "--lines", "2e3", "--seed", "1_0", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["lines"], 2000);
    assert_eq!(v["seed"], 10);
}

#[test]
fn offset_plus_lines_must_fit_64_bits() {
    fails_with(&["complexity", "cube", "--offset", "18446744073709551615", "--lines", "100"], &["--offset", "2^64-1"]);
    // The last representable range is accepted.
    let out = itgfx(&["complexity", "cube", "--offset", "18446744073709551515", "--lines", "100", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn huge_line_counts_run_in_bounded_memory() {
    // Before: an allocation abort (exit 134) listing 1e15/8/16384 chunk
    // starts up front; then a refusal. Now chunk starts are made one wave at
    // a time: the run starts tracing, reports progress and is still alive
    // (in little memory) when we stop it.
    let mut child = Command::new(env!("CARGO_BIN_EXE_itgfx"))
        .args(["complexity", "cube", "--lines", "1e15"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_secs(3));
    let status = child.try_wait().unwrap();
    // Resident memory, where /proc says (Linux): well under 100 MB.
    let rss_kb = std::fs::read_to_string(format!("/proc/{}/status", child.id()))
        .ok()
        .and_then(|s| s.lines().find(|l| l.starts_with("VmRSS:"))?.split_whitespace().nth(1)?.parse::<u64>().ok());
    let _ = child.kill();
    let _ = child.wait();
    assert!(status.is_none(), "exited early: {status:?}");
    assert!(rss_kb.is_none_or(|kb| kb < 100_000), "{rss_kb:?} kB resident");
}

#[test]
fn help_and_version_go_to_stdout() {
    for args in [&["--help"][..], &["complexity", "--help"], &["viewpoints", "--help"], &["measure", "--help"], &[]] {
        let out = itgfx(args);
        assert_eq!(out.status.code(), Some(0), "{args:?}");
        assert!(!out.stdout.is_empty() && out.stderr.is_empty(), "{args:?}");
    }
    let s = String::from_utf8(itgfx(&["complexity", "--help"]).stdout).unwrap();
    for b in itgfx_backends::scene::BUILT_IN {
        assert!(s.contains(b.name), "built-in {} missing from complexity help", b.name);
    }
    for flag in ["--lines", "--seed", "--local", "--subdivide", "--blocks", "--backend", "--offset", "--merge"] {
        assert!(s.contains(flag), "{flag}");
    }
    let s = String::from_utf8(itgfx(&["viewpoints", "--help"]).stdout).unwrap();
    for flag in ["--viewpoints", "--resolution", "--distance", "--best-n", "--capture", "--out", "--smooth"] {
        assert!(s.contains(flag), "{flag}");
    }
    let v = String::from_utf8(itgfx(&["--version"]).stdout).unwrap();
    assert!(v.contains(env!("CARGO_PKG_VERSION")), "{v}");
}

#[test]
fn grouping_labels_are_compacted() {
    // Before: a vector of 10^8 group slots, an allocation abort for larger labels.
    let out =
        itgfx(&["measure", "grouping", "--p", "0.5,0.25,0.25", "--groups", "0,99999999999,99999999999", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["group_labels"], serde_json::json!([0, 99_999_999_999u64]));
    assert_eq!(v["group_probabilities"], serde_json::json!([0.5, 0.5]));
    assert!((v["h_in"].as_f64().unwrap() + v["h_out"].as_f64().unwrap() - 1.5).abs() < 1e-12);
    fails_with(&["measure", "grouping", "--p", "0.5,0.5", "--groups", "0,1.5"], &["--groups", "1.5"]);
}

/// A negative number after an option is that option's value, checked by its
/// own parser (it was "unknown option -1"); a true unknown short option is
/// still named as such.
#[test]
fn negative_values_reach_their_option() {
    fails_with(&["render", "mirror-room", "--delta", "-1", "--size", "8x8"], &["--delta", "0..=1", "-1"]);
    fails_with(&["complexity", "cube", "--lines", "-5"], &["--lines", "-5"]);
    fails_with(&["viewpoints", "cube", "--distance", "-3"], &["--distance", "1.05..=1000"]);
    fails_with(&["volume", "hydrogen", "--step", "-1"], &["--step", "0.05..=2"]);
    fails_with(&["radiosity", "cornell-box", "--samples", "-3"], &["--samples", "-3"]);
    fails_with(&["complexity", "cube", "-x"], &["unknown option -x"]);
}
