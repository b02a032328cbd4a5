//! The cost of a collapse from the viewpoint channel `V → O` (Part V §3):
//! how much `I(V;O)` (eq. (6)) or the viewpoints' entropies `H(O|v)`
//! (eq. (2)) change when the triangles around the collapsed vertex change.
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
use itgfx_core::{Base, entropy_of_weight_sums, mutual_information_of_weight_sums, weight_log_term};

use super::collapse::{Change, Dynamic};
use crate::viewpoint::ViewpointChannel;
use crate::viewpoint::solid_angle::triangle_solid_angle;

/// What a collapse's cost measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    /// `|ΔI(V;O)|`, the change of the mesh's viewpoint mutual information
    /// (Castelló, Sbert, Chover, Feixas 2008).
    Vmi,
    /// `Σ_v p(v) |ΔH(O|v)|`, the mean change of viewpoint entropy
    /// (Castelló et al., WSCG 2007).
    Ve,
}

/// `x ln x` through the core (weights here are finite and non-negative).
fn term(x: f64) -> f64 {
    weight_log_term(x).unwrap_or(0.0)
}

/// The channel's weights and running sums.
#[derive(Clone, Debug)]
pub struct ViewState {
    /// Viewpoint positions (the mesh's normalised frame).
    pub eyes: Vec<DVec3>,
    /// `a_o(v)` of triangle `o` from viewpoint `v` at `o · V + v`.
    pub a: Vec<f64>,
    /// Whole solid angle `Ω_o(v)` (visible or not), same layout.
    pub omega: Vec<f64>,
    /// `S_v = Σ_o a_o(v)`.
    pub row_sum: Vec<f64>,
    /// `Σ_o a_o(v) ln a_o(v)` per viewpoint.
    pub row_xlnx: Vec<f64>,
    /// `A_o = Σ_v a_o(v)` per triangle.
    pub col_sum: Vec<f64>,
    /// `S = Σ_v S_v`.
    pub total: f64,
    /// `Σ_{v,o} a ln a`.
    pub joint_xlnx: f64,
    /// `Σ_v S_v ln S_v`.
    pub rows_xlnx: f64,
    /// `Σ_o A_o ln A_o`.
    pub cols_xlnx: f64,
}

/// The new weights of the moved triangles of one collapse.
#[derive(Clone, Debug, Default)]
pub struct Proposal {
    /// `a_o(v)` of each moved triangle (`moved[i]` at `i · V + v`).
    pub a: Vec<f64>,
    /// `Ω_o(v)`, same layout.
    pub omega: Vec<f64>,
    /// The cost.
    pub cost: f64,
}

impl ViewState {
    /// Bytes needed for `faces` triangles and `views` viewpoints.
    #[must_use]
    pub fn bytes(faces: usize, views: usize) -> u64 {
        2 * 8 * faces as u64 * views as u64 + 8 * (faces + 2 * views) as u64
    }

    /// Weights from a traced channel of the living triangles: channel patch
    /// `i` is triangle `live[i]` of `d`.
    #[must_use]
    pub fn from_channel(ch: &ViewpointChannel, d: &Dynamic, live: &[u32]) -> Self {
        let nv = ch.viewpoints();
        let nf = d.faces.len();
        let eyes = ch.positions.clone();
        let mut a = vec![0.0; nf * nv];
        let mut omega = vec![0.0; nf * nv];
        for v in 0..nv {
            let (p, w) = ch.row(v);
            for (&i, &x) in p.iter().zip(w) {
                a[live[i as usize] as usize * nv + v] = x;
            }
        }
        for &f in live {
            let t = d.corners(f);
            for (v, e) in eyes.iter().enumerate() {
                omega[f as usize * nv + v] = triangle_solid_angle(t[0] - *e, t[1] - *e, t[2] - *e);
            }
        }
        let mut s = Self {
            eyes,
            a,
            omega,
            row_sum: vec![0.0; nv],
            row_xlnx: vec![0.0; nv],
            col_sum: vec![0.0; nf],
            total: 0.0,
            joint_xlnx: 0.0,
            rows_xlnx: 0.0,
            cols_xlnx: 0.0,
        };
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
        self.row_sum.iter_mut().for_each(|x| *x = 0.0);
        self.row_xlnx.iter_mut().for_each(|x| *x = 0.0);
        self.joint_xlnx = 0.0;
        for (f, col) in self.col_sum.iter_mut().enumerate() {
            let row = &self.a[f * nv..(f + 1) * nv];
            *col = row.iter().sum();
            for (v, &x) in row.iter().enumerate() {
                self.row_sum[v] += x;
                let t = term(x);
                self.row_xlnx[v] += t;
                self.joint_xlnx += t;
            }
        }
        self.total = self.row_sum.iter().sum();
        self.rows_xlnx = self.row_sum.iter().map(|&x| term(x)).sum();
        self.cols_xlnx = self.col_sum.iter().map(|&x| term(x)).sum();
    }

    /// `I(V;O)` in bits from the running sums (Part V eq. (6)).
    #[must_use]
    pub fn mutual_information(&self) -> f64 {
        mutual_information_of_weight_sums(self.total, self.joint_xlnx, self.rows_xlnx, self.cols_xlnx, Base::Bits)
            .unwrap_or(0.0)
    }

