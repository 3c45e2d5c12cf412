//! `spe_scaling`'s summary: per scene and builder the speedup on 4, 6 and 8
//! SPEs (and 12 and 16 in the what-if beyond 8), where one SPE more was
//! slower and whether the tree is the baseline's; with `--zoo` the goals
//! checked (what each family of builders promises on large scenes, as the
//! registry says it; on every scene one SPE more never slower; every tree
//! the baseline's), and a plot of the speedup on 8 SPEs against the
//! scene's size.

use std::path::Path;

use serde_json::{Value, json};

use cellbih::registry::BuilderKind;
use cellbih::strategy::Promise;
use cellbih_cli::report::{Series, output, scatter_plot};

/// The count chosen may run this much slower than the fastest count at
/// most the SPEs given and still meet the goal (within 2 %).
const COUNT_SLACK: f64 = 1.02;

pub struct Summary {
    pub rows: Vec<Value>,
    /// With `--zoo`: each goal, met or not, with the measured figure.
    pub goals: Vec<Value>,
}

/// Whether a row's builder runs with its defaults (a name without
/// options).
fn is_default(builder: &str) -> bool {
    !builder.contains(' ')
}

/// The default-knob rows of `rows`.
fn defaults(rows: &[Value]) -> impl Iterator<Item = &Value> {
    (rows.iter()).filter(|r| is_default(r["builder"].as_str().unwrap_or_default()))
}

/// A row's `key` on `spes` SPEs.
fn at_count(rows: &[Value], scene: &str, builder: &str, spes: u64, key: &str) -> Option<f64> {
    rows.iter()
        .find(|r| r["scene"] == scene && r["builder"] == builder && r["spes"] == spes)
        .and_then(|r| r[key].as_f64())
}

/// Per scene and builder variant, in the rows' order: the speedups, where
/// one SPE more was slower, and on the most SPEs run the DMA wait's share
/// and the memory interface's use; with `zoo`, the goals (each builder's
/// defaults).
pub fn summary(rows: &[Value], zoo: bool) -> Summary {
    let most = rows
        .iter()
        .filter_map(|r| r["spes"].as_u64())
        .max()
        .unwrap_or(1);
    let mut pairs: Vec<(String, String, u64, f64)> = Vec::new();
    for r in rows {
        let (scene, builder) = (
            r["scene"].as_str().unwrap_or_default(),
            r["builder"].as_str().unwrap_or_default(),
        );
        if !pairs.iter().any(|p| p.0 == scene && p.1 == builder) {
            let (n, base) = (
                r["triangles"].as_u64().unwrap_or(0),
                r["baseline_ms"].as_f64().unwrap_or(0.0),
            );
            pairs.push((scene.into(), builder.into(), n, base));
        }
    }
    let mut out = Vec::new();
    for (scene, builder, n, base) in &pairs {
        let at = |spes| at_count(rows, scene, builder, spes, "speedup");
        let same = (rows.iter())
            .filter(|r| r["scene"] == scene.as_str() && r["builder"] == builder.as_str())
            .all(|r| r["baseline_tree"] == true);
        // Each count at which one SPE more was slower: "k+1<k".
        let slower: Vec<String> = (1..16u64)
            .filter(|&k| matches!((at(k + 1), at(k)), (Some(more), Some(fewer)) if more < fewer))
            .map(|k| format!("{}<{k}", k + 1))
            .collect();
        // Each count given at which the count chosen ran over 2 % slower
        // than the fastest at most that many: "k:j" (j the fastest).
        let off: Vec<String> = (rows.iter())
            .filter(|r| r["scene"] == scene.as_str() && r["builder"] == builder.as_str())
            .filter(|r| {
                let (ms, best) = (r["simulated_ms"].as_f64(), r["best_count_ms"].as_f64());
                matches!((ms, best), (Some(ms), Some(best)) if ms > best * COUNT_SLACK)
            })
            .map(|r| format!("{}:{}", r["spes"], r["best_count"]))
            .collect();
        let predicts = (rows.iter()).any(|r| {
            r["scene"] == scene.as_str()
                && r["builder"] == builder.as_str()
                && !r["best_count"].is_null()
        });
        out.push(json!({
            "scene": scene, "triangles": n, "baseline_ms": base, "builder": builder,
            "speedup_4": at(4), "speedup_6": at(6), "speedup_8": at(8),
            "speedup_12": at(12), "speedup_16": at(16),
            "one_more_slower": slower,
            "count_off": if predicts { json!(off) } else { Value::Null },
            "baseline_tree": same,
            "most_spes": most,
            "dma_wait_most": at_count(rows, scene, builder, most, "dma_wait"),
            "memory_utilisation_most": at_count(rows, scene, builder, most, "memory_utilisation"),
        }));
    }
    let goals = match zoo {
        true => goals(&defaults(&out).cloned().collect::<Vec<_>>()),
        false => Vec::new(),
    };
    Summary { rows: out, goals }
}

