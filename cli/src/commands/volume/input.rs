//! What `itgfx volume` reads: the volume (built-in, NRRD or raw), the
//! transfer function, the focus object, and the option parsers.

use std::path::Path;

use itgfx_backends::volume::builtin::{BUILT_IN, built_in, is_built_in};
use itgfx_backends::volume::nrrd::read_nrrd;
use itgfx_backends::volume::raw::{RawType, read_raw};
use itgfx_backends::volume::transfer::PRESETS;
use itgfx_backends::volume::{TransferFunction, Volume};

use super::VolumeOptions;
use crate::CliError;
use crate::values::{ranged, real};

pub(super) fn volume_help() -> String {
    let mut s = String::from(
        "VOLUME is a built-in, an .nrrd file (one raw scalar volume, little-endian) or a raw file\n\
                      (little-endian values, x fastest; give --dims and --type):\n",
    );
    for b in BUILT_IN {
        s.push_str(&format!("  {}\n      {}\n", b.syntax, b.description));
    }
    s.push_str("--tf is a preset (");
    s.push_str(&PRESETS.iter().map(|p| format!("{}: {}", p.0, p.1)).collect::<Vec<_>>().join("; "));
    s.push_str(") or a file of lines 'value opacity r g b' over the scalar normalised to [0, 1],\n");
    s.push_str("or a .json file {\"points\": [{\"value\": V, \"opacity\": A, \"colour\": [R, G, B]}, ...]}.\n");
    s.push_str("--out DIR gets best.png, worst.png, best-n.png, sphere.png, vomi.png, colour-vomi.png, volume.json\n");
    s.push_str("and tour.png (the exploration path's views); for labelled volumes objects.png (each object's\n");
    s.push_str("characteristic view) and path-between.png with --path-between.\n");
    let (syntax, what) = itgfx_backends::volume::series::SERIES_BUILT_IN;
    s.push_str(&format!(
        "--time SERIES (instead of VOLUME): the built-in {syntax}\n      {what}\n\
         or frames 'a.nrrd,b.nrrd,...' or 'dir/f*.nrrd' (same grid; one transfer function over their common range);\n\
         --out DIR then gets path.png (the dynamic path's views), static.png (the best static view),\n\
         frames-best.png (each frame's best view) and series.json."
    ));
    s
}

pub(super) fn size(s: &str) -> Result<u32, String> {
    ranged(s, 8, 1024).map(|v| v as u32)
}

pub(super) fn image_side(s: &str) -> Result<u32, String> {
    ranged(s, 16, 2048).map(|v| v as u32)
}

pub(super) fn path_steps(s: &str) -> Result<usize, String> {
    ranged(s, 2, 64).map(|v| v as usize)
}

pub(super) fn turn_degrees(s: &str) -> Result<f64, String> {
    let x = real(s)?;
    if (0.0..=180.0).contains(&x) { Ok(x) } else { Err("must be in 0..=180 degrees".into()) }
}

pub(super) fn step(s: &str) -> Result<f64, String> {
    let x = real(s)?;
    if (0.05..=2.0).contains(&x) { Ok(x) } else { Err("must be in 0.05..=2 voxels".into()) }
}

pub(super) fn iso_value(s: &str) -> Result<f64, String> {
    let x = real(s)?;
    if x > 0.0 && x < 1.0 { Ok(x) } else { Err("must be in (0, 1): a value of the scalar normalised to [0, 1]".into()) }
}

fn triple<T: std::str::FromStr>(s: &str, what: &str) -> Result<[T; 3], String> {
    let v: Vec<T> = s
        .split(',')
        .map(|x| x.trim().parse::<T>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("want three {what} X,Y,Z"))?;
    <[T; 3]>::try_from(v).map_err(|_| format!("want three {what} X,Y,Z"))
}

pub(super) fn dims(s: &str) -> Result<[usize; 3], String> {
    let d: [usize; 3] = triple(s, "sizes")?;
    if d.iter().any(|&x| x == 0 || x > 4096) {
        return Err("every size must be in 1..=4096".into());
    }
    Ok(d)
}

