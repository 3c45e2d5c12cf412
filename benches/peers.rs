//! cellbih beside a peer (issue 15, item 8): obvhs's CWBVH, built with its
//! fastest and medium presets on one thread (no `parallel` feature), and
//! cellbih's host builder and tracer — the paper's tree and the best
//! quality knobs (the cut-off alone, and binned SAH with it) — on the same
//! triangles and the same rays.
//!
//! `CELLBIH_DATA=../shared/data cargo bench --bench peers [-- --scenes bunny,dragon] [--runs 5]`
//!
//! For each scene: build ms (median of `--runs`), cellbih's with and
//! without the tracer's own preparation (`Tracer::new`: the leaf-ordered
//! triangle groups and leaf boxes); primary rays of the render camera and
//! incoherent rays (the testbed's [`RaySets`]), rays per second (median);
//! how many rays hit, and on how many rays the two agree (both miss, or hit
//! the same triangle, or hit at the same distance within 1e-4 relative —
//! obvhs tests in `f32`, cellbih in `f64`); bytes of each structure. One
//! thread throughout; say the machine and the RUSTFLAGS when you quote it.

use std::time::{Duration, Instant};

use glam::Vec3A;
use obvhs::BvhBuildParams;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::{Ray as ORay, RayHit};
use obvhs::triangle::Triangle as OTri;

use cellbih::bih::{BihConfig, Ray, RayStats, Tracer};
use cellbih::build::BuilderKind;
use cellbih::quality::rays::RaySets;
use cellbih::scene::{self, Scene};

fn main() {
    let mut scenes: Vec<String> = ["bunny", "dragon", "sponza-dabrovic", "sibenik"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let mut runs = 5usize;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--scenes" => {
                scenes = it
                    .next()
                    .expect("--scenes LIST")
                    .split(',')
                    .map(String::from)
                    .collect()
            }
            "--runs" => runs = it.next().and_then(|r| r.parse().ok()).expect("--runs N"),
            _ => {} // cargo bench's own flags (--bench)
        }
    }
    let data = scene::data_dir(None);
    println!(
        "one thread; RUSTFLAGS={:?}; build ms and Mrays/s: medians of {runs}",
        std::env::var("RUSTFLAGS").unwrap_or_default()
    );
    for name in &scenes {
        let s = match scene::load(name, data.as_deref()) {
            Ok(s) => s,
            Err(e) => {
                println!("{name}: skipped ({e})");
                continue;
            }
        };
        compare(&s, runs);
    }
}

/// The cheap knob of the tradeoff experiment: the empty-space cut-off
/// alone.
const CUT: BihConfig = BihConfig {
    empty_cut: Some(30),
    ..BihConfig::DEFAULT
};

/// Each ray's closest hit (triangle, t), or a miss.
type Answers = Vec<Option<(u32, f64)>>;

/// One contender's row.
struct Row {
    name: String,
    build: Duration,
    /// Build plus the tracer's preparation (`Tracer::new`, median of its
    /// own runs) for cellbih; the build for obvhs.
    ready: Duration,
    primary: f64,
    incoherent: f64,
    hits: [usize; 2],
    bytes: usize,
}