/// "builder (a, b)" for each builder of `scene` whose list `key` is not
/// empty.
fn listed(summary: &[Value], scene: &str, key: &str) -> Vec<String> {
    (summary.iter())
        .filter(|r| r["scene"] == scene)
        .filter_map(|r| {
            let at: Vec<&str> = (r[key].as_array().into_iter().flatten())
                .filter_map(|v| v.as_str())
                .collect();
            let builder = r["builder"].as_str().unwrap_or_default();
            (!at.is_empty()).then(|| format!("{builder} ({})", at.join(", ")))
        })
        .collect()
}

fn goals(summary: &[Value]) -> Vec<Value> {
    let mut goals = Vec::new();
    let mut scenes: Vec<&str> = summary.iter().filter_map(|r| r["scene"].as_str()).collect();
    scenes.dedup();
    let on8 = |scene: &str, pick: &dyn Fn(&str) -> bool| -> Option<f64> {
        summary
            .iter()
            .filter(|r| r["scene"] == scene && pick(r["builder"].as_str().unwrap_or_default()))
            .filter_map(|r| r["speedup_8"].as_f64())
            .reduce(f64::max)
    };
    // Each family's promise, as its builders state it (the registry).
    let mut promises: Vec<Promise> = (BuilderKind::ALL.iter())
        .filter_map(|b| b.promise())
        .collect();
    promises.dedup_by(|a, b| a.family == b.family);
    let family = |builder: &str| BuilderKind::from_name(builder).and_then(|b| b.promise());
    for &scene in &scenes {
        let tris = (summary.iter())
            .filter(|r| r["scene"] == scene)
            .filter_map(|r| r["triangles"].as_u64())
            .max()
            .unwrap_or(0);
        for p in promises.iter().filter(|p| tris >= p.triangles) {
            let of = |b: &str| family(b).is_some_and(|f| f.family == p.family);
            if let Some(x) = on8(scene, &of) {
                goals.push(json!({ "scene": scene, "goal": format!("best {} >= {}x on 8 SPEs", p.family, p.speedup), "measured": x, "met": x >= p.speedup }));
            }
        }
        let slower = listed(summary, scene, "one_more_slower");
        goals.push(json!({ "scene": scene, "goal": "one SPE more never slower", "measured": slower.join(", "), "met": slower.is_empty() }));
        let off = listed(summary, scene, "count_off");
        if summary
            .iter()
            .any(|r| r["scene"] == scene && r["count_off"].is_array())
        {
            goals.push(json!({ "scene": scene, "goal": "the count chosen within 2 % of the fastest", "measured": off.join(", "), "met": off.is_empty() }));
        }
        let other: Vec<&str> = summary
            .iter()
            .filter(|r| r["scene"] == scene && r["baseline_tree"] != true)
            .filter_map(|r| r["builder"].as_str())
            .collect();
        goals.push(json!({ "scene": scene, "goal": "every tree the baseline's", "measured": other.join(", "), "met": other.is_empty() }));
    }
    goals
}

