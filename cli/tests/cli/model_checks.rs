//! The machine model's checks, run as a user runs them: `validate`
//! (published PS3 figures, fitted apart from held out, and SPU kernels
//! timed on hardware beside their instruction counts) and `sensitivity`
//! (how the headline speedups move across every unpinned rate's band),
//! and `cellbih rates` (every rate a run may set).

use crate::common::stderr;
use cellbih::registry::BuilderKind;

use crate::common::{assert_fails_with, assert_ok, cellbih};

/// The source files under `dir` (of the workspace) that hold rates: each
/// that defines a rate table, or the machine's `CostModel`.
fn rate_sources(dir: &str) -> Vec<(std::path::PathBuf, String)> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut todo = vec![root.join(dir)];
    let mut found = Vec::new();
    while let Some(dir) = todo.pop() {
        for e in std::fs::read_dir(&dir).unwrap().map(Result::unwrap) {
            let path = e.path();
            if path.is_dir() {
                todo.push(path);
            } else if path.extension().is_some_and(|x| x == "rs") {
                let text = std::fs::read_to_string(&path).unwrap();
                if text.contains("rate_table!(") || text.contains("pub struct CostModel") {
                    found.push((path, text));
                }
            }
        }
    }
    found
}

/// Whether `text` holds `number` as a number of its own (not a part of
/// a longer one: 22 is not in 22.13, nor 150 in 1,500).
fn holds_number(text: &str, number: &str) -> bool {
    text.match_indices(number).any(|(at, _)| {
        let before = text[..at].chars().next_back();
        let mut after = text[at + number.len()..].chars();
        let digit = |c: Option<char>| c.is_some_and(|c| c.is_ascii_digit());
        let (next, then) = (after.next(), after.next());
        let part_of_longer = digit(before)
            || before.is_some_and(|c| c == '.' || c == ',')
            || digit(next)
            || next.is_some_and(|c| c == '.' || c == ',') && digit(then);
        !part_of_longer
    })
}

/// A figure that set a rate is fitted, never held out: no held-out row's
/// published figure appears as a number in a comment of a file that
/// holds rates of its kind (where a rate's source is written): the
/// machine's figures in the machine's, the kernels' in the library's.
fn no_held_out_figure_sets_a_rate(rows: &[serde_json::Value]) {
    let (machine, kernels) = (rate_sources("cell/src"), rate_sources("src"));
    assert!(
        !machine.is_empty() && kernels.len() >= 4,
        "{}",
        kernels.len()
    );
    assert!(holds_number("about 22.0 GB/s", "22.0") && !holds_number("22.13", "22"));
    for r in rows.iter().filter(|r| r["role"] == "held-out") {
        let sources = match r["section"].is_null() {
            true => &machine,
            false => &kernels,
        };
        let v = r["published"].as_f64().unwrap();
        let mut forms = vec![format!("{v}"), format!("{v:.1}"), format!("{v:.2}")];
        forms.dedup();
        for (path, text) in sources {
            for (n, line) in text.lines().enumerate() {
                let Some(at) = line.find("//") else { continue };
                let cited = forms.iter().find(|f| holds_number(&line[at..], f));
                assert!(
                    cited.is_none(),
                    "the held-out figure {} ({}) is cited where a rate is set: {}:{}: {line}",
                    cited.unwrap(),
                    r["figure"],
                    path.display(),
                    n + 1
                );
            }
        }
    }
}

