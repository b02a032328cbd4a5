#![no_main]
//! The glTF/GLB reader: the input up to the first NUL byte is the file
//! (JSON or GLB), the rest the bytes of every external buffer it names.
//! Oracle: `Ok(scene)` validates, has finite positive areas, materials in
//! range and a finite camera if any; otherwise an `Err` with a one-line
//! message. Never a panic.
use itgfx_backends::formats::gltf::{parse_gltf, relative_uri};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (file, ext) = match data.iter().position(|&b| b == 0) {
        Some(i) if !data.starts_with(b"glTF") => (&data[..i], &data[i + 1..]),
        _ => (data, &[][..]),
    };
    match parse_gltf("fuzz.gltf", file, |uri| relative_uri(uri).map(|_| ext.to_vec())) {
        Ok(scene) => {
            assert!(scene.validate().is_ok());
            for p in &scene.patches {
                assert!(p.area.is_finite() && p.area > 0.0, "area {}", p.area);
                assert!(p.material < scene.materials.len());
            }
            for m in &scene.materials {
                assert!(m.reflectance.iter().all(|r| (0.0..=1.0).contains(r)));
                assert!(m.emittance.iter().all(|e| e.is_finite() && *e >= 0.0));
            }
            if let Some(c) = scene.camera {
                assert!(c.eye.is_finite() && c.forward.is_finite() && c.fov_y > 0.0);
            }
            for w in &scene.warnings {
                assert!(!w.contains('\n'));
            }
        }
        Err(e) => assert!(!e.to_string().contains('\n'), "{e}"),
    }
});
