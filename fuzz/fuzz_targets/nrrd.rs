#![no_main]
//! The NRRD reader: any bytes, and a valid header with its numbers edited
//! (sizes, spacings, space directions) over a few bytes of data, either read
//! into a volume whose voxel count matches its sizes, with finite values and
//! finite positive spacings, or are refused in one line. Never a panic, and
//! never an allocation the file's length does not back.
use itgfx_backends::volume::nrrd::read_nrrd;
use libfuzzer_sys::fuzz_target;

#[path = "mutate.rs"]
mod mutate;

/// A 2 x 2 x 2 `uchar` volume's header (`space directions` form).
const HEADER: &str =
    "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nspace directions: (1.5,0,0) (0,1,0) (0,0,2)\nencoding: raw\n\n";
/// The same with `spacings` and 16-bit values.
const HEADER_SPACINGS: &str =
    "NRRD0005\ntype: ushort\ndimension: 3\nsizes: 2 2 2\nspacings: 1 1 0.5\nendian: little\nencoding: raw\n\n";

fuzz_target!(|data: &[u8]| {
    // The reader takes a path (it checks the file's length before
    // allocating): each input is written to this process's own file.
    let path = std::env::temp_dir().join(format!("itgfx-fuzz-{}.nrrd", std::process::id()));
    check(&path, data);
    for header in [HEADER, HEADER_SPACINGS] {
        let mut file = mutate::edit_numbers(header, data).into_bytes();
        file.extend_from_slice(&data[..data.len().min(64)]);
        check(&path, &file);
    }
});

fn check(path: &std::path::Path, bytes: &[u8]) {
    std::fs::write(path, bytes).expect("write the input");
    match read_nrrd(path) {
        Ok(v) => {
            assert_eq!(v.data.len(), v.dims.iter().product::<usize>());
            assert!(v.data.iter().all(|x| x.is_finite()));
            assert!(v.spacing.iter().all(|s| s.is_finite() && *s > 0.0), "{:?}", v.spacing);
        }
        Err(e) => assert!(!e.to_string().contains('\n'), "{e}"),
    }
}