/// `validate`: on the measured model every published PS3 figure is
/// reproduced within its tolerance (exit 0, each row's ratio inside it,
/// the files written); on the legacy model — every figure before the validation against real PS3s
/// — the same probes leave their tolerances and the run fails naming
/// them (the memory interface's ceiling, the hot spot on one local store,
/// the lock lines).
#[test]
fn validate_holds_the_measured_model_to_every_published_figure() {
    let exe = env!("CARGO_BIN_EXE_validate");
    let dir = crate::common::tmp("validate");
    let out = crate::common::command(exe)
        .args(["--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("validate.json")).unwrap()).unwrap();
    let rows = doc["rows"].as_array().unwrap();
    assert!(rows.len() >= 20, "{} figures", rows.len());
    // Every row that gates the run passes; the PPE's sort is reported
    // beside where it puts the update's rates in their bands.
    for r in rows.iter().filter(|r| r["gates"] != false) {
        let (ratio, tol) = (
            r["ratio"].as_f64().unwrap(),
            r["tolerance"].as_f64().unwrap(),
        );
        assert!(
            (ratio - 1.0).abs() <= tol.max(0.01) && r["pass"] == true,
            "{r}"
        );
    }
    let csv = std::fs::read_to_string(dir.join("validate.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + rows.len());
    // The fitted figures (each names the rate it set) and the held-out
    // ones are printed apart, each group with its pass count.
    let machine = |r: &&serde_json::Value| r["section"].is_null();
    let fitted = (rows.iter().filter(machine))
        .filter(|r| r["role"] == "fitted")
        .count();
    let held_out = (rows.iter().filter(machine))
        .filter(|r| r["role"] == "held-out")
        .count();
    let kernels = rows.iter().filter(|r| r["section"] == "compute").count();
    let of_compiled = |r: &&serde_json::Value| {
        r["section"] == "compute" && r["sets"].as_str().is_some_and(|s| s.contains("compiled"))
    };
    let compiled_kernels = rows.iter().filter(of_compiled).count();
    let ppe: Vec<_> = rows.iter().filter(|r| r["section"] == "ppe").collect();
    assert_eq!(fitted + held_out + kernels + ppe.len(), rows.len());
    assert!(
        fitted > 0 && held_out > 0,
        "{fitted} fitted, {held_out} held out"
    );
    for r in rows {
        let role = r["role"].as_str().unwrap();
        assert!(["fitted", "bounding", "held-out"].contains(&role), "{r}");
        assert_eq!(r["sets"].is_string(), role != "held-out", "{r}");
    }
    no_held_out_figure_sets_a_rate(rows);
    let text = String::from_utf8_lossy(&out.stdout);
    for line in [
        format!("{fitted} of {fitted} pass"),
        format!("{held_out} of {held_out} pass"),
        format!("{0} of {0} pass", kernels - compiled_kernels),
        format!("{compiled_kernels} of {compiled_kernels} pass"),
    ] {
        assert!(text.contains(&line), "{line}: {text}");
    }
    for line in text.lines() {
        assert!(
            line.chars().count() <= 80,
            "{} columns: {line}",
            line.chars().count()
        );
    }
    let (a, b) = (
        text.find("figures that set a rate"),
        text.find("held-out figures"),
    );
    assert!(a.is_some() && b.is_some() && a < b, "{text}");
    // The compute section: SPU kernels timed on hardware beside their
    // instruction counts (a 12-instruction loop and an unhinted taken
    // branch: 12 + 18 cycles), and the count times the derivation factor.
    let compute: Vec<_> = rows.iter().filter(|r| r["section"] == "compute").collect();
    assert!(compute.len() >= 5, "{} compute kernels", compute.len());
    let branch = (compute.iter())
        .find(|r| r["source"] == "cellmark spu_branch_kernel.S")
        .unwrap();
    assert_eq!(branch["emulated"], 30.0, "{branch}");
    for r in compute
        .iter()
        .filter(|r| r["ratio_times_derivation_factor"].is_number())
    {
        let x1 = r["ratio"].as_f64().unwrap();
        let x4 = r["ratio_times_derivation_factor"].as_f64().unwrap();
        assert!((x1 / x4 - 4.0).abs() < 0.01, "{r}");
    }
    // Codeplay's quicksort through the software cache, judged in the
    // paper's class: its instructions at their count alone run it faster.
    let sorts: Vec<_> = (compute.iter())
        .filter(|r| r["figure"].as_str().unwrap().starts_with("quicksort"))
        .collect();
    assert_eq!(sorts.len(), 2);
    for r in sorts {
        assert!(r["at_count"].as_f64() < r["emulated"].as_f64(), "{r}");
        // The class factors it admits: the paper's 4 among them, and a
        // range wide enough that it tells the classes apart only weakly.
        let admits: Vec<f64> = (r["admits_factor"].as_array().unwrap().iter())
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert!(admits[0] < 4.0 && 4.0 < admits[1], "{r}");
    }
    // The compiled class's kernels: fitted, each met at its own factor.
    let compiled: Vec<_> = (compute.iter())
        .filter(|r| r["sets"].as_str().is_some_and(|s| s.contains("compiled")))
        .collect();
    assert_eq!(compiled.len(), 2, "{compiled:?}");
    // The PPE: the latencies its loads are priced at, and the PPU's sort
    // priced the same way, a lower bound (Codeplay's is tuned), with the
    // rates it implies beside their bands.
    assert!(ppe.len() >= 5, "{ppe:?}");
    let sort = ppe.iter().find(|r| r["role"] == "held-out").unwrap();
    assert_eq!(sort["gates"], false, "{sort}");
    assert_eq!(sort["bound"], "lower", "{sort}");
    let ratio = sort["ratio"].as_f64().unwrap();
    assert_eq!(sort["pass"], ratio >= 1.0, "{sort}");
    assert_eq!(sort["update_rates_implied"].as_array().unwrap().len(), 4);
    assert!(text.contains("the plain sort at"), "{text}");

    let legacy = crate::common::command(exe)
        .args(["--model", "legacy", "--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    let err = stderr(&legacy);
    assert!(!legacy.status.success(), "the legacy model passed: {err}");
    for figure in [
        "16 KiB gets, 2 in flight",
        "5 SPEs reading SPE 0's local store",
        "putlluc on one line",
        "6 SPEs putting 32 bytes into one line",
        "handing one lock line round a ring",
    ] {
        assert!(err.contains(figure), "{figure}: {err}");
    }
}

/// `sensitivity`: a row for the rates as calibrated and one for each end
/// of every uncertain rate's band (each machine estimate, each kernel rate
/// the registry marks uncertain), each with a speedup per headline (every
/// multi-SPE builder of the registry on each SPE count); the calibrated
/// row moves nothing, and moving a rate moves some headline.
#[test]
fn sensitivity_moves_every_uncertain_rate_across_its_band() {
    use cellbih::registry::BuilderKind;
    let exe = env!("CARGO_BIN_EXE_sensitivity");
    let dir = crate::common::tmp("sensitivity");
    let out = crate::common::command(exe)
        .args(crate::common::fill(
            "--scenes default --spes 2,6 --out {}",
            &[dir.to_str().unwrap()],
        ))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        assert!(
            line.chars().count() <= 80,
            "{} columns: {line}",
            line.chars().count()
        );
    }
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("sensitivity.json")).unwrap())
            .unwrap();
    let rows = doc["rows"].as_array().unwrap();
    use cellbih::cell::CostModel;
    let uncertain = CostModel::ESTIMATES.len()
        + BuilderKind::uncertain_rates(cellbih::kernels::rates::Code::Paper).len();
    // The rates as calibrated, each rate alone at each end, the programs
    // started as OS thread groups, the 4 corners.
    assert_eq!(rows.len(), 1 + 2 * uncertain + 1 + 4);
    let group = &rows[1 + 2 * CostModel::ESTIMATES.len()];
    assert_eq!(group["rate"], "spe_start_cycles", "{group}");
    assert!(group["largest_move"].as_f64().unwrap() < 0.0, "{group}");
    let heads = 2 * BuilderKind::ALL.iter().filter(|b| b.multi_spe()).count();
    for r in rows {
        assert_eq!(r["speedups"].as_array().unwrap().len(), heads, "{r}");
    }
    assert_eq!(rows[0]["largest_move"], 0.0);
    // Every rate moves some headline at one end of its band at least (a
    // rate whose override did not apply would move nothing), but for the
    // rates no multi-SPE build charges with the paper's tree, which move
    // nothing at all (so that the list cannot go stale).
    const NOT_CHARGED: [&str; 10] = [
        "ppe_atomic_cycles",  // the PPE takes no lock line in these builds
        "ppe_memory_cycles",  // the PPE's loads: its builds and updates only
        "ppe_node",           // the PPE builders' per-node rate
        "spe_bin_item",       // binned SAH only
        "spe_sah_bin",        // binned SAH only
        "ppe_sah_bin",        // binned SAH on the PPE only
        "ppe_bounds_item",    // the PPE builders' bounds pass
        "spe_find_slot",      // the update's search on the SPEs only
        "spe_find_moved",     // the update's search on the SPEs only
        "ppe_partition_item", // the naive PPE build only
    ];
    let mut largest: std::collections::BTreeMap<String, f64> = Default::default();
    for r in (rows[1..2 + 2 * uncertain].iter()).filter(|r| r["rate"] != "spe_start_cycles") {
        let rate = r["rate"].as_str().unwrap();
        let name = rate.split(" (").next().unwrap().to_string();
        let moved = r["largest_move"].as_f64().unwrap().abs();
        let m = largest.entry(name).or_insert(0.0);
        *m = m.max(moved);
    }
    assert_eq!(largest.len(), uncertain);
    for (name, moved) in &largest {
        match NOT_CHARGED.contains(&name.as_str()) {
            true => assert_eq!(*moved, 0.0, "{name} moves a headline now"),
            false => assert!(*moved > 0.0, "{name} moves no headline at either end"),
        }
    }
    // A band per headline: its speedup as calibrated inside it, its ends
    // the least and most over every variant.
    let bands = doc["bands"].as_array().unwrap();
    assert_eq!(bands.len(), heads);
    for (h, b) in bands.iter().enumerate() {
        let (at, low, high) = (
            b["speedup"].as_f64().unwrap(),
            b["low"].as_f64().unwrap(),
            b["high"].as_f64().unwrap(),
        );
        assert!(low <= at && at <= high, "{b}");
        let seen: Vec<f64> = (rows.iter())
            .map(|r| r["speedups"][h]["speedup"].as_f64().unwrap())
            .collect();
        assert_eq!(
            low,
            seen.iter().copied().fold(f64::INFINITY, f64::min),
            "{b}"
        );
        assert_eq!(
            high,
            seen.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            "{b}"
        );
    }
    assert!(
        bands.iter().any(|b| b["low"] != b["high"]),
        "no band is wider than a point"
    );
}

/// `cellbih rates` lists every rate a run may set — each machine rate of
/// the cost model and each rate of the library's tables — at its value in
/// the class asked for, marks the ones moved, and fits 80 columns.
#[test]
fn rates_lists_every_rate_at_its_value_in_the_class() {
    use cellbih::kernels::rates::Code;
    let json = |extra: &[&str]| -> serde_json::Value {
        let mut args = vec!["rates", "--format", "json"];
        args.extend(extra);
        let out = cellbih(&args);
        assert_ok(&out);
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let names = |doc: &serde_json::Value, key: &str| -> Vec<String> {
        (doc[key].as_array().unwrap().iter())
            .map(|r| r["name"].as_str().unwrap().to_string())
            .collect()
    };
    let paper = json(&[]);
    let machine: Vec<&str> = cellbih::cell::CostModel::RATES
        .iter()
        .map(|r| r.name)
        .collect();
    assert_eq!(names(&paper, "machine"), machine);
    let every: Vec<&str> = (BuilderKind::every_rate(Code::Paper).iter())
        .map(|r| r.name)
        .collect();
    assert_eq!(names(&paper, "kernels"), every);
    let cycles = |doc: &serde_json::Value, name: &str| {
        (doc["kernels"].as_array().unwrap().iter())
            .find(|r| r["name"] == name)
            .map(|r| r["cycles"].as_u64().unwrap())
            .unwrap()
    };
    assert_eq!(cycles(&paper, "spe_partition_item"), 161);
    let tuned = json(&["--code", "tuned"]);
    assert_eq!(cycles(&tuned, "spe_partition_item"), 44);
    assert!(cycles(&tuned, "spe_morton.key_bit") < cycles(&paper, "spe_morton.key_bit"));
    let compiled = json(&["--code", "compiled"]);
    assert_eq!(cycles(&compiled, "spe_partition_item"), 139);
    let moved = json(&[
        "--rate",
        "spe_job=7",
        "--rate",
        "memory_shared_bandwidth=20",
    ]);
    assert_eq!(cycles(&moved, "spe_job"), 7);
    let is_moved = |key: &str, name: &str| {
        (moved[key].as_array().unwrap().iter())
            .find(|r| r["name"] == name)
            .map(|r| r["moved"] == true)
            .unwrap()
    };
    assert!(is_moved("kernels", "spe_job") && is_moved("machine", "memory_shared_bandwidth"));
    assert!(!is_moved("kernels", "spe_bin_item") && !is_moved("machine", "memory_bandwidth"));
    let text = cellbih(&["rates", "--rate", "spe_job=7"]);
    assert_ok(&text);
    let text = String::from_utf8_lossy(&text.stdout).to_string();
    assert!(text.lines().all(|l| l.chars().count() <= 80), "{text}");
    assert!(text.contains("2.75-8.4 (cellmark PPE)") && text.contains("*: moved"));
    assert_fails_with(
        &cellbih(&["rates", "--rate", "nope=1"]),
        "no rate named nope",
    );
}

/// The fitted rates' bands are the spread of their fits: `table1 --fits`
/// refits each on every real-mesh cell of its column, and `cellbih rates`
/// shows each fitted rate's band as the least and the most of them, the
/// rate as fitted inside it.
#[test]
fn a_fitted_rates_band_is_the_spread_of_its_fits() {
    let Some(data) = crate::common::data_dir() else {
        eprintln!(
            "a_fitted_rates_band_is_the_spread_of_its_fits: CELLBIH_DATA is not set: did NOT run"
        );
        return;
    };
    let dir = crate::common::tmp("table1-fits");
    let out = crate::common::command(env!("CARGO_BIN_EXE_table1"))
        .args(["--fits", "--data", data.to_str().unwrap(), "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert_ok(&out);
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("table1_fits.json")).unwrap())
            .unwrap();
    let rates = cellbih(&["rates", "--format", "json"]);
    assert_ok(&rates);
    let rates: serde_json::Value = serde_json::from_slice(&rates.stdout).unwrap();
    let rows = doc["rows"].as_array().unwrap();
    for rate in ["ppe_partition_item", "spe_partition_item"] {
        let fits: Vec<u64> = (rows.iter())
            .filter(|r| r["rate"] == rate)
            .map(|r| r["fit"].as_u64().unwrap())
            .collect();
        assert_eq!(
            fits.len(),
            2,
            "{rate}: a fit on the bunny and on the dragon"
        );
        let listed = (rates["kernels"].as_array().unwrap().iter())
            .find(|r| r["name"] == rate)
            .unwrap();
        // The band holds the fits and the rate as fitted.
        let at = listed["cycles"].as_u64().unwrap();
        let (low, high) = (
            fits.iter().min().unwrap().min(&at),
            fits.iter().max().unwrap().max(&at),
        );
        assert_eq!(
            listed["band"],
            format!("{low}-{high} (Table 1's fits)"),
            "{rate}"
        );
        assert!(
            fits.iter().any(|f| f != &at),
            "{rate}: every fit is the rate"
        );
    }
    let tuned = crate::common::command(env!("CARGO_BIN_EXE_table1"))
        .args([
            "--fits",
            "--code",
            "tuned",
            "--data",
            data.to_str().unwrap(),
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    assert_fails_with(&tuned, "derived, not fitted");
}
