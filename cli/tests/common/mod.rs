//! Helpers shared by the end-to-end tests that run the `itgfx` binary.
//! Each test file is its own crate and uses a subset of these.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the binary under test with `args`.
pub fn itgfx(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_itgfx")).args(args).output().expect("run itgfx")
}

/// A fresh, empty directory for one test, unique to this process.
pub fn temp(prefix: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("itgfx-{prefix}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The JSON a successful run printed.
pub fn json(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// A path as the `&str` argument the CLI takes.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Asserts that `args` fail with exit 2 and one line on stderr containing `needle`.
pub fn fails(args: &[&str], needle: &str) {
    let out = itgfx(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: one line: {err}");
    assert!(err.contains(needle), "{args:?}: {err:?} lacks {needle:?}");
}

/// A mesh of the shared test data (`shared/data/meshes/NAME`, see its
/// README for the origins), found from the workspace root: `ITGFX_SHARED`
/// if set, else `shared/` in the checkout, else `../shared` beside it. A
/// test that needs it fails, naming where it looked, rather than skip.
pub fn shared_mesh(name: &str) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut tried = Vec::new();
    let env = std::env::var_os("ITGFX_SHARED").map(PathBuf::from);
    for dir in env.into_iter().chain([root.join("shared"), root.join("..").join("shared")]) {
        let p = dir.join("data").join("meshes").join(name);
        if p.is_file() {
            return p;
        }
        tried.push(p);
    }
    panic!("test mesh {name} not found (set ITGFX_SHARED to the shared folder); tried {tried:?}");
}

/// `itgfx render SCENE --size 48x48 --spp 32 --out OUT --json EXTRA…`: the
/// JSON and each pixel's luminance (the size the sampler tests share).
pub fn render_luminance(scene: &str, out: &Path, extra: &[&str]) -> (serde_json::Value, Vec<f64>) {
    let mut args = vec!["render", scene, "--size", "48x48", "--spp", "32", "--out", s(out), "--json"];
    args.extend(extra);
    let v = json(&itgfx(&args));
    let image = itgfx_cli::render::images::read_exr(&out.join("image.exr")).unwrap();
    (v, image.rgb.iter().map(|&c| itgfx_core::pixel::luminance(c)).collect())
}

/// The z-score of the mean of `a − b` over pixels, its standard error from
/// their scatter (two images of independent seeds: see render_bias.rs).
pub fn z_score(a: &[f64], b: &[f64]) -> f64 {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0);
    mean / (var / n).sqrt()
}

/// Runs `args`, killing it after 30 s: a hang fails the test instead of
/// stalling the suite.
pub fn no_hang(args: &[&str]) -> std::process::Output {
    use std::process::{Command, Stdio};
    use std::time::{Duration, Instant};
    let mut child = Command::new(env!("CARGO_BIN_EXE_itgfx"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(30) {
            child.kill().unwrap();
            let _ = child.wait();
            panic!("{args:?} hangs");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// Runs `itgfx args` under `ulimit -v kib` (address space, KiB), on two
/// worker threads whatever the machine (each thread maps a stack and a
/// 64 MiB allocator arena, so the limits below hold for two).
pub fn under_ulimit(kib: u64, args: &[&str]) -> std::process::Output {
    let mut cmd = std::process::Command::new("sh");
    cmd.env("RAYON_NUM_THREADS", "2");
    cmd.arg("-c").arg(format!("ulimit -v {kib} && exec \"$0\" \"$@\"")).arg(env!("CARGO_BIN_EXE_itgfx")).args(args);
    cmd.output().expect("run sh")
}

/// A refusal for memory: exit 2, one line; `(needed MiB, budget MiB)`.
pub fn refused_for_memory(out: &std::process::Output, what: &str) -> (u64, u64) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{what}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{what}: one line: {err}");
    let number = |after: &str| -> u64 {
        let rest = &err[err.find(after).unwrap_or_else(|| panic!("{what}: {err:?} lacks {after:?}")) + after.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    (number("needs about "), number(" leaves "))
}
