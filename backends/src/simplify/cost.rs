//! The cost of a collapse from the viewpoint channel `V → O` (Part V §3):
//! how much `I(V;O)` (eq. (6)) or the viewpoints' entropies `H(O|v)`
//! (eq. (2)) change when the triangles around the collapsed vertex change,
//! or how far each view's projected areas are from the actual areas (the
//! viewpoint Kullback-Leibler distance, Part V eq. (3)).
//!
//! The channel's weights are the projected solid angles `a_o(v)` of every
//! triangle from every viewpoint, `p(v)` proportional to the object's
//! projected area (the viewpoint module's default) and no background. They
//! are kept with the running sums the core's [`mutual_information_of_weight_sums`]
//! and [`entropy_of_weight_sums`] take, so a collapse is measured and applied by
//! updating only the entries of the triangles around it, for every viewpoint:
//! `O(triangles around u × viewpoints)` work instead of a new channel.
//!
//! A moved triangle's new `a_o(v)` is its exact solid angle (Van Oosterom
//! and Strackee, as the solid-angle channel) times the visible fraction of
//! the triangles it replaces from `v`: visibility is inherited locally and
//! refreshed from a traced channel every time the mesh halves (see
//! [`super::simplify`]).

use glam::DVec3;
use itgfx_core::{
    Base, entropy_of_weight_sums, mutual_information_of_weight_sums, specific_information_of_weight_sums,
    weight_log_term,
};

use super::collapse::{Change, Dynamic};
use super::mesh::triangle_area;
use crate::viewpoint::ViewpointChannel;
use crate::viewpoint::solid_angle::triangle_solid_angle;

/// What a collapse's cost measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    /// `Σ_v p(v) |ΔI(v;O)|`, the mean change of each viewpoint's mutual
    /// information (Part V eq. (7); Castelló, Sbert, Chover, Feixas 2008).
    Vmi,
    /// `|ΔI(V;O)|`, the change of the whole channel's mutual information
    /// (Part V eq. (6)): changes seen from different viewpoints may cancel.
    Ivo,
    /// `Σ_v p(v) |ΔH(O|v)|`, the mean change of viewpoint entropy
    /// (Castelló et al., WSCG 2007).
    Ve,
    /// `Σ_v p(v) |ΔKL_v|`, the mean change of each viewpoint's
    /// Kullback-Leibler distance from its projected areas to the actual
    /// areas `A_o / A_T` (Part V eq. (3)): the object's triangles only, the
    /// background has no area.
    Vkl,
}

/// `x ln x` through the core (weights here are finite and non-negative).
fn term(x: f64) -> f64 {
    weight_log_term(x).unwrap_or(0.0)
}

/// `w ln c`, the cross term of [`specific_information_of_weight_sums`] (0 when `w = 0`).
fn cross_term(w: f64, c: f64) -> f64 {
    if w > 0.0 && c > 0.0 { w * itgfx_core::ln(c) } else { 0.0 }
}

