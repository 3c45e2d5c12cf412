//! Counters and the timeline of a run. Counters are always kept; the
//! timeline only when asked for (it grows with every operation). The
//! timeline exports as Chrome trace-event JSON, which opens in Perfetto
//! (ui.perfetto.dev) and chrome://tracing: one row per core and one per
//! SPE's MFC, times in microseconds of simulated time.

use serde::Serialize;
use serde_json::json;

use super::clock::Cycles;

/// Where one core's cycles went, and what it moved.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct CoreCounters {
    /// Compute charged by the program and the SPU side of issuing commands.
    pub busy: Cycles,
    /// Stalled in `wait_tags` or on a full MFC queue.
    pub dma_wait: Cycles,
    /// Stalled on a mailbox or signal (empty on read, full on write).
    pub mailbox_wait: Cycles,
    /// In getllar / putllc / putlluc.
    pub atomic: Cycles,
    /// From the core's end to the end of the run.
    pub idle: Cycles,
    pub gets: u64,
    pub puts: u64,
    pub bytes_get: u64,
    pub bytes_put: u64,
    /// putllc that found the reservation lost (contention on a shared line).
    pub reservations_lost: u64,
    pub mailbox_messages: u64,
    /// Local-store high-water mark in bytes (reserved room included).
    pub ls_high_water: u32,
}

/// What a span of a core's time was.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum SpanKind {
    Compute,
    Issue,
    DmaWait,
    MailboxWait,
    Atomic,
    /// A DMA transfer on an SPE's MFC row.
    Transfer,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Span {
    /// Trace row: 0 is the PPE, 1 + 2·i SPE i, 2 + 2·i SPE i's MFC.
    pub row: usize,
    pub kind: SpanKind,
    pub start: Cycles,
    pub end: Cycles,
    pub label: Option<String>,
}

#[derive(Clone, Debug, Default)]
pub struct Trace {
    pub spans: Vec<Span>,
}

impl Trace {
    pub(crate) fn push(
        &mut self,
        row: usize,
        kind: SpanKind,
        start: Cycles,
        end: Cycles,
        label: Option<String>,
    ) {
        if end > start {
            self.spans.push(Span {
                row,
                kind,
                start,
                end,
                label,
            });
        }
    }

    /// Chrome trace-event JSON ("X" complete events, microseconds).
    pub fn to_chrome_json(&self, spes: usize, hz: f64) -> serde_json::Value {
        let mut events = vec![
            json!({"name": "thread_name", "ph": "M", "pid": 1, "tid": 0, "args": {"name": "PPE"}}),
        ];
        for i in 0..spes {
            events.push(json!({"name": "thread_name", "ph": "M", "pid": 1, "tid": 1 + 2 * i, "args": {"name": format!("SPE {i}")}}));
            events.push(json!({"name": "thread_name", "ph": "M", "pid": 1, "tid": 2 + 2 * i, "args": {"name": format!("SPE {i} MFC")}}));
        }
        for s in &self.spans {
            let name = s.label.clone().unwrap_or_else(|| format!("{:?}", s.kind));
            events.push(json!({
                "name": name, "cat": format!("{:?}", s.kind), "ph": "X", "pid": 1, "tid": s.row,
                "ts": s.start.us(hz), "dur": (s.end - s.start).us(hz),
            }));
        }
        json!({ "traceEvents": events, "displayTimeUnit": "ns" })
    }
}
