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
use cellbih::scene::{self, Scene};
use cellbih::strategy::Knobs;
use criterion::measurement::Measurement;
use criterion::{BenchmarkGroup, Criterion, Throughput, criterion_group, criterion_main};
use simulated::SimulatedTime;

const METHODS: [BuilderKind; 4] = [
    BuilderKind::PPE_NAIVE,
    BuilderKind::PPE_APPROX,
    BuilderKind::SPE_DFS,
    BuilderKind::SPE_BFS,
];

fn scenes() -> Vec<Scene> {
    let mut v = vec![scene::load("default", None).unwrap()];
    match scene::data_dir(None) {
        Some(dir) => v.push(scene::load("bunny", Some(&dir)).unwrap()),
        None => eprintln!("CELLBIH_DATA is not set: the default scene only"),
    }
    v
}

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

fn simulated(c: &mut Criterion<SimulatedTime>) {
    let scenes = scenes();
    let mut g = c.benchmark_group("paper_builders_simulated");
    group(&mut g, &scenes);
    g.finish();
}

fn host(c: &mut Criterion) {
    let scenes = scenes();
    let mut g = c.benchmark_group("paper_builders_host");
    group(&mut g, &scenes);
    g.finish();
}

criterion_group! {
    name = simulated_time;
    // Simulated time has no spread: criterion's plots of a comparison with
    // an earlier run (a t-test over identical samples) would panic.
    config = Criterion::default().with_measurement(SimulatedTime).without_plots();
    targets = simulated
}
criterion_group!(host_time, host);
criterion_main!(simulated_time, host_time);
