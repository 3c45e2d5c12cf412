//! What `cellbih info` and `cellbih build` print: a scene's facts, a
//! build's time, tree and, for an emulated builder, every core's counters.

use serde_json::json;

use cellbih::bih::Tracer;
use cellbih::quality::rays::RaySets;
use cellbih::registry::BuildReport;
use cellbih::scene::Scene;
use cellbih::strategy::machinery::footprint::{Footprint, Purpose, work_ppe_jobs};

use super::{Format, Res};

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

/// The SPEs a build ran programs on: those that report work (a
/// multi-SPE builder on a small scene uses fewer), else every SPE that
/// was busy.
fn spes_used(m: &cellbih::strategy::Simulated) -> usize {
    match m.spe_work.len() {
        0 => m.run.cores[1..]
            .iter()
            .filter(|(_, c)| c.busy.0 > 0)
            .count(),
        k => k,
    }
}

pub fn print_build(s: &Scene, r: &BuildReport, format: Format) {
    let q = r.bih.quality();
    let (primary, incoherent) = RaySets::standard(&s.bounds()).measure(&Tracer::new(&r.bih, s));
    let ms = r.host_time.as_secs_f64() * 1e3;
    let sim = r.simulated.as_ref();
    let timed = sim.filter(|m| m.run.timed);
    match format {
        Format::Json => println!(
            "{}",
            json!({
                "scene": s.name, "triangles": s.len(), "builder": r.builder.name(),
                "threads": r.threads,
                "host_ms": ms, "quality": q,
                "footprint": sim.map(|m| &m.footprint),
                "rays": { "primary": primary, "incoherent": incoherent },
                "simulated_ms": timed.map(|m| m.run.ms),
                "spes": sim.map(|m| m.run.cores.len() - 1),
                "spes_used": sim.map(spes_used),
                "simulated_cycles": timed.map(|m| m.run.cycles.0),
                "timing": sim.map(|m| if m.run.timed { "simulated" } else { "none: functional mode" }),
                "cores": sim.map(|m| &m.run.cores),
                "work": sim.map(|m| m.stats),
                "spe_work": sim.map(|m| &m.spe_work),
                "phases": sim.map(|m| m.phase_ms().iter()
                    .map(|(name, ms)| json!({ "phase": name, "ms": ms }))
                    .collect::<Vec<_>>()),
            })
        ),
        Format::Text => {
            println!("scene       {} ({} triangles)", s.name, s.len());
            match r.threads {
                Some(n) => println!(
                    "builder     {} on {n} host thread{}",
                    r.builder,
                    if n == 1 { "" } else { "s" }
                ),
                None => println!("builder     {}", r.builder),
            }
            match sim {
                Some(m) if !m.run.timed => println!(
                    "simulated   none: functional mode (no timing) with {}",
                    super::spes(m.run.cores.len() - 1)
                ),
                Some(m) => println!(
                    "simulated   {:.2} ms on the PS3 model with {} ({} cycles)",
                    m.run.ms,
                    super::spes(m.run.cores.len() - 1),
                    m.run.cycles.0
                ),
                None => {}
            }
            if let Some(m) = sim.filter(|m| spes_used(m) < m.run.cores.len() - 1) {
                println!(
                    "SPEs used   {} of {}: a small scene runs on fewer (--tris-per-spe 1 uses every SPE)",
                    spes_used(m),
                    m.run.cores.len() - 1
                );
            }
            if sim.is_some() {
                println!("host time   {ms:.2} ms (the emulation)");
            } else {
                println!(
                    "host time   {ms:.2} ms ({:.2} Mtris/s)",
                    s.len() as f64 / ms / 1e3
                );
            }
            println!(
                "nodes       {} ({} inner, {} leaves)",
                q.nodes, q.inner_nodes, q.leaves
            );
            println!(
                "depth       max {}, mean {:.1} (per triangle)",
                q.max_depth, q.mean_leaf_depth
            );
            println!(
                "leaves      mean {:.2} triangles, max {}",
                q.mean_leaf_triangles, q.max_leaf_triangles
            );
            println!(
                "SAH cost    {:.2} (node steps + triangle tests of a ray through the scene box, by area)",
                q.sah_cost
            );
            for (name, c) in [("primary", primary), ("incoherent", incoherent)] {
                println!(
                    "{name:<11} {:.1} nodes + {:.1} triangles per ray, {:.2} Mrays/s (measured, one thread)",
                    c.nodes, c.triangles, c.mrays_per_s
                );
            }
            println!(
                "tree        {} bytes (nodes and triangle ids)",
                q.memory_bytes
            );
            if let Some(m) = sim {
                print_footprint(&m.footprint, s.len(), r.bih.config.leaf_size);
                print_cores(m);
                let phases = m.phase_ms();
                if !phases.is_empty() {
                    let list: Vec<String> = phases
                        .iter()
                        .map(|(n, ms)| format!("{n} {ms:.2} ms"))
                        .collect();
                    println!("phases      {}", list.join(", "));
                }
            }
        }
    }
}

