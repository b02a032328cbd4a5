//! Transfer functions: opacity and colour, piecewise linear over the
//! scalar normalised to `[0, 1]` by the volume's range.
//!
//! A file holds one control point per line, `value opacity r g b` (all in
//! `[0, 1]`, values strictly increasing), `#` starting a comment. Between
//! points everything is interpolated linearly; outside, the end points hold.
//!
//! The same points as JSON ([`TransferFunction::parse_json`]):
//! `{"points": [{"value": 0.1, "opacity": 0, "colour": [0.1, 0.3, 0.9]}, …]}`,
//! strictly: no other key, every key present, numbers only (JSON has no NaN).

use super::VolumeError;

/// A control point: scalar, opacity, colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlPoint {
    /// Normalised scalar in `[0, 1]`.
    pub value: f64,
    /// Opacity per world unit of length (a voxel of spacing 1) in `[0, 1]`.
    pub opacity: f64,
    /// Linear RGB in `[0, 1]`.
    pub colour: [f64; 3],
}

/// A piecewise-linear transfer function over the normalised scalar.
#[derive(Clone, Debug, PartialEq)]
pub struct TransferFunction {
    /// Control points, increasing in value (at least one).
    pub points: Vec<ControlPoint>,
}

/// The presets, by name.
pub const PRESETS: &[(&str, &str)] = &[
    ("ramp", "opacity 0 below 0.1, rising linearly to 0.6 at 1; blue to white to orange"),
    ("step", "opacity 1 above 0.5 (an opaque iso-surface), white"),
];

impl TransferFunction {
    /// A transfer function from control points.
    ///
    /// # Errors
    /// No point, a value out of `[0, 1]` or not finite, values not strictly
    /// increasing.
    pub fn new(points: Vec<ControlPoint>) -> Result<Self, VolumeError> {
        if points.is_empty() {
            return Err(VolumeError::new("transfer function: no control point"));
        }
        for (i, p) in points.iter().enumerate() {
            let all = [p.value, p.opacity, p.colour[0], p.colour[1], p.colour[2]];
            if all.iter().any(|x| !x.is_finite() || !(0.0..=1.0).contains(x)) {
                return Err(VolumeError::new(format!(
                    "transfer function point {}: every number must be in [0, 1]",
                    i + 1
                )));
            }
            if i > 0 && points[i - 1].value >= p.value {
                return Err(VolumeError::new(format!(
                    "transfer function point {}: values must increase strictly",
                    i + 1
                )));
            }
        }
        if points.iter().all(|p| p.opacity == 0.0) {
            return Err(VolumeError::new("transfer function: opacity 0 everywhere (nothing to see)"));
        }
        Ok(Self { points })
    }

    /// A preset by name (see [`PRESETS`]).
    ///
    /// # Errors
    /// An unknown name.
    pub fn preset(name: &str) -> Result<Self, VolumeError> {
        let p = |value, opacity, colour| ControlPoint { value, opacity, colour };
        match name {
            "ramp" => Self::new(vec![
                p(0.0, 0.0, [0.1, 0.2, 0.8]),
                p(0.1, 0.0, [0.1, 0.3, 0.9]),
                p(0.5, 0.25, [0.95, 0.95, 0.95]),
                p(1.0, 0.6, [1.0, 0.55, 0.1]),
            ]),
            "step" => Self::new(vec![p(0.0, 0.0, [1.0; 3]), p(0.499, 0.0, [1.0; 3]), p(0.5, 1.0, [1.0; 3])]),
            _ => Err(VolumeError::new(format!(
                "transfer function {name:?}: not a preset ({}) nor a file",
                PRESETS.iter().map(|p| p.0).collect::<Vec<_>>().join(", ")
            ))),
        }
    }

    /// Parses the text format (see the module docs).
    ///
    /// # Errors
    /// A line that is not five numbers; the checks of [`TransferFunction::new`].
    pub fn parse(text: &str) -> Result<Self, VolumeError> {
        let mut points = Vec::new();
        for (n, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let x: Vec<f64> = line
                .split_whitespace()
                .map(str::parse)
                .collect::<Result<_, _>>()
                .map_err(|_| VolumeError::new(format!("transfer function line {}: not numbers", n + 1)))?;
            let [value, opacity, r, g, b] = x[..] else {
                return Err(VolumeError::new(format!(
                    "transfer function line {}: want 5 numbers (value opacity r g b), got {}",
                    n + 1,
                    x.len()
                )));
            };
            points.push(ControlPoint { value, opacity, colour: [r, g, b] });
        }
        Self::new(points)
    }

