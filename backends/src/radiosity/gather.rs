//! Gathering with push-pull (Hanrahan, Salzman and Aupperle's hierarchical
//! radiosity): every element gathers the irradiance `Σ_j F_ij B_j` over its links,
//! pushes it down to its leaves, where `B = E + ρ H`,
//! and pulls area-weighted averages back up. Jacobi iterations in a fixed
//! order, so results do not depend on threads. A final link with shares
//! gathers from the leaves its transport samples landed on
//! ([`Share`], [`parts`]). [`Conservation`] makes what
//! the links carry equal what the leaves radiate (times their true row
//! sums), so a closed scene absorbs what it emits.

use super::element::{ElementId, Hierarchy};
use super::link::{Link, Share};

/// RGB triple.
pub type Rgb = [f64; 3];

/// Per-element reflectance and emission (from the patch's material).
pub(crate) struct Surfaces {
    pub reflectance: Vec<Rgb>,
    pub emission: Vec<Rgb>,
}

/// Every link's parts `(receiver, sending element, form factor)`: its
/// [`Share`]s, in order (`shares` holds `Link::shares` of them per link,
/// links in order), or the link itself with the source's mean when it has
/// none. A link gathers `Σ F_part · send[sending element]`.
pub(crate) fn parts<'a>(
    links: &'a [Link],
    shares: &'a [Share],
) -> impl Iterator<Item = (ElementId, ElementId, f64)> + 'a {
    let mut at = 0usize;
    links.iter().flat_map(move |l| {
        let n = usize::from(l.shares);
        let own = shares.get(at..at + n).unwrap_or(&[]);
        at += n;
        let whole = (n == 0).then_some((l.receiver, l.source, l.form_factor));
        own.iter().map(move |s| (l.receiver, s.leaf, f64::from(s.form_factor))).chain(whole)
    })
}

/// How each leaf sends and receives, so that a closed scene conserves
/// power whatever the hierarchy (see [`Conservation::new`]).
pub(crate) struct Conservation {
    /// Per element: a leaf's `c_ℓ = T_ℓ / S_ℓ` (what it sends is `c_ℓ B_ℓ`).
    send: Vec<f64>,
    /// Per element: `V_e`, the area-weighted mean of `S*` over its leaves.
    visible: Vec<f64>,
    /// Per element: a leaf's `S*_ℓ` (its irradiance share).
    front: Vec<f64>,
}

impl Conservation {
    /// Plain push-pull: every leaf sends its `B` and receives its
    /// ancestors' irradiance uniformly (`c = S* = V = 1`).
    pub fn plain(h: &Hierarchy) -> Self {
        let n = h.elements.len();
        Self { send: vec![1.0; n], visible: vec![1.0; n], front: vec![1.0; n] }
    }

