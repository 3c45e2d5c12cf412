//! cellbih beside a peer: obvhs's CWBVH, built with its
//! fastest and medium presets on one thread (a rayon pool of one: obvhs's
//! `parallel` feature is on for `host_scaling`), and
//! cellbih's host builder and tracer — the paper's tree and the best
//! quality knobs (the cut-off alone, and binned SAH with it) — on the same
//! triangles and the same rays.
//!
//! `CELLBIH_DATA=../shared/data cargo bench --bench peers [-- --scenes bunny,dragon] [--runs 5] [--sah-above 4096,16384] [--brief]`
//! (`--sah-above`: a row of binned SAH with the cut-off per threshold;
//! 4096 and 16384 by default, the settings of the goals in docs/tradeoff.md;
//! `--brief`: only the rows of the cut-off's tree, of binned SAH with the
//! cut-off and of Embree low, and only build plus preparation, rays per
//! second and agreement; all measured all the same)
//!
//! cellbih's rows trace with the tracer's default (`Tracer::hits`: packets
//! of coherent rays, the fast `f32` walk for the rest); the cut-off's tree
//! is also traced by the exact walk alone, by the fast walk on every ray,
//! and with the rays sorted into coherent runs first.
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

mod embree;

use glam::Vec3A;
use obvhs::BvhBuildParams;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::{Ray as ORay, RayHit};
use obvhs::triangle::Triangle as OTri;

use cellbih::aabb::Aabb;
use cellbih::bih::{Bih, BihConfig, Hit, Ray, RayStats, SplitChoice, Tracer};
use cellbih::quality::rays::RaySets;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{self, Scene};

