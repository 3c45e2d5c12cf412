//! Nothing lost, nothing silent: what the commands write, as a new user
//! meets it. Writes that fail are errors naming the path (to `/dev/full`,
//! to paths that cannot exist, a full standard output); a failed write
//! leaves no file that looks valid; an experiment with nothing to measure
//! keeps earlier results; degenerate requests get sensible answers; traces
//! nest; a closed pipe ends quietly. Arguments refused before any work are
//! in `cli/tests/cli/refusals.rs`.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use crate::common::{
    ONE_RAY, assert_fails_with, assert_ok, cellbih, fill, json, line, run_limited, stderr, stdout,
    text_file, tmp,
};

/// A link in a fresh directory that points at `/dev/full`.
fn link_to_dev_full(dir: &Path, name: &str) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let p = dir.join(name);
    let _ = std::fs::remove_file(&p);
    std::os::unix::fs::symlink("/dev/full", &p).unwrap();
    p
}

#[test]
fn raycast_to_dev_full_or_a_bad_path_fails_naming_it() {
    let rays = text_file("one.rays.csv", ONE_RAY);
    let full = link_to_dev_full(&tmp("full"), "hits.csv");
    let out = cellbih(&["raycast", "--rays", &rays, "--out", full.to_str().unwrap()]);
    assert_fails_with(&out, &format!("{}: cannot write", full.display()));
    assert!(!stderr(&out).contains("written to"), "{}", stderr(&out));

    // Larger output: the error still names the file.
    let many: String = std::iter::once("ox,oy,oz,dx,dy,dz,tmin,tmax\n")
        .chain(std::iter::repeat_n("0,1,8,0,0,-1,0,inf\n", 20_000))
        .collect();
    let rays = text_file("many.rays.csv", &many);
    let out = cellbih(&["raycast", "--rays", &rays, "--out", full.to_str().unwrap()]);
    assert_fails_with(&out, &format!("{}: cannot write", full.display()));

    // Paths that cannot be written fail before any work, naming the path.
    let a_file = tmp("plain-file");
    std::fs::write(&a_file, "x").unwrap();
    for bad in [
        "/no/such/dir/hits.csv".to_string(),
        "/proc/cellbih-hits.csv".to_string(),
        format!("{}/hits.csv", a_file.display()),
    ] {
        let out = cellbih(&["raycast", "--rays", &rays, "--out", &bad]);
        assert_fails_with(&out, &format!("{bad}: cannot write"));
        assert!(!Path::new(&bad).exists());
    }
}

#[test]
fn render_refuses_bad_sizes_and_names_up_front_and_leaves_no_file() {
    let dir = tmp("render");
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("r.png");
    let p = png.to_str().unwrap();
    for (args, msg) in [
        (
            vec!["--width", "0", "--out", p],
            "an image of 0 × 600 pixels has no pixel",
        ),
        (
            vec!["--width", "100000", "--height", "100000", "--out", p],
            "each side is at most 16384",
        ),
        (
            vec!["--width", "16384", "--height", "16384", "--out", p],
            "at most 67108864 pixels",
        ),
    ] {
        let mut a = vec!["render"];
        a.extend(args);
        let out = run_limited(env!("CARGO_BIN_EXE_cellbih"), &a, Duration::from_secs(20));
        assert_fails_with(&out, msg);
        assert!(!png.exists(), "a refused render leaves no file");
    }
    let jpg = dir.join("x.jpg");
    let out = cellbih(&["render", "--out", jpg.to_str().unwrap()]);
    assert_fails_with(&out, "images are written as PNG");
    assert!(!jpg.exists());

    let full = link_to_dev_full(&dir, "full.png");
    let out = cellbih(&fill(
        "render --width 32 --height 24 --out {}",
        &[full.to_str().unwrap()],
    ));
    assert_fails_with(&out, &format!("{}: cannot write", full.display()));
}

