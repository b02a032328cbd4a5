//! clap's errors as one line each: what was wrong, the option, the value
//! and clap's suggestion, without the multi-line usage block.

use std::fmt::Write as _;

use clap::error::{ContextKind, ContextValue, ErrorKind};

fn text(v: &ContextValue) -> String {
    match v {
        ContextValue::String(s) => s.clone(),
        ContextValue::Strings(v) => v.join(", "),
        ContextValue::StyledStr(s) => s.to_string(),
        ContextValue::StyledStrs(v) => v.iter().map(ToString::to_string).collect::<Vec<_>>().join(", "),
        ContextValue::Number(n) => n.to_string(),
        ContextValue::Bool(b) => b.to_string(),
        _ => String::new(),
    }
}

/// `--lines <N>` is named `--lines`.
fn flag_of(arg: &str) -> &str {
    arg.split([' ', '=']).next().unwrap_or(arg)
}

/// The one-line message for a clap error; `measure` when the command was
/// `itgfx measure` (an unknown subcommand there is an unknown measure).
#[must_use]
pub fn message(e: &clap::Error, measure: bool) -> String {
    let get = |k: ContextKind| e.get(k).map(text);
    let arg = get(ContextKind::InvalidArg).unwrap_or_default();
    let value = get(ContextKind::InvalidValue).unwrap_or_default();
    let mut m = match e.kind() {
        ErrorKind::InvalidSubcommand => {
            let v = get(ContextKind::InvalidSubcommand).unwrap_or_default();
            if measure {
                format!("unknown measure {v:?}; `itgfx measure --help` lists them")
            } else {
                format!("unknown command {v:?}; try `itgfx --help`")
            }
        }
        ErrorKind::UnknownArgument => format!("unknown option {arg}"),
        ErrorKind::ValueValidation => {
            let why = std::error::Error::source(e).map(ToString::to_string).unwrap_or_default();
            format!("{} {why} (got {value:?})", flag_of(&arg))
        }
        ErrorKind::InvalidValue => {
            let valid = get(ContextKind::ValidValue).unwrap_or_default();
            if value.is_empty() {
                format!("{} needs a value", flag_of(&arg))
            } else {
                format!("{}: {value:?} is not one of {valid}", flag_of(&arg))
            }
        }
        ErrorKind::MissingRequiredArgument => format!("missing {arg}"),
        ErrorKind::ArgumentConflict => {
            let other = get(ContextKind::PriorArg).unwrap_or_default();
            format!("{} cannot be used with {other}", flag_of(&arg))
        }
        _ => {
            // Anything else: clap's own first line, without its "error: ".
            let r = e.render().to_string();
            let first = r.lines().next().unwrap_or("invalid arguments").to_string();
            first.strip_prefix("error: ").unwrap_or(&first).to_string()
        }
    };
    for k in [ContextKind::SuggestedSubcommand, ContextKind::SuggestedArg, ContextKind::SuggestedValue] {
        if let Some(s) = get(k) {
            let _ = write!(m, "; did you mean {s}?");
        }
    }
    m
}
