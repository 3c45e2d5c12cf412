//! `validate`'s figures where several cores meet one line or one bus, and
//! the start of a program: puts from six SPEs into one 128-byte line, the
//! PPE and six SPEs handing one lock line round a ring, eight SPEs on the
//! EIB of a Cell blade, and starting and joining SPE programs. Each is
//! reproduced as its source's kernel does it.

use cellbih::cell::{Cell, CellConfig, CellError, CostModel, Cycles, LsAddr};

use super::{Figure, Role, cell, eib, seconds, take_turn};

/// SpuTest's `task_put.c` as it was until 2024 (`test_block.c` then gave
/// every SPE the same 128-byte target): each of `spes` SPEs puts 32 bytes
/// into the one line `count` times on one tag, never waiting but for room
/// in its MFC queue. Returns ns per put, aggregate.
fn puts_into_one_line(cost: &CostModel, spes: usize, count: u32) -> Result<f64, CellError> {
    // Unchecked: the source leaves its puts to one place unordered, which
    // checked mode refuses.
    let mut cfg = CellConfig::ps3().with_spes(spes);
    cfg.cost = cost.clone();
    cfg.checked = false;
    cfg.resident = true;
    let mut c = Cell::new(cfg)?;
    let line = c.memory_mut().alloc("line", 128, 128)?;
    for id in 0..spes {
        c.spawn_spe(id, move |spe| async move {
            let buf = spe.ls_alloc(128, 128)?;
            let tag = spe.tag("put")?;
            for i in 0..count {
                // The source's rotating 32-byte window of its buffer.
                let from = LsAddr(buf.0 + (i % 6) * 16);
                spe.put(from, line, 32, tag).await?;
            }
            spe.wait_tag(tag).await
        });
    }
    let run = c.run()?;
    Ok(seconds(cost, run.cycles) * 1e9 / (spes as u32 * count) as f64)
}

/// SpuTest's `task_spuspinlock.c` and `test_spinlock.c`: a ring of the
/// PPE and `spes` SPEs on one word. SPE `i` waits for the value `i` and
/// swaps in `i + 1` (getllar, compare, putllc when it matches; retried on
/// a lost reservation); the PPE waits for `spes` and swaps in 0 (its
/// compare-and-swap). Returns ns per hand-off.
fn spin_ring(cost: &CostModel, spes: usize, rounds: u32) -> Result<f64, CellError> {
    let mut c = cell(cost, spes)?;
    let word = c.memory_mut().alloc("lock", 128, 128)?;
    for id in 0..spes {
        c.spawn_spe(id, move |spe| async move {
            let buf = spe.ls_alloc(128, 128)?;
            for _ in 0..rounds {
                take_turn(&spe, buf, word, |v| (v == id as u32).then_some(v + 1)).await?;
            }
            Ok(())
        });
    }
    c.spawn_ppe(move |ppe| async move {
        for _ in 0..rounds {
            while ppe.atomic_cas_u32(word, spes as u32, 0).await? != spes as u32 {}
        }
        Ok(())
    });
    let run = c.run()?;
    let hand_offs = rounds as u64 * (spes as u64 + 1);
    Ok(seconds(cost, run.cycles) * 1e9 / hand_offs as f64)
}

/// SpuTest's `test_avalanche.c`: the PPE starts trivial programs on `spes`
/// SPEs and joins them, `runs` times. Returns µs per program.
fn avalanche(cost: &CostModel, spes: usize, runs: u32) -> Result<f64, CellError> {
    let mut cfg = CellConfig::ps3().with_spes(spes);
    cfg.cost = cost.clone();
    let mut c = Cell::new(cfg)?;
    let mut total = Cycles::ZERO;
    for _ in 0..runs {
        for id in 0..spes {
            c.spawn_spe(id, |spe| async move {
                spe.compute(Cycles(1));
                Ok(())
            });
        }
        total += c.run()?.cycles;
    }
    Ok(seconds(cost, total) * 1e6 / (runs as usize * spes) as f64)
}

pub fn figures() -> Vec<Figure> {
    vec![
        Figure {
            what: "6 SPEs putting 32 bytes into one line, no wait, per put",
            source: "SpuTest task_put.c (until 2024)",
            published: 3984e6 / 60e6,
            unit: "ns",
            tolerance: 0.25,
            role: Role::Fitted("partial_puts_claim"),
            probe: Box::new(|c| puts_into_one_line(c, 6, 2000)),
        },
        Figure {
            what: "PPE and 6 SPEs handing one lock line round a ring, per hand-off",
            source: "SpuTest task_spuspinlock.c",
            published: 4409e6 / 1.5e6 / 7.0,
            unit: "ns",
            tolerance: 0.25,
            role: Role::HeldOut,
            probe: Box::new(|c| spin_ring(c, 6, 300)),
        },
        Figure {
            what: "8 SPEs in 4 disjoint pairs, both directions (a Cell blade): aggregate",
            source: "Kistler, Perrone & Petrini 2006",
            published: 200.0,
            unit: "GB/s",
            tolerance: 0.15,
            role: Role::Fitted("eib_total_bandwidth_blade"),
            probe: Box::new(|c| {
                let pairs: Vec<(usize, usize)> = (0..8).map(|s| (s, s ^ 1)).collect();
                eib(c, 8, &pairs)
            }),
        },
        Figure {
            what: "start, run and join a trivial SPU program, 6 SPUs, per program",
            source: "SpuTest test_avalanche.c",
            published: 2740e3 / 1_048_576.0,
            unit: "us",
            tolerance: 0.10,
            role: Role::Fitted("spe_start_cycles"),
            probe: Box::new(|c| avalanche(c, 6, 20)),
        },
    ]
}