    /// Parses the JSON format (see the module docs): one object with the
    /// single key `points`, a list of objects with exactly the keys `value`,
    /// `opacity` and `colour` (three numbers).
    ///
    /// # Errors
    /// Text that is not that JSON (unknown or missing keys, a string or
    /// `NaN` for a number), with its line and column; the checks of
    /// [`TransferFunction::new`].
    pub fn parse_json(text: &str) -> Result<Self, VolumeError> {
        #[derive(serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Point {
            value: f64,
            opacity: f64,
            colour: [f64; 3],
        }
        #[derive(serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        struct File {
            points: Vec<Point>,
        }
        let f: File =
            serde_json::from_str(text).map_err(|e| VolumeError::new(format!("transfer function JSON: {e}")))?;
        Self::new(
            f.points
                .into_iter()
                .map(|p| ControlPoint { value: p.value, opacity: p.opacity, colour: p.colour })
                .collect(),
        )
    }

    /// Opacity and colour at normalised scalar `s`.
    #[must_use]
    pub fn eval(&self, s: f64) -> (f64, [f64; 3]) {
        let pts = &self.points;
        let k = pts.partition_point(|p| p.value <= s);
        if k == 0 {
            return (pts[0].opacity, pts[0].colour);
        }
        if k == pts.len() {
            let p = pts[k - 1];
            return (p.opacity, p.colour);
        }
        let (a, b) = (pts[k - 1], pts[k]);
        let t = (s - a.value) / (b.value - a.value);
        let lerp = |x: f64, y: f64| x + (y - x) * t;
        (
            lerp(a.opacity, b.opacity),
            [lerp(a.colour[0], b.colour[0]), lerp(a.colour[1], b.colour[1]), lerp(a.colour[2], b.colour[2])],
        )
    }

    /// Smallest normalised scalar with positive opacity, if the opacity is 0
    /// below it (the lookup that skips empty voxels uses it).
    #[must_use]
    pub fn transparent_below(&self) -> f64 {
        let pts = &self.points;
        match pts.iter().position(|p| p.opacity > 0.0) {
            Some(0) | None => 0.0,
            Some(k) => pts[k - 1].value,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_eval_and_refuse() {
        let tf = TransferFunction::parse("# c\n0 0 0 0 0\n0.5 1 1 0 0  # half\n1 0.5 0 0 1\n").unwrap();
        assert_eq!(tf.eval(0.25).0, 0.5);
        assert_eq!(tf.eval(0.75).1, [0.5, 0.0, 0.5]);
        assert_eq!(tf.eval(2.0).0, 0.5);
        assert_eq!(tf.eval(-1.0).0, 0.0);
        assert!(TransferFunction::parse("").is_err());
        assert!(TransferFunction::parse("0 0 0 0 0\n1 0 1 1 1").is_err());
        assert!(TransferFunction::parse("0 0.5 0 0\n").is_err());
        assert!(TransferFunction::parse("0.5 1 1 1 1\n0.5 1 1 1 1").is_err());
        assert!(TransferFunction::parse("0 2 0 0 0").is_err());
        assert!(TransferFunction::parse("0 nan 0 0 0").is_err());
        assert_eq!(TransferFunction::preset("ramp").unwrap().transparent_below(), 0.1);
        assert!(TransferFunction::preset("none").is_err());
    }

    #[test]
    fn json_is_the_text_format() {
        let json = r#"{"points": [
            {"value": 0, "opacity": 0, "colour": [0, 0, 0]},
            {"value": 0.5, "opacity": 1, "colour": [1, 0, 0]},
            {"value": 1, "opacity": 0.5, "colour": [0, 0, 1]}]}"#;
        let text = "0 0 0 0 0\n0.5 1 1 0 0\n1 0.5 0 0 1\n";
        assert_eq!(TransferFunction::parse_json(json).unwrap(), TransferFunction::parse(text).unwrap());
        let bad = [
            ("", "JSON"),
            ("{}", "missing field `points`"),
            (r#"{"points": []}"#, "no control point"),
            (
                r#"{"points": [{"value": 0.5, "opacity": 1, "colour": [1, 1, 1]}, {"value": 0.2, "opacity": 1, "colour": [1, 1, 1]}]}"#,
                "increase strictly",
            ),
            (r#"{"points": [{"value": 0.5, "opacity": 1.5, "colour": [1, 1, 1]}]}"#, "in [0, 1]"),
            (r#"{"points": [{"value": NaN, "opacity": 1, "colour": [1, 1, 1]}]}"#, "JSON"),
            (r#"{"points": [{"value": 0.5, "opacity": 1, "colour": [1, 1]}]}"#, "JSON"),
            (r#"{"points": [{"value": 0.5, "opacity": 1, "colour": [1, 1, 1], "alpha": 1}]}"#, "unknown field"),
            (r#"{"points": [{"value": 0.5, "opacity": 0, "colour": [1, 1, 1]}]}"#, "opacity 0 everywhere"),
        ];
        for (text, want) in bad {
            let e = TransferFunction::parse_json(text).unwrap_err().to_string();
            assert!(e.contains(want) && !e.contains('\n'), "{text}: {e}");
        }
    }
}
