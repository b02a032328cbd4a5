//! The typed options of `itgfx measure NAME`: one variant per measure, with
//! vectors and matrices read and checked while parsing.

use clap::{Args, Subcommand};

use crate::input::Matrix;
use crate::options::Common;
use crate::values::{count, finite};

/// `itgfx measure NAME`: the measure and its typed options.
#[derive(Debug, Args)]
#[command(after_help = "Vectors: inline (0.5,0.25,0.25 or separate words) or a CSV file.\n\
                        Matrices: a CSV file (one row per line) or inline rows split by ';' (0.9,0.1;0.1,0.9).")]
pub struct MeasureCommand {
    /// The measure.
    #[command(subcommand)]
    pub measure: Measure,
}

/// A vector option: inline numbers or a CSV file, read while parsing.
#[derive(Debug, Clone)]
pub struct Vector(pub Vec<f64>);

/// A matrix option: a CSV file or inline `;` rows, read while parsing.
#[derive(Debug, Clone)]
pub struct MatrixArg(pub Matrix);

fn vector(s: &str) -> Result<Vector, String> {
    crate::input::vector_arg("value", s).map(Vector).map_err(|e| e.to_string())
}

fn max_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err("must be a positive number of seconds".into()),
    }
}

fn matrix(s: &str) -> Result<MatrixArg, String> {
    crate::input::matrix_arg("value", s).map(MatrixArg).map_err(|e| e.to_string())
}

/// Probabilities as positional words (or one CSV file).
#[derive(Debug, Args)]
pub struct Values {
    /// Probabilities: separate words, one comma list, or a CSV file
    #[arg(value_name = "P", allow_negative_numbers = true)]
    pub values: Vec<String>,
    /// Divide by the sum first
    #[arg(long)]
    pub normalize: bool,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub common: Common,
}

/// Two distributions.
#[derive(Debug, Args)]
pub struct Pair {
    /// The first distribution
    #[arg(long, value_name = "P", required = true, value_parser = vector)]
    pub p: Option<Vector>,
    /// The second distribution
    #[arg(long, value_name = "Q", required = true, value_parser = vector)]
    pub q: Option<Vector>,
    /// Divide each by its sum first
    #[arg(long)]
    pub normalize: bool,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub common: Common,
}

/// One matrix.
#[derive(Debug, Args)]
pub struct OneMatrix {
    /// The matrix
    #[arg(long, value_name = "M", required = true, value_parser = matrix)]
    pub matrix: Option<MatrixArg>,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub common: Common,
}

