//! What `cellbih info` and `cellbih build` print: a scene's facts, a
//! build's time, tree and, for an emulated builder, every core's counters.

use serde_json::json;

use crate::report::Settings;
use cellbih::bih::Tracer;
use cellbih::cell::Cycles;
use cellbih::quality::rays::RaySets;
use cellbih::registry::{BuildReport, BuilderKind};
use cellbih::render::View;
use cellbih::scene::Scene;
use cellbih::spe::footprint::{Footprint, Purpose, work_ppe_jobs};
use cellbih::strategy::machinery::top::TRIS_PER_SPE;
use cellbih::strategy::{Phase, Simulated};

use crate::Res;
use crate::args::Format;

pub fn info(s: &Scene, format: Format) -> Res<()> {
    let b = s.bounds();
    let degenerate = s.degenerate_count();
    match format {
        Format::Json => println!(
            "{}",
            json!({
                "scene": s.name, "triangles": s.len(), "geometry_ids": s.geometry_names.len(),
                "bounds_min": b.min.to_array(), "bounds_max": b.max.to_array(), "degenerate": degenerate,
            })
        ),
        Format::Text => {
            println!("scene         {}", s.name);
            println!("triangles     {}", s.len());
            println!("geometry ids  {}", s.geometry_names.len());
            println!(
                "bounds        {:?} .. {:?}",
                b.min.to_array(),
                b.max.to_array()
            );
            println!("degenerate    {degenerate} (zero-area: kept, never hit)");
        }
    }
    Ok(())
}

/// The counters of a core that are times, left out where nothing was
/// timed (the functional mode).
const TIMED_COUNTERS: [&str; 7] = [
    "busy",
    "dma_wait",
    "mailbox_wait",
    "atomic",
    "atomic_wait",
    "memory_wait",
    "idle",
];

/// Every core's counters as JSON; without the times in the functional mode.
fn cores_json(m: &cellbih::strategy::Simulated) -> serde_json::Value {
    let mut v = json!(m.run.cores);
    if !m.run.timed {
        for core in v.as_array_mut().into_iter().flatten() {
            if let Some(c) = core.get_mut(1).and_then(|c| c.as_object_mut()) {
                c.retain(|k, _| !TIMED_COUNTERS.contains(&k.as_str()));
            }
        }
    }
    v
}

