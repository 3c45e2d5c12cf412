//! The sensitivity report: how the headline speedups of
//! section 5's strategies move when a rate no measurement pins moves across
//! its plausible band — each machine estimate of `CostModel::ESTIMATES`
//! from half to twice its value, each derived or estimated kernel rate of
//! the registry (`BuilderKind::uncertain_rates`: the shared kernels' and
//! each strategy's own) across its band. Every multi-SPE builder of the
//! registry is built on each SPE count beside the baseline `spe_bfs` on the
//! same rates; a rate under which the order of the builders, or whether
//! more SPEs are faster, changes is reported as a flip.
//!
//! `cargo run --release --bin sensitivity -- --data ../shared/data [--scenes bunny,dragon] [--spes 6,8] [--model measured|legacy] [--threads N] [--out results]`

use clap::{Parser, ValueEnum};
use serde_json::json;

use cellbih::cell::{CellConfig, CostModel, Cycles};
use cellbih::kernels::rates::{Code, RateOverrides};
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::Scene;
use cellbih_cli::args::DataArg;
use cellbih_cli::args::RunArgs;
use cellbih_cli::report::{Format, side_by_side};

#[derive(Parser)]
#[command(
    about = "How the headline speedups move when every unpinned rate crosses its documented band (default run: about 2 min)"
)]
struct Args {
    /// Scenes, comma-separated (names, OBJ files or procedural specs).
    #[arg(long, default_value = "bunny,dragon", value_delimiter = ',')]
    scenes: Vec<String>,
    /// SPE counts of the headline speedups, comma-separated (1 to 16;
    /// above 8 a what-if).
    #[arg(long, default_value = "6,8", value_delimiter = ',', value_parser = cellbih_cli::args::between::<u64, _>(1..=16))]
    spes: Vec<u64>,
    /// The cost model the rates are moved on.
    #[arg(long, value_enum, default_value = "measured")]
    model: Model,
    /// The class of code whose rates are moved (docs/cost-model.md).
    #[arg(long, value_enum, default_value = "paper")]
    code: cellbih_cli::args::CodeArg,
    #[command(flatten)]
    run: RunArgs,
    #[command(flatten)]
    data: DataArg,
}

#[derive(Clone, Copy, ValueEnum)]
enum Model {
    Measured,
    Legacy,
}

/// One setting of the rates: its name, and the model and kernel rates.
struct Variant {
    rate: String,
    end: &'static str,
    value: u64,
    cost: CostModel,
    rates: RateOverrides,
}

/// The variants: the rates as they are, then each uncertain rate at the
/// low and the high end of its band.
fn variants(base: &CostModel, code: Code) -> Vec<Variant> {
    let class = RateOverrides::default().with_code(code);
    let mut v = vec![Variant {
        rate: "(as calibrated)".into(),
        end: "",
        value: 0,
        cost: base.clone(),
        rates: class,
    }];
    for name in CostModel::ESTIMATES.iter().map(|e| e.name) {
        let at = base.estimate(name).expect("a named estimate").0;
        for (end, value) in [("low", at / 2), ("high", at * 2)] {
            let cost = base.with_estimate(name, Cycles(value)).unwrap();
            v.push(Variant {
                rate: name.into(),
                end,
                value,
                cost,
                rates: class,
            });
        }
    }
    // Every program started as an SPU thread group through the OS, not as
    // a SPURS task: the high end of the start's band.
    let mut cost = base.clone();
    let group = CostModel::SPE_START_GROUP.0;
    cost.set_rate("spe_start_cycles", &group.to_string())
        .expect("a machine rate")
        .expect("a whole number of cycles");
    v.push(Variant {
        rate: "spe_start_cycles".into(),
        end: "high",
        value: group,
        cost,
        rates: class,
    });
    for u in BuilderKind::uncertain_rates(code) {
        for (end, value) in [("low", u.low), ("high", u.high)] {
            v.push(Variant {
                rate: format!("{} ({})", u.name, u.why),
                end,
                value: value.0,
                cost: base.clone(),
                rates: class.with(u.name, value),
            });
        }
    }
    // The corners: every estimate at one end of its band together with
    // every uncertain kernel rate at one end of its own.
    for machine in ["low", "high"] {
        for kernels in ["low", "high"] {
            let mut cost = base.clone();
            for name in CostModel::ESTIMATES.iter().map(|e| e.name) {
                let at = base.estimate(name).expect("a named estimate").0;
                let value = if machine == "low" { at / 2 } else { at * 2 };
                cost = cost
                    .with_estimate(name, Cycles(value))
                    .expect("a named estimate");
            }
            let mut rates = class;
            for u in BuilderKind::uncertain_rates(code) {
                rates = rates.with(u.name, if kernels == "low" { u.low } else { u.high });
            }
            v.push(Variant {
                rate: format!("every estimate {machine}, every kernel rate {kernels}"),
                end: "all",
                value: 0,
                cost,
                rates,
            });
        }
    }
    v
}

