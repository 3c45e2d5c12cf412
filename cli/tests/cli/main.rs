//! The front end's tests, one test binary: the `cellbih` command (its
//! output, refusals and errors, inputs, quiet and interrupted runs, every
//! option named in the settings) and the experiments (their tables,
//! files and figures), each run as a user runs it.

mod common;

mod basics;
mod compare;
mod emulator;
mod errors;
mod experiments;
mod footprint;
mod frame;
mod host_threads;
mod inputs;
mod job_stacks;
mod meshes;
mod model_checks;
mod quiet;
mod rates;
mod refusals;
mod result_sets;
mod settings;
