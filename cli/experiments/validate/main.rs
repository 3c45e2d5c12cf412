//! The machine model held against real PS3s: each published
//! measurement of several SPEs at once (`../shared/CELL-FACTS.md`,
//! `docs/validation.md`) reproduced through the emulator's public API as
//! its source's kernel does it — the same transfer sizes, DMAs in flight,
//! windows and retry loops — beside the published figure, with a verdict
//! per figure and a non-zero exit when one leaves its tolerance; then SPU
//! compute kernels timed on a real PS3 beside their instruction counts
//! (`compute.rs`).
//!
//! `cargo run --release --bin validate -- [--model measured|legacy] [--threads N] [--out results]`

use clap::{Parser, ValueEnum};
use serde_json::json;

use cellbih::cell::{Cell, CellConfig, CellError, CostModel, Cycles, Ea, LsAddr, Reservation, Spe};

mod compute;
mod contention;
mod ppe;
mod sorts;
use cellbih_cli::args::RunArgs;
use cellbih_cli::report::{Format, side_by_side};

#[derive(Parser)]
#[command(
    about = "The machine model held against published PS3 measurements with several SPEs, and SPU kernels timed on a PS3 beside their instruction counts (default run: under a second)"
)]
struct Args {
    /// The cost model to hold against the PS3: `measured` (the default
    /// model, `CostModel::ps3`) or `legacy` (the model before the validated one,
    /// `CostModel::ps3_legacy`).
    #[arg(long, value_enum, default_value = "measured")]
    model: Model,
    #[command(flatten)]
    run: RunArgs,
    #[command(flatten)]
    rates: cellbih_cli::args::RateSetArgs,
}

#[derive(Clone, Copy, ValueEnum)]
enum Model {
    Measured,
    Legacy,
}

impl Model {
    fn cost(self) -> CostModel {
        match self {
            Model::Measured => CostModel::ps3(),
            Model::Legacy => CostModel::ps3_legacy(),
        }
    }
}

/// One published figure and how to reproduce it.
struct Figure {
    what: &'static str,
    source: &'static str,
    published: f64,
    unit: &'static str,
    /// Relative tolerance (0.10: ±10 %).
    tolerance: f64,
    /// What the figure set, bounded, or that it set nothing.
    role: Role,
    probe: Probe,
}