/// The measures, each with its own options.
#[derive(Debug, Subcommand)]
pub enum Measure {
    /// Shannon entropy H(p) (Part II eq. 2)
    Entropy(Values),
    /// Binary entropy H(p, 1-p) (Part II eq. 4) of one probability P
    Binary(Values),
    /// Renyi entropy of order A
    Renyi {
        /// The order A
        #[arg(long, value_name = "A", value_parser = finite)]
        alpha: f64,
        #[command(flatten)]
        #[allow(missing_docs)]
        values: Values,
    },
    /// Tsallis entropy of index Q
    Tsallis {
        /// The index Q
        #[arg(long, value_name = "Q", value_parser = finite)]
        q: f64,
        #[command(flatten)]
        #[allow(missing_docs)]
        values: Values,
    },
    /// H(X), H(Y), H(X,Y), H(X|Y), H(Y|X), I(X;Y) of a joint p(x,y)
    Joint(OneMatrix),
    /// Kullback-Leibler divergence (Part II eq. 8)
    Kl(Pair),
    /// KL, chi-square, Hellinger, their roots, AG, VO, L1, L2 (Part III-IV)
    Divergences(Pair),
    /// Weighted Jensen-Shannon divergence of the rows of M (Part II eq. 17)
    Js {
        /// The weights W
        #[arg(long, value_name = "W", required = true, value_parser = vector)]
        weights: Option<Vector>,
        /// The distributions, one per row
        #[arg(long, value_name = "M", required = true, value_parser = matrix)]
        dists: Option<MatrixArg>,
        #[command(flatten)]
        #[allow(missing_docs)]
        common: Common,
    },
    /// Every quantity of the channel X -> Y (Part II, Part V eqs. 5-7)
    Channel {
        /// The input distribution p(X)
        #[arg(long, value_name = "P", required = true, value_parser = vector)]
        input: Option<Vector>,
        /// The transition matrix p(Y|X), one row per input
        #[arg(long, value_name = "M", required = true, value_parser = matrix)]
        matrix: Option<MatrixArg>,
        #[command(flatten)]
        #[allow(missing_docs)]
        common: Common,
    },
    /// Stationary distribution, entropy rate, excess entropy (Part II eqs. 13-14)
    Markov(OneMatrix),
    /// Smallest error Fano allows; bound at E (Part II eqs. 21-22)
    Fano {
        /// H(X|Y)
        #[arg(long, value_name = "H", value_parser = finite)]
        h_cond: f64,
        /// Number of outcomes
        #[arg(long, value_name = "N", value_parser = count)]
        n: u64,
        /// An error probability to bound at
        #[arg(long, value_name = "E", value_parser = finite)]
        pe: Option<f64>,
        #[command(flatten)]
        #[allow(missing_docs)]
        common: Common,
    },
    /// Huffman expected length vs entropy (Part II eqs. 24-25)
    Huffman {
        /// Code blocks of K symbols too: 1..=64, and at most 2^22 blocks (n^K <= 4194304 for n symbols)
        #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(1..=64))]
        block: Option<u32>,
        #[command(flatten)]
        #[allow(missing_docs)]
        values: Values,
    },
    /// H = H_in + H_out over a partition (Part IV eq. 24)
    Grouping {
        /// The distribution
        #[arg(long, value_name = "P", required = true, value_parser = vector)]
        p: Option<Vector>,
        /// A group label per outcome (non-negative integers, any values)
        #[arg(long, value_name = "LABELS", required = true, value_parser = vector)]
        groups: Option<Vector>,
        /// Divide by the sum first
        #[arg(long)]
        normalize: bool,
        #[command(flatten)]
        #[allow(missing_docs)]
        common: Common,
    },
    /// H_P, H_S, H_J, I_S and MI matrix of a form-factor matrix (Part III)
    Scene {
        /// Patch areas
        #[arg(long, value_name = "A", required = true, value_parser = vector)]
        areas: Option<Vector>,
        /// Form factors, one row per patch
        #[arg(long, value_name = "F", required = true, value_parser = matrix)]
        matrix: Option<MatrixArg>,
        #[command(flatten)]
        #[allow(missing_docs)]
        common: Common,
    },
    /// Agglomerative information bottleneck merges (Slonim-Tishby)
    Bottleneck {
        /// The joint distribution p(x,y)
        #[arg(long, value_name = "M", required = true, value_parser = matrix)]
        joint: Option<MatrixArg>,
        /// Refuse a run estimated (from its rows and columns) to take more than S CPU seconds
        #[arg(long, value_name = "S", default_value = "60", value_parser = max_seconds)]
        max_seconds: f64,
        #[command(flatten)]
        #[allow(missing_docs)]
        common: Common,
    },
}

impl Measure {
    /// The options every measure has.
    #[must_use]
    pub fn common(&self) -> Common {
        match self {
            Measure::Entropy(v) | Measure::Binary(v) => v.common,
            Measure::Renyi { values, .. } | Measure::Tsallis { values, .. } | Measure::Huffman { values, .. } => {
                values.common
            }
            Measure::Joint(m) | Measure::Markov(m) => m.common,
            Measure::Kl(p) | Measure::Divergences(p) => p.common,
            Measure::Js { common, .. }
            | Measure::Channel { common, .. }
            | Measure::Fano { common, .. }
            | Measure::Grouping { common, .. }
            | Measure::Scene { common, .. }
            | Measure::Bottleneck { common, .. } => *common,
        }
    }
}
