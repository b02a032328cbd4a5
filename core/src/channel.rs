//! Discrete information channels `X → Y` and their algebra (Part II §2–§3,
//! Part V eqs. (5)–(7)).

use crate::divergence::mixture_divergence_and_entropy;
use crate::math::ln;
use crate::matrix::{MatrixRef, for_column_blocks};
use crate::scan::{check_normalized, entropy_nats, mass, mass_xlnx, same_len};
use crate::sum::Neumaier;
use crate::{Base, Error, Real};

/// A borrowed channel: an input distribution `p(x)` and a row-stochastic
/// conditional matrix `p(y|x)` (`rows = |X|`, `cols = |Y|`).
///
/// # Examples
/// ```
/// use itgfx_core::{Base, Channel};
/// // A binary symmetric channel with crossover 0.1 and a uniform input.
/// let ch = Channel::new(&[0.5f64, 0.5], &[0.9, 0.1, 0.1, 0.9], 2).unwrap();
/// let m = ch.measures(Base::Bits);
/// let h_b = -(0.1f64 * 0.1f64.log2() + 0.9 * 0.9f64.log2());
/// assert!((m.mutual_information - (1.0 - h_b)).abs() < 1e-12);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Channel<'a, T> {
    input: &'a [T],
    matrix: MatrixRef<'a, T>,
}

/// Every entropy of a channel, in one unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelMeasures {
    /// `H(X)`, the input entropy.
    pub h_x: f64,
    /// `H(Y)`, the output entropy.
    pub h_y: f64,
    /// `H(Y|X) = Σ p(x) H(Y|x)` (Part II eq. (5); Part V eq. (5)).
    pub h_y_given_x: f64,
    /// `H(X|Y) = H(X) − I(X;Y)`.
    pub h_x_given_y: f64,
    /// `H(X,Y) = H(X) + H(Y|X)` (Part II property 2).
    pub h_xy: f64,
    /// `I(X;Y) = Σ p(x) D_KL(p(Y|x) ‖ p(Y))`, computed directly (Part II eq. (7)).
    pub mutual_information: f64,
}

impl<'a, T: Real> Channel<'a, T> {
    /// Validates an input distribution and a `len(input) × cols` row-stochastic matrix.
    ///
    /// # Errors
    /// [`Error::Empty`], [`Error::LengthMismatch`], input errors as
    /// [`crate::Pmf::new`], matrix errors as [`MatrixRef::check_stochastic`].
    pub fn new(input: &'a [T], matrix: &'a [T], cols: usize) -> Result<Self, Error> {
        let rows = input.len();
        let matrix = MatrixRef::new(matrix, rows, cols)?;
        check_normalized::<T>(mass(input)?)?;
        matrix.check_stochastic()?;
        Ok(Self { input, matrix })
    }

    /// `|X|`.
    #[must_use]
    pub fn inputs(&self) -> usize {
        self.matrix.rows()
    }

    /// `|Y|`.
    #[must_use]
    pub fn outputs(&self) -> usize {
        self.matrix.cols()
    }

