//! Results as an ordered list of named quantities, rendered as a readable
//! table or as one JSON object.
//!
//! JSON has no infinity: `+∞` and `−∞` are written as the strings `"inf"`
//! and `"-inf"` (KL divergence with disjoint supports, for example). NaN is
//! never produced by the core; if it ever were, it is written as `"nan"`
//! rather than as invalid JSON. A quantity that is not available (a standard
//! error with a single block of lines) is `null`.

use serde_json::{Map, Value};

/// One reported value.
#[derive(Debug, Clone, PartialEq)]
pub enum Item {
    /// A real number with an optional unit for the table.
    Real(f64, Option<&'static str>),
    /// A count.
    Count(u64),
    /// A list of reals.
    Reals(Vec<f64>),
    /// A short text.
    Text(String),
    /// A list of counts (e.g. indices).
    Counts(Vec<u64>),
    /// A list of short texts (e.g. files written).
    Texts(Vec<String>),
    /// A nested list of objects (e.g. merge steps).
    Records(Vec<Report>),
    /// Not available (JSON `null`).
    Missing,
    /// Yes or no (JSON `true`/`false`).
    Flag(bool),
    /// Rows of reals (JSON: an array of arrays), e.g. a distance matrix.
    Matrix(Vec<Vec<f64>>),
}

/// Named quantities in the order they are reported.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Report {
    items: Vec<(String, Item)>,
}

/// A real number as JSON: finite numbers as numbers, infinities as strings.
#[must_use]
pub fn json_real(v: f64) -> Value {
    if v.is_finite() {
        serde_json::Number::from_f64(v).map_or(Value::Null, Value::Number)
    } else if v.is_nan() {
        Value::String("nan".into())
    } else if v > 0.0 {
        Value::String("inf".into())
    } else {
        Value::String("-inf".into())
    }
}

impl Report {
    /// Lists `paths` as the report's `files` and writes it, pretty JSON,
    /// to the last of them (the imaging commands' `result.json`).
    ///
    /// # Errors
    /// The output's write error.
    pub fn write_result(mut self, paths: &[std::path::PathBuf]) -> Result<Self, crate::CliError> {
        self.texts("files", paths.iter().map(|p| p.display().to_string()).collect());
        let text = serde_json::to_string_pretty(&self.to_json()).unwrap_or_default();
        let last = paths.last().ok_or_else(|| crate::CliError::runtime("no result.json path"))?;
        crate::output::write(last, format!("{text}\n").as_bytes())?;
        Ok(self)
    }

    /// An empty report.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a real number with a unit.
    pub fn real(&mut self, key: &str, v: f64, unit: Option<&'static str>) -> &mut Self {
        self.items.push((key.to_string(), Item::Real(v, unit)));
        self
    }

    /// Adds a real number that may be unavailable: JSON `null`, table `n/a`.
    pub fn maybe_real(&mut self, key: &str, v: Option<f64>, unit: Option<&'static str>) -> &mut Self {
        match v {
            Some(x) => self.real(key, x, unit),
            None => self.text_null(key),
        }
    }

    fn text_null(&mut self, key: &str) -> &mut Self {
        self.items.push((key.to_string(), Item::Missing));
        self
    }

    /// Adds a yes/no.
    pub fn flag(&mut self, key: &str, v: bool) -> &mut Self {
        self.items.push((key.to_string(), Item::Flag(v)));
        self
    }

    /// Adds a count.
    pub fn count(&mut self, key: &str, v: u64) -> &mut Self {
        self.items.push((key.to_string(), Item::Count(v)));
        self
    }

    /// Adds a list of reals.
    pub fn reals(&mut self, key: &str, v: Vec<f64>) -> &mut Self {
        self.items.push((key.to_string(), Item::Reals(v)));
        self
    }

    /// Adds a text.
    pub fn text(&mut self, key: &str, v: impl Into<String>) -> &mut Self {
        self.items.push((key.to_string(), Item::Text(v.into())));
        self
    }