fn compare(s: &Scene, runs: usize) {
    let rays = RaySets::standard(&s.bounds());
    let sets = [&rays.primary, &rays.incoherent];
    let tris: Vec<OTri> = (s.triangles.iter())
        .map(|t| OTri {
            v0: t.v[0].into(),
            v1: t.v[1].into(),
            v2: t.v[2].into(),
        })
        .collect();
    let mut rows = Vec::new();
    let mut answers: Vec<Vec<Answers>> = Vec::new();
    for (label, cfg) in [
        ("cellbih host", BihConfig::default()),
        ("cellbih host --empty-cut 30", CUT),
        (
            "cellbih host --split sah --empty-cut 10",
            BihConfig::SAH_CUT,
        ),
    ] {
        let build = median(runs, || {
            time(|| BuilderKind::HOST.build(s, &cfg).unwrap()).0
        });
        let bih = BuilderKind::HOST.build(s, &cfg).unwrap().bih;
        let prep = median(runs, || time(|| Tracer::new(&bih, s)).0);
        let tracer = Tracer::new(&bih, s);
        let trace = |set: &[Ray]| -> Answers {
            let mut st = RayStats::default();
            set.iter()
                .map(|r| tracer.closest(r, &mut st).map(|h| (h.prim, h.t)))
                .collect()
        };
        let bytes = bih.memory_bytes() + tracer.memory_bytes();
        let (row, got) = measured(label, build, build + prep, bytes, sets, runs, trace);
        rows.push(row);
        answers.push(got);
    }
    for (label, params) in [
        ("obvhs fastest", BvhBuildParams::fastest_build()),
        ("obvhs medium", BvhBuildParams::medium_build()),
    ] {
        let build = median(runs, || {
            time(|| build_cwbvh_from_tris(&tris, params, &mut Duration::default())).0
        });
        let bvh = build_cwbvh_from_tris(&tris, params, &mut Duration::default());
        let ordered: Vec<OTri> = bvh
            .primitive_indices
            .iter()
            .map(|&i| tris[i as usize])
            .collect();
        let trace = |set: &[Ray]| -> Answers {
            set.iter()
                .map(|r| {
                    let ray = ORay::new(
                        Vec3A::from(r.origin.as_vec3()),
                        Vec3A::from(r.dir.as_vec3()),
                        0.0,
                        f32::INFINITY,
                    );
                    let mut hit = RayHit::none();
                    bvh.ray_traverse(ray, &mut hit, |ray, id| ordered[id].intersect(ray))
                        .then(|| {
                            (
                                bvh.primitive_indices[hit.primitive_id as usize],
                                hit.t as f64,
                            )
                        })
                })
                .collect()
        };
        let bytes = size_of_val(bvh.nodes.as_slice())
            + size_of_val(bvh.primitive_indices.as_slice())
            + size_of_val(ordered.as_slice());
        let (row, got) = measured(label, build, build, bytes, sets, runs, trace);
        rows.push(row);
        answers.push(got);
    }
    println!(
        "\n{} ({} triangles; {} primary, {} incoherent rays)",
        s.name,
        s.len(),
        sets[0].len(),
        sets[1].len()
    );
    println!(
        "{:<40} {:>9} {:>11} {:>9} {:>9} {:>9} {:>9} {:>8} {:>8} {:>9}",
        "",
        "build ms",
        "+prep ms",
        "prim Mr/s",
        "x medium",
        "inco Mr/s",
        "x medium",
        "hits",
        "agree",
        "MB"
    );
    let medium = rows
        .last()
        .map_or((1.0, 1.0), |m| (m.primary, m.incoherent));
    for (k, r) in rows.iter().enumerate() {
        let agree: usize = (0..2)
            .map(|set| agreeing(&answers[k][set], &answers[0][set]))
            .sum();
        println!(
            "{:<40} {:>9.1} {:>11.1} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>8} {:>7.2}% {:>9.1}",
            r.name,
            ms(r.build),
            ms(r.ready),
            r.primary,
            r.primary / medium.0,
            r.incoherent,
            r.incoherent / medium.1,
            r.hits[0] + r.hits[1],
            100.0 * agree as f64 / (sets[0].len() + sets[1].len()) as f64,
            r.bytes as f64 / 1e6,
        );
    }
    println!(
        "(agree: rays whose answer matches cellbih's paper tree — same triangle, or the same t within 1e-4, or both miss)"
    );
}

/// One contender's row: `trace` answers both ray sets (kept for the
/// agreement check) and is timed on each.
fn measured(
    name: &str,
    build: Duration,
    ready: Duration,
    bytes: usize,
    sets: [&Vec<Ray>; 2],
    runs: usize,
    trace: impl Fn(&[Ray]) -> Answers,
) -> (Row, Vec<Answers>) {
    let speed = |set: &[Ray]| median_rate(runs, set.len(), || trace(set));
    let got: Vec<Answers> = sets.iter().map(|set| trace(set)).collect();
    let row = Row {
        name: name.into(),
        build,
        ready,
        primary: speed(sets[0]),
        incoherent: speed(sets[1]),
        hits: [0, 1].map(|k| got[k].iter().filter(|h| h.is_some()).count()),
        bytes,
    };
    (row, got)
}

/// Rays on which `a` and `b` agree.
fn agreeing(a: &[Option<(u32, f64)>], b: &[Option<(u32, f64)>]) -> usize {
    a.iter()
        .zip(b)
        .filter(|(x, y)| match (x, y) {
            (None, None) => true,
            (Some((p, t)), Some((q, u))) => p == q || (t - u).abs() <= 1e-4 * u.abs().max(1e-30),
            _ => false,
        })
        .count()
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn time<T>(f: impl FnOnce() -> T) -> (Duration, T) {
    let start = Instant::now();
    let v = f();
    (start.elapsed(), v)
}

fn median(runs: usize, mut f: impl FnMut() -> Duration) -> Duration {
    let mut t: Vec<Duration> = (0..runs.max(1)).map(|_| f()).collect();
    t.sort();
    t[t.len() / 2]
}

/// Median million rays per second of `runs` passes over `n` rays.
fn median_rate<T>(runs: usize, n: usize, mut f: impl FnMut() -> T) -> f64 {
    let d = median(runs, || time(&mut f).0);
    n as f64 / d.as_secs_f64() / 1e6
}