/// The channel's weights and running sums.
#[derive(Clone, Debug)]
pub struct ViewState {
    /// Viewpoint positions (the mesh's normalised frame).
    pub eyes: Vec<DVec3>,
    /// Whether the background is an extra polygon (Part V §3.1): its
    /// weight at `v` is the sampled cone's solid angle less the object's,
    /// so a shrinking silhouette is a change of the channel.
    pub background: bool,
    /// `a_o(v)` of triangle `o` from viewpoint `v` at `o · V + v`.
    pub a: Vec<f64>,
    /// `a ln a` of each weight, same layout (kept, not recomputed per
    /// proposal).
    pub a_xlnx: Vec<f64>,
    /// Whole solid angle `Ω_o(v)` (visible or not), same layout; NaN where
    /// not yet needed (the triangle is hidden from `v`).
    pub omega: Vec<f64>,
    /// `S_v = Σ_o a_o(v)`, the object's projected solid angle.
    pub object: Vec<f64>,
    /// Background weight per viewpoint (0 without background).
    pub bg: Vec<f64>,
    /// `Σ_o a_o(v) ln a_o(v)` (+ the background's term) per viewpoint.
    pub row_xlnx: Vec<f64>,
    /// `A_o = Σ_v a_o(v)` per triangle.
    pub col_sum: Vec<f64>,
    /// Sum of every weight.
    pub total: f64,
    /// `Σ w ln w` over every weight.
    pub joint_xlnx: f64,
    /// `Σ_v r_v ln r_v` of the row sums `r_v = S_v (+ background)`.
    pub rows_xlnx: f64,
    /// `Σ_o A_o ln A_o` over the triangles (the background column apart).
    pub cols_xlnx: f64,
    /// The background column's sum.
    pub bg_total: f64,
    /// `K_v = Σ_o a_o(v) ln A_o` (+ the background's) per viewpoint.
    pub cross: Vec<f64>,
    /// `I(v;O)` in bits per viewpoint from the sums above (kept with them).
    pub vmi: Vec<f64>,
    /// Area `A_o` of each triangle (0 once removed).
    pub areas: Vec<f64>,
    /// `A_T = Σ_o A_o`.
    pub area_total: f64,
    /// `Σ_o a_o(v) ln A_o` per viewpoint.
    pub area_cross: Vec<f64>,
    /// `KL_v` in bits per viewpoint (Part V eq. (3)) from the sums above.
    pub vkl: Vec<f64>,
}

/// The new weights of the moved triangles of one collapse.
#[derive(Clone, Debug, Default)]
pub struct Proposal {
    /// `a_o(v)` of each moved triangle (`moved[i]` at `i · V + v`).
    pub a: Vec<f64>,
    /// `a ln a` of those, same layout.
    pub a_xlnx: Vec<f64>,
    /// `Ω_o(v)`, same layout (NaN where hidden).
    pub omega: Vec<f64>,
    /// Area of each moved triangle.
    pub areas: Vec<f64>,
    /// The cost.
    pub cost: f64,
}

/// `ln` of the columns a collapse touches ([`ViewState::column_logs`]).
struct ColumnLogs {
    /// Of the moved triangles' new columns.
    new: Vec<f64>,
    /// Of the moved, then the removed triangles' current columns.
    old: Vec<f64>,
}

/// How one viewpoint's row changes when its object weight changes by `ds`
/// and its `Σ a ln a` by `dterm`.
#[derive(Clone, Copy, Debug, Default)]
struct RowStep {
    object: f64,
    bg: f64,
    d_total: f64,
    d_joint: f64,
    d_rows: f64,
    /// Row sum and `Σ w ln w` before and after.
    before: (f64, f64),
    after: (f64, f64),
    /// The row's sums did not change (its entropy did not either).
    unchanged: bool,
}

impl ViewState {
    /// Bytes needed for `faces` triangles and `views` viewpoints.
    #[must_use]
    pub fn bytes(faces: usize, views: usize) -> u64 {
        3 * 8 * faces as u64 * views as u64 + 8 * (2 * faces + 5 * views) as u64
    }

