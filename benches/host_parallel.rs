//! The host's parallel builders (every builder of the registry
//! that builds on the host's threads) beside the serial host builder,
//! under criterion: build time on the default scene and, when CELLBIH_DATA
//! is set, on bunny and dragon, with 1, 2 and the machine's available
//! threads (a rayon pool of that many, `ThreadPool::install`). Criterion
//! reports medians; `Throughput` makes it print Melem/s (triangles).
//! Wall time only: `cargo run --release --example host_scaling` adds CPU
//! time, the peer and the large scenes.

use std::hint::black_box;

use cellbih::bih::BihConfig;
use cellbih::registry::{Build, BuilderKind};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

mod common;
use common::scenes::default_bunny_dragon as scenes;

fn threads() -> Vec<usize> {
    let most = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut t = vec![1, 2, most];
    t.sort_unstable();
    t.dedup();
    t
}

fn build(c: &mut Criterion) {
    let mut g = c.benchmark_group("host_parallel");
    g.sample_size(10);
    let cfg = BihConfig::default();
    for s in scenes() {
        g.throughput(Throughput::Elements(s.len() as u64));
        g.bench_function(format!("{}/host", s.name), |b| {
            b.iter(|| {
                Build::new(BuilderKind::HOST)
                    .with_tree(cfg)
                    .run(black_box(&s))
                    .unwrap()
            })
        });
        for t in threads() {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap();
            for p in BuilderKind::ALL.iter().filter(|b| b.host_threads()) {
                g.bench_function(format!("{}/{p}/{t}", s.name), |b| {
                    b.iter(|| {
                        pool.install(|| Build::new(*p).with_tree(cfg).run(black_box(&s)).unwrap())
                    })
                });
            }
        }
    }
    g.finish();
}

criterion_group!(benches, build);
criterion_main!(benches);