#[test]
fn a_trace_nests_on_every_track_and_a_bad_trace_path_fails_first() {
    let p = tmp("default.trace.json");
    let out = cellbih(&fill(
        "build --builder spe_bfs --trace {}",
        &[p.to_str().unwrap()],
    ));
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
    crate::common::check_nesting(&v).unwrap();
    // The default scene's SPE streams with several transfers in flight.
    let names: Vec<&str> = v["traceEvents"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["name"] == "thread_name")
        .filter_map(|e| e["args"]["name"].as_str())
        .collect();
    assert!(names.contains(&"SPE 0 MFC (2)"), "{names:?}");

    let full = link_to_dev_full(&tmp("trace"), "t.json");
    let out = cellbih(&fill(
        "build --builder spe_bfs --trace {}",
        &[full.to_str().unwrap()],
    ));
    assert_fails_with(&out, &format!("{}: cannot write", full.display()));
    let out = cellbih(&line("build --builder spe_bfs --trace /no/such/dir/t.json"));
    assert_fails_with(&out, "/no/such/dir/t.json: cannot write");
    assert!(stdout(&out).is_empty(), "refused before the build ran");
}

#[test]
fn experiments_check_their_arguments_and_output_before_the_work() {
    let limit = Duration::from_secs(30);
    let dma = env!("CARGO_BIN_EXE_dma_bandwidth");
    let out = tmp("exp-out");
    let o = out.to_str().unwrap();
    for (args, msg) in [
        (
            &["--mib", "0", "--out", o][..],
            "0 is not between 1 and 1024",
        ),
        (
            &["--max-spes", "0", "--out", o][..],
            "0 is not between 1 and 16",
        ),
        (
            &["--max-spes", "17", "--out", o][..],
            "17 is not between 1 and 16",
        ),
        (&["--out", "/proc/x"][..], "/proc/x: cannot write"),
    ] {
        assert_fails_with(&run_limited(dma, args, limit), msg);
    }
    let partial = env!("CARGO_BIN_EXE_partial_rebuild");
    for (args, msg) in [
        (
            &["--step", "0", "--out", o][..],
            "0 is less than 1: give a whole number of at least 1",
        ),
        (
            &["--frames", "0", "--out", o][..],
            "0 is not between 1 and 100000",
        ),
        (
            &["--from", "5000", "--to", "4000", "--out", o][..],
            "--from 5000 is larger than --to 4000",
        ),
        (
            &["--to", "100000000", "--out", o][..],
            "100000000 is not between 1 and 10000000",
        ),
        (
            &["--format", "yaml", "--out", o][..],
            "invalid value 'yaml'",
        ),
    ] {
        assert_fails_with(&run_limited(partial, args, limit), msg);
    }
    for exe in [env!("CARGO_BIN_EXE_table1"), env!("CARGO_BIN_EXE_table2")] {
        assert_fails_with(
            &run_limited(exe, &["--out", "/proc/x"], limit),
            "/proc/x: cannot write",
        );
    }
}

/// A write that fails after the work: the table is printed first, then the
/// path that could not be written is named.
#[test]
fn an_experiment_prints_its_table_then_names_the_file_it_could_not_write() {
    let dir = tmp("partial-full");
    link_to_dev_full(&dir, "partial_rebuild.csv");
    let out = run_limited(
        env!("CARGO_BIN_EXE_partial_rebuild"),
        &[
            "--from",
            "2000",
            "--to",
            "2000",
            "--frames",
            "3",
            "--no-sim",
            "--out",
            dir.to_str().unwrap(),
        ],
        Duration::from_secs(60),
    );
    assert_fails_with(&out, "partial_rebuild.csv: cannot write");
    assert!(stdout(&out).contains("2000"), "the table: {}", stdout(&out));
}

