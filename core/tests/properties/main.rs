//! Property tests of the tutorial's identities and inequalities, one module
//! per family. Every module states its case count with
//! `ProptestConfig::with_cases`; CI can raise all of them with `PROPTEST_CASES`.
//! Each family checks its equality cases, not only the bound (a bound alone
//! does not catch a wrong log base).

// Shared generators: distributions with exact zeros, joints, channels, partitions.
mod strategies;

// Part II §2: 0 ≤ H ≤ log n, equality cases, concavity, Rényi/Tsallis orderings.
mod entropy;
// Part II §2-§3: chain rules, subadditivity, I ≥ 0, symmetry, I = KL(joint‖product), JS = I.
mod mutual_information;
// Part II eqs. (8), (18): information inequality and the log-sum inequality.
mod divergence;
// Part III-IV: f-divergence convexity (eq. (6)), uniqueness, Fig. 3 bounds, Bregman/Burbea-Rao links.
mod fdivergence;
// Part II eq. (19): data processing on cascades; channel reversal; specific information.
mod data_processing;
// Part II eqs. (21)-(22): Fano's inequality for the MAP estimator.
mod fano;
// Part II eqs. (24)-(25): Huffman length bounds.
mod coding;
// Part IV eq. (24): grouping decomposition on random partitions.
mod grouping;
// Part II eqs. (13)-(14): entropy rate, stationarity and excess entropy of reversible chains.
mod markov;
// Part V §3.2: VMI invariant and VE rising by p(o|v) when a polygon is split.
mod viewpoint;
// Part III: scene reversibility, H_J identities, MI matrix, δ_ij ≥ 0, oracle identities.
mod scene;
// Sparse channels and Jensen–Shannon equal their dense forms (Part V at 10^6 polygons).
mod sparse;
// Part IV eqs. (11), (18), (26)-(27): pixel colour quality/contrast and importance-weighted node contrast.
mod pixel;
