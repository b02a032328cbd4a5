//! `itgfx complexity SCENE`: the scene visibility channel of Part III;
//! `args.rs` holds the options, `run.rs` the run.

mod args;
mod run;

pub use args::ComplexityOptions;
pub use run::{DEFAULT_LINES, check, line_range, run};
