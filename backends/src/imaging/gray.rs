//! Scalar images: storage, Gaussian smoothing, shrinking and bilinear samples.

/// A scalar image, row-major, `width × height` samples.
#[derive(Clone, Debug, PartialEq)]
pub struct Gray {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Row-major samples (`data[y * width + x]`).
    pub data: Vec<f32>,
}

impl Gray {
    /// An image of `width × height` zeros.
    #[must_use]
    pub fn new(width: usize, height: usize) -> Self {
        Self { width, height, data: vec![0.0; width * height] }
    }

    /// The sample at column `x`, row `y`.
    #[inline]
    #[must_use]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.width + x]
    }

    /// Smallest and largest sample (`(0, 0)` when empty).
    #[must_use]
    pub fn range(&self) -> (f32, f32) {
        range_of(&self.data)
    }

    /// Bilinear sample at continuous pixel coordinates (pixel centres at
    /// integers); `None` outside `[0, w−1] × [0, h−1]`.
    #[inline]
    #[must_use]
    pub fn bilinear(&self, x: f64, y: f64) -> Option<f64> {
        let (w, h) = (self.width, self.height);
        if !(x >= 0.0 && y >= 0.0 && x <= (w - 1) as f64 && y <= (h - 1) as f64) {
            return None;
        }
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let a = f64::from(self.at(x0, y0)) * (1.0 - fx) + f64::from(self.at(x1, y0)) * fx;
        let b = f64::from(self.at(x0, y1)) * (1.0 - fx) + f64::from(self.at(x1, y1)) * fx;
        Some(a * (1.0 - fy) + b * fy)
    }

    /// The four samples around continuous coordinates `(x, y)` with their
    /// bilinear weights (summing to 1); `None` outside the image, as
    /// [`Self::bilinear`]. Partial-volume histograms spread a point over them.
    #[inline]
    #[must_use]
    pub fn neighbours(&self, x: f64, y: f64) -> Option<[(f32, f64); 4]> {
        let (w, h) = (self.width, self.height);
        if !(x >= 0.0 && y >= 0.0 && x <= (w - 1) as f64 && y <= (h - 1) as f64) {
            return None;
        }
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        Some([
            (self.at(x0, y0), (1.0 - fx) * (1.0 - fy)),
            (self.at(x1, y0), fx * (1.0 - fy)),
            (self.at(x0, y1), (1.0 - fx) * fy),
            (self.at(x1, y1), fx * fy),
        ])
    }

    /// Separable Gaussian smoothing with standard deviation `sigma` pixels
    /// (kernel radius `⌈3σ⌉`, edges clamped); `sigma ≤ 0` copies.
    #[must_use]
    pub fn smoothed(&self, sigma: f64) -> Self {
        let data = smooth_grid(&self.data, &[self.width, self.height], sigma);
        Self { width: self.width, height: self.height, data }
    }

    /// Shrinks by an integer `factor`: output pixel `(i, j)` is the bilinear
    /// sample at full-resolution coordinates `((i + ½)·f − ½, (j + ½)·f − ½)`
    /// (the pixel-centre convention of the pyramid); at least 1 × 1.
    #[must_use]
    pub fn shrunk(&self, factor: usize) -> Self {
        if factor <= 1 {
            return self.clone();
        }
        let (w, h) = ((self.width / factor).max(1), (self.height / factor).max(1));
        let f = factor as f64;
        let mut out = Self::new(w, h);
        for j in 0..h {
            for i in 0..w {
                let x = ((i as f64 + 0.5) * f - 0.5).min((self.width - 1) as f64);
                let y = ((j as f64 + 0.5) * f - 0.5).min((self.height - 1) as f64);
                out.data[j * w + i] = self.bilinear(x, y).unwrap_or(0.0) as f32;
            }
        }
        out
    }
}

/// Smallest and largest of `data` (`(0, 0)` when empty).
pub(super) fn range_of(data: &[f32]) -> (f32, f32) {
    let mut it = data.iter().copied();
    let first = it.next().unwrap_or(0.0);
    it.fold((first, first), |(lo, hi), v| (lo.min(v), hi.max(v)))
}

/// The normalised Gaussian taps `exp(−i²/2σ²)`, `i ∈ [−⌈3σ⌉, ⌈3σ⌉]`.
fn gaussian_kernel(sigma: f64) -> Vec<f64> {
    let r = (3.0 * sigma).ceil() as isize;
    let mut k: Vec<f64> = (-r..=r).map(|i| (-((i * i) as f64) / (2.0 * sigma * sigma)).exp()).collect();
    let s: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= s);
    k
}

/// One pass of the odd-length kernel `k` along `axis` of a grid stored with
/// `dims[0]` fastest, edges clamped.
fn convolve_axis(src: &[f32], dims: &[usize], axis: usize, k: &[f64]) -> Vec<f32> {
    let r = (k.len() / 2) as isize;
    let stride: usize = dims[..axis].iter().product();
    let n = dims[axis] as isize;
    let mut out = vec![0.0f32; src.len()];
    for (idx, o) in out.iter_mut().enumerate() {
        let pos = ((idx / stride) % dims[axis]) as isize;
        let base = idx - pos as usize * stride;
        let mut acc = 0.0;
        for (j, kv) in k.iter().enumerate() {
            let p = (pos + j as isize - r).clamp(0, n - 1) as usize;
            acc += kv * f64::from(src[base + p * stride]);
        }
        *o = acc as f32;
    }
    out
}

/// Separable Gaussian smoothing of a 2D or 3D grid (`dims[0]` fastest),
/// one pass per axis in order; `sigma ≤ 0` copies.
pub(super) fn smooth_grid(data: &[f32], dims: &[usize], sigma: f64) -> Vec<f32> {
    if sigma <= 0.0 || data.is_empty() {
        return data.to_vec();
    }
    let k = gaussian_kernel(sigma);
    let mut out = convolve_axis(data, dims, 0, &k);
    for axis in 1..dims.len() {
        out = convolve_axis(&out, dims, axis, &k);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smoothing_keeps_constants_and_mass() {
        let mut g = Gray::new(9, 7);
        g.data.iter_mut().for_each(|v| *v = 0.25);
        assert!(g.smoothed(1.5).data.iter().all(|v| (v - 0.25).abs() < 1e-6));
        let mut d = Gray::new(31, 31);
        d.data[15 * 31 + 15] = 1.0;
        let s: f32 = d.smoothed(2.0).data.iter().sum();
        assert!((s - 1.0).abs() < 1e-5);
    }

    #[test]
    fn bilinear_is_exact_on_ramps() {
        let mut g = Gray::new(5, 4);
        for y in 0..4 {
            for x in 0..5 {
                g.data[y * 5 + x] = (2 * x + 3 * y) as f32;
            }
        }
        assert!((g.bilinear(1.25, 2.5).unwrap() - (2.5 + 7.5)).abs() < 1e-9);
        assert!(g.bilinear(4.01, 0.0).is_none());
        assert_eq!(g.shrunk(2).width, 2);
    }
}
