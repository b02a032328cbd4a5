//! The checks of `itgfx render`'s options that clap cannot express (which
//! options go with which sampler, the least budget of each), made before
//! any scene is loaded.

use itgfx_backends::render::{TreeContrast, adaptive, criteria};

use super::RenderOptions;
use crate::CliError;

/// Options that do not go together, whatever the sampler.
///
/// # Errors
/// One usage line.
pub fn run_options(o: &RenderOptions) -> Result<(), CliError> {
    if o.unbiased {
        return Err(CliError::usage(
            "--unbiased is gone: the unbiased form is the default now, and --spp counts its decision samples too (an old --spp N --unbiased run is --spp 2N); --tutorial-form gives the tutorial's biased form",
        ));
    }
    if o.variance && (o.out.is_none() || o.shards.shard.is_some() || !o.shards.merge.is_empty()) {
        return Err(CliError::usage(
            "--variance writes variance.exr beside image.exr: give --out DIR (and no --shard or --merge)",
        ));
    }
    if o.time_budget.is_some() && (o.shards.shard.is_some() || !o.shards.merge.is_empty()) {
        return Err(CliError::usage("--time-budget is for a single run, not --shard or --merge"));
    }
    Ok(())
}

/// The sampler's options: each goes with the samplers that read it.
///
/// # Errors
/// One usage line.
pub fn sampler_options(o: &RenderOptions) -> Result<(), CliError> {
    let adaptive = o.sampler != "uniform";
    if !adaptive && (o.max_spp.is_some() || o.threshold.is_some() || o.tutorial_form) {
        return Err(CliError::usage(
            "--max-spp, --threshold and --tutorial-form are for adaptive samplers (--sampler cc, kl, ...)",
        ));
    }
    let is_tree = TreeContrast::from_name(&o.sampler).is_some();
    if o.variance && (is_tree || (o.sampler == "es" && o.tutorial_form)) {
        return Err(CliError::usage(format!(
            "--variance: --sampler {}{} gives pixels that are not the mean of the samples it keeps (eq. (29) or the oracle's samples); use another sampler",
            o.sampler,
            if o.tutorial_form { " --tutorial-form" } else { "" }
        )));
    }
    if o.sampler == "adaptive" && (o.threshold.is_some() || o.tutorial_form) {
        return Err(CliError::usage(
            "--sampler adaptive has no threshold and one (unbiased) form: it spends exactly --spp on average",
        ));
    }
    if is_tree && o.max_spp.is_some() {
        return Err(CliError::usage(format!(
            "--sampler {}: the refinement tree is capped by its depth (4 levels), not --max-spp",
            o.sampler
        )));
    }
    if o.node_samples.is_some() && !is_tree {
        return Err(CliError::usage(
            "--node-samples is for the refinement trees (--sampler ec, ic, cc-tree, ec-binary)",
        ));
    }
    let oracle_maps = o.sampler == "es" || o.maps;
    if o.delta.is_some() && !(is_tree || oracle_maps) {
        return Err(CliError::usage(
            "--delta is for the contrast samplers (--sampler ec, ic, cc-tree, ec-binary, es) and --maps",
        ));
    }
    if o.binary_contrast && !oracle_maps {
        return Err(CliError::usage("--binary-contrast is for --sampler es and --maps"));
    }
    if o.sampler == "es" && o.threshold.is_some() {
        return Err(CliError::usage("--sampler es spends exactly --spp on average: no --threshold"));
    }
    Ok(())
}

/// The least budget each sampler takes.
///
/// # Errors
/// One usage line.
pub fn budget(o: &RenderOptions) -> Result<(), CliError> {
    let adaptive = o.sampler != "uniform";
    if let Some(m) = o.max_spp
        && m < o.spp
    {
        return Err(CliError::usage(format!("--max-spp {m} is below --spp {}", o.spp)));
    }
    if o.sampler == "adaptive" && o.spp < adaptive::PILOT {
        return Err(CliError::usage(format!(
            "--spp {}: --sampler adaptive takes a pilot of {} a pixel; give --spp {} or more",
            o.spp,
            adaptive::PILOT,
            adaptive::PILOT
        )));
    }
    if adaptive && o.sampler != "adaptive" && o.spp < criteria::BATCH {
        return Err(CliError::usage(format!(
            "--spp {}: adaptive samplers take at least {} per pixel",
            o.spp,
            criteria::BATCH
        )));
    }
    // The unbiased form traces at least 8 samples to decide and 8 to estimate.
    let floor = 2 * criteria::BATCH;
    if adaptive
        && o.sampler != "adaptive"
        && !o.tutorial_form
        && o.spp < floor
        && (o.threshold.is_none() || o.sampler == "es")
    {
        return Err(CliError::usage(format!(
            "--spp {}: the unbiased form traces at least {floor} a pixel (8 to decide, 8 for the image): give --spp {floor} or more, or --tutorial-form",
            o.spp
        )));
    }
    Ok(())
}