#[test]
fn degenerate_updates_give_sensible_answers() {
    // No frames: an empty summary that says so.
    let out = cellbih(&line("update --scene car --animation car --frames 0"));
    assert_ok(&out);
    let text = stdout(&out);
    assert!(text.contains("no frames ran"), "{text}");
    assert!(!text.contains("NaN") && !text.contains("inf"), "{text}");
    let v =
        json("update --scene car --animation car --frames 0 --builder ppe_approx --format json");
    assert!(v["summary"].is_null());
    // The fresh build it compares with is by the same builder.
    assert_eq!(v["sah_after"], v["sah_fresh_build"]);

    // An animation whose geometry the scene does not have.
    for (scene, anim, msg) in [
        ("default", "car", "animation 'car' moves the car's parts"),
        ("car", "cup", "animation 'cup' moves the 'glass'"),
        ("cup", "rtperf", "animation 'rtperf' moves rtPerf's spheres"),
    ] {
        let out = cellbih(&["update", "--scene", scene, "--animation", anim]);
        assert_fails_with(&out, msg);
    }

    // No complete rebuild: said in words, not as a ratio of infinity.
    let out = cellbih(&line(
        "update --scene rtperf:3000 --animation rtperf --frames 4 --seed 4",
    ));
    assert_ok(&out);
    let text = stdout(&out);
    assert!(
        text.contains("complete rebuilds 0 · no complete rebuilds"),
        "{text}"
    );
    assert!(!text.contains("inf"), "{text}");
}

/// Origin and direction up to the ±1e200 the ray file takes, both large at
/// once (their products pass f64::MAX from about 1e154): every path —
/// the host's (packets, fast walk, exact walk), the SPEs' packets and
/// single rays in either precision — gives the same answer, bit for bit;
/// up to 1e15 (the origin within 2^53 times the triangle's size, where
/// the watertight test's offsets to the vertices still resolve it) a hit
/// at t = 1.
#[test]
fn large_origins_and_directions_hit_on_every_path() {
    let scene = text_file("sweep.obj", "v 0 0 0\nv -1 1 0\nv 1 1 0\nf 1 2 3\n");
    let mut rays = String::from("ox,oy,oz,dx,dy,dz,tmin,tmax\n");
    for m in (0..=200).step_by(5) {
        // o + d = (0, 0.5, 0), inside the triangle.
        rays += &format!("1e{},0.5,1e{m},-1e{},0,-1e{m},0,inf\n", m - 1, m - 1);
    }
    let rays = text_file("sweep.rays.csv", &rays);
    let mut answers = Vec::new();
    for extra in [
        &[][..],
        &["--on-cell"][..],
        &["--on-cell", "--packet", "1x1", "--precision", "double"][..],
    ] {
        let out_path = tmp(&format!("sweep{}.hits.csv", answers.len()));
        let o = out_path.to_str().unwrap();
        let args = [
            &["raycast", "--scene", &scene, "--rays", &rays, "--out", o][..],
            extra,
        ];
        assert_ok(&cellbih(&args.concat()));
        let hits = std::fs::read_to_string(&out_path).unwrap();
        for (line, m) in hits.lines().skip(1).zip((0..=200).step_by(5)) {
            if m > 15 {
                continue;
            }
            let f: Vec<&str> = line.split(',').collect();
            assert_eq!(f[1], "0", "{extra:?} missed at 1e{m}: {line}");
            let t: f64 = f[2].parse().unwrap();
            assert!((t - 1.0).abs() < 1e-15, "{extra:?}: {line}");
        }
        answers.push(hits);
    }
    assert!(answers.iter().all(|a| *a == answers[0]), "{answers:?}");
}

