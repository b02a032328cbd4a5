//! The measures of the viewpoint channel (Part V §3): `p(V)`, `p(O|v)` and
//! `p(O)` over the viewpoints that see the object, and everything computed
//! from them through [`itgfx_core::SparseChannel`].

use itgfx_core::{Base, Error, SparseChannel, SparseRows};

use rayon::prelude::*;

use super::ViewpointChannel;

/// Outputs per block of the per-output passes (`p(o)`, `I(o;V)`) that run
/// side by side: each block reads its part of every row.
const OUTPUT_BLOCK: usize = 1 << 14;

/// `ln x` of every value (the core's [`itgfx_core::sparse_logs`], on chunks
/// side by side): what the core's `*_logs` passes take for a target
/// distribution.
fn logs_of(xs: &[f64]) -> Vec<f64> {
    let mut logs = vec![0.0; xs.len()];
    logs.par_chunks_mut(4096).zip(xs.par_chunks(4096)).for_each(|(l, x)| itgfx_core::sparse_logs(x, l));
    logs
}

/// How the input distribution `p(V)` is chosen (Part V §3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewpointWeights {
    /// Proportional to the object's projected solid angle at `v` (the default).
    ProjectedArea,
    /// `1 / N_v` over the viewpoints that see the object.
    Uniform,
}

/// The normalised channel `V → O` over the viewpoints that see the object.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewpointAnalysis {
    /// Viewpoint index (in the sampled channel) of each row.
    pub seen: Vec<usize>,
    /// `p(v)` of each row.
    pub p_v: Vec<f64>,
    /// `p(o)`, the output marginal (the last entry is the background when
    /// it is counted as a polygon).
    pub p_o: Vec<f64>,
    /// Projected solid angle of the object at each row's viewpoint.
    pub seen_angle: Vec<f64>,
    /// Whether the background is the extra output `patches`.
    pub background: bool,
    /// Viewpoints in the sampled channel.
    pub viewpoints: usize,
    /// Patches in the scene.
    pub patches: usize,
    /// `p(O|v)` of every row, checked once when the analysis is made.
    rows: SparseRows<f64>,
}

/// Per-viewpoint measures over all sampled viewpoints, in one unit.
/// Viewpoints that see nothing get weight 0, VE 0 and VMI/VKL `∞`.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewpointMeasures {
    /// `p(v)`.
    pub weight: Vec<f64>,
    /// Viewpoint entropy `H(O|v)` (Part V eq. (2)).
    pub entropy: Vec<f64>,
    /// Viewpoint mutual information `I(v;O)` (eq. (7)).
    pub mutual_information: Vec<f64>,
    /// Viewpoint Kullback–Leibler distance to the actual areas (eq. (3));
    /// NaN when the background is an output (it has no area).
    pub kullback_leibler: Vec<f64>,
    /// Plemenos–Benayada heuristic (eq. (1)): the fraction of polygons
    /// visible plus the object's projected solid angle over `4π`.
    pub heuristic: Vec<f64>,
    /// `I(V;O)` (eq. (6)).
    pub total_mutual_information: f64,
    /// `H(O|V)` (eq. (5)).
    pub conditional_entropy: f64,
    /// `H(O)`.
    pub object_entropy: f64,
    /// Index of the viewpoint with minimum VMI: the best view.
    pub best: usize,
    /// Index of the viewpoint with maximum VMI.
    pub worst: usize,
}