    /// `H(O|v)` in bits of every viewpoint (Part V eq. (2)); 0 where nothing is seen.
    #[must_use]
    pub fn viewpoint_entropies(&self) -> Vec<f64> {
        (0..self.views()).map(|v| self.entropy_at(v, self.row_sum[v], self.row_xlnx[v])).collect()
    }

    fn entropy_at(&self, _v: usize, sum: f64, xlnx: f64) -> f64 {
        entropy_of_weight_sums(sum, xlnx, Base::Bits).unwrap_or(0.0)
    }

    /// The new weights and the cost of collapse `u → v` (checked by
    /// [`Dynamic::check`]). The triangles around `u` keep, from each
    /// viewpoint, their joint visible fraction `Σ a / Σ Ω`.
    #[must_use]
    pub fn propose(&self, d: &Dynamic, u: u32, v: u32, change: &Change, metric: Metric) -> Proposal {
        let nv = self.views();
        let m = change.moved.len();
        let mut p = Proposal { a: vec![0.0; m * nv], omega: vec![0.0; m * nv], cost: 0.0 };
        let corners: Vec<[DVec3; 3]> = change.moved.iter().map(|&f| d.moved_corners(f, u, v)).collect();
        let old = || change.moved.iter().chain(&change.removed).map(|&f| f as usize);
        let (mut d_total, mut d_joint, mut d_rows) = (0.0, 0.0, 0.0);
        let mut ve = 0.0;
        for (k, eye) in self.eyes.iter().enumerate() {
            let (mut sa, mut so, mut old_terms) = (0.0, 0.0, 0.0);
            for f in old() {
                let x = self.a[f * nv + k];
                sa += x;
                so += self.omega[f * nv + k];
                old_terms += term(x);
            }
            let fraction = if so > 0.0 { (sa / so).min(1.0) } else { 0.0 };
            let (mut na, mut new_terms) = (0.0, 0.0);
            for (i, t) in corners.iter().enumerate() {
                let om = triangle_solid_angle(t[0] - *eye, t[1] - *eye, t[2] - *eye);
                let x = om * fraction;
                p.omega[i * nv + k] = om;
                p.a[i * nv + k] = x;
                na += x;
                new_terms += term(x);
            }
            let ds = na - sa;
            d_total += ds;
            d_joint += new_terms - old_terms;
            let (s0, s1) = (self.row_sum[k], (self.row_sum[k] + ds).max(0.0));
            d_rows += term(s1) - term(s0);
            if metric == Metric::Ve && self.total > 0.0 {
                let h0 = self.entropy_at(k, s0, self.row_xlnx[k]);
                let h1 = self.entropy_at(k, s1, self.row_xlnx[k] + new_terms - old_terms);
                ve += s0 / self.total * (h1 - h0).abs();
            }
        }
        p.cost = match metric {
            Metric::Ve => ve,
            Metric::Vmi => {
                let mut d_cols = 0.0;
                for (i, &f) in change.moved.iter().enumerate() {
                    let col: f64 = p.a[i * nv..(i + 1) * nv].iter().sum();
                    d_cols += term(col) - term(self.col_sum[f as usize]);
                }
                for &f in &change.removed {
                    d_cols -= term(self.col_sum[f as usize]);
                }
                let before = self.mutual_information();
                let after = mutual_information_of_weight_sums(
                    (self.total + d_total).max(0.0),
                    self.joint_xlnx + d_joint,
                    self.rows_xlnx + d_rows,
                    self.cols_xlnx + d_cols,
                    Base::Bits,
                )
                .unwrap_or(0.0);
                (after - before).abs()
            }
        };
        p
    }

    /// Applies a proposal: the moved triangles' weights replaced, the
    /// removed triangles' zeroed, the running sums updated by their terms.
    pub fn apply(&mut self, change: &Change, p: &Proposal) {
        let nv = self.views();
        let mut update = |f: usize, new_a: Option<&[f64]>, new_o: Option<&[f64]>| {
            for k in 0..nv {
                let old = self.a[f * nv + k];
                let x = new_a.map_or(0.0, |r| r[k]);
                self.a[f * nv + k] = x;
                self.omega[f * nv + k] = new_o.map_or(0.0, |r| r[k]);
                let s0 = self.row_sum[k];
                let s1 = (s0 + x - old).max(0.0);
                self.rows_xlnx += term(s1) - term(s0);
                self.row_sum[k] = s1;
                let dt = term(x) - term(old);
                self.row_xlnx[k] += dt;
                self.joint_xlnx += dt;
                self.total += x - old;
            }
            let col = new_a.map_or(0.0, |r| r.iter().sum());
            self.cols_xlnx += term(col) - term(self.col_sum[f]);
            self.col_sum[f] = col;
        };
        for (i, &f) in change.moved.iter().enumerate() {
            update(f as usize, Some(&p.a[i * nv..(i + 1) * nv]), Some(&p.omega[i * nv..(i + 1) * nv]));
        }
        for &f in &change.removed {
            update(f as usize, None, None);
        }
    }
}
