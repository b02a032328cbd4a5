//! Value parsers for the typed options: each checks its range and says why a
//! value is refused, so clap rejects it before any work starts.

use std::path::PathBuf;

use itgfx_backends::BackendChoice;
use itgfx_core::Base;

/// A non-negative integer; `1e7`, `1_000_000` and `2^20`-free plain digits accepted.
///
/// # Errors
/// A reason, for clap to show beside the option.
pub fn count(s: &str) -> Result<u64, String> {
    let t = s.replace('_', "");
    t.parse::<u64>().or_else(|_| {
        // 1e7-style counts, when they are exact integers that fit.
        t.parse::<f64>()
            .ok()
            .filter(|x| x.fract() == 0.0 && *x >= 0.0 && *x < 1.8e19)
            .map(|x| x as u64)
            .ok_or_else(|| "is not a non-negative integer".to_string())
    })
}

/// The one integer range parser: a [`count`] in `lo..=hi`. Every command's
/// bounded integer options are built on it.
///
/// # Errors
/// A reason.
pub fn ranged(s: &str, lo: u64, hi: u64) -> Result<u64, String> {
    let v = count(s)?;
    if (lo..=hi).contains(&v) { Ok(v) } else { Err(format!("must be in {lo}..={hi}")) }
}

/// A finite number.
///
/// # Errors
/// A reason.
pub fn real(s: &str) -> Result<f64, String> {
    s.parse::<f64>().ok().filter(|x| x.is_finite()).ok_or_else(|| "is not a finite number".to_string())
}

/// The one real range parser: a finite number in `[lo, hi]`.
///
/// # Errors
/// A reason.
pub fn real_in(s: &str, lo: f64, hi: f64) -> Result<f64, String> {
    let v = real(s)?;
    if (lo..=hi).contains(&v) { Ok(v) } else { Err(format!("must be in [{lo}, {hi}]")) }
}

/// `--lines`: positive, at most 10^18 (line indices are 64-bit).
///
/// # Errors
/// A reason.
pub fn lines(s: &str) -> Result<u64, String> {
    match count(s)? {
        0 => Err("must be positive".into()),
        n if n > 1_000_000_000_000_000_000 => Err("must be at most 1e18".into()),
        n => Ok(n),
    }
}

/// `--threads`: 1..=1024.
///
/// # Errors
/// A reason.
pub fn threads(s: &str) -> Result<usize, String> {
    ranged(s, 1, 1024).map(|v| v as usize)
}

/// `--subdivide` of `complexity`: 1..=1024.
///
/// # Errors
/// A reason.
pub fn subdivide(s: &str) -> Result<u32, String> {
    ranged(s, 1, 1024).map(|v| v as u32)
}

/// `--subdivide` of `viewpoints`: 1..=64 (beyond, polygons outnumber the
/// rays of a view at any resolution this command allows).
///
/// # Errors
/// A reason.
pub fn vp_subdivide(s: &str) -> Result<u32, String> {
    ranged(s, 1, 64).map(|v| v as u32)
}

/// `--blocks`: 1..=1024.
///
/// # Errors
/// A reason.
pub fn blocks(s: &str) -> Result<u32, String> {
    ranged(s, 1, 1024).map(|v| v as u32)
}

/// `--viewpoints`: the vertex counts of a subdivided icosahedron.
///
/// # Errors
/// A reason.
pub fn viewpoint_count(s: &str) -> Result<u32, String> {
    match count(s)? {
        n @ (12 | 42 | 162 | 642 | 2562) => Ok(n as u32),
        _ => Err("must be 12, 42, 162, 642 or 2562 (a subdivided icosahedron)".into()),
    }
}

/// The icosphere subdivision level of a viewpoint count.
#[must_use]
pub fn viewpoint_level(n: u32) -> u32 {
    match n {
        12 => 0,
        42 => 1,
        162 => 2,
        642 => 3,
        _ => 4,
    }
}

/// `--resolution`: 4..=4096 (rays per viewpoint = resolution²).
///
/// # Errors
/// A reason.
pub fn resolution(s: &str) -> Result<u32, String> {
    ranged(s, 4, 4096).map(|v| v as u32).map_err(|e| format!("{e} (rays per viewpoint = resolution²)"))
}

