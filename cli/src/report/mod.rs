//! Reports of experiments: a results directory, CSV and JSON files, and SVG
//! plots a person can read (`plot`). Every file goes through
//! [`crate::output`]: written whole or not at all, errors naming the path.

pub mod parallel;
pub mod plot;
pub mod result_set;
pub mod step;

use std::path::{Path, PathBuf};

pub use crate::args::{Format, OutputArgs, ThreadsArg, TreeArgs, ViewsArg};
pub use cellbih::registry::{CellSettings, Settings};
pub use parallel::{JOB_STACK_BYTES, Progress, one_thread_each, side_by_side};
pub use plot::{Series, line_plot, scatter_plot};
pub use step::step;

pub use crate::output::OutputError;
use crate::output::{check_writable, write_file};

/// What every program of the front end does first thing in `main`: a
/// closed pipe ends it quietly, a standard output that cannot be written
/// ends it with one line, an interrupt removes its unfinished files, and
/// the library's warnings are said on stderr (the library never prints).
pub fn start(name: &'static str) {
    quiet_on_closed_pipe();
    one_line_on_failed_stdout(name);
    crate::output::clean_up_on_interrupt();
    cellbih::scene::on_warning(|why| eprintln!("warning: {why}"));
}

/// Lets a closed pipe end the program quietly, as it ends other Unix tools
/// (`cellbih build | head`): Rust ignores SIGPIPE, so `println!` to a
/// closed pipe would panic instead.
fn quiet_on_closed_pipe() {
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of one signal at start-up,
    // before any thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// A standard output that cannot be written (a full disk, `> /dev/full`)
/// ends the program with a one-line error and exit code 1, not a
/// panic: `println!` panics when a write fails, and this hook turns that
/// panic, and only that one, into the error.
fn one_line_on_failed_stdout(name: &'static str) {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = (info.payload().downcast_ref::<String>().map(String::as_str))
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if let Some(why) = msg.strip_prefix("failed printing to stdout: ") {
            eprintln!("error: cannot write to standard output ({name}): {why}");
            std::process::exit(1);
        }
        default(info);
    }));
}

pub use cellbih::words::count;

/// A scene's spec as part of a file name: every character but ASCII
/// letters, digits, `-` and `_` becomes `_` (`dir/x.obj` → `dir_x_obj`,
/// `rtperf:1000` → `rtperf_1000`), so that a plot's name never holds a
/// path separator or anything a shell must quote.
pub fn file_part(spec: &str) -> String {
    spec.chars()
        .map(
            |c| match c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                true => c,
                false => '_',
            },
        )
        .collect()
}

/// `text` wrapped at spaces into lines of at most `width` characters (a
/// word longer than that stands alone on its line).
pub fn wrap(text: &str, width: usize) -> String {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines.join("\n")
}

pub use cellbih::words::wrapped;

/// An experiment's whole `main`: its arguments parsed
/// ([`crate::args::parse`]), then `run` on them as [`experiment_main`]
/// runs it, into the `--out` directory `output` names.
pub fn main<A: clap::Parser>(
    name: &'static str,
    output: impl Fn(&A) -> &crate::args::OutputArgs,
    run: impl FnOnce(&A) -> Result<(), String>,
) {
    let args: A = crate::args::parse();
    crate::args::name_the_model_in_text(output(&args).format == crate::args::Format::Text);
    let out = output(&args).out.clone();
    experiment_main(name, &out, || run(&args));
}

/// An experiment's `main`: a closed pipe ends it quietly, its `--out`
/// directory is checked before `run` does any work, and an error is
/// printed as `error: …` (as the `cellbih` command and the argument parser
/// print theirs) with exit code 1.
pub fn experiment_main(name: &'static str, out: &Path, run: impl FnOnce() -> Result<(), String>) {
    start(name);
    // The directories `--out` creates, removed again if the run fails
    // before writing into them.
    let created: Vec<PathBuf> = (out.ancestors())
        .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
        .map(Path::to_path_buf)
        .collect();
    let result = prepare_dir(out).map_err(|e| e.to_string()).and_then(|()| {
        result_set::begin(out, name);
        run()?;
        result_set::commit().map(drop)
    });
    if let Err(e) = result {
        let said = result_set::abandon(name);
        // Deepest first; a directory with anything in it stays.
        for dir in &created {
            if std::fs::remove_dir(dir).is_err() {
                break;
            }
        }
        eprintln!("{}", wrapped(&format!("error: {e}")));
        for line in said {
            eprintln!("{}", wrapped(&line));
        }
        std::process::exit(1);
    }
}

