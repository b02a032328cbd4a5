//! The options of `itgfx render` and `itgfx compare`, and their value parsers.

use std::path::PathBuf;

use clap::Args;
use glam::DVec3;
use itgfx_backends::camera::Camera;
use itgfx_backends::render::{Criterion, TreeContrast, criteria, tree};

use super::shard;
use crate::options::Traced;
use crate::values::{count, finite, out_path};

/// Largest image side.
pub(super) const MAX_SIDE: u32 = 8192;
/// Most samples per pixel (average) a run may ask for.
pub(super) const MAX_SPP: u32 = itgfx_backends::render::job::MAX_SPP;

/// `itgfx render SCENE`.
#[derive(Debug, Args)]
#[command(after_help = "SCENE is an .obj file with its MTL (Kd diffuse, Ke emission, Ks with illum 3/5/8 a mirror), \
                        a .ply, a .gltf/.glb (its first camera is the default camera), a Mitsuba 3 .xml, \
                        or a built-in with materials: cornell-box, mirror-room, open-blocks, open-sphere (docs/SCENES.md).\n\
                        DIR receives image.exr (linear radiance), image.png (sRGB) and density.png \
                        (samples per pixel, log scale); with --variance also variance.exr.\n\
                        Recommended: --sampler adaptive (unbiased; pays on scenes with empty or flat regions, \
                        about uniform elsewhere).",
          mut_arg("shard", |a| a.help(shard::SHARD_HELP).requires("save_shard")),
          mut_arg("save_shard", |a| a.help("Write the shard's pixels to F (for --merge)").requires("shard")),
          mut_arg("merge", |a| a.help(shard::MERGE_HELP).num_args(1..).conflicts_with_all(shard::MERGE_CONFLICTS)))]
pub struct RenderOptions {
    /// A built-in scene name (cornell-box, mirror-room, open-blocks, open-sphere) or a scene file
    /// (.obj, .ply, .gltf, .glb, Mitsuba .xml)
    #[arg(value_name = "SCENE")]
    pub scene: Option<String>,
    /// Directory for image.exr, image.png and density.png (made if missing)
    #[arg(long, value_name = "DIR", value_parser = out_path)]
    pub out: Option<PathBuf>,
    /// Samples per pixel (uniform), or the average rays per pixel every adaptive sampler traces
    /// (the samples it decides on included)
    #[arg(long, value_name = "N", default_value = "16", value_parser = spp)]
    pub spp: u32,
    /// Pixel sampler: uniform (stratified); adaptive (RECOMMENDED: unbiased, every ray in the image, an
    /// 8-spp pilot in each pixel and the rest shared by its neighbours' display-space noise); or an
    /// adaptive criterion of the tutorial: cc (classic contrast), ct
    /// (confidence test), kl cs hl (f-divergences), kl-sqrt cs-sqrt hl-sqrt (their square roots), ec
    /// (entropy refinement tree, Part IV §6), ic (importance-weighted classic contrast tree), cc-tree
    /// (classic contrast tree), ec-binary (the entropy tree with binary contrasts in colour and
    /// geometry, Part IV eqs. 19, 21), ec-batch (entropy contrast in batches), rel (relative confidence
    /// half-width, beyond the tutorial), es (entropy-based supersampling, Part IV §5: a contrast map
    /// of 8 spp decides where the rest of the budget goes); see docs/RENDER.md
    #[arg(long, value_name = "NAME", default_value = "uniform", value_parser = sampler_name)]
    pub sampler: String,
    /// ec, ic, cc-tree, ec-binary, es: weight of the colour contrast against the geometry contrast of the
    /// rays' first hits (Part IV eqs. (23), (28)); 1 is colour only. With --maps, also p_v's colour
    /// weight (eq. (4); 0.9 when not given)
    #[arg(long, value_name = "D", value_parser = delta)]
    pub delta: Option<f64>,
    /// ec, ic, cc-tree, ec-binary: samples per tree node, N_s^r (Part IV §6): a multiple of 4 (the
    /// node's quadrants) in 4..=1024; default 8 (Table 2), Fig. 13 used 4
    #[arg(long, value_name = "N", value_parser = node_samples)]
    pub node_samples: Option<u32>,
    /// es and --maps: the binary colour contrast C_b (Part IV eq. (19)) instead of the entropy
    /// contrast (eq. (18)) in the oracle's contrast
    #[arg(long)]
    pub binary_contrast: bool,
    /// Also write the pixel quality and contrast maps of an 8-spp pass (Part IV §3-4, Figs. 1-6):
    /// quality.png, geometry-quality.png, contrast.png, colour-contrast.png, binary-contrast.png,
    /// geometry-contrast.png, geometry-binary-contrast.png (eq. 21), geometry-log-contrast.png
    /// (eq. 22), quality.exr, contrast.exr, geometry-contrast.exr; and Simmons' priorities of the
    /// same samples (§2 eqs. 2-4, a second trace of the pass): priority-colour.png,
    /// depth-difference.png, priority-value.png, priority.exr
    #[arg(long)]
    pub maps: bool,
    /// Also write variance.exr: each pixel's sample variance per channel (of the samples averaged
    /// into its value; not for the trees ec ic cc-tree nor es --tutorial-form). Needs --out
    #[arg(long)]
    pub variance: bool,
    /// Render passes of the sampler's budget (--spp) until S seconds have passed, then write the mean
    /// of the complete passes' samples, to compare renderers at equal time. Each pass's seed derives
    /// from --seed, but how many passes fit depends on the machine: the image depends on timing
    #[arg(long, value_name = "S", value_parser = time_budget)]
    pub time_budget: Option<f64>,
    /// Adaptive: most samples one pixel may take (default 16 x --spp)
    #[arg(long, value_name = "N", value_parser = spp)]
    pub max_spp: Option<u32>,
    /// Adaptive: this threshold instead of one tuned to spend --spp on average
    #[arg(long, value_name = "EPS", value_parser = threshold)]
    pub threshold: Option<f64>,
    /// Adaptive: the tutorial's form, BIASED: the samples a criterion decides on are averaged into
    /// the image (3.5-17% dark on mirror-room, docs/RENDER.md). Default: decisions on samples that
    /// are kept out of the image (a pilot set, the tree's pilot, es's oracle), unbiased
    #[arg(long)]
    pub tutorial_form: bool,
    /// Gone: the unbiased form is the default now (and --spp counts its decision samples)
    #[arg(long, hide = true)]
    pub unbiased: bool,
    /// Image size in pixels
    #[arg(long, value_name = "WxH", default_value = "256x256", value_parser = size)]
    pub size: (u32, u32),
    /// Camera in scene units: eye, target, up (3 numbers each) and vertical field of view in degrees
    #[arg(long, value_name = "EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOV", value_parser = camera)]
    pub camera: Option<Camera>,
    /// Seed; same seed, same image, any thread count
    #[arg(long, value_name = "S", default_value = "1", value_parser = count)]
    pub seed: u64,
    /// PNG exposure in stops (the EXR is never scaled)
    #[arg(long, value_name = "STOPS", default_value = "0", value_parser = exposure)]
    pub exposure: f64,
    /// Add RMSE/PSNR/relMSE against this reference EXR to the output
    #[arg(long, value_name = "R.exr")]
    pub reference: Option<PathBuf>,
    /// Also write the scene for other renderers in DIR: one OBJ per material, scene.xml (Mitsuba 3:
    /// `mitsuba scene.xml` renders it as is, and itgfx reads it back) and scene.json
    #[arg(long)]
    pub export_scene: bool,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub shards: crate::shard::ShardArgs,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub run: Traced,
}

