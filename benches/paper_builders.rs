//! The paper's four builders (Table 1) on the same scenes, twice over:
//!
//! - `paper_builders_simulated/*` measures **simulated Cell time** with a
//!   custom criterion [`Measurement`]: each iteration advances this thread's
//!   simulated clock by the build's cycles on the PS3 model, so criterion's
//!   statistics and its comparisons between runs (a changed strategy or cost
//!   rate) are of simulated milliseconds. The model is deterministic, so
//!   every sample is the same: the spread is zero, and a reported change is
//!   a real change of the model or the program.
//! - `paper_builders_host/*` measures the host wall time the emulation takes.
//!
//! `cargo bench --bench paper_builders` (the default scene), with
//! `CELLBIH_DATA=../shared/data` also the Bunny.

mod common;
use common::simulated;

use cellbih::cell::CellConfig;
use cellbih::registry::BuilderKind;
use cellbih::scene::Scene;
use cellbih::strategy::Knobs;
use criterion::measurement::Measurement;
use criterion::{BenchmarkGroup, Throughput};

const METHODS: [BuilderKind; 4] = [
    BuilderKind::PPE_NAIVE,
    BuilderKind::PPE_APPROX,
    BuilderKind::SPE_DFS,
    BuilderKind::SPE_BFS,
];

fn group<M: Measurement>(g: &mut BenchmarkGroup<M>, scenes: &[Scene]) {
    g.sample_size(10);
    for s in scenes {
        g.throughput(Throughput::Elements(s.len() as u64));
        for m in METHODS {
            g.bench_function(format!("{}/{}", s.name, m.name()), |b| {
                b.iter(|| simulated::build(m, s, &CellConfig::ps3(), &Knobs::default()))
            });
        }
    }
}

common::simulated::simulated_and_host!("paper_builders", group);
