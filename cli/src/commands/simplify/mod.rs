//! `itgfx simplify MESH.obj --target 10% --out DIR`: viewpoint-driven mesh
//! simplification (Part VII) and the errors a user checks it by; `args.rs`
//! holds the options, `run.rs` the run.

mod args;
mod run;

pub use args::SimplifyOptions;
pub use run::{parse_target, run};
