//! A small two-stage argument parser: raw words into options, flags and
//! positionals, then typed look-ups that name the option in every error.

use std::collections::BTreeMap;
use std::ffi::OsString;

use itgfx_core::Base;

use crate::CliError;
use crate::input::{self, Matrix};

/// Parsed options of one command.
#[derive(Debug, Default)]
pub struct Args {
    values: BTreeMap<String, String>,
    flags: Vec<String>,
    /// Positional words, in order.
    pub positionals: Vec<String>,
    used: std::cell::RefCell<Vec<String>>,
}

/// Options that never take a value.
const FLAGS: &[&str] = &["json", "normalize", "help", "local", "uniform-input", "sorted", "background", "per-polygon"];

impl Args {
    /// Parses `words` (everything after the command name): `--name value`,
    /// `--name=value`, flags, `--` and positionals (negative numbers included).
    ///
    /// # Errors
    /// A [`CliError`] for a missing option value, a repeated option, or non-UTF-8 input.
    pub fn parse(words: Vec<OsString>) -> Result<Self, CliError> {
        let mut a = Args::default();
        let mut it = words.into_iter();
        while let Some(w) = it.next() {
            let w = w.into_string().map_err(|_| CliError::usage("argument is not UTF-8"))?;
            if let Some(long) = w.strip_prefix("--") {
                if long.is_empty() {
                    // `--` ends options: everything after is positional.
                    for rest in it.by_ref() {
                        a.positionals.push(rest.into_string().map_err(|_| CliError::usage("argument is not UTF-8"))?);
                    }
                    break;
                }
                let (name, inline) = match long.split_once('=') {
                    Some((n, v)) => (n.to_string(), Some(v.to_string())),
                    None => (long.to_string(), None),
                };
                if FLAGS.contains(&name.as_str()) {
                    if inline.is_some() {
                        return Err(CliError::usage(format!("--{name} takes no value")));
                    }
                    a.flags.push(name);
                    continue;
                }
                let v = match inline {
                    Some(v) => v,
                    None => it
                        .next()
                        .ok_or_else(|| CliError::usage(format!("--{name} needs a value")))?
                        .into_string()
                        .map_err(|_| CliError::usage(format!("--{name}: value is not UTF-8")))?,
                };
                if a.values.insert(name.clone(), v).is_some() {
                    return Err(CliError::usage(format!("--{name} given twice")));
                }
            } else if w == "-h" {
                a.flags.push("help".into());
            } else if w.starts_with('-') && w.len() > 1 && w.parse::<f64>().is_err() {
                return Err(CliError::usage(format!("unknown option {w}")));
            } else {
                // Plain words and negative numbers are positional values.
                a.positionals.push(w);
            }
        }
        Ok(a)
    }

    /// The one positional argument a command takes (a scene, a mesh).
    ///
    /// # Errors
    /// A usage error: `missing` when there is none, a count when there are several.
    pub fn single_positional(&self, what: &str, missing: &str) -> Result<String, CliError> {
        match self.positionals.as_slice() {
            [s] => Ok(s.clone()),
            [] => Err(CliError::usage(missing)),
            more => Err(CliError::usage(format!("one {what} expected, got {}", more.len()))),
        }
    }

    /// Whether `--name` was given.
    #[must_use]
    pub fn flag(&self, name: &str) -> bool {
        self.used.borrow_mut().push(name.to_string());
        self.flags.iter().any(|f| f == name)
    }

    /// The raw value of `--name`.
    #[must_use]
    pub fn value(&self, name: &str) -> Option<&str> {
        self.used.borrow_mut().push(name.to_string());
        self.values.get(name).map(String::as_str)
    }

    /// The value of a required `--name`.
    ///
    /// # Errors
    /// A usage error naming the option.
    pub fn required(&self, name: &str) -> Result<&str, CliError> {
        self.value(name).ok_or_else(|| CliError::usage(format!("missing --{name}")))
    }

    /// `--name` as a number.
    ///
    /// # Errors
    /// A usage error naming the option and the text.
    pub fn number(&self, name: &str) -> Result<Option<f64>, CliError> {
        self.value(name)
            .map(|v| v.parse::<f64>().map_err(|_| CliError::usage(format!("--{name}: not a number: {v:?}"))))
            .transpose()
    }

    /// `--name` as a non-negative integer.
    ///
    /// # Errors
    /// A usage error naming the option and the text.
    pub fn integer(&self, name: &str) -> Result<Option<u64>, CliError> {
        self.value(name)
            .map(|v| {
                let t = v.replace('_', "");
                t.parse::<u64>()
                    .or_else(|_| {
                        // Accept 1e7-style counts when they are exact integers.
                        t.parse::<f64>()
                            .ok()
                            .filter(|x| x.fract() == 0.0 && *x >= 0.0 && *x < 1.8e19)
                            .map(|x| x as u64)
                            .ok_or(())
                    })
                    .map_err(|()| CliError::usage(format!("--{name}: not a non-negative integer: {v:?}")))
            })
            .transpose()
    }

    /// `--name` as a vector (inline or file).
    ///
    /// # Errors
    /// Parse errors naming the option or file.
    pub fn vector(&self, name: &str) -> Result<Option<Vec<f64>>, CliError> {
        self.value(name).map(|v| input::vector_arg(&format!("--{name}"), v).map_err(CliError::input)).transpose()
    }

    /// `--name` as a matrix (file or inline `;` rows).
    ///
    /// # Errors
    /// Parse errors naming the option or file.
    pub fn matrix(&self, name: &str) -> Result<Option<Matrix>, CliError> {
        self.value(name).map(|v| input::matrix_arg(&format!("--{name}"), v).map_err(CliError::input)).transpose()
    }

    /// The `--base` option (default bits).
    ///
    /// # Errors
    /// A usage error for an unknown base.
    pub fn base(&self) -> Result<Base, CliError> {
        match self.value("base") {
            None | Some("2" | "bits") => Ok(Base::Bits),
            Some("e" | "nats") => Ok(Base::Nats),
            Some("10" | "hartleys" | "bans") => Ok(Base::Hartleys),
            Some(other) => Err(CliError::usage(format!("--base: expected 2, e or 10, got {other:?}"))),
        }
    }

    /// Refuses options the command never looked at (typos).
    ///
    /// # Errors
    /// A usage error naming the first unknown option.
    pub fn finish(&self) -> Result<(), CliError> {
        let used = self.used.borrow();
        let generic = ["json", "base", "help", "threads"];
        for k in self.values.keys().chain(self.flags.iter()) {
            if !used.iter().any(|u| u == k) && !generic.contains(&k.as_str()) {
                return Err(CliError::usage(format!("unknown option --{k} for this command")));
            }
        }
        Ok(())
    }
}