    /// Weights from a traced channel of the living triangles: channel patch
    /// `i` is triangle `live[i]` of `d`.
    #[must_use]
    pub fn from_channel(ch: &ViewpointChannel, d: &Dynamic, live: &[u32], background: bool) -> Self {
        let nv = ch.viewpoints();
        let nf = d.faces.len();
        let eyes = ch.positions.clone();
        let mut a = vec![0.0; nf * nv];
        let mut omega = vec![f64::NAN; nf * nv];
        for v in 0..nv {
            let (p, w) = ch.row(v);
            for (&i, &x) in p.iter().zip(w) {
                a[live[i as usize] as usize * nv + v] = x;
            }
        }
        for &f in live {
            let t = d.corners(f);
            for (v, e) in eyes.iter().enumerate() {
                if a[f as usize * nv + v] > 0.0 {
                    omega[f as usize * nv + v] = triangle_solid_angle(t[0] - *e, t[1] - *e, t[2] - *e);
                }
            }
        }
        let bg = if background { ch.background.clone() } else { vec![0.0; nv] };
        let mut s = Self {
            eyes,
            background,
            a,
            a_xlnx: vec![0.0; nf * nv],
            omega,
            object: vec![0.0; nv],
            bg,
            row_xlnx: vec![0.0; nv],
            col_sum: vec![0.0; nf],
            total: 0.0,
            joint_xlnx: 0.0,
            rows_xlnx: 0.0,
            cols_xlnx: 0.0,
            bg_total: 0.0,
            cross: vec![0.0; nv],
            vmi: vec![0.0; nv],
            areas: vec![0.0; nf],
            area_total: 0.0,
            area_cross: vec![0.0; nv],
            vkl: vec![0.0; nv],
        };
        for &f in live {
            s.areas[f as usize] = triangle_area(&d.corners(f));
        }
        s.resum();
        s
    }

    /// Viewpoints.
    #[must_use]
    pub fn views(&self) -> usize {
        self.eyes.len()
    }

    /// Recomputes every running sum from the weights.
    pub fn resum(&mut self) {
        let nv = self.views();
        self.a_xlnx = self.a.iter().map(|&x| term(x)).collect();
        self.object.iter_mut().for_each(|x| *x = 0.0);
        self.row_xlnx.iter_mut().for_each(|x| *x = 0.0);
        for (f, col) in self.col_sum.iter_mut().enumerate() {
            let row = &self.a[f * nv..(f + 1) * nv];
            *col = row.iter().sum();
            for (v, &x) in row.iter().enumerate() {
                self.object[v] += x;
                self.row_xlnx[v] += term(x);
            }
        }
        for v in 0..nv {
            self.row_xlnx[v] += term(self.bg[v]);
        }
        self.joint_xlnx = self.row_xlnx.iter().sum();
        self.total = self.object.iter().sum::<f64>() + self.bg.iter().sum::<f64>();
        self.rows_xlnx = (0..nv).map(|v| term(self.object[v] + self.bg[v])).sum();
        self.cols_xlnx = self.col_sum.iter().map(|&x| term(x)).sum();
        self.bg_total = self.bg.iter().sum();
        self.cross = (0..nv).map(|v| cross_term(self.bg[v], self.bg_total)).collect();
        for (f, &col) in self.col_sum.iter().enumerate() {
            for (v, &x) in self.a[f * nv..(f + 1) * nv].iter().enumerate() {
                self.cross[v] += cross_term(x, col);
            }
        }
        self.vmi = self.viewpoint_information();
        self.area_total = self.areas.iter().sum();
        self.area_cross = vec![0.0; nv];
        for (f, &area) in self.areas.iter().enumerate() {
            for (v, &x) in self.a[f * nv..(f + 1) * nv].iter().enumerate() {
                self.area_cross[v] += cross_term(x, area);
            }
        }
        self.vkl = self.viewpoint_kl();
    }

    /// `KL_v` in bits of every viewpoint (Part V eq. (3)): the specific
    /// information of the object's row with the actual areas `A_o / A_T` in
    /// place of `p(o)`; 0 where nothing is seen.
    #[must_use]
    pub fn viewpoint_kl(&self) -> Vec<f64> {
        (0..self.views())
            .map(|v| {
                let x = self.row_xlnx[v] - term(self.bg[v]);
                specific(self.area_total, self.object[v], x, self.area_cross[v])
            })
            .collect()
    }

    /// `I(v;O)` in bits of every viewpoint (Part V eq. (7)); 0 where nothing is seen.
    #[must_use]
    pub fn viewpoint_information(&self) -> Vec<f64> {
        (0..self.views())
            .map(|v| specific(self.total, self.object[v] + self.bg[v], self.row_xlnx[v], self.cross[v]))
            .collect()
    }

