//! Simulated Cell time as a criterion [`Measurement`], shared by the benches:
//! each build advances this thread's simulated clock by its cycles on the
//! PS3 model, so criterion's statistics and its comparisons between runs are
//! of simulated milliseconds. The model is deterministic: every sample is
//! the same, and a reported change is a change of the model or a program.

use std::cell::Cell;
use std::hint::black_box;

use cellbih::cell::CellConfig;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::Scene;
use cellbih::strategy::Knobs;
use criterion::Throughput;
use criterion::measurement::{Measurement, ValueFormatter};

thread_local! {
    /// This thread's simulated clock, in nanoseconds of PS3 time.
    static SIMULATED_NS: Cell<f64> = const { Cell::new(0.0) };
}

/// Builds `scene` with `method` on `cell` with `knobs` and advances the
/// simulated clock by the build's simulated time.
pub fn build(method: BuilderKind, scene: &Scene, cell: &CellConfig, knobs: &Knobs) {
    let r = Build::new(method)
        .on(cell)
        .with_knobs(knobs)
        .run_in(black_box(scene), scene.bounds())
        .unwrap();
    let ms = r.simulated.expect("an emulated builder").run.ms;
    SIMULATED_NS.with(|c| c.set(c.get() + ms * 1e6));
}

/// Simulated Cell time: the difference of this thread's simulated clock.
pub struct SimulatedTime;

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

/// The simulated benches' scenes: the default scene, and the Bunny where
/// `CELLBIH_DATA` is set (said so where it is not).
pub fn default_and_bunny() -> Vec<Scene> {
    let mut v = vec![cellbih::scene::load("default", None).unwrap()];
    match cellbih::scene::data_dir(None) {
        Some(dir) => v.push(cellbih::scene::load("bunny", Some(&dir)).unwrap()),
        None => eprintln!("CELLBIH_DATA is not set: the default scene only"),
    }
    v
}

/// A bench's `main`, measuring its builds twice: `NAME_simulated/*` in
/// simulated time ([`SimulatedTime`]), `NAME_host/*` in host time; `group`
/// adds the builds of the scenes ([`default_and_bunny`]) to a group.
macro_rules! simulated_and_host {
    ($name:literal, $group:path) => {
        fn simulated(c: &mut criterion::Criterion<common::simulated::SimulatedTime>) {
            let scenes = common::simulated::default_and_bunny();
            let mut g = c.benchmark_group(concat!($name, "_simulated"));
            $group(&mut g, &scenes);
            g.finish();
        }

        fn host(c: &mut criterion::Criterion) {
            let scenes = common::simulated::default_and_bunny();
            let mut g = c.benchmark_group(concat!($name, "_host"));
            $group(&mut g, &scenes);
            g.finish();
        }

        criterion::criterion_group! {
            name = simulated_time;
            // Simulated time has no spread: criterion's plots of a
            // comparison with an earlier run (a t-test over identical
            // samples) would panic.
            config = criterion::Criterion::default()
                .with_measurement(common::simulated::SimulatedTime)
                .without_plots();
            targets = simulated
        }
        criterion::criterion_group!(host_time, host);
        criterion::criterion_main!(simulated_time, host_time);
    };
}
pub(crate) use simulated_and_host;
