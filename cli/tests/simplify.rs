//! `itgfx simplify` end to end: a closed torus simplified by VMI and VE,
//! the outputs checked for manifoldness, genus, triangle counts, the
//! channel's I(V;O) against `itgfx viewpoints`, and bad input.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn itgfx(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_itgfx")).args(args).output().expect("run itgfx")
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("itgfx-simplify-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A closed torus of `u × v` quads split into triangles (`2uv` triangles),
/// shared vertices, faces wound outwards, with a bump so that it has no
/// symmetry making every collapse cost the same.
fn torus(path: &Path, u: usize, v: usize) {
    let mut s = String::new();
    for i in 0..u {
        for j in 0..v {
            let (a, b) = (std::f64::consts::TAU * i as f64 / u as f64, std::f64::consts::TAU * j as f64 / v as f64);
            let r = 0.35 * (1.0 + 0.3 * (3.0 * a).cos().max(0.0));
            let (x, y, z) = ((1.0 + r * b.cos()) * a.cos(), (1.0 + r * b.cos()) * a.sin(), r * b.sin());
            s.push_str(&format!("v {x} {y} {z}\n"));
        }
    }
    let id = |i: usize, j: usize| (i % u) * v + (j % v) + 1;
    for i in 0..u {
        for j in 0..v {
            let (p, q, r, t) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            s.push_str(&format!("f {p} {q} {r}\nf {p} {r} {t}\n"));
        }
    }
    std::fs::write(path, s).unwrap();
}

/// Vertices used, edges and triangles of an OBJ, and the largest number
/// of triangles on one edge.
fn topology(path: &Path) -> (usize, usize, usize, usize) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut faces = Vec::new();
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("f ") {
            let t: Vec<usize> = rest.split_whitespace().map(|w| w.parse().unwrap()).collect();
            assert_eq!(t.len(), 3, "{line}");
            faces.push(t);
        }
    }
    let mut edges: HashMap<(usize, usize), usize> = HashMap::new();
    let mut verts = std::collections::HashSet::new();
    for t in &faces {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            verts.insert(a);
        }
    }
    (verts.len(), edges.len(), faces.len(), edges.values().copied().max().unwrap_or(0))
}

