//! Line charts as pictures: curves `y(x)` on linear or logarithmic axes in a
//! frame with a 10 × 10 grid, the ends of both axes labelled with a small
//! built-in 3 × 5 font (digits and capitals; no font files, no text
//! dependencies), optionally with axis titles and a legend ([`titled`]). Used by
//! `simplify` (error against triangle count) and the imaging commands
//! (mutual information against regions or iterations).

use image::{Rgb, RgbImage};

/// One axis: the range shown and whether it is logarithmic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    /// Smallest value shown.
    pub lo: f64,
    /// Largest value shown.
    pub hi: f64,
    /// Logarithmic spacing (values <= 0 sit at the low end).
    pub log: bool,
}

impl Axis {
    /// A linear axis over `[lo, hi]`.
    #[must_use]
    pub const fn linear(lo: f64, hi: f64) -> Self {
        Self { lo, hi, log: false }
    }

    /// A logarithmic axis over `[lo, hi]` (`lo > 0`).
    #[must_use]
    pub const fn log(lo: f64, hi: f64) -> Self {
        Self { lo, hi, log: true }
    }

    /// Where `v` falls, 0 at `lo` and 1 at `hi`, clamped; 0.5 for an empty range.
    #[must_use]
    pub fn fraction(&self, v: f64) -> f64 {
        let f = |x: f64| if self.log { x.max(f64::MIN_POSITIVE).ln() } else { x };
        let (a, b) = (f(self.lo), f(self.hi));
        if b > a && v.is_finite() { ((f(v) - a) / (b - a)).clamp(0.0, 1.0) } else { 0.5 }
    }
}

/// A polyline `(x, y)` and its colour.
pub type Curve = (Vec<(f64, f64)>, [u8; 3]);

/// Colours of a chart.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Style {
    /// Background.
    pub background: [u8; 3],
    /// Frame and labels.
    pub frame: [u8; 3],
    /// Inner grid lines.
    pub grid: [u8; 3],
}

impl Style {
    /// Dark on white (the imaging pictures).
    pub const LIGHT: Self = Self { background: [255, 255, 255], frame: [90, 90, 90], grid: [228, 228, 228] };
    /// Light on the preview background (the simplify pictures).
    pub const DARK: Self =
        Self { background: itgfx_backends::preview::BACKGROUND, frame: [150, 150, 155], grid: [70, 70, 76] };
}

/// Pixels per label character (3 × 5 glyphs drawn 2× with a 2-pixel gap).
const ADVANCE: i64 = 8;

/// Axis titles and a legend for [`titled`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Titles {
    /// Under the x axis, centred.
    pub x: String,
    /// Above the y axis, at its top.
    pub y: String,
    /// One line per curve: its name in its colour, drawn in a box at the
    /// plot's lower left.
    pub legend: Vec<(String, [u8; 3])>,
}

/// Height of a title line: a glyph (10 pixels) and a gap.
const LINE: i64 = 14;

/// A `w × h` chart of `curves` over the axes `x` and `y`. Points are joined
/// and, for curves of at most 64 points, marked; the axis ends carry their
/// values (three significant digits).
#[must_use]
pub fn chart(curves: &[Curve], x: Axis, y: Axis, size: (u32, u32), style: &Style) -> RgbImage {
    titled(curves, x, y, size, style, &Titles::default())
}