/// Every scene of an experiment's `--scenes`, loaded before any work: one
/// that does not load is an error naming it (an experiment never measures
/// some of its scenes and writes its files as if that were all of them).
pub fn load_scenes(
    specs: &[String],
    data: Option<&Path>,
) -> Result<Vec<cellbih::scene::Scene>, String> {
    let data = cellbih::scene::data_dir(data);
    let mut scenes = Vec::new();
    let mut failed: Vec<String> = Vec::new();
    // Unknown names that fail for one reason are named together, the
    // reason said once.
    let mut unknown: Vec<(String, Vec<String>)> = Vec::new();
    let mut n = 0;
    for spec in specs {
        match cellbih::scene::load(spec, data.as_deref()) {
            Ok(s) => scenes.push(s),
            Err(cellbih::scene::SceneError::Unknown { spec, why }) => {
                n += 1;
                match unknown.iter_mut().find(|(w, _)| *w == why) {
                    Some((_, names)) => names.push(spec),
                    None => unknown.push((why, vec![spec])),
                }
            }
            Err(e) => {
                n += 1;
                failed.push(e.to_string());
            }
        }
    }
    for (why, names) in unknown {
        let quoted: Vec<String> = names.iter().map(|s| format!("'{s}'")).collect();
        failed.push(match names.len() {
            1 => format!("unknown scene {}: {why}", quoted[0]),
            _ => format!("unknown scenes {}: {why}", quoted.join(", ")),
        });
    }
    // 80 columns: each failure indented, its lines after the first more.
    let failed: Vec<String> = (failed.iter())
        .map(|f| wrap(f, 76).replace('\n', "\n    "))
        .collect();
    match n {
        0 if scenes.is_empty() => Err("--scenes names no scene: nothing measured".into()),
        0 => Ok(scenes),
        n => Err(format!(
            "{} of --scenes did not load: nothing measured, no file written\n  {}\n{}",
            count(n as u64, "scene"),
            failed.join("\n  "),
            wrap(
                &format!(
                    "(leave {} out of --scenes, or give the data directory: --data DIR or {})",
                    if n == 1 { "it" } else { "them" },
                    cellbih::scene::DATA_ENV,
                ),
                80
            ),
        )),
    }
}

/// Prints an experiment's result: its JSON document `doc` (the file's,
/// settings included: [`document`]) pretty, or `rows` as `table` lays
/// them out.
pub fn print_rows(
    format: Format,
    doc: &serde_json::Value,
    rows: &[serde_json::Value],
    table: impl FnOnce(&[serde_json::Value]),
) -> Result<(), String> {
    match format {
        Format::Json => println!(
            "{}",
            serde_json::to_string_pretty(doc).map_err(|e| e.to_string())?
        ),
        Format::Text => table(rows),
    }
    Ok(())
}

/// A numeric column of a printed table: header, JSON key, decimals, width.
pub type Column<'a> = (&'a str, &'a str, usize, usize);

/// Prints `rows` as several narrow tables, one per `(title, columns)`, each
/// row led by the text columns `keys` (header, JSON key, width; left
/// aligned): a wide result in 80 columns. A missing number prints as `-`.
pub fn print_tables(
    rows: &[serde_json::Value],
    keys: &[(&str, &str, usize)],
    tables: &[(&str, &[Column])],
) {
    let lead = |text: &dyn Fn(&str, &str) -> String| -> String {
        let cells: Vec<String> = (keys.iter())
            .map(|(h, k, w)| format!("{:<w$}", text(h, k)))
            .collect();
        cells.join(" ")
    };
    for (title, cols) in tables {
        let mut head = lead(&|h, _| h.to_string());
        for (h, _, _, w) in *cols {
            head += &format!(" {h:>w$}");
        }
        println!("{title}\n{head}");
        for r in rows {
            let mut line = lead(&|_, k| r[k].as_str().unwrap_or("").to_string());
            for (_, k, d, w) in *cols {
                let v = r[*k].as_f64().map_or("-".into(), |x| format!("{x:.d$}"));
                line += &format!(" {v:>w$}");
            }
            println!("{line}");
        }
        println!();
    }
}

/// Creates `dir` if need be and checks that files can be written in it:
/// an experiment calls this before its work, so that a bad `--out` fails at
/// once.
pub fn prepare_dir(dir: &Path) -> Result<(), OutputError> {
    if dir.as_os_str() == "-" {
        return Err(OutputError {
            path: dir.to_path_buf(),
            source: std::io::Error::other(
                "--out names a directory for several files; '-' (the standard output) cannot hold them",
            ),
        });
    }
    if let Some(file) = crate::output::not_a_directory(dir) {
        return Err(OutputError {
            path: dir.to_path_buf(),
            source: std::io::Error::other(format!("{} is not a directory", file.display())),
        });
    }
    std::fs::create_dir_all(dir).map_err(|source| OutputError {
        path: dir.to_path_buf(),
        source,
    })?;
    // The error names the directory the user gave, not the probe's name.
    check_writable(&dir.join(".cellbih-write-check")).map_err(|e| OutputError {
        path: dir.to_path_buf(),
        source: e.source,
    })
}

/// Creates `dir` and returns the path to write `file` of it at: while an
/// experiment's run is under way, a staging place beside it
/// ([`result_set`]), so that the run's files replace the old ones only
/// together, when the run has finished.
pub fn output(dir: &Path, file: &str) -> Result<PathBuf, OutputError> {
    prepare_dir(dir)?;
    result_set::place(dir, file).map_err(|source| OutputError {
        path: dir.join(file),
        source,
    })
}

