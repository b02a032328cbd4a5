//! `itgfx radiosity SCENE`: the pattern every command follows,
//! `commands/<command>/` with `args.rs` (the clap options and their value
//! parsers) and `run.rs` (the run, short, over engine calls), plus the
//! command's own helpers (`check.rs`: `--check-paths`; `mesh.rs`: the PLY
//! of the leaf elements).

mod args;
pub mod check;
pub mod mesh;
mod run;

pub use args::RadiosityOptions;
pub use run::run;