/// As [`chart`], with the axis titles and the legend of `titles` (drawn in
/// capitals).
#[must_use]
pub fn titled(curves: &[Curve], x: Axis, y: Axis, size: (u32, u32), style: &Style, titles: &Titles) -> RgbImage {
    let (w, h) = size;
    let mut img = RgbImage::from_pixel(w, h, Rgb(style.background));
    let (y_lo, y_hi) = (number(y.lo), number(y.hi));
    let left = 10 + ADVANCE * y_lo.len().max(y_hi.len()) as i64;
    let top = if titles.y.is_empty() { 12i64 } else { 12 + LINE };
    let bottom = if titles.x.is_empty() { 22i64 } else { 22 + LINE };
    let right = 14i64;
    let (pw, ph) = ((i64::from(w) - left - right).max(1), (i64::from(h) - top - bottom).max(1));
    for k in 0..=10 {
        let c = if k == 0 || k == 10 { style.frame } else { style.grid };
        let gx = (left + pw * k / 10) as f64;
        let gy = (top + ph * k / 10) as f64;
        line(&mut img, (gx, top as f64), (gx, (top + ph) as f64), c);
        line(&mut img, (left as f64, gy), ((left + pw) as f64, gy), c);
    }
    let to =
        |px: f64, py: f64| (left as f64 + x.fraction(px) * pw as f64, (top + ph) as f64 - y.fraction(py) * ph as f64);
    for (points, colour) in curves {
        for pair in points.windows(2) {
            let (a, b) = (to(pair[0].0, pair[0].1), to(pair[1].0, pair[1].1));
            line(&mut img, a, b, *colour);
            line(&mut img, (a.0, a.1 + 1.0), (b.0, b.1 + 1.0), *colour);
        }
        if points.len() <= 64 {
            for p in points {
                let (px, py) = to(p.0, p.1);
                for (dx, dy) in [(0, 0), (1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, -1), (1, -1), (-1, 1)] {
                    put(&mut img, px as i64 + dx, py as i64 + dy, *colour);
                }
            }
        }
    }
    label(&mut img, 4, top - 4, &y_hi, style.frame);
    label(&mut img, 4, top + ph - 6, &y_lo, style.frame);
    let (x_lo, x_hi) = (number(x.lo), number(x.hi));
    label(&mut img, left - 4, top + ph + 6, &x_lo, style.frame);
    label(&mut img, left + pw + 4 - ADVANCE * x_hi.len() as i64, top + ph + 6, &x_hi, style.frame);
    // Capitals throughout: the font's lower-case `e` is the exponent's.
    let (tx, ty) = (titles.x.to_uppercase(), titles.y.to_uppercase());
    let width = |t: &str| ADVANCE * t.chars().count() as i64;
    if !titles.x.is_empty() {
        label(&mut img, left + (pw - width(&tx)) / 2, top + ph + 6 + LINE, &tx, style.frame);
    }
    if !titles.y.is_empty() {
        label(&mut img, 4, 6, &ty, style.frame);
    }
    if !titles.legend.is_empty() {
        let n = titles.legend.len() as i64;
        let wide = titles.legend.iter().map(|(t, _)| width(t)).max().unwrap_or(0) + 28;
        let (x0, y0) = (left + 8, top + ph - 8 - n * LINE - 6);
        for yy in y0..y0 + n * LINE + 6 {
            line(&mut img, (x0 as f64, yy as f64), ((x0 + wide) as f64, yy as f64), style.background);
        }
        let frame = [(x0, y0), (x0 + wide, y0), (x0 + wide, y0 + n * LINE + 6), (x0, y0 + n * LINE + 6), (x0, y0)];
        for e in frame.windows(2) {
            line(&mut img, (e[0].0 as f64, e[0].1 as f64), (e[1].0 as f64, e[1].1 as f64), style.frame);
        }
        for (k, (t, c)) in titles.legend.iter().enumerate() {
            let yy = y0 + 6 + k as i64 * LINE;
            for d in [4, 5] {
                line(&mut img, ((x0 + 5) as f64, (yy + d) as f64), ((x0 + 19) as f64, (yy + d) as f64), *c);
            }
            label(&mut img, x0 + 24, yy, &t.to_uppercase(), *c);
        }
    }
    img
}

/// A value as a label: whole numbers as they are, others to three
/// significant digits, very large or small ones as `d.dde-n`.
#[must_use]
pub fn number(v: f64) -> String {
    if !v.is_finite() {
        return String::new();
    }
    if v == v.round() && v.abs() < 1e7 {
        return format!("{v:.0}");
    }
    let a = v.abs();
    if (1e-3..1e7).contains(&a) {
        let digits = (2 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.digits$}")
    } else {
        format!("{v:.2e}")
    }
}

