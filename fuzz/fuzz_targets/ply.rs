#![no_main]
//! The PLY reader (ASCII and binary, headers that lie). Oracle: `Ok(scene)`
//! validates, has finite positive areas and unit normals and one material;
//! otherwise an `Err` with a one-line message. Never a panic, and never an
//! allocation the file's length does not back (libFuzzer's -rss_limit_mb).
use itgfx_backends::formats::ply::parse_ply;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    match parse_ply("fuzz.ply", data) {
        Ok(scene) => {
            assert!(scene.validate().is_ok());
            assert!(!scene.patches.is_empty());
            for p in &scene.patches {
                assert!(p.area.is_finite() && p.area > 0.0, "area {}", p.area);
                assert!(p.normal.is_finite());
                assert_eq!(p.material, 0);
            }
            for w in &scene.warnings {
                assert!(!w.contains('\n'));
            }
        }
        Err(e) => assert!(!e.to_string().contains('\n'), "{e}"),
    }
});
