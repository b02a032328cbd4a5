//! Wavefront MTL materials for radiosity and rendering.
//!
//! What is read, precisely:
//! * `Kd r [g b]` → [`Material::reflectance`] (default 0.7 grey); each in
//!   `[0, 1]`.
//! * `Ke r [g b]` → [`Material::emittance`] (default 0); each in
//!   `[0, 10¹²]` ([`Material::MAX_EMITTANCE`]: larger lights overflow f32 pictures).
//! * `Ks r [g b]` in `[0, 1]`: a material is an ideal **mirror** when
//!   `illum` is 3, 5 or 8 (the reflection models), or when `Kd` is given as
//!   `0 0 0` and `Ks` is not zero. A mirror's reflectance is `Ks` when `Ks`
//!   is given and not zero, else `Kd`. On a diffuse material with
//!   `illum` 2 (or none) a non-zero `Ks` is a Phong highlight, which is not
//!   modelled: warning `specular-ignored`.
//! * `illum` 0, 1, 2 diffuse; 3, 5, 8 mirror; 4, 6, 7, 9 (glass,
//!   refraction) and 10 (shadow matte) are not modelled: warning
//!   `illum-unsupported`, the material stays diffuse. Other values: error.
//! * `d` < 1, `Tr` > 0: warning `transparency-ignored` (the surface stays
//!   opaque). `Ni` and `Tf` are range-checked and only matter for
//!   transparency, so they add nothing else.
//! * `Ka` (ambient, in `[0, 1]`): no ambient term in radiosity; non-zero
//!   gives warning `ambient-ignored`. `Ns` only shapes the highlight of `Ks`.
//! * `map_*`, `bump`, `disp`, `decal`, `refl`: warning `texture-ignored`.
//! * Anything else: warning `mtl-statement-ignored`.
//!
//! Bad numbers, out-of-range colours and spectral or CIE XYZ colours are
//! errors with the file and line.

use super::Warnings;
use crate::scene::{Material, SceneError};

/// A parsed colour statement: 1 or 3 numbers.
fn colour(path: &str, line: usize, key: &str, args: &[&str], range: (f64, f64)) -> Result<[f64; 3], SceneError> {
    colour_of(path, line, key, args, range, None)
}

/// [`colour`] naming the material in its errors.
fn colour_of(
    path: &str,
    line: usize,
    key: &str,
    args: &[&str],
    range: (f64, f64),
    material: Option<&str>,
) -> Result<[f64; 3], SceneError> {
    let of = material.map(|m| format!("material {m:?}: ")).unwrap_or_default();
    let e = |m: String| SceneError::Obj { path: path.to_string(), message: format!("line {line}: {of}{key} {m}") };
    if matches!(args.first(), Some(&"spectral" | &"xyz")) {
        return Err(e(format!("{}: only r g b colours are supported", args[0])));
    }
    let v: Vec<f64> = args
        .iter()
        .map(|s| s.parse::<f64>().map_err(|_| e(format!("value {s:?} is not a number"))))
        .collect::<Result<_, _>>()?;
    let c = match v.len() {
        1 => [v[0]; 3],
        3 => [v[0], v[1], v[2]],
        k => return Err(e(format!("needs 1 or 3 numbers, found {k}"))),
    };
    for x in c {
        if !(x >= range.0 && x <= range.1) {
            let hi = if range.1 > 1e6 { format!("{:e}", range.1) } else { range.1.to_string() };
            let x = if x.abs() > 1e6 { format!("{x:e}") } else { x.to_string() };
            return Err(e(format!("value {x} is outside [{}, {hi}]", range.0)));
        }
    }
    Ok(c)
}

fn scalar(path: &str, line: usize, key: &str, args: &[&str], range: (f64, f64)) -> Result<f64, SceneError> {
    let e = |m: String| SceneError::Obj { path: path.to_string(), message: format!("line {line}: {key} {m}") };
    // `d -halo 0.5`: the halo flag does not change the factor's range.
    let args: Vec<&str> = args.iter().copied().filter(|a| *a != "-halo").collect();
    let [s] = args.as_slice() else { return Err(e(format!("needs one number, found {}", args.len()))) };
    let x: f64 = s.parse().map_err(|_| e(format!("value {s:?} is not a number")))?;
    if !(x >= range.0 && x <= range.1) {
        return Err(e(format!("value {x} is outside [{}, {}]", range.0, range.1)));
    }
    Ok(x)
}

/// One material being read.
struct Pending {
    name: String,
    line: usize,
    kd: Option<[f64; 3]>,
    ks: Option<[f64; 3]>,
    ke: [f64; 3],
    illum: Option<u32>,
}

