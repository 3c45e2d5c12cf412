//! Refactorings keep every simulated cycle and every tree: each run below
//! (every builder of the registry, with the paper's settings, the quality
//! knobs it builds and each knob of its table moved once, on the default
//! scene; every builder on the bunny) is compared with a recording, on
//! both machine models: `tests/golden/runs.txt` (the default, validated
//! model) and `tests/golden/runs-legacy.txt` (the model before the
//! validated one: its machine rules, with the PPE's costs both share).
//!
//! When the machine model changes on purpose, re-record with
//! `CELLBIH_RECORD=1 CELLBIH_DATA=../shared/data cargo test --release
//! --test unchanged` and say in the commit which figures moved and why;
//! recording without the data directory is refused (the bunny's runs would
//! drop out).

use std::collections::BTreeMap;

use cellbih::bih::{Bih, BihConfig, SplitChoice};
use cellbih::cell::{CellConfig, CostModel};
use cellbih::registry::{Build, BuildReport, BuilderKind};
use cellbih::scene::{self, Scene};
use cellbih::strategy::Knobs;

/// FNV-1a over the node array's bytes and the triangle ids: two trees with
/// the same digest are the same tree (nodes and leaf order).
fn digest(bih: &Bih) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let nodes: &[u8] = bytemuck::cast_slice(&bih.nodes);
    let ids: &[u8] = bytemuck::cast_slice(&bih.prim_ids);
    for &b in nodes.iter().chain(ids) {
        h = (h ^ b as u64).wrapping_mul(0x100_0000_01b3);
    }
    h
}

fn line(r: &BuildReport) -> String {
    let cycles = r.simulated.as_ref().map_or(0, |s| s.run.cycles.0);
    format!("{cycles} {:016x}", digest(&r.bih))
}

/// Each run's label (the `cellbih build` options it stands for) and its
/// cycles and tree digest.
fn runs(cost: &CostModel) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut record = |label: String, r: BuildReport| {
        assert!(
            out.insert(label.clone(), line(&r)).is_none(),
            "{label} twice"
        );
    };
    let default = scene::load("default", None).unwrap();
    // The host's parallel builders on two threads on every machine: their
    // tree is the serial builder's on any number, but the order of the
    // triangles within a leaf may differ between one thread and more
    // (host_morton's key order).
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let build = |s: &Scene, b: BuilderKind, cfg: &BihConfig, spes: usize, k: &Knobs| {
        let mut cell = CellConfig::ps3().with_spes(spes);
        cell.cost = cost.clone();
        let run = || Build::new(b).with_tree(*cfg).on(&cell).with_knobs(k).run(s);
        match b.host_threads() {
            true => two.install(run),
            false => run(),
        }
        .unwrap_or_else(|e| panic!("{b}: {e}"))
    };
    let d = Knobs::default();
    let quality = BihConfig {
        split: SplitChoice::BinnedSah {
            bins: 16,
            above: 40,
        },
        empty_cut: Some(10),
        ..BihConfig::DEFAULT
    };
    for &b in BuilderKind::ALL {
        let paper = BihConfig::DEFAULT;
        record(format!("default {b}"), build(&default, b, &paper, 6, &d));
        if b.multi_spe() {
            for spes in [1, 8] {
                let label = format!("default {b} --spes {spes}");
                record(label, build(&default, b, &paper, spes, &d));
            }
        }
        if b.builds(&quality) {
            let label = format!("default {b} --split sah --sah-above 40 --empty-cut 10");
            record(label, build(&default, b, &quality, 6, &d));
        }
        // Each knob of the builder's table moved once, to its first sweep
        // value.
        for &knob in b.knobs() {
            let k = Knobs::default().with(knob, knob.sweep[0]).unwrap();
            let label = format!("default {b} {}", knob.spelled(knob.sweep[0]));
            record(label, build(&default, b, &BihConfig::DEFAULT, 6, &k));
        }
    }
    if let Some(dir) = scene::data_dir(None) {
        let bunny = scene::load("bunny", Some(&dir)).unwrap();
        for &b in BuilderKind::ALL {
            record(
                format!("bunny {b}"),
                build(&bunny, b, &BihConfig::DEFAULT, 6, &d),
            );
        }
    }
    out
}

