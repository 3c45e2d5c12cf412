//! An experiment's files as one set: moved into place whole or not at
//! all whatever moment a signal comes, staging left by a dead process
//! removed by the next run, a failed write named by the user's path and
//! no "written" before it, and the files of the set it replaces gone.

use std::path::Path;
use std::process::Stdio;

use crate::common::*;

const EXP: &str = env!("CARGO_BIN_EXE_dma_bandwidth");

/// The `bytes_streamed` of the set's CSV and of its JSON (which run made
/// each), or `None` where the file is absent.
fn made_by(dir: &Path) -> (Option<String>, Option<String>) {
    let csv = std::fs::read_to_string(dir.join("dma_bandwidth.csv")).ok();
    let csv = csv.map(|t| {
        t.lines()
            .nth(1)
            .unwrap()
            .split(',')
            .nth(3)
            .unwrap()
            .to_string()
    });
    let doc = std::fs::read_to_string(dir.join("dma_bandwidth.json")).ok();
    let doc = doc.map(|t| serde_json::from_str::<serde_json::Value>(&t).unwrap());
    (csv, doc.map(|d| d["rows"][0]["bytes_streamed"].to_string()))
}

/// Hidden files left in `dir` besides the set's record.
fn leftovers(dir: &Path) -> Vec<String> {
    (std::fs::read_dir(dir).unwrap())
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.') && n != ".dma_bandwidth.set")
        .collect()
}

/// SIGTERM at moments spread over a run: each run ends with 0 or 143,
/// never names its staging, and leaves one whole set (the old one or the
/// new one) with nothing hidden beside it.
#[test]
fn a_signal_at_any_moment_leaves_one_whole_set() {
    let dir = tmp("signal-sets");
    let d = dir.to_str().unwrap();
    assert_ok(
        &command(EXP)
            .args(["--mib", "1", "--max-spes", "1", "--out", d])
            .output()
            .unwrap(),
    );
    let old = made_by(&dir);
    // How long a whole run takes here and now: the signals are spread
    // over twice that.
    let started = std::time::Instant::now();
    let args = ["--mib", "2", "--max-spes", "1", "--out", d];
    assert_ok(&command(EXP).args(args).output().unwrap());
    let whole = started.elapsed();
    assert_ok(
        &command(EXP)
            .args(["--mib", "1", "--max-spes", "1", "--out", d])
            .output()
            .unwrap(),
    );
    let mut outcomes = std::collections::BTreeSet::new();
    for k in 0..30u32 {
        let child = command(EXP)
            .args(["--mib", "2", "--max-spes", "1", "--out", d])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(whole * 2 * k / 30);
        unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
        let out = child.wait_with_output().unwrap();
        let err = stderr(&out);
        // 0: the set was in place first; 143: the handler ended it; no
        // code: the signal came before the handler was set, nothing begun.
        assert!(
            matches!(out.status.code(), Some(0 | 143) | None),
            "{:?}: {err}",
            out.status
        );
        assert!(!err.contains(".cellbih-run"), "names its staging: {err}");
        let now = made_by(&dir);
        assert_eq!(now.0, now.1, "a mixed set after {err}");
        assert!(now == old || now.0.as_deref() == Some("2097152"), "{now:?}");
        assert!(
            leftovers(&dir).is_empty(),
            "{:?} after {err}",
            leftovers(&dir)
        );
        outcomes.insert(out.status.code());
    }
    // The moments reach both ends: some runs ended before the set was
    // moved, some after.
    let interrupted = outcomes.contains(&Some(143)) || outcomes.contains(&None);
    assert!(outcomes.contains(&Some(0)) && interrupted, "{outcomes:?}");
}

/// A staging directory of a process that no longer runs is removed by the
/// next run into that directory, and said.
#[test]
fn staging_left_by_a_dead_process_is_removed_and_said() {
    let dir = tmp("stale-staging");
    std::fs::create_dir_all(&dir).unwrap();
    // A process that has ended: its id is free (until reused).
    let mut gone = std::process::Command::new("true").spawn().unwrap();
    let pid = gone.id();
    gone.wait().unwrap();
    let stale = dir.join(format!(".cellbih-run-{pid}"));
    std::fs::create_dir_all(&stale).unwrap();
    std::fs::write(stale.join(".tmpX"), "half").unwrap();
    let out = command(EXP)
        .args([
            "--mib",
            "1",
            "--max-spes",
            "1",
            "--out",
            dir.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert_ok(&out);
    assert!(!stale.exists());
    assert!(
        stderr(&out).contains(&format!("removed {}", stale.display())),
        "{}",
        stderr(&out)
    );
}

/// A write of the set that fails (a file-size limit, as a full disk) names
/// the file by its place in `--out`, and nothing is said to be written.
#[test]
fn a_failed_write_names_the_users_path_and_says_nothing_written() {
    let dir = tmp("limited-set");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("dma_bandwidth.csv"), "old\n").unwrap();
    let script = format!(
        "ulimit -f 8 && exec {EXP} --mib 1 --max-spes 1 --out {}",
        dir.display()
    );
    let out = command("sh").args(["-c", &script]).output().unwrap();
    let err = stderr(&out);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains(&format!("error: {}/dma_bandwidth.", dir.display()))
            && err.contains(": cannot write: File too large"),
        "{err}"
    );
    assert!(
        !err.contains(".cellbih-run") && !err.contains("written:"),
        "{err}"
    );
}

/// The set names its files: a run whose set has fewer files removes those
/// of the set it replaces that it does not write, and says so; a file the
/// experiment never wrote stays.
#[test]
fn the_files_of_a_replaced_set_go_with_it() {
    let dir = tmp("replaced-set");
    let d = dir.to_str().unwrap();
    let exe = env!("CARGO_BIN_EXE_spe_scaling");
    let run = |scenes: &str| {
        let args = [
            "--scenes",
            scenes,
            "--max-spes",
            "2",
            "--defaults-only",
            "--out",
            d,
        ];
        let out = command(exe).args(args).output().unwrap();
        assert_ok(&out);
        stderr(&out)
    };
    run("rtperf:2000,rtperf:3000");
    std::fs::write(dir.join("mine.txt"), "kept").unwrap();
    let plot = dir.join("spe_scaling_rtperf_3000_1.svg");
    assert!(plot.exists());
    let said = run("rtperf:2000");
    assert!(!plot.exists(), "a stale plot stayed");
    assert!(dir.join("spe_scaling_rtperf_2000_1.svg").exists());
    assert!(dir.join("mine.txt").exists());
    assert!(said.contains("spe_scaling_rtperf_3000_1.svg"), "{said}");
}