    /// Adds a list of counts.
    pub fn counts(&mut self, key: &str, v: Vec<u64>) -> &mut Self {
        self.items.push((key.to_string(), Item::Counts(v)));
        self
    }

    /// Adds a list of texts.
    pub fn texts(&mut self, key: &str, v: Vec<String>) -> &mut Self {
        self.items.push((key.to_string(), Item::Texts(v)));
        self
    }

    /// Adds rows of reals (a matrix).
    pub fn matrix(&mut self, key: &str, v: Vec<Vec<f64>>) -> &mut Self {
        self.items.push((key.to_string(), Item::Matrix(v)));
        self
    }

    /// Adds nested records.
    pub fn records(&mut self, key: &str, v: Vec<Report>) -> &mut Self {
        self.items.push((key.to_string(), Item::Records(v)));
        self
    }

    /// Looks a real value up by key (for tests and composition).
    #[must_use]
    pub fn get_real(&self, key: &str) -> Option<f64> {
        self.items.iter().find(|(k, _)| k == key).and_then(|(_, v)| match v {
            Item::Real(x, _) => Some(*x),
            _ => None,
        })
    }

    /// The report as a JSON object whose keys are the quantities' names.
    #[must_use]
    pub fn to_json(&self) -> Value {
        let mut m = Map::new();
        for (k, v) in &self.items {
            let j = match v {
                Item::Real(x, _) => json_real(*x),
                Item::Count(n) => Value::from(*n),
                Item::Reals(xs) => Value::Array(xs.iter().map(|&x| json_real(x)).collect()),
                Item::Text(s) => Value::String(s.clone()),
                Item::Counts(n) => Value::Array(n.iter().map(|&x| Value::from(x)).collect()),
                Item::Texts(s) => Value::Array(s.iter().cloned().map(Value::String).collect()),
                Item::Records(rs) => Value::Array(rs.iter().map(Report::to_json).collect()),
                Item::Missing => Value::Null,
                Item::Flag(b) => Value::Bool(*b),
                Item::Matrix(rows) => {
                    Value::Array(rows.iter().map(|r| Value::Array(r.iter().map(|&x| json_real(x)).collect())).collect())
                }
            };
            m.insert(k.clone(), j);
        }
        Value::Object(m)
    }

    /// The report as an aligned two-column table.
    #[must_use]
    pub fn to_table(&self) -> String {
        let width = self.items.iter().map(|(k, _)| k.len()).max().unwrap_or(0);
        let mut out = String::new();
        for (k, v) in &self.items {
            let val = match v {
                Item::Real(x, unit) => {
                    let num = fmt_real(*x);
                    match unit {
                        Some(u) => format!("{num} {u}"),
                        None => num,
                    }
                }
                Item::Count(n) => n.to_string(),
                Item::Reals(xs) => {
                    let shown: Vec<String> = xs.iter().take(12).map(|&x| fmt_real(x)).collect();
                    let more = if xs.len() > 12 { format!(" … ({} values)", xs.len()) } else { String::new() };
                    format!("[{}]{more}", shown.join(", "))
                }
                Item::Text(s) => s.clone(),
                Item::Counts(n) => format!("{n:?}"),
                Item::Texts(s) => s.join(", "),
                Item::Records(rs) => format!("{} records (use --json for all)", rs.len()),
                Item::Missing => "n/a".into(),
                Item::Flag(b) => if *b { "yes" } else { "no" }.into(),
                Item::Matrix(rows) => {
                    format!("{} x {} matrix (use --json)", rows.len(), rows.first().map_or(0, Vec::len))
                }
            };
            out.push_str(&format!("{k:<width$}  {val}\n"));
        }
        out
    }
}

fn fmt_real(x: f64) -> String {
    if x.is_infinite() {
        return if x > 0.0 { "inf".into() } else { "-inf".into() };
    }
    if x != 0.0 && (x.abs() < 1e-4 || x.abs() >= 1e7) { format!("{x:.6e}") } else { format!("{x:.6}") }
}
