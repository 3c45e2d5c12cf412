//! Inputs a new user gets wrong, and outputs that must not collide: every
//! line of a text input is bounded (a file without newlines is refused by
//! its line, never read until memory runs out), two outputs of one run
//! never name one file, a file-size limit is an error that cleans up.

use std::time::Duration;

use crate::common::{
    assert_fails_with, assert_says, cellbih, fill, line, one_ray, run_limited, stderr, tmp,
};

const EXE: &str = env!("CARGO_BIN_EXE_cellbih");

#[test]
fn a_text_input_without_newlines_is_refused_by_its_line() {
    let limit = Duration::from_secs(20);
    let out = run_limited(
        EXE,
        &["raycast", "--rays", "/dev/zero", "--out", "-"],
        limit,
    );
    assert_fails_with(&out, "/dev/zero:1: it is not text");
    let out = run_limited(EXE, &["info", "--scene", "/dev/zero"], limit);
    assert_fails_with(&out, "it is not text: it starts with NUL bytes only");

    // A line of two megabytes, after a good first line.
    let long = tmp("long-line.csv");
    let mut text = b"ox,oy,oz,dx,dy,dz,tmin,tmax\n".to_vec();
    text.extend(std::iter::repeat_n(b'1', 2 << 20));
    std::fs::write(&long, &text).unwrap();
    let out = run_limited(
        EXE,
        &["raycast", "--rays", long.to_str().unwrap(), "--out", "-"],
        limit,
    );
    assert_fails_with(&out, ":2: longer than 1 MiB without a newline");
    let obj = tmp("long-line.obj");
    let mut text = b"v 0 0 0\n".to_vec();
    text.extend(std::iter::repeat_n(b'#', 2 << 20));
    std::fs::write(&obj, &text).unwrap();
    let out = run_limited(EXE, &["info", "--scene", obj.to_str().unwrap()], limit);
    assert_fails_with(&out, "long-line.obj:2: a line longer than 1 MiB");
    assert!(
        !stderr(&out).contains("memory allocation"),
        "{}",
        stderr(&out)
    );

    // UTF-32 is named as such (it was called UTF-16).
    let utf32 = tmp("utf32.obj");
    let text: Vec<u8> = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
        .bytes()
        .flat_map(|b| [b, 0, 0, 0])
        .collect();
    std::fs::write(&utf32, text).unwrap();
    let out = cellbih(&["info", "--scene", utf32.to_str().unwrap()]);
    assert_fails_with(&out, "it is UTF-32 text");
}

/// Two outputs of one run that resolve to one file — the same name, a
/// link to it, `-` beside `/dev/stdout`, the report's standard output
/// beside a trace — are refused before any work, and nothing is written.
#[test]
fn two_outputs_that_name_one_file_are_refused() {
    let dir = tmp("same-out");
    std::fs::create_dir_all(&dir).unwrap();
    let rays = one_ray("one.rays.csv");
    let rays = rays.as_str();
    let same = dir.join("same.out");
    let same = same.to_str().unwrap();
    let png = dir.join("same.png");
    let png = png.to_str().unwrap();
    let link = dir.join("link.png");
    std::fs::write(png, "old").unwrap();
    std::os::unix::fs::symlink(png, &link).unwrap();
    let link = link.to_str().unwrap();
    let cases: Vec<Vec<&str>> = vec![
        vec![
            "raycast",
            "--rays",
            rays,
            "--on-cell",
            "--out",
            same,
            "--trace",
            same,
        ],
        vec![
            "render",
            "--on-cell",
            "--out",
            png,
            "--trace",
            png,
            "--width",
            "8",
            "--height",
            "8",
        ],
        vec![
            "render",
            "--on-cell",
            "--out",
            png,
            "--trace",
            link,
            "--width",
            "8",
            "--height",
            "8",
        ],
        vec![
            "raycast",
            "--rays",
            rays,
            "--on-cell",
            "--out",
            "-",
            "--trace",
            "/dev/stdout",
        ],
        vec!["build", "--builder", "spe_bfs", "--trace", "/dev/stdout"],
    ];
    for args in cases {
        let out = cellbih(&args);
        assert_fails_with(&out, "name the same file");
        assert!(out.stdout.is_empty(), "{args:?}");
    }
    assert!(!std::path::Path::new(same).exists());
    assert_eq!(std::fs::read_to_string(png).unwrap(), "old");
    // Distinct files are fine.
    let other = dir.join("other.trace.json");
    let out = cellbih(&fill(
        "raycast --rays {} --on-cell --out {} --trace {}",
        &[rays, same, other.to_str().unwrap()],
    ));
    crate::common::assert_ok(&out);
}

