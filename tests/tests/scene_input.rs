//! Reading and building scenes from hostile input (issue 9): OBJ/MTL
//! parsing, the built-in registry and the size limits.

use std::path::PathBuf;
use std::time::Duration;

use glam::DVec3;
use itgfx_backends::obj::{load_obj, parse_obj};
use itgfx_backends::scene::{BUILT_IN, Scene, SceneError, built_in};
use itgfx_backends::tracer::Prepared;

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("itgfx-scene-input-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn file(name: &str, text: &str) -> PathBuf {
    let p = dir().join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn obj(text: &str) -> Result<Scene, SceneError> {
    parse_obj("t.obj", text.as_bytes(), |lib| Err(SceneError::Obj { path: lib.into(), message: "no MTL here".into() }))
}

fn obj_mtl(text: &str, mtl: &str) -> Result<Scene, SceneError> {
    parse_obj("t.obj", text.as_bytes(), |_| Ok(("t.mtl".into(), mtl.as_bytes().to_vec())))
}

const TETRA: [[f64; 3]; 4] = [[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]];

fn tetra(scale: f64, offset: f64) -> String {
    let mut s = String::new();
    for v in TETRA {
        s += &format!("v {:e} {:e} {:e}\n", v[0] * scale + offset, v[1] * scale + offset, v[2] * scale + offset);
    }
    s + "f 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n"
}

#[test]
fn byte_order_mark_keeps_the_first_vertex() {
    let s = obj("\u{feff}v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n").unwrap();
    assert_eq!(s.patches.len(), 2);
    assert!((s.total_area() - 1.0).abs() < 1e-15, "{}", s.total_area());
}

#[test]
fn concave_polygon_has_its_true_area() {
    // Shoelace area 2.2; a fan from the first vertex covers 3.8.
    let s = obj("v 0 0 0\nv 2 0 0\nv 2 2 0\nv 1 0.2 0\nv 0 2 0\nf 1 2 3 4 5\n").unwrap();
    assert_eq!(s.patches.len(), 1);
    assert!((s.patches[0].area - 2.2).abs() < 1e-12, "{}", s.patches[0].area);
    assert_eq!(s.triangles.len(), 3);
}

#[test]
fn self_intersecting_polygon_is_an_error_with_its_line() {
    let e = obj("v 0 0 0\nv 2 2 0\nv 2 0 0\nv 0 1 0\n\nf 1 2 3 4\n").unwrap_err().to_string();
    assert!(e.contains("t.obj: line 6: face 1 is self-intersecting"), "{e}");
}

#[test]
fn non_planar_face_is_a_named_warning() {
    let s = obj("v 0 0 0\nv 1 0 0\nv 1 1 0.2\nv 0 1 0\nf 1 2 3 4\n").unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].starts_with("non-planar-face: t.obj: line 5: face 1"), "{:?}", s.warnings);
    let flat = obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
    assert!(flat.warnings.is_empty(), "{:?}", flat.warnings);
}

#[test]
fn far_offset_tetrahedron_traces_like_the_one_at_the_origin() {
    let at_origin = Prepared::new(&obj(&tetra(1.0, 0.0)).unwrap());
    let far = obj(&tetra(1.0, 1e8)).unwrap();
    assert!(far.warnings.is_empty(), "{:?}", far.warnings);
    let far = Prepared::new(&far);
    assert_eq!(at_origin.triangles, far.triangles);
    assert_eq!(far.centre, DVec3::splat(1e8));
}

#[test]
fn huge_and_tiny_tetrahedra_load_with_the_same_area_ratios() {
    let unit = obj(&tetra(1.0, 0.0)).unwrap();
    for scale in [1e39, 1e300, 1e-300] {
        let s = obj(&tetra(scale, 0.0)).unwrap_or_else(|e| panic!("{scale:e}: {e}"));
        assert!(s.total_area().is_finite() && s.total_area() > 0.0, "{scale:e}");
        for (a, b) in s.areas().iter().zip(unit.areas()) {
            assert!((a / s.total_area() - b / unit.total_area()).abs() < 1e-12, "{scale:e}");
        }
        let p = Prepared::new(&s);
        assert_eq!(p.triangles, Prepared::new(&unit).triangles, "{scale:e}");
    }
    assert!(obj(&tetra(1e300, 0.0)).unwrap().warnings[0].starts_with("rescaled:"));
    // Found by the grammar fuzz below: an unused far vertex must not rescale
    // the used ones into underflow (areas of 0).
    let s = obj("v 1e300 0 0\nv 0 0 0\nv 1e-8 0 0\nv 0 1e-8 0\nf 2 3 4\n").unwrap();
    assert!((s.patches[0].area - 0.5e-16).abs() < 1e-30 && s.warnings.is_empty(), "{:?}", s.patches);
    // Subnormal sizes, and tiny sizes far from the origin, neither overflow nor panic.
    assert!(obj(&tetra(1e-310, 0.0)).is_ok());
    let e = obj(&tetra(1e-300, 1e10)).unwrap_err().to_string();
    assert!(e.contains("degenerate"), "{e}");
    // Too far out for f64 to tell the vertices apart: a clear error.
    let e = obj(&tetra(1.0, 1e300)).unwrap_err().to_string();
    assert!(e.contains("degenerate"), "{e}");
}

