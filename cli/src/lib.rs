//! Library side of the `itgfx` command line: typed options and CSV parsing,
//! reports, and the commands themselves (the binary is a thin `main`).

pub mod clap_error;
pub mod complexity;
pub mod devices;
pub mod export;
pub mod imaging;
pub mod input;
pub mod measure;
pub mod measure_options;
pub mod options;
pub mod output;
pub mod plot;
pub mod progress;
pub mod radiosity;
pub mod radiosity_check;
pub mod radiosity_mesh;
pub mod render;
pub mod report;
pub mod scene;
pub mod shard;
pub mod simplify;
pub mod values;
pub mod viewpoint_shard;
pub mod viewpoints;
pub mod volume;

use std::fmt;

/// A command-line failure, printed as one line and exit code 2.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CliError {
    message: String,
}

impl CliError {
    /// A usage error (bad or missing option).
    pub fn usage(message: impl Into<String>) -> Self {
        Self { message: message.into() }
    }

    /// An input parsing error.
    #[must_use]
    pub fn input(e: input::InputError) -> Self {
        Self { message: e.to_string() }
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
    CliError { message: format!("{what}: {e}{hint}") }
}
