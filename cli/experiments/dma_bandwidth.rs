//! DMA bandwidth of the emulated Cell: stream an array from main memory
//! through 1 to 8 SPEs with DMA sizes from 16 B to 16 KiB, single- and
//! double-buffered, and report the achieved bandwidth in simulated time.
//!
//! It shows the two facts the paper's builders rest on: one SPE reaches
//! its peak only with large (16 KiB) transfers, and the memory interface
//! that all SPEs share saturates as SPEs are added.
//!
//! `cargo run --release --bin dma_bandwidth -- [--out results] [--format text|json] [--mib 64] [--max-spes 8]`
//! writes dma_bandwidth.csv, .json and .svg to the output directory.

use std::time::Instant;

use clap::Parser;
use serde_json::json;

use cellbih::cell::{Cell, CellConfig, CostModel, Ea};
use cellbih_cli::report::{OutputArgs, Series, count, line_plot, output};

#[derive(Parser)]
#[command(
    about = "DMA bandwidth of 1 to 8 SPEs streaming gets of 128 B to 16 KiB, single- and double-buffered (default run: about 14 s)"
)]
struct Args {
    #[command(flatten)]
    output: OutputArgs,
    /// MiB per configuration, 1 to 1,024: whole 16 KiB transfers per SPE
    /// of it are streamed (63 MiB of the default 64 with 6 SPEs); transfers
    /// under 1 KiB stream at most 65,536 commands' worth, since bandwidth is
    /// a steady-state rate.
    #[arg(long, default_value_t = 64, value_parser = cellbih_cli::args::between::<u64, _>(1..=1024))]
    mib: u64,
    /// Most SPEs to stream through (1 to 16; above 8 a what-if): the runs
    /// use 1, 2, 3, 4, 6, 8, 12 and 16 SPEs up to this many.
    #[arg(long, default_value_t = 8, value_parser = cellbih_cli::args::between::<u64, _>(1..=16))]
    max_spes: u64,
    #[command(flatten)]
    rates: cellbih_cli::args::RateSetArgs,
}

struct Run {
    spes: usize,
    size: u32,
    double: bool,
    bytes: u64,
    gb_per_s: f64,
    host_s: f64,
}

/// Streams `bytes` split evenly over `spes` SPEs in `size`-byte gets.
fn stream(cost: &CostModel, spes: usize, size: u32, double: bool, bytes: u64) -> Run {
    let mut cfg = CellConfig::ps3().with_spes(spes);
    cfg.cost = cost.clone();
    cfg.main_memory_bytes = bytes + (1 << 20);
    let hz = cfg.cost.clock_hz;
    let mut cell = Cell::new(cfg).expect("config");
    let base = cell
        .memory_mut()
        .alloc("streamed array", bytes, 128)
        .expect("memory");
    // Whole transfers per SPE, so every get stays aligned.
    let per_spe = bytes / spes as u64 / size as u64 * size as u64;
    for id in 0..spes {
        let start: Ea = base.offset(id as u64 * per_spe);
        cell.spawn_spe(id, move |spe| async move {
            let bufs = [spe.ls_alloc(size, 128)?, spe.ls_alloc(size, 128)?];
            let chunks = per_spe / size as u64;
            if double {
                spe.get(bufs[0], start, size, 0).await?;
                for k in 0..chunks {
                    let b = (k % 2) as usize;
                    if k + 1 < chunks {
                        spe.get(
                            bufs[1 - b],
                            start.offset((k + 1) * size as u64),
                            size,
                            1 - b as u32,
                        )
                        .await?;
                    }
                    spe.wait_tag(b as u32).await?;
                }
            } else {
                for k in 0..chunks {
                    spe.get(bufs[0], start.offset(k * size as u64), size, 0)
                        .await?;
                    spe.wait_tag(0).await?;
                }
            }
            Ok(())
        });
    }
    let t = Instant::now();
    let report = cell.run().expect("streaming never breaks a rule");
    let host_s = t.elapsed().as_secs_f64();
    let moved = per_spe / size as u64 * size as u64 * spes as u64;
    Run {
        spes,
        size,
        double,
        bytes: moved,
        gb_per_s: moved as f64 / (report.cycles.0 as f64 / hz) / 1e9,
        host_s,
    }
}

