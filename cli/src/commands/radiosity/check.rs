//! `itgfx radiosity --check-paths N`: the solution's mean radiosity over
//! every patch against the renderer's path tracer from `N` uniform points
//! of that patch ([`traced_patch_means`]), in the JSON and `patches.csv`.

use itgfx_backends::radiosity::Solution;
use itgfx_backends::radiosity::patches::{solved_patch_means, traced_patch_means};
use itgfx_backends::scene::Scene;
use itgfx_backends::tracer::{Prepared, Tracer};
use itgfx_core::pixel::luminance;

use crate::CliError;
use crate::report::Report;

/// Adds the check to `r` (per patch under `patches`; summaries in sRGB
/// luminance) and returns the CSV: patch, area, solved and traced means
/// per channel, the traced standard error, relative difference and
/// z-score in luminance, and the samples whose first hit was another patch.
///
/// # Errors
/// Tracing errors, one line.
pub fn check(
    r: &mut Report,
    scene: &Scene,
    prepared: &Prepared,
    tracer: &dyn Tracer,
    solution: &Solution,
    paths: u32,
    seed: u64,
) -> Result<String, CliError> {
    let h = &solution.hierarchy;
    let traced = traced_patch_means(scene, prepared, tracer, h, paths, seed)
        .map_err(|e| CliError::usage(format!("--check-paths: {e}")))?;
    let solved = solved_patch_means(h, &solution.radiosity, scene.patches.len());
    let mut csv = String::from(
        "patch,name,area,solved_r,solved_g,solved_b,traced_r,traced_g,traced_b,traced_se_lum,rel_lum,z_lum,strays\n",
    );
    let mut records = Vec::new();
    let (mut worst, mut sum_abs, mut n) = (0.0f64, 0.0, 0.0);
    let (mut a_solved, mut a_traced, mut a_var) = (0.0, 0.0, 0.0);
    let mut strays = 0u64;
    for t in &traced {
        let Some(s) = solved[t.patch as usize] else { continue };
        let (ls, lt) = (luminance(s), luminance(t.mean));
        // The luminance's standard error, channels treated as independent
        // (they share paths, so this understates it a little where they correlate).
        let se = {
            let w = itgfx_core::pixel::SRGB_LUMINANCE_WEIGHTS;
            (0..3).map(|c| (w[c] * t.stderr[c]).powi(2)).sum::<f64>().sqrt()
        };
        let rel = if lt > 0.0 { ls / lt - 1.0 } else { 0.0 };
        let z = if se > 0.0 { (ls - lt) / se } else { 0.0 };
        if lt > 0.0 {
            worst = worst.max(rel.abs());
            sum_abs += rel.abs();
            n += 1.0;
        }
        a_solved += t.area * ls;
        a_traced += t.area * lt;
        a_var += (t.area * se).powi(2);
        strays += u64::from(t.strays);
        let name = scene.patches[t.patch as usize].name.replace(',', ";");
        csv.push_str(&format!(
            "{},{name},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:.6},{:.3},{}\n",
            t.patch, t.area, s[0], s[1], s[2], t.mean[0], t.mean[1], t.mean[2], se, rel, z, t.strays
        ));
        let mut p = Report::new();
        p.count("patch", u64::from(t.patch)).text("name", name);
        p.real("solved", ls, None).real("traced", lt, None).real("traced_stderr", se, None);
        p.real("relative_difference", rel, None).real("z", z, None);
        records.push(p);
    }
    r.count("check_paths_per_patch", u64::from(paths));
    r.real("check_max_abs_relative", worst, None);
    r.real("check_mean_abs_relative", if n > 0.0 { sum_abs / n } else { 0.0 }, None);
    if a_traced > 0.0 {
        r.real("check_scene_relative", a_solved / a_traced - 1.0, None);
        r.real("check_scene_relative_stderr", a_var.sqrt() * a_solved / (a_traced * a_traced), None);
    }
    r.count("check_strays", strays);
    r.records("check_patches", records);
    Ok(csv)
}
