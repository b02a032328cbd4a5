//! `itgfx measure NAME ...`: any core measure on numbers typed or read from CSV.

use itgfx_core as core_;
use itgfx_core::{Base, Channel};

use crate::args::Args;
use crate::report::Report;
use crate::{CliError, core_err};

/// The measures `itgfx measure` knows, with a one-line synopsis each.
pub const MEASURES: &[(&str, &str)] = &[
    ("entropy", "P... [--normalize]            Shannon entropy H(p) (Part II eq. 2)"),
    ("binary", "P                             binary entropy H(p, 1-p) (Part II eq. 4)"),
    ("renyi", "--alpha A P... [--normalize]   Renyi entropy of order A"),
    ("tsallis", "--q Q P... [--normalize]       Tsallis entropy of index Q"),
    ("joint", "--matrix M                     H(X), H(Y), H(X,Y), H(X|Y), H(Y|X), I(X;Y) of a joint p(x,y)"),
    ("kl", "--p P --q Q                    Kullback-Leibler divergence (Part II eq. 8)"),
    (
        "divergences",
        "--p P --q Q                    KL, chi-square, Hellinger, their roots, AG, VO, L1, L2 (Part III-IV)",
    ),
    ("js", "--weights W --dists M          weighted Jensen-Shannon divergence of the rows of M (Part II eq. 17)"),
    ("channel", "--input P --matrix M           every quantity of the channel X -> Y (Part II, Part V eqs. 5-7)"),
    (
        "markov",
        "--matrix M                     stationary distribution, entropy rate, excess entropy (Part II eqs. 13-14)",
    ),
    ("fano", "--h-cond H --n N [--pe E]      smallest error Fano allows; bound at E (Part II eqs. 21-22)"),
    ("huffman", "P... [--block K]               Huffman expected length vs entropy (Part II eqs. 24-25)"),
    ("grouping", "--p P --groups LABELS          H = H_in + H_out over a partition (Part IV eq. 24)"),
    ("scene", "--areas A --matrix F           H_P, H_S, H_J, I_S and MI matrix of a form-factor matrix (Part III)"),
    ("bottleneck", "--joint M                      agglomerative information bottleneck merges (Slonim-Tishby)"),
];

fn probabilities(args: &Args, name: &str, v: Vec<f64>) -> Result<Vec<f64>, CliError> {
    if args.flag("normalize") {
        let s: f64 = v.iter().sum();
        if !(s > 0.0 && s.is_finite()) {
            // Let the core name the offending element.
            core_::entropy_of_weights(&v, Base::Bits).map_err(|e| core_err(name, e))?;
            return Err(CliError::usage(format!("{name}: values do not sum to a positive finite total")));
        }
        Ok(v.into_iter().map(|x| x / s).collect())
    } else {
        Ok(v)
    }
}

fn positional_vector(args: &Args) -> Result<Vec<f64>, CliError> {
    if args.positionals.is_empty() {
        return Err(CliError::usage("give the probabilities as arguments, e.g. 0.5 0.25 0.25, or a CSV file"));
    }
    let joined = args.positionals.join(" ");
    if args.positionals.len() == 1 {
        crate::input::vector_arg("values", &joined).map_err(CliError::input)
    } else {
        crate::input::parse_vector_text("values", &joined).map_err(CliError::input)
    }
}