/// The build's report: its settings, time, tree, ray cost and, for an
/// emulated builder, memory and every core's counters.
pub fn print_build(s: &Scene, r: &BuildReport, format: Format, settings: &Settings, view: &View) {
    let q = r.bih.quality();
    let sets = RaySets::for_scene(s, view).expect("the view was checked before the build");
    let (primary, incoherent) = crate::report::step("measuring the tree's ray cost", || {
        sets.measure(&Tracer::new(&r.bih, s))
    });
    let ms = r.host_time.as_secs_f64() * 1e3;
    let sim = r.simulated.as_ref();
    let timed = sim.filter(|m| m.run.timed);
    match format {
        Format::Json => println!(
            "{}",
            json!({
                "settings": settings.to_json(),
                "scene": s.name, "triangles": s.len(), "builder": r.builder.name(),
                "threads": r.threads,
                "host_ms": ms, "quality": q, "tree_hash": r.bih.tree_hash_hex(),
                "footprint": sim.map(|m| &m.footprint),
                "rays": { "primary": primary, "incoherent": incoherent },
                "simulated_ms": timed.map(|m| m.run.ms),
                "spes": sim.map(|m| m.run.cores.len() - 1),
                "spes_used": sim.map(|m| m.spes_used),
                "prediction": sim.and_then(|m| m.prediction()),
                "simulated_cycles": timed.map(|m| m.run.cycles.0),
                "timing": sim.map(|m| if m.run.timed { "simulated" } else { "none: functional mode" }),
                "cores": sim.map(cores_json),
                "work": sim.map(|m| m.stats),
                "spe_work": sim.map(|m| &m.spe_work),
                "phases": sim.map(|m| m.phase_ms().iter()
                    .map(|(name, ms)| json!({ "phase": name, "ms": ms }))
                    .collect::<Vec<_>>()),
            })
        ),
        Format::Text => {
            field(&format!(
                "scene       {} ({})",
                s.name,
                crate::report::count(s.len() as u64, "triangle")
            ));
            match r.threads {
                Some(n) => field(&format!(
                    "builder     {} on {n} host thread{}",
                    r.builder,
                    if n == 1 { "" } else { "s" }
                )),
                None => field(&format!("builder     {}", r.builder)),
            }
            field(&format!("settings    {}", settings.line()));
            match sim {
                Some(m) if !m.run.timed => field(&format!(
                    "simulated   none: functional mode (no timing) with {}",
                    super::spes(m.run.cores.len() - 1)
                )),
                Some(m) => field(&format!(
                    "simulated   {:.2} ms on the PS3 model with {} ({} cycles)",
                    m.run.ms,
                    super::spes(m.run.cores.len() - 1),
                    m.run.cycles.0
                )),
                None => {}
            }
            if let Some(line) = sim.and_then(|m| spes_used_line(m, r.builder)) {
                field(&line);
            }
            if sim.is_some() {
                field(&format!("host time   {ms:.2} ms (the emulation)"));
            } else {
                field(&format!(
                    "host time   {ms:.2} ms ({:.2} Mtris/s)",
                    s.len() as f64 / ms / 1e3
                ));
            }
            field(&format!(
                "nodes       {} ({} inner, {})",
                q.nodes,
                q.inner_nodes,
                match q.leaves {
                    1 => "1 leaf".to_string(),
                    n => format!("{n} leaves"),
                }
            ));
            field(&format!(
                "depth       max {}, mean {:.1} (per triangle)",
                q.max_depth, q.mean_leaf_depth
            ));
            field(&format!(
                "leaves      mean {:.2} triangles, max {}",
                q.mean_leaf_triangles, q.max_leaf_triangles
            ));
            field(&format!(
                "SAH cost    {:.2} (node steps + triangle tests of a ray through the scene box, by area)",
                q.sah_cost
            ));
            let sizes = [sets.primary.len(), sets.incoherent.len()];
            for ((name, c), all) in [("primary", primary), ("incoherent", incoherent)]
                .into_iter()
                .zip(sizes)
            {
                let on = match c.sampled {
                    Some(n) => format!(
                        "measured on {n} of the {all} rays, evenly spread: all of them would \
                         take more than {} node visits and triangle tests",
                        cellbih::quality::rays::WORK_BUDGET
                    ),
                    None => "measured".into(),
                };
                field(&format!(
                    "{name:<11} {:.1} nodes + {:.1} triangles per ray, {:.2} Mrays/s ({on}, one thread)",
                    c.nodes, c.triangles, c.mrays_per_s
                ));
            }
            field(&format!(
                "tree        {} bytes (nodes and triangle ids), hash {}",
                q.memory_bytes,
                r.bih.tree_hash_hex()
            ));
            if let Some(m) = sim {
                print_footprint(&m.footprint, s.len(), r.bih.config.leaf_size);
                print_cores(m);
                let phases = m.phase_ms();
                if !phases.is_empty() {
                    let list: Vec<String> = phases
                        .iter()
                        .map(|(n, ms)| format!("{n} {ms:.2} ms"))
                        .collect();
                    field(&format!("phases      {}", list.join(", ")));
                }
            }
        }
    }
}

/// One line of the report: a label in its first 12 columns, the rest
/// wrapped to 80 columns under it.
fn field(line: &str) {
    let (label, text) = line.split_at(line.char_indices().nth(12).map_or(line.len(), |(i, _)| i));
    let text = crate::report::wrap(text, 80 - 12);
    println!("{label}{}", text.replace('\n', &format!("\n{:12}", "")));
}