/// `itgfx compare A.exr B.exr`.
#[derive(Debug, Args)]
pub struct CompareOptions {
    /// The image to score
    #[arg(value_name = "A.exr")]
    pub a: PathBuf,
    /// The reference
    #[arg(value_name = "B.exr")]
    pub b: PathBuf,
    /// Exposure in stops of the 8-bit display values that RMSE and PSNR are taken on
    #[arg(long, value_name = "STOPS", default_value = "0", value_parser = exposure)]
    pub exposure: f64,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub common: crate::options::JsonOnly,
}

fn spp(s: &str) -> Result<u32, String> {
    match count(s)? {
        n @ 1..=65_536 => Ok(n as u32),
        _ => Err(format!("must be in 1..={MAX_SPP}")),
    }
}

fn sampler_name(s: &str) -> Result<String, String> {
    if s == "uniform"
        || s == "es"
        || s == "adaptive"
        || TreeContrast::from_name(s).is_some()
        || Criterion::from_name(s).is_some()
    {
        Ok(s.to_string())
    } else {
        let names: Vec<&str> = ["uniform", "adaptive", "es"]
            .into_iter()
            .chain(tree::NAMES.iter().copied())
            .chain(criteria::NAMES.iter().copied())
            .collect();
        let hint = names
            .iter()
            .map(|n| (edit_distance(s, n), *n))
            .filter(|&(d, _)| d <= 2)
            .min()
            .map_or(String::new(), |(_, n)| format!(" (did you mean {n}?)"));
        Err(format!("unknown sampler {s:?}{hint}: {}", names.join(", ")))
    }
}

/// Levenshtein distance between two names (insertions, deletions and
/// substitutions of characters), for the "did you mean" hint.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diag = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let next = (diag + usize::from(ca != cb)).min(row[j] + 1).min(row[j + 1] + 1);
            diag = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

/// Longest time budget: a week.
const MAX_TIME_BUDGET: f64 = 7.0 * 86_400.0;

fn time_budget(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if x > 0.0 && x <= MAX_TIME_BUDGET {
        Ok(x)
    } else {
        Err(format!("must be seconds in (0, {MAX_TIME_BUDGET}] (a week)"))
    }
}

fn node_samples(s: &str) -> Result<u32, String> {
    match u32::try_from(count(s)?) {
        Ok(n) if tree::valid_node_samples(n) => Ok(n),
        _ => Err(format!("must be a multiple of {} in {}..={}", tree::REGIONS, tree::REGIONS, tree::MAX_NODE_SAMPLES)),
    }
}

fn delta(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if (0.0..=1.0).contains(&x) { Ok(x) } else { Err("must be in 0..=1".into()) }
}

fn threshold(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if x >= 0.0 { Ok(x) } else { Err("must be a finite number >= 0".into()) }
}

fn exposure(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if (-64.0..=64.0).contains(&x) { Ok(x) } else { Err("must be in -64..=64 stops".into()) }
}

fn size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("must be WxH, e.g. 256x256")?;
    let side = |v: &str| match v.parse::<u32>() {
        Ok(n @ 1..=MAX_SIDE) => Ok(n),
        _ => Err(format!("{v:?}: each side must be an integer in 1..={MAX_SIDE}")),
    };
    Ok((side(w)?, side(h)?))
}

/// Parses `--camera EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOV`.
pub(crate) fn camera(s: &str) -> Result<Camera, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()
        .ok_or("must be 10 finite numbers: eye, target, up (x,y,z each) and fov")?;
    if v.len() != 10 {
        return Err(format!("must be 10 numbers (eye, target, up, fov), got {}", v.len()));
    }
    let d = |i: usize| DVec3::new(v[i], v[i + 1], v[i + 2]);
    Camera::look_at(d(0), d(3), d(6), v[9]).map_err(|e| e.to_string())
}