fn main() {
    let mut scenes: Vec<String> = ["bunny", "dragon", "sponza-dabrovic", "sibenik"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let mut runs = 5usize;
    let mut above = vec![4096u32, 16384];
    let mut brief = false;
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
            "--brief" => brief = true,
            "--runs" => runs = it.next().and_then(|r| r.parse().ok()).expect("--runs N"),
            "--sah-above" => {
                above = (it.next().expect("--sah-above LIST").split(','))
                    .map(|n| n.parse().expect("--sah-above: triangle counts"))
                    .collect()
            }
            "--bench" => {} // cargo bench's own flag
            other => panic!("peers: unknown option {other}"),
        }
    }
    let embree = embree::Embree::load();
    match &embree {
        Ok(e) => println!("Embree {}: {}", e.version(), e.name),
        Err(why) => println!(
            "Embree: not found ({why}); run scripts/get-embree, or set CELLBIH_EMBREE to its library"
        ),
    }
    println!("host: {}", host_cpu());
    let embree = embree.ok();
    let data = scene::data_dir(None);
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a pool of one thread");
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
        one_thread.install(|| compare(&s, runs, &above, brief, embree.as_ref()));
    }
    if !brief {
        println!(
            "\n(x ref: rays per second over Embree low's, else obvhs medium's; -: not measured)"
        );
        println!(
            "(agree: rays whose answer matches cellbih's paper tree — same triangle, or the same t within 1e-4, or both miss)"
        );
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

fn compare(s: &Scene, runs: usize, above: &[u32], brief: bool, embree: Option<&embree::Embree>) {
    let rays = RaySets::standard(s);
    let sets = [&rays.primary, &rays.incoherent];
    let tris: Vec<OTri> = (s.triangles.iter())
        .map(|t| OTri {
            v0: t.v[0].into(),
            v1: t.v[1].into(),
            v2: t.v[2].into(),
        })
        .collect();
    // Each contender: its label, a timed build (build, and build plus the
    // tracer's preparation), its tracer, and its bytes.
    // The paper's tree, the cut-off alone, binned SAH with the cut-off,
    // and binned SAH above each `--sah-above` count with the cut-off.
    let mut settings = vec![BihConfig::default(), CUT, BihConfig::SAH_CUT];
    settings.extend(above.iter().map(|&above| BihConfig {
        split: SplitChoice::BinnedSah { bins: 16, above },
        ..BihConfig::SAH_CUT
    }));
    let trees: Vec<Bih> = (settings.iter())
        .map(|cfg| {
            Build::new(BuilderKind::HOST)
                .with_tree(*cfg)
                .run(s)
                .unwrap()
                .bih
        })
        .collect();
    let cut = Tracer::new(&trees[1], s);
    let cut = &cut;
    let handing = [1, 4].map(|k| Tracer::new(&trees[1], s).handing_over(k));
    let handing = &handing;
    let mut contenders: Vec<Contender> = Vec::new();
    for (cfg, bih) in settings.into_iter().zip(&trees) {
        let tracer = Tracer::new(bih, s);
        let bytes = bih.memory_bytes() + tracer.memory_bytes();
        contenders.push(Contender {
            name: format!("cellbih host {}", cfg.flags()).trim_end().into(),
            build: Box::new(move || {
                let (built, bih) = time(|| {
                    Build::new(BuilderKind::HOST)
                        .with_tree(cfg)
                        .run(s)
                        .unwrap()
                        .bih
                });
                let (prep, _) = time(|| Tracer::new(&bih, s));
                (built, built + prep)
            }),
            trace: Box::new(move |set: &[Ray]| -> Answers { answers(tracer.hits(set)) }),
            bytes,
        });
    }
    // The cut-off's tree traced other ways: the exact walk (packets, else
    // single rays in f64: what counts nodes and triangles), the fast walk
    // on every ray (no packets), packets that hand their last one or four
    // active rays over to the fast walk, and the rays sorted into coherent
    // runs (direction octant, then the origin's Morton code; the sort
    // timed with the tracing) before the default.
    let ways: [(&str, Trace); 5] = [
        (
            "exact walk",
            Box::new(move |set: &[Ray]| answers(cut.closest_all(set, &mut RayStats::default()))),
        ),
        (
            "fast walk, no packets",
            Box::new(move |set: &[Ray]| answers(set.iter().map(|r| cut.closest_fast(r)).collect())),
        ),
        (
            "handing 1 ray over to the fast walk",
            Box::new(move |set: &[Ray]| answers(handing[0].hits(set))),
        ),
        (
            "handing up to 4 rays over to the fast walk",
            Box::new(move |set: &[Ray]| answers(handing[1].hits(set))),
        ),
        (
            "rays sorted first",
            Box::new(move |set: &[Ray]| {
                let order = coherent_order(set, &s.bounds());
                let sorted: Vec<Ray> = order.iter().map(|&i| set[i as usize]).collect();
                let mut out = vec![None; set.len()];
                for (&i, h) in order.iter().zip(cut.hits(&sorted)) {
                    out[i as usize] = h.map(|h| (h.prim, h.t));
                }
                out
            }),
        ),
    ];
    for (way, trace) in ways {
        contenders.push(Contender {
            // Not among `--brief`'s rows: the hand-over rows.
            name: match way.starts_with("handing") {
                true => format!("cellbih host, --empty-cut 30 {way}"),
                false => format!("cellbih host --empty-cut 30, {way}"),
            },
            build: Box::new(|| (Duration::ZERO, Duration::ZERO)),
            trace,
            bytes: 0,
        });
    }
    // The paper's tree traced ray by ray in f64, as before packets.
    let tracer = Tracer::new(&trees[0], s);
    contenders.push(Contender {
        name: "cellbih host, rays one by one".into(),
        build: Box::new(|| (Duration::ZERO, Duration::ZERO)),
        trace: Box::new(move |set: &[Ray]| -> Answers {
            let mut st = RayStats::default();
            answers(set.iter().map(|r| tracer.closest(r, &mut st)).collect())
        }),
        bytes: 0,
    });
    for (label, quality) in [
        ("Embree low", embree::Quality::Low),
        ("Embree medium", embree::Quality::Medium),
    ] {
        let Some(e) = embree else { break };
        let built = e.build(s, quality);
        contenders.push(Contender {
            name: label.into(),
            build: Box::new(move || {
                let (t, _) = time(|| e.build(s, quality));
                (t, t)
            }),
            trace: Box::new(move |set: &[Ray]| -> Answers {
                set.iter().map(|r| built.closest(r)).collect()
            }),
            bytes: 0,
        });
    }
    for (label, params) in [
        ("obvhs fastest", BvhBuildParams::fastest_build()),
        ("obvhs medium", BvhBuildParams::medium_build()),
    ] {
        let bvh = build_cwbvh_from_tris(&tris, params, &mut Duration::default());
        let ordered: Vec<OTri> = bvh
            .primitive_indices
            .iter()
            .map(|&i| tris[i as usize])
            .collect();
        let bytes = size_of_val(bvh.nodes.as_slice())
            + size_of_val(bvh.primitive_indices.as_slice())
            + size_of_val(ordered.as_slice());
        let tris = &tris;
        contenders.push(Contender {
            name: label.into(),
            build: Box::new(move || {
                let (built, _) =
                    time(|| build_cwbvh_from_tris(tris, params, &mut Duration::default()));
                (built, built)
            }),
            trace: Box::new(move |set: &[Ray]| -> Answers {
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
            }),
            bytes,
        });
    }
    let (rows, answers) = measured(&contenders, sets, runs);
    println!(
        "\n{} ({} triangles; {} primary, {} incoherent rays)",
        s.name,
        s.len(),
        sets[0].len(),
        sets[1].len()
    );
    // Rays per second against Embree low's where Embree is loaded, else
    // against obvhs medium's.
    let reference = (rows.iter())
        .find(|r| r.name == "Embree low")
        .or_else(|| rows.iter().find(|r| r.name == "obvhs medium"))
        .expect("obvhs medium is always measured");
    let by = (reference.primary, reference.incoherent);
    let blank = |x: f64, text: String| if x > 0.0 { text } else { "-".into() };
    if brief {
        // Build plus preparation, rays per second, agreement.
        println!(
            "{:<38} {:>9} {:>9} {:>6} {:>9} {:>6} {:>8}",
            "", "ready ms", "prim Mr/s", "x ref", "inco Mr/s", "x ref", "agree"
        );
    } else {
        println!(
            "{:<44} {:>9} {:>9} {:>9} {:>7} {:>9} {:>7} {:>7} {:>8} {:>6}",
            "",
            "build ms",
            "+prep ms",
            "prim Mr/s",
            "x ref",
            "inco Mr/s",
            "x ref",
            "hits",
            "agree",
            "MB"
        );
    }
    for (k, r) in rows.iter().enumerate() {
        if brief && !BRIEF.iter().any(|w| r.name.starts_with(w)) {
            continue;
        }
        let agree: usize = (0..2)
            .map(|set| agreeing(&answers[k][set], &answers[0][set]))
            .sum();
        let agree = 100.0 * agree as f64 / (sets[0].len() + sets[1].len()) as f64;
        let (b, p) = (ms(r.build), ms(r.ready));
        if brief {
            println!(
                "{:<38} {:>9} {:>9.2} {:>6.2} {:>9.2} {:>6.2} {:>7.2}%",
                r.name.trim_start_matches("cellbih host "),
                blank(p, format!("{p:.1}")),
                r.primary,
                r.primary / by.0,
                r.incoherent,
                r.incoherent / by.1,
                agree,
            );
            continue;
        }
        println!(
            "{:<44} {:>9} {:>9} {:>9.2} {:>7.2} {:>9.2} {:>7.2} {:>7} {:>7.2}% {:>6}",
            r.name,
            blank(b, format!("{b:.1}")),
            blank(p, format!("{p:.1}")),
            r.primary,
            r.primary / by.0,
            r.incoherent,
            r.incoherent / by.1,
            r.hits[0] + r.hits[1],
            agree,
            blank(r.bytes as f64, format!("{:.1}", r.bytes as f64 / 1e6)),
        );
    }
}

/// Answers a set of rays (a contender's tracer).
type Trace<'a> = Box<dyn Fn(&[Ray]) -> Answers + 'a>;

/// One contender: a timed build, its tracer, its bytes.
struct Contender<'a> {
    name: String,
    /// Builds once: (build, build plus the tracer's preparation).
    build: Box<dyn Fn() -> (Duration, Duration) + 'a>,
    /// Answers a set of rays.
    trace: Trace<'a>,
    bytes: usize,
}