/// Main memory by purpose, the widest level against the paper's sizing of
/// WorkAPPE, the local stores' high-water marks.
fn print_footprint(f: &Footprint, n: usize, leaf: u32) {
    let mb = |b: u64| b as f64 / (1024.0 * 1024.0);
    let parts: Vec<String> = (f.by_purpose.iter())
        .filter(|(_, b)| *b > 0)
        .map(|(p, b)| format!("{} {:.2}", p.name(), mb(*b)))
        .collect();
    field(&format!(
        "main memory {:.2} MiB: {} MiB; {:.2} MiB of node slots unused",
        mb(f.total),
        parts.join(", "),
        mb(f.unused_node_bytes)
    ));
    let hw = f.ls_high_water.iter().max().copied().unwrap_or(0);
    field(&format!(
        "            local store high-water {} KiB (most of the SPEs)",
        hw / 1024
    ));
    if f.bytes(Purpose::WorkPpe) > 0 {
        field(&format!(
            "            widest level {} jobs; WorkAPPE/WorkBPPE sized for {} (the paper's sizing: {n})",
            f.work_ppe_needed,
            work_ppe_jobs(n, leaf),
        ));
    }
}

/// Every core's counters in two tables that fit 80 columns: where its time
/// went (cycles; not in the functional mode, which times nothing), and what
/// it moved and, for a multi-SPE build, each SPE's jobs and ObjectArena
/// blocks.
fn print_cores(m: &cellbih::registry::Simulated) {
    let work = !m.spe_work.is_empty();
    let note = |text: &str| println!("{}", crate::report::wrap(text, 80));
    if m.run.timed {
        println!(
            "\n{:<7} {:>11} {:>11} {:>11} {:>11} {:>11} {:>11}",
            "core", "busy", "DMA wait", "mem shared", "mbox wait", "atomic", "idle"
        );
        for (name, c) in &m.run.cores {
            println!(
                "{name:<7} {:>11} {:>11} {:>11} {:>11} {:>11} {:>11}",
                c.busy.0, c.dma_wait.0, c.memory_wait.0, c.mailbox_wait.0, c.atomic.0, c.idle.0,
            );
        }
        note(
            "(cycles; \"mem shared\": what sharing the memory interface added to the \
             core's transfers; \"mbox wait\": mailboxes and signals, a barrier's wait is one)",
        );
        let started = m
            .run
            .cores
            .iter()
            .filter(|(_, c)| c.start > Cycles::ZERO)
            .count();
        if let Some((_, ppe)) = m.run.cores.first().filter(|(_, c)| c.start > Cycles::ZERO) {
            note(&format!(
                "(before them the PPE started {} in {} cycles, one after another)",
                crate::report::count((started - 1) as u64, "SPE program"),
                ppe.start.0
            ));
        }
    } else {
        println!("\n(the functional mode times nothing: no cycles per core)");
    }
    print!(
        "\n{:<7} {:>8} {:>8} {:>4}",
        "core", "MB in", "MB out", "lost"
    );
    if work {
        print!(
            " {:>8} {:>6} {:>6} {:>6} {:>6} {:>6} {:>5}",
            "jobs", "taken", "stolen", "blocks", "unused", "local", "limit"
        );
    }
    println!();
    for (i, (name, c)) in m.run.cores.iter().enumerate() {
        print!(
            "{name:<7} {:>8.2} {:>8.2} {:>4}",
            c.bytes_get as f64 / 1e6,
            c.bytes_put as f64 / 1e6,
            c.reservations_lost,
        );
        if let Some(w) = i.checked_sub(1).and_then(|k| m.spe_work.get(k)) {
            print!(
                " {:>8} {:>6} {:>6} {:>6} {:>6} {:>6} {:>5}",
                w.jobs,
                w.taken,
                w.stolen,
                w.arena_blocks,
                w.arena_unused,
                w.subtrees,
                w.subtree_limit
            );
        }
        println!();
    }
    note(&format!(
        "(MB moved by DMA; lost: reservations lost{})",
        if work {
            "; jobs: nodes made; taken: takes from the shared job queue that found jobs \
             (spe_bfs_shared) or regions built (spe_morton); stolen: dealt jobs taken from \
             another SPE's list; blocks: ObjectArena blocks taken, unused: their slots \
             without a node; local: jobs finished as subtrees in the local store (--finish \
             local), limit: the most triangles such a job could have"
        } else {
            ""
        }
    ));
    print_phases(m);
    let mut cache = cellbih::cast::CacheStats::default();
    for w in &m.spe_work {
        cache += w.job_cache;
    }
    if cache.lookups > 0 {
        note(&format!(
            "job-queue software cache (--job-cache): {} line lookups, {} misses (hit rate {:.1} %), emptied {} times",
            cache.lookups,
            cache.misses,
            cache.hit_rate() * 100.0,
            cache.invalidations
        ));
    }
}