/// What a figure did to the model. A figure that set a rate or justified
/// a mechanism is fitted (its row shows the fit took, and proves nothing
/// about prediction); one that set a band's end bounds; only a figure
/// that set nothing is held out and tests what the model predicts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Set this rate, factor or mechanism.
    Fitted(&'static str),
    /// Set this band's end.
    Bounds(&'static str),
    /// Set nothing.
    HeldOut,
}

impl Role {
    /// Its name in the rows: `fitted`, `bounding` or `held-out`.
    pub fn name(self) -> &'static str {
        match self {
            Role::Fitted(_) => "fitted",
            Role::Bounds(_) => "bounding",
            Role::HeldOut => "held-out",
        }
    }

    /// The row's `role`, and `sets` (what it set or bounds, null when
    /// held out), as JSON fields.
    pub fn fields(self) -> [(&'static str, serde_json::Value); 2] {
        let what = match self {
            Role::Fitted(w) | Role::Bounds(w) => serde_json::Value::from(w),
            Role::HeldOut => serde_json::Value::Null,
        };
        [("role", self.name().into()), ("sets", what)]
    }
}

/// How a figure is reproduced on a cost model.
type Probe = Box<dyn Fn(&CostModel) -> Result<f64, CellError> + Send + Sync>;

const KIB16: u32 = 16 * 1024;

/// A machine of `spes` SPEs on `cost`, with room for the probes' windows.
/// Its programs are resident: the sources time runs so long (or time
/// inside the SPU program) that starting it adds nothing they see.
fn cell(cost: &CostModel, spes: usize) -> Result<Cell, CellError> {
    let mut cfg = CellConfig::ps3().with_spes(spes);
    cfg.cost = cost.clone();
    cfg.resident = true;
    Cell::new(cfg)
}

fn seconds(cost: &CostModel, c: Cycles) -> f64 {
    c.0 as f64 / cost.clock_hz
}

/// cellmark's DMA kernel (`engine/spu_shared/spu_dma_kernel.c`): each of
/// `spes` SPEs streams `iterations` transfers of `size` bytes through its
/// own 1 MiB window, `depth` in flight (a ring of tags: wait for the oldest,
/// issue the next). Returns the aggregate GB/s over the run.
fn stream(
    cost: &CostModel,
    spes: usize,
    put: bool,
    size: u32,
    depth: u32,
    iterations: u64,
) -> Result<f64, CellError> {
    let mut c = cell(cost, spes)?;
    let window = 1u64 << 20;
    let base = c.memory_mut().alloc("windows", window * spes as u64, 128)?;
    for id in 0..spes {
        let mine = base.offset(id as u64 * window);
        c.spawn_spe(id, move |spe| async move {
            let ring: Vec<LsAddr> = (0..depth)
                .map(|_| spe.ls_alloc(size, 128))
                .collect::<Result<_, _>>()?;
            let tags = spe.tags("ring", depth)?;
            let mut off = 0u64;
            for i in 0..iterations {
                let slot = (i % depth as u64) as u32;
                if i >= depth as u64 {
                    spe.wait_tag(tags + slot).await?;
                }
                let (ls, ea) = (ring[slot as usize], mine.offset(off));
                match put {
                    true => spe.put(ls, ea, size, tags + slot).await?,
                    false => spe.get(ls, ea, size, tags + slot).await?,
                }
                off = (off + size as u64) % window;
            }
            for slot in 0..depth {
                spe.wait_tag(tags + slot).await?;
            }
            Ok(())
        });
    }
    let run = c.run()?;
    let bytes = spes as u64 * iterations * size as u64;
    Ok(bytes as f64 / seconds(cost, run.cycles) / 1e9)
}

/// cellmark's EIB kernel (`benches/eib/spu_eib_main.c`): each reader SPE
/// gets 16 KiB blocks from its target SPE's local store, 8 in flight.
/// `pairs` are (reader, target). Returns the aggregate GB/s.
fn eib(cost: &CostModel, spes: usize, pairs: &[(usize, usize)]) -> Result<f64, CellError> {
    let mut c = cell(cost, spes)?;
    let (depth, iterations) = (8u32, 128u64);
    for &(reader, target) in pairs {
        c.spawn_spe(reader, move |spe| async move {
            let ring: Vec<LsAddr> = (0..depth)
                .map(|_| spe.ls_alloc(KIB16, 128))
                .collect::<Result<_, _>>()?;
            let tags = spe.tags("ring", depth)?;
            // The target's buffer: the upper half of its local store.
            let src = Ea::of_local_store(target, 128 * 1024);
            for i in 0..iterations {
                let slot = (i % depth as u64) as u32;
                if i >= depth as u64 {
                    spe.wait_tag(tags + slot).await?;
                }
                spe.get(ring[slot as usize], src, KIB16, tags + slot)
                    .await?;
            }
            for slot in 0..depth {
                spe.wait_tag(tags + slot).await?;
            }
            Ok(())
        });
    }
    let run = c.run()?;
    let bytes = pairs.len() as u64 * iterations * KIB16 as u64;
    Ok(bytes as f64 / seconds(cost, run.cycles) / 1e9)
}

/// cellmark's atomic ping-pong (`benches/atomic/spu_atomic_main.c`): two
/// SPEs poll one line by getllar; the one whose parity matches increments
/// it by putllc (retrying on a lost reservation). Returns ns per bounce
/// (total time over both SPEs' successful stores).
fn ping_pong(cost: &CostModel) -> Result<f64, CellError> {
    let mut c = cell(cost, 2)?;
    let line = c.memory_mut().alloc("line", 128, 128)?;
    let rounds = 2000u32;
    for id in 0..2 {
        c.spawn_spe(id, move |spe| async move {
            let buf = spe.ls_alloc(128, 128)?;
            for _ in 0..rounds {
                take_turn(&spe, buf, line, |v| (v & 1 == id as u32).then_some(v + 1)).await?;
            }
            Ok(())
        });
    }
    let run = c.run()?;
    Ok(seconds(cost, run.cycles) * 1e9 / (2 * rounds) as f64)
}

/// The polling loop of cellmark's and SpuTest's lock-line kernels: getllar
/// the line into `buf` until `turn` accepts its first word (and gives the
/// word to store), then putllc; from the getllar again on a lost
/// reservation.
async fn take_turn(
    spe: &Spe,
    buf: LsAddr,
    line: Ea,
    turn: impl Fn(u32) -> Option<u32>,
) -> Result<(), CellError> {
    loop {
        spe.getllar(buf, line).await?;
        let Some(next) = turn(spe.ls_read::<u32>(buf, 1)?[0]) else {
            continue;
        };
        spe.ls_write(buf, &[next])?;
        if spe.putllc(buf, line).await? == Reservation::Stored {
            return Ok(());
        }
    }
}

/// SpuTest's `task_putllc.c`: every SPE repeats getllar/putllc on one line
/// until the store succeeds, `count` times; with `ppe_threads`, its
/// `test_mfc64.c`: the PPE's hardware threads increment the line too
/// (`cellAtomicIncr64`: lwarx/stwcx.), `count` times each, the PPE program
/// interleaving its threads' increments. Returns ns per increment,
/// aggregate.
fn increments(cost: &CostModel, spes: usize, ppe_threads: u32) -> Result<f64, CellError> {
    let mut c = cell(cost, spes)?;
    let line = c.memory_mut().alloc("line", 128, 128)?;
    let count = 1000u32;
    for id in 0..spes {
        c.spawn_spe(id, move |spe| async move {
            let buf = spe.ls_alloc(128, 128)?;
            for _ in 0..count {
                loop {
                    spe.getllar(buf, line).await?;
                    if spe.putllc(buf, line).await? == Reservation::Stored {
                        break;
                    }
                }
            }
            Ok(())
        });
    }
    if ppe_threads > 0 {
        c.spawn_ppe(move |ppe| async move {
            for _ in 0..ppe_threads * count {
                ppe.atomic_fetch_add_u32(line, 1).await?;
            }
            Ok(())
        });
    }
    let run = c.run()?;
    let total = (spes as u32 + ppe_threads) * count;
    Ok(seconds(cost, run.cycles) * 1e9 / total as f64)
}

/// SpuTest's `task_putlluc.c`: every SPE stores one line unconditionally,
/// `count` times. Returns ns per store, aggregate.
fn putllucs(cost: &CostModel, spes: usize) -> Result<f64, CellError> {
    let mut c = cell(cost, spes)?;
    let line = c.memory_mut().alloc("line", 128, 128)?;
    let count = 2000u32;
    for id in 0..spes {
        c.spawn_spe(id, move |spe| async move {
            let buf = spe.ls_alloc(128, 128)?;
            for _ in 0..count {
                spe.putlluc(buf, line).await?;
            }
            Ok(())
        });
    }
    let run = c.run()?;
    Ok(seconds(cost, run.cycles) * 1e9 / (spes as u32 * count) as f64)
}

/// SpuTest's `task_put.c` and `task_largeput.c`: every SPE puts `size`
/// bytes to its own place and waits for the put, `count` times. Returns
/// ns per put and wait, as one SPE sees it.
fn put_and_wait(cost: &CostModel, spes: usize, size: u32, count: u32) -> Result<f64, CellError> {
    let mut c = cell(cost, spes)?;
    let stride = (size as u64).max(128);
    let base = c.memory_mut().alloc("targets", stride * spes as u64, 128)?;
    for id in 0..spes {
        let at = base.offset(id as u64 * stride);
        c.spawn_spe(id, move |spe| async move {
            let buf = spe.ls_alloc(size.max(128), 128)?;
            let tag = spe.tag("put")?;
            for _ in 0..count {
                spe.put(buf, at, size, tag).await?;
                spe.wait_tag(tag).await?;
            }
            Ok(())
        });
    }
    let run = c.run()?;
    Ok(seconds(cost, run.cycles) * 1e9 / count as f64)
}

/// Kistler et al.: one 128-byte get, from issue to completion seen by the
/// SPE. Returns ns.
fn lone_dma(cost: &CostModel) -> Result<f64, CellError> {
    let mut c = cell(cost, 1)?;
    let src = c.memory_mut().alloc("line", 128, 128)?;
    let exit = c.spawn_spe(0, move |spe| async move {
        let buf = spe.ls_alloc(128, 128)?;
        let start = spe.now();
        spe.get(buf, src, 128, 0).await?;
        spe.wait_tag(0).await?;
        Ok(spe.now() - start)
    });
    c.run()?;
    Ok(seconds(cost, exit.take("SPE 0")?) * 1e9)
}

/// cellmark's mailbox bench (§3.6): the PPE writes an SPE's inbound
/// mailbox and waits for its answer through the event queue; the SPE
/// reads, adds one and answers through its interrupting outbound mailbox.
/// Returns µs per round trip, with the mailboxes reached through the PS3
/// kernel as cellmark's thread-mode SPUs reach them.
fn mailbox(cost: &CostModel) -> Result<f64, CellError> {
    let cost = &cost.clone().with_ps3_kernel_mailboxes();
    let mut c = cell(cost, 1)?;
    let rounds = 64u32;
    c.spawn_spe(0, move |spe| async move {
        for _ in 0..rounds {
            let v = spe.read_in_mbox().await;
            spe.write_out_mbox(v + 1).await;
        }
        Ok(())
    });
    c.spawn_ppe(move |ppe| async move {
        let mut v = 0;
        for _ in 0..rounds {
            ppe.write_in_mbox(0, v).await?;
            v = ppe.wait_any_out_mbox(&[0]).await?.1;
        }
        Ok(())
    });
    let run = c.run()?;
    Ok(seconds(cost, run.cycles) * 1e6 / rounds as f64)
}

fn figures() -> Vec<Figure> {
    let mut v = vec![
        Figure {
            what: "6 SPEs, 16 KiB gets, 2 in flight: aggregate",
            source: "cellmark §4.1, §2.3.2",
            published: 22.83,
            unit: "GB/s",
            tolerance: 0.10,
            role: Role::Fitted("memory_shared_bandwidth"),
            probe: Box::new(|c| stream(c, 6, false, KIB16, 2, 256)),
        },
        Figure {
            what: "6 SPEs, 16 KiB gets, 8 in flight: aggregate",
            source: "cellmark §2.3.2",
            published: 22.83,
            unit: "GB/s",
            tolerance: 0.10,
            role: Role::Fitted("memory_shared_bandwidth"),
            probe: Box::new(|c| stream(c, 6, false, KIB16, 8, 256)),
        },
        Figure {
            what: "6 SPEs, 16 KiB puts, 2 in flight: aggregate",
            source: "cellmark §4.1",
            published: 22.13,
            unit: "GB/s",
            tolerance: 0.10,
            role: Role::HeldOut,
            probe: Box::new(|c| stream(c, 6, true, KIB16, 2, 256)),
        },
    ];
    for (size, tolerance) in [(256u32, 0.15), (1024, 0.10), (4096, 0.10)] {
        v.push(Figure {
            what: match size {
                256 => "6 SPEs, 256 B gets, 8 in flight: aggregate",
                1024 => "6 SPEs, 1 KiB gets, 8 in flight: aggregate",
                _ => "6 SPEs, 4 KiB gets, 8 in flight: aggregate",
            },
            source: "cellmark §2.3.1",
            published: 22.0,
            unit: "GB/s",
            tolerance,
            role: Role::HeldOut,
            probe: Box::new(move |c| {
                let iterations = (1u64 << 20) / size as u64;
                stream(c, 6, false, size, 8, iterations)
            }),
        });
    }
    v.push(Figure {
        what: "1 SPE, 16 KiB gets, 2 in flight (a lone stream reaches the peak)",
        source: "Kistler, Perrone & Petrini 2006",
        published: 25.6,
        unit: "GB/s",
        tolerance: 0.05,
        role: Role::Fitted("memory_bandwidth"),
        probe: Box::new(|c| stream(c, 1, false, KIB16, 2, 256)),
    });
    v.push(Figure {
        what: "one SPE reading a peer's local store, 16 KiB gets",
        source: "cellmark §3.4",
        published: 23.42,
        unit: "GB/s",
        tolerance: 0.10,
        role: Role::Fitted("ls_port_bandwidth"),
        probe: Box::new(|c| eib(c, 6, &[(1, 0)])),
    });
    v.push(Figure {
        what: "3 disjoint SPE pairs, both directions: aggregate",
        source: "cellmark §3.1",
        published: 114.73,
        unit: "GB/s",
        tolerance: 0.15,
        role: Role::Fitted("eib_total_bandwidth"),
        probe: Box::new(|c| eib(c, 6, &[(0, 1), (1, 0), (2, 3), (3, 2), (4, 5), (5, 4)])),
    });
    for (n, published) in [(1, 23.58), (2, 23.78), (3, 23.86), (4, 23.76), (5, 23.71)] {
        v.push(Figure {
            what: match n {
                1 => "1 SPE reading SPE 0's local store",
                2 => "2 SPEs reading SPE 0's local store: aggregate",
                3 => "3 SPEs reading SPE 0's local store: aggregate",
                4 => "4 SPEs reading SPE 0's local store: aggregate",
                _ => "5 SPEs reading SPE 0's local store: aggregate",
            },
            source: "cellmark §3.2-3.3",
            published,
            unit: "GB/s",
            tolerance: 0.15,
            role: Role::Fitted("ls_port_bandwidth"),
            probe: Box::new(move |c| {
                let readers: Vec<(usize, usize)> = (1..=n).map(|r| (r, 0)).collect();
                eib(c, 6, &readers)
            }),
        });
    }
    v.extend([
        Figure {
            what: "2-SPE getllar/putllc ping-pong on one line, per bounce",
            source: "cellmark §3.5",
            published: 150.0,
            unit: "ns",
            tolerance: 0.25,
            role: Role::HeldOut,
            probe: Box::new(ping_pong),
        },
        Figure {
            what: "6 SPEs incrementing one line (getllar/putllc, retry), per increment",
            source: "SpuTest task_putllc.c",
            published: 187.0,
            unit: "ns",
            tolerance: 0.25,
            role: Role::HeldOut,
            probe: Box::new(|c| increments(c, 6, 0)),
        },
        Figure {
            what: "6 SPEs and the PPE's 2 threads incrementing one line, per increment",
            source: "SpuTest test_mfc64.c",
            // 6 SPEs and 2 PPU threads, 3 M increments each, in 4443 ms.
            published: 4443e6 / 24e6,
            unit: "ns",
            tolerance: 0.25,
            role: Role::Fitted("the PPE's atomics (ppe_atomic_cycles, a claim a line)"),
            probe: Box::new(|c| increments(c, 6, 2)),
        },
        Figure {
            what: "6 SPEs putlluc on one line, per store",
            source: "SpuTest task_putlluc.c",
            published: 64.2,
            unit: "ns",
            tolerance: 0.25,
            role: Role::Fitted("lock_lines claim_cycles"),
            probe: Box::new(|c| putllucs(c, 6)),
        },
        Figure {
            what: "6 SPEs, 32-byte put then wait, own lines, per put",
            source: "SpuTest task_put.c",
            published: 152.0,
            unit: "ns",
            tolerance: 0.25,
            role: Role::Fitted("put_ack_cycles"),
            probe: Box::new(|c| put_and_wait(c, 6, 32, 2000)),
        },
        Figure {
            what: "6 SPEs, 16 KiB put then wait, per put",
            source: "SpuTest task_largeput.c",
            published: 4423.0,
            unit: "ns",
            tolerance: 0.10,
            role: Role::HeldOut,
            probe: Box::new(|c| put_and_wait(c, 6, KIB16, 200)),
        },
        Figure {
            what: "a lone 128-byte get, issue to completion",
            source: "Kistler, Perrone & Petrini 2006",
            published: 100.0,
            unit: "ns",
            tolerance: 0.05,
            role: Role::Fitted("dma_latency_cycles"),
            probe: Box::new(lone_dma),
        },
        Figure {
            what: "PPE-SPE mailbox round trip through the PS3 kernel",
            source: "cellmark §3.6",
            published: 11.6,
            unit: "us",
            tolerance: 0.25,
            role: Role::Fitted("mailbox_os_cycles"),
            probe: Box::new(mailbox),
        },
    ]);
    v.extend(contention::figures());
    v
}

/// A row's verdict.
fn verdict(ok: bool) -> String {
    (if ok { "pass" } else { "FAIL" }).to_string()
}

/// Columns of a row after its name.
const VALUE_COLUMNS: [usize; 5] = [9, 9, 6, 5, 7];

/// One row in 80 columns: the name wrapped to its column, the values
/// beside its first line.
fn row(text: bool, name: &str, values: [String; 5]) {
    if !text {
        return;
    }
    let width = 80 - VALUE_COLUMNS.iter().map(|w| w + 1).sum::<usize>();
    let wrapped = cellbih_cli::report::wrap(name, width);
    let mut lines = wrapped.lines();
    let cells: Vec<String> = (values.iter().zip(VALUE_COLUMNS))
        .map(|(v, w)| format!("{v:>w$}"))
        .collect();
    println!("{:<width$} {}", lines.next().unwrap_or(""), cells.join(" "));
    for line in lines {
        println!("  {line}");
    }
}

fn main() {
    cellbih_cli::report::main("validate", |a: &Args| &a.run.output, run);
}

fn run(args: &Args) -> Result<(), String> {
    args.run.threads.install()?;
    let text = args.run.output.format == Format::Text;
    let mut cost = args.model.cost();
    args.rates.machine_only(&mut cost, "validate")?;
    // Every figure's probe side by side (each its own emulated machine).
    let figures = figures();
    let probed = side_by_side("figures", &figures, |f| (f.probe)(&cost));
    let mut rows = Vec::new();
    let mut failed = Vec::new();
    let results: Vec<(&Figure, f64)> = (figures.iter().zip(probed))
        .map(|(f, got)| got.map(|g| (f, g)).map_err(|e| format!("{}: {e}", f.what)))
        .collect::<Result<_, _>>()?;
    for (fitted, title) in [
        (
            true,
            "figures that set a rate or a mechanism (they show that the fit took)",
        ),
        (
            false,
            "held-out figures (they set nothing: they test the model)",
        ),
    ] {
        let group: Vec<_> = (results.iter())
            .filter(|(f, _)| matches!(f.role, Role::Fitted(_)) == fitted)
            .collect();
        if text {
            println!("\n{title}");
        }
        row(
            text,
            "published figure (retail PS3, 3.2 GHz)",
            ["published", "emulated", "ratio", "tol.", "verdict"].map(String::from),
        );
        let mut passed = 0;
        for &&(f, got) in &group {
            let ratio = got / f.published;
            let ok = (ratio - 1.0).abs() <= f.tolerance;
            match ok {
                true => passed += 1,
                false => failed.push(f.what),
            }
            row(
                text,
                &format!("{} ({})", f.what, f.unit),
                [
                    format!("{:.2}", f.published),
                    format!("{got:.2}"),
                    format!("{ratio:.3}"),
                    format!("{:.0}%", f.tolerance * 100.0),
                    verdict(ok),
                ],
            );
            let mut row = json!({
                "figure": f.what, "source": f.source, "unit": f.unit,
                "published": f.published, "emulated": got, "ratio": ratio,
                "tolerance": f.tolerance, "pass": ok,
            });
            row.as_object_mut()
                .unwrap()
                .extend(f.role.fields().map(|(k, v)| (k.into(), v)));
            rows.push(row);
        }
        if text {
            println!("{passed} of {} pass", group.len());
        }
    }
    let (compute_rows, compute_failed) = compute::section(&cost, text)?;
    rows.extend(compute_rows);
    failed.extend(compute_failed);
    rows.extend(ppe::section(text));
    let csv: Vec<String> = (rows.iter())
        .map(|r| {
            format!(
                "\"{}\",\"{}\",{},{},{:.4},{:.4},{},{},{},{}",
                r["figure"].as_str().unwrap(),
                r["source"].as_str().unwrap(),
                r["unit"].as_str().unwrap(),
                r["published"],
                r["emulated"].as_f64().unwrap(),
                r["ratio"].as_f64().unwrap(),
                r["tolerance"],
                r["pass"],
                r["role"].as_str().unwrap(),
                r["sets"].as_str().unwrap_or("")
            )
        })
        .collect();
    let header = "figure,source,unit,published,emulated,ratio,tolerance,pass,role,sets";
    args.run
        .output
        .report_printed("validate", (header, &csv), &json!({ "rows": rows }), None)?;
    match failed.len() {
        0 => Ok(()),
        n => Err(format!(
            "{n} figures outside their tolerance: {}",
            failed.join("; ")
        )),
    }
}
