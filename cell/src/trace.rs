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
    /// In getllar / putllc / putlluc (including waiting for the line).
    pub atomic: Cycles,
    /// Of which: waiting for a lock line another core's atomic command held.
    pub atomic_wait: Cycles,
    /// Cycles this core's transfers took on the shared memory interface
    /// beyond their time alone on it: what sharing cost (for an SPE, time of
    /// its MFC, which overlaps its compute; for the PPE, time it stalled).
    pub memory_wait: Cycles,
    /// From the core's end to the end of the run.
    pub idle: Cycles,
    /// Starting the run's SPE programs (the PPE, one after another) or
    /// waiting for its own program's start (an SPE): `CostModel::spe_start_cycles`.
    pub start: Cycles,
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
    /// The PPE stalled on the shared memory interface.
    MemoryWait,
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

/// The timeline of one machine: its spans, and what it takes to draw them.
#[derive(Clone, Debug)]
pub struct Trace {
    pub spans: Vec<Span>,
    /// SPEs of the machine (rows 1 ..= 2·spes).
    pub spes: usize,
    /// Core clock, for converting cycles to time.
    pub hz: f64,
}

/// Extra tracks of one row start at this thread id: row `r`'s lane `k > 0`
/// is thread `LANE_TIDS + 100·r + k`.
const LANE_TIDS: usize = 10_000;

impl Trace {
    pub(crate) fn new(spes: usize, hz: f64) -> Self {
        Trace {
            spans: Vec::new(),
            spes,
            hz,
        }
    }

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

    /// Appends `other`'s spans (a machine of as many SPEs or fewer) moved
    /// `offset` later: several runs in one timeline, one after another.
    pub fn append(&mut self, other: Trace, offset: Cycles) {
        self.spes = self.spes.max(other.spes);
        self.spans.extend(other.spans.into_iter().map(|s| Span {
            start: s.start + offset,
            end: s.end + offset,
            ..s
        }));
    }

    /// An empty timeline of a machine of `spes` SPEs at `hz`.
    pub fn empty(spes: usize, hz: f64) -> Self {
        Trace::new(spes, hz)
    }

    /// Each span's lane within its row: spans of one row that overlap in
    /// time (an MFC with several transfers in flight) go to different
    /// lanes, each lane holding spans that never overlap. Lanes are given
    /// greedily in order of start (lowest free lane first), so a row whose
    /// spans never overlap is one lane.
    pub fn lanes(&self) -> Vec<usize> {
        let mut order: Vec<usize> = (0..self.spans.len()).collect();
        order.sort_by_key(|&i| (self.spans[i].row, self.spans[i].start, i));
        let mut lane = vec![0; self.spans.len()];
        // Per row: the end of the last span in each lane.
        let mut ends: Vec<Cycles> = Vec::new();
        let mut row = usize::MAX;
        for i in order {
            let s = &self.spans[i];
            if s.row != row {
                row = s.row;
                ends.clear();
            }
            let k = match ends.iter().position(|&e| e <= s.start) {
                Some(k) => k,
                None => {
                    ends.push(Cycles::ZERO);
                    ends.len() - 1
                }
            };
            ends[k] = s.end;
            lane[i] = k;
        }
        lane
    }

