//! `validate`'s PPE section: the PPE's latencies and streaming rates
//! measured on a retail PS3 (cellmark's PPE page): the L1 and L2 hits
//! price every PPE load through its caches (`kernels::ppe_rates`), the
//! streaming rates bound `ppe_memory_bandwidth`; and a held-out check of
//! them: Codeplay's quicksort timed on the PPU, its reads through the same
//! caches at the same latencies (`sorts.rs`). Codeplay's sort is tuned,
//! so the model's plain sort should take at least its time.

use cellbih::kernels::ppe_rates::{PpeRates, latency};
use cellbih::kernels::rates::Band;

use super::sorts;

/// The figures the PPE's rates are built from: (what, source, published,
/// unit, the model's value in that unit).
fn sources() -> [(
    &'static str,
    &'static str,
    f64,
    &'static str,
    f64,
    &'static str,
); 4] {
    const LOADS: &str = "the PPE's loads through its caches (update.*, ppe_naive, ppe_approx)";
    const STREAMS: &str = "ppe_memory_bandwidth's band";
    let gbs = |per_byte: f64| 3.2 / per_byte;
    [
        (
            "PPE load chained on an L1 hit",
            "cellmark ppe_tuning.md",
            6.4,
            "cycles",
            latency::L1_LOAD,
            LOADS,
        ),
        (
            "PPE load chained on an L2 hit",
            "cellmark ppe_tuning.md",
            36.0,
            "cycles",
            latency::L2_HIT,
            LOADS,
        ),
        (
            "PPE reads streaming from the L2, plain",
            "cellmark ppe_tuning.md",
            2.75,
            "GB/s",
            gbs(latency::STREAM_BYTE),
            STREAMS,
        ),
        (
            "PPE reads streaming from the L2, dcbt 512 B ahead",
            "cellmark ppe_tuning.md",
            8.4,
            "GB/s",
            gbs(latency::STREAM_BYTE_DCBT),
            STREAMS,
        ),
    ]
}

/// The section's rows. The sort's verdict is reported, not enforced:
/// the PPE's rates are estimates with bands, and the row says where in
/// their bands the sort puts them.
pub fn section(text: bool) -> Vec<serde_json::Value> {
    let mut rows = Vec::new();
    if text {
        let title = "PPE: the measured latencies its loads are priced at and the streaming \
                     rates that bound its bandwidth, and a sort timed on the PPU priced the same \
                     way (held out; Codeplay's sort is tuned, so the model's plain one should \
                     take at least its time; reported, not enforced: the rates are banded \
                     estimates)";
        println!("\n{}", cellbih_cli::report::wrap(title, 80));
    }
    super::row(
        text,
        "published figure (retail PS3, 3.2 GHz)",
        ["published", "model", "ratio", "tol.", "verdict"].map(String::from),
    );
    for (what, source, published, unit, model, sets) in sources() {
        super::row(
            text,
            &format!("{what} ({unit})"),
            [
                format!("{published:.2}"),
                format!("{model:.2}"),
                format!("{:.3}", model / published),
                "-".into(),
                "sets".into(),
            ],
        );
        rows.push(serde_json::json!({
            "figure": what, "source": source, "unit": unit, "published": published,
            "emulated": model, "ratio": model / published, "tolerance": 0.0,
            "pass": (model / published - 1.0).abs() < 0.01, "role": "fitted",
            "sets": sets, "section": "ppe",
        }));
    }
    let t = &sorts::PPU;
    let got = t.ppu();
    let ratio = got / t.published_ms;
    // A lower bound: plain code is no faster than the tuned sort.
    let ok = ratio >= 1.0;
    super::row(
        text,
        &format!("{} (ms)", t.what),
        [
            format!("{:.2}", t.published_ms),
            format!("{got:.2}"),
            format!("{ratio:.3}"),
            ">=1".into(),
            // Reported, not enforced: a miss is the model's, said so.
            if ok { "pass" } else { "below" }.into(),
        ],
    );
    let implied = implied(ratio);
    if text {
        let note = format!(
            "the plain sort at {ratio:.2} of the tuned sort's time: the PPE is priced at \
             least {:.2}x too cheap here; the update's steps at that factor: {}",
            1.0 / ratio,
            implied.join(", ")
        );
        println!("{}", cellbih_cli::report::wrap(&note, 80));
    }
    rows.push(serde_json::json!({
        "figure": t.what, "source": sorts::SOURCE, "unit": "ms",
        "published": t.published_ms, "emulated": got, "ratio": ratio, "tolerance": 0.0,
        "bound": "lower",
        "pass": ok, "gates": false, "role": "held-out", "sets": null, "section": "ppe",
        "update_rates_implied": implied,
    }));
    rows
}

/// Where a sort at `ratio` of its figure puts the update's rates: each
/// scaled as the sort's time would need, beside its band.
fn implied(ratio: f64) -> Vec<String> {
    (PpeRates::table().iter())
        .map(|r| {
            let at = (r.at)(&mut PpeRates::PS3.clone()).0 as f64 / ratio;
            let Band::Between { low, high, .. } = r.band else {
                unreachable!("the PPE's rates are banded")
            };
            let inside = (low.0 as f64..=high.0 as f64).contains(&at);
            format!(
                "{} {at:.0} ({}-{}, {})",
                r.name.trim_start_matches("update."),
                low.0,
                high.0,
                if inside { "inside" } else { "OUTSIDE" }
            )
        })
        .collect()
}