/// Each headline's band: its speedup as calibrated, and the least and
/// the most it reaches over every variant (each rate alone at each end of
/// its band, and the corners).
fn bands(speedups: &[Vec<f64>]) -> Vec<(f64, f64, f64)> {
    (0..speedups[0].len())
        .map(|h| {
            let all = speedups.iter().map(|v| v[h]);
            let low = all.clone().fold(f64::INFINITY, f64::min);
            let high = all.fold(f64::NEG_INFINITY, f64::max);
            (speedups[0][h], low, high)
        })
        .collect()
}

/// The simulated ms of `b` on `s` with `spes` SPEs under variant `v`.
fn ms(b: BuilderKind, s: &Scene, spes: usize, v: &Variant) -> Result<f64, String> {
    let mut cell = CellConfig::ps3().with_spes(spes);
    cell.cost = v.cost.clone();
    cell.checked = false;
    let r = Build::new(b)
        .on(&cell)
        .with_rates(&v.rates)
        .run(s)
        .map_err(|e| format!("{b} on {}: {e}", s.name))?;
    Ok(r.simulated.expect("an emulated builder").run.ms)
}

fn main() {
    cellbih_cli::report::main("sensitivity", |a: &Args| &a.run.output, run);
}

fn run(args: &Args) -> Result<(), String> {
    args.run.threads.install()?;
    let scenes: Vec<Scene> =
        cellbih_cli::report::load_scenes(&args.scenes, args.data.dir().as_deref())?;
    let base = match args.model {
        Model::Measured => CostModel::ps3(),
        Model::Legacy => CostModel::ps3_legacy(),
    };
    let builders: Vec<BuilderKind> = (BuilderKind::ALL.iter().copied())
        .filter(|b| b.multi_spe())
        .collect();
    let code = args.code.code();
    let variants = variants(&base, code);
    // Every emulation side by side: each variant's baseline on each scene
    // (no SPE count) and each builder on each SPE count.
    let mut jobs = Vec::new();
    for k in 0..variants.len() {
        for si in 0..scenes.len() {
            jobs.push((k, si, None));
            for ni in 0..args.spes.len() {
                jobs.extend((0..builders.len()).map(|bi| (k, si, Some((ni, bi)))));
            }
        }
    }
    let done = side_by_side("emulations", &jobs, |&(k, si, at)| match at {
        None => ms(BuilderKind::SPE_BFS, &scenes[si], 1, &variants[k]),
        Some((ni, bi)) => ms(
            builders[bi],
            &scenes[si],
            args.spes[ni] as usize,
            &variants[k],
        ),
    });
    let mut done = done.into_iter();
    // speedups[variant][scene][spes][builder], in the jobs' order.
    let mut speedups: Vec<Vec<Vec<Vec<f64>>>> = Vec::new();
    for _ in &variants {
        let mut by_scene = Vec::new();
        for _ in &scenes {
            let mut next = || done.next().expect("a job a figure");
            let baseline = next()?;
            let mut by_spes = Vec::new();
            for _ in &args.spes {
                let row: Vec<f64> = (builders.iter())
                    .map(|_| next().map(|t| baseline / t))
                    .collect::<Result<_, _>>()?;
                by_spes.push(row);
            }
            by_scene.push(by_spes);
        }
        speedups.push(by_scene);
    }
    // The order of the builders at each headline, and whether each builder
    // is faster on more SPEs: a variant that changes either flips.
    let order = |row: &[f64]| {
        let mut idx: Vec<usize> = (0..row.len()).collect();
        idx.sort_by(|&a, &b| row[b].total_cmp(&row[a]));
        idx
    };
    let more_is_faster = |per_spes: &[Vec<f64>]| -> Vec<bool> {
        (0..builders.len())
            .map(|b| per_spes.windows(2).all(|w| w[1][b] > w[0][b]))
            .collect()
    };
    let mut rows = Vec::new();
    let mut csv = Vec::new();
    let mut heads: Vec<String> = Vec::new();
    for s in &scenes {
        for n in &args.spes {
            for b in &builders {
                heads.push(format!("{} {b} {n}", s.name));
            }
        }
    }
    let title = format!(
        "Headline speedups over spe_bfs on one SPE (simulated, {} model) with each \
         uncertain rate at the ends of its band, then every rate at once (the corners): \
         the largest move of a headline, and any flip",
        match args.model {
            Model::Measured => "measured",
            Model::Legacy => "legacy",
        }
    );
    let text = args.run.output.format == Format::Text;
    if text {
        println!("{}\n", cellbih_cli::report::wrap(&title, 80));
    }
    // Each rate's line: its ends, the flips, the largest move at either end.
    let mut lines: Vec<(String, Vec<String>, Vec<String>, f64)> = Vec::new();
    for (k, v) in variants.iter().enumerate() {
        let mut flips = Vec::new();
        for (si, s) in scenes.iter().enumerate() {
            for (ni, n) in args.spes.iter().enumerate() {
                if order(&speedups[k][si][ni]) != order(&speedups[0][si][ni]) {
                    flips.push(format!("order of the builders, {} on {n} SPEs", s.name));
                }
            }
            let (now, then) = (
                more_is_faster(&speedups[k][si]),
                more_is_faster(&speedups[0][si]),
            );
            for (b, (x, y)) in builders.iter().zip(now.iter().zip(&then)) {
                if x != y {
                    flips.push(format!("{b} on more SPEs faster: {y} -> {x}, {}", s.name));
                }
            }
        }
        let flat: Vec<f64> = speedups[k].iter().flatten().flatten().copied().collect();
        let base_flat: Vec<f64> = speedups[0].iter().flatten().flatten().copied().collect();
        let worst = (flat.iter().zip(&base_flat))
            .map(|(a, b)| a / b - 1.0)
            .fold(0.0f64, |m, d| if d.abs() > m.abs() { d } else { m });
        // A line a rate: each end with its value and the largest move,
        // then the flips (wrapped, the rest indented, in 80 columns).
        let value = match v.end {
            "" | "all" => String::new(),
            _ => format!(" {}", v.value),
        };
        let piece = format!("{}{value} {:+.1} %", v.end, worst * 100.0)
            .trim_start()
            .to_string();
        match lines.last_mut() {
            Some((rate, pieces, f, most)) if *rate == v.rate => {
                pieces.push(piece);
                f.extend(flips.iter().cloned());
                *most = most.max(worst.abs());
            }
            _ => lines.push((v.rate.clone(), vec![piece], flips.clone(), worst.abs())),
        }
        let speeds: Vec<String> = flat.iter().map(|x| format!("{x:.3}")).collect();
        csv.push(format!(
            "\"{}\",{},{},{:.4},{},{}",
            v.rate,
            v.end,
            v.value,
            worst,
            flips.len(),
            speeds.join(",")
        ));
        rows.push(json!({
            "rate": v.rate, "end": v.end, "value": v.value,
            "largest_move": worst, "flips": flips,
            "speedups": heads.iter().zip(&flat).map(|(h, x)| json!({"headline": h, "speedup": x})).collect::<Vec<_>>(),
        }));
    }
    // The rates that move no headline by 0.05 % at either end, named on
    // one line after the others.
    let mut still = Vec::new();
    for (rate, pieces, flips, most) in &lines {
        if flips.is_empty() && *most < 0.0005 && !rate.starts_with('(') {
            still.push(rate.split(" (").next().unwrap_or(rate));
            continue;
        }
        let moved = match flips.is_empty() {
            true => "no flip".to_string(),
            false => format!("FLIPS: {}", flips.join("; ")),
        };
        let line = format!("{rate}: {}; {moved}", pieces.join(", "));
        if text {
            let wrapped = cellbih_cli::report::wrap(line.trim_start(), 76);
            println!("{}", wrapped.replace('\n', "\n    "));
        }
    }
    if text && !still.is_empty() {
        let line = format!(
            "moving no headline by 0.05 % at either end, no flip: {}",
            still.join(", ")
        );
        println!("{}", cellbih_cli::report::wrap(&line, 80));
    }
    let line = format!("headlines: {}", heads.join(", "));
    if text {
        println!("\n{}", cellbih_cli::report::wrap(&line, 80));
    }
    // Each headline with its band, and whether the order of the builders
    // at it holds over every variant.
    let flat: Vec<Vec<f64>> = (speedups.iter())
        .map(|v| v.iter().flatten().flatten().copied().collect())
        .collect();
    let bands = bands(&flat);
    if text {
        println!(
            "\n{:<28} {:>8} {:>15}  order of the builders",
            "headline (scene builder SPEs)", "speedup", "band"
        );
    }
    let mut band_rows = Vec::new();
    for (h, (head, &(at, low, high))) in heads.iter().zip(&bands).enumerate() {
        let (si, ni) = (
            h / (args.spes.len() * builders.len()),
            (h / builders.len()) % args.spes.len(),
        );
        let holds =
            (0..variants.len()).all(|k| order(&speedups[k][si][ni]) == order(&speedups[0][si][ni]));
        if text {
            println!(
                "{head:<28} {at:>7.2}x {:>15}  {}",
                format!("{low:.2}-{high:.2}x"),
                if holds {
                    "holds"
                } else {
                    "FLIPS inside the bands"
                }
            );
        }
        band_rows.push(json!({
            "headline": head, "speedup": at, "low": low, "high": high,
            "order_holds": holds,
        }));
    }
    let header = format!(
        "rate,end,value,largest_move,flips,{}",
        heads.join(",").replace(' ', "_")
    );
    args.run.output.report_printed(
        "sensitivity",
        (&header, &csv),
        &json!({ "rows": rows, "bands": band_rows }),
        Some(&Build::new(BuilderKind::HOST).with_rates(&RateOverrides::default().with_code(code))),
    )?;
    Ok(())
}
