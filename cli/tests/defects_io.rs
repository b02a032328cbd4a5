//! Regression tests for issue 24's defects of outputs, hangs, options, small
//! inputs and numerics, each run where the user sees it: the `itgfx` binary.

mod common;

use common::*;

/// Rényi near α = 1 and Tsallis near q = 1 cancelled: `--alpha
/// 1.00000000000001` on (½, ¼, ¼) gave 1.5103 bits, not 1.5.
#[test]
fn renyi_and_tsallis_next_to_one() {
    let v = json(&itgfx(&["measure", "renyi", "--alpha", "1.00000000000001", "0.5,0.25,0.25", "--json"]));
    let h = v["renyi_entropy"].as_f64().unwrap();
    assert!((h - 1.5).abs() < 1e-12, "{h}");
    let v = json(&itgfx(&["measure", "renyi", "--alpha", "0.999999999999999", "0.25,0.25,0.25,0.25", "--json"]));
    let h = v["renyi_entropy"].as_f64().unwrap();
    assert!((h - 2.0).abs() < 1e-12, "{h}");
    let v = json(&itgfx(&["measure", "tsallis", "--q", "1.00000000000001", "0.25,0.25,0.25,0.25", "--json"]));
    let s = v["tsallis_entropy"].as_f64().unwrap();
    assert!((s - 4f64.ln()).abs() < 1e-12, "{s}");
}

/// Exit code `code` and one line on stderr containing `needle`.
fn fails_with(args: &[&str], code: i32, needle: &str) {
    let out = itgfx(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: one line: {err}");
    assert!(err.contains(needle), "{args:?}: {err:?} lacks {needle:?}");
}

fn sh(script: &str) -> std::process::Output {
    std::process::Command::new("sh").args(["-c", script, "sh", env!("CARGO_BIN_EXE_itgfx")]).output().expect("run sh")
}

/// A write error on stdout was ignored (`> /dev/full` exited 0, silent):
/// one line and exit 1, for a report and for `--help`; a closed pipe
/// (`| head`) ends the run quietly.
#[test]
fn stdout_write_errors_are_reported() {
    for args in ["measure entropy 0.5 0.5", "measure entropy 0.5 0.5 --json", "--help", "complexity --help"] {
        let out = sh(&format!("\"$1\" {args} > /dev/full"));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args}: {err}");
        assert!(err.contains("standard output") && err.contains("No space left"), "{args}: {err}");
    }
    // A reader that closed the pipe before the write (EPIPE): no message, success.
    for args in ["measure entropy 0.5 0.5", "--help"] {
        let out = std::process::Command::new("bash")
            .args(["-c", &format!("{{ sleep 0.3; \"$1\" {args}; }} | true; echo ${{PIPESTATUS[0]}}"), "bash"])
            .arg(env!("CARGO_BIN_EXE_itgfx"))
            .output()
            .unwrap();
        assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "0", "{args}");
        assert!(out.stderr.is_empty(), "{args}: {}", String::from_utf8_lossy(&out.stderr));
    }
}

/// An output that fails at the end left the others written: `--export-ply
/// good.ply --image /dev/full` left good.ply, `viewpoints --out D
/// --ao-image /dev/full` wrote five PNGs. Now all or none, and D (made by
/// the run) goes again.
#[test]
fn outputs_are_all_or_none() {
    let d = temp("defio", "all-or-none");
    let good = d.join("good.ply");
    fails_with(
        &["complexity", "cube", "--lines", "1000", "--export-ply", s(&good), "--image", "/dev/full"],
        1,
        "/dev/full",
    );
    assert!(!good.exists(), "good.ply left behind");
    let v = d.join("v");
    fails_with(&["viewpoints", "cube", "--out", s(&v), "--ao-image", "/dev/full"], 1, "/dev/full");
    assert!(!v.exists(), "the --out directory made by the run is left: {:?}", std::fs::read_dir(&v).map(|r| r.count()));
    // A directory that was there stays, empty, with no temporary in it.
    std::fs::create_dir(&v).unwrap();
    fails_with(&["viewpoints", "cube", "--out", s(&v), "--ao-image", "/dev/full"], 1, "/dev/full");
    assert_eq!(std::fs::read_dir(&v).unwrap().count(), 0);
    // Stdout failing after the files were made: no file either.
    let out = sh(&format!("\"$1\" complexity cube --lines 1000 --export-ply '{}' > /dev/full", s(&good)));
    assert_eq!(out.status.code(), Some(1));
    assert!(!good.exists());
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1, "only v: no temporary left");
    // And a run that succeeds writes them all.
    let ok =
        itgfx(&["complexity", "cube", "--lines", "1000", "--export-ply", s(&good), "--image", s(&d.join("i.png"))]);
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    assert!(good.is_file() && d.join("i.png").is_file());
}

