//! `itgfx phantom`: a synthetic two-modality pair with a known rigid
//! transform (Part 8); `args.rs` holds the options, `run.rs` the run.

mod args;
mod run;

pub use args::PhantomOptions;
pub use run::{CONVENTION_3D, run_phantom};
