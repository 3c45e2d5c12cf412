//! `cargo xtask figures [--check] [--quick] [--only TEXT] [--data DIR]`:
//! every generated table and plot of the README and docs/ made again by
//! the command its marker names ([`blocks`]), written in place, or with
//! `--check` held against the pages ([`compare`]) and the first
//! differences printed (exit status 1).

mod blocks;
mod compare;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::Instant;

use blocks::{Block, Page};

const USAGE: &str = "usage: cargo xtask figures [--check] [--quick] [--only TEXT] [--data DIR]

  (no option)  run every block's command and write its output and plots
               into the README and docs/ in place
  --check      run them into a scratch directory and compare: simulated
               figures exactly, host times for presence; exit 1 on a
               difference
  --quick      only the blocks marked `quick` (a few minutes on 2 cores)
  --only TEXT  only the blocks whose command contains TEXT
  --data DIR   the real meshes (default: $CELLBIH_DATA, else ../shared/data)";

/// What was asked.
#[derive(Debug)]
struct Options {
    check: bool,
    quick: bool,
    only: Option<String>,
    data: Option<PathBuf>,
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let options = match parse(&args) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}\n\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    match figures(&options) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn parse(args: &[String]) -> Result<Options, String> {
    let mut it = args.iter();
    match it.next().map(String::as_str) {
        Some("figures") => {}
        Some("-h" | "--help") | None => return Err("name a task: figures".into()),
        Some(other) => return Err(format!("unknown task `{other}` (the one task is figures)")),
    }
    let mut o = Options {
        check: false,
        quick: false,
        only: None,
        data: None,
    };
    while let Some(a) = it.next() {
        let mut value = || it.next().cloned().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--check" => o.check = true,
            "--quick" => o.quick = true,
            "--only" => o.only = Some(value()?),
            "--data" => o.data = Some(PathBuf::from(value()?)),
            other => return Err(format!("unknown option `{other}`")),
        }
    }
    Ok(o)
}

/// The repository's root: the xtask crate's parent.
fn root() -> PathBuf {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    here.parent()
        .expect("xtask/ sits in the repository")
        .to_path_buf()
}