/// Writes a CSV file with a header line.
pub fn write_csv(path: &Path, header: &str, rows: &[String]) -> Result<(), OutputError> {
    write_file(path, |f| {
        writeln!(f, "{header}")?;
        for r in rows {
            writeln!(f, "{r}")?;
        }
        Ok(())
    })
}

/// Writes the fields `keys` of JSON objects `rows` as a CSV file (null is
/// an empty cell, strings unquoted).
pub fn write_rows_csv(
    path: &Path,
    keys: &[&str],
    rows: &[serde_json::Value],
) -> Result<(), OutputError> {
    let lines: Vec<String> = rows
        .iter()
        .map(|r| {
            keys.iter()
                .map(|&k| match &r[k] {
                    serde_json::Value::Null => String::new(),
                    serde_json::Value::String(s) => s.clone(),
                    v => v.to_string(),
                })
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect();
    write_csv(path, &keys.join(","), &lines)
}

/// An experiment's JSON document: `doc` (an object; anything else
/// becomes its `rows`) with its settings: a `settings` object with the
/// command line that made it, cellbih's version and, where its builds
/// share one request (`shared`: the tree, the emulated Cell, the
/// host-thread builders' threads, moved rates; [`Settings::shared`]), that
/// request. What the rows vary (the builder and its knobs, the SPEs, a
/// rate) each row names. The file and `--format json` on the standard
/// output carry the same document.
pub fn document(
    doc: &serde_json::Value,
    shared: Option<&cellbih::registry::Build>,
) -> serde_json::Value {
    let mut settings = match shared {
        Some(b) => Settings::shared(b).to_json(),
        None => serde_json::json!({ "version": cellbih::registry::settings::version() }),
    };
    let command: Vec<String> = std::env::args().collect();
    settings["command"] = serde_json::json!(command.join(" "));
    let mut doc = match doc {
        serde_json::Value::Object(_) => doc.clone(),
        rows => serde_json::json!({ "rows": rows }),
    };
    doc["settings"] = settings;
    doc
}

/// Writes [`document`]`(doc, shared)` to `path`.
pub fn write_json(
    path: &Path,
    doc: &serde_json::Value,
    shared: Option<&cellbih::registry::Build>,
) -> Result<(), OutputError> {
    write_document(path, &document(doc, shared))
}

/// Writes a finished JSON document ([`document`]) to `path`.
pub fn write_document(path: &Path, doc: &serde_json::Value) -> Result<(), OutputError> {
    write_file(path, |w| {
        serde_json::to_writer_pretty(&mut *w, doc)?;
        writeln!(w)
    })
}

impl OutputArgs {
    /// An experiment's result: printed (a table, or with `--format json`
    /// the JSON document), then written into `--out` as `NAME.csv` (the
    /// `keys` columns of `rows`) and `NAME.json` (`doc` with its settings:
    /// [`document`]), each whole or not at all. The table comes first, so
    /// that a write that fails loses nothing measured.
    pub fn report(
        &self,
        name: &str,
        (keys, rows): (&[&str], &[serde_json::Value]),
        doc: &serde_json::Value,
        shared: Option<&cellbih::registry::Build>,
        table: impl FnOnce(&[serde_json::Value]),
    ) -> Result<(), String> {
        let doc = document(doc, shared);
        print_rows(self.format, &doc, rows, table)?;
        let io = |e: OutputError| e.to_string();
        let csv = output(&self.out, &format!("{name}.csv")).map_err(io)?;
        write_rows_csv(&csv, keys, rows).map_err(io)?;
        let json = output(&self.out, &format!("{name}.json")).map_err(io)?;
        write_document(&json, &doc).map_err(io)
    }

    /// The result of an experiment that printed its tables as it ran (in
    /// text): `NAME.csv` (`header` and `lines`) and `NAME.json` (`doc` with
    /// its settings) written into `--out`; with `--format json` the
    /// document printed as well. Says what it wrote on stderr.
    pub fn report_printed(
        &self,
        name: &str,
        (header, lines): (&str, &[String]),
        doc: &serde_json::Value,
        shared: Option<&cellbih::registry::Build>,
    ) -> Result<(), String> {
        let io = |e: OutputError| e.to_string();
        let csv = output(&self.out, &format!("{name}.csv")).map_err(io)?;
        write_csv(&csv, header, lines).map_err(io)?;
        let doc = document(doc, shared);
        if self.format == Format::Json {
            print_rows(self.format, &doc, &[], |_| {})?;
        }
        let json = output(&self.out, &format!("{name}.json")).map_err(io)?;
        write_document(&json, &doc).map_err(io)?;
        result_set::say_written(format!(
            "written: {}/{name}.{{csv,json}}",
            self.out.display()
        ));
        Ok(())
    }
}
