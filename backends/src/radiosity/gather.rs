//! Gathering with push-pull (Hanrahan, Salzman and Aupperle's hierarchical
//! radiosity): every element gathers the irradiance `Σ_j F_ij B_j` over its links,
//! pushes it down to its leaves, where `B = E + ρ H`,
//! and pulls area-weighted averages back up. Jacobi iterations in a fixed
//! order, so results do not depend on threads.

use super::element::{ElementId, Hierarchy};
use super::link::Link;

/// RGB triple.
pub type Rgb = [f64; 3];

/// Per-element reflectance and emission (from the patch's material).
pub(crate) struct Surfaces {
    pub reflectance: Vec<Rgb>,
    pub emission: Vec<Rgb>,
}

/// One Jacobi sweep: the new radiosities and irradiances of every element.
fn sweep(h: &Hierarchy, links: &[Link], s: &Surfaces, b: &[Rgb]) -> (Vec<Rgb>, Vec<Rgb>) {
    let mut gathered = vec![[0.0; 3]; h.elements.len()];
    for l in links {
        let (g, src) = (&mut gathered[l.receiver as usize], b[l.source as usize]);
        for c in 0..3 {
            g[c] += l.form_factor * src[c];
        }
    }
    let mut out = vec![[0.0; 3]; h.elements.len()];
    let mut irradiance = vec![[0.0; 3]; h.elements.len()];
    for r in &h.roots {
        push_pull(h, s, &gathered, r.element, [0.0; 3], &mut out, &mut irradiance);
    }
    (out, irradiance)
}

/// Pushes the irradiance gathered above `e` down to its leaves, where
/// `B = E + ρ H`, and pulls area-weighted means of `B` and `H` up.
fn push_pull(
    h: &Hierarchy,
    s: &Surfaces,
    gathered: &[Rgb],
    e: ElementId,
    down: Rgb,
    out: &mut [Rgb],
    irradiance: &mut [Rgb],
) -> (Rgb, Rgb) {
    let i = e as usize;
    let root = h.elements[i].root as usize;
    let mut here = down;
    for c in 0..3 {
        here[c] += gathered[i][c];
    }
    let (b, hh) = match h.elements[i].children {
        None => {
            let (em, rho) = (s.emission[root], s.reflectance[root]);
            ([em[0] + rho[0] * here[0], em[1] + rho[1] * here[1], em[2] + rho[2] * here[2]], here)
        }
        Some(first) => {
            let (mut acc, mut acc_h) = ([0.0; 3], [0.0; 3]);
            let mut area = 0.0;
            for k in first..first + 4 {
                let (bk, hk) = push_pull(h, s, gathered, k, here, out, irradiance);
                let a = h.elements[k as usize].area;
                area += a;
                for c in 0..3 {
                    acc[c] += a * bk[c];
                    acc_h[c] += a * hk[c];
                }
            }
            if area > 0.0 { (acc.map(|x| x / area), acc_h.map(|x| x / area)) } else { (acc, acc_h) }
        }
    };
    out[i] = b;
    irradiance[i] = hh;
    (b, hh)
}

/// Iterates sweeps until the largest change of a leaf radiosity is below
/// `tolerance` times the largest radiosity, or `max` sweeps; returns the
/// sweeps made. `b` is resized to the hierarchy (new elements start at 0).
pub(crate) fn solve(
    h: &Hierarchy,
    links: &[Link],
    s: &Surfaces,
    b: &mut Vec<Rgb>,
    irradiance: &mut Vec<Rgb>,
    tolerance: f64,
    max: u32,
) -> u32 {
    b.resize(h.elements.len(), [0.0; 3]);
    let mut n = 0;
    while n < max {
        let (next, hh) = sweep(h, links, s, b);
        *irradiance = hh;
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