#[test]
fn every_builder_keeps_its_cycles_and_its_tree() {
    let golden = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden/runs.txt");
    compare_with(golden, &CostModel::ps3());
}

#[test]
fn every_builder_keeps_its_cycles_and_its_tree_on_the_legacy_model() {
    let golden = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden/runs-legacy.txt");
    compare_with(golden, &CostModel::ps3_legacy());
}

fn compare_with(path: &str, cost: &CostModel) {
    let now = runs(cost);
    if std::env::var_os("CELLBIH_RECORD").is_some() {
        // Without the data directory the bunny's runs would silently drop
        // out of the recording.
        assert!(
            now.keys().any(|k| k.starts_with("bunny")),
            "recording refused: CELLBIH_DATA is not set, so the bunny's runs would be \
             dropped from {path}; record with CELLBIH_DATA=../shared/data"
        );
        let text: String = (now.iter()).map(|(k, v)| format!("{k}: {v}\n")).collect();
        std::fs::write(path, text).unwrap();
        return;
    }
    let text = std::fs::read_to_string(path).unwrap();
    let golden: BTreeMap<&str, &str> = (text.lines()).filter_map(|l| l.split_once(": ")).collect();
    let mut differ = Vec::new();
    for (label, got) in &now {
        match golden.get(label.as_str()) {
            Some(want) if want == got => {}
            Some(want) => differ.push(format!("{label}: recorded {want}, now {got}")),
            None => differ.push(format!("{label}: not recorded")),
        }
    }
    let bunny = now.keys().any(|k| k.starts_with("bunny"));
    for label in golden.keys() {
        if !now.contains_key(*label) && (bunny || !label.starts_with("bunny")) {
            differ.push(format!("{label}: recorded, no longer run"));
        }
    }
    assert!(
        differ.is_empty(),
        "cycles or trees changed (cycles, tree digest):\n{}",
        differ.join("\n")
    );
    if !bunny {
        eprintln!("unchanged: CELLBIH_DATA is not set: the bunny runs did NOT run");
    }
}

/// The baseline's figures docs/calibration.md states in words are the
/// recording's (the bunny's cycles at 3.2 GHz) and Table 1's generated
/// cell (the dragon's): a move of the baseline must restate them.
#[test]
fn the_baselines_stated_figures_are_the_recorded_ones() {
    let root = env!("CARGO_MANIFEST_DIR");
    let read = |p: &str| std::fs::read_to_string(format!("{root}/{p}")).unwrap();
    // The page's words with its line breaks as spaces.
    let calibration = read("docs/calibration.md")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    let golden = read("tests/golden/runs.txt");
    let cycles: u64 = (golden.lines())
        .find_map(|l| l.strip_prefix("bunny spe_bfs: "))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|c| c.parse().ok())
        .expect("the bunny's baseline is recorded");
    let bunny = format!("{:.2} simulated ms on the bunny", cycles as f64 / 3.2e6);
    assert!(
        calibration.contains(&bunny),
        "calibration.md does not say '{bunny}'"
    );
    // Table 1's generated block: the dragon's spe_bfs row, simulated ms.
    let table1 = read("docs/table1.md");
    let dragon = (table1.lines())
        .skip_while(|l| !l.starts_with("Dragon"))
        .find(|l| l.split_whitespace().next() == Some("spe_bfs"))
        .and_then(|l| l.split_whitespace().nth(1))
        .expect("Table 1 has the dragon's spe_bfs row");
    let said = format!("and {dragon} on the dragon");
    assert!(
        calibration.contains(&said),
        "calibration.md does not give the dragon's {dragon} ms"
    );
}