    /// From what each leaf sees (`seen`: the fractions of its
    /// cosine-weighted rays meeting a surface's front and back, see
    /// `front.rs`) and the links.
    ///
    /// A leaf `ℓ` radiates `A_ℓ B_ℓ`; the links of its ancestors-or-self `j`
    /// carry `A_ℓ B_ℓ S_ℓ` of it, `S_ℓ = Σ_{j ⊇ ℓ} Σ_{i ← j} A_i F_ij / A_j`
    /// (the source-side row sum through every link that reads it; a link
    /// with [`Share`]s counts each share `F_ijℓ'` at its own leaf `ℓ'`
    /// instead: `A_i F_ijℓ' / A_ℓ'`, the power it carries from that leaf
    /// alone, so `S_ℓ` is then the Monte Carlo estimate of the leaf's own
    /// row sum and `c_ℓ` corrects its noise). With
    /// form factors averaged over an ancestor `S_ℓ` is not the leaf's own
    /// row sum, and power is made or lost by `Σ_ℓ A_ℓ B_ℓ (S_ℓ − T_ℓ)`, `T_ℓ`
    /// the share of the leaf's radiated power that meets a surface: its
    /// rays that met a front over those not starting hidden (a back hit: a
    /// hidden point receives nothing, so radiates nothing of its own), 1 in
    /// a closed scene. So each leaf sends `c_ℓ B_ℓ`, `c_ℓ = T_ℓ / S_ℓ`, and
    /// the links carry exactly `Σ_ℓ A_ℓ B_ℓ T_ℓ`. On the receiving side an
    /// ancestor's irradiance goes to its leaves in proportion to their
    /// front fraction `S*_ℓ` (normalised over the ancestor, so its power is
    /// kept): a leaf hidden under a box receives nothing, instead of the
    /// ancestor's mean, which it would re-emit from where no light reaches.
    pub fn new(h: &Hierarchy, links: &[Link], shares: &[Share], seen: &[[f64; 2]]) -> Self {
        let n = h.elements.len();
        let mut out = vec![0.0; n];
        for (i, j, f) in parts(links, shares) {
            let (ai, aj) = (h.elements[i as usize].area, h.elements[j as usize].area);
            if aj > 0.0 {
                out[j as usize] += ai * f / aj;
            }
        }
        let mut c = Self { send: vec![1.0; n], visible: vec![1.0; n], front: vec![1.0; n] };
        for r in &h.roots {
            c.fill(h, &out, seen, r.element, 0.0);
        }
        c
    }

    /// Sets `send` and `front` of the leaves under `e` (`above`: the row sum
    /// of its ancestors) and returns `(Σ A S*, Σ A)` over them, setting `visible`.
    fn fill(&mut self, h: &Hierarchy, out: &[f64], seen: &[[f64; 2]], e: ElementId, above: f64) -> (f64, f64) {
        let i = e as usize;
        let row = above + out[i];
        let el = &h.elements[i];
        let (sum, area) = match el.children {
            None => {
                let [f, back] = seen[i].map(|x| x.clamp(0.0, 1.0));
                let target = if back < 1.0 { f / (1.0 - back) } else { 1.0 };
                self.front[i] = f;
                self.send[i] = if row > 0.0 { target / row } else { 1.0 };
                (el.area * f, el.area)
            }
            Some(first) => (first..first + 4).fold((0.0, 0.0), |(s, a), k| {
                let (sk, ak) = self.fill(h, out, seen, k, row);
                (s + sk, a + ak)
            }),
        };
        self.visible[i] = if area > 0.0 { sum / area } else { 0.0 };
        (sum, area)
    }
}

/// One Jacobi sweep: the new radiosities, irradiances and sent radiosities
/// of every element.
fn sweep(
    h: &Hierarchy,
    links: &[Link],
    shares: &[Share],
    s: &Surfaces,
    k: &Conservation,
    send: &[Rgb],
) -> [Vec<Rgb>; 3] {
    let mut gathered = vec![[0.0; 3]; h.elements.len()];
    for (i, j, f) in parts(links, shares) {
        let (g, src) = (&mut gathered[i as usize], send[j as usize]);
        for c in 0..3 {
            g[c] += f * src[c];
        }
    }
    let mut out =
        [vec![[0.0; 3]; h.elements.len()], vec![[0.0; 3]; h.elements.len()], vec![[0.0; 3]; h.elements.len()]];
    for r in &h.roots {
        push_pull(h, s, k, &gathered, r.element, ([0.0; 3], [0.0; 3]), &mut out);
    }
    out
}