    /// Writes the timeline as Chrome trace-event JSON ("X" complete events;
    /// times in microseconds with nanosecond digits, rounded down from
    /// cycles so that spans that touch in cycles never overlap), one event
    /// a line, streamed: memory stays that of the spans. Rows are named
    /// "PPE", "SPE i" and "SPE i MFC"; a row whose spans overlap gets extra
    /// tracks "SPE i MFC (2)", … so that no two events on one track overlap.
    pub fn write_chrome(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        let lanes = self.lanes();
        let mut used = vec![0usize; 2 * self.spes + 1];
        for (s, &k) in self.spans.iter().zip(&lanes) {
            used[s.row] = used[s.row].max(k + 1);
        }
        let tid = |row: usize, lane: usize| {
            if lane == 0 {
                row
            } else {
                LANE_TIDS + 100 * row + lane
            }
        };
        let row_name = |row: usize| match row {
            0 => "PPE".to_string(),
            r if r % 2 == 1 => format!("SPE {}", (r - 1) / 2),
            r => format!("SPE {} MFC", (r - 2) / 2),
        };
        writeln!(w, "{{\"displayTimeUnit\": \"ns\", \"traceEvents\": [")?;
        let mut first = true;
        let mut event = |w: &mut dyn std::io::Write, e: serde_json::Value| {
            let sep = if first { "" } else { ",\n" };
            first = false;
            write!(w, "{sep}{e}")
        };
        for (row, &n) in used.iter().enumerate() {
            for lane in 0..n.max(1) {
                let name = if lane == 0 {
                    row_name(row)
                } else {
                    format!("{} ({})", row_name(row), lane + 1)
                };
                let t = tid(row, lane);
                event(
                    w,
                    json!({"name": "thread_name", "ph": "M", "pid": 1, "tid": t, "args": {"name": name}}),
                )?;
                event(
                    w,
                    json!({"name": "thread_sort_index", "ph": "M", "pid": 1, "tid": t, "args": {"sort_index": row * 100 + lane}}),
                )?;
            }
        }
        let ns = |c: Cycles| (c.0 as f64 * 1e9 / self.hz).floor() as u64;
        let us = |ns: u64| format!("{}.{:03}", ns / 1000, ns % 1000);
        for (s, &lane) in self.spans.iter().zip(&lanes) {
            let kind = format!("{:?}", s.kind);
            let name = s.label.as_deref().unwrap_or(&kind);
            let (a, b) = (ns(s.start), ns(s.end));
            let sep = if first { "" } else { ",\n" };
            first = false;
            write!(
                w,
                "{sep}{{\"name\": {}, \"cat\": \"{kind}\", \"ph\": \"X\", \"pid\": 1, \"tid\": {}, \"ts\": {}, \"dur\": {}}}",
                serde_json::Value::from(name),
                tid(s.row, lane),
                us(a),
                us(b - a)
            )?;
        }
        writeln!(w, "\n]}}")
    }
}

/// Checks that the complete ("X") events on each track of a Chrome trace
/// (as [`Trace::write_chrome`] writes it) are apart or nested, as the
/// format requires (Perfetto drops or misdraws the others). Compared in
/// whole nanoseconds, as Perfetto reads them. The error names the track
/// and the two slices.
pub fn check_nesting(trace: &serde_json::Value) -> Result<(), String> {
    let ns = |v: &serde_json::Value| (v.as_f64().unwrap_or(f64::NAN) * 1000.0).round() as i64;
    let mut by_track: std::collections::BTreeMap<i64, Vec<(i64, i64)>> = Default::default();
    let events = trace["traceEvents"]
        .as_array()
        .ok_or("the trace has no traceEvents array")?;
    for e in events {
        if e["ph"] == "X" {
            let start = ns(&e["ts"]);
            by_track
                .entry(e["tid"].as_i64().unwrap_or(-1))
                .or_default()
                .push((start, start + ns(&e["dur"])));
        }
    }
    for (tid, mut slices) in by_track {
        // Longest first among equal starts, so that a parent precedes its children.
        slices.sort_by_key(|&(a, b)| (a, std::cmp::Reverse(b)));
        let mut open: Vec<i64> = Vec::new();
        for (a, b) in slices {
            while open.last().is_some_and(|&end| end <= a) {
                open.pop();
            }
            if let Some(&end) = open.last()
                && b > end
            {
                return Err(format!(
                    "track {tid}: slice {a}..{b} ns overlaps its neighbour ending at {end} without nesting"
                ));
            }
            open.push(b);
        }
    }
    Ok(())
}