/// An error names the path the user gave, never a temporary file or the
/// probe an experiment writes to check its directory.
#[test]
fn errors_name_the_path_the_user_gave() {
    let rays = one_ray("temp-name.rays.csv");
    let out = cellbih(&["raycast", "--rays", &rays, "--out", "/proc/x.csv"]);
    assert_fails_with(&out, "/proc/x.csv: cannot write");
    assert!(!stderr(&out).contains(".tmp"), "{}", stderr(&out));
    let out = crate::common::command(env!("CARGO_BIN_EXE_table1"))
        .args(["--out", "/proc/self"])
        .output()
        .unwrap();
    assert_fails_with(&out, "/proc/self: cannot write");
    assert!(
        !stderr(&out).contains("write-check") && !stderr(&out).contains(".tmp"),
        "{}",
        stderr(&out)
    );
}

/// Under a file-size limit (`ulimit -f`) a write fails with "File too
/// large", names the file and leaves no temporary file, where SIGXFSZ used
/// to kill the process mid-write (status 153) and leave a hidden `.tmp`.
#[test]
fn a_file_size_limit_is_a_write_error_that_cleans_up() {
    let dir = tmp("fsize");
    std::fs::create_dir_all(&dir).unwrap();
    let script = format!("ulimit -f 1; exec '{EXE}' render --out a.png --width 300 --height 300");
    let out = std::process::Command::new("bash")
        .args(["-c", &script])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert_says(&out, "a.png: cannot write: File too large");
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

/// An experiment's files are one set: a run that fails after writing its
/// CSV (here its JSON is over a file-size limit) replaces nothing — the
/// old CSV and JSON stay together — and keeps what it wrote in
/// `incomplete-NAME/`, saying both. A scene given as a path names its plot
/// safely (`dir/x.obj` → `frame_loop_dir_x_obj_…`), and the run lands whole.
#[test]
fn an_experiment_replaces_its_files_together_or_not_at_all() {
    let dir = tmp("result-set");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("in")).unwrap();
    let scene = &format!("{}/scenes/default.obj", crate::common::ROOT);
    std::fs::copy(scene, dir.join("in/x.obj")).unwrap();
    let out = dir.join("res");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("frame_loop.csv"), "old csv\n").unwrap();
    std::fs::write(out.join("frame_loop.json"), "old json\n").unwrap();
    let exe = env!("CARGO_BIN_EXE_frame_loop");
    let run = |limit: &str| {
        let script =
            format!("{limit} exec '{exe}' --scenes in/x.obj --frames 2 --sizes 64x48 --out res");
        std::process::Command::new("bash")
            .args(["-c", &script])
            .current_dir(&dir)
            .output()
            .unwrap()
    };
    let failed = run("ulimit -f 8;");
    let err = stderr(&failed);
    assert_eq!(failed.status.code(), Some(1), "{err}");
    assert!(err.contains("File too large"), "{err}");
    assert!(
        err.contains("frame_loop.csv, frame_loop.json kept as they were"),
        "{err}"
    );
    assert!(
        err.contains("incomplete-frame_loop: frame_loop.csv"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("frame_loop.csv")).unwrap(),
        "old csv\n"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("frame_loop.json")).unwrap(),
        "old json\n"
    );
    let staged = std::fs::read_to_string(out.join("incomplete-frame_loop/frame_loop.csv")).unwrap();
    assert!(staged.starts_with("scene,"), "{staged}");

    let ok = run("");
    assert!(ok.status.success(), "{}", stderr(&ok));
    let json = std::fs::read_to_string(out.join("frame_loop.json")).unwrap();
    assert!(json.contains("\"settings\""), "{json}");
    assert!(out.join("frame_loop_in_x_obj_64x48.svg").exists());
    let hidden = std::fs::read_dir(&out)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with(".cellbih-run")
        })
        .count();
    assert_eq!(hidden, 0, "a staging directory was left behind");
}

