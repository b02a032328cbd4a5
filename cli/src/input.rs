//! Parsing the numbers a user types or keeps in CSV files.
//!
//! A vector is either inline (`0.5,0.25,0.25`, or whitespace-separated
//! words) or a file path; a matrix is a file with one row per line, or
//! inline rows separated by `;` (`0.9,0.1;0.1,0.9`). In files, fields are
//! separated by commas, semicolons, tabs or spaces; blank lines and lines
//! starting with `#` are skipped, as is a UTF-8 byte-order mark. Errors name
//! the file, line and field.

use std::fmt;
use std::path::Path;

/// Why an input could not be read.
#[derive(Debug, Clone, PartialEq)]
pub enum InputError {
    /// A field was not a number.
    Number {
        /// File name or option name.
        source: String,
        /// 1-based line.
        line: usize,
        /// 1-based field.
        field: usize,
        /// The text found (at most 40 characters).
        text: String,
    },
    /// Rows of a matrix differ in length.
    Ragged {
        /// File name or option name.
        source: String,
        /// 1-based line.
        line: usize,
        /// Fields in the first row.
        expected: usize,
        /// Fields in this row.
        found: usize,
    },
    /// Nothing to read.
    Empty {
        /// File name or option name.
        source: String,
    },
    /// The file could not be read.
    Io {
        /// The path.
        path: String,
        /// The system's message.
        message: String,
    },
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InputError::Number { source, line, field, text } => {
                write!(f, "{source}:{line}: field {field} is not a number: {text:?}")
            }
            InputError::Ragged { source, line, expected, found } => {
                write!(f, "{source}:{line}: row has {found} values, expected {expected} like the first row")
            }
            InputError::Empty { source } => write!(f, "{source}: no numbers found"),
            InputError::Io { path, message } => write!(f, "{path}: {message}"),
        }
    }
}

impl std::error::Error for InputError {}

/// A parsed row-major matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct Matrix {
    /// Row-major values.
    pub data: Vec<f64>,
    /// Number of rows.
    pub rows: usize,
    /// Number of columns.
    pub cols: usize,
}

fn split_fields(line: &str) -> impl Iterator<Item = &str> {
    line.split(|c: char| c == ',' || c == ';' || c.is_whitespace()).filter(|s| !s.is_empty())
}

fn parse_field(source: &str, line: usize, field: usize, text: &str) -> Result<f64, InputError> {
    // Rust accepts "inf"/"nan"; they are parsed here and refused by the core
    // with an index, which is clearer than a parse error.
    text.parse::<f64>().map_err(|_| InputError::Number {
        source: source.to_string(),
        line,
        field,
        text: text.chars().take(40).collect(),
    })
}

/// Parses CSV-like text into a matrix (rows of equal length).
///
/// # Errors
/// [`InputError::Number`], [`InputError::Ragged`], [`InputError::Empty`].
pub fn parse_matrix_text(source: &str, text: &str, row_separator: Option<char>) -> Result<Matrix, InputError> {
    let mut data = Vec::new();
    let mut cols = 0;
    let mut rows = 0;
    let lines: Vec<&str> = match row_separator {
        Some(sep) => text.split(sep).collect(),
        None => text.lines().collect(),
    };
    for (i, raw) in lines.iter().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = if row_separator.is_some() {
            line.split(|c: char| c == ',' || c.is_whitespace()).filter(|s| !s.is_empty()).collect()
        } else {
            split_fields(line).collect()
        };
        if fields.is_empty() {
            continue;
        }
        if rows == 0 {
            cols = fields.len();
        } else if fields.len() != cols {
            return Err(InputError::Ragged {
                source: source.to_string(),
                line: i + 1,
                expected: cols,
                found: fields.len(),
            });
        }
        for (k, f) in fields.iter().enumerate() {
            data.push(parse_field(source, i + 1, k + 1, f)?);
        }
        rows += 1;
    }
    if rows == 0 {
        return Err(InputError::Empty { source: source.to_string() });
    }
    Ok(Matrix { data, rows, cols })
}

/// Parses a vector: all numbers of the text, in order, whatever the rows.
///
/// # Errors
/// [`InputError::Number`], [`InputError::Empty`].
pub fn parse_vector_text(source: &str, text: &str) -> Result<Vec<f64>, InputError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.starts_with('#') {
            continue;
        }
        for (k, f) in split_fields(line).enumerate() {
            out.push(parse_field(source, i + 1, k + 1, f)?);
        }
    }
    if out.is_empty() {
        return Err(InputError::Empty { source: source.to_string() });
    }
    Ok(out)
}

/// A file's text, without the UTF-8 byte-order mark some editors write first.
fn read(path: &str) -> Result<String, InputError> {
    let text = itgfx_backends::files::read_regular_to_string(Path::new(path))
        .map_err(|e| InputError::Io { path: path.to_string(), message: e.to_string() })?;
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

/// Refuses, before anything opens it, an input `path` that is not a
/// regular file: `open()` on a FIFO with no writer waits for ever
/// ([`itgfx_backends::files::check_regular`]). One line, `flag path: why`.
///
/// # Errors
/// Missing, a directory, a FIFO, a device.
pub fn regular(flag: &str, path: &Path) -> Result<(), crate::CliError> {
    itgfx_backends::files::check_regular(path).map_err(|e| crate::CliError::usage(format!("{flag} {path:?}: {e}")))
}

fn looks_like_file(arg: &str) -> bool {
    Path::new(arg).is_file() || arg.ends_with(".csv") || arg.ends_with(".txt") || arg.ends_with(".tsv")
}

/// A vector from inline numbers or a file path.
///
/// # Errors
/// As [`parse_vector_text`], or [`InputError::Io`].
pub fn vector_arg(name: &str, arg: &str) -> Result<Vec<f64>, InputError> {
    if looks_like_file(arg) { parse_vector_text(arg, &read(arg)?) } else { parse_vector_text(name, arg) }
}

/// A matrix from a file path or inline `;`-separated rows.
///
/// # Errors
/// As [`parse_matrix_text`], or [`InputError::Io`].
pub fn matrix_arg(name: &str, arg: &str) -> Result<Matrix, InputError> {
    if looks_like_file(arg) {
        parse_matrix_text(arg, &read(arg)?, None)
    } else {
        parse_matrix_text(name, arg, Some(';'))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inline_forms() {
        assert_eq!(parse_vector_text("p", "0.5, 0.25 0.25").unwrap(), vec![0.5, 0.25, 0.25]);
        let m = parse_matrix_text("m", "0.9,0.1;0.2 0.8", Some(';')).unwrap();
        assert_eq!((m.rows, m.cols), (2, 2));
        assert_eq!(m.data, vec![0.9, 0.1, 0.2, 0.8]);
    }

    #[test]
    fn file_errors_name_line_and_field() {
        let e = parse_matrix_text("m.csv", "# joint\n0.1,0.2\n0.3,x\n", None).unwrap_err();
        assert_eq!(e.to_string(), "m.csv:3: field 2 is not a number: \"x\"");
        let e = parse_matrix_text("m.csv", "0.1,0.2\n0.3\n", None).unwrap_err();
        assert_eq!(e.to_string(), "m.csv:2: row has 1 values, expected 2 like the first row");
        assert!(matches!(parse_matrix_text("m.csv", "# nothing\n\n", None), Err(InputError::Empty { .. })));
    }
}