/// `--distance` in bounding-sphere radii: `1.05..=1000`. Below, the
/// viewpoint would touch the bounding sphere. Above, the f32 ray origins of
/// the tracer (relative precision 6e-8, an absolute error of `6e-8 D` radii
/// while the cone of view narrows as `1/D`) move hits between polygons.
/// Measured on the Stanford bunny (42 views, resolution 128): I(V;O) is
/// 3.7397, 3.7354, 3.7360 bits at D = 100, 1e3, 1e4 (perspective converging,
/// best view 0), drifts to 3.7464 at 1e5 and jumps to 4.3976 at 1e6 where the
/// best view changes (0 -> 12): 1000 keeps a factor 100 from the drift.
///
/// # Errors
/// A reason.
pub fn distance(s: &str) -> Result<f64, String> {
    let d = real(s)?;
    if (1.05..=1000.0).contains(&d) {
        Ok(d)
    } else {
        Err("must be in 1.05..=1000 bounding-sphere radii (f32 tracing loses precision farther away)".into())
    }
}

/// `--tolerance`: a relative error on every VMI in `1e-4..=0.5` (below
/// 1e-4 the subdivision cap, not the tolerance, decides the cost; above 0.5
/// an estimate is no longer worth the name).
///
/// # Errors
/// A reason.
pub fn tolerance(s: &str) -> Result<f64, String> {
    let t = real(s)?;
    if (1e-4..=0.5).contains(&t) { Ok(t) } else { Err("must be in 1e-4..=0.5 (a relative error: 0.01 is 1%)".into()) }
}

/// `--max-subdivision`: `1..=256` (`M²` visibility rays per boundary
/// triangle and viewpoint).
///
/// # Errors
/// A reason.
pub fn max_subdivision(s: &str) -> Result<u32, String> {
    ranged(s, 1, 256).map(|v| v as u32)
}

/// `--capture`: a fraction in (0, 1].
///
/// # Errors
/// A reason.
pub fn capture(s: &str) -> Result<f64, String> {
    let c = real(s)?;
    if c > 0.0 && c <= 1.0 {
        Ok(c)
    } else {
        Err("must be in (0, 1]: the fraction of I(V;O) the best-n views keep".into())
    }
}

/// `--best-n`: 1..=64.
///
/// # Errors
/// A reason.
pub fn best_n(s: &str) -> Result<usize, String> {
    ranged(s, 1, 64).map(|v| v as usize)
}

/// `--explore`: 0..=10000 steps.
///
/// # Errors
/// A reason.
pub fn explore(s: &str) -> Result<usize, String> {
    ranged(s, 0, 10_000).map(|v| v as usize)
}

/// `--smooth`: 0..=100 rounds.
///
/// # Errors
/// A reason.
pub fn smooth(s: &str) -> Result<u32, String> {
    ranged(s, 0, 100).map(|v| v as u32)
}

/// `--base`: 2, e or 10 (or bits, nats, hartleys).
///
/// # Errors
/// A reason.
pub fn base(s: &str) -> Result<Base, String> {
    match s {
        "2" | "bits" => Ok(Base::Bits),
        "e" | "nats" => Ok(Base::Nats),
        "10" | "hartleys" | "bans" => Ok(Base::Hartleys),
        _ => Err("expected 2, e or 10".into()),
    }
}

/// `--backend`: cpu, reference or vulkan.
///
/// # Errors
/// The backend's own message listing the choices.
pub fn backend(s: &str) -> Result<BackendChoice, String> {
    s.parse().map_err(|e: itgfx_backends::backend::UnknownBackend| e.to_string())
}

/// An output path: never empty (an empty path would silently mean the
/// current directory).
///
/// # Errors
/// A reason.
pub fn out_path(s: &str) -> Result<PathBuf, String> {
    if s.is_empty() { Err("is an empty path".into()) } else { Ok(PathBuf::from(s)) }
}

/// A finite real number.
///
/// # Errors
/// A reason.
pub fn finite(s: &str) -> Result<f64, String> {
    real(s)
}

/// A positive integer count (e.g. `--n`, `--block`).
///
/// # Errors
/// A reason.
pub fn positive(s: &str) -> Result<u64, String> {
    match count(s)? {
        0 => Err("must be positive".into()),
        n => Ok(n),
    }
}

/// Index of the smallest finite value (0 if none): the best view of a
/// minimum-VMI criterion, wherever a command reports one.
#[must_use]
pub fn argmin(x: &[f64]) -> usize {
    (0..x.len()).filter(|&i| x[i].is_finite()).min_by(|&a, &b| x[a].total_cmp(&x[b])).unwrap_or(0)
}