/// 3 × 5 glyphs (rows top down, three bits each, the high bit on the left).
fn glyph(c: char) -> Option<[u8; 5]> {
    Some(match c {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 1, 1],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '.' => [0, 0, 0, 0, 2],
        '-' => [0, 0, 7, 0, 0],
        'e' => [0, 7, 5, 6, 3],
        '(' => [2, 4, 4, 4, 2],
        ')' => [2, 1, 1, 1, 2],
        ':' => [0, 2, 0, 2, 0],
        '/' => [1, 1, 2, 4, 4],
        '_' => [0, 0, 0, 0, 7],
        '+' => [0, 2, 7, 2, 0],
        '=' => [0, 7, 0, 7, 0],
        c if c.is_ascii_alphabetic() => LETTERS[(c.to_ascii_uppercase() as u8 - b'A') as usize],
        _ => return None,
    })
}

/// Capitals A to Z in the 3 × 5 font of [`glyph`].
const LETTERS: [[u8; 5]; 26] = [
    [2, 5, 7, 5, 5],
    [6, 5, 6, 5, 6],
    [3, 4, 4, 4, 3],
    [6, 5, 5, 5, 6],
    [7, 4, 6, 4, 7],
    [7, 4, 6, 4, 4],
    [3, 4, 5, 5, 3],
    [5, 5, 7, 5, 5],
    [7, 2, 2, 2, 7],
    [1, 1, 1, 5, 2],
    [5, 5, 6, 5, 5],
    [4, 4, 4, 4, 7],
    [5, 7, 7, 5, 5],
    [6, 5, 5, 5, 5],
    [2, 5, 5, 5, 2],
    [6, 5, 6, 4, 4],
    [2, 5, 5, 6, 3],
    [6, 5, 6, 5, 5],
    [3, 4, 2, 1, 6],
    [7, 2, 2, 2, 2],
    [5, 5, 5, 5, 7],
    [5, 5, 5, 5, 2],
    [5, 5, 7, 7, 5],
    [5, 5, 2, 5, 5],
    [5, 5, 2, 2, 2],
    [7, 1, 2, 4, 7],
];

/// Draws `text` (digits, letters as capitals except the exponent's `e`,
/// `. - ( ) : / _ + =`) with its top-left corner at `(x, y)`, pixels
/// doubled; other characters (a space) leave a gap.
pub fn label(img: &mut RgbImage, x: i64, y: i64, text: &str, colour: [u8; 3]) {
    for (i, c) in text.chars().enumerate() {
        let Some(g) = glyph(c) else { continue };
        for (row, bits) in g.iter().enumerate() {
            for col in 0..3 {
                if bits >> (2 - col) & 1 == 1 {
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        put(img, x + ADVANCE * i as i64 + 2 * col + dx, y + 2 * row as i64 + dy, colour);
                    }
                }
            }
        }
    }
}

/// A line from `a` to `b` (pixel coordinates), one pixel wide, clipped.
pub fn line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), colour: [u8; 3]) {
    let n = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0);
    if !n.is_finite() {
        return;
    }
    let n = n.min(1e5) as usize;
    for k in 0..=n {
        let t = k as f64 / n as f64;
        put(img, (a.0 + (b.0 - a.0) * t).floor() as i64, (a.1 + (b.1 - a.1) * t).floor() as i64, colour);
    }
}

