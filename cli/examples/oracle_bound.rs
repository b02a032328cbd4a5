//! The cross-validated oracle bound of per-pixel sample allocation: how much
//! lower RMSE_a any sampler that only chooses each pixel's sample count could
//! reach at the same average count, measured without selection bias.
//!
//! ```text
//! cargo run --release -p itgfx-cli --example oracle_bound -- SCENE REF.exr [SIZE] [SPP] [K]
//! ```
//!
//! 1. `2K` independent 1-spp images (uniform, seeds `10_000 + i` for set A
//!    and `20_000 + i` for set B; never the seeds of the table's runs or of
//!    the reference).
//! 2. Each pixel's **error curve** on a set: for a count `n` in the
//!    candidate list, the mean over the `⌊K/n⌋` disjoint groups of `n`
//!    samples of `Σ_c (255 sRGB(ḡ_c) − R_c)² / 3`, the squared display error
//!    of RMSE_a (Part IV Table 2) of that group's mean `ḡ` against the
//!    reference `R` (display values of REF.exr, another seed).
//! 3. **Choose on A**: counts `n_p` minimising `Σ_p e_A(p, n_p)` with
//!    `Σ_p n_p ≤ SPP · P` (a Lagrange multiplier `λ`, each pixel taking the
//!    `n` minimising `e_A(p, n) + λ n`, bisected on `λ`).
//! 4. **Score on B**: `sqrt(mean_p e_B(p, n_p))` against uniform's
//!    `sqrt(mean_p e_B(p, SPP))`, their ratio the bound. Choosing and scoring
//!    on the same set (printed too) understates it: selection bias.
//!
//! Prints one JSON line. The uniform here is `SPP` independent samples (not
//! stratified), scored the same way, so the ratio is allocation alone.

use std::path::PathBuf;

use itgfx_backends::render::{self, Job, Sampling, Shading, views};
use itgfx_backends::tracer::Prepared;
use itgfx_backends::{BackendChoice, open};
use itgfx_cli::render::images::read_exr;
use itgfx_cli::scene::load_scene;
use itgfx_core::pixel::srgb_encode;
use rayon::prelude::*;

/// Candidate counts of a pixel (all divide or fit in K = 480 groups).
const COUNTS: [u32; 20] = [1, 2, 3, 4, 5, 6, 8, 10, 12, 16, 20, 24, 30, 40, 48, 60, 80, 96, 120, 160];