/// `--format json` puts on the standard output the very document the
/// experiment writes to its JSON file, settings included — for every
/// experiment, `validate`, `dma_bandwidth` and `sensitivity` too.
#[test]
fn an_experiments_json_on_stdout_is_its_files_document() {
    let runs: [(&str, &str, &[&str]); 4] = [
        (env!("CARGO_BIN_EXE_validate"), "validate", &[]),
        (
            env!("CARGO_BIN_EXE_dma_bandwidth"),
            "dma_bandwidth",
            &["--mib", "1", "--max-spes", "2"],
        ),
        (
            env!("CARGO_BIN_EXE_sensitivity"),
            "sensitivity",
            &["--scenes", "default", "--spes", "2"],
        ),
        (env!("CARGO_BIN_EXE_table2"), "table2", &["--no-sim"]),
    ];
    for (exe, name, args) in runs {
        let dir = tmp(&format!("stdout-doc-{name}"));
        let out = crate::common::command(exe)
            .args(args)
            .args(["--format", "json", "--out", dir.to_str().unwrap()])
            .output()
            .unwrap();
        crate::common::assert_ok(&out);
        let printed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
            panic!(
                "{name}: stdout is not JSON ({e}): {}",
                crate::common::stdout(&out)
            )
        });
        let file = std::fs::read(dir.join(format!("{name}.json"))).unwrap();
        let written: serde_json::Value = serde_json::from_slice(&file).unwrap();
        assert!(
            printed["settings"]["command"].is_string(),
            "{name}: {printed}"
        );
        assert_eq!(printed, written, "{name}");
    }
}

/// A relative OBJ path without a `/` is read, and no note says it was not;
/// a built-in scene's name that is also a file here gets the note.
#[test]
fn a_relative_obj_path_is_read_without_a_wrong_note() {
    let dir = tmp("relative");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("x.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(dir.join("car"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let run = |scene: &str| {
        crate::common::command(EXE)
            .args(["info", "--scene", scene])
            .current_dir(&dir)
            .output()
            .unwrap()
    };
    let out = run("x.obj");
    crate::common::assert_ok(&out);
    assert!(!stderr(&out).contains("note"), "{}", stderr(&out));
    assert!(
        crate::common::stdout(&out).contains("triangles     1"),
        "{}",
        crate::common::stdout(&out)
    );
    let out = run("car");
    assert_says(&out, "is the built-in scene car");
}

/// Counts agree with their nouns ("1 ray, 1 hit", "1 SPE", "2 SPEs"), a
/// range is said in words, and an experiment's error has the one prefix.
#[test]
fn words_agree_with_their_counts() {
    let rays = one_ray("words.rays.csv");
    let out = cellbih(&["raycast", "--rays", &rays, "--out", "/dev/null"]);
    assert!(
        stderr(&out).starts_with("1 ray, 1 hit ("),
        "{}",
        stderr(&out)
    );
    let out = cellbih(&line("compare --spes 1"));
    let text = crate::common::stdout(&out)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    assert!(text.contains("multi-SPE builders on 1 SPE)"), "{text}");
    assert!(!text.contains("(s)"), "{text}");
    let out = cellbih(&line("build --spes 0"));
    assert_fails_with(&out, "0 is not between 1 and 16");
    let dir = tmp("words-dma");
    let out = crate::common::command(env!("CARGO_BIN_EXE_dma_bandwidth"))
        .args(fill(
            "--mib 1 --max-spes 2 --out {}",
            &[dir.to_str().unwrap()],
        ))
        .output()
        .unwrap();
    let table = crate::common::stdout(&out);
    assert!(table.contains("   1 SPE   2 SPEs"), "{table}");
    let out = crate::common::command(env!("CARGO_BIN_EXE_dma_bandwidth"))
        .args(["--out", "/proc/self"])
        .output()
        .unwrap();
    assert!(stderr(&out).starts_with("error: "), "{}", stderr(&out));
}