fn put(img: &mut RgbImage, x: i64, y: i64, colour: [u8; 3]) {
    if x >= 0 && y >= 0 && x < i64::from(img.width()) && y < i64::from(img.height()) {
        img.put_pixel(x as u32, y as u32, Rgb(colour));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_place_values_linearly_and_logarithmically() {
        assert!((Axis::linear(0.0, 10.0).fraction(2.5) - 0.25).abs() < 1e-15);
        assert!((Axis::log(1.0, 1000.0).fraction(10.0) - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(Axis::log(1.0, 100.0).fraction(-3.0), 0.0, "non-positive values sit at the low end");
        assert_eq!(Axis::linear(2.0, 2.0).fraction(2.0), 0.5, "an empty range centres");
        assert_eq!(Axis::linear(0.0, 1.0).fraction(f64::NAN), 0.5);
    }

    #[test]
    fn labels_are_short_and_drawable() {
        assert_eq!(number(64.0), "64");
        assert_eq!(number(0.1234), "0.123");
        assert_eq!(number(12.345), "12.3");
        assert_eq!(number(-1.5), "-1.50");
        assert_eq!(number(2.5e-5), "2.50e-5");
        for v in [0.0, 1e9, -7.25, 3.3e-9, 123_456.7] {
            assert!(number(v).chars().all(|c| glyph(c).is_some()), "{v}: {}", number(v));
        }
    }

    /// Titles sit outside the plot (the x title below the axis labels, the
    /// y title above the frame), the legend inside its lower left, each
    /// entry in its curve's colour; letters have glyphs.
    #[test]
    fn titles_and_legend_are_drawn_where_they_belong() {
        assert!("RECALL precision (mAP)".chars().filter(|c| *c != ' ').all(|c| glyph(c).is_some()));
        let (red, blue) = ([200, 0, 0], [0, 0, 200]);
        let titles = Titles {
            x: "recall".into(),
            y: "precision".into(),
            legend: vec![("one".into(), red), ("two".into(), blue)],
        };
        let curves = [(vec![(0.0, 1.0), (1.0, 0.9)], red), (vec![(0.0, 1.0), (1.0, 0.8)], blue)];
        let (a, o) = (Axis::linear(0.0, 1.0), Style::LIGHT);
        let img = titled(&curves, a, a, (300, 200), &o, &titles);
        let plain = chart(&curves, a, a, (300, 200), &o);
        // Counts pixels of `colour` in `rows`, in the middle third of the columns
        // (the x axis's value labels sit at its ends).
        let ink = |img: &RgbImage, rows: std::ops::Range<u32>, colour: [u8; 3]| {
            img.enumerate_pixels()
                .filter(|p| (100..200).contains(&p.0) && rows.contains(&p.1) && p.2.0 == colour)
                .count()
        };
        assert!(ink(&img, 182..200, o.frame) > 20, "x title under the axis");
        assert_eq!(ink(&plain, 180..200, o.frame), 0, "nothing there without it");
        let corner =
            |img: &RgbImage| img.enumerate_pixels().filter(|p| p.0 < 80 && p.1 < 8 && p.2.0 == o.frame).count();
        assert!(corner(&img) > 20 && corner(&plain) == 0, "y title above the frame");
        // The legend: curve-coloured text at the lower left, where the curves (near the top) are not.
        let legend = |img: &RgbImage, c: [u8; 3]| {
            img.enumerate_pixels().filter(|p| p.0 < 100 && (100..180).contains(&p.1) && p.2.0 == c).count()
        };
        assert!(legend(&img, red) > 20 && legend(&img, blue) > 20);
        assert_eq!(legend(&plain, red), 0);
    }

    #[test]
    fn a_rising_curve_is_drawn_from_bottom_left_to_top_right() {
        let red = [200, 0, 0];
        let img = chart(
            &[(vec![(1.0, 0.0), (100.0, 1.0)], red)],
            Axis::log(1.0, 100.0),
            Axis::linear(0.0, 1.0),
            (200, 120),
            &Style::LIGHT,
        );
        let reds: Vec<(u32, u32)> = img.enumerate_pixels().filter(|p| p.2.0 == red).map(|p| (p.0, p.1)).collect();
        assert!(!reds.is_empty());
        let (lo, hi) = (reds.iter().min_by_key(|p| p.0).unwrap(), reds.iter().max_by_key(|p| p.0).unwrap());
        assert!(lo.1 > hi.1, "left end lower on screen than right end: {lo:?} {hi:?}");
        // On a log axis the midpoint x = 10 sits at half the width of the plot area.
        assert!(reds.iter().all(|p| p.0 < 200 && p.1 < 120));
    }
}