/// Main memory by purpose, the widest level against the paper's sizing of
/// WorkAPPE, the local stores' high-water marks.
fn print_footprint(f: &Footprint, n: usize, leaf: u32) {
    let mb = |b: u64| b as f64 / (1024.0 * 1024.0);
    let parts: Vec<String> = (f.by_purpose.iter())
        .filter(|(_, b)| *b > 0)
        .map(|(p, b)| format!("{} {:.2}", p.name(), mb(*b)))
        .collect();
    println!(
        "main memory {:.2} MiB: {} MiB; {:.2} MiB of node slots unused",
        mb(f.total),
        parts.join(", "),
        mb(f.unused_node_bytes)
    );
    let hw = f.ls_high_water.iter().max().copied().unwrap_or(0);
    println!(
        "            local store high-water {} KiB (most of the SPEs)",
        hw / 1024
    );
    if f.bytes(Purpose::WorkPpe) > 0 {
        println!(
            "            widest level {} jobs; WorkAPPE/WorkBPPE sized for {} (the paper's sizing: {n})",
            f.work_ppe_needed,
            work_ppe_jobs(n, leaf),
        );
    }
}

/// Every core's counters; for a multi-SPE build also each SPE's jobs and
/// ObjectArena blocks.
fn print_cores(m: &cellbih::registry::Simulated) {
    let work = !m.spe_work.is_empty();
    print!(
        "\n{:<7} {:>11} {:>11} {:>11} {:>11} {:>10} {:>5} {:>11} {:>8} {:>8}",
        "core",
        "busy",
        "DMA wait",
        "mem shared",
        "mbox wait",
        "atomic",
        "lost",
        "idle",
        "MB in",
        "MB out"
    );
    if work {
        print!(
            " {:>8} {:>6} {:>6} {:>7} {:>7}",
            "jobs", "taken", "stolen", "blocks", "unused"
        );
    }
    println!();
    for (i, (name, c)) in m.run.cores.iter().enumerate() {
        print!(
            "{name:<7} {:>11} {:>11} {:>11} {:>11} {:>10} {:>5} {:>11} {:>8.2} {:>8.2}",
            c.busy.0,
            c.dma_wait.0,
            c.memory_wait.0,
            c.mailbox_wait.0,
            c.atomic.0,
            c.reservations_lost,
            c.idle.0,
            c.bytes_get as f64 / 1e6,
            c.bytes_put as f64 / 1e6,
        );
        if let Some(w) = i.checked_sub(1).and_then(|k| m.spe_work.get(k)) {
            print!(
                " {:>8} {:>6} {:>6} {:>7} {:>7}",
                w.jobs, w.taken, w.stolen, w.arena_blocks, w.arena_unused
            );
        }
        println!();
    }
    println!(
        "(cycles; \"mem shared\": what sharing the memory interface added to the core's \
         transfers; \"mbox wait\": mailboxes and signals (a barrier's wait is one); lost: reservations lost; MB moved by \
         DMA{})",
        if work {
            "; jobs: nodes made; taken: takes from the shared job queue that found jobs (spe_bfs_shared) or regions built (spe_morton); stolen: \
             dealt jobs taken from another SPE's list; blocks: \
             ObjectArena blocks taken, unused: their slots without a node"
        } else {
            ""
        }
    );
    let mut cache = cellbih::cast::CacheStats::default();
    for w in &m.spe_work {
        cache += w.job_cache;
    }
    if cache.lookups > 0 {
        println!(
            "job-queue software cache (--job-cache): {} line lookups, {} misses (hit rate {:.1} %), emptied {} times",
            cache.lookups,
            cache.misses,
            cache.hit_rate() * 100.0,
            cache.invalidations
        );
    }
}
