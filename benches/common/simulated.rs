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
