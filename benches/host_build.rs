//! Host builder throughput (triangles per second) and ray casting (primary
//! rays per second, one thread: ray by ray, and in 4 × 4 packets beside
//! it) on the default scene and, when CELLBIH_DATA is set, on bunny and
//! dragon. Criterion reports medians; `Throughput` makes
//! it print Melem/s (triangles or rays).

use std::hint::black_box;

use cellbih::bih::{RayStats, Tracer};
use cellbih::registry::{Build, BuilderKind};
use cellbih::render::View;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

mod common;
use common::scenes::default_bunny_dragon as scenes;

fn build(c: &mut Criterion) {
    let mut g = c.benchmark_group("host_build");
    g.sample_size(20);
    for s in scenes() {
        g.throughput(Throughput::Elements(s.len() as u64));
        g.bench_function(&s.name, |b| {
            b.iter(|| Build::new(BuilderKind::HOST).run(black_box(&s)).unwrap())
        });
    }
    g.finish();
}

fn raycast(c: &mut Criterion) {
    let mut g = c.benchmark_group("host_raycast_primary");
    g.sample_size(10);
    for s in scenes() {
        let bih = Build::new(BuilderKind::HOST).run(&s).unwrap().bih;
        let tracer = Tracer::new(&bih, &s);
        let cam = View::Default
            .camera(&s.name, &s.bounds(), 512, 512)
            .unwrap();
        let rays = cam.rays();
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.bench_function(&s.name, |b| {
            b.iter(|| {
                let mut st = RayStats::default();
                rays.iter()
                    .filter(|r| tracer.closest(r, &mut st).is_some())
                    .count()
            })
        });
        // The same rays in 4 × 4 blocks, traced as packets.
        let blocks = cam.rays_in_blocks(4, 4);
        g.bench_function(format!("{} packets", s.name), |b| {
            b.iter(|| {
                let mut st = RayStats::default();
                (tracer.closest_all(&blocks, &mut st).iter())
                    .filter(|h| h.is_some())
                    .count()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, build, raycast);
criterion_main!(benches);
