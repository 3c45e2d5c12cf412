//! `frame_loop --ends`: whether section 5's arrangement or the paper's
//! wins each case wherever the model's uncertain PPE lies and whatever
//! code the SPUs run. Each arrangement is played again at the fixed policy
//! that was its best at the rates in force, with every PPE rate at the
//! cheap end of its band, then at the dear end, then in each other code
//! class; the table gives the paper's total over section 5's at each.

use serde_json::{Value, json};

use cellbih::cell::{Bandwidth, CellConfig};
use cellbih::kernels::ppe_rates::PpeRates;
use cellbih::kernels::rates::{Band, Code, RateOverrides};

/// A model the cases are played again on: its name, the machine and the
/// library's rates.
pub struct End {
    pub name: String,
    pub cell: CellConfig,
    pub rates: RateOverrides,
}

/// The ends of the model in force (`cell`, `rates`): the PPE cheap and
/// dear (its steps' rates at their bands' ends, its memory latency at
/// half and twice, its bandwidth at cellmark's 8.4 and 2.75 GB/s), then
/// each code class but the one in force.
pub fn ends(cell: &CellConfig, rates: &RateOverrides) -> Vec<End> {
    let hz = cell.cost.clock_hz;
    let ppe = |cheap: bool| {
        let (mut c, mut r) = (cell.clone(), *rates);
        for rate in PpeRates::table() {
            if let Band::Between { low, high, .. } = rate.band {
                r = r.with(rate.name, if cheap { low } else { high });
            }
        }
        let latency = cell.cost.ppe_memory_cycles.0;
        c.cost.ppe_memory_cycles.0 = if cheap { latency / 2 } else { latency * 2 };
        let gbs = if cheap { 8.4 } else { 2.75 };
        c.cost.ppe_memory_bandwidth = Bandwidth::from_gb_per_s(gbs, hz);
        (c, r)
    };
    let mut v = Vec::new();
    for (name, cheap) in [("PPE cheap", true), ("PPE dear", false)] {
        let (cell, rates) = ppe(cheap);
        v.push(End {
            name: name.into(),
            cell,
            rates,
        });
    }
    for code in Code::ALL.into_iter().filter(|&c| c != rates.code()) {
        v.push(End {
            name: code.to_string(),
            cell: cell.clone(),
            rates: rates.with_code(code),
        });
    }
    v
}

/// The paper's total over section 5's: above 1, section 5's wins.
pub fn ratio(five_ms: f64, paper_ms: f64) -> f64 {
    paper_ms / five_ms
}

/// The table of `rows` (one per case and end: `scene`, `width`, `height`,
/// `end`, `ratio`), the in-force ratio of each case first (`in_force`).
pub fn table(in_force: &[Value], rows: &[Value]) {
    let names: Vec<&str> = {
        let mut n: Vec<&str> = Vec::new();
        for r in rows {
            let e = r["end"].as_str().unwrap_or("");
            if !n.contains(&e) {
                n.push(e);
            }
        }
        n
    };
    let head = "which arrangement wins at the model's ends (the paper's total over section \
                5's, each at the fixed policy best at the rates in force; above 1: section \
                5's wins):";
    println!("\n{}", cellbih_cli::report::wrap(head, 80));
    print!("{:<12} {:>9} {:>9}", "scene", "size", "in force");
    for n in &names {
        print!(" {n:>9}");
    }
    println!();
    let (mut cases, mut held) = (0, 0);
    for f in in_force {
        let same = |r: &&Value| r["scene"] == f["scene"] && r["width"] == f["width"];
        let at = f["ratio"].as_f64().unwrap_or(f64::NAN);
        print!(
            "{:<12} {:>9} {:>9.3}",
            super::cut(f["scene"].as_str().unwrap_or(""), 12),
            format!("{}x{}", f["width"], f["height"]),
            at
        );
        let mut holds = true;
        for n in &names {
            let r = rows.iter().filter(same).find(|r| r["end"] == *n);
            let x = r.and_then(|r| r["ratio"].as_f64()).unwrap_or(f64::NAN);
            holds &= (x > 1.0) == (at > 1.0);
            print!(" {x:>9.3}");
        }
        println!();
        cases += 1;
        held += holds as usize;
    }
    let line = format!(
        "the winner at the rates in force wins at every end in {held} of {cases} cases \
         (PPE cheap / dear: every PPE step's rate at its band's low / high end, \
         ppe_memory_cycles at half / twice, ppe_memory_bandwidth 8.4 / 2.75 GB/s; \
         a class: every SPU kernel's rate in it)"
    );
    println!("{}", cellbih_cli::report::wrap(&line, 80));
}

/// A row of the ends' table, as the JSON keeps it.
pub fn row(case: &Value, end: &str, five_ms: f64, paper_ms: f64) -> Value {
    json!({
        "scene": case["scene"], "width": case["width"], "height": case["height"],
        "end": end, "section5_ms": five_ms, "paper_ms": paper_ms,
        "ratio": ratio(five_ms, paper_ms),
    })
}