impl Pending {
    fn finish(self, path: &str, warnings: &mut Warnings) -> Material {
        let ks = self.ks.filter(|k| k.iter().any(|&x| x > 0.0));
        let mirror = matches!(self.illum, Some(3 | 5 | 8)) || (self.kd == Some([0.0; 3]) && ks.is_some());
        let kd = self.kd.unwrap_or([0.7; 3]);
        if !mirror && ks.is_some() && !matches!(self.illum, Some(0 | 1)) {
            warnings.add("specular-ignored", || {
                format!(
                    "{path}: line {}: material {:?}: Ks (a Phong highlight) is not modelled, only Kd",
                    self.line, self.name
                )
            });
        }
        Material {
            name: self.name,
            reflectance: if mirror { ks.unwrap_or(kd) } else { kd },
            emittance: self.ke,
            mirror,
        }
    }
}

/// Reads the materials of one MTL file.
///
/// # Errors
/// [`SceneError::Obj`] naming the file and line.
pub fn parse_mtl(path: &str, text: &str, warnings: &mut Warnings) -> Result<Vec<Material>, SceneError> {
    let mut out = Vec::new();
    let mut cur: Option<Pending> = None;
    for (ln, raw) in text.lines().enumerate() {
        let line = ln + 1;
        let mut it = raw.split_whitespace();
        let Some(key) = it.next() else { continue };
        if key.starts_with('#') {
            continue;
        }
        let args: Vec<&str> = it.collect();
        if key == "newmtl" {
            if let Some(p) = cur.take() {
                out.push(p.finish(path, warnings));
            }
            let name = args.join(" ");
            if name.is_empty() {
                return Err(SceneError::Obj {
                    path: path.into(),
                    message: format!("line {line}: newmtl without a name"),
                });
            }
            cur = Some(Pending { name, line, kd: None, ks: None, ke: [0.0; 3], illum: None });
            continue;
        }
        let Some(m) = cur.as_mut() else {
            return Err(SceneError::Obj {
                path: path.into(),
                message: format!("line {line}: {key} before any newmtl"),
            });
        };
        let name = m.name.clone();
        match key {
            "Kd" => m.kd = Some(colour(path, line, key, &args, (0.0, 1.0))?),
            "Ks" => m.ks = Some(colour(path, line, key, &args, (0.0, 1.0))?),
            "Ke" => m.ke = colour_of(path, line, key, &args, (0.0, Material::MAX_EMITTANCE), Some(&name))?,
            "Tf" => {
                colour(path, line, key, &args, (0.0, 1.0))?;
            }
            "Ka" => {
                if colour(path, line, key, &args, (0.0, 1.0))?.iter().any(|&x| x > 0.0) {
                    warnings.add("ambient-ignored", || {
                        format!("{path}: line {line}: material {name:?}: Ka (ambient) has no part in radiosity")
                    });
                }
            }
            "Ns" => {
                scalar(path, line, key, &args, (0.0, f64::MAX))?;
            }
            "Ni" => {
                scalar(path, line, key, &args, (0.0, f64::MAX))?;
            }
            "d" | "Tr" => {
                let x = scalar(path, line, key, &args, (0.0, 1.0))?;
                if (key == "d" && x < 1.0) || (key == "Tr" && x > 0.0) {
                    warnings.add("transparency-ignored", || {
                        format!("{path}: line {line}: material {name:?}: {key} {x}: surfaces are opaque")
                    });
                }
            }
            "illum" => {
                let n = args.first().and_then(|s| s.parse::<u32>().ok()).filter(|&n| n <= 10 && args.len() == 1);
                let Some(n) = n else {
                    return Err(SceneError::Obj {
                        path: path.into(),
                        message: format!("line {line}: illum must be one integer in 0..=10, got {:?}", args.join(" ")),
                    });
                };
                if matches!(n, 4 | 6 | 7 | 9 | 10) {
                    warnings.add("illum-unsupported", || {
                        format!(
                            "{path}: line {line}: material {name:?}: illum {n} (transparency, refraction or shadow matte) is not modelled; diffuse Kd is used"
                        )
                    });
                }
                m.illum = Some(n);
            }
            k if k.starts_with("map_") || matches!(k, "bump" | "disp" | "decal" | "refl") => {
                warnings.add("texture-ignored", || {
                    format!("{path}: line {line}: material {name:?}: {k}: textures are not used, one colour per patch")
                });
            }
            k => {
                warnings.add("mtl-statement-ignored", || {
                    format!("{path}: line {line}: material {name:?}: {k} is not supported")
                });
            }
        }
    }
    if let Some(p) = cur.take() {
        out.push(p.finish(path, warnings));
    }
    Ok(out)
}
