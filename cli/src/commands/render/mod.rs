//! `itgfx render SCENE`: path-traced images with the tutorial's adaptive
//! pixel criteria (Part IV; Part III-IV §5), and `itgfx compare A.exr B.exr`.
//! `args.rs` holds the options, `check.rs` their checks, `run.rs` the run
//! (the job itself is `itgfx_backends::render::RenderJob`), `shard.rs` its
//! `--shard` and `--merge`.

mod args;
mod check;
mod export_scene;
pub mod images;
pub mod maps;
mod metrics;
mod run;
mod shard;

pub(crate) use args::camera;
pub use args::{CompareOptions, RenderOptions};
pub use metrics::compare_images;
pub use run::{run, run_compare};
