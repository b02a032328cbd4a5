#![no_main]
//! The OBJ/MTL reader: the input up to the first NUL byte is the OBJ, the
//! rest the MTL that every `mtllib` names. Oracle: `Ok(scene)` validates,
//! has finite positive areas and unit normals, and every material is in
//! range; otherwise an `Err` with a one-line message. Never a panic.
use itgfx_backends::obj::parse_obj;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (obj, mtl) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    match parse_obj("fuzz.obj", obj, |_| Ok(("fuzz.mtl".to_string(), mtl.to_vec()))) {
        Ok(scene) => {
            assert!(scene.validate().is_ok());
            assert!(!scene.patches.is_empty());
            for p in &scene.patches {
                assert!(p.area.is_finite() && p.area > 0.0, "area {}", p.area);
                assert!(p.normal.is_finite());
                assert!(p.material < scene.materials.len());
            }
            for m in &scene.materials {
                assert!(m.reflectance.iter().all(|r| (0.0..=1.0).contains(r)));
                assert!(m.emittance.iter().all(|e| e.is_finite() && *e >= 0.0));
            }
            for w in &scene.warnings {
                assert!(!w.contains('\n'));
            }
        }
        Err(e) => assert!(!e.to_string().contains('\n'), "{e}"),
    }
});