/// Runs one measure.
///
/// # Errors
/// Usage, input and core errors, each one line.
pub fn run(name: &str, args: &Args) -> Result<Report, CliError> {
    let base = args.base()?;
    let unit = Some(base.unit());
    let mut r = Report::new();
    match name {
        "entropy" => {
            let p = probabilities(args, "p", positional_vector(args)?)?;
            let h = core_::entropy(&p, base).map_err(|e| core_err("p", e))?;
            let max = base.log(p.len() as f64);
            r.count("outcomes", p.len() as u64).real("entropy", h, unit).real("max_entropy", max, unit);
            r.real("normalized_entropy", if max > 0.0 { h / max } else { 0.0 }, None);
        }
        "binary" => {
            let v = positional_vector(args)?;
            if v.len() != 1 {
                return Err(CliError::usage("binary takes one probability p"));
            }
            r.real("binary_entropy", core_::binary_entropy(v[0], base).map_err(|e| core_err("p", e))?, unit);
        }
        "renyi" | "tsallis" => {
            let key = if name == "renyi" { "alpha" } else { "q" };
            let a = args.number(key)?.ok_or_else(|| CliError::usage(format!("missing --{key}")))?;
            let p = probabilities(args, "p", positional_vector(args)?)?;
            if name == "renyi" {
                r.real("alpha", a, None).real(
                    "renyi_entropy",
                    core_::renyi_entropy(&p, a, base).map_err(|e| core_err("p", e))?,
                    unit,
                );
            } else {
                r.real("q", a, None).real(
                    "tsallis_entropy",
                    core_::tsallis_entropy(&p, a).map_err(|e| core_err("p", e))?,
                    None,
                );
            }
        }
        "joint" => {
            let m = args.matrix("matrix")?.ok_or_else(|| CliError::usage("missing --matrix"))?;
            let e = core_::joint_entropies(&m.data, m.rows, m.cols, base).map_err(|e| core_err("matrix", e))?;
            r.count("rows", m.rows as u64).count("cols", m.cols as u64);
            r.real("h_x", e.h_x, unit).real("h_y", e.h_y, unit).real("h_xy", e.h_xy, unit);
            r.real("h_x_given_y", e.h_x_given_y, unit).real("h_y_given_x", e.h_y_given_x, unit);
            r.real("mutual_information", e.mutual_information, unit);
        }
        "kl" | "divergences" => {
            let p = args.vector("p")?.ok_or_else(|| CliError::usage("missing --p"))?;
            let q = args.vector("q")?.ok_or_else(|| CliError::usage("missing --q"))?;
            let (p, q) = (probabilities(args, "p", p)?, probabilities(args, "q", q)?);
            if name == "kl" {
                r.real("kl", core_::kl_divergence(&p, &q, base).map_err(|e| core_err("p, q", e))?, unit);
            } else {
                let d = core_::divergences(&p, &q, base).map_err(|e| core_err("p, q", e))?;
                r.real("kl", d.kl, unit).real("kl_sqrt", d.kl_sqrt, None);
                r.real("chi_square", d.chi_square, None).real("chi_square_sqrt", d.chi_square_sqrt, None);
                r.real("hellinger", d.hellinger, None).real("hellinger_sqrt", d.hellinger_sqrt, None);
                r.real("arithmetic_geometric", d.arithmetic_geometric, unit);
                r.real("vasershtein_ornstein", d.vasershtein_ornstein, None);
                r.real("l1", d.l1, None).real("l2", d.l2, None);
            }
        }
        "js" => {
            let w = args.vector("weights")?.ok_or_else(|| CliError::usage("missing --weights"))?;
            let d = args.matrix("dists")?.ok_or_else(|| CliError::usage("missing --dists"))?;
            if d.rows != w.len() {
                return Err(CliError::usage(format!(
                    "--dists has {} rows but --weights has {} values",
                    d.rows,
                    w.len()
                )));
            }
            let js = core_::jensen_shannon(&w, &d.data, d.cols, base).map_err(|e| core_err("weights, dists", e))?;
            r.count("distributions", d.rows as u64).count("outcomes", d.cols as u64).real("jensen_shannon", js, unit);
        }
        "channel" => {
            let p = args.vector("input")?.ok_or_else(|| CliError::usage("missing --input"))?;
            let m = args.matrix("matrix")?.ok_or_else(|| CliError::usage("missing --matrix"))?;
            if m.rows != p.len() {
                return Err(CliError::usage(format!(
                    "--matrix has {} rows but --input has {} values",
                    m.rows,
                    p.len()
                )));
            }
            let ch = Channel::new(&p, &m.data, m.cols).map_err(|e| core_err("channel", e))?;
            let cm = ch.measures(base);
            let mut py = vec![0.0; m.cols];
            ch.output_into(&mut py).map_err(|e| core_err("channel", e))?;
            let mut ix = vec![0.0; m.rows];
            ch.specific_information_into(&py, base, &mut ix).map_err(|e| core_err("channel", e))?;
            let mut rev = vec![0.0; m.rows * m.cols];
            ch.reversed_into(&mut rev).map_err(|e| core_err("channel", e))?;
            let mut iy = vec![0.0; m.cols];
            ch.output_specific_information_into(&rev, base, &mut iy).map_err(|e| core_err("channel", e))?;
            r.count("inputs", m.rows as u64).count("outputs", m.cols as u64);
            r.real("h_x", cm.h_x, unit).real("h_y", cm.h_y, unit).real("h_xy", cm.h_xy, unit);
            r.real("h_y_given_x", cm.h_y_given_x, unit).real("h_x_given_y", cm.h_x_given_y, unit);
            r.real("mutual_information", cm.mutual_information, unit);
            r.reals("output_distribution", py).reals("input_specific_information", ix);
            r.reals("output_specific_information", iy).reals("reversed_channel", rev);
        }
        "markov" => {
            let m = args.matrix("matrix")?.ok_or_else(|| CliError::usage("missing --matrix"))?;
            if m.rows != m.cols {
                return Err(CliError::usage(format!("--matrix must be square, got {}x{}", m.rows, m.cols)));
            }
            let n = m.rows;
            // GTH elimination works on an n x n copy: refuse what cannot fit.
            let bytes = 8u64.saturating_mul(n as u64).saturating_mul(n as u64);
            if bytes > 8 << 30 {
                return Err(CliError::usage(format!("--matrix: {n} states need {bytes} bytes of scratch; the limit is 8 GiB")));
            }
            let w = core_::stationary_distribution(&m.data, n).map_err(|e| core_err("matrix", e))?;
            let h = core_::entropy_rate(&m.data, &w, base).map_err(|e| core_err("matrix", e))?;
            let e = core_::markov_excess_entropy(&m.data, &w, base).map_err(|e| core_err("matrix", e))?;
            r.count("states", n as u64);
            r.reals("stationary_distribution", w).real("entropy_rate", h, unit).real("excess_entropy", e, unit);
        }
        "fano" => {
            let h = args.number("h-cond")?.ok_or_else(|| CliError::usage("missing --h-cond (H(X|Y))"))?;
            let n = args.integer("n")?.ok_or_else(|| CliError::usage("missing --n (number of outcomes)"))? as usize;
            let min = core_::fano_minimum_error(h, n, base).map_err(|e| core_err("fano", e))?;
            r.real("h_cond", h, unit).count("n", n as u64).real("minimum_error_probability", min, None);
            if base == Base::Bits && n >= 2 {
                r.real("weak_bound", core_::fano_weak_bound(h, n).map_err(|e| core_err("fano", e))?, None);
            }
            if let Some(pe) = args.number("pe")? {
                let b = core_::fano_bound(pe, n, base).map_err(|e| core_err("pe", e))?;
                r.real("pe", pe, None)
                    .real("fano_bound", b, unit)
                    .text("consistent", if b >= h { "yes" } else { "no" });
            }
        }
        "huffman" => {
            let p = probabilities(args, "p", positional_vector(args)?)?;
            let mut s = vec![0.0; p.len()];
            let l = core_::huffman_expected_length(&p, &mut s).map_err(|e| core_err("p", e))?;
            let h = core_::entropy(&p, Base::Bits).map_err(|e| core_err("p", e))?;
            r.real("entropy", h, Some("bits")).real("expected_length", l, Some("bits/symbol"));
            r.real("redundancy", l - h, Some("bits/symbol"));
            if let Some(k) = args.integer("block")? {
                let k = u32::try_from(k).map_err(|_| CliError::usage("--block: too large"))?;
                let lk = core_::huffman_block_length(&p, k).map_err(|e| core_err("block", e))?;
                r.count("block", u64::from(k)).real("block_length_per_symbol", lk, Some("bits/symbol"));
            }
        }
        "grouping" => {
            let p = args.vector("p")?.ok_or_else(|| CliError::usage("missing --p"))?;
            let g = args
                .vector("groups")?
                .ok_or_else(|| CliError::usage("missing --groups (a group label per outcome)"))?;
            let p = probabilities(args, "p", p)?;
            let labels: Vec<usize> = g
                .iter()
                .map(|&x| {
                    if x >= 0.0 && x.fract() == 0.0 && x <= 9_007_199_254_740_992.0 {
                        Ok(x as usize)
                    } else {
                        Err(CliError::usage(format!("--groups: label {x} is not a small non-negative integer")))
                    }
                })
                .collect::<Result<_, _>>()?;
            let mut order = vec![0usize; p.len()];
            let mut q = vec![0.0; p.len()];
            let (d, g) = core_::grouping_by_label(&p, &labels, &mut order, &mut q, base)
                .map_err(|e| core_err("p, groups", e))?;
            q.truncate(g);
            let h = core_::entropy(&p, base).map_err(|e| core_err("p", e))?;
            r.real("entropy", h, unit).real("h_in", d.h_in, unit).real("h_out", d.h_out, unit);
            r.reals("group_probabilities", q);
        }
        "scene" => {
            let a = args.vector("areas")?.ok_or_else(|| CliError::usage("missing --areas"))?;
            let f = args.matrix("matrix")?.ok_or_else(|| CliError::usage("missing --matrix (form factors)"))?;
            if f.rows != a.len() || f.cols != a.len() {
                return Err(CliError::usage(format!(
                    "--matrix is {}x{} but there are {} areas",
                    f.rows,
                    f.cols,
                    a.len()
                )));
            }
            let m = core_::scene_measures(&a, &f.data, base).map_err(|e| core_err("scene", e))?;
            let n = a.len();
            let mut mi = vec![0.0; n * n];
            let mut per = vec![0.0; n];
            core_::mutual_information_matrix_into(&a, &f.data, base, &mut mi, &mut per)
                .map_err(|e| core_err("scene", e))?;
            r.count("patches", n as u64);
            r.real("H_P", m.positional_entropy, unit).real("H_S", m.scene_entropy, unit);
            r.real("H_J", m.joint_entropy, unit).real("I_S", m.mutual_information, unit);
            r.real("H_S_normalized", m.normalized_entropy, None).real(
                "I_S_normalized",
                m.normalized_mutual_information,
                None,
            );
            r.reals("I_i", per).reals("I_ij", mi);
        }
        "bottleneck" => {
            let m = args.matrix("joint")?.ok_or_else(|| CliError::usage("missing --joint"))?;
            let b = core_::agglomerative_bottleneck(&m.data, m.rows, m.cols, base).map_err(|e| core_err("joint", e))?;
            r.real("initial_information", b.initial_information, unit);
            let steps = b
                .merges
                .iter()
                .map(|s| {
                    let mut x = Report::new();
                    x.count("into", s.into as u64).count("from", s.from as u64).real("loss", s.loss, unit);
                    x.real("information", s.information, unit).count("clusters", s.clusters as u64);
                    x
                })
                .collect();
            r.records("merges", steps);
        }
        other => {
            return Err(CliError::usage(format!("unknown measure {other:?}; `itgfx measure --help` lists them")));
        }
    }
    args.finish()?;
    Ok(r)
}

/// Help text for `itgfx measure`.
#[must_use]
pub fn help() -> String {
    let mut s = String::from(
        "itgfx measure NAME [OPTIONS] — evaluate an information measure\n\n\
         Vectors: inline (0.5,0.25,0.25 or separate words) or a CSV file.\n\
         Matrices: a CSV file (one row per line) or inline rows split by ';' (0.9,0.1;0.1,0.9).\n\
         Common options: --base 2|e|10 (default 2), --json (one object, infinities as \"inf\").\n\nMeasures:\n",
    );
    for (n, d) in MEASURES {
        s.push_str(&format!("  {n:<12} {d}\n"));
    }
    s
}
