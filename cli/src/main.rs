//! The `cellbih` command: inspect a scene, build its BIH with any builder,
//! cast rays from a file, render, update, play frames. With no arguments
//! it runs a short demonstration on the embedded default scene. This file
//! dispatches; each command is its own file in `command/`.

use std::process::ExitCode;

use clap::Parser;

use cellbih_cli::args::{Cli, Command};
use cellbih_cli::command;
use cellbih_cli::report;

fn main() -> ExitCode {
    report::start("cellbih");
    let result = match Cli::parse().command {
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
