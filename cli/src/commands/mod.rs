//! Commands laid out as `commands/<cmd>/{args,run}.rs`: the options clap
//! parses, and the run. `radiosity` and `shapes` are here; the others follow
//! the same layout.

pub mod radiosity;

/// `itgfx shapes`: shape descriptors and retrieval scores.
pub mod shapes {
    pub mod args;
    pub mod run;
}