/// Every contender's row and answers. Builds and ray sets are timed in
/// rounds, one of each contender a round, and the medians taken, so that
/// every contender meets the same conditions. This host runs one binary
/// on one input at one of two speeds, process after process (up to 1.4x
/// apart, cellbih's binning hit hardest): run the bench more than once.
fn measured(
    contenders: &[Contender],
    sets: [&Vec<Ray>; 2],
    runs: usize,
) -> (Vec<Row>, Vec<Vec<Answers>>) {
    let answers: Vec<Vec<Answers>> = (contenders.iter())
        .map(|c| sets.iter().map(|set| (c.trace)(set)).collect())
        .collect();
    let n = contenders.len();
    let (mut build, mut ready) = (vec![Vec::new(); n], vec![Vec::new(); n]);
    let mut trace = vec![[Vec::new(), Vec::new()]; n];
    for _ in 0..runs.max(1) {
        for (k, c) in contenders.iter().enumerate() {
            let (b, r) = (c.build)();
            build[k].push(b);
            ready[k].push(r);
        }
        for (k, c) in contenders.iter().enumerate() {
            for (set, t) in sets.iter().zip(&mut trace[k]) {
                t.push(time(|| (c.trace)(set)).0);
            }
        }
    }
    let rows = (contenders.iter().enumerate())
        .map(|(k, c)| Row {
            name: c.name.clone(),
            build: median(&mut build[k]),
            ready: median(&mut ready[k]),
            primary: sets[0].len() as f64 / median(&mut trace[k][0]).as_secs_f64() / 1e6,
            incoherent: sets[1].len() as f64 / median(&mut trace[k][1]).as_secs_f64() / 1e6,
            hits: [0, 1].map(|set| answers[k][set].iter().filter(|h| h.is_some()).count()),
            bytes: c.bytes,
        })
        .collect();
    (rows, answers)
}

