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

use std::cell::Cell;
use std::hint::black_box;

use cellbih::bih::BihConfig;
use cellbih::build::BuilderKind;
use cellbih::scene::{self, Scene};
use criterion::measurement::{Measurement, ValueFormatter};
use criterion::{BenchmarkGroup, Criterion, Throughput, criterion_group, criterion_main};

const METHODS: [BuilderKind; 4] = [
    BuilderKind::PPE_NAIVE,
    BuilderKind::PPE_APPROX,
    BuilderKind::SPE_DFS,
    BuilderKind::SPE_BFS,
];

thread_local! {
    /// This thread's simulated clock, in nanoseconds of PS3 time.
    static SIMULATED_NS: Cell<f64> = const { Cell::new(0.0) };
}

/// Builds `scene` with `method` and advances the simulated clock by the
/// build's simulated time.
fn build(method: BuilderKind, scene: &Scene) {
    let r = method
        .build(black_box(scene), &BihConfig::default())
        .unwrap();
    let ms = r.simulated.expect("an emulated builder").run.ms;
    SIMULATED_NS.with(|c| c.set(c.get() + ms * 1e6));
}

/// Simulated Cell time: the difference of this thread's simulated clock.
struct SimulatedTime;

impl Measurement for SimulatedTime {
    type Intermediate = f64;
    type Value = f64;
    fn start(&self) -> f64 {
        SIMULATED_NS.with(Cell::get)
    }
    fn end(&self, start: f64) -> f64 {
        SIMULATED_NS.with(Cell::get) - start
    }
    fn add(&self, a: &f64, b: &f64) -> f64 {
        a + b
    }
    fn zero(&self) -> f64 {
        0.0
    }
    fn to_f64(&self, v: &f64) -> f64 {
        *v
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        &SimulatedFormatter
    }
}

/// Prints simulated nanoseconds as simulated µs, ms or s.
struct SimulatedFormatter;

impl ValueFormatter for SimulatedFormatter {
    fn scale_values(&self, typical: f64, values: &mut [f64]) -> &'static str {
        let (div, unit) = if typical < 1e6 {
            (1e3, "µs (simulated)")
        } else if typical < 1e9 {
            (1e6, "ms (simulated)")
        } else {
            (1e9, "s (simulated)")
        };
        values.iter_mut().for_each(|v| *v /= div);
        unit
    }

    fn scale_throughputs(&self, _typical: f64, t: &Throughput, values: &mut [f64]) -> &'static str {
        let per = match *t {
            Throughput::Elements(n) | Throughput::Bytes(n) | Throughput::BytesDecimal(n) => {
                n as f64
            }
            Throughput::ElementsAndBytes { elements, .. } => elements as f64,
            _ => 1.0,
        };
        // Millions of items per simulated second.
        values.iter_mut().for_each(|v| *v = per / *v * 1e3);
        "M/s (simulated)"
    }

    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        "ns (simulated)"
    }
}

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
                b.iter(|| build(m, s))
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
    config = Criterion::default().with_measurement(SimulatedTime);
    targets = simulated
}
criterion_group!(host_time, host);
criterion_main!(simulated_time, host_time);
