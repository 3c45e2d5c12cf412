//! The machinery behind the calls programs make: the state of every core,
//! the event queue, DMA timing and the checks of checked mode. The
//! executor that runs the programs is in `executor.rs`.
//!
//! Each core's program is an `async` block over its context ([`Spe`],
//! [`Ppe`]). Every call that touches shared state (DMA issue and wait,
//! mailboxes, signals, the atomic unit, main memory) first yields: the
//! executor then resumes, one at a time, the ready core with the smallest
//! virtual clock (ties: PPE before SPE 0 before SPE 1 …), after applying
//! every event (DMA completion, mailbox or signal arrival) due at or before
//! that time. So the order of all shared effects is fixed by virtual time
//! alone: the same program gives the same cycles and the same bytes on any
//! host, with any number of host threads. Between yields a core touches
//! only its own local store, so nothing it computes can race.
//!
//! [`Spe`]: super::Spe
//! [`Ppe`]: super::Ppe

use std::cmp::{Ordering, Reverse};
use std::collections::{BinaryHeap, VecDeque};
use std::future::Future;
use std::pin::Pin;

use super::clock::Cycles;
use super::local_store::LocalStore;
use super::memory::MainMemory;
use super::mfc::{Direction, Segment, WaitMode};
use super::trace::{CoreCounters, SpanKind, Trace};
use super::{CellConfig, CellError, Ea, LsAddr, SignalMode};

pub(crate) type Task = Pin<Box<dyn Future<Output = Result<(), CellError>>>>;

/// Index of the PPE among the cores; SPE `i` is core `i + 1`.
pub(crate) const PPE: usize = 0;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum OutBox {
    Out = 0,
    OutIntr = 1,
}

/// What a blocked core waits for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Wait {
    Tags {
        mask: u32,
        mode: WaitMode,
    },
    QueueFull,
    InMbox,
    OutMboxFull(OutBox),
    Signal(usize),
    /// PPE: SPE `k`'s inbound mailbox is full.
    InMboxFull(usize),
    /// PPE: SPE `k`'s outbound mailbox is empty.
    OutMbox(usize, OutBox),
}

impl Wait {
    pub(crate) fn describe(&self, core: usize) -> String {
        let who = core_name(core);
        match *self {
            Wait::Tags { mask, mode } => format!("{who} waits ({mode:?}) on tag mask {mask:#x}"),
            Wait::QueueFull => format!("{who} waits for a free slot in its MFC queue"),
            Wait::InMbox => format!("{who} waits for a value in its inbound mailbox"),
            Wait::OutMboxFull(b) => format!("{who} waits for its {b:?} mailbox to be read"),
            Wait::Signal(r) => format!("{who} waits for signal-notification register {}", r + 1),
            Wait::InMboxFull(k) => format!("{who} waits for room in SPE {k}'s inbound mailbox"),
            Wait::OutMbox(k, b) => format!("{who} waits for a value in SPE {k}'s {b:?} mailbox"),
        }
    }

    fn is_mailbox(&self) -> bool {
        !matches!(self, Wait::Tags { .. } | Wait::QueueFull)
    }
}

