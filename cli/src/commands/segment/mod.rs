//! `itgfx segment`: image segmentation by the region-intensity channel
//! (Part 8); `args.rs` holds the options, `run.rs` the run.

mod args;
mod run;

pub use args::SegmentOptions;
pub use run::run_segment;
