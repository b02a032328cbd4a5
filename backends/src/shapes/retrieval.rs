//! Retrieval scores of a distance matrix against class labels, each query
//! left out of its own ranking (Osada et al. 2002 and the Princeton Shape
//! Benchmark report the same): nearest-neighbour accuracy, mean average
//! precision, and the precision-recall curve averaged over queries.

/// Scores of one descriptor.
#[derive(Clone, Debug, PartialEq)]
pub struct Scores {
    /// Fraction of queries whose nearest other shape has their class.
    pub nearest_neighbour: f64,
    /// Mean over queries of the average precision of their ranking.
    pub mean_average_precision: f64,
    /// Interpolated precision at recall 0, 0.1, …, 1, averaged over queries.
    pub precision_at_recall: Vec<f64>,
    /// Queries scored (those with at least one other shape of their class).
    pub queries: usize,
}

/// The other shapes in order of distance from `q` (ties by index).
fn ranking(distance: &[f64], n: usize, q: usize) -> Vec<usize> {
    let mut r: Vec<usize> = (0..n).filter(|&j| j != q).collect();
    r.sort_by(|&a, &b| distance[q * n + a].total_cmp(&distance[q * n + b]).then(a.cmp(&b)));
    r
}

/// Scores the `n × n` row-major `distance` against `labels` (one per shape).
/// Queries whose class has no other member are left out of every score;
/// `None` when no query is left.
#[must_use]
pub fn scores(distance: &[f64], labels: &[&str]) -> Option<Scores> {
    let n = labels.len();
    if distance.len() != n * n {
        return None;
    }
    let levels = 11;
    let (mut nn, mut ap_sum, mut queries) = (0usize, 0.0, 0usize);
    let mut pr = vec![0.0; levels];
    for q in 0..n {
        let relevant = labels.iter().enumerate().filter(|&(j, l)| j != q && *l == labels[q]).count();
        if relevant == 0 {
            continue;
        }
        queries += 1;
        let r = ranking(distance, n, q);
        if labels[r[0]] == labels[q] {
            nn += 1;
        }
        let (mut hits, mut ap) = (0usize, 0.0);
        let mut points = Vec::with_capacity(relevant);
        for (k, &j) in r.iter().enumerate() {
            if labels[j] == labels[q] {
                hits += 1;
                let precision = hits as f64 / (k + 1) as f64;
                ap += precision;
                points.push((hits as f64 / relevant as f64, precision));
            }
        }
        ap_sum += ap / relevant as f64;
        // Interpolated precision: the best precision at any recall >= r.
        for (i, p) in pr.iter_mut().enumerate() {
            let at = i as f64 / (levels - 1) as f64;
            *p += points.iter().filter(|x| x.0 >= at - 1e-12).map(|x| x.1).fold(0.0, f64::max);
        }
    }
    if queries == 0 {
        return None;
    }
    let qf = queries as f64;
    Some(Scores {
        nearest_neighbour: nn as f64 / qf,
        mean_average_precision: ap_sum / qf,
        precision_at_recall: pr.into_iter().map(|p| p / qf).collect(),
        queries,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perfect_and_inverted_rankings() {
        // Two classes far apart: everything right.
        let pts = [0.0, 0.1, 10.0, 10.2];
        let d: Vec<f64> = pts.iter().flat_map(|a| pts.iter().map(move |b| f64::abs(a - b))).collect();
        let s = scores(&d, &["a", "a", "b", "b"]).unwrap();
        assert_eq!((s.nearest_neighbour, s.mean_average_precision, s.queries), (1.0, 1.0, 4));
        assert!(s.precision_at_recall.iter().all(|&p| p == 1.0));
        // Each shape nearest to the other class: NN 0, AP of rank 3 of 3 = 1/3.
        let s = scores(&d, &["a", "b", "a", "b"]).unwrap();
        assert_eq!(s.nearest_neighbour, 0.0);
        // APs: 1/2, 1/3, 1/3, 1/2 (each query's class mate ranked 2nd or 3rd).
        assert!((s.mean_average_precision - 5.0 / 12.0).abs() < 1e-12, "{s:?}");
        // A singleton class is no query.
        assert_eq!(scores(&d, &["a", "a", "b", "c"]).unwrap().queries, 2);
        assert!(scores(&d, &["a", "b", "c", "d"]).is_none());
    }
}
