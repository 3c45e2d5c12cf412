//! Rates a user sets (`--rate`, `--rates`): kept at the precision given
//! or refused, within a stated range, recorded as given, and read from a
//! file as every text input is read.

use crate::common::*;

/// `build --format json` with `extra` (on `spe_bfs` unless it names a
/// builder).
fn build_json(extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["build", "--format", "json"];
    if !extra.contains(&"--builder") {
        args.extend(["--builder", "spe_bfs"]);
    }
    args.extend(extra);
    let out = cellbih(&args);
    assert_ok(&out);
    serde_json::from_slice(&out.stdout).unwrap()
}

fn ms(extra: &[&str]) -> f64 {
    build_json(extra)["simulated_ms"].as_f64().unwrap()
}

/// A bandwidth is kept to six significant digits: a slower memory is
/// slower (never rounded to "free"), a value between two steps of the old
/// grid moves the figure, and the settings record the value as given.
#[test]
fn a_bandwidth_keeps_its_digits_and_a_smaller_one_is_slower() {
    let base = ms(&[]);
    let slow = ms(&["--rate", "memory_bandwidth=0.001"]);
    assert!(slow > 1000.0 * base, "0.001 GB/s: {slow} ms vs {base} ms");
    let json = build_json(&["--rate", "spe_bandwidth=0.001"]);
    let given = &json["settings"]["cell"]["machine_rates"]["spe_bandwidth"];
    assert_eq!(given.as_f64(), Some(0.001), "not recorded as given: {json}");
    // 25.6001 and 25.6002 lie within one step of the old 0.0032 GB/s grid.
    let a = ms(&["--rate", "spe_bandwidth=1.0001"]);
    let b = ms(&["--rate", "spe_bandwidth=1.0002"]);
    assert!(a > b, "{a} vs {b}");
    for bad in ["0.0009", "0", "10001", "0.0010000000001", "nan"] {
        let arg = format!("spe_bandwidth={bad}");
        let out = cellbih(&["build", "--builder", "spe_bfs", "--rate", &arg]);
        assert_fails_with(
            &out,
            &format!("--rate {arg}: a bandwidth in GB/s from 0.001 to 10000"),
        );
    }
    // A ceiling may be given as `cellbih rates` prints its absence.
    let out = cellbih(&["rates", "--rate", "ls_port_bandwidth=unlimited"]);
    assert_ok(&out);
    assert!(
        stdout(&out).contains("ls_port_bandwidth         unlimited * validate"),
        "{}",
        stdout(&out)
    );
}

/// Every rate has a range; outside it, refused by name; a charge that
/// would pass 2^64 cycles is an error, never a wrapped or saturated time.
#[test]
fn rates_outside_their_range_are_refused_and_time_never_wraps() {
    for (rate, value) in [
        ("spe_partition_item", "18446744073709551615"),
        ("spe_partition_item", "1000000000000000000"),
        ("dma_latency_cycles", "1099511627777"),
    ] {
        let arg = format!("{rate}={value}");
        let out = cellbih(&["build", "--builder", "spe_bfs", "--rate", &arg]);
        assert_fails_with(
            &out,
            &format!("--rate {arg}: a whole number of cycles from 0 to 1099511627776 (2^40)"),
        );
    }
    // At the top of the range a build's time is large and right: twice
    // the rate, twice the partition's share (a wrapped or saturated sum
    // would not double).
    let top = ms(&["--rate", "spe_partition_item=1099511627776"]);
    let half = ms(&["--rate", "spe_partition_item=549755813888"]);
    assert!((top / half - 2.0).abs() < 0.01, "{half} ms, then {top} ms");
    assert!(top > 1e9, "{top} ms");
}

/// Rate messages name the option and the rate, never an internal prefix.
#[test]
fn rate_messages_name_what_was_given() {
    for (arg, says) in [
        ("=5", "--rate =5: the rate's name is missing before '='"),
        (
            "dma_latency_cycles=x",
            "--rate dma_latency_cycles=x: a whole number of cycles",
        ),
        ("nope=1", "--rate no rate named nope"),
    ] {
        let out = cellbih(&["build", "--builder", "spe_bfs", "--rate", arg]);
        assert_fails_with(&out, says);
        assert!(!stderr(&out).contains("configuration:"), "{}", stderr(&out));
    }
    let out = cellbih(&[
        "build",
        "--builder",
        "spe_bfs",
        "--mode",
        "functional",
        "--rate",
        "spe_job=1",
    ]);
    assert_fails_with(&out, "--rate does not apply");
}