#[test]
fn materials_are_read_as_documented() {
    let mtl = "newmtl white\nKd 0.5 0.6 0.7\nnewmtl lamp\nKd 0.1\nKe 10 9 8\nnewmtl glass\nillum 3\nKd 0.2 0.2 0.2\n\
               newmtl chrome\nKd 0 0 0\nKs 0.9 0.8 0.7\n";
    let s = obj_mtl("mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl lamp\nf 1 2 3\nusemtl chrome\nf 1 3 2\n", mtl)
        .unwrap();
    let m = |n: &str| s.materials.iter().find(|m| m.name == n).unwrap();
    assert_eq!(m("white").reflectance, [0.5, 0.6, 0.7]);
    assert_eq!((m("lamp").reflectance, m("lamp").emittance), ([0.1; 3], [10.0, 9.0, 8.0]));
    assert!(m("glass").mirror && m("glass").reflectance == [0.2; 3]);
    assert!(m("chrome").mirror && m("chrome").reflectance == [0.9, 0.8, 0.7]);
    assert!(!m("white").mirror);
    assert_eq!(s.materials[s.patches[0].material].name, "lamp");
    assert_eq!(s.materials[s.patches[1].material].name, "chrome");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn bad_and_unsupported_materials_are_errors_or_named_warnings() {
    let tri = "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
    for (mtl, error) in [
        ("newmtl a\nKd 1.5 0 0\n", "t.mtl: line 2: Kd value 1.5 is outside [0, 1]"),
        ("newmtl a\nKd nan 0 0\n", "t.mtl: line 2: Kd value NaN is outside [0, 1]"),
        ("newmtl a\nKe -1\n", "t.mtl: line 2: material \"a\": Ke value -1 is outside"),
        ("newmtl a\nKe inf\n", "t.mtl: line 2: material \"a\": Ke value inf is outside [0, 1e12]"),
        ("newmtl a\nKe 1 1e300 1\n", "t.mtl: line 2: material \"a\": Ke value 1e300 is outside [0, 1e12]"),
        ("newmtl a\nKd spectral x.rfl\n", "t.mtl: line 2: Kd spectral: only r g b"),
        ("newmtl a\nillum 11\n", "t.mtl: line 2: illum must be one integer in 0..=10"),
        ("Kd 1 1 1\n", "t.mtl: line 1: Kd before any newmtl"),
        ("newmtl b\n", "t.obj: line 5: usemtl \"a\": no such material"),
    ] {
        let e = obj_mtl(tri, mtl).unwrap_err().to_string();
        assert!(e.contains(error), "{mtl:?}: {e}");
    }
    let s =
        obj_mtl(tri, "newmtl a\nKd 1 1 1\nmap_Kd a.png\nd 0.5\nillum 7\nNi 1.5\nKa 0.1 0.1 0.1\nPr 0.5\nKs 1 1 1\n")
            .unwrap();
    let names: Vec<&str> = s.warnings.iter().map(|w| w.split(':').next().unwrap()).collect();
    assert_eq!(
        names,
        [
            "texture-ignored",
            "transparency-ignored",
            "illum-unsupported",
            "ambient-ignored",
            "mtl-statement-ignored",
            "specular-ignored"
        ]
    );
}

#[test]
fn missing_mtl_file_is_named() {
    let p = file("missing-mtl.obj", "mtllib nope.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let e = load_obj(&p).unwrap_err().to_string();
    assert!(e.contains("nope.mtl: mtllib nope.mtl:") && !e.contains('\n'), "{e}");
}

#[test]
fn endless_mtl_is_refused_before_reading() {
    // A device as the MTL (endless: it was read up to the 16 MiB limit) is
    // refused before it is opened, as every non-regular input is.
    let p = file("dev-zero.obj", "mtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let e = load_obj(&p).unwrap_err().to_string();
    assert!(e.contains("/dev/zero: mtllib /dev/zero: is a device, not a regular file"), "{e}");
}

#[cfg(unix)]
#[test]
fn obj_from_a_fifo_is_refused_without_hanging() {
    // A FIFO with no writer hung in open(); non-regular inputs are refused
    // before they are opened (issue 24), so this answers at once.
    let p = dir().join("fifo.obj");
    let _ = std::fs::remove_file(&p);
    assert!(std::process::Command::new("mkfifo").arg(&p).status().unwrap().success());
    let (tx, rx) = std::sync::mpsc::channel();
    let reader_path = p.clone();
    std::thread::spawn(move || tx.send(load_obj(&reader_path).map(|s| s.patches.len())).unwrap());
    let got = rx.recv_timeout(Duration::from_secs(20)).expect("load_obj of a FIFO hangs");
    let e = got.unwrap_err().to_string();
    assert!(e.contains("is a FIFO, not a regular file") && !e.contains('\n'), "{e}");
}

#[test]
fn every_registry_entry_builds_and_refuses_extra_parameters() {
    for b in BUILT_IN {
        let s = built_in(b.name).unwrap_or_else(|e| panic!("{}: {e}", b.name));
        assert!(!s.patches.is_empty());
        assert!(b.syntax.starts_with(b.name));
        let extra = if b.syntax.contains('[') { format!("{}:1:2:3:4", b.name) } else { format!("{}:1", b.name) };
        assert!(
            matches!(built_in(&extra), Err(SceneError::ExtraParameters { .. } | SceneError::BadParameter { .. })),
            "{extra}"
        );
    }
    for spec in ["cube:3", "tetrahedron:1", "cornell-box:x", "sphere:8,8,8", "geosphere:2:2"] {
        assert!(matches!(built_in(spec), Err(SceneError::ExtraParameters { .. })), "{spec}");
    }
    for spec in ["cube-enclosure:0", "cube-enclosure:1001", "geosphere:10", "torus:2,8", "sphere:8", "cubes-room:1001"]
    {
        assert!(matches!(built_in(spec), Err(SceneError::BadParameter { .. })), "{spec}");
    }
    assert!(matches!(built_in("nothing"), Err(SceneError::UnknownScene { .. })));
}

#[test]
fn cubes_room_places_every_cube_or_says_so() {
    assert_eq!(built_in("cubes-room:1000").unwrap().patches.len(), 600 + 6 * 1000);
    assert_eq!(built_in("cubes-room:2197:clustered").unwrap().patches.len(), 600 + 6 * 2197);
    let (lo, hi) = built_in("cubes-room:2197:clustered").unwrap().bounds();
    assert_eq!((lo, hi), (DVec3::ZERO, DVec3::ONE), "cubes stay inside the room");
}

#[test]
fn scenes_past_the_limits_are_refused_before_allocating() {
    for spec in ["sphere:4096,4096", "torus:4096,4096", "table-chairs:256"] {
        let e = built_in(spec).unwrap_err();
        assert!(matches!(e, SceneError::TooLarge { .. }), "{spec}: {e}");
    }
    let e = built_in("cube-enclosure:10").unwrap().subdivided(1024).unwrap_err();
    let SceneError::TooLarge { triangles, patches, .. } = e else { panic!("{e}") };
    assert_eq!((triangles, patches), (1200 * 1024 * 1024, 600 * 1024 * 1024));
    let e = built_in("geosphere:2").unwrap().subdivided(2000).unwrap_err();
    assert!(matches!(e, SceneError::TooLarge { triangles: 320_000_000, .. }), "{e}");
    // Under the limits: counts as predicted.
    let s = built_in("cube-enclosure:2").unwrap().subdivided(3).unwrap();
    assert_eq!((s.triangles.len(), s.patches.len()), (48 * 9, 24 * 9));
    assert!(built_in("sphere:8,16").unwrap().subdivided(4096).is_err());
}

#[test]
fn obj_with_too_many_vertices_in_a_face_is_an_error() {
    let mut s = String::new();
    for i in 0..1100 {
        let a = f64::from(i) / 1100.0 * std::f64::consts::TAU;
        s += &format!("v {} {} 0\n", a.cos(), a.sin());
    }
    s += "f";
    for i in 1..=1100 {
        s += &format!(" {i}");
    }
    let e = obj(&(s + "\n")).unwrap_err().to_string();
    assert!(e.contains("line 1101: face 1 has 1100 vertices, at most 1024"), "{e}");
}

/// A grammar-driven fuzz of the OBJ/MTL reader (the libFuzzer target in
/// `fuzz/` is blind without coverage instrumentation on stable): random
/// statements with hostile numbers and indices. Oracle as in
/// `fuzz/fuzz_targets/obj.rs`: `Ok` scenes validate with finite positive
/// areas and in-range materials, errors are one line, never a panic.
#[test]
fn grammar_fuzz_of_the_obj_and_mtl_reader() {
    let runs: u64 = std::env::var("ITGFX_OBJ_FUZZ_RUNS").ok().and_then(|s| s.parse().ok()).unwrap_or(3000);
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move |n: u64| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state % n
    };
    let numbers = [
        "0",
        "1",
        "-1",
        "0.5",
        "2",
        "1e8",
        "1e39",
        "1e300",
        "-1e300",
        "1e-300",
        "1e-310",
        "nan",
        "inf",
        "1.7976931348623157e308",
        "x",
        "",
        "100000001",
        "3",
    ];
    let obj_keys = [
        "v",
        "v",
        "v",
        "v",
        "f",
        "f",
        "f",
        "g",
        "o",
        "usemtl",
        "mtllib",
        "vt",
        "vn",
        "s",
        "l",
        "#",
        "curv",
        "\u{feff}v",
    ];
    let mtl_keys =
        ["newmtl", "Kd", "Ke", "Ks", "Ka", "illum", "d", "Tr", "Ni", "Ns", "map_Kd", "Tf", "Pr", "Kd spectral"];
    let mut loaded = 0u64;
    for run in 0..runs {
        // Half the runs use only valid numbers, indices and materials.
        let hostile = next(2) == 0;
        let pick = |n: u64, valid: u64, r: u64| if hostile { r % n } else { r % valid };
        let mut o = String::new();
        if !hostile {
            for _ in 0..6 {
                let c = [next(5), next(5), next(5)].map(|i| numbers[i as usize]);
                o += &format!("v {} {} {}\n", c[0], c[1], c[2]);
            }
        }
        for _ in 0..next(30) {
            let key = obj_keys[next(obj_keys.len() as u64) as usize];
            o += key;
            let args = match key {
                "f" | "l" => 3 + next(2) * next(4),
                "usemtl" | "mtllib" | "g" | "o" => 1,
                _ => 3 + pick(2, 1, next(2)) - pick(2, 1, next(2)),
            };
            for _ in 0..args {
                o.push(' ');
                o += &match key {
                    "f" | "l" => {
                        let i = if hostile { next(12) as i64 - 4 } else { next(6) as i64 + 1 };
                        if next(4) == 0 { format!("{i}/1/{i}") } else { i.to_string() }
                    }
                    "usemtl" => ["a", "b", "zz"][pick(3, 2, next(3)) as usize].to_string(),
                    "mtllib" => "m.mtl".to_string(),
                    _ => numbers[pick(numbers.len() as u64, if next(8) == 0 { 11 } else { 5 }, next(1 << 20)) as usize]
                        .to_string(),
                };
            }
            o.push('\n');
        }
        let mut m = String::new();
        m += "newmtl a\nnewmtl b\n";
        for _ in 0..next(12) {
            let key = mtl_keys[pick(mtl_keys.len() as u64, 13, next(64)) as usize];
            m += key;
            let args = if key == "newmtl" {
                1
            } else if hostile {
                next(4)
            } else {
                [1, 3][next(2) as usize]
            };
            for _ in 0..args {
                m.push(' ');
                m += if key == "newmtl" {
                    ["a", "b"][next(2) as usize]
                } else {
                    ["0", "1", "0.5", "3", "1.5", "-1", "nan", "8", "x"][pick(9, 4, next(9)) as usize]
                };
            }
            m.push('\n');
        }
        match parse_obj("f.obj", o.as_bytes(), |_| Ok(("m.mtl".into(), m.as_bytes().to_vec()))) {
            Ok(s) => {
                loaded += 1;
                assert!(s.validate().is_ok(), "run {run}");
                for p in &s.patches {
                    assert!(p.area.is_finite() && p.area > 0.0 && p.normal.is_finite(), "run {run}: {o}");
                    assert!(p.material < s.materials.len());
                }
                for mat in &s.materials {
                    assert!(mat.reflectance.iter().all(|r| (0.0..=1.0).contains(r)), "run {run}");
                    assert!(mat.emittance.iter().all(|e| e.is_finite() && *e >= 0.0), "run {run}");
                }
            }
            Err(e) => assert!(!e.to_string().contains('\n'), "run {run}: {e}"),
        }
    }
    eprintln!("{loaded} of {runs} inputs loaded");
    assert!(loaded * 50 > runs, "the grammar should produce loadable scenes: {loaded} of {runs}");
}