/// Where a breadth-first build's SPEs spent their run, phase by phase:
/// the top levels, the levels they streamed, the subtrees they finished
/// in the local store (nothing for other builds, or untimed runs).
fn print_phases(m: &Simulated) {
    let spes = m.run.cores.iter().skip(1).zip(&m.spe_work);
    if !m.run.timed || m.spe_work.iter().all(|w| w.top.cycles == 0) {
        return;
    }
    let mut phases = [Phase::default(); 3];
    for ((_, c), w) in spes {
        let end = m.run.cycles.0 - c.idle.0;
        let all = Phase {
            cycles: end,
            dma_wait: c.dma_wait.0,
            bytes: c.bytes_get + c.bytes_put,
        };
        let (top, sub) = (w.top, w.in_subtrees);
        phases[0] += top;
        phases[1] += Phase {
            cycles: all.cycles - top.cycles - sub.cycles,
            dma_wait: all.dma_wait - top.dma_wait - sub.dma_wait,
            bytes: all.bytes - top.bytes - sub.bytes,
        };
        phases[2] += sub;
    }
    let k = m.spe_work.len() as f64;
    let ms_per_cycle = m.run.ms / m.run.cycles.0.max(1) as f64;
    println!(
        "\n{:<16} {:>8} {:>6} {:>9} {:>9} {:>8}",
        "phase", "ms", "share", "DMA wait", "MB/SPE", "least ms"
    );
    let names = ["top levels", "streamed levels", "subtrees", "all"];
    let mut all = Phase::default();
    for p in phases {
        all += p;
    }
    let total = all.cycles;
    for (name, p) in names.iter().zip(phases.into_iter().chain([all])) {
        let ms = p.cycles as f64 / k * ms_per_cycle;
        let of = |x: u64, y: u64| 100.0 * x as f64 / y.max(1) as f64;
        println!(
            "{name:<16} {ms:>8.2} {:>5.0}% {:>8.0}% {:>9.2} {:>8.2}",
            of(p.cycles, total),
            of(p.dma_wait, p.cycles),
            p.bytes as f64 / k / 1e6,
            m.run.memory_shared.cycles(p.bytes).0 as f64 * ms_per_cycle,
        );
    }
    println!(
        "{}",
        crate::report::wrap(
            &format!(
                "(the mean of {}: ms and share of its run, the share of that it waited on DMA, MB \
         it moved; least ms: every SPE's bytes of the phase at the memory interface's shared \
         bandwidth, so the bytes alone allow this run at most {:.2}x faster; top levels: the \
         starts, the top built or helped with, the deal)",
                crate::report::count(m.spe_work.len() as u64, "SPE"),
                m.run.cycles.0 as f64 / m.run.memory_shared.cycles(all.bytes).0.max(1) as f64,
            ),
            80
        )
    );
}

/// The strategy's own decision of how many SPEs to use, said of builders
/// that put every SPE to work (the paper's use one or none by design) when
/// it used fewer than given.
fn spes_used_line(m: &Simulated, builder: BuilderKind) -> Option<String> {
    let given = m.run.cores.len() - 1;
    if !builder.multi_spe() || m.spes_used >= given {
        return None;
    }
    let takes = builder.knobs().iter().any(|k| k.name == TRIS_PER_SPE.name);
    let why = match (takes, &m.predicted) {
        (false, _) => String::new(),
        (true, Some(_)) => format!(
            ": the count it predicts fastest (--{} 1 uses every SPE)",
            TRIS_PER_SPE.name
        ),
        (true, None) => format!(
            ": a small scene runs on fewer (--{} 1 uses every SPE)",
            TRIS_PER_SPE.name
        ),
    };
    Some(format!("SPEs used   {} of {given}{why}", m.spes_used))
}