#[test]
fn rays_at_the_edges_of_f64() {
    let out_path = tmp("edge.hits.csv");
    let o = out_path.to_str().unwrap();
    // A direction too short to trace, and components near f64::MAX that
    // would overflow the triangle test (a hit at finite t silently
    // missed): each refused by its line. Up to 1e200 they hit.
    for (name, second_ray, says) in [
        (
            "short.rays.csv",
            "0.2,0.2,1,0,0,-1e-320,0,inf",
            "short.rays.csv:3: the direction is too short",
        ),
        (
            "huge.rays.csv",
            "0,1,1e308,0,0,-1e308,0,inf",
            "huge.rays.csv:3: 1e308 is beyond ±1e200",
        ),
    ] {
        let rays = text_file(name, &format!("{ONE_RAY}{second_ray}\n"));
        assert_fails_with(&cellbih(&["raycast", "--rays", &rays, "--out", o]), says);
    }
    let rays = text_file(
        "large.rays.csv",
        "ox,oy,oz,dx,dy,dz,tmin,tmax
0,1,1e200,0,0,-1e200,0,inf
",
    );
    for cell in [&[][..], &["--on-cell"][..]] {
        let out = cellbih(&[&["raycast", "--rays", &rays, "--out", o][..], cell].concat());
        assert_ok(&out);
        let hits = std::fs::read_to_string(&out_path).unwrap();
        assert!(
            hits.lines().nth(1).is_some_and(|l| !l.contains(",-1")),
            "{hits}"
        );
    }
    // With a byte-order mark before the header: read as without.
    let rays = text_file("bom.rays.csv", &format!("\u{feff}{ONE_RAY}"));
    let out = cellbih(&["raycast", "--rays", &rays, "--out", o]);
    assert_ok(&out);
    let hits = std::fs::read_to_string(&out_path).unwrap();
    assert_eq!(hits.lines().count(), 2, "{hits}");
    // A direction whose largest component is normal but tiny: any hit has
    // a finite t in [tmin, tmax].
    let rays = text_file(
        "tiny.rays.csv",
        "ox,oy,oz,dx,dy,dz,tmin,tmax\n0.5,1,8,0,0,-1e-300,0,inf\n",
    );
    let out = cellbih(&["raycast", "--rays", &rays, "--out", o]);
    assert_ok(&out);
    let hits = std::fs::read_to_string(&out_path).unwrap();
    let line = hits.lines().nth(1).unwrap();
    let t = line.split(',').nth(2).unwrap();
    assert!(
        t.is_empty() || t.parse::<f64>().unwrap().is_finite(),
        "{line}"
    );
}

/// Output into a pipe that closes early (`cellbih update … | head -1`)
/// ends the command quietly, as it ends other Unix tools: no panic. (The
/// update prints more than a pipe holds, so it writes after the close.)
#[test]
fn a_closed_pipe_ends_the_command_quietly() {
    use std::io::Read;
    let mut child = crate::common::command(env!("CARGO_BIN_EXE_cellbih"))
        .args([
            "update",
            "--scene",
            "rtperf:400",
            "--animation",
            "rtperf",
            "--frames",
            "3000",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Read one byte, then close our end of the pipe.
    let mut first = [0u8; 1];
    child.stdout.take().unwrap().read_exact(&mut first).unwrap();
    let out = child.wait_with_output().unwrap();
    let err = stderr(&out);
    assert!(!err.contains("panicked"), "{err}");
}

/// A standard output that cannot be written is a one-line error with exit
/// code 1, not a panic, for every command that prints and for an
/// experiment.
#[test]
fn a_full_standard_output_is_a_one_line_error() {
    let full = || {
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap()
    };
    let runs: [(&str, &[&str]); 5] = [
        (env!("CARGO_BIN_EXE_cellbih"), &["info"]),
        (env!("CARGO_BIN_EXE_cellbih"), &["builders"]),
        (
            env!("CARGO_BIN_EXE_cellbih"),
            &["build", "--builder", "spe_bfs"],
        ),
        (
            env!("CARGO_BIN_EXE_cellbih"),
            &[
                "update",
                "--scene",
                "car",
                "--animation",
                "car",
                "--frames",
                "2",
            ],
        ),
        (
            env!("CARGO_BIN_EXE_validate"),
            &["--out", "/tmp/cellbih-full-validate"],
        ),
    ];
    for (exe, args) in runs {
        let out = crate::common::command(exe)
            .args(args)
            .stdout(full())
            .output()
            .unwrap();
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains("cannot write to standard output") && !err.contains("panicked"),
            "{args:?}: {err}"
        );
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    }
}

/// An experiment one of whose scenes does not load fails before any work,
/// names the scene, and leaves the results of an earlier run as they were;
/// an `--out` directory it would have created is not left behind, and an
/// `--out` that is a file is "not a directory".
#[test]
fn an_experiment_with_a_scene_that_does_not_load_fails_and_keeps_earlier_results() {
    let runs = [
        (
            env!("CARGO_BIN_EXE_spe_scaling"),
            "spe_scaling.csv",
            "--max-spes",
        ),
        (env!("CARGO_BIN_EXE_tradeoff"), "tradeoff.csv", "--spes"),
        (
            env!("CARGO_BIN_EXE_sensitivity"),
            "sensitivity.csv",
            "--spes",
        ),
    ];
    for (exe, file, spes) in runs {
        let run = |out: &Path| {
            crate::common::command(exe)
                .args(["--scenes", "default,no-such-scene", spes, "1", "--out"])
                .arg(out)
                .env_remove("CELLBIH_DATA")
                .output()
                .unwrap()
        };
        let dir = tmp(&format!("nothing-{file}"));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(file), "earlier results\n").unwrap();
        let out = run(&dir);
        let err = stderr(&out);
        assert!(!out.status.success(), "{file}: {err}");
        assert!(
            err.starts_with("error: 1 scene of --scenes did not load")
                && err.contains("no-such-scene"),
            "{err}"
        );
        let kept = std::fs::read_to_string(dir.join(file)).unwrap();
        assert_eq!(kept, "earlier results\n", "{file}");

        let fresh = dir.join("fresh/results");
        assert!(!run(&fresh).status.success());
        assert!(!dir.join("fresh").exists(), "{file}: --out was created");

        let plain = dir.join("plain");
        std::fs::write(&plain, "x").unwrap();
        let out = run(&plain);
        let err = stderr(&out);
        assert!(err.contains("plain is not a directory"), "{err}");
    }
}