/// A run of more than a moment shows its progress on a stderr that is not
/// a terminal (a log, CI): lines counting the builds done, and a last one.
#[test]
fn a_long_run_shows_progress_off_a_terminal() {
    let dir = tmp("progress");
    let out = crate::common::command(env!("CARGO_BIN_EXE_spe_scaling"))
        .args([
            "--scenes",
            "rtperf:400000",
            "--max-spes",
            "8",
            "--defaults-only",
        ])
        .args(["--threads", "1", "--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    crate::common::assert_ok(&out);
    let err = stderr(&out);
    assert!(err.contains("builds: 24/24 done ("), "{err}");
    assert!(
        err.lines().filter(|l| l.starts_with("builds: ")).count() >= 2,
        "{err}"
    );
}

/// `--version` names the commit and says `-dirty` exactly when the files
/// the build reads differ from it (as `git status` sees them).
#[test]
fn the_version_says_when_the_sources_were_modified() {
    let version = crate::common::stdout(&cellbih(&line("--version")));
    let root = crate::common::ROOT;
    let status = std::process::Command::new("git")
        .args(["status", "--porcelain", "--untracked-files=no", "--"])
        .args([
            "src",
            "cell",
            "cli/src",
            "cli/experiments",
            "cli/Cargo.toml",
        ])
        .args([
            "scenes",
            "scripts/meshes.tsv",
            "Cargo.toml",
            "Cargo.lock",
            "build.rs",
        ])
        .current_dir(root)
        .output();
    match status {
        Ok(s) if s.status.success() => {
            let dirty = !s.stdout.is_empty();
            assert!(
                version.contains(" ("),
                "a checkout's build names its commit: {version}"
            );
            assert_eq!(version.contains("-dirty)"), dirty, "{version}");
        }
        // Not a checkout (a source archive): the version alone.
        _ => assert!(!version.contains('('), "{version}"),
    }
}

/// Lines of at most 80 characters: every help text (clap wraps them), and
/// what the commands and experiments print — tables split or narrowed,
/// notes and settings wrapped.
#[test]
fn what_a_person_reads_fits_80_columns() {
    let wide = |what: &str, text: &str| {
        let long: Vec<&str> = text.lines().filter(|l| l.chars().count() > 80).collect();
        assert!(
            long.is_empty(),
            "{what}: {} lines over 80: {:?}",
            long.len(),
            long.first()
        );
    };
    let experiments = [
        env!("CARGO_BIN_EXE_table1"),
        env!("CARGO_BIN_EXE_table2"),
        env!("CARGO_BIN_EXE_tradeoff"),
        env!("CARGO_BIN_EXE_frame_loop"),
        env!("CARGO_BIN_EXE_footprint"),
        env!("CARGO_BIN_EXE_extremes"),
        env!("CARGO_BIN_EXE_validate"),
        env!("CARGO_BIN_EXE_sensitivity"),
        env!("CARGO_BIN_EXE_spe_scaling"),
        env!("CARGO_BIN_EXE_partial_rebuild"),
        env!("CARGO_BIN_EXE_dma_bandwidth"),
    ];
    let run = |exe: &str, args: &[&str]| {
        let out = crate::common::command(exe).args(args).output().unwrap();
        format!("{}{}", crate::common::stdout(&out), stderr(&out))
    };
    for exe in experiments {
        wide(exe, &run(exe, &["--help"]));
    }
    for cmd in [
        "", "info", "compare", "build", "raycast", "render", "update", "frame", "builders",
    ] {
        let args: Vec<&str> = [cmd, "--help"]
            .into_iter()
            .filter(|a| !a.is_empty())
            .collect();
        wide(cmd, &run(EXE, &args));
    }
    let out = tmp("narrow");
    let o = out.to_str().unwrap();
    let rays = one_ray("narrow.rays.csv");
    let png = tmp("narrow.png");
    for (exe, args) in [
        (
            env!("CARGO_BIN_EXE_frame_loop"),
            fill(
                "--scenes rtperf:2000 --sizes 32x24 --frames 2 --out {}",
                &[o],
            ),
        ),
        (
            env!("CARGO_BIN_EXE_footprint"),
            vec!["--memory-mib", "32", "--out", o],
        ),
        (env!("CARGO_BIN_EXE_extremes"), vec!["--out", o]),
        (
            env!("CARGO_BIN_EXE_tradeoff"),
            vec!["--scenes", "default", "--out", o],
        ),
        (
            EXE,
            fill("raycast --rays {} --out /dev/null --on-cell", &[&rays]),
        ),
        (
            EXE,
            fill(
                "render --out {} --on-cell --width 16 --height 16",
                &[png.to_str().unwrap()],
            ),
        ),
    ] {
        wide(&format!("{exe} {args:?}"), &run(exe, &args));
    }
}

/// Every scene of `--scenes` that does not load is named, `frame_loop`'s
/// too, and a reason shared by several is said once.
#[test]
fn every_bad_scene_is_named_and_a_reason_said_once() {
    let dir = tmp("bad-scenes");
    let out = crate::common::command(env!("CARGO_BIN_EXE_frame_loop"))
        .args(fill(
            "--scenes nope1,car,nope2 --out {}",
            &[dir.to_str().unwrap()],
        ))
        .env_remove("CELLBIH_DATA")
        .output()
        .unwrap();
    assert_fails_with(&out, "2 scenes of --scenes did not load");
    let err = stderr(&out);
    assert!(err.contains("'nope1', 'nope2'"), "{err}");
    assert_eq!(err.matches("not a procedural scene").count(), 1, "{err}");
    assert!(err.lines().all(|l| l.chars().count() <= 80), "{err}");
}

/// An output that names an input — the rays, the scene's file, the rates
/// file, through a link or by another name — is refused before any work
/// and the input is left as it was; a link to a file not yet there names
/// that file.
#[test]
fn an_output_never_replaces_an_input() {
    let dir = tmp("inputs-as-outputs");
    std::fs::create_dir_all(&dir).unwrap();
    let at = |n: &str| dir.join(n).to_str().unwrap().to_string();
    let rays = at("r.csv");
    std::fs::write(
        &rays,
        "ox,oy,oz,dx,dy,dz,tmin,tmax\n0.1,0.1,5,0,0,-1,0,inf\n",
    )
    .unwrap();
    let mesh = at("m.obj");
    std::fs::write(&mesh, "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let rates = at("x.rates");
    std::fs::write(&rates, "spe_job = 200\n").unwrap();
    let rays_link = at("rays-link.csv");
    std::os::unix::fs::symlink(&rays, &rays_link).unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["raycast", "--rays", &rays, "--out", &rays], "--out"),
        (
            vec!["raycast", "--rays", &rays, "--out", &rays_link],
            "--out",
        ),
        (
            vec![
                "raycast",
                "--rays",
                &rays,
                "--on-cell",
                "--out",
                "-",
                "--trace",
                &rays,
            ],
            "--trace",
        ),
        (
            vec![
                "build",
                "--scene",
                &mesh,
                "--builder",
                "spe_bfs",
                "--trace",
                &mesh,
            ],
            "--trace",
        ),
        (
            vec![
                "build",
                "--builder",
                "spe_bfs",
                "--rates",
                &rates,
                "--trace",
                &rates,
            ],
            "--trace",
        ),
        (
            vec![
                "render", "--scene", &mesh, "--out", &mesh, "--width", "4", "--height", "4",
            ],
            "--out",
        ),
    ];
    for (args, option) in cases {
        let out = cellbih(&args);
        assert_fails_with(&out, &format!("{option} "));
        assert_fails_with(&out, "would replace the input");
    }
    assert!(std::fs::read_to_string(&rays).unwrap().starts_with("ox,"));
    assert!(std::fs::read_to_string(&mesh).unwrap().starts_with("v -1"));
    assert_eq!(std::fs::read_to_string(&rates).unwrap(), "spe_job = 200\n");
    // A link to a file not yet there, beside that file.
    let later = at("later.csv");
    let dangling = at("dangling.json");
    std::os::unix::fs::symlink("later.csv", &dangling).unwrap();
    let cast_to = |out: &str| {
        cellbih(&[
            "raycast",
            "--rays",
            &rays,
            "--on-cell",
            "--out",
            out,
            "--trace",
            &dangling,
        ])
    };
    assert_fails_with(&cast_to(&later), "name the same file");
    assert!(!std::path::Path::new(&later).exists());
    // Written through it, the link stays a link to the trace.
    crate::common::assert_ok(&cast_to(&at("hits.csv")));
    let link = std::fs::symlink_metadata(&dangling).unwrap();
    assert!(link.file_type().is_symlink());
    assert!(
        std::fs::read_to_string(&later)
            .unwrap()
            .contains("traceEvents")
    );
}

/// A vertex is `x y z`, `x y z w` or `x y z r g b`: any other count, or a
/// colour that is not a number, is named by its line; zoo and built-in
/// scene specs say what is wrong with them, never a saturated count or the
/// wrong part.
#[test]
fn vertex_colours_and_scene_specs_are_checked_by_what_they_say() {
    for (first, says) in [
        ("v 0 0 0 0.5 0.5", ":1: vertex 1 has 5 values"),
        (
            "v 1 0 0 1 0 x",
            ":1: vertex 1's colour: 'x' is not a number",
        ),
        ("v 0 0 0 1 0 0 1", ":1: vertex 1 has 7 values"),
    ] {
        let obj =
            crate::common::text_file("col.obj", &format!("{first}\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
        assert_fails_with(&cellbih(&["info", "--scene", &obj]), says);
    }
    let obj = crate::common::text_file("rgb.obj", "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    crate::common::assert_ok(&cellbih(&["info", "--scene", &obj]));
    for (spec, says) in [
        ("city:4294967297", "city makes more than 50000000 triangles"),
        (
            "ground:teapot:1e39",
            "the scale of ground is beyond f32: '1e39'",
        ),
        (
            "ground:rtperf:100:10",
            "its mesh 'rtperf' (a mesh name or file",
        ),
        ("", "unknown scene '': no scene given"),
    ] {
        let out = cellbih(&["info", "--scene", spec]);
        assert_fails_with(&out, says);
        assert!(!crate::common::stderr(&out).contains("18446744073709551615"));
    }
}