pub(crate) fn core_name(core: usize) -> String {
    if core == PPE {
        "PPE".into()
    } else {
        format!("SPE {}", core - 1)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Status {
    Ready,
    Blocked { why: Wait, since: Cycles },
    Done,
}

pub(crate) struct Core {
    pub clock: Cycles,
    pub status: Status,
    pub counters: CoreCounters,
}

/// A command's local-store range that the program has not yet waited for
/// (checked mode).
pub(crate) struct Unwaited {
    pub tag: u32,
    pub dir: Direction,
    pub lo: u32,
    pub hi: u32,
}

#[derive(Default)]
pub(crate) struct SignalReg {
    pub value: u32,
    pub pending: bool,
}

pub(crate) struct SpeState {
    pub ls: LocalStore,
    pub queued: usize,
    pub outstanding: [u32; 32],
    pub unwaited: Vec<Unwaited>,
    pub mfc_free: Cycles,
    pub in_mbox: VecDeque<u32>,
    pub in_arriving: usize,
    pub out_mbox: [VecDeque<u32>; 2],
    pub out_arriving: [usize; 2],
    pub signals: [SignalReg; 2],
    pub reservation: Option<u64>,
}

pub(crate) struct Dma {
    pub spe: usize,
    pub tag: u32,
    pub dir: Direction,
    pub segments: Vec<Segment>,
    /// For a put: the local-store bytes, taken at issue.
    pub data: Vec<u8>,
}

pub(crate) enum EventKind {
    DmaDone(Box<Dma>),
    InMbox {
        spe: usize,
        value: u32,
    },
    OutMbox {
        spe: usize,
        which: OutBox,
        value: u32,
    },
    Signal {
        spe: usize,
        reg: usize,
        value: u32,
    },
}

pub(crate) struct Event {
    pub(crate) at: Cycles,
    seq: u64,
    pub(crate) kind: EventKind,
}

impl PartialEq for Event {
    fn eq(&self, o: &Self) -> bool {
        (self.at, self.seq) == (o.at, o.seq)
    }
}
impl Eq for Event {}
impl PartialOrd for Event {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Event {
    fn cmp(&self, o: &Self) -> Ordering {
        (self.at, self.seq).cmp(&(o.at, o.seq))
    }
}

pub(crate) struct Machine {
    pub cfg: CellConfig,
    pub mem: MainMemory,
    pub cores: Vec<Core>,
    pub spes: Vec<SpeState>,
    pub(crate) events: BinaryHeap<Reverse<Event>>,
    seq: u64,
    pub mem_free: Cycles,
    pub trace: Option<Trace>,
}

impl Machine {
    pub fn new(cfg: CellConfig) -> Self {
        let spes = (0..cfg.spes)
            .map(|_| SpeState {
                ls: LocalStore::new(cfg.local_store_bytes, cfg.ls_reserved_bytes),
                queued: 0,
                outstanding: [0; 32],
                unwaited: Vec::new(),
                mfc_free: Cycles::ZERO,
                in_mbox: VecDeque::new(),
                in_arriving: 0,
                out_mbox: [VecDeque::new(), VecDeque::new()],
                out_arriving: [0, 0],
                signals: Default::default(),
                reservation: None,
            })
            .collect();
        let cores = (0..=cfg.spes)
            .map(|_| Core {
                clock: Cycles::ZERO,
                status: Status::Done,
                counters: CoreCounters::default(),
            })
            .collect();
        Machine {
            mem: MainMemory::new(cfg.main_memory_bytes),
            trace: cfg.trace.then(|| Trace::new(cfg.spes, cfg.cost.clock_hz)),
            cfg,
            cores,
            spes,
            events: BinaryHeap::new(),
            seq: 0,
            mem_free: Cycles::ZERO,
        }
    }

    /// Trace row of a core (0 PPE, 1 + 2i SPE i) and of SPE i's MFC.
    fn row(core: usize) -> usize {
        if core == PPE { 0 } else { 1 + 2 * (core - 1) }
    }

    pub fn span(&mut self, core: usize, kind: SpanKind, start: Cycles, end: Cycles) {
        if let Some(t) = &mut self.trace {
            t.push(Self::row(core), kind, start, end, None);
        }
    }

    /// Charges `c` busy cycles to `core`.
    pub fn busy(&mut self, core: usize, c: Cycles, kind: SpanKind) {
        let start = self.cores[core].clock;
        self.cores[core].clock += c;
        self.cores[core].counters.busy += c;
        self.span(core, kind, start, start + c);
    }

    /// Charges `c` cycles spent in the atomic unit.
    pub fn atomic(&mut self, core: usize, c: Cycles) {
        let start = self.cores[core].clock;
        self.cores[core].clock += c;
        self.cores[core].counters.atomic += c;
        self.span(core, SpanKind::Atomic, start, start + c);
    }

    pub fn block(&mut self, core: usize, why: Wait) {
        let since = self.cores[core].clock;
        self.cores[core].status = Status::Blocked { why, since };
    }

    /// Resumes `core` at `at` if it is blocked on something `pred` accepts,
    /// booking the wait to its counters.
    pub fn wake_if(&mut self, core: usize, at: Cycles, pred: impl Fn(&Wait) -> bool) {
        if let Status::Blocked { why, since } = self.cores[core].status
            && pred(&why)
        {
            let end = at.max(since);
            let c = &mut self.cores[core];
            c.clock = c.clock.max(end);
            if why.is_mailbox() {
                c.counters.mailbox_wait += end - since;
            } else {
                c.counters.dma_wait += end - since;
            }
            c.status = Status::Ready;
            let kind = if why.is_mailbox() {
                SpanKind::MailboxWait
            } else {
                SpanKind::DmaWait
            };
            self.span(core, kind, since, end);
        }
    }

    pub fn schedule(&mut self, at: Cycles, kind: EventKind) {
        self.seq += 1;
        self.events.push(Reverse(Event {
            at,
            seq: self.seq,
            kind,
        }));
    }

    /// Issues a DMA command for SPE `spe` (queue space already checked):
    /// charges the issue, computes when it completes, and schedules that.
    pub fn issue_dma(
        &mut self,
        spe: usize,
        dir: Direction,
        segments: Vec<Segment>,
        tag: u32,
    ) -> Result<(), CellError> {
        let core = spe + 1;
        let cost = &self.cfg.cost;
        let bytes: u64 = segments.iter().map(|s| s.size as u64).sum();
        // Every segment must lie inside the local store and main memory.
        for s in &segments {
            self.spes[spe].ls.check_range(spe, s.ls, s.size as u64)?;
            self.mem
                .read(s.ea, s.size as u64)
                .map_err(|e| CellError::Dma {
                    spe,
                    cmd: super::mfc::command_name(dir, segments.len() > 1),
                    ls: s.ls,
                    ea: s.ea,
                    size: s.size,
                    why: e.to_string(),
                })?;
        }
        if self.cfg.checked {
            self.check_overlap_at_issue(spe, dir, &segments)?;
        }
        let data = match dir {
            Direction::Put => {
                let ls = self.spes[spe].ls.bytes();
                segments
                    .iter()
                    .flat_map(|s| {
                        ls[s.ls.0 as usize..(s.ls.0 + s.size) as usize]
                            .iter()
                            .copied()
                    })
                    .collect()
            }
            Direction::Get => Vec::new(),
        };
        let (issue, command, elements, latency) = (
            cost.dma_issue_cycles,
            cost.mfc_command_cycles,
            Cycles(cost.mfc_list_element_cycles.0 * (segments.len() as u64 - 1)),
            cost.dma_latency_cycles,
        );
        let (spe_data, mem_data) = (
            cost.spe_bandwidth.cycles(bytes),
            cost.memory_bandwidth.cycles(bytes),
        );
        self.busy(core, issue, SpanKind::Issue);
        let issued = self.cores[core].clock;
        // The MFC takes commands one at a time; the memory interface takes
        // the data of every SPE's commands in issue order.
        let start = issued.max(self.spes[spe].mfc_free);
        let data_start = (start + command + elements).max(self.mem_free);
        self.mem_free = data_start + mem_data;
        self.spes[spe].mfc_free = (start + command + elements + spe_data).max(self.mem_free);
        let done = self.spes[spe].mfc_free + latency;
        let st = &mut self.spes[spe];
        st.queued += 1;
        st.outstanding[tag as usize] += 1;
        for s in &segments {
            st.unwaited.push(Unwaited {
                tag,
                dir,
                lo: s.ls.0,
                hi: s.ls.0 + s.size,
            });
        }
        let c = &mut self.cores[core].counters;
        match dir {
            Direction::Get => {
                c.gets += 1;
                c.bytes_get += bytes;
            }
            Direction::Put => {
                c.puts += 1;
                c.bytes_put += bytes;
            }
        }
        if let Some(t) = &mut self.trace {
            let label = format!(
                "{} {bytes} B tag {tag}",
                if dir == Direction::Get { "get" } else { "put" }
            );
            t.push(
                Self::row(core) + 1,
                SpanKind::Transfer,
                start,
                done,
                Some(label),
            );
        }
        self.schedule(
            done,
            EventKind::DmaDone(Box::new(Dma {
                spe,
                tag,
                dir,
                segments,
                data,
            })),
        );
        Ok(())
    }

    /// Checked mode: a get into bytes an unfinished put still sends, or a
    /// put of bytes an unfinished get has not yet filled, is a race.
    fn check_overlap_at_issue(
        &self,
        spe: usize,
        dir: Direction,
        segments: &[Segment],
    ) -> Result<(), CellError> {
        for s in segments {
            let (lo, hi) = (s.ls.0, s.ls.0 + s.size);
            if let Some(u) = self.spes[spe]
                .unwaited
                .iter()
                .find(|u| u.lo < hi && lo < u.hi && u.dir != dir)
            {
                let action = if dir == Direction::Get {
                    "a get into"
                } else {
                    "a put from"
                };
                return Err(race(spe, format!("{action} ls {lo:#x}..{hi:#x} issued"), u));
            }
        }
        Ok(())
    }

    /// Checked mode: the program touches local store `lo..hi`; reading
    /// bytes of an unwaited get, or writing bytes of an unwaited get or put,
    /// is an error.
    pub fn check_ls_access(
        &self,
        spe: usize,
        lo: u32,
        hi: u32,
        write: bool,
    ) -> Result<(), CellError> {
        if !self.cfg.checked {
            return Ok(());
        }
        let hit = self.spes[spe]
            .unwaited
            .iter()
            .find(|u| u.lo < hi && lo < u.hi && (write || u.dir == Direction::Get));
        match hit {
            None => Ok(()),
            Some(u) => {
                let verb = if write { "writes" } else { "reads" };
                Err(race(
                    spe,
                    format!("the program {verb} ls {lo:#x}..{hi:#x}"),
                    u,
                ))
            }
        }
    }

    /// Any store to main memory `ea..ea+len` loses every reservation on
    /// the 128-byte lines it touches.
    pub fn lose_reservations(&mut self, ea: Ea, len: u64) {
        let (first, last) = (ea.0 / 128, (ea.0 + len.max(1) - 1) / 128);
        for s in &mut self.spes {
            if let Some(line) = s.reservation
                && (first..=last).contains(&(line / 128))
            {
                s.reservation = None;
            }
        }
    }

    pub(crate) fn apply(&mut self, at: Cycles, kind: EventKind) -> Result<(), CellError> {
        match kind {
            EventKind::DmaDone(d) => {
                let mut offset = 0usize;
                for s in &d.segments {
                    let n = s.size as usize;
                    match d.dir {
                        Direction::Get => {
                            let src = self.mem.read(s.ea, n as u64)?.to_vec();
                            let r = s.ls.0 as usize..s.ls.0 as usize + n;
                            self.spes[d.spe].ls.bytes_mut()[r].copy_from_slice(&src);
                        }
                        Direction::Put => {
                            self.mem.write(s.ea, &d.data[offset..offset + n])?;
                            self.lose_reservations(s.ea, n as u64);
                        }
                    }
                    offset += n;
                }
                let st = &mut self.spes[d.spe];
                st.queued -= 1;
                st.outstanding[d.tag as usize] -= 1;
                self.wake_if(d.spe + 1, at, |w| {
                    matches!(w, Wait::Tags { .. } | Wait::QueueFull)
                });
            }
            EventKind::InMbox { spe, value } => {
                let st = &mut self.spes[spe];
                st.in_arriving -= 1;
                st.in_mbox.push_back(value);
                self.wake_if(spe + 1, at, |w| *w == Wait::InMbox);
            }
            EventKind::OutMbox { spe, which, value } => {
                let st = &mut self.spes[spe];
                st.out_arriving[which as usize] -= 1;
                st.out_mbox[which as usize].push_back(value);
                self.wake_if(PPE, at, |w| *w == Wait::OutMbox(spe, which));
            }
            EventKind::Signal { spe, reg, value } => {
                let r = &mut self.spes[spe].signals[reg];
                r.value = match self.cfg.signal_modes[reg] {
                    SignalMode::Overwrite => value,
                    SignalMode::Or => r.value | value,
                };
                r.pending = true;
                self.wake_if(spe + 1, at, |w| *w == Wait::Signal(reg));
            }
        }
        Ok(())
    }
}

/// The error for `what` happening to bytes of a transfer not waited for.
fn race(spe: usize, what: String, u: &Unwaited) -> CellError {
    CellError::Race {
        spe,
        what: format!(
            "{what} while the {} of ls {:#x}..{:#x} (tag {}) is not waited for",
            u.dir, u.lo, u.hi, u.tag
        ),
    }
}

/// Local-store address helper for the contexts.
pub(crate) fn ls_range(
    spe: usize,
    m: &Machine,
    addr: LsAddr,
    bytes: u64,
) -> Result<std::ops::Range<usize>, CellError> {
    m.spes[spe].ls.check_range(spe, addr, bytes)
}