/// Pushes the irradiance gathered above `e` down to its leaves, where
/// `B = E + ρ H`, and pulls area-weighted means of `B`, `H` and the sent
/// radiosity `c B` up. `down` is `(per unit S*, uniform)`: an ancestor's
/// irradiance goes to its leaves in proportion to `S*_ℓ / V_i`, or
/// uniformly where `V_i = 0` (no leaf of it sees anything).
fn push_pull(
    h: &Hierarchy,
    s: &Surfaces,
    k: &Conservation,
    gathered: &[Rgb],
    e: ElementId,
    down: (Rgb, Rgb),
    out: &mut [Vec<Rgb>; 3],
) -> [Rgb; 3] {
    let i = e as usize;
    let root = h.elements[i].root as usize;
    let (mut per, mut uniform) = down;
    let v = k.visible[i];
    for c in 0..3 {
        if v > 0.0 {
            per[c] += gathered[i][c] / v;
        } else {
            uniform[c] += gathered[i][c];
        }
    }
    let res = match h.elements[i].children {
        None => {
            let (em, rho) = (s.emission[root], s.reflectance[root]);
            let here: Rgb = std::array::from_fn(|c| k.front[i] * per[c] + uniform[c]);
            let b: Rgb = std::array::from_fn(|c| em[c] + rho[c] * here[c]);
            [b, here, b.map(|x| x * k.send[i])]
        }
        Some(first) => {
            let mut acc = [[0.0; 3]; 3];
            let mut area = 0.0;
            for kid in first..first + 4 {
                let r = push_pull(h, s, k, gathered, kid, (per, uniform), out);
                let a = h.elements[kid as usize].area;
                area += a;
                for (x, y) in acc.iter_mut().zip(r) {
                    for c in 0..3 {
                        x[c] += a * y[c];
                    }
                }
            }
            if area > 0.0 { acc.map(|x| x.map(|y| y / area)) } else { acc }
        }
    };
    for (o, r) in out.iter_mut().zip(res) {
        o[i] = r;
    }
    res
}

/// The sent radiosity `c B` of every element from `b` (leaves `c_ℓ B_ℓ`,
/// interior elements the area-weighted mean of their leaves').
fn sent(h: &Hierarchy, k: &Conservation, b: &[Rgb]) -> Vec<Rgb> {
    fn pull(h: &Hierarchy, k: &Conservation, b: &[Rgb], e: ElementId, out: &mut [Rgb]) -> Rgb {
        let i = e as usize;
        let r = match h.elements[i].children {
            None => b[i].map(|x| x * k.send[i]),
            Some(first) => {
                let (mut acc, mut area) = ([0.0; 3], 0.0);
                for kid in first..first + 4 {
                    let r = pull(h, k, b, kid, out);
                    let a = h.elements[kid as usize].area;
                    area += a;
                    for c in 0..3 {
                        acc[c] += a * r[c];
                    }
                }
                if area > 0.0 { acc.map(|x| x / area) } else { acc }
            }
        };
        out[i] = r;
        r
    }
    let mut out = vec![[0.0; 3]; h.elements.len()];
    for r in &h.roots {
        pull(h, k, b, r.element, &mut out);
    }
    out
}

/// Iterates sweeps until the largest change of a leaf radiosity is below
/// `tolerance` times the largest radiosity, or `max` sweeps; returns the
/// sweeps made. `b` is resized to the hierarchy (new elements start at 0).
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve(
    h: &Hierarchy,
    links: &[Link],
    shares: &[Share],
    s: &Surfaces,
    k: &Conservation,
    b: &mut Vec<Rgb>,
    irradiance: &mut Vec<Rgb>,
    tolerance: f64,
    max: u32,
) -> u32 {
    b.resize(h.elements.len(), [0.0; 3]);
    let mut send = sent(h, k, b);
    let mut n = 0;
    while n < max {
        let [next, hh, sn] = sweep(h, links, shares, s, k, &send);
        *irradiance = hh;
        send = sn;
        n += 1;
        let mut change = 0.0f64;
        let mut top = 0.0f64;
        for (x, y) in next.iter().zip(b.iter()) {
            for c in 0..3 {
                change = change.max((x[c] - y[c]).abs());
                top = top.max(x[c].abs());
            }
        }
        *b = next;
        if change <= tolerance * top {
            break;
        }
    }
    n
}