pub(super) fn spacing(s: &str) -> Result<[f64; 3], String> {
    let d: [f64; 3] = triple(s, "numbers")?;
    if d.iter().any(|x| !x.is_finite() || *x <= 0.0 || *x > 1e6) {
        return Err("every spacing must be in (0, 1e6]".into());
    }
    Ok(d)
}

pub(super) fn load(o: &VolumeOptions, spec: &str) -> Result<Volume, CliError> {
    let usage = |e: itgfx_backends::volume::VolumeError| CliError::usage(e.to_string());
    let path = Path::new(spec);
    if is_built_in(spec) && !path.exists() {
        if o.dims.is_some() || o.value_type.is_some() || o.spacing.is_some() {
            return Err(CliError::usage("--dims, --type and --spacing are for raw files, not built-in volumes"));
        }
        return built_in(spec).map_err(usage);
    }
    if !path.exists() {
        // Not a file: report it as a built-in (the message lists them) or a missing file.
        if spec.contains(['/', '.']) {
            return Err(CliError::usage(format!("{spec:?}: no such file")));
        }
        return built_in(spec).map_err(usage);
    }
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("nrrd")) {
        if o.dims.is_some() || o.value_type.is_some() || o.spacing.is_some() {
            return Err(CliError::usage("--dims, --type and --spacing are for raw files: an NRRD header has them"));
        }
        return read_nrrd(path).map_err(usage);
    }
    let d = o.dims.ok_or_else(|| CliError::usage(format!("{spec:?}: a raw file needs --dims X,Y,Z")))?;
    let ty = RawType::parse(o.value_type.as_deref().unwrap_or("u8")).map_err(usage)?;
    read_raw(path, d, ty, o.spacing.unwrap_or([1.0; 3])).map_err(usage)
}

pub(super) fn transfer(spec: &str) -> Result<TransferFunction, CliError> {
    if PRESETS.iter().any(|p| p.0 == spec) {
        return TransferFunction::preset(spec).map_err(|e| CliError::usage(e.to_string()));
    }
    let meta = std::fs::metadata(spec)
        .map_err(|e| CliError::usage(format!("--tf {spec:?}: not a preset ({}) and {e}", preset_names())))?;
    if meta.len() > 1 << 20 {
        return Err(CliError::usage(format!("--tf {spec:?}: larger than 1 MiB")));
    }
    let text = itgfx_backends::files::read_regular_to_string(Path::new(spec))
        .map_err(|e| CliError::usage(format!("--tf {spec:?}: {e}")))?;
    // JSON by its extension or its first character; the text format has neither.
    let json = Path::new(spec).extension().is_some_and(|e| e.eq_ignore_ascii_case("json"))
        || text.trim_start().starts_with('{');
    let tf = if json { TransferFunction::parse_json(&text) } else { TransferFunction::parse(&text) };
    tf.map_err(|e| CliError::usage(format!("--tf {spec:?}: {e}")))
}

fn preset_names() -> String {
    PRESETS.iter().map(|p| p.0).collect::<Vec<_>>().join(", ")
}

/// The label (`1..`) of an object of `v` given by name or number.
pub(super) fn label(v: &Volume, name: &str) -> Option<usize> {
    v.label_names
        .iter()
        .position(|n| n == name)
        .map(|k| k + 1)
        .or_else(|| name.parse::<usize>().ok().filter(|&k| (1..=v.label_names.len()).contains(&k)))
}

/// The focus importance: 1 on the voxels of the named label, 0 elsewhere
/// (`p(o|z)` for a fuzzy object).
pub(super) fn focus(v: &Volume, name: &str) -> Result<(Vec<f64>, String), CliError> {
    let Some(labels) = &v.labels else {
        return Err(CliError::usage(format!("--focus {name:?}: {} has no labelled objects", v.name)));
    };
    let k = label(v, name).ok_or_else(|| {
        CliError::usage(format!("--focus {name:?}: not a label of {} ({})", v.name, v.label_names.join(", ")))
    })?;
    // A fuzzy object's importance is its membership p(o|z).
    let importance = match &v.membership {
        Some(m) => m.of(k as u8),
        None => labels.iter().map(|&l| f64::from(u8::from(usize::from(l) == k))).collect(),
    };
    Ok((importance, v.label_names[k - 1].clone()))
}