    /// `ln` of each column a collapse touches, once per collapse rather
    /// than once per viewpoint: of `new` (the moved triangles' new column
    /// sums or areas), and of `old` (this state's, per triangle) for the
    /// moved then the removed triangles; 0 where the column is 0.
    fn column_logs(change: &Change, new: &[f64], old: &[f64]) -> ColumnLogs {
        let ln = |c: f64| if c > 0.0 { itgfx_core::ln(c) } else { 0.0 };
        ColumnLogs {
            new: new.iter().map(|&c| ln(c)).collect(),
            old: change.moved.iter().chain(&change.removed).map(|&f| ln(old[f as usize])).collect(),
        }
    }

    /// Change of `Σ_o a_o(v) ln c_o` at viewpoint `k` when the moved
    /// triangles get the weights `new_a` and the removed ones vanish, with
    /// the columns' logarithms `logs` (the cross term of
    /// [`specific_information_of_weight_sums`]).
    fn weighted_log_change(&self, k: usize, change: &Change, new_a: &[f64], logs: &ColumnLogs) -> f64 {
        let nv = self.views();
        let mut d = 0.0;
        for (i, &f) in change.moved.iter().enumerate() {
            d += new_a[i * nv + k] * logs.new[i] - self.a[f as usize * nv + k] * logs.old[i];
        }
        let m = change.moved.len();
        for (j, &f) in change.removed.iter().enumerate() {
            d -= self.a[f as usize * nv + k] * logs.old[m + j];
        }
        d
    }