fn json(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn torus_sweep_stays_a_manifold_torus_at_the_targets() {
    let d = dir("sweep");
    let obj = d.join("torus.obj");
    torus(&obj, 16, 8);
    let out = d.join("out");
    let (o, ds) = (out.to_str().unwrap(), obj.to_str().unwrap());
    let v = json(&itgfx(&["simplify", ds, "--sweep", "50%,64", "--viewpoints", "12", "--out", o, "--json"]));
    assert_eq!(v["triangles"], 256);
    let results = v["results"].as_array().unwrap();
    assert_eq!(results.len(), 2);
    for (r, want) in results.iter().zip([128, 64]) {
        assert_eq!(r["triangles"], want, "{r}");
        let path = PathBuf::from(r["obj"].as_str().unwrap());
        let (nv, ne, nf, most) = topology(&path);
        assert_eq!(nf, want);
        // Closed and manifold: every edge has exactly two triangles...
        assert_eq!(most, 2, "{path:?}");
        assert_eq!(2 * ne, 3 * nf);
        // ... and the genus is kept: V − E + F = 0 for a torus.
        assert_eq!(nv as i64 - ne as i64 + nf as i64, 0, "{path:?}");
        let rmse = r["image_rmse"].as_f64().unwrap();
        assert!(rmse > 0.0 && rmse < 0.5, "{rmse}");
        let h = r["hausdorff"].as_f64().unwrap();
        assert!(h > 0.0 && h < 0.5, "{h}");
        assert!(r["mean_distance"].as_f64().unwrap() <= h);
    }
    // Fewer triangles, larger errors.
    assert!(results[1]["hausdorff"].as_f64() >= results[0]["hausdorff"].as_f64());
    for f in ["original.png", "compare.png", "simplified_128.png", "simplified_64.png", "errors.png"] {
        assert_eq!(&std::fs::read(out.join(f)).unwrap()[1..4], b"PNG", "{f}");
    }

    // --evaluate measures a given mesh with the same code: the same numbers.
    let simplified = results[1]["obj"].as_str().unwrap();
    let e = json(&itgfx(&["simplify", ds, "--evaluate", simplified, "--out", o, "--json"]));
    let er = &e["results"][0];
    assert_eq!(er["triangles"], 64);
    for k in ["image_rmse", "silhouette_rmse", "hausdorff", "mean_distance"] {
        let (a, b) = (er[k].as_f64().unwrap(), results[1][k].as_f64().unwrap());
        assert!((a - b).abs() <= 1e-9 * b.max(1e-9), "{k}: {a} vs {b}");
    }

    // Another tool's output with triangles of no area (meshoptimizer leaves
    // some): a vertex repeated at the same place and a face on it, and a
    // face on three points of a line. The reader leaves them out with one
    // warning line instead of refusing the file; the numbers are the clean
    // mesh's.
    let text = std::fs::read_to_string(simplified).unwrap();
    let first: Vec<&str> = text.lines().filter(|l| l.starts_with("v ")).take(2).collect();
    let nv = text.lines().filter(|l| l.starts_with("v ")).count();
    let p: Vec<Vec<f64>> =
        first.iter().map(|l| l.split_whitespace().skip(1).map(|x| x.parse().unwrap()).collect()).collect();
    let mid: Vec<String> = (0..3).map(|k| format!("{}", 0.5 * (p[0][k] + p[1][k]))).collect();
    let dirty = d.join("dirty.obj");
    std::fs::write(&dirty, format!("{text}{}\nv {}\nf 1 2 {}\nf 1 {} 3\n", first[0], mid.join(" "), nv + 2, nv + 1))
        .unwrap();
    let out = itgfx(&["simplify", ds, "--evaluate", dirty.to_str().unwrap(), "--out", o, "--json"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("degenerate-face-dropped") && err.contains("(and 1 more)"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    let e = json(&out);
    let er = &e["results"][0];
    assert_eq!(er["triangles"], 64);
    for k in ["image_rmse", "silhouette_rmse", "hausdorff", "mean_distance"] {
        let (a, b) = (er[k].as_f64().unwrap(), results[1][k].as_f64().unwrap());
        assert!((a - b).abs() <= 1e-9 * b.max(1e-9), "{k}: {a} vs {b}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn channel_information_is_the_viewpoint_commands() {
    // The simplifier's running-sum I(V;O) of the input (core:
    // mutual_information_of_weight_sums) against `itgfx viewpoints` on the
    // same channel (core: SparseChannel::measures): one definition, one
    // number. With the background as a polygon every row sums to the cone's
    // solid angle, so p(v) is uniform: `--background --uniform-input`.
    let d = dir("ivo");
    let obj = d.join("torus.obj");
    torus(&obj, 12, 6);
    let ds = obj.to_str().unwrap();
    let out = d.join("out");
    for (mine, theirs) in [(&[][..], &["--background", "--uniform-input"][..]), (&["--no-background"][..], &[][..])] {
        let mut args =
            vec!["simplify", ds, "--target", "50%", "--viewpoints", "12", "--out", out.to_str().unwrap(), "--json"];
        args.extend_from_slice(mine);
        let s = json(&itgfx(&args));
        assert_eq!(s["results"][0]["triangles"], 72);
        let mut args =
            vec!["viewpoints", ds, "--viewpoints", "12", "--tolerance", "0.05", "--max-subdivision", "8", "--json"];
        args.extend_from_slice(theirs);
        let v = json(&itgfx(&args));
        let (a, b) = (s["I_VO"].as_f64().unwrap(), v["I_VO"].as_f64().unwrap());
        assert!((a - b).abs() < 1e-9, "{mine:?}: simplify {a} vs viewpoints {b}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn same_output_for_any_thread_count() {
    let d = dir("threads");
    let obj = d.join("torus.obj");
    torus(&obj, 12, 6);
    for placement in ["blend", "best", "endpoint"] {
        let mut objs = Vec::new();
        for t in ["1", "2"] {
            let out = d.join(format!("out{t}-{placement}"));
            let v = json(&itgfx(&[
                "simplify",
                obj.to_str().unwrap(),
                "--target",
                "40",
                "--viewpoints",
                "12",
                "--placement",
                placement,
                "--threads",
                t,
                "--out",
                out.to_str().unwrap(),
                "--json",
            ]));
            assert_eq!(v["results"][0]["triangles"], 40, "{placement}");
            objs.push(std::fs::read(v["results"][0]["obj"].as_str().unwrap()).unwrap());
        }
        assert_eq!(objs[0], objs[1], "{placement}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn bad_input_is_one_line_and_exit_2() {
    let d = dir("bad");
    let obj = d.join("torus.obj");
    torus(&obj, 8, 4);
    let fin = d.join("fin.obj");
    // Three triangles on one edge.
    std::fs::write(&fin, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n").unwrap();
    let (o, m) = (d.join("out"), obj.to_str().unwrap());
    let o = o.to_str().unwrap();
    let big = d.join("big.obj");
    // 56,000 triangles × 2562 viewpoints of weights: over the 2 GiB cap.
    torus(&big, 200, 140);
    let file = d.join("a-file");
    std::fs::write(&file, "x").unwrap();
    for (args, needle) in [
        (vec!["simplify", m, "--target", "0", "--out", o], "--target"),
        (vec!["simplify", m, "--target", "-5", "--out", o], "--target"),
        (vec!["simplify", m, "--target", "0%", "--out", o], "--target"),
        (vec!["simplify", m, "--target", "100%", "--out", o], "--target"),
        (vec!["simplify", m, "--target", "abc", "--out", o], "--target"),
        (vec!["simplify", m, "--target", "64", "--out", o], "not fewer than the mesh's 64"),
        (vec!["simplify", m, "--sweep", "50%,x", "--out", o], "--sweep"),
        (vec!["simplify", m, "--out", o], "--target"),
        (vec!["simplify", m, "--target", "10%"], "--out"),
        (vec!["simplify", m, "--target", "10%", "--out", file.to_str().unwrap()], "not a directory"),
        (vec!["simplify", m, "--target", "10%", "--out", o, "--metric", "qem"], "--metric"),
        (vec!["simplify", m, "--target", "10%", "--out", o, "--viewpoints", "50"], "--viewpoints"),
        (vec!["simplify", m, "--target", "10%", "--out", o, "--placement", "optimal"], "--placement"),
        (vec!["simplify", m, "--target", "10%", "--out", o, "--lambda", "nan"], "--lambda"),
        (vec!["simplify", "sphere", "--target", "10%", "--out", o], "no triangles"),
        (vec!["simplify", big.to_str().unwrap(), "--target", "10%", "--out", o, "--viewpoints", "2562"], "GiB"),
        (vec!["simplify", "/nonexistent/mesh.obj", "--target", "10%", "--out", o], "/nonexistent/mesh.obj"),
        (vec!["simplify", m, "--target", "10%", "--evaluate", m, "--out", o], "--evaluate"),
    ] {
        let out = itgfx(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    }
    // A fin (three triangles on an edge) is repaired: the third triangle is
    // detached; three triangles cannot lose one and stay a surface, so the
    // run stops short of its target and says why.
    let out = itgfx(&["simplify", fin.to_str().unwrap(), "--target", "2", "--out", o, "--json"]);
    let v = json(&out);
    assert_eq!(v["repaired_detached"], 1);
    assert_eq!(v["results"][0]["triangles"], 3);
    assert!(v["results"][0]["stalled"].as_str().unwrap().contains("stopped at 3"));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("repaired") && err.contains("not reached"), "{err}");
    std::fs::remove_dir_all(&d).unwrap();
}
