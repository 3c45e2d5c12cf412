//! The emulator's timeline as Chrome trace-event JSON: a row per core and
//! per MFC, and transfers in flight at once on tracks of their own so that
//! every slice nests.

use cellbih_cell::trace::check_nesting;
use cellbih_cell::{Cell, CellConfig, Cycles, WaitMode};

#[test]
fn the_trace_is_chrome_json_with_a_row_per_core() {
    let mut cfg = CellConfig::ps3().with_spes(2);
    cfg.trace = true;
    let mut c = Cell::new(cfg).unwrap();
    let ea = c.memory_mut().alloc("test buffer", 4096, 128).unwrap();
    for id in 0..2 {
        c.spawn_spe(id, move |spe| async move {
            let b = spe.ls_alloc(4096, 128)?;
            spe.get(b, ea, 4096, 0).await?;
            spe.wait_tag(0).await?;
            spe.compute(Cycles(100));
            Ok(())
        });
    }
    c.run().unwrap();
    let mut buf = Vec::new();
    c.take_trace().unwrap().write_chrome(&mut buf).unwrap();
    let j: serde_json::Value = serde_json::from_slice(&buf).unwrap();
    let events = j["traceEvents"].as_array().unwrap();
    let names: Vec<&str> = events
        .iter()
        .filter(|e| e["name"] == "thread_name")
        .map(|e| e["args"]["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        vec!["PPE", "SPE 0", "SPE 0 MFC", "SPE 1", "SPE 1 MFC"]
    );
    let transfers = events.iter().filter(|e| e["cat"] == "Transfer").count();
    assert_eq!(transfers, 2);
    assert!(
        events
            .iter()
            .any(|e| e["cat"] == "Compute" && e["tid"] == 3)
    );
}

/// Transfers in flight at once on one MFC overlap in time; the Chrome
/// format wants every slice on a track nested or apart, so they go to
/// tracks of their own ("SPE 0 MFC (2)", …), as many as were in flight.
#[test]
fn overlapping_transfers_get_tracks_of_their_own() {
    let mut cfg = CellConfig::ps3().with_spes(1);
    cfg.trace = true;
    let mut c = Cell::new(cfg).unwrap();
    let ea = c.memory_mut().alloc("test buffer", 4 * 16384, 128).unwrap();
    c.spawn_spe(0, move |spe| async move {
        let b = spe.ls_alloc(4 * 16384, 128)?;
        for k in 0..4u64 {
            spe.get(
                b.offset(k as u32 * 16384),
                ea.offset(k * 16384),
                16384,
                k as u32,
            )
            .await?;
        }
        spe.wait_tags(0b1111, WaitMode::All).await?;
        Ok(())
    });
    c.run().unwrap();
    let trace = c.take_trace().unwrap();
    let mut buf = Vec::new();
    trace.write_chrome(&mut buf).unwrap();
    let j: serde_json::Value = serde_json::from_slice(&buf).unwrap();
    check_nesting(&j).unwrap();
    let events = j["traceEvents"].as_array().unwrap();
    let tracks: std::collections::BTreeSet<u64> = events
        .iter()
        .filter(|e| e["cat"] == "Transfer")
        .map(|e| e["tid"].as_u64().unwrap())
        .collect();
    // As many tracks as transfers were in flight at once (counted in
    // cycles), and more than one.
    let mut edges: Vec<(u64, i32)> = trace
        .spans
        .iter()
        .filter(|s| s.kind == cellbih_cell::trace::SpanKind::Transfer)
        .flat_map(|s| [(s.start.0, 1), (s.end.0, -1)])
        .collect();
    edges.sort_by_key(|&(t, d)| (t, d));
    let in_flight = edges
        .iter()
        .scan(0, |n, &(_, d)| {
            *n += d;
            Some(*n)
        })
        .max()
        .unwrap();
    assert!(in_flight >= 2, "the gets overlap in time");
    assert_eq!(tracks.len(), in_flight as usize);
    let names: Vec<&str> = events
        .iter()
        .filter(|e| e["name"] == "thread_name")
        .map(|e| e["args"]["name"].as_str().unwrap())
        .collect();
    assert!(names.contains(&"SPE 0 MFC (2)"), "{names:?}");
    // The checker itself catches two slices that overlap without nesting.
    let bad = serde_json::json!({"traceEvents": [
        {"ph": "X", "tid": 1, "ts": 0.0, "dur": 2.0},
        {"ph": "X", "tid": 1, "ts": 1.0, "dur": 2.0},
    ]});
    assert!(check_nesting(&bad).is_err());
}
