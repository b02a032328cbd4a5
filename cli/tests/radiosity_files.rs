//! `itgfx radiosity` files: the solution as linear OpenEXR beside the PFM,
//! the adaptive mesh as PLY with vertex radiosities, and `--reference`
//! reading either image format with the same scores.

mod common;

use common::{fails, itgfx, json, s, temp};

#[test]
fn exr_ply_and_an_exr_reference() {
    let dir = temp("radiosity-files", "solution");
    let reference = temp("radiosity-files", "reference");
    let r = json(&itgfx(&[
        "radiosity",
        "cornell-box",
        "--path-trace",
        "8",
        "--size",
        "16",
        "--out",
        s(&reference),
        "--json",
    ]));
    assert_eq!(r["walks_per_pixel"], 8);
    let score = |file: &str| {
        json(&itgfx(&[
            "radiosity",
            "cornell-box",
            "--oracle",
            "kl",
            "--epsilon",
            "1e-3",
            "--size",
            "16",
            "--reference",
            s(&reference.join(file)),
            "--out",
            s(&dir),
            "--json",
        ]))
    };
    let (a, b) = (score("reference.exr"), score("reference.pfm"));
    for k in ["RMSE_a", "RMSE_p", "PSNR_a", "RMSE_a_flat", "elements"] {
        assert_eq!(a[k], b[k], "{k}: the EXR and the PFM hold the same f32 pixels");
    }
    // The solution's EXR against the reference's: `compare` reads both.
    let c = json(&itgfx(&["compare", s(&reference.join("reference.exr")), s(&dir.join("radiosity.exr")), "--json"]));
    assert_eq!(c["width"], 16);
    assert!(c["RMSE_a"].as_f64().unwrap() > 0.0);

    // One PLY face per leaf element; every face's indices name a vertex;
    // every vertex radiosity finite and non-negative.
    let ply = std::fs::read_to_string(dir.join("mesh.ply")).unwrap();
    let header = |k: &str| -> usize {
        ply.lines().find_map(|l| l.strip_prefix(&format!("element {k} "))).unwrap().parse().unwrap()
    };
    let (nv, nf) = (header("vertex"), header("face"));
    assert_eq!(nf as u64, a["elements"].as_u64().unwrap(), "one face per element");
    let body: Vec<&str> = ply.lines().skip_while(|l| *l != "end_header").skip(1).collect();
    assert_eq!(body.len(), nv + nf);
    for v in &body[..nv] {
        let f: Vec<f64> = v.split(' ').map(|x| x.parse().unwrap()).collect();
        assert_eq!(f.len(), 9);
        assert!(f[3..6].iter().all(|b| b.is_finite() && *b >= 0.0), "{v}");
    }
    for face in &body[nv..] {
        let f: Vec<usize> = face.split(' ').map(|x| x.parse().unwrap()).collect();
        assert!(f[0] == 3 || f[0] == 4);
        assert_eq!(f.len(), f[0] + 1);
        assert!(f[1..].iter().all(|&i| i < nv), "{face}");
    }
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&reference);
}

#[test]
fn a_bad_exr_reference_is_one_line() {
    let dir = temp("radiosity-files", "bad");
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("r.exr");
    // The EXR magic number, then nothing an EXR reader accepts.
    std::fs::write(&f, [0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0, 0]).unwrap();
    fails(&["radiosity", "cornell-box", "--reference", s(&f)], "OpenEXR");
    let _ = std::fs::remove_dir_all(&dir);
}
