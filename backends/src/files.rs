//! Opening input files: regular files only.
//!
//! `open()` on a FIFO with no writer blocks until one comes, and a device
//! may never end, so every input (OBJ, MTL, counts, shards, NRRD and raw
//! volumes, EXR, PNG, CSV) is refused unless it is a regular file (after
//! following links), before it is opened.

use std::fs::{self, File};
use std::io;
use std::path::Path;

/// `Ok` when `path` names a regular file (through links); otherwise the
/// system's error (missing, unreadable) or one saying what it is instead.
///
/// # Errors
/// Not found, a directory, a FIFO, device or socket.
pub fn check_regular(path: &Path) -> io::Result<()> {
    let meta = fs::metadata(path)?;
    if meta.is_file() {
        return Ok(());
    }
    let what = if meta.is_dir() {
        "is a directory"
    } else {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_fifo() {
            "is a FIFO, not a regular file"
        } else if t.is_char_device() || t.is_block_device() {
            "is a device, not a regular file"
        } else {
            "not a regular file"
        }
    };
    Err(io::Error::new(io::ErrorKind::InvalidInput, what))
}

/// Opens a regular file for reading ([`check_regular`] first, so a FIFO is
/// never opened).
///
/// # Errors
/// As [`check_regular`], then `open`'s.
pub fn open_regular(path: &Path) -> io::Result<File> {
    check_regular(path)?;
    File::open(path)
}

/// The whole of a regular file.
///
/// # Errors
/// As [`open_regular`], then the read's.
pub fn read_regular(path: &Path) -> io::Result<Vec<u8>> {
    check_regular(path)?;
    fs::read(path)
}

/// The whole of a regular file as UTF-8.
///
/// # Errors
/// As [`open_regular`], then the read's (invalid UTF-8 included).
pub fn read_regular_to_string(path: &Path) -> io::Result<String> {
    check_regular(path)?;
    fs::read_to_string(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_regular_files() {
        let d = std::env::temp_dir().join(format!("itgfx-files-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        let f = d.join("a.txt");
        fs::write(&f, "x").unwrap();
        assert_eq!(read_regular_to_string(&f).unwrap(), "x");
        assert!(check_regular(&d).unwrap_err().to_string().contains("directory"));
        assert!(check_regular(Path::new("/dev/null")).unwrap_err().to_string().contains("device"));
        assert_eq!(check_regular(&d.join("none")).unwrap_err().kind(), io::ErrorKind::NotFound);
        let fifo = d.join("p");
        assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
        // Would block forever in open() if it were opened.
        assert!(read_regular(&fifo).unwrap_err().to_string().contains("FIFO"));
        let _ = fs::remove_dir_all(&d);
    }
}
