//! What `itgfx phantom`, `itgfx register` and `itgfx segment` (information
//! theory on images, syllabus Part 8, over [`itgfx_backends::imaging`];
//! the commands are in `commands/`) share: their value parsers, pictures
//! and progress lines.

pub mod pictures;

use crate::values::{real, real_in};

/// One of several numbers: [`real`], its refusal naming the text (`"x" is not a finite number`).
fn finite(v: &str) -> Result<f64, String> {
    real(v.trim()).map_err(|e| format!("{v:?} {e}"))
}

/// Largest width or height of a generated phantom.
pub const MAX_SIDE: usize = 8192;

/// `W,H`: two sides in `4..=8192`, at most [`pictures::MAX_PIXELS`] pixels.
///
/// # Errors
/// A reason.
pub fn size(s: &str) -> Result<(usize, usize), String> {
    let (w, h) = s.split_once(',').ok_or("is not W,H (two integers and a comma)")?;
    let side = |v: &str| -> Result<usize, String> {
        let n: usize = v.trim().parse().map_err(|_| format!("{v:?} is not a whole number"))?;
        if (4..=MAX_SIDE).contains(&n) { Ok(n) } else { Err(format!("each side must be in 4..={MAX_SIDE}, not {n}")) }
    };
    let (w, h) = (side(w)?, side(h)?);
    if (w * h) as u64 > pictures::MAX_PIXELS {
        return Err(format!("{w} x {h} is more than {} pixels", pictures::MAX_PIXELS));
    }
    Ok((w, h))
}

/// A comma-separated list of 1 to 8 finite numbers (the length is checked
/// where the dimension is known: 2D or 3D).
#[derive(Clone, Debug, PartialEq)]
pub struct Numbers(pub Vec<f64>);

/// Parses [`Numbers`].
///
/// # Errors
/// A reason.
pub fn numbers(s: &str) -> Result<Numbers, String> {
    let v: Vec<f64> = s.split(',').map(finite).collect::<Result<_, _>>()?;
    if v.len() > 8 { Err("give at most 8 numbers".into()) } else { Ok(Numbers(v)) }
}

/// Largest side of a generated phantom volume.
pub const MAX_SIDE_3D: usize = 1024;

/// `--size` of `phantom`: `W,H` ([`size`]) or `X,Y,Z` (sides in `4..=1024`,
/// at most [`pictures::MAX_PIXELS`] voxels).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Size {
    /// An image.
    Two(usize, usize),
    /// A volume.
    Three([usize; 3]),
}

/// Parses [`Size`].
///
/// # Errors
/// A reason.
pub fn sizes(s: &str) -> Result<Size, String> {
    if s.split(',').count() != 3 {
        return size(s).map(|(w, h)| Size::Two(w, h));
    }
    let mut d = [0usize; 3];
    for (k, v) in s.split(',').enumerate() {
        let n: usize = v.trim().parse().map_err(|_| format!("{v:?} is not a whole number"))?;
        if !(4..=MAX_SIDE_3D).contains(&n) {
            return Err(format!("each side must be in 4..={MAX_SIDE_3D}, not {n}"));
        }
        d[k] = n;
    }
    if (d[0] * d[1] * d[2]) as u64 > pictures::MAX_PIXELS {
        return Err(format!("{} x {} x {} is more than {} voxels", d[0], d[1], d[2], pictures::MAX_PIXELS));
    }
    Ok(Size::Three(d))
}

/// `X,Y`: two finite numbers.
///
/// # Errors
/// A reason.
pub fn pair(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s.split_once(',').ok_or("is not X,Y (two numbers and a comma)")?;
    Ok((finite(a)?, finite(b)?))
}

/// `--angle`: degrees in `[−180, 180]`.
///
/// # Errors
/// A reason.
pub fn angle(s: &str) -> Result<f64, String> {
    real_in(s, -180.0, 180.0)
}

/// `--noise`: standard deviation in `[0, 1]`.
///
/// # Errors
/// A reason.
pub fn unit(s: &str) -> Result<f64, String> {
    real_in(s, 0.0, 1.0)
}

/// `--bias`: in `[0, 0.9]` (the field stays positive).
///
/// # Errors
/// A reason.
pub fn bias(s: &str) -> Result<f64, String> {
    real_in(s, 0.0, 0.9)
}

/// `--bins`: 2..=256.
///
/// # Errors
/// A reason.
pub fn bins(s: &str) -> Result<usize, String> {
    let n: usize = s.parse().map_err(|_| "is not a whole number".to_string())?;
    if (2..=256).contains(&n) { Ok(n) } else { Err("must be in 2..=256".into()) }
}

/// Progress lines on stderr when it is a terminal or `ITGFX_PROGRESS=1`.
pub fn say(msg: &str) {
    use std::io::IsTerminal;
    if std::io::stderr().is_terminal() || std::env::var_os("ITGFX_PROGRESS").is_some_and(|v| v == "1") {
        eprintln!("{msg}");
    }
}
