//! Commands laid out as `commands/<cmd>/{args,run}.rs`: the options clap
//! parses, and the run.

/// `itgfx shapes`: shape descriptors and retrieval scores.
pub mod shapes {
    pub mod args;
    pub mod run;
}
