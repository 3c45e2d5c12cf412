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

/// A command's result: its error is printed as `error: …`, exit status 1,
/// or 2 for a [`Usage`] error.
pub type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// The command line is wrong: a value its option cannot take, or options
/// that cannot go together. Exit status 2, as the argument parser's own
/// refusals; an input or a run that fails is 1.
#[derive(Debug)]
pub struct Usage(pub String);

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// A [`Usage`] error saying `what`, boxed as commands return it.
pub fn usage(what: impl Into<String>) -> Box<dyn std::error::Error> {
    Box::new(Usage(what.into()))
}

/// The exit status of a command that failed with `e`: 2 for a [`Usage`]
/// error, 1 for any other.
pub fn exit_status(e: &(dyn std::error::Error + 'static)) -> u8 {
    match e.is::<Usage>() {
        true => 2,
        false => 1,
    }
}