    /// The input distribution `p(x)`.
    #[must_use]
    pub fn input(&self) -> &'a [T] {
        self.input
    }

    /// The conditional matrix `p(y|x)`.
    #[must_use]
    pub fn matrix(&self) -> MatrixRef<'a, T> {
        self.matrix
    }

    /// Writes the joint `p(x, y) = p(x) p(y|x)` (Part II eq. (6)), row-major.
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] if `out.len() != |X|·|Y|`.
    pub fn joint_into(&self, out: &mut [T]) -> Result<(), Error> {
        same_len(self.matrix.data().len(), out.len())?;
        let c = self.outputs();
        for (i, px) in self.input.iter().enumerate() {
            let px = px.to_f64();
            for (o, x) in out[i * c..(i + 1) * c].iter_mut().zip(self.matrix.row(i)) {
                *o = T::from_f64(px * x.to_f64());
            }
        }
        Ok(())
    }

    /// Writes the output marginal `p(y) = Σ_x p(x) p(y|x)`.
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] if `out.len() != |Y|`.
    pub fn output_into(&self, out: &mut [T]) -> Result<(), Error> {
        same_len(self.outputs(), out.len())?;
        for_column_blocks(&self.matrix, Some(self.input), |c0, col| {
            for (o, &v) in out[c0..c0 + col.len()].iter_mut().zip(col) {
                *o = T::from_f64(v);
            }
        });
        Ok(())
    }

    /// Writes the reversed channel `p(x|y) = p(x) p(y|x) / p(y)` by Bayes'
    /// theorem (Part II eq. (6)) as a row-major `|Y| × |X|` matrix.
    ///
    /// Outputs that can never occur (`p(y) = 0`) get the prior `p(x)` as
    /// their row, so the result is always row-stochastic.
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] if `out.len() != |X|·|Y|`.
    pub fn reversed_into(&self, out: &mut [T]) -> Result<(), Error> {
        same_len(self.matrix.data().len(), out.len())?;
        let r = self.inputs();
        for_column_blocks(&self.matrix, Some(self.input), |c0, col| {
            for (dj, &py) in col.iter().enumerate() {
                let j = c0 + dj;
                for (i, px) in self.input.iter().enumerate() {
                    let v = if py > 0.0 { px.to_f64() * self.matrix.row(i)[j].to_f64() / py } else { px.to_f64() };
                    out[j * r + i] = T::from_f64(v);
                }
            }
        });
        Ok(())
    }

    /// Every entropy of the channel in `base`, allocation-free (two passes).
    #[must_use]
    pub fn measures(&self, base: Base) -> ChannelMeasures {
        let h_x = match mass_xlnx(self.input) {
            Ok(m) => entropy_nats(m),
            Err(_) => f64::NAN, // validated in `new`
        };
        let (mi, h_y, h_y_given_x) = mixture_divergence_and_entropy(self.input, &self.matrix);
        let h_y_given_x = h_y_given_x.max(0.0);
        let k = base.per_nat();
        let h_x_given_y = h_x - mi;
        ChannelMeasures {
            h_x: h_x * k,
            h_y: h_y * k,
            h_y_given_x: h_y_given_x * k,
            h_x_given_y: if h_x_given_y < 0.0 { 0.0 } else { h_x_given_y * k },
            h_xy: (h_x + h_y_given_x) * k,
            mutual_information: mi * k,
        }
    }

    /// Specific information of each input, `I(x;Y) = D_KL(p(Y|x) ‖ p(Y))`
    /// (Part V eq. (7), the viewpoint mutual information when `x` is a
    /// viewpoint). `Σ_x p(x) I(x;Y) = I(X;Y)` (Part V eq. (6)).
    ///
    /// `output` must be the output marginal (from [`Channel::output_into`]).
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] for wrong buffer lengths.
    pub fn specific_information_into(&self, output: &[T], base: Base, out: &mut [T]) -> Result<(), Error> {
        same_len(self.outputs(), output.len())?;
        same_len(self.inputs(), out.len())?;
        let k = base.per_nat();
        for (i, o) in out.iter_mut().enumerate() {
            let mut acc = Neumaier::new();
            for (x, y) in self.matrix.row(i).iter().zip(output) {
                let (x, y) = (x.to_f64(), y.to_f64());
                if x > 0.0 {
                    acc.add(if y > 0.0 { x * (ln(x) - ln(y)) } else { f64::INFINITY });
                }
            }
            let v = acc.value();
            *o = T::from_f64(if v < 0.0 { 0.0 } else { v * k });
        }
        Ok(())
    }

    /// Specific information of each output, `I(y;X) = D_KL(p(X|y) ‖ p(X))`,
    /// computed from the reversed channel (polygonal mutual information in
    /// Part V when `y` is a polygon). `Σ_y p(y) I(y;X) = I(X;Y)`.
    ///
    /// `reversed` must come from [`Channel::reversed_into`].
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] for wrong buffer lengths.
    pub fn output_specific_information_into(&self, reversed: &[T], base: Base, out: &mut [T]) -> Result<(), Error> {
        let (r, c) = (self.inputs(), self.outputs());
        same_len(r * c, reversed.len())?;
        same_len(c, out.len())?;
        let k = base.per_nat();
        for (j, o) in out.iter_mut().enumerate() {
            let mut acc = Neumaier::new();
            for (x, px) in reversed[j * r..(j + 1) * r].iter().zip(self.input) {
                let (x, px) = (x.to_f64(), px.to_f64());
                if x > 0.0 {
                    acc.add(if px > 0.0 { x * (ln(x) - ln(px)) } else { f64::INFINITY });
                }
            }
            let v = acc.value();
            *o = T::from_f64(if v < 0.0 { 0.0 } else { v * k });
        }
        Ok(())
    }
}

/// Cascade of channels `X → Y → Z`: writes `p(z|x) = Σ_y p(y|x) p(z|y)`,
/// the `|X| × |Z|` product of two row-stochastic matrices. By the data
/// processing inequality (Part II eq. (19)), `I(X;Z) ≤ I(X;Y)`.
///
/// # Errors
/// [`Error::Empty`], [`Error::LengthMismatch`] (including `out`), and the
/// errors of [`MatrixRef::check_stochastic`] for either matrix.
pub fn cascade_into<T: Real>(
    first: &[T],
    x: usize,
    y: usize,
    second: &[T],
    z: usize,
    out: &mut [T],
) -> Result<(), Error> {
    let a = MatrixRef::new(first, x, y)?;
    let b = MatrixRef::new(second, y, z)?;
    a.check_stochastic()?;
    b.check_stochastic()?;
    same_len(x * z, out.len())?;
    let mut acc = [0.0f64; crate::matrix::COL_BLOCK];
    for i in 0..x {
        let mut c0 = 0;
        while c0 < z {
            let c1 = (c0 + acc.len()).min(z);
            let w = &mut acc[..c1 - c0];
            w.iter_mut().for_each(|v| *v = 0.0);
            for (k, pk) in a.row(i).iter().enumerate() {
                let pk = pk.to_f64();
                if pk != 0.0 {
                    for (v, q) in w.iter_mut().zip(&b.row(k)[c0..c1]) {
                        *v += pk * q.to_f64();
                    }
                }
            }
            for (o, v) in out[i * z + c0..i * z + c1].iter_mut().zip(w.iter()) {
                *o = T::from_f64(*v);
            }
            c0 = c1;
        }
    }
    Ok(())
}

/// Conditional entropy of each row `H(Y|x) = −Σ_y p(y|x) log p(y|x)`
/// (e.g. the entropy of a patch, Part III eq. (40)) into `out`.
///
/// # Errors
/// As [`MatrixRef::new`], element errors with row-major indices, and
/// [`Error::LengthMismatch`] if `out.len() != rows`.
pub fn row_entropies_into<T: Real>(
    matrix: &[T],
    rows: usize,
    cols: usize,
    base: Base,
    out: &mut [T],
) -> Result<(), Error> {
    let m = MatrixRef::new(matrix, rows, cols)?;
    same_len(rows, out.len())?;
    for (i, o) in out.iter_mut().enumerate() {
        let s = mass_xlnx(m.row(i)).map_err(|e| crate::matrix::offset(e, i * cols))?;
        *o = T::from_f64(if s.sum > 0.0 { entropy_nats(s) * base.per_nat() } else { 0.0 });
    }
    Ok(())
}