/// The pages that may hold generated blocks: the README and docs/*.md.
fn pages(root: &Path) -> Result<Vec<PathBuf>, String> {
    let mut out = vec![root.join("README.md")];
    let docs = std::fs::read_dir(root.join("docs")).map_err(|e| format!("docs/: {e}"))?;
    let mut md: Vec<PathBuf> = (docs.filter_map(|e| e.ok()).map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    md.sort();
    out.extend(md);
    Ok(out)
}

/// Runs the task; `Ok(false)` when `--check` found a difference.
fn figures(o: &Options) -> Result<bool, String> {
    let root = root();
    let mut parsed: Vec<(PathBuf, String, Page)> = Vec::new();
    for path in pages(&root)? {
        let text =
            std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let page = blocks::parse(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        parsed.push((path, text, page));
    }
    let wanted = |b: &Block| {
        (!o.quick || b.quick)
            && o.only
                .as_ref()
                .is_none_or(|t| b.command().contains(t.as_str()))
    };
    // Each command once, in the order the pages name them.
    let mut commands: Vec<String> = Vec::new();
    for b in parsed.iter().flat_map(|(_, _, p)| &p.blocks) {
        if wanted(b) && !commands.contains(&b.command()) {
            commands.push(b.command());
        }
    }
    if commands.is_empty() {
        return Err("no block is wanted: check --quick and --only".into());
    }
    build(&root, &commands)?;
    // This run's own scratch: two runs at once do not share one.
    let scratch = root.join(format!("target/figures/{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    let data = data_dir(o, &root);
    let started = Instant::now();
    let mut made: BTreeMap<String, Run> = BTreeMap::new();
    for (i, command) in commands.iter().enumerate() {
        let out = scratch.join(format!("{i}"));
        eprintln!("[{}/{}] {command}", i + 1, commands.len());
        let run = run(&root, command, &out, data.as_deref())?;
        eprintln!("       {:.1} s", run.seconds);
        made.insert(command.clone(), run);
    }
    eprintln!(
        "{} in {:.1} min",
        match commands.len() {
            1 => "1 command".to_string(),
            n => format!("{n} commands"),
        },
        started.elapsed().as_secs_f64() / 60.0
    );
    let mut agree = true;
    for (path, text, page) in &parsed {
        let dir = path.parent().expect("a page is in a folder");
        let name = path
            .strip_prefix(&root)
            .unwrap_or(path)
            .display()
            .to_string();
        for b in page.blocks.iter().filter(|b| wanted(b)) {
            let run = &made[&b.command()];
            if o.check {
                agree &= check_block(&name, b, run, dir);
            } else {
                for svg in &b.svgs {
                    std::fs::copy(made_plot(run, svg), dir.join(svg))
                        .map_err(|e| format!("{name}:{}: {svg}: {e}", b.line))?;
                }
            }
        }
        if !o.check {
            let mut lacking = None;
            let new = page.with_bodies(|b| match wanted(b) {
                true => (b.body_of(&made[&b.command()].stdout)).unwrap_or_else(|| {
                    lacking = Some(format!(
                        "{name}:{}: `{}` printed no line starting `{}`",
                        b.line,
                        b.command(),
                        b.from.as_deref().unwrap_or("")
                    ));
                    b.body.clone()
                }),
                false => b.body.clone(),
            });
            if let Some(e) = lacking {
                return Err(e);
            }
            if &new != text {
                std::fs::write(path, new).map_err(|e| format!("{name}: {e}"))?;
                eprintln!("written: {name}");
            }
        }
    }
    if o.check && agree {
        eprintln!("every figure checked agrees with its page");
    }
    Ok(agree)
}

/// Holds one block against its page; prints what differs.
fn check_block(name: &str, b: &Block, run: &Run, dir: &Path) -> bool {
    let Some(made) = b.body_of(&run.stdout) else {
        println!(
            "{name}:{}: `{}` printed no line starting `{}`",
            b.line,
            b.command(),
            b.from.as_deref().unwrap_or("")
        );
        return false;
    };
    let diffs = compare::differences(&b.body, &made, b.host, 5);
    let mut agree = diffs.is_empty();
    if !agree {
        println!("{name}:{}: `{}` differs:", b.line, b.command());
        for d in &diffs {
            println!(
                "  line {}:\n    page: {}\n    made: {}",
                d.line, d.page, d.made
            );
        }
    }
    for svg in &b.svgs {
        let new = std::fs::read(made_plot(run, svg));
        let old = std::fs::read(dir.join(svg));
        let same = match (&new, &old) {
            (Ok(_), Ok(_)) if b.host || b.host_svgs.contains(svg) => true,
            (Ok(n), Ok(o)) => n == o,
            _ => false,
        };
        if !same {
            println!("{name}:{}: plot {svg} differs (or is missing)", b.line);
            agree = false;
        }
    }
    agree
}

/// Where the run wrote the plot a block names (by the page's path to it,
/// `docs/x.svg` from the README): its `--out` directory, by file name.
fn made_plot(run: &Run, svg: &str) -> PathBuf {
    run.out.join(Path::new(svg).file_name().unwrap_or_default())
}

/// One command's run.
struct Run {
    stdout: String,
    out: PathBuf,
    seconds: f64,
}

/// Builds the front end's binaries once, and its examples where a wanted
/// command runs one.
fn build(root: &Path, commands: &[String]) -> Result<(), String> {
    let examples = examples(root)?;
    let wants_example = (commands.iter()).any(|c| {
        examples
            .iter()
            .any(|e| c.split_whitespace().next() == Some(e))
    });
    let mut args = vec!["build", "--release", "--package", "cellbih-cli", "--bins"];
    if wants_example {
        args.push("--examples");
    }
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = (Command::new(cargo).current_dir(root).args(args).status())
        .map_err(|e| format!("cargo build: {e}"))?;
    match status.success() {
        true => Ok(()),
        false => Err("the front end did not build".into()),
    }
}

/// The front end's examples: the names of `cli/Cargo.toml`'s `[[example]]`s.
fn examples(root: &Path) -> Result<Vec<String>, String> {
    let manifest = std::fs::read_to_string(root.join("cli/Cargo.toml"))
        .map_err(|e| format!("cli/Cargo.toml: {e}"))?;
    let mut out = Vec::new();
    let mut in_example = false;
    for line in manifest.lines().map(str::trim) {
        if line.starts_with('[') {
            in_example = line == "[[example]]";
        } else if let Some(v) = line.strip_prefix("name").filter(|_| in_example) {
            out.push(
                v.trim_start_matches([' ', '='])
                    .trim_matches('"')
                    .to_string(),
            );
        }
    }
    Ok(out)
}

/// The data directory for the runs: `--data`, else `$CELLBIH_DATA`, else
/// `../shared/data` where it is there.
fn data_dir(o: &Options, root: &Path) -> Option<PathBuf> {
    let beside = root.join("../shared/data");
    (o.data.clone())
        .or_else(|| std::env::var_os("CELLBIH_DATA").map(PathBuf::from))
        .or_else(|| beside.is_dir().then_some(beside))
}

/// Runs `command` from the repository's root, an experiment's files into
/// `out`.
/// A command `bench NAME ARGS` is `cargo bench --bench NAME -- ARGS` (its
/// table is what it prints; cargo's own lines go to the terminal).
fn run(root: &Path, command: &str, out: &Path, data: Option<&Path>) -> Result<Run, String> {
    let mut words = command.split_whitespace();
    let bin = words.next().expect("a command has a binary");
    let mut cmd = if bin == "bench" {
        let name = words.next().ok_or("`bench` names a bench")?;
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.args(["bench", "--bench", name, "--"]);
        cmd
    } else {
        let release = root.join("target/release");
        let Some(exe) = [release.join(bin), release.join("examples").join(bin)]
            .into_iter()
            .find(|p| p.is_file())
        else {
            return Err(format!(
                "`{command}`: no binary or example {bin} in the front end"
            ));
        };
        Command::new(exe)
    };
    cmd.current_dir(root).args(words);
    if bin != "cellbih" && bin != "bench" {
        cmd.arg("--out").arg(out);
    }
    if let Some(d) = data {
        cmd.env("CELLBIH_DATA", d);
    }
    let started = Instant::now();
    let output = cmd
        .stderr(std::process::Stdio::inherit())
        .output()
        .map_err(|e| format!("`{command}`: {e}"))?;
    if !output.status.success() {
        return Err(format!("`{command}` failed ({})", output.status));
    }
    Ok(Run {
        stdout: String::from_utf8_lossy(&output.stdout).into_owned(),
        out: out.to_path_buf(),
        seconds: started.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_front_ends_examples_are_read_from_its_manifest() {
        assert_eq!(examples(&root()).unwrap(), ["host_scaling"]);
    }

    #[test]
    fn a_task_and_its_options_parse_and_others_are_refused() {
        let args = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let o = parse(&args(&["figures", "--check", "--quick", "--only", "zoo"])).unwrap();
        assert!(o.check && o.quick && o.only.as_deref() == Some("zoo"));
        assert!(parse(&args(&["figure"])).unwrap_err().contains("figure"));
        assert!(
            parse(&args(&["figures", "--quik"]))
                .unwrap_err()
                .contains("--quik")
        );
        assert!(
            parse(&args(&["figures", "--only"]))
                .unwrap_err()
                .contains("needs a value")
        );
    }
}