/// Ctrl-C (SIGINT), `kill`/`timeout` (SIGTERM) and a closed terminal
/// (SIGHUP) in the middle of a run: the command says what ended it, exits
/// with 128 + the signal as a shell reports it (130, 143, 129), and leaves
/// nothing in the output's directory — no half-written file and no hidden
/// temporary one (a signal during a write removes it: `output`'s tests list
/// it while it is written).
#[test]
fn a_signal_leaves_no_file_behind() {
    for (signal, code, said) in [
        ("INT", 130, "interrupted"),
        ("TERM", 143, "terminated (SIGTERM)"),
        ("HUP", 129, "hung up (SIGHUP)"),
    ] {
        let dir = tmp(&format!("signalled-{signal}"));
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("frame.png");
        let child = crate::common::command(env!("CARGO_BIN_EXE_cellbih"))
            .args(["render", "--on-cell", "--width", "1280", "--height", "960"])
            .arg("--out")
            .arg(&out)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(300));
        let kill = Command::new("kill")
            .args([&format!("-{signal}"), &child.id().to_string()])
            .status()
            .unwrap();
        assert!(kill.success());
        let o = child.wait_with_output().unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "SIG{signal}: {err}");
        assert!(err.contains(said), "SIG{signal}: {err}");
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert!(left.is_empty(), "SIG{signal}: {left:?}");
    }
}

/// A new file gets the mode `open(2)` gives it, `0666 & !umask`: under
/// `umask 077` the hits, the image, the trace and an experiment's files are
/// private; an existing file keeps its own mode.
#[test]
fn new_files_follow_the_umask() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tmp("umask");
    std::fs::create_dir_all(&dir).unwrap();
    let rays = text_file("umask.rays.csv", ONE_RAY);
    let d = dir.display();
    let kept = dir.join("kept.csv");
    std::fs::write(&kept, "old").unwrap();
    std::fs::set_permissions(&kept, std::fs::Permissions::from_mode(0o640)).unwrap();
    let bin = env!("CARGO_BIN_EXE_cellbih");
    let exp = env!("CARGO_BIN_EXE_dma_bandwidth");
    let script = format!(
        "umask 077 && {bin} raycast --rays {rays} --out {d}/hits.csv \
         && {bin} raycast --rays {rays} --out {d}/kept.csv \
         && {bin} render --width 8 --height 8 --out {d}/a.png \
         && {bin} build --builder spe_bfs --trace {d}/t.json \
         && {exp} --mib 1 --max-spes 1 --out {d}/exp"
    );
    let out = Command::new("sh").args(["-c", &script]).output().unwrap();
    assert_ok(&out);
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    for f in ["hits.csv", "a.png", "t.json"] {
        assert_eq!(mode(&dir.join(f)), 0o600, "{f}");
    }
    assert_eq!(mode(&kept), 0o640);
    let written: Vec<_> = std::fs::read_dir(dir.join("exp"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert!(!written.is_empty());
    for f in written {
        assert_eq!(mode(&f), 0o600, "{}", f.display());
    }
}