/// A FIFO with no writer given as an input hung in `open()`: OBJ, MTL,
/// counts, shard, EXR, PNG and CSV inputs are refused at once, one line.
#[test]
fn fifo_inputs_are_refused() {
    let d = temp("defio", "fifo");
    let fifo = |name: &str| {
        let p = d.join(name);
        assert!(std::process::Command::new("mkfifo").arg(&p).status().unwrap().success());
        s(&p).to_string()
    };
    let (obj, counts, shard, exr, png, csv, tf) = (
        fifo("a.obj"),
        fifo("a.counts"),
        fifo("a.shard.json"),
        fifo("a.exr"),
        fifo("a.png"),
        fifo("a.csv"),
        fifo("tf.json"),
    );
    let mtl = d.join("m.obj");
    std::fs::write(&mtl, format!("mtllib {}\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", fifo("m.mtl"))).unwrap();
    let good_exr = d.join("g.exr");
    let out = itgfx(&["render", "cornell-box", "--spp", "1", "--size", "8x8", "--out", s(&d.join("r"))]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    std::fs::copy(d.join("r").join("image.exr"), &good_exr).unwrap();
    let out_dir = d.join("o");
    let cases: Vec<Vec<&str>> = vec![
        vec!["complexity", &obj, "--lines", "1000"],
        vec!["complexity", s(&mtl), "--lines", "1000"],
        vec!["complexity", "cube", "--lines", "1000", "--merge", &counts],
        vec!["viewpoints", "cube", "--merge", &shard],
        vec!["render", "--merge", &shard, "--out", s(&out_dir)],
        vec!["compare", &exr, s(&good_exr)],
        vec!["segment", &png, "--out", s(&out_dir)],
        vec!["measure", "entropy", &csv],
        vec!["volume", "hydrogen", "--tf", &tf],
    ];
    for args in &cases {
        let out = no_hang(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains("FIFO"), "{args:?}: {err}");
    }
}

/// Options that were accepted and ignored in some combinations: each is
/// refused with one line, exit 2, before any work.
#[test]
fn ignored_options_are_refused() {
    for extra in [
        &["--shares"][..],
        &["--oracle", "ks"],
        &["--samples", "5"],
        &["--base-level", "1"],
        &["--transport-samples", "4"],
        &["--min-area", "1e-5"],
        &["--count-tolerance", "0.1"],
        &["--max-trials", "5"],
    ] {
        let mut args = vec!["radiosity", "cornell-box", "--path-trace", "4"];
        args.extend_from_slice(extra);
        fails(&args, &format!("--path-trace cannot be used with {}", extra[0]));
    }
    let cases: &[(&[&str], &str)] = &[
        (&["render", "--merge", "x.json", "--save-shard", "y.json", "--out", "o"], "--save-shard"),
        (&["render", "--merge", "x.json", "--backend", "cpu", "--out", "o"], "--backend"),
        (&["complexity", "--merge", "a.counts", "--seed", "3"], "--seed"),
        (&["complexity", "--merge", "a.counts", "--blocks", "4"], "--blocks"),
        (&["volume", "--time", "hydrogen-beat", "--best-n", "3"], "--best-n"),
        (&["volume", "--time", "hydrogen-beat", "--explore", "3"], "--explore"),
        (&["volume", "--time", "hydrogen-beat", "--capture", "0.5"], "--capture"),
        (&["measure", "binary", "--normalize", "0.3"], "--normalize"),
        (&["compare", "a.exr", "b.exr", "--base", "2"], "--base"),
        (&["segment", "x.png", "--out", "o", "--regions", "3", "--ratio", "0.5"], "--ratio"),
        (&["simplify", "cube", "--evaluate", "x.obj", "--metric", "ve"], "--metric"),
        (&["volume", "hydrogen", "--image", "64"], "missing --out"),
        (&["viewpoints", "cube", "--smooth", "3"], "--ao-image"),
        (&["complexity", "cube", "--color-by", "delta"], "--image"),
    ];
    for (args, needle) in cases {
        fails(args, needle);
    }
    // Where they mean something they are still taken.
    let d = temp("defio", "taken");
    let png = d.join("c.png");
    let out = itgfx(&["complexity", "cube", "--lines", "1000", "--color-by", "delta", "--image", s(&png)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let ao = d.join("ao.png");
    let out = itgfx(&["viewpoints", "cube", "--viewpoints", "12", "--smooth", "0", "--ao-image", s(&ao)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(png.is_file() && ao.is_file());
}

/// Small defects: a CSV with a byte-order mark, an absorbing chain with
/// state 0 transient, a shift of 1e300 pixels, the huffman block limit,
/// a 301-digit number in an error.
#[test]
fn small_inputs() {
    let d = temp("defio", "small");
    let bom = d.join("bom.csv");
    std::fs::write(&bom, "\u{feff}0.5,0.25,0.25\n").unwrap();
    let v = json(&itgfx(&["measure", "entropy", s(&bom), "--json"]));
    assert!((v["entropy"].as_f64().unwrap() - 1.5).abs() < 1e-15, "{v}");
    // Both absorbing chains have a unique stationary distribution.
    let v = json(&itgfx(&["measure", "markov", "--matrix", "0.5,0.5;0,1", "--json"]));
    assert_eq!(v["stationary_distribution"], serde_json::json!([0.0, 1.0]));
    let v = json(&itgfx(&["measure", "markov", "--matrix", "1,0;0.5,0.5", "--json"]));
    assert_eq!(v["stationary_distribution"], serde_json::json!([1.0, 0.0]));
    fails(&["measure", "markov", "--matrix", "1,0;0,1"], "more than one closed class");
    let ph = d.join("ph");
    fails(&["phantom", "--out", s(&ph), "--shift", "1e300,0"], "--shift 1e300");
    assert!(!ph.exists(), "refused before any work");
    // The help gives the real limit, and the refusal says what to give.
    let help = String::from_utf8(itgfx(&["measure", "huffman", "--help"]).stdout).unwrap();
    assert!(help.contains("2^22"), "{help}");
    fails(&["measure", "huffman", "--block", "64", "0.5,0.5"], "give at most --block 22");
    let v = json(&itgfx(&["measure", "huffman", "--block", "22", "0.5,0.5", "--json"]));
    assert_eq!(v["block"], 22);
    let out = itgfx(&["register", "a.png", "b.png", "--out", s(&d.join("r")), "--levels", "1:1e300"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert!(err.len() < 200 && err.contains("1e300"), "{err}");
}

#[test]
fn unnormalised_input_hints_at_normalize_only_where_it_exists() {
    // `joint` and `bottleneck` take no --normalize: the hint sent users to
    // an option clap then refused ("unknown option --normalize").
    let d = temp("defio", "hint");
    let joint = d.join("joint.csv");
    std::fs::write(&joint, "1,1\n1,1\n").unwrap();
    for args in [&["measure", "joint", "--matrix", "1,1;1,1"][..], &["measure", "bottleneck", "--joint", s(&joint)]] {
        fails_with(args, 2, "normalise them first");
        let err = String::from_utf8_lossy(&itgfx(args).stderr).into_owned();
        assert!(!err.contains("--normalize"), "{args:?}: {err}");
    }
    // Where it exists, the hint stays.
    fails_with(&["measure", "entropy", "1", "1"], 2, "(--normalize does)");
    let _ = std::fs::remove_dir_all(&d);
}

/// NRRD `space directions` were ignored (only `spacings` read): a volume
/// with directions (1,0,0) (0,1,0) (0,0,4) is the one with spacings 1 1 4;
/// a rotated grid is refused.
#[test]
fn nrrd_space_directions() {
    let d = temp("defio", "nrrd");
    let data: Vec<u8> = (0..512u32).map(|i| ((i % 8) * 7 + (i / 8 % 8) * 3 + (i / 64) * 11) as u8).collect();
    let nrrd = |name: &str, field: &str| {
        let p = d.join(name);
        let head = format!("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 8 8 8\nencoding: raw\n{field}\n\n");
        std::fs::write(&p, [head.as_bytes(), &data].concat()).unwrap();
        s(&p).to_string()
    };
    let i_vz = |path: &str| json(&itgfx(&["volume", path, "--viewpoints", "12", "--json"]))["I_VZ"].as_f64().unwrap();
    let directions = i_vz(&nrrd("d.nrrd", "space: right-anterior-superior\nspace directions: (1,0,0) (0,1,0) (0,0,4)"));
    let spacings = i_vz(&nrrd("s.nrrd", "spacings: 1 1 4"));
    let unit = i_vz(&nrrd("u.nrrd", "spacings: 1 1 1"));
    assert_eq!(directions, spacings);
    assert!((directions - unit).abs() > 1e-6, "{directions} vs {unit}");
    let rotated = nrrd("r.nrrd", "space directions: (0.7,0.7,0) (-0.7,0.7,0) (0,0,1)");
    fails(&["volume", &rotated, "--viewpoints", "12"], "not along a coordinate axis");
}

/// A greyscale PNG of `w × h` from `f(x, y)` (no dependencies: stored
/// deflate blocks, the zlib Adler-32 and the PNG CRC written out).
fn gray_png(path: &std::path::Path, w: u32, h: u32, f: impl Fn(u32, u32) -> u8) {
    let mut raw = Vec::new();
    for y in 0..h {
        raw.push(0u8);
        raw.extend((0..w).map(|x| f(x, y)));
    }
    let mut z = vec![0x78, 0x01];
    for (i, block) in raw.chunks(65535).enumerate() {
        let last = (i + 1) * 65535 >= raw.len();
        let n = block.len() as u16;
        z.push(u8::from(last));
        z.extend(n.to_le_bytes());
        z.extend((!n).to_le_bytes());
        z.extend(block);
    }
    let (a, b) =
        raw.iter().fold((1u32, 0u32), |(a, b), &x| ((a + u32::from(x)) % 65521, (b + a + u32::from(x)) % 65521));
    z.extend(((b << 16) | a).to_be_bytes());
    let crc = |data: &[u8]| {
        let mut c = 0xffff_ffffu32;
        for &byte in data {
            c ^= u32::from(byte);
            for _ in 0..8 {
                c = if c & 1 == 1 { 0xedb8_8320 ^ (c >> 1) } else { c >> 1 };
            }
        }
        !c
    };
    let chunk = |out: &mut Vec<u8>, kind: &[u8], data: &[u8]| {
        out.extend((data.len() as u32).to_be_bytes());
        let body = [kind, data].concat();
        out.extend(&body);
        out.extend(crc(&body).to_be_bytes());
    };
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let ihdr = [&w.to_be_bytes()[..], &h.to_be_bytes(), &[8, 0, 0, 0, 0]].concat();
    chunk(&mut png, b"IHDR", &ihdr);
    chunk(&mut png, b"IDAT", &z);
    chunk(&mut png, b"IEND", &[]);
    std::fs::write(path, png).unwrap();
}

/// `register` of an image constant along y with itself returned a shift
/// of 47 pixels: the metric is flat along y (every shift sees the same
/// rows), and the line search followed rounding noise to its step limit.
/// The identity stays the identity.
#[test]
fn register_stays_on_a_flat_direction() {
    let d = temp("defio", "flat");
    let png = d.join("flat.png");
    gray_png(&png, 128, 96, |x, _| (127.0 + 100.0 * (f64::from(x) / 6.0).sin()) as u8);
    let v = json(&itgfx(&["register", s(&png), s(&png), "--out", s(&d.join("r")), "--json"]));
    let (a, tx, ty) = (v["angle_deg"].as_f64().unwrap(), v["tx"].as_f64().unwrap(), v["ty"].as_f64().unwrap());
    // Along y not a step; along x and in angle, within interpolation's
    // hundredth of a pixel of the identity.
    assert!(ty.abs() < 1e-9 && tx.abs() < 0.01 && a.abs() < 0.01, "{v}");
    assert!(v["overlap"].as_f64().unwrap() > 0.99, "{v}");
}

/// `measure bottleneck` on 2,000 rows ran past 60 s with no word: the merge
/// losses are kept now (400 x 64: 43 s -> 1.5 s CPU), progress goes to
/// stderr, and a run estimated above `--max-seconds` (60) is refused.
#[test]
fn bottleneck_estimate_progress_and_refusal() {
    let d = temp("defio", "bottleneck");
    let csv = d.join("j.csv");
    let (rows, cols) = (600, 64);
    let mut state = 7u64;
    let values: Vec<f64> = (0..rows * cols)
        .map(|_| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 + 0.01
        })
        .collect();
    let total: f64 = values.iter().sum();
    let text: String = values
        .chunks(cols)
        .map(|r| r.iter().map(|x| format!("{:?}", x / total)).collect::<Vec<_>>().join(","))
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(&csv, text).unwrap();
    let out = itgfx(&["measure", "bottleneck", "--joint", s(&csv), "--max-seconds", "1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("600 rows x 64 columns") && err.contains("--max-seconds 1"), "{err}");
    let five_k = d.join("wide.csv");
    std::fs::write(&five_k, vec!["0.0002"; 5000].join("\n")).unwrap();
    fails(&["measure", "bottleneck", "--joint", s(&five_k)], "above --max-seconds 60");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_itgfx"))
        .args(["measure", "bottleneck", "--joint", s(&csv), "--json"])
        .env("ITGFX_PROGRESS", "1")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["merges"].as_array().unwrap().len(), rows - 1);
    assert!(String::from_utf8_lossy(&out.stderr).contains("Mcomparisons/s"), "progress on stderr");
}
