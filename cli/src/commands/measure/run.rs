//! `itgfx measure NAME ...`: any core measure on numbers typed or read from CSV.

use itgfx_core as core_;
use itgfx_core::{Base, Channel};

use super::args::{MatrixArg, Measure, OneMatrix, Pair, Values, Vector};
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

/// Merge-loss terms per CPU second of the agglomerative bottleneck (a few
/// logarithms each) and comparisons per CPU second of its search, measured
/// on the 2-core development machine under load (400 x 64: 1.5 s; 2,000 x 2:
/// 42 s; 1,000 x 256: 35 s); its estimate is `terms / TERMS + comparisons /
/// COMPARES` ([`core_::bottleneck_work`]), CPU seconds.
const BOTTLENECK_TERMS_PER_S: f64 = 8e6;
/// See [`BOTTLENECK_TERMS_PER_S`].
const BOTTLENECK_COMPARES_PER_S: f64 = 3e7;

fn probabilities(normalize: bool, name: &str, v: Vec<f64>) -> Result<Vec<f64>, CliError> {
    if normalize {
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

fn positional_vector(words: &[String]) -> Result<Vec<f64>, CliError> {
    if words.is_empty() {
        return Err(CliError::usage("give the probabilities as arguments, e.g. 0.5 0.25 0.25, or a CSV file"));
    }
    let joined = words.join(" ");
    if words.len() == 1 {
        crate::input::vector_arg("values", &joined).map_err(CliError::input)
    } else {
        crate::input::parse_vector_text("values", &joined).map_err(CliError::input)
    }
}

fn given<T>(v: &Option<T>, flag: &str) -> Result<T, CliError>
where
    T: Clone,
{
    v.clone().ok_or_else(|| CliError::usage(format!("missing {flag}")))
}

/// Grouping labels as compact indices `0..k` in increasing label order, with
/// the distinct labels: memory follows the number of outcomes, never the
/// largest label.
///
/// # Errors
/// A usage error for a label that is not a non-negative integer.
pub fn compact_labels(g: &[f64]) -> Result<(Vec<usize>, Vec<u64>), CliError> {
    let mut raw = Vec::with_capacity(g.len());
    for &x in g {
        if !(x >= 0.0 && x.fract() == 0.0 && x <= 9_007_199_254_740_992.0) {
            return Err(CliError::usage(format!("--groups: label {x} is not a non-negative integer")));
        }
        raw.push(x as u64);
    }
    let mut distinct = raw.clone();
    distinct.sort_unstable();
    distinct.dedup();
    let labels = raw.iter().map(|l| distinct.binary_search(l).unwrap_or(0)).collect();
    Ok((labels, distinct))
}

/// Runs one measure: each has its own function below, which adds its
/// values to the report.
///
/// # Errors
/// Usage, input and core errors, each one line.
pub fn run(m: &Measure) -> Result<Report, CliError> {
    let base = m.common().base;
    let mut r = Report::new();
    match m {
        Measure::Entropy(v) => entropy(v, base, &mut r)?,
        Measure::Binary(v) => binary(v, base, &mut r)?,
        Measure::Renyi { alpha, values } => renyi(*alpha, values, base, &mut r)?,
        Measure::Tsallis { q, values } => tsallis(*q, values, &mut r)?,
        Measure::Joint(x) => joint(x, base, &mut r)?,
        Measure::Kl(x) => kl(x, base, &mut r)?,
        Measure::Divergences(x) => divergences(x, base, &mut r)?,
        Measure::Js { weights, dists, .. } => js(weights, dists, base, &mut r)?,
        Measure::Channel { input, matrix, .. } => channel(input, matrix, base, &mut r)?,
        Measure::Markov(x) => markov(x, base, &mut r)?,
        Measure::Fano { h_cond, n, pe, .. } => fano(*h_cond, *n, *pe, base, &mut r)?,
        Measure::Huffman { block, values } => huffman(*block, values, &mut r)?,
        Measure::Grouping { p, groups, normalize, .. } => grouping(p, groups, *normalize, base, &mut r)?,
        Measure::Scene { areas, matrix, .. } => scene(areas, matrix, base, &mut r)?,
        Measure::Bottleneck { joint, max_seconds, .. } => bottleneck(joint, *max_seconds, base, &mut r)?,
    }
    Ok(r)
}

/// `measure entropy`: H(p) (Part II eq. 2), its maximum and ratio.
fn entropy(v: &Values, base: Base, r: &mut Report) -> Result<(), CliError> {
    let unit = Some(base.unit());
    let p = probabilities(v.normalize, "p", positional_vector(&v.values)?)?;
    let h = core_::entropy(&p, base).map_err(|e| core_err("p", e))?;
    let max = base.log(p.len() as f64);
    r.count("outcomes", p.len() as u64).real("entropy", h, unit).real("max_entropy", max, unit);
    r.real("normalized_entropy", if max > 0.0 { h / max } else { 0.0 }, None);
    Ok(())
}

/// `measure binary`: H(p, 1-p) (Part II eq. 4).
fn binary(v: &Values, base: Base, r: &mut Report) -> Result<(), CliError> {
    if v.normalize {
        return Err(CliError::usage("--normalize: binary takes one probability p, there is no sum to divide by"));
    }
    let v = positional_vector(&v.values)?;
    if v.len() != 1 {
        return Err(CliError::usage("binary takes one probability p"));
    }
    r.real("binary_entropy", core_::binary_entropy(v[0], base).map_err(|e| core_err("p", e))?, Some(base.unit()));
    Ok(())
}

/// `measure renyi`: the Rényi entropy of order `a`.
fn renyi(a: f64, values: &Values, base: Base, r: &mut Report) -> Result<(), CliError> {
    let p = probabilities(values.normalize, "p", positional_vector(&values.values)?)?;
    let h = core_::renyi_entropy(&p, a, base).map_err(|e| core_err("p", e))?;
    r.real("alpha", a, None).real("renyi_entropy", h, Some(base.unit()));
    Ok(())
}

/// `measure tsallis`: the Tsallis entropy of index `q` (no unit: it takes no logarithm base).
fn tsallis(q: f64, values: &Values, r: &mut Report) -> Result<(), CliError> {
    let p = probabilities(values.normalize, "p", positional_vector(&values.values)?)?;
    r.real("q", q, None).real("tsallis_entropy", core_::tsallis_entropy(&p, q).map_err(|e| core_err("p", e))?, None);
    Ok(())
}

/// `measure joint`: the entropies and mutual information of a joint p(x,y).
/// A core error of a measure that takes no `--normalize` (`joint`, `js`,
/// `channel`, `markov`, `scene`, `bottleneck`): without [`core_err`]'s hint
/// at an option that measure refuses (the core's line already says to
/// normalise).
fn no_option_err(what: &str, e: itgfx_core::Error) -> CliError {
    CliError::usage(format!("{what}: {e}"))
}

fn joint(x: &OneMatrix, base: Base, r: &mut Report) -> Result<(), CliError> {
    let unit = Some(base.unit());
    let m = given(&x.matrix, "--matrix")?.0;
    let e = core_::joint_entropies(&m.data, m.rows, m.cols, base).map_err(|e| no_option_err("matrix", e))?;
    r.count("rows", m.rows as u64).count("cols", m.cols as u64);
    r.real("h_x", e.h_x, unit).real("h_y", e.h_y, unit).real("h_xy", e.h_xy, unit);
    r.real("h_x_given_y", e.h_x_given_y, unit).real("h_y_given_x", e.h_y_given_x, unit);
    r.real("mutual_information", e.mutual_information, unit);
    Ok(())
}

/// `--p` and `--q`, each divided by its sum with `--normalize`.
fn pair(x: &Pair) -> Result<(Vec<f64>, Vec<f64>), CliError> {
    let p = given(&x.p, "--p")?.0;
    let q = given(&x.q, "--q")?.0;
    Ok((probabilities(x.normalize, "p", p)?, probabilities(x.normalize, "q", q)?))
}

/// `measure kl`: D(p||q) (Part II eq. 8).
fn kl(x: &Pair, base: Base, r: &mut Report) -> Result<(), CliError> {
    let (p, q) = pair(x)?;
    r.real("kl", core_::kl_divergence(&p, &q, base).map_err(|e| core_err("p, q", e))?, Some(base.unit()));
    Ok(())
}

/// `measure divergences`: every divergence of Part III-IV between p and q.
fn divergences(x: &Pair, base: Base, r: &mut Report) -> Result<(), CliError> {
    let unit = Some(base.unit());
    let (p, q) = pair(x)?;
    let d = core_::divergences(&p, &q, base).map_err(|e| core_err("p, q", e))?;
    r.real("kl", d.kl, unit).real("kl_sqrt", d.kl_sqrt, None);
    r.real("chi_square", d.chi_square, None).real("chi_square_sqrt", d.chi_square_sqrt, None);
    r.real("hellinger", d.hellinger, None).real("hellinger_sqrt", d.hellinger_sqrt, None);
    r.real("arithmetic_geometric", d.arithmetic_geometric, unit);
    r.real("vasershtein_ornstein", d.vasershtein_ornstein, None);
    r.real("l1", d.l1, None).real("l2", d.l2, None);
    Ok(())
}

/// A usage error unless a matrix has one row per value of a vector.
fn rows_match(matrix: (&str, usize), vector: (&str, usize)) -> Result<(), CliError> {
    if matrix.1 == vector.1 {
        return Ok(());
    }
    Err(CliError::usage(format!("{} has {} rows but {} has {} values", matrix.0, matrix.1, vector.0, vector.1)))
}

/// `measure js`: the weighted Jensen-Shannon divergence (Part II eq. 17).
fn js(weights: &Option<Vector>, dists: &Option<MatrixArg>, base: Base, r: &mut Report) -> Result<(), CliError> {
    let w = given(weights, "--weights")?.0;
    let d = given(dists, "--dists")?.0;
    rows_match(("--dists", d.rows), ("--weights", w.len()))?;
    let js = core_::jensen_shannon(&w, &d.data, d.cols, base).map_err(|e| no_option_err("weights, dists", e))?;
    r.count("distributions", d.rows as u64).count("outcomes", d.cols as u64);
    r.real("jensen_shannon", js, Some(base.unit()));
    Ok(())
}

/// `measure channel`: every quantity of the channel X -> Y (Part II; Part V eqs. 5-7).
fn channel(input: &Option<Vector>, matrix: &Option<MatrixArg>, base: Base, r: &mut Report) -> Result<(), CliError> {
    let unit = Some(base.unit());
    let p = given(input, "--input")?.0;
    let m = given(matrix, "--matrix")?.0;
    rows_match(("--matrix", m.rows), ("--input", p.len()))?;
    let err = |e| no_option_err("channel", e);
    let ch = Channel::new(&p, &m.data, m.cols).map_err(err)?;
    let cm = ch.measures(base);
    let mut py = vec![0.0; m.cols];
    ch.output_into(&mut py).map_err(err)?;
    let mut ix = vec![0.0; m.rows];
    ch.specific_information_into(&py, base, &mut ix).map_err(err)?;
    let mut rev = vec![0.0; m.rows * m.cols];
    ch.reversed_into(&mut rev).map_err(err)?;
    let mut iy = vec![0.0; m.cols];
    ch.output_specific_information_into(&rev, base, &mut iy).map_err(err)?;
    r.count("inputs", m.rows as u64).count("outputs", m.cols as u64);
    r.real("h_x", cm.h_x, unit).real("h_y", cm.h_y, unit).real("h_xy", cm.h_xy, unit);
    r.real("h_y_given_x", cm.h_y_given_x, unit).real("h_x_given_y", cm.h_x_given_y, unit);
    r.real("mutual_information", cm.mutual_information, unit);
    r.reals("output_distribution", py).reals("input_specific_information", ix);
    r.reals("output_specific_information", iy).reals("reversed_channel", rev);
    Ok(())
}

/// `measure markov`: stationary distribution, entropy rate and excess
/// entropy (Part II eqs. 13-14).
fn markov(x: &OneMatrix, base: Base, r: &mut Report) -> Result<(), CliError> {
    let unit = Some(base.unit());
    let m = given(&x.matrix, "--matrix")?.0;
    if m.rows != m.cols {
        return Err(CliError::usage(format!("--matrix must be square, got {}x{}", m.rows, m.cols)));
    }
    let n = m.rows;
    // GTH elimination works on an n x n copy: refuse what cannot fit.
    let bytes = 8u64.saturating_mul(n as u64).saturating_mul(n as u64);
    if bytes > 8 << 30 {
        return Err(CliError::usage(format!("--matrix: {n} states need {bytes} bytes of scratch; the limit is 8 GiB")));
    }
    let w = core_::stationary_distribution(&m.data, n).map_err(|e| no_option_err("matrix", e))?;
    let h = core_::entropy_rate(&m.data, &w, base).map_err(|e| no_option_err("matrix", e))?;
    let e = core_::markov_excess_entropy(&m.data, &w, base).map_err(|e| no_option_err("matrix", e))?;
    r.count("states", n as u64);
    r.reals("stationary_distribution", w).real("entropy_rate", h, unit).real("excess_entropy", e, unit);
    Ok(())
}

/// `measure fano`: the smallest error Fano's inequality allows, and the
/// bound at `pe` (Part II eqs. 21-22).
fn fano(h: f64, n: u64, pe: Option<f64>, base: Base, r: &mut Report) -> Result<(), CliError> {
    let n = usize::try_from(n).map_err(|_| CliError::usage("--n: too large"))?;
    let min = core_::fano_minimum_error(h, n, base).map_err(|e| core_err("fano", e))?;
    r.real("h_cond", h, Some(base.unit())).count("n", n as u64).real("minimum_error_probability", min, None);
    if base == Base::Bits && n >= 2 {
        r.real("weak_bound", core_::fano_weak_bound(h, n).map_err(|e| core_err("fano", e))?, None);
    }
    if let Some(pe) = pe {
        let b = core_::fano_bound(pe, n, base).map_err(|e| core_err("pe", e))?;
        r.real("pe", pe, None).real("fano_bound", b, Some(base.unit()));
        r.text("consistent", if b >= h { "yes" } else { "no" });
    }
    Ok(())
}

/// `measure huffman`: expected code length against entropy, per symbol and
/// per block of `block` symbols (Part II eqs. 24-25).
fn huffman(block: Option<u32>, values: &Values, r: &mut Report) -> Result<(), CliError> {
    let p = probabilities(values.normalize, "p", positional_vector(&values.values)?)?;
    let n = p.len() as u64;
    if let Some(k) = block
        && n.checked_pow(k).is_none_or(|m| m > core_::HUFFMAN_MAX_BLOCKS)
    {
        let most = (1..=k).take_while(|&j| n.pow(j) <= core_::HUFFMAN_MAX_BLOCKS).last().unwrap_or(0);
        return Err(CliError::usage(format!(
            "--block {k}: {n}^{k} blocks is more than 2^22; with {n} symbols give at most --block {most}"
        )));
    }
    let mut s = vec![0.0; p.len()];
    let l = core_::huffman_expected_length(&p, &mut s).map_err(|e| core_err("p", e))?;
    let h = core_::entropy(&p, Base::Bits).map_err(|e| core_err("p", e))?;
    r.real("entropy", h, Some("bits")).real("expected_length", l, Some("bits/symbol"));
    r.real("redundancy", l - h, Some("bits/symbol"));
    if let Some(k) = block {
        let lk = core_::huffman_block_length(&p, k).map_err(|e| core_err("block", e))?;
        r.count("block", u64::from(k)).real("block_length_per_symbol", lk, Some("bits/symbol"));
    }
    Ok(())
}

/// `measure grouping`: H = H_in + H_out over a partition (Part IV eq. 24).
fn grouping(
    p: &Option<Vector>,
    groups: &Option<Vector>,
    normalize: bool,
    base: Base,
    r: &mut Report,
) -> Result<(), CliError> {
    let unit = Some(base.unit());
    let p = probabilities(normalize, "p", given(p, "--p")?.0)?;
    let (labels, distinct) = compact_labels(&given(groups, "--groups")?.0)?;
    let mut q = vec![0.0; distinct.len()];
    let d = core_::grouping(&p, &labels, distinct.len(), &mut q, base).map_err(|e| core_err("p, groups", e))?;
    let h = core_::entropy(&p, base).map_err(|e| core_err("p", e))?;
    r.real("entropy", h, unit).real("h_in", d.h_in, unit).real("h_out", d.h_out, unit);
    r.reals("group_probabilities", q).counts("group_labels", distinct);
    Ok(())
}

/// `measure scene`: the scene measures of a form-factor matrix and the
/// mutual information matrix (Part III eqs. (42)-(46)).
fn scene(areas: &Option<Vector>, matrix: &Option<MatrixArg>, base: Base, r: &mut Report) -> Result<(), CliError> {
    let unit = Some(base.unit());
    let a = given(areas, "--areas")?.0;
    let f = given(matrix, "--matrix")?.0;
    if f.rows != a.len() || f.cols != a.len() {
        return Err(CliError::usage(format!("--matrix is {}x{} but there are {} areas", f.rows, f.cols, a.len())));
    }
    let m = core_::scene_measures(&a, &f.data, base).map_err(|e| no_option_err("scene", e))?;
    let n = a.len();
    reciprocity_warning(&a, &f.data);
    let mut mi = vec![0.0; n * n];
    let mut per = vec![0.0; n];
    core_::mutual_information_matrix_into(&a, &f.data, base, &mut mi, &mut per)
        .map_err(|e| no_option_err("scene", e))?;
    r.count("patches", n as u64);
    r.real("H_P", m.positional_entropy, unit).real("H_S", m.scene_entropy, unit);
    r.real("H_J", m.joint_entropy, unit).real("I_S", m.mutual_information, unit);
    r.real("H_S_normalized", m.normalized_entropy, None);
    r.real("I_S_normalized", m.normalized_mutual_information, None);
    r.reals("I_i", per).reals("I_ij", mi);
    Ok(())
}

/// `measure bottleneck`: the agglomerative information bottleneck's merges,
/// refused above `--max-seconds` by its estimated time.
fn bottleneck(joint: &Option<MatrixArg>, max_seconds: f64, base: Base, r: &mut Report) -> Result<(), CliError> {
    let unit = Some(base.unit());
    let m = given(joint, "--joint")?.0;
    let (terms, compares) = core_::bottleneck_work(m.rows, m.cols);
    let estimate = terms as f64 / BOTTLENECK_TERMS_PER_S + compares as f64 / BOTTLENECK_COMPARES_PER_S;
    if estimate > max_seconds {
        return Err(CliError::usage(format!(
            "bottleneck: {} rows x {} columns take about {} CPU seconds (estimate), above --max-seconds {max_seconds}; raise it to run",
            m.rows,
            m.cols,
            estimate.ceil()
        )));
    }
    let mut progress = crate::progress::Progress::with_unit("Mcomparisons/s");
    let b = core_::agglomerative_bottleneck_with_progress(&m.data, m.rows, m.cols, base, |d, t| {
        progress.update(d, t);
    })
    .map_err(|e| no_option_err("joint", e))?;
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
    Ok(())
}

/// Largest relative departure from reciprocity `a_i F_ij = a_j F_ji`
/// (Part III eq. (42)) that passes without a warning.
const RECIPROCITY_TOLERANCE: f64 = 1e-3;

/// Warns (stderr, one line) when the form factors are not reciprocal: the
/// measures take `p_ij = a_i F_ij` as the joint and `a` as both marginals
/// (eqs. (42)-(46)), which only a reciprocal matrix makes true. A warning,
/// not a refusal: estimated form factors are reciprocal only up to their
/// noise, and no tolerance would suit every estimate.
fn reciprocity_warning(a: &[f64], f: &[f64]) {
    let n = a.len();
    let total: f64 = a.iter().sum();
    let mut worst = (0.0, 0, 0);
    for i in 0..n {
        for j in i + 1..n {
            let (x, y) = (a[i] / total * f[i * n + j], a[j] / total * f[j * n + i]);
            let scale = x.abs().max(y.abs());
            if scale > 0.0 && (x - y).abs() / scale > worst.0 {
                worst = ((x - y).abs() / scale, i, j);
            }
        }
    }
    if worst.0 > RECIPROCITY_TOLERANCE {
        eprintln!(
            "itgfx: warning: scene: the form factors are not reciprocal (a_i F_ij = a_j F_ji, Part III eq. (42)): patches {} and {} differ by {:.3}%; the measures take a as both marginals",
            worst.1,
            worst.2,
            100.0 * worst.0
        );
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    use super::MEASURES;
    use crate::options::Cli;

    #[test]
    fn the_measure_list_is_the_parser_list() {
        let cmd = Cli::command();
        let m = cmd.find_subcommand("measure").unwrap();
        let parsed: Vec<&str> = m.get_subcommands().map(clap::Command::get_name).collect();
        let listed: Vec<&str> = MEASURES.iter().map(|(n, _)| *n).collect();
        assert_eq!(parsed, listed);
    }

    #[test]
    fn options_are_consistent() {
        Cli::command().debug_assert();
    }
}
