//! `cellbih rates`: every rate the model charges, by the name `--rate`
//! takes — the machine's (cycles, or GB/s for a bandwidth) and the
//! library's kernels' in the code class chosen (cycles, with the band
//! `sensitivity` moves each through) — at its value with the options
//! given (docs/cost-model.md says where each comes from).

use serde_json::json;

use cellbih::cell::CostModel;
use cellbih::kernels::rates::Band;
use cellbih::registry::BuilderKind;

use crate::Res;
use crate::args::{Charges, Format, MachineModel, RatesCommand, charged_by};

/// Runs `cellbih rates`.
pub fn run(args: RatesCommand) -> Res<()> {
    let mut cost = match args.model.unwrap_or(MachineModel::Measured) {
        MachineModel::Measured => CostModel::ps3(),
        MachineModel::Legacy => CostModel::ps3_legacy(),
    };
    let base = cost.clone();
    let rates = args.rates.apply(&mut cost)?;
    let code = rates.code();
    let moves = |name: &str| moves(name, code);
    // A rate of the other model only (the legacy model claims no line).
    let machine: Vec<_> = (CostModel::RATES.iter())
        .filter_map(|r| {
            let value = cost.rate_text(r.name)?;
            let moved = base.rate_text(r.name).as_ref() != Some(&value);
            let band = base.band_text(r.name).unwrap_or_default();
            Some((r.name, value, moved, band))
        })
        .collect();
    let kernels: Vec<_> = (BuilderKind::every_rate(code).into_iter())
        .map(|r| {
            let value = rates.get(r.name).unwrap_or(r.value);
            (r.name, value.0, r.band, rates.get(r.name).is_some())
        })
        .collect();
    let band_text = |b: Band| match b {
        Band::Fitted => "fixed".to_string(),
        Band::Open(why) => format!("open ({why})"),
        Band::Between { low, high, why } => format!("{}-{} ({why})", low.0, high.0),
    };
    if args.format == Format::Json {
        let doc = json!({
            "model": match args.model { Some(MachineModel::Legacy) => "legacy", _ => "measured" },
            "code": code.name(),
            "machine": machine.iter().map(|(n, v, moved, band)| json!({
                "name": n, "value": v.parse::<f64>().ok(), "moved": moved,
                "band": (!band.is_empty()).then_some(band), "moves": moves(n),
            })).collect::<Vec<_>>(),
            "kernels": kernels.iter().map(|(n, v, b, moved)| json!({
                "name": n, "cycles": v, "band": band_text(*b), "moved": moved,
                "moves": moves(n),
            })).collect::<Vec<_>>(),
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(());
    }
    let mark = |moved: bool| if moved { " *" } else { "" };
    println!(
        "Rates by the name --rate NAME=VALUE takes (--model {} --code {code})",
        match args.model {
            Some(MachineModel::Legacy) => "legacy",
            _ => "measured",
        }
    );
    println!("\nthe machine's (cell/src/cost.rs): cycles, or GB/s for a bandwidth;");
    println!("band: where a rate no measurement pins may lie; moves: the runs that");
    println!("charge it (a command that charges none refuses it)");
    for (name, value, moved, band) in &machine {
        let line = format!(
            "  {name:<25} {value:>8}{:<2} {:<9} {band}",
            mark(*moved),
            moves(name)
        );
        println!("{}", line.trim_end());
    }
    println!("\nthe kernels' (cycles; band: what sensitivity moves it through)");
    for (name, value, band, moved) in &kernels {
        println!(
            "  {name:<26} {value:>5}{:<2} {:<13} {}",
            mark(*moved),
            moves(name),
            band_text(*band)
        );
    }
    if machine.iter().any(|m| m.2) || kernels.iter().any(|k| k.3) {
        println!("\n*: moved by --rate or --rates");
    }
    Ok(())
}

/// The runs that charge the rate `name` in the class `code` (what marks
/// it in the list).
fn moves(name: &str, code: cellbih::kernels::rates::Code) -> &'static str {
    let every = Charges {
        casts: true,
        updates: true,
        fabric_and_ppe_atomics: true,
        ..Charges::BUILDS
    };
    charged_by(name, code, every).1
}
