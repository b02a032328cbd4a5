//! The commands, one folder each (`<command>/args.rs`, `<command>/run.rs`).
//! `radiosity` is the first moved here; the others follow the same layout.

pub mod radiosity;
