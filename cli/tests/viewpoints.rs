//! `itgfx viewpoints` end to end.

use std::process::{Command, Output};

fn itgfx(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_itgfx")).args(args).output().expect("run itgfx")
}

#[test]
fn cube_json_and_pictures() {
    let dir = std::env::temp_dir().join(format!("itgfx-vp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("box.obj");
    // A cube with faces wound outwards: seen from outside.
    std::fs::write(
        &obj,
        "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
         f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n",
    )
    .unwrap();
    let best = dir.join("best.png");
    let out = itgfx(&[
        "viewpoints",
        obj.to_str().unwrap(),
        "--viewpoints",
        "42",
        "--estimator",
        "grid",
        "--resolution",
        "64",
        "--best-image",
        best.to_str().unwrap(),
        "--json",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["polygons"], 6);
    assert_eq!(v["views"].as_array().unwrap().len(), 42);
    // The best view sees three faces: its direction is far from every axis.
    let d: Vec<f64> = v["best_view_direction"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    assert!(d.iter().all(|c| c.abs() > 0.2), "best direction {d:?}");
    let best_vmi = v["views"][v["best_view"].as_u64().unwrap() as usize]["VMI"].as_f64().unwrap();
    for view in v["views"].as_array().unwrap() {
        assert!(view["VMI"].as_f64().unwrap() >= best_vmi);
    }
    assert_eq!(&std::fs::read(&best).unwrap()[1..4], b"PNG");
    for (args, needle) in [
        (&["viewpoints", "/nonexistent/mesh.obj"][..], "/nonexistent/mesh.obj"),
        (&["viewpoints", "cube", "--resolution", "2"][..], "--resolution"),
        (&["viewpoints", "cube", "--distance", "0.5"][..], "--distance"),
    ] {
        let out = itgfx(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(String::from_utf8_lossy(&out.stderr).contains(needle), "{args:?}");
    }
    let out = itgfx(&["viewpoints", obj.to_str().unwrap(), "--viewpoints", "50"]);
    assert_eq!(out.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--out DIR` writes every picture of a built-in mesh; the JSON names them,
/// carries the best-n selection and the exploration path, and per-polygon
/// arrays only on request.
#[test]
fn built_in_mesh_writes_every_picture() {
    let dir = std::env::temp_dir().join(format!("itgfx-vp-out-{}", std::process::id()));
    let out = itgfx(&[
        "viewpoints",
        "table-chairs",
        "--viewpoints",
        "42",
        "--estimator",
        "grid",
        "--resolution",
        "48",
        "--out",
        dir.to_str().unwrap(),
        "--per-polygon",
        "--json",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let names = [
        "best.png",
        "worst.png",
        "best-n.png",
        "best-importance.png",
        "sphere.png",
        "ao.png",
        "saliency.png",
        "info.png",
        "ao.ply",
        "saliency.ply",
    ];
    let wrote = v["wrote"].as_array().unwrap();
    assert_eq!(wrote.len(), names.len());
    for n in names {
        let bytes = std::fs::read(dir.join(n)).unwrap();
        assert!(bytes.starts_with(b"\x89PNG") || bytes.starts_with(b"ply"), "{n}");
    }
    let polygons = v["polygons"].as_u64().unwrap() as usize;
    assert_eq!(v["saliency"].as_array().unwrap().len(), polygons);
    assert_eq!(v["best_n_views"][0], v["best_view"]);
    assert!(v["exploration_path"].as_array().unwrap().len() > 1);
    assert!(v["views"][0]["saliency"].as_f64().unwrap() >= 0.0);
    // No per-polygon arrays by default.
    let out = itgfx(&[
        "viewpoints",
        "torus:12,6",
        "--viewpoints",
        "12",
        "--estimator",
        "grid",
        "--resolution",
        "16",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v.get("saliency").is_none() && v.get("wrote").is_none());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The default estimator (exact solid angles, visibility sampled where it
/// changes) meets its tolerance and says so per view; `--resolution` belongs
/// to the grid estimator only.
#[test]
fn default_estimator_reports_standard_errors_and_tolerance() {
    let out = itgfx(&["viewpoints", "torus:16,8", "--viewpoints", "12", "--tolerance", "0.02", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["estimator"], "solid-angle");
    assert_eq!(v["tolerance_met"], true);
    assert!(v.get("rays_per_viewpoint").is_none());
    for view in v["views"].as_array().unwrap() {
        let (vmi, se) = (view["VMI"].as_f64().unwrap(), view["VMI_stderr"].as_f64().unwrap());
        assert!(se >= 0.0 && 2.0 * se <= 0.02 * vmi + 1e-12, "VMI {vmi} stderr {se}");
        assert_eq!(view["tolerance_met"], true);
    }
    // The torus hides part of itself from most views: some triangles needed sampling.
    assert!(v["boundary_triangles"].as_u64().unwrap() > 0);
    let out = itgfx(&["viewpoints", "cube", "--resolution", "64"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--estimator grid"));
    for bad in ["0", "0.9", "nan"] {
        let out = itgfx(&["viewpoints", "cube", "--tolerance", bad]);
        assert_eq!(out.status.code(), Some(2), "--tolerance {bad}");
    }
}
