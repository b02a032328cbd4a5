//! `itgfx measure NAME ...`: any core measure on numbers typed or read
//! from CSV; `args.rs` holds the typed options (one variant per measure),
//! `run.rs` the run.

pub mod args;
mod run;

pub use args::{Measure, MeasureCommand};
pub use run::{MEASURES, compact_labels, run};