    /// The background's part of the change of `K_v` when its column goes
    /// from `bg_total` to `bg_total1`: at viewpoint `k`, `bg1 ln bg_total1 −
    /// bg[k] ln bg_total` (the logarithms once per collapse, not per view).
    fn background_cross(&self, bg_total1: f64) -> impl Fn(usize, f64) -> f64 + '_ {
        let ln = |c: f64| if c > 0.0 { itgfx_core::ln(c) } else { 0.0 };
        let (l1, l0) = (ln(bg_total1), ln(self.bg_total));
        move |k, bg1| {
            let b0 = self.bg[k];
            (if bg1 > 0.0 { bg1 * l1 } else { 0.0 }) - (if b0 > 0.0 { b0 * l0 } else { 0.0 })
        }
    }

    /// Change of `A_T` when the moved triangles get the areas `new_areas`
    /// and the removed ones vanish.
    fn area_change(&self, change: &Change, new_areas: &[f64]) -> f64 {
        let moved: f64 = change.moved.iter().zip(new_areas).map(|(&f, &a)| a - self.areas[f as usize]).sum();
        moved - change.removed.iter().map(|&f| self.areas[f as usize]).sum::<f64>()
    }

    fn mi(total: f64, joint: f64, rows: f64, cols: f64, bg_total: f64) -> f64 {
        mutual_information_of_weight_sums(total.max(0.0), joint, rows, cols + term(bg_total.max(0.0)), Base::Bits)
            .unwrap_or(0.0)
    }

    /// `I(V;O)` in bits from the running sums (Part V eq. (6)).
    #[must_use]
    pub fn mutual_information(&self) -> f64 {
        Self::mi(self.total, self.joint_xlnx, self.rows_xlnx, self.cols_xlnx, self.bg_total)
    }

    /// `H(O|v)` in bits of every viewpoint (Part V eq. (2)); 0 where nothing is seen.
    #[must_use]
    pub fn viewpoint_entropies(&self) -> Vec<f64> {
        (0..self.views()).map(|v| entropy(self.object[v] + self.bg[v], self.row_xlnx[v])).collect()
    }

    fn row_step(&self, k: usize, ds: f64, dterm: f64) -> RowStep {
        let (s0, b0) = (self.object[k], self.bg[k]);
        if ds == 0.0 && dterm == 0.0 {
            let r = (s0 + b0, self.row_xlnx[k]);
            return RowStep { object: s0, bg: b0, before: r, after: r, unchanged: true, ..RowStep::default() };
        }
        let s1 = (s0 + ds).max(0.0);
        let b1 = if self.background { (b0 - ds).max(0.0) } else { 0.0 };
        let d_joint = dterm + term(b1) - term(b0);
        let (r0, r1) = (s0 + b0, s1 + b1);
        RowStep {
            object: s1,
            bg: b1,
            d_total: r1 - r0,
            d_joint,
            d_rows: term(r1) - term(r0),
            before: (r0, self.row_xlnx[k]),
            after: (r1, self.row_xlnx[k] + d_joint),
            unchanged: false,
        }
    }

    /// The new weights and the cost of collapse `u → v` (checked by
    /// [`Dynamic::check`]). The triangles that move (around `u`, and around
    /// `v` when `v` moves) keep, from each viewpoint, the joint visible
    /// fraction `Σ a / Σ Ω` of those they replace.
    #[must_use]
    pub fn propose(&self, d: &Dynamic, u: u32, v: u32, change: &Change, metric: Metric) -> Proposal {
        let nv = self.views();
        let m = change.moved.len();
        let corners: Vec<[DVec3; 3]> =
            change.moved.iter().map(|&f| d.moved_corners(f, u, v, change.position)).collect();
        let areas = corners.iter().map(triangle_area).collect();
        let mut p =
            Proposal { a: vec![0.0; m * nv], a_xlnx: vec![0.0; m * nv], omega: vec![0.0; m * nv], areas, cost: 0.0 };
        let old = || change.moved.iter().chain(&change.removed).map(|&f| f as usize);
        let (mut d_total, mut d_joint, mut d_rows, mut d_bg) = (0.0, 0.0, 0.0, 0.0);
        let mut ve = 0.0;
        let keep = matches!(metric, Metric::Vmi | Metric::Vkl);
        let mut steps = Vec::with_capacity(if keep { nv } else { 0 });
        let mut hidden = Vec::with_capacity(if keep { nv } else { 0 });
        let mut object_terms = Vec::with_capacity(if keep { nv } else { 0 });
        for (k, eye) in self.eyes.iter().enumerate() {
            let (mut sa, mut old_terms) = (0.0, 0.0);
            for f in old() {
                sa += self.a[f * nv + k];
                old_terms += self.a_xlnx[f * nv + k];
            }
            let (mut na, mut new_terms) = (0.0, 0.0);
            if sa > 0.0 {
                // Seen from here: the whole solid angles (cached, or from the
                // current corners where not yet known) give the visible fraction.
                let so: f64 = old()
                    .map(|f| {
                        let om = self.omega[f * nv + k];
                        if om.is_nan() {
                            let t = d.corners(f as u32);
                            triangle_solid_angle(t[0] - *eye, t[1] - *eye, t[2] - *eye)
                        } else {
                            om
                        }
                    })
                    .sum();
                let fraction = if so > 0.0 { (sa / so).min(1.0) } else { 0.0 };
                for (i, t) in corners.iter().enumerate() {
                    let om = triangle_solid_angle(t[0] - *eye, t[1] - *eye, t[2] - *eye);
                    let x = om * fraction;
                    let xlnx = term(x);
                    p.omega[i * nv + k] = om;
                    p.a[i * nv + k] = x;
                    p.a_xlnx[i * nv + k] = xlnx;
                    na += x;
                    new_terms += xlnx;
                }
            } else {
                // Hidden from here: it stays hidden; its solid angle is worked
                // out only if a neighbour's collapse ever needs it.
                for i in 0..m {
                    p.omega[i * nv + k] = f64::NAN;
                }
            }
            let step = self.row_step(k, na - sa, new_terms - old_terms);
            d_total += step.d_total;
            d_joint += step.d_joint;
            d_rows += step.d_rows;
            d_bg += step.bg - self.bg[k];
            if keep {
                steps.push(step);
                hidden.push(sa == 0.0);
                object_terms.push(new_terms - old_terms);
            }
            if metric == Metric::Ve && self.total > 0.0 && !step.unchanged {
                let h0 = entropy(step.before.0, step.before.1);
                let h1 = entropy(step.after.0, step.after.1);
                ve += step.before.0 / self.total * (h1 - h0).abs();
            }
        }
        let new_cols: Vec<f64> = (0..m).map(|i| p.a[i * nv..(i + 1) * nv].iter().sum()).collect();
        p.cost = match metric {
            Metric::Ve => ve,
            Metric::Vmi => {
                let col_logs = Self::column_logs(change, &new_cols, &self.col_sum);
                let total1 = self.total + d_total;
                let bg_cross = self.background_cross(self.bg_total + d_bg);
                let mut c = 0.0;
                for (k, step) in steps.iter().enumerate() {
                    if step.before.0 <= 0.0 || self.total <= 0.0 {
                        continue;
                    }
                    // Triangles this viewpoint does not see add nothing to K_v:
                    // only the background's term moves.
                    let dk = if hidden[k] {
                        bg_cross(k, step.bg)
                    } else {
                        bg_cross(k, step.bg) + self.weighted_log_change(k, change, &p.a, &col_logs)
                    };
                    let k1 = self.cross[k] + dk;
                    let i0 = self.vmi[k];
                    let i1 = specific(total1, step.after.0, step.after.1, k1);
                    c += step.before.0 / self.total * (i1 - i0).abs();
                }
                c
            }
            Metric::Vkl => {
                let area_total1 = self.area_total + self.area_change(change, &p.areas);
                let area_logs = Self::column_logs(change, &p.areas, &self.areas);
                let mut c = 0.0;
                for (k, step) in steps.iter().enumerate() {
                    if step.before.0 <= 0.0 || self.total <= 0.0 {
                        continue;
                    }
                    // A hidden viewpoint's row is unchanged; only A_T moves.
                    let dk = if hidden[k] { 0.0 } else { self.weighted_log_change(k, change, &p.a, &area_logs) };
                    let x1 = self.row_xlnx[k] - term(self.bg[k]) + object_terms[k];
                    let kl1 = specific(area_total1, step.object, x1, self.area_cross[k] + dk);
                    c += step.before.0 / self.total * (kl1 - self.vkl[k]).abs();
                }
                c
            }
            Metric::Ivo => {
                let mut d_cols = 0.0;
                for (i, &f) in change.moved.iter().enumerate() {
                    d_cols += term(new_cols[i]) - term(self.col_sum[f as usize]);
                }
                for &f in &change.removed {
                    d_cols -= term(self.col_sum[f as usize]);
                }
                let after = Self::mi(
                    self.total + d_total,
                    self.joint_xlnx + d_joint,
                    self.rows_xlnx + d_rows,
                    self.cols_xlnx + d_cols,
                    self.bg_total + d_bg,
                );
                (after - self.mutual_information()).abs()
            }
        };
        p
    }

    /// Applies a proposal: the moved triangles' weights replaced, the
    /// removed triangles' zeroed, the running sums updated by their terms.
    pub fn apply(&mut self, change: &Change, p: &Proposal) {
        let nv = self.views();
        let m = change.moved.len();
        let new_cols: Vec<f64> = (0..m).map(|i| p.a[i * nv..(i + 1) * nv].iter().sum()).collect();
        let steps: Vec<RowStep> = (0..nv)
            .map(|k| {
                let (mut ds, mut dterm) = (0.0, 0.0);
                for (i, &f) in change.moved.iter().enumerate() {
                    let j = f as usize * nv + k;
                    ds += p.a[i * nv + k] - self.a[j];
                    dterm += p.a_xlnx[i * nv + k] - self.a_xlnx[j];
                }
                for &f in &change.removed {
                    let j = f as usize * nv + k;
                    ds -= self.a[j];
                    dterm -= self.a_xlnx[j];
                }
                self.row_step(k, ds, dterm)
            })
            .collect();
        let bg_total1 = self.bg_total + steps.iter().enumerate().map(|(k, s)| s.bg - self.bg[k]).sum::<f64>();
        let col_logs = Self::column_logs(change, &new_cols, &self.col_sum);
        let cross: Vec<f64> = {
            let bg_cross = self.background_cross(bg_total1);
            (0..nv).map(|k| bg_cross(k, steps[k].bg) + self.weighted_log_change(k, change, &p.a, &col_logs)).collect()
        };
        let area_total1 = self.area_total + self.area_change(change, &p.areas);
        let area_logs = Self::column_logs(change, &p.areas, &self.areas);
        for k in 0..nv {
            self.area_cross[k] += self.weighted_log_change(k, change, &p.a, &area_logs);
        }
        self.area_total = area_total1;
        for (k, step) in steps.iter().enumerate() {
            self.cross[k] += cross[k];
            self.total += step.d_total;
            self.joint_xlnx += step.d_joint;
            self.rows_xlnx += step.d_rows;
            self.row_xlnx[k] = step.after.1;
            self.object[k] = step.object;
            self.bg[k] = step.bg;
        }
        self.bg_total = bg_total1;
        for (i, &f) in change.moved.iter().enumerate() {
            let f = f as usize;
            self.a[f * nv..(f + 1) * nv].copy_from_slice(&p.a[i * nv..(i + 1) * nv]);
            self.a_xlnx[f * nv..(f + 1) * nv].copy_from_slice(&p.a_xlnx[i * nv..(i + 1) * nv]);
            self.omega[f * nv..(f + 1) * nv].copy_from_slice(&p.omega[i * nv..(i + 1) * nv]);
            self.cols_xlnx += term(new_cols[i]) - term(self.col_sum[f]);
            self.col_sum[f] = new_cols[i];
            self.areas[f] = p.areas[i];
        }
        for &f in &change.removed {
            let f = f as usize;
            self.a[f * nv..(f + 1) * nv].iter_mut().for_each(|x| *x = 0.0);
            self.a_xlnx[f * nv..(f + 1) * nv].iter_mut().for_each(|x| *x = 0.0);
            self.omega[f * nv..(f + 1) * nv].iter_mut().for_each(|x| *x = 0.0);
            self.cols_xlnx -= term(self.col_sum[f]);
            self.col_sum[f] = 0.0;
            self.areas[f] = 0.0;
        }
        self.vmi = self.viewpoint_information();
        self.vkl = self.viewpoint_kl();
    }
}