fn main() {
    let args: Args = cellbih_cli::args::parse();
    cellbih_cli::report::experiment_main("dma_bandwidth", &args.output.out, || {
        run(&args).map_err(|e| e.to_string())
    });
}

/// "1 SPE", "6 SPEs".
fn spes(n: usize) -> String {
    count(n as u64, "SPE")
}

fn run(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    let sizes: Vec<u32> = (4..=14).map(|p| 1u32 << p).collect();
    let spe_counts: Vec<usize> = [1, 2, 3, 4, 6, 8, 12, 16]
        .into_iter()
        .filter(|&n| n as u64 <= args.max_spes)
        .collect();
    let mut cost = CostModel::ps3();
    args.rates.machine_only(&mut cost, "dma_bandwidth")?;
    let mut runs = Vec::new();
    for &double in &[false, true] {
        for &n in &spe_counts {
            eprintln!(
                "streaming through {}, {}…",
                spes(n),
                if double {
                    "double-buffered"
                } else {
                    "single-buffered"
                }
            );
            for &size in &sizes {
                let bytes = (args.mib << 20).min(size as u64 * 65536 * n as u64);
                runs.push(stream(&cost, n, size, double, bytes));
            }
        }
    }
    let table = |_: &[serde_json::Value]| {
        println!("Achieved bandwidth, GB/s of simulated time (PS3 cost model; peak 25.6 GB/s)\n");
        for double in [false, true] {
            println!(
                "{}",
                if double {
                    "double-buffered (2 gets in flight per SPE)"
                } else {
                    "single-buffered (get, wait, get, …)"
                }
            );
            print!("{:>9}", "DMA size");
            for &n in &spe_counts {
                print!(" {:>8}", spes(n));
            }
            println!();
            for &size in &sizes {
                let label = if size >= 1024 {
                    format!("{} KiB", size / 1024)
                } else {
                    format!("{size} B")
                };
                print!("{label:>9}");
                for &n in &spe_counts {
                    let r = runs
                        .iter()
                        .find(|r| r.spes == n && r.size == size && r.double == double)
                        .expect("every size ran on every count");
                    print!(" {:>8.2}", r.gb_per_s);
                }
                println!();
            }
            println!();
        }
        for n in [1usize, 6] {
            if let Some(r) = runs
                .iter()
                .find(|r| r.spes == n && r.size == 16384 && !r.double)
            {
                println!(
                    "host time to stream {:.1} MiB through {} in 16 KiB gets: {:.3} s",
                    r.bytes as f64 / (1 << 20) as f64,
                    spes(n),
                    r.host_s
                );
            }
        }
    };
    let rows: Vec<_> = runs
        .iter()
        .map(|r| json!({"spes": r.spes, "dma_bytes": r.size, "buffering": if r.double {"double"} else {"single"}, "bytes_streamed": r.bytes, "gb_per_s": r.gb_per_s, "host_s": r.host_s}))
        .collect();
    let keys = [
        "spes",
        "dma_bytes",
        "buffering",
        "bytes_streamed",
        "gb_per_s",
        "host_s",
    ];
    args.output
        .report("dma_bandwidth", (&keys, &rows), &json!(rows), None, table)?;
    let series: Vec<Series> = [false, true]
        .iter()
        .flat_map(|&double| {
            let runs = &runs;
            spe_counts.iter().enumerate().map(move |(i, &n)| Series {
                color: i,
                name: format!("{}, {}", spes(n), if double { "double" } else { "single" }),
                points: runs
                    .iter()
                    .filter(|r| r.spes == n && r.double == double)
                    .map(|r| (r.size as f64, r.gb_per_s))
                    .collect(),
                dashed: !double,
            })
        })
        .collect();
    let svg = output(&args.output.out, "dma_bandwidth.svg")?;
    line_plot(
        &svg,
        "Emulated Cell: DMA bandwidth vs transfer size",
        "DMA size",
        "GB/s (simulated)",
        &series,
        true,
    )?;
    cellbih_cli::report::result_set::say_written(format!(
        "written: {}/dma_bandwidth.{{csv,json,svg}}",
        args.output.out.display()
    ));
    Ok(())
}