/// The rows `--brief` prints: the cut-off's tree every way it is traced,
/// binned SAH with the cut-off, Embree low.
const BRIEF: [&str; 3] = [
    "cellbih host --empty-cut 30",
    "cellbih host --split sah --empty-cut 10",
    "Embree low",
];

/// Each hit's triangle and distance.
fn answers(hits: Vec<Option<Hit>>) -> Answers {
    hits.iter().map(|h| h.map(|h| (h.prim, h.t))).collect()
}

/// The rays' indices sorted by direction octant, then by the Morton code
/// of the origin in `bounds` (10 bits an axis).
fn coherent_order(rays: &[Ray], bounds: &Aabb) -> Vec<u32> {
    let (lo, ext) = (bounds.min.as_dvec3(), bounds.extent_f64());
    let spread = |x: u64| -> u64 { (0..10).fold(0, |m, b| m | ((x >> b) & 1) << (3 * b)) };
    let mut keyed: Vec<(u64, u32)> = (rays.iter().enumerate())
        .map(|(i, r)| {
            let octant = (0..3).fold(0u64, |o, a| o | (r.dir[a].is_sign_negative() as u64) << a);
            let cell = (r.origin - lo) / ext.max(glam::DVec3::splat(f64::MIN_POSITIVE));
            let q = cell.to_array().map(|c| (c.clamp(0.0, 1.0) * 1023.0) as u64);
            let morton = spread(q[0]) | spread(q[1]) << 1 | spread(q[2]) << 2;
            (octant << 30 | morton, i as u32)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
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

fn median(t: &mut [Duration]) -> Duration {
    t.sort();
    t[t.len() / 2]
}

/// The host's CPU (its model name) and the widest SIMD it offers.
fn host_cpu() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|c| {
            (c.lines())
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "an unknown CPU".into());
    #[cfg(target_arch = "x86_64")]
    let simd = if std::arch::is_x86_feature_detected!("avx512f") {
        "AVX-512 (512-bit)"
    } else if std::arch::is_x86_feature_detected!("avx2") {
        "AVX2 (256-bit)"
    } else {
        "SSE2 (128-bit)"
    };
    #[cfg(not(target_arch = "x86_64"))]
    let simd = "not x86-64";
    format!("{model}; widest SIMD {simd}")
}