/// `I(x;Y)` in bits of one row from its sums (core); 0 for an empty row.
fn specific(total: f64, row: f64, xlnx: f64, cross: f64) -> f64 {
    specific_information_of_weight_sums(total, row, xlnx, cross, Base::Bits).unwrap_or(0.0)
}

/// `H` in bits of weights with sum `sum` and `Σ w ln w = xlnx` (core); 0 for none.
fn entropy(sum: f64, xlnx: f64) -> f64 {
    entropy_of_weight_sums(sum, xlnx, Base::Bits).unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simplify::tests::test_settings;
    use crate::simplify::{IndexedMesh, trace};

    fn bumpy() -> IndexedMesh {
        crate::simplify::tests::bumpy(2)
    }

    #[test]
    fn running_sums_match_a_recount_after_collapses() {
        for (metric, background) in
            [(Metric::Vmi, true), (Metric::Ve, false), (Metric::Ivo, true), (Metric::Vkl, true), (Metric::Vkl, false)]
        {
            let s = test_settings(metric, background);
            let mut d = Dynamic::new(&bumpy());
            let mut state = trace(&d, &s).unwrap();
            for _ in 0..60 {
                // The cheapest valid half-edge, by brute force.
                let mut best: Option<(f64, u32, u32)> = None;
                for u in 0..d.positions.len() as u32 {
                    for v in d.neighbours(u) {
                        if let Some(c) = d.check(u, v, d.positions[v as usize]) {
                            let cost = state.propose(&d, u, v, &c, metric).cost;
                            assert!(cost.is_finite() && cost >= 0.0);
                            if best.is_none_or(|b| cost < b.0) {
                                best = Some((cost, u, v));
                            }
                        }
                    }
                }
                let (_, u, v) = best.unwrap();
                let c = d.check(u, v, d.positions[v as usize]).unwrap();
                let p = state.propose(&d, u, v, &c, metric);
                state.apply(&c, &p);
                d.apply(u, v, &c);
            }
            assert_eq!(d.live, 320 - 120);
            let mut fresh = state.clone();
            fresh.resum();
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * (1.0 + b.abs());
            assert!(close(state.mutual_information(), fresh.mutual_information()), "{metric:?}");
            for (a, b) in state.viewpoint_information().iter().zip(fresh.viewpoint_information()) {
                assert!(close(*a, b), "{metric:?} VMI {a} vs {b}");
            }
            for (a, b) in state.viewpoint_entropies().iter().zip(fresh.viewpoint_entropies()) {
                assert!(close(*a, b), "{metric:?} VE {a} vs {b}");
            }
            for (a, b) in state.vkl.iter().zip(fresh.viewpoint_kl()) {
                assert!(close(*a, b), "{metric:?} VKL {a} vs {b}");
            }
            assert!(close(state.area_total, fresh.area_total));
            // The removed triangles carry nothing; the channel still sees the object.
            assert!(state.total > 0.0 && state.mutual_information() > 0.0);
        }
    }

    /// `KL_v` from the running sums equals Part V eq. (3) computed directly
    /// by the core's `kl_divergence` from the weights and the triangle areas
    /// (object only: the background has no area), before and after collapses.
    #[test]
    fn viewpoint_kl_is_eq3_by_the_core() {
        use itgfx_core::kl_divergence;
        for background in [false, true] {
            let s = test_settings(Metric::Vkl, background);
            let mut d = Dynamic::new(&bumpy());
            let mut state = trace(&d, &s).unwrap();
            let direct = |state: &ViewState, d: &Dynamic| -> Vec<f64> {
                let nv = state.views();
                let live: Vec<usize> = (0..d.faces.len()).filter(|&f| state.areas[f] > 0.0).collect();
                let q: Vec<f64> = live.iter().map(|&f| triangle_area(&d.corners(f as u32))).collect();
                (0..nv)
                    .map(|v| {
                        let p: Vec<f64> = live.iter().map(|&f| state.a[f * nv + v]).collect();
                        let sp: f64 = p.iter().sum();
                        let sq: f64 = q.iter().sum();
                        let p: Vec<f64> = p.iter().map(|x| x / sp).collect();
                        let q: Vec<f64> = q.iter().map(|x| x / sq).collect();
                        kl_divergence(&p, &q, Base::Bits).unwrap()
                    })
                    .collect()
            };
            for round in 0..3 {
                let want = direct(&state, &d);
                assert!(want.iter().any(|&x| x > 0.01), "the views are not all alike");
                for (v, (a, b)) in state.vkl.iter().zip(&want).enumerate() {
                    assert!((a - b).abs() < 1e-9 * (1.0 + b), "round {round} view {v}: {a} vs {b}");
                }
                // 20 collapses, the first valid half-edge each time.
                for _ in 0..20 {
                    let (u, v, c) = (0..d.positions.len() as u32)
                        .flat_map(|u| d.neighbours(u).into_iter().map(move |v| (u, v)))
                        .find_map(|(u, v)| d.check(u, v, d.positions[v as usize]).map(|c| (u, v, c)))
                        .unwrap();
                    let p = state.propose(&d, u, v, &c, Metric::Vkl);
                    assert!(p.cost.is_finite() && p.cost >= 0.0);
                    state.apply(&c, &p);
                    d.apply(u, v, &c);
                }
            }
        }
    }
}