fn main() {
    if let Err(e) = run() {
        eprintln!("oracle_bound: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: oracle_bound SCENE REF.exr [WxH (128x128)] [SPP (60)] [K (480)]";
    let scene_spec = args.first().ok_or(usage)?;
    let reference = PathBuf::from(args.get(1).ok_or(usage)?);
    let size = args.get(2).map_or("128x128", String::as_str);
    let (w, h) = size
        .split_once('x')
        .and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?)))
        .filter(|&(a, b)| (1..=4096).contains(&a) && (1..=4096).contains(&b))
        .ok_or("size must be WxH, sides in 1..=4096")?;
    let spp: u32 = args.get(3).map_or(Ok(60), |s| s.parse()).map_err(|_| "SPP must be an integer")?;
    let k: u32 = args.get(4).map_or(Ok(480), |s| s.parse()).map_err(|_| "K must be an integer")?;
    if !(1..=160).contains(&spp) || !(160..=4096).contains(&k) {
        return Err("SPP must be in 1..=160 and K in 160..=4096".into());
    }
    let r = read_exr(&reference).map_err(|e| e.to_string())?;
    if (r.width, r.height) != (w as usize, h as usize) {
        return Err(format!("{reference:?} is {} x {}, not {size}", r.width, r.height));
    }
    let reference: Vec<[f64; 3]> = r.rgb.iter().map(|c| c.map(|v| 255.0 * srgb_encode(v))).collect();
    let scene = load_scene(scene_spec, 1).map_err(|e| e.to_string())?;
    let prepared = Prepared::new(&scene);
    let shading = Shading::new(&scene, &prepared).map_err(|e| e.to_string())?;
    let tracer = open(BackendChoice::Cpu, &prepared).map_err(|e| e.to_string())?;
    let camera = views::default_camera(&scene);
    let pixels = (w * h) as usize;
    // One set: K one-sample images, stored per pixel (sample-major within a pixel).
    let set = |base: u64| -> Result<Vec<[f32; 3]>, String> {
        let mut all = vec![[0f32; 3]; pixels * k as usize];
        for i in 0..k {
            let job = Job {
                tracer: tracer.as_ref(),
                scene: &scene,
                prepared: &prepared,
                shading: &shading,
                camera: &camera,
                size: (w, h),
                seed: base + u64::from(i),
                sampling: &Sampling::Uniform(1),
                maps: None,
                rows: None,
                time_budget: None,
            };
            let f = render::render(&job, &|_, _| {}).map_err(|e| e.to_string())?.frame;
            for (p, c) in f.rgb.iter().enumerate() {
                all[p * k as usize + i as usize] = c.map(|v| v as f32);
            }
        }
        Ok(all)
    };
    let curves = |samples: &[[f32; 3]]| -> Vec<[f64; COUNTS.len()]> {
        (0..pixels)
            .into_par_iter()
            .map(|p| {
                let s = &samples[p * k as usize..(p + 1) * k as usize];
                std::array::from_fn(|j| {
                    let n = COUNTS[j] as usize;
                    let groups = k as usize / n;
                    let mut e = 0.0;
                    for g in 0..groups {
                        let mut m = [0.0f64; 3];
                        for c in &s[g * n..(g + 1) * n] {
                            for ch in 0..3 {
                                m[ch] += f64::from(c[ch]);
                            }
                        }
                        for ch in 0..3 {
                            let d = 255.0 * srgb_encode(m[ch] / n as f64) - reference[p][ch];
                            e += d * d / 3.0;
                        }
                    }
                    e / groups as f64
                })
            })
            .collect()
    };
    let a = curves(&set(10_000)?);
    let b = curves(&set(20_000)?);
    let uniform_at = COUNTS.iter().position(|&c| c == spp);
    let choose = |e: &[[f64; COUNTS.len()]], lambda: f64| -> Vec<usize> {
        e.iter()
            .map(|c| {
                (0..COUNTS.len())
                    .min_by(|&i, &j| {
                        (c[i] + lambda * f64::from(COUNTS[i])).total_cmp(&(c[j] + lambda * f64::from(COUNTS[j])))
                    })
                    .unwrap_or(0)
            })
            .collect()
    };
    let budget = f64::from(spp) * pixels as f64;
    let spent = |idx: &[usize]| idx.iter().map(|&i| f64::from(COUNTS[i])).sum::<f64>();
    // Bisection on log λ: a larger λ spends fewer samples.
    let (mut lo, mut hi) = (1e-6f64, 1e6f64);
    for _ in 0..60 {
        let mid = (lo * hi).sqrt();
        if spent(&choose(&a, mid)) > budget { lo = mid } else { hi = mid }
    }
    let chosen = choose(&a, hi);
    let score = |e: &[[f64; COUNTS.len()]], idx: &[usize]| {
        (e.iter().zip(idx).map(|(c, &i)| c[i]).sum::<f64>() / pixels as f64).sqrt()
    };
    let uniform_index = uniform_at.ok_or("SPP must be one of the candidate counts")?;
    let uniform = vec![uniform_index; pixels];
    let (ub, cb) = (score(&b, &uniform), score(&b, &chosen));
    let (ua, ca) = (score(&a, &uniform), score(&a, &chosen));
    println!(
        "{{\"scene\": {scene_spec:?}, \"size\": {size:?}, \"spp\": {spp}, \"K\": {k}, \"spp_chosen_mean\": {:.3}, \
         \"uniform_rmse_b\": {ub:.4}, \"oracle_rmse_b\": {cb:.4}, \"bound\": {:.4}, \"same_set_bound\": {:.4}}}",
        spent(&chosen) / pixels as f64,
        cb / ub,
        ca / ua
    );
    Ok(())
}
