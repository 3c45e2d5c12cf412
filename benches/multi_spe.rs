//! Each multi-SPE strategy (and its main knobs) beside the single-SPE
//! baseline `spe_bfs`, on 6 SPEs (the PS3's), on the default scene and
//! (with `CELLBIH_DATA`) the Bunny: `multi_spe_simulated/*` in simulated Cell time (the shared
//! criterion `Measurement` of `common/simulated.rs`), `multi_spe_host/*` in
//! host time of the emulation.
//!
//! `CELLBIH_DATA=../shared/data cargo bench --bench multi_spe`

mod common;
use common::simulated;

use cellbih::cell::CellConfig;
use cellbih::registry::BuilderKind;
use cellbih::scene::Scene;
use cellbih::strategy::Knobs;
use criterion::measurement::Measurement;
use criterion::{BenchmarkGroup, Throughput};

const SPES: usize = 6;

/// The baseline and every multi-SPE builder, the latter with its defaults
/// and with its strategy's settings of several knobs at once
/// ([`BuilderKind::combos`]: section 5's queue improvements for the
/// breadth-first ones): (label, builder, knobs).
fn variants() -> Vec<(String, BuilderKind, Knobs)> {
    let mut v = vec![(
        "spe_bfs".to_string(),
        BuilderKind::SPE_BFS,
        Knobs::default(),
    )];
    for &b in BuilderKind::ALL.iter().filter(|b| b.multi_spe()) {
        v.push((b.name().to_string(), b, Knobs::default()));
        for knobs in b.combos() {
            let options = knobs.spelled().replace("--", "").replace(' ', "_");
            v.push((format!("{}_{options}", b.name()), b, knobs));
        }
    }
    v
}

fn group<M: Measurement>(g: &mut BenchmarkGroup<M>, scenes: &[Scene]) {
    g.sample_size(10);
    let cell = CellConfig::ps3().with_spes(SPES);
    for s in scenes {
        g.throughput(Throughput::Elements(s.len() as u64));
        for (label, b, knobs) in variants() {
            g.bench_function(format!("{}/{label}/{SPES}_spes", s.name), |bench| {
                bench.iter(|| simulated::build(b, s, &cell, &knobs))
            });
        }
    }
}

common::simulated::simulated_and_host!("multi_spe", group);