/// A rates file: bounded like every text input, a byte-order mark read,
/// a name set twice an error naming both lines, an unknown name named
/// with its file and line, `-` the standard input.
#[test]
fn a_rates_file_is_read_like_every_text_input() {
    let out = run_limited(
        env!("CARGO_BIN_EXE_cellbih"),
        &["build", "--builder", "spe_bfs", "--rates", "/dev/zero"],
        std::time::Duration::from_secs(20),
    );
    assert_fails_with(&out, "--rates /dev/zero: ");
    let bom = text_file("bom.rates", "\u{feff}spe_partition_item = 200\n");
    assert_eq!(
        ms(&["--rates", &bom]),
        ms(&["--rate", "spe_partition_item=200"])
    );
    let twice = text_file("twice.rates", "spe_job = 1\n# x\nspe_job = 2\n");
    assert_fails_with(
        &cellbih(&["build", "--builder", "spe_bfs", "--rates", &twice]),
        "twice.rates:3: spe_job is set again (first at ",
    );
    let out = cellbih(&["build", "--builder", "spe_bfs", "--rates", &twice]);
    assert!(stderr(&out).contains("twice.rates:1)"), "{}", stderr(&out));
    let unknown = text_file("unknown.rates", "spe_job = 1\nspe_jbo = 2\n");
    assert_fails_with(
        &cellbih(&["build", "--builder", "spe_bfs", "--rates", &unknown]),
        "unknown.rates:2: no rate named spe_jbo",
    );
    let mut child = command(env!("CARGO_BIN_EXE_cellbih"))
        .args([
            "build",
            "--builder",
            "spe_bfs",
            "--format",
            "json",
            "--rates",
            "-",
        ])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    use std::io::Write;
    (child.stdin.take().unwrap())
        .write_all(b"spe_partition_item = 200\n")
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert_ok(&out);
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        doc["simulated_ms"].as_f64().unwrap(),
        ms(&["--rate", "spe_partition_item=200"])
    );
}

/// Every rate `cellbih rates` lists moves something, and says what; a
/// command refuses a rate it never charges, naming it; the software
/// cache's rates are charged by every software cache (the job cache
/// too); the lock lines' claim is a rate; what was given is recorded.
#[test]
fn every_listed_rate_moves_what_it_says() {
    let listed = cellbih(&["rates", "--format", "json"]);
    assert_ok(&listed);
    let doc: serde_json::Value = serde_json::from_slice(&listed.stdout).unwrap();
    let names: Vec<&str> = (doc["machine"].as_array().unwrap().iter())
        .chain(doc["kernels"].as_array().unwrap())
        .map(|r| r["name"].as_str().unwrap())
        .collect();
    assert!(names.contains(&"claim_cycles") && !names.contains(&"putllc_cycles"));
    assert!(names.contains(&"cache.lookup") && !names.contains(&"cast.cache.lookup"));
    for r in doc["machine"]
        .as_array()
        .unwrap()
        .iter()
        .chain(doc["kernels"].as_array().unwrap())
    {
        assert!(r["moves"].is_string(), "{r}");
    }
    for (args, says) in [
        (
            vec![
                "build",
                "--builder",
                "spe_bfs",
                "--rate",
                "cast.node_step=5",
            ],
            "--rate cast.node_step: build never charges it",
        ),
        (
            vec!["build", "--builder", "spe_bfs", "--rate", "eib_bandwidth=5"],
            "--rate eib_bandwidth: build never charges it",
        ),
        (
            vec!["build", "--builder", "spe_bfs", "--rate", "update.route=5"],
            "--rate update.route: build never charges it",
        ),
        (
            vec![
                "render",
                "--builder",
                "spe_bfs",
                "--out",
                "-",
                "--rate",
                "cast.node_step=5",
            ],
            "render without --on-cell never charges it",
        ),
    ] {
        assert_fails_with(&cellbih(&args), says);
    }
    let shared = |extra: &[&str]| {
        let base = ["--builder", "spe_bfs_shared", "--job-cache", "8"];
        ms(&[&base[..], extra].concat())
    };
    assert!(shared(&["--rate", "cache.lookup=2800"]) > shared(&[]));
    assert!(shared(&["--rate", "claim_cycles=20000"]) > shared(&[]));
    let doc = build_json(&["--mailboxes", "ps3-kernel", "--rate", "mailbox_os_cycles=5"]);
    assert_eq!(doc["settings"]["cell"]["mailboxes"], "ps3-kernel", "{doc}");
}
