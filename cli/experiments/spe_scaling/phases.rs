//! `spe_scaling --phases`: where the time of each builder made of phases
//! goes (`spe_morton`: the scene box, the keys, each radix pass, the keys
//! within cells, the top, the regions), on the most SPEs run, a column a
//! scene: the rows' `phases`, side by side.

use serde_json::Value;

/// Columns of a scene's name.
const NAME: usize = 13;

/// `name` in at most [`NAME`] characters.
fn short(name: &str) -> String {
    match name.chars().count() <= NAME {
        true => name.to_string(),
        false => name.chars().take(NAME - 1).chain(['…']).collect(),
    }
}

/// For each builder (with its defaults) whose rows have phases: a table of
/// each phase's simulated ms on the most SPEs, a column a scene, and their
/// total.
pub fn print(rows: &[Value], code: cellbih::kernels::rates::Code) {
    let most = rows.iter().filter_map(|r| r["spes"].as_u64()).max();
    let on_most = |r: &&Value| r["spes"].as_u64() == most;
    let phased = |r: &&Value| r["phases"].as_array().is_some_and(|p| !p.is_empty());
    let mut builders: Vec<&str> = (rows.iter().filter(on_most).filter(phased))
        .filter_map(|r| r["builder"].as_str())
        .collect();
    builders.dedup();
    for builder in builders {
        let of: Vec<&Value> = (rows.iter().filter(on_most))
            .filter(|r| r["builder"] == builder)
            .collect();
        // Every scene's phases in their order: one a scene lacks after
        // the phase before it in a scene that has it.
        let mut names: Vec<&str> = Vec::new();
        for r in &of {
            let mut after = None;
            for p in r["phases"].as_array().into_iter().flatten() {
                let name = p["phase"].as_str().unwrap_or_default();
                match names.iter().position(|&n| n == name) {
                    Some(at) => after = Some(at),
                    None => {
                        let at = after.map_or(0, |a| a + 1);
                        names.insert(at, name);
                        after = Some(at);
                    }
                }
            }
        }
        let ms = |r: &Value, name: &str| -> Option<f64> {
            (r["phases"].as_array().into_iter().flatten())
                .filter(|p| p["phase"] == name)
                .filter_map(|p| p["ms"].as_f64())
                .reduce(|a, b| a + b)
        };
        println!(
            "\nphases: {builder} on {} SPEs, simulated ms, {code} code class",
            most.unwrap_or(0)
        );
        print!("{:<22}", "phase");
        for r in &of {
            print!(" {:>NAME$}", short(r["scene"].as_str().unwrap_or_default()));
        }
        println!();
        for name in names.iter().copied().chain(["total"]) {
            print!("{name:<22}");
            for r in &of {
                let v = match name {
                    "total" => r["simulated_ms"].as_f64(),
                    _ => ms(r, name),
                };
                match v {
                    Some(v) => print!(" {v:>NAME$.2}"),
                    None => print!(" {:>NAME$}", "-"),
                }
            }
            println!();
        }
    }
}
