//! `itgfx viewpoints MESH`: the viewpoint channel of Part V; `args.rs`
//! holds the options, `run.rs` the run, `shard.rs` its `--shard` and
//! `--merge`.

mod args;
mod run;
pub mod shard;

pub use args::ViewpointsOptions;
pub use run::{memory_check, run};
