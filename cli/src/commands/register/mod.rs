//! `itgfx register`: rigid registration by mutual information (Part 8);
//! `args.rs` holds the options, `run.rs` the 2D run (and what the 3D run
//! shares), `run3.rs` the 3D run.

mod args;
pub mod run;
mod run3;

pub use args::RegisterOptions;
pub use run::run_register;
