//! The `cellbih` command: inspect a scene, build its BIH with any builder,
//! cast rays from a file, render, update, play frames. With no arguments
//! it runs a short demonstration on the embedded default scene. This file
//! dispatches; each command is its own file in `command/`.

use std::process::ExitCode;

use clap::Parser;

use cellbih_cli::args::{Charges, Cli, Command, set_charges};
use cellbih_cli::command;
use cellbih_cli::report;

fn main() -> ExitCode {
    report::start("cellbih");
    let command = Cli::parse().command;
    if let Some((name, charges)) = charges(&command) {
        set_charges(name, charges);
    }
    let result = match command {
        None => command::compare::demo(),
        Some(Command::Builders) => command::builders::run(),
        Some(Command::Rates(args)) => command::rates::run(args),
        Some(Command::Info(args)) => command::info::run(args),
        Some(Command::Compare(args)) => command::compare::run(args),
        Some(Command::Build(args)) => command::build::run(args),
        Some(Command::Raycast(args)) => command::raycast::run(args),
        Some(Command::Render(args)) => command::render::run(args),
        Some(Command::Update(args)) => command::update::run(args),
        Some(Command::Frame(args)) => command::frame::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{}", report::wrapped(&format!("error: {e}")));
            if e.to_string().contains("main memory full:") {
                eprintln!(
                    "{}",
                    report::wrapped(
                        "note: the emulated Cell's main memory is --memory-mib (256 MiB, a PS3's, \
                         unless given): give more to run this"
                    )
                );
            }
            ExitCode::from(cellbih_cli::exit_status(&*e))
        }
    }
}

/// What `command` charges, for refusing a `--rate` it never charges.
fn charges(command: &Option<Command>) -> Option<(&'static str, Charges)> {
    let with = Charges::builds_and;
    Some(match command.as_ref()? {
        Command::Build(_) => ("build", Charges::BUILDS),
        Command::Compare(_) => ("compare", Charges::BUILDS),
        Command::Raycast(a) if a.cast.on_cell => ("raycast --on-cell", with(true, false)),
        Command::Raycast(_) => ("raycast without --on-cell", Charges::BUILDS),
        Command::Render(a) if a.cast.on_cell => ("render --on-cell", with(true, false)),
        Command::Render(_) => ("render without --on-cell", Charges::BUILDS),
        Command::Update(_) => ("update", with(false, true)),
        Command::Frame(_) => ("frame", with(true, true)),
        _ => return None,
    })
}