impl ViewpointAnalysis {
    /// Normalises the sampled channel; `background` adds the background as
    /// an extra polygon (Part V §3.1).
    ///
    /// # Errors
    /// [`Error::ZeroMass`] when no viewpoint sees the object.
    pub fn new(ch: &ViewpointChannel, weights: ViewpointWeights, background: bool) -> Result<Self, Error> {
        // Each row's sum, then its entries divided by its total, row by row
        // on every thread (the same operations per row as one after another).
        let sums: Vec<f64> = (0..ch.viewpoints()).into_par_iter().map(|v| ch.row(v).1.iter().sum()).collect();
        let (mut seen, mut seen_angle, mut starts) = (Vec::new(), Vec::new(), vec![0]);
        for (v, &object) in sums.iter().enumerate() {
            if object <= 0.0 {
                continue;
            }
            let bg = if background && ch.background[v] > 0.0 { 1 } else { 0 };
            starts.push(starts[starts.len() - 1] + ch.row(v).0.len() + bg);
            seen.push(v);
            seen_angle.push(object);
        }
        let entries = starts[starts.len() - 1];
        let (mut cols, mut values) = (vec![0u32; entries], vec![0.0f64; entries]);
        let mut parts = Vec::with_capacity(seen.len());
        let (mut c_rest, mut v_rest) = (&mut cols[..], &mut values[..]);
        for w in starts.windows(2) {
            let (c, cr) = std::mem::take(&mut c_rest).split_at_mut(w[1] - w[0]);
            let (x, vr) = std::mem::take(&mut v_rest).split_at_mut(w[1] - w[0]);
            (c_rest, v_rest) = (cr, vr);
            parts.push((c, x));
        }
        parts.into_par_iter().zip(seen.par_iter().zip(&seen_angle)).for_each(|((c, x), (&v, &object))| {
            let (p, a) = ch.row(v);
            let bg = if background { ch.background[v] } else { 0.0 };
            let total = object + bg;
            c[..p.len()].copy_from_slice(p);
            for (x, a) in x.iter_mut().zip(a) {
                *x = a / total;
            }
            if bg > 0.0 {
                c[p.len()] = ch.patches as u32;
                x[p.len()] = bg / total;
            }
        });
        Self::normalised(seen, seen_angle, starts, cols, values, weights, ch.viewpoints(), ch.patches, background)
    }

    /// [`ViewpointAnalysis::new`] without the background, consuming the
    /// channel: its rows are normalised in place and the rows of viewpoints
    /// that see nothing dropped, so the entries are held once (the volume
    /// channel's rows are large). The same numbers as `new`, bit for bit.
    ///
    /// # Errors
    /// [`Error::ZeroMass`] when no viewpoint sees the object.
    pub fn from_channel(ch: ViewpointChannel, weights: ViewpointWeights) -> Result<Self, Error> {
        let viewpoints = ch.viewpoints();
        let ViewpointChannel { starts: old, patch: mut cols, solid_angle: mut values, patches, .. } = ch;
        let sums: Vec<f64> = old.par_windows(2).map(|w| values[w[0]..w[1]].iter().sum()).collect();
        if sums.iter().all(|&s| s > 0.0) {
            // Every row kept: each divided in place, row by row on every thread.
            let mut rows = Vec::with_capacity(viewpoints);
            let mut rest = &mut values[..];
            for w in old.windows(2) {
                let (row, r) = std::mem::take(&mut rest).split_at_mut(w[1] - w[0]);
                rest = r;
                rows.push(row);
            }
            rows.into_par_iter().zip(&sums).for_each(|(row, &object)| row.iter_mut().for_each(|x| *x /= object));
            let seen = (0..viewpoints).collect();
            return Self::normalised(seen, sums, old, cols, values, weights, viewpoints, patches, false);
        }
        let (mut seen, mut seen_angle, mut starts) = (Vec::new(), Vec::new(), vec![0]);
        let mut at = 0;
        for v in 0..viewpoints {
            let (a, b) = (old[v], old[v + 1]);
            let object = sums[v];
            if object <= 0.0 {
                continue;
            }
            // Rows move down over dropped ones: `at <= a`.
            cols.copy_within(a..b, at);
            for k in a..b {
                values[at + k - a] = values[k] / object;
            }
            at += b - a;
            starts.push(at);
            seen.push(v);
            seen_angle.push(object);
        }
        cols.truncate(at);
        values.truncate(at);
        Self::normalised(seen, seen_angle, starts, cols, values, weights, viewpoints, patches, false)
    }

    #[allow(clippy::too_many_arguments)]
    fn normalised(
        seen: Vec<usize>,
        seen_angle: Vec<f64>,
        starts: Vec<usize>,
        cols: Vec<u32>,
        values: Vec<f64>,
        weights: ViewpointWeights,
        viewpoints: usize,
        patches: usize,
        background: bool,
    ) -> Result<Self, Error> {
        if seen.is_empty() {
            return Err(Error::ZeroMass);
        }
        let p_v = match weights {
            ViewpointWeights::ProjectedArea => {
                let t: f64 = seen_angle.iter().sum();
                seen_angle.iter().map(|s| s / t).collect()
            }
            ViewpointWeights::Uniform => vec![1.0 / seen.len() as f64; seen.len()],
        };
        let outputs = patches + usize::from(background);
        let rows = SparseRows::new(&p_v, starts, cols, values, outputs)?;
        let mut p_o = vec![0.0; outputs];
        let ch = rows.channel(&p_v)?;
        // Blocks of outputs side by side, each summed over the rows in row
        // order: the whole pass's bits.
        p_o.par_chunks_mut(OUTPUT_BLOCK)
            .enumerate()
            .try_for_each(|(k, out)| ch.output_cols_into(k * OUTPUT_BLOCK..k * OUTPUT_BLOCK + out.len(), out))?;
        Ok(Self { seen, p_v, p_o, seen_angle, background, viewpoints, patches, rows })
    }

