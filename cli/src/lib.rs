//! The front end of cellbih: the `cellbih` command ([`command`], one file
//! a subcommand), every command-line argument ([`args`]), and the
//! experiments' harness ([`report`]: tables, CSV/JSON/SVG files, progress,
//! `experiment_main`), all writing through [`output`] (whole or not at
//! all, nothing left behind on an interrupt). The experiments are this
//! crate's binaries (`experiments/`). The library below (`cellbih`)
//! builds, casts and measures; this crate parses, prints and exits.

pub mod args;
pub mod command;
pub mod output;
pub mod report;

/// A command's result: its error is printed as one line, exit code 1.
pub type Res<T> = Result<T, Box<dyn std::error::Error>>;
