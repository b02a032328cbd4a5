//! Library side of the `itgfx` command line: typed options and CSV parsing,
//! reports, and the commands themselves (the binary is a thin `main`).

pub mod clap_error;
pub mod commands;
pub mod devices;
pub mod export;
pub mod huge_pages;
pub mod imaging;
pub mod input;
pub mod options;
pub mod output;
pub mod plot;
pub mod progress;
pub use commands::{complexity, measure, radiosity, render, simplify, viewpoints, volume};
pub mod report;
pub mod scene;
pub mod shard;
pub mod values;

use std::fmt;

/// What went wrong, which decides the exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// Bad options or input: exit code 2, before any work where it can be
    /// told before.
    Usage,
    /// The run failed on the way (an output that could not be written, a
    /// broken standard output): exit code 1.
    Runtime,
}

/// A command-line failure, printed as one line; exit code 2 for a usage
/// error, 1 for a runtime failure ([`ErrorKind`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CliError {
    message: String,
    kind: ErrorKind,
}

impl CliError {
    /// A usage error (bad or missing option).
    pub fn usage(message: impl Into<String>) -> Self {
        Self { message: message.into(), kind: ErrorKind::Usage }
    }

    /// A runtime failure (an output that could not be written).
    pub fn runtime(message: impl Into<String>) -> Self {
        Self { message: message.into(), kind: ErrorKind::Runtime }
    }

    /// An input parsing error.
    #[must_use]
    pub fn input(e: input::InputError) -> Self {
        Self::usage(e.to_string())
    }

    /// Usage or runtime.
    #[must_use]
    pub fn kind(&self) -> ErrorKind {
        self.kind
    }

    /// The process exit code: 2 for usage, 1 for runtime failures.
    #[must_use]
    pub fn exit_code(&self) -> u8 {
        match self.kind {
            ErrorKind::Usage => 2,
            ErrorKind::Runtime => 1,
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for CliError {}

/// A core error, prefixed with what was being measured.
#[must_use]
pub fn core_err(what: &str, e: itgfx_core::Error) -> CliError {
    // The core names no option; the CLI says which one helps.
    let hint = if matches!(e, itgfx_core::Error::NotNormalized { .. }) { " (--normalize does)" } else { "" };
    CliError::usage(format!("{what}: {e}{hint}"))
}