pub fn print(s: &Summary) {
    println!(
        "\n{}",
        cellbih_cli::report::wrap(
            "summary: speedup over spe_bfs on one SPE, simulated PS3 time; DMA, mem: on the \
             most SPEs, the mean share of the run waiting on DMA and the memory interface's \
             use of its peak; notes: k+1<k where one SPE more was slower, tree! where not the \
             baseline's tree",
            80
        )
    );
    // The what-if's 12 and 16 SPEs where the run went that far.
    let beyond = s.rows.iter().any(|r| !r["speedup_12"].is_null());
    let spes: &[u64] = match beyond {
        true => &[4, 6, 8, 12, 16],
        false => &[4, 6, 8],
    };
    let scene_width = (s.rows.iter())
        .filter_map(|r| r["scene"].as_str().map(str::len))
        .fold(5, usize::max);
    let width = (s.rows.iter())
        .filter_map(|r| r["builder"].as_str().map(str::len))
        .fold(16, usize::max);
    let mut head = format!(
        "{:<scene_width$} {:>8} {:<width$}",
        "scene", "tris", "builder"
    );
    for n in spes {
        head += &format!(" {n:>5}");
    }
    println!("{head}  DMA  mem  notes");
    let f = |v: &Value| v.as_f64().map_or("-".into(), |x| format!("{x:.2}"));
    let pct = |v: &Value| {
        v.as_f64()
            .map_or("-".into(), |x| format!("{:.0}%", 100.0 * x))
    };
    for r in &s.rows {
        let mut notes: Vec<&str> = (r["one_more_slower"].as_array().into_iter().flatten())
            .filter_map(|v| v.as_str())
            .collect();
        if r["baseline_tree"] != true {
            notes.push("tree!");
        }
        let mut line = format!(
            "{:<scene_width$} {:>8} {:<width$}",
            r["scene"].as_str().unwrap_or_default(),
            r["triangles"].as_u64().unwrap_or(0),
            r["builder"].as_str().unwrap_or_default(),
        );
        for n in spes {
            line += &format!(" {:>5}", f(&r[format!("speedup_{n}")]));
        }
        let (dma, mem) = (&r["dma_wait_most"], &r["memory_utilisation_most"]);
        line += &format!(" {:>4} {:>4}", pct(dma), pct(mem));
        println!("{line}  {}", notes.join("; "));
    }
    print_goals(&s.goals);
}

/// The goals' count and one line a goal missed (none without goals).
fn print_goals(goals: &[Value]) {
    if goals.is_empty() {
        return;
    }
    let f = |v: &Value| v.as_f64().map_or("-".into(), |x| format!("{x:.2}"));
    let missed: Vec<&Value> = goals.iter().filter(|g| g["met"] != true).collect();
    println!(
        "\ngoals: {} of {} met",
        goals.len() - missed.len(),
        goals.len()
    );
    // One line a goal missed, every scene where it was, what was measured
    // there (the builders where one SPE more was slower; their counts are
    // in the table's notes and the JSON).
    let mut kinds: Vec<&str> = missed.iter().filter_map(|g| g["goal"].as_str()).collect();
    kinds.dedup();
    kinds.sort_unstable();
    kinds.dedup();
    for kind in kinds {
        let at: Vec<String> = (missed.iter())
            .filter(|g| g["goal"] == kind)
            .map(|g| {
                let measured = match &g["measured"] {
                    Value::String(s) => builders_only(s),
                    v => f(v) + "x",
                };
                format!("{} {measured}", g["scene"].as_str().unwrap_or_default())
            })
            .collect();
        let line = format!("NOT met, {kind}: {}", at.join("; "));
        println!("{}", cellbih_cli::report::wrap(&line, 80));
    }
}

/// "spe_bfs_shared (7<6, 8<7), spe_morton (8<7)" as "spe_bfs_shared,
/// spe_morton".
fn builders_only(measured: &str) -> String {
    let mut out = String::new();
    let mut depth = 0;
    for c in measured.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            _ if depth == 0 => out.push(c),
            _ => {}
        }
    }
    out.split(',')
        .map(str::trim)
        .filter(|b| !b.is_empty())
        .collect::<Vec<_>>()
        .join(", ")
}

/// spe_scaling_speedup8.svg: each builder's speedup on 8 SPEs (defaults)
/// against the scene's triangles, one dot per scene.
pub fn plot(dir: &Path, rows: &[Value]) -> Result<(), Box<dyn std::error::Error>> {
    let mut builders: Vec<&str> = defaults(rows)
        .filter_map(|r| r["builder"].as_str())
        .collect();
    builders.sort_unstable();
    builders.dedup();
    let points: Vec<Series> = builders
        .iter()
        .enumerate()
        .map(|(i, &b)| Series {
            name: b.to_string(),
            points: defaults(rows)
                .filter(|r| r["builder"] == b && r["spes"] == 8)
                .filter_map(|r| Some((r["triangles"].as_f64()?, r["speedup"].as_f64()?)))
                .collect(),
            color: i,
            dashed: false,
        })
        .filter(|s| !s.points.is_empty())
        .collect();
    if points.is_empty() {
        return Ok(());
    }
    scatter_plot(
        &output(dir, "spe_scaling_speedup8.svg")?,
        "speedup on 8 SPEs over spe_bfs on one, each scene (simulated PS3 time)",
        "triangles",
        "speedup on 8 SPEs",
        &points,
        &[],
    )
}
