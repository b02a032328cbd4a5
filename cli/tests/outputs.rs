//! Output files: devices, FIFOs and symbolic links are never replaced by
//! regular files; every output path is checked before the run; errors quote
//! paths so they stay on one line.

use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn itgfx(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_itgfx")).args(args).output().expect("run itgfx")
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("itgfx-outputs-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn one_line_exit_2(out: &Output) -> String {
    one_line_exit(out, 2)
}

/// Exit 1 is a failure on the way (a write), 2 a usage error.
fn one_line_exit(out: &Output, code: i32) -> String {
    assert_eq!(out.status.code(), Some(code), "{}", String::from_utf8_lossy(&out.stderr));
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(err.lines().count(), 1, "{err}");
    err
}

#[test]
fn dev_full_is_written_through_and_its_error_reported() {
    for flag in ["--image", "--export-ply", "--save-counts"] {
        let out = itgfx(&["complexity", "cube", "--lines", "1000", flag, "/dev/full"]);
        let err = one_line_exit(&out, 1);
        assert!(err.contains("/dev/full") && err.contains("No space left"), "{flag}: {err}");
        assert!(std::fs::metadata("/dev/full").unwrap().file_type().is_char_device(), "still a device");
    }
    // /dev/null accepts anything: exit 0, still a device.
    let out = itgfx(&["complexity", "cube", "--lines", "1000", "--export-ply", "/dev/null"]);
    assert!(out.status.success());
    assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device());
}

#[test]
fn a_symlink_survives_and_its_target_is_replaced() {
    let d = dir("link");
    let (target, link) = (d.join("real.ply"), d.join("link.ply"));
    std::fs::write(&target, "old").unwrap();
    std::os::unix::fs::symlink("real.ply", &link).unwrap();
    let out = itgfx(&["complexity", "cube", "--lines", "1000", "--export-ply", s(&link)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink(), "the link is kept");
    assert!(std::fs::read_to_string(&target).unwrap().starts_with("ply\n"), "the target is written");
    // A dangling link is written through to its (new) target.
    let (gone, dangling) = (d.join("new.counts"), d.join("dangling.counts"));
    std::os::unix::fs::symlink(&gone, &dangling).unwrap();
    let out = itgfx(&["complexity", "cube", "--lines", "1000", "--save-counts", s(&dangling)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::symlink_metadata(&dangling).unwrap().file_type().is_symlink());
    assert!(gone.is_file());
}

#[test]
fn a_fifo_stays_a_fifo() {
    let d = dir("fifo");
    let fifo = d.join("pipe");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let reader = {
        let f = fifo.clone();
        std::thread::spawn(move || std::fs::read(f).unwrap())
    };
    let out = itgfx(&["complexity", "cube", "--lines", "1000", "--save-counts", s(&fifo)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let got = reader.join().unwrap();
    assert!(!got.is_empty(), "the reader got the counts");
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo(), "not replaced by a file");
}

#[test]
fn every_output_is_checked_before_the_run() {
    let d = dir("check");
    let ok = d.join("ok.ply");
    let out = itgfx(&["complexity", "cube", "--lines", "1000", "--export-ply", s(&ok), "--image", "nodir/x.png"]);
    let err = one_line_exit_2(&out);
    assert!(err.contains("--image") && err.contains("\"nodir/x.png\""), "{err}");
    assert!(!ok.exists(), "nothing written when another output is bad");
    // A directory is not a file.
    let out = itgfx(&["complexity", "cube", "--lines", "1000", "--save-counts", s(&d)]);
    assert!(one_line_exit_2(&out).contains("is a directory"));
    // The viewpoint pictures too.
    let out = itgfx(&["viewpoints", "cube", "--best-image", s(&ok), "--sphere-image", "nodir/s.png"]);
    one_line_exit_2(&out);
    assert!(!ok.exists());
    assert!(std::fs::read_dir(&d).unwrap().next().is_none(), "no probe or temporary file left");
}

#[test]
fn a_newline_in_a_path_stays_on_one_line() {
    let out = itgfx(&["complexity", "cube", "--lines", "1000", "--image", "no\ndir/x.png"]);
    let err = one_line_exit_2(&out);
    assert!(err.contains("no\\ndir/x.png"), "{err}");
    let out = itgfx(&["complexity", "/nonexistent/a\nb.obj"]);
    one_line_exit_2(&out);
}

#[test]
fn an_empty_path_is_refused() {
    for args in [
        &["viewpoints", "cube", "--out", ""][..],
        &["complexity", "cube", "--image", ""],
        &["complexity", "cube", "--save-counts", ""],
    ] {
        let err = one_line_exit_2(&itgfx(args));
        assert!(err.contains("empty path"), "{args:?}: {err}");
    }
}

#[test]
fn a_refused_run_leaves_no_out_directory() {
    let d = dir("outdir");
    let out_dir = d.join("pictures");
    let out = itgfx(&["viewpoints", "cube", "--out", s(&out_dir), "--best-image", "nodir/b.png"]);
    one_line_exit_2(&out);
    assert!(!out_dir.exists(), "the --out directory made for the run is removed again");
}

/// A dangling symbolic link as `--out DIR` is refused in one line saying
/// what it is (it was "File exists (os error 17)"), and nothing is created
/// at its target.
#[test]
fn a_dangling_link_as_out_is_refused_plainly() {
    let d = dir("dangling");
    let link = d.join("out");
    let target = d.join("missing");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    for args in
        [vec!["phantom", "--out", s(&link)], vec!["viewpoints", "tetrahedron", "--viewpoints", "12", "--out", s(&link)]]
    {
        let err = one_line_exit_2(&itgfx(&args));
        assert!(err.contains(&format!("--out {link:?}: a symbolic link to {target:?}, which does not exist")), "{err}");
        assert!(!err.contains("os error 17"), "{err}");
        assert!(!target.exists());
    }
}