    /// The core's view of the channel (its rows checked once, when the
    /// analysis was made; only `p(v)` is checked here).
    ///
    /// # Errors
    /// Never for an analysis built by [`ViewpointAnalysis::new`].
    pub fn channel(&self) -> Result<SparseChannel<'_, f64>, Error> {
        self.rows.channel(&self.p_v)
    }

    /// A per-row pass of the core over every row, on chunks of rows side
    /// by side: each chunk is a channel of its own (the same rows and
    /// output count, a uniform input, which the core's per-row passes do not
    /// read), so each row's value is the one the whole channel gives.
    fn by_rows(
        &self,
        pass: impl Fn(&SparseChannel<'_, f64>, &mut [f64]) -> Result<(), Error> + Sync,
    ) -> Result<Vec<f64>, Error> {
        let mut out = vec![0.0; self.rows()];
        let per = self.rows().div_ceil(4 * rayon::current_num_threads()).max(1);
        let all = self.channel()?;
        out.par_chunks_mut(per).enumerate().try_for_each(|(k, out)| {
            let r = k * per..k * per + out.len();
            let input = vec![1.0 / out.len() as f64; out.len()];
            pass(&all.rows_with_input(r, &input)?, out)
        })?;
        Ok(out)
    }

    /// `D_KL(p(O|v) ‖ target)` of every row (the VMI of Part V eq. (7)
    /// with `target = p(O)`): the core's `specific_information_into`, on
    /// chunks of rows side by side.
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] if `target` is not one per output.
    pub fn row_information(&self, target: &[f64], base: Base) -> Result<Vec<f64>, Error> {
        self.row_information_with(target, base, None)
    }

    /// [`ViewpointAnalysis::row_information`], on the entries' logarithms
    /// when given (from [`ViewpointAnalysis::entry_logs`]: the core's
    /// `specific_information_logs_into`, the same bits, no logarithm per entry).
    fn row_information_with(&self, target: &[f64], base: Base, logs: Option<&[f64]>) -> Result<Vec<f64>, Error> {
        match logs {
            None => self.by_rows(|ch, out| ch.specific_information_into(target, base, out)),
            Some(logs) => {
                let target_logs = logs_of(target);
                self.by_rows(|ch, out| ch.specific_information_logs_into(target, &target_logs, logs, base, out))
            }
        }
    }

    /// Outputs: patches, plus one for the background when counted.
    #[must_use]
    pub fn outputs(&self) -> usize {
        self.patches + usize::from(self.background)
    }

    /// Rows (viewpoints that see the object).
    #[must_use]
    pub fn rows(&self) -> usize {
        self.seen.len()
    }

    /// Row `x`: outputs seen and `p(o|v)`.
    #[must_use]
    pub fn row(&self, x: usize) -> (&[u32], &[f64]) {
        let r = self.rows.starts()[x]..self.rows.starts()[x + 1];
        (&self.rows.cols()[r.clone()], &self.rows.values()[r])
    }

    /// The part of row `x` whose outputs fall in `cols` (rows are increasing).
    pub(super) fn row_part(&self, x: usize, cols: &std::ops::Range<usize>) -> (&[u32], &[f64]) {
        let (c, p) = self.row(x);
        let a = c.partition_point(|&o| (o as usize) < cols.start);
        let b = a + c[a..].partition_point(|&o| (o as usize) < cols.end);
        (&c[a..b], &p[a..b])
    }

    /// The row of viewpoint `v`, if it sees the object.
    #[must_use]
    pub fn row_of(&self, v: usize) -> Option<usize> {
        self.seen.binary_search(&v).ok()
    }

    /// Spreads per-row values over all viewpoints, `missing` elsewhere.
    #[must_use]
    pub fn expand(&self, rows: &[f64], missing: f64) -> Vec<f64> {
        let mut out = vec![missing; self.viewpoints];
        for (x, &v) in self.seen.iter().enumerate() {
            out[v] = rows[x];
        }
        out
    }

    /// Every per-viewpoint measure; `areas` are the patch areas (for VKL).
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] if `areas` is not one per patch.
    pub fn measures(&self, areas: &[f64], base: Base) -> Result<ViewpointMeasures, Error> {
        self.measures_with(areas, base, None)
    }

    /// [`ViewpointAnalysis::measures`] on the entries' logarithms (from
    /// [`ViewpointAnalysis::entry_logs`]): no logarithm per entry in the
    /// core's passes (the whole-channel one runs on one thread), the same bits.
    ///
    /// # Errors
    /// Those of [`ViewpointAnalysis::measures`]; [`Error::LengthMismatch`]
    /// if `logs` is not one per entry.
    pub fn measures_logs(&self, areas: &[f64], base: Base, logs: &[f64]) -> Result<ViewpointMeasures, Error> {
        self.measures_with(areas, base, Some(logs))
    }

    fn measures_with(&self, areas: &[f64], base: Base, logs: Option<&[f64]>) -> Result<ViewpointMeasures, Error> {
        if areas.len() != self.patches {
            return Err(Error::LengthMismatch { expected: self.patches, found: areas.len() });
        }
        let ch = self.channel()?;
        let n = self.rows();
        // The core's whole-channel measures on one thread while the per-row
        // passes (VMI, VE, VKL) run on chunks of rows (each value as alone:
        // the same bits).
        let vkl = || {
            if self.background {
                return Ok(vec![f64::NAN; n]);
            }
            let total: f64 = areas.iter().sum();
            let rel: Vec<f64> = areas.iter().map(|a| a / total).collect();
            self.row_information_with(&rel, base, logs)
        };
        let per_row = || {
            let vmi = self.row_information_with(&self.p_o, base, logs)?;
            let ve = self.by_rows(|ch, out| ch.row_entropies_into(base, out))?;
            Ok::<_, Error>((vmi, ve, vkl()?))
        };
        let whole = || match logs {
            None => ch.measures(&self.p_o, base),
            Some(logs) => ch.measures_logs(&self.p_o, &logs_of(&self.p_o), logs, base),
        };
        let (cm, rows) = rayon::join(whole, per_row);
        let (cm, (vmi, ve, vkl)) = (cm?, rows?);
        let heuristic: Vec<f64> = (0..n)
            .map(|x| {
                let visible = self.row(x).0.iter().filter(|&&o| (o as usize) < self.patches).count();
                visible as f64 / self.patches as f64 + self.seen_angle[x] / (4.0 * std::f64::consts::PI)
            })
            .collect();
        let best = self.seen[(0..n).min_by(|&a, &b| vmi[a].total_cmp(&vmi[b])).unwrap_or(0)];
        let worst = self.seen[(0..n).max_by(|&a, &b| vmi[a].total_cmp(&vmi[b])).unwrap_or(0)];
        Ok(ViewpointMeasures {
            weight: self.expand(&self.p_v, 0.0),
            entropy: self.expand(&ve, 0.0),
            mutual_information: self.expand(&vmi, f64::INFINITY),
            kullback_leibler: self.expand(&vkl, f64::INFINITY),
            heuristic: self.expand(&heuristic, 0.0),
            total_mutual_information: cm.mutual_information,
            conditional_entropy: cm.h_y_given_x,
            object_entropy: cm.h_y,
            best,
            worst,
        })
    }

    /// Polygonal mutual information `I(o;V) = D_KL(p(V|o) ‖ p(V))` of every
    /// output (the reversed channel, Part V); 0 where `p(o) = 0`.
    ///
    /// # Errors
    /// None in practice (sizes are consistent by construction).
    pub fn polygonal_information(&self, base: Base) -> Result<Vec<f64>, Error> {
        let mut info = vec![0.0; self.outputs()];
        let ch = self.channel()?;
        // Blocks of outputs side by side (each output's terms over the rows
        // in row order: the whole pass's bits).
        info.par_chunks_mut(OUTPUT_BLOCK).enumerate().try_for_each(|(k, out)| {
            ch.output_specific_information_cols_into(
                &self.p_o,
                k * OUTPUT_BLOCK..k * OUTPUT_BLOCK + out.len(),
                base,
                out,
            )
        })?;
        Ok(info)
    }

    /// Dissimilarity of rows `a` and `b`: the Jensen–Shannon divergence of
    /// their `p(O|v)` with weights `p(v)/(p(a)+p(b))` (Part II eq. (17)).
    ///
    /// # Errors
    /// None in practice.
    pub fn dissimilarity(&self, a: usize, b: usize, base: Base) -> Result<f64, Error> {
        let t = self.p_v[a] + self.p_v[b];
        self.channel()?.jensen_shannon((self.p_v[a] / t, self.p_v[b] / t), a, b, base)
    }

    /// `ln` of every entry of the channel, in row order (8 bytes an entry):
    /// what [`ViewpointAnalysis::dissimilarity_logs`] and
    /// [`ViewpointAnalysis::instability_logs`] take, so that rows compared
    /// with many others take their logarithms once.
    #[must_use]
    pub fn entry_logs(&self) -> Vec<f64> {
        logs_of(self.rows.values())
    }

    /// [`ViewpointAnalysis::dissimilarity`] on precomputed logarithms
    /// ([`SparseChannel::jensen_shannon_logs`]: the same merge, the same bits).
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] if `logs` is not one per entry.
    pub fn dissimilarity_logs(&self, a: usize, b: usize, logs: &[f64], base: Base) -> Result<f64, Error> {
        let t = self.p_v[a] + self.p_v[b];
        self.channel()?.jensen_shannon_logs((self.p_v[a] / t, self.p_v[b] / t), a, b, logs, base)
    }

    /// Viewpoint instability: the mean dissimilarity of each viewpoint to
    /// its neighbours that see the object (low = stable); NaN for
    /// viewpoints that see nothing. `neighbours` is over all viewpoints.
    /// Every row meets about six neighbours, so its logarithms are taken
    /// once ([`ViewpointAnalysis::entry_logs`], 8 bytes per entry).
    ///
    /// # Errors
    /// None in practice.
    pub fn instability(&self, neighbours: &[Vec<usize>], base: Base) -> Result<Vec<f64>, Error> {
        self.instability_logs(neighbours, &self.entry_logs(), base)
    }

    /// [`ViewpointAnalysis::instability`] on logarithms the caller holds
    /// (from [`ViewpointAnalysis::entry_logs`]); the same bits.
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] if `logs` is not one per entry.
    pub fn instability_logs(&self, neighbours: &[Vec<usize>], logs: &[f64], base: Base) -> Result<Vec<f64>, Error> {
        if logs.len() != self.rows.values().len() {
            return Err(Error::LengthMismatch { expected: self.rows.values().len(), found: logs.len() });
        }
        let ch = self.channel()?;
        self.instability_by(neighbours, |w, x, y| ch.jensen_shannon_logs(w, x, y, logs, base))
    }

    /// [`ViewpointAnalysis::instability`] without holding a logarithm per
    /// entry: each pair takes its rows' logarithms itself
    /// ([`SparseChannel::jensen_shannon`], the same merge, so the same bits). For
    /// channels whose memory is counted without those 8 bytes per entry (the
    /// volume channel's estimate): more CPU, no extra memory.
    ///
    /// # Errors
    /// None in practice.
    pub fn instability_lean(&self, neighbours: &[Vec<usize>], base: Base) -> Result<Vec<f64>, Error> {
        let ch = self.channel()?;
        self.instability_by(neighbours, |w, x, y| ch.jensen_shannon(w, x, y, base))
    }

    /// The mean of `js((π_x, π_y), x, y)` over each row's neighbours that see
    /// the object, each row summing its neighbours in order, so the values
    /// do not depend on the thread count. A pair that are each other's
    /// neighbours is measured once: the merge is symmetric bit for bit
    /// (the mixture `π_x p_x + π_y p_y` and each entry's two terms are
    /// sums of two numbers, which commute in floating point), so reading
    /// `(y, x)` from `(x, y)` changes no value.
    fn instability_by(
        &self,
        neighbours: &[Vec<usize>],
        js: impl Fn((f64, f64), usize, usize) -> Result<f64, Error> + Sync,
    ) -> Result<Vec<f64>, Error> {
        let near: Vec<Vec<usize>> = (0..self.seen.len())
            .map(|x| neighbours[self.seen[x]].iter().filter_map(|&u| self.row_of(u)).collect())
            .collect();
        let mut pairs: Vec<(usize, usize)> =
            near.iter().enumerate().flat_map(|(x, n)| n.iter().map(move |&y| (x.min(y), x.max(y)))).collect();
        pairs.sort_unstable();
        pairs.dedup();
        let values: Vec<f64> = pairs
            .par_iter()
            .map(|&(x, y)| {
                let t = self.p_v[x] + self.p_v[y];
                js((self.p_v[x] / t, self.p_v[y] / t), x, y)
            })
            .collect::<Result<_, Error>>()?;
        let rows: Vec<f64> = near
            .iter()
            .enumerate()
            .map(|(x, near)| {
                let mut s = 0.0;
                for &y in near {
                    s += pairs.binary_search(&(x.min(y), x.max(y))).map_or(f64::NAN, |k| values[k]);
                }
                if near.is_empty() { 0.0 } else { s / near.len() as f64 }
            })
            .collect();
        Ok(self.expand(&rows, f64::NAN))
    }
}
