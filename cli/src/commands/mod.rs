//! Commands laid out as `commands/<cmd>/{args,run}.rs`: the options clap
//! parses, and the run. Every command is here but `devices`; `compare`
//! lives with `render`.

pub mod complexity;
pub mod measure;
pub mod phantom;
pub mod radiosity;
pub mod register;
pub mod render;
pub mod segment;
pub mod simplify;
pub mod viewpoints;
pub mod volume;

/// `itgfx shapes`: shape descriptors and retrieval scores.
pub mod shapes {
    pub mod args;
    pub mod run;
}
