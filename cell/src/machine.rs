//! The machinery behind the calls programs make: the state of every core,
//! the event queue, DMA timing and the checks of checked mode. The
//! executor that runs the programs is in `executor.rs`.
//!
//! Each core's program is an `async` block over its context ([`Spe`],
//! [`Ppe`]). Every call that touches shared state (DMA issue and wait,
//! mailboxes, signals, the atomic unit, main memory) first yields: the
//! executor then resumes, one at a time, the ready core with the smallest
//! virtual clock (ties broken in a seeded order that rotates at every
//! resume, the same every run: see `executor.rs`), after applying
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
use super::memif::MemoryInterface;
use super::memory::MainMemory;
use super::mfc::{Direction, Order, Segment, WaitMode};
use super::trace::{CoreCounters, SpanKind, Trace};
use super::{CellConfig, CellError, Ea, LockLines, LsAddr, SignalMode};

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
    /// PPE: its own reads or writes of main memory are on the interface.
    Memory,
    /// PPE: the outbound mailbox of any SPE of the mask is empty.
    AnyOutMbox(u64),
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
            Wait::Memory => format!("{who} waits for its main-memory access"),
            Wait::AnyOutMbox(mask) => {
                format!("{who} waits for a value in the Out mailbox of any SPE of mask {mask:#x}")
            }
        }
    }

    fn is_mailbox(&self) -> bool {
        !matches!(self, Wait::Tags { .. } | Wait::QueueFull | Wait::Memory)
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
    /// When the MFC finished its last command's data.
    pub mfc_free: Cycles,
    /// The MFC works on one command at a time (command phase, then data);
    /// the others wait here in issue order.
    pub mfc_busy: bool,
    pub pending: VecDeque<Dma>,
    /// Tag groups allocated by name: (name, first, count).
    pub tag_names: Vec<(&'static str, u32, u32)>,
    /// Commands issued and not yet complete, in issue order (for ordering).
    pub incomplete: Vec<InFlight>,
    /// Per tag group: the latest completion of a command whose data has
    /// moved, and of a barrier command.
    pub tag_done: [Cycles; 32],
    pub barrier_done: [Cycles; 32],
    /// Commands issued so far (numbers them).
    pub issued: u64,
    pub in_mbox: VecDeque<u32>,
    pub in_arriving: usize,
    /// Outbound mailboxes: values with the cycle they arrived.
    pub out_mbox: [VecDeque<(u32, Cycles)>; 2],
    pub out_arriving: [usize; 2],
    pub signals: [SignalReg; 2],
    pub reservation: Option<u64>,
    /// The lines in this SPE's atomic cache (line numbers), least recently
    /// used first.
    pub atomic_cache: VecDeque<u64>,
}

impl SpeState {
    /// An SPE as a program finds it when started: an empty local store
    /// (beyond the room reserved for code and stack), an idle MFC, empty
    /// mailboxes.
    pub(crate) fn new(cfg: &CellConfig) -> Self {
        SpeState {
            ls: LocalStore::new(cfg.local_store_bytes, cfg.ls_reserved_bytes),
            queued: 0,
            outstanding: [0; 32],
            unwaited: Vec::new(),
            mfc_free: Cycles::ZERO,
            mfc_busy: false,
            pending: VecDeque::new(),
            tag_names: Vec::new(),
            incomplete: Vec::new(),
            tag_done: [Cycles::ZERO; 32],
            barrier_done: [Cycles::ZERO; 32],
            issued: 0,
            in_mbox: VecDeque::new(),
            in_arriving: 0,
            out_mbox: [VecDeque::new(), VecDeque::new()],
            out_arriving: [0, 0],
            signals: Default::default(),
            reservation: None,
            atomic_cache: VecDeque::new(),
        }
    }

    /// Nothing of the SPE's is on its way: no command queued or in
    /// flight, no mailbox value arriving.
    pub(crate) fn quiet(&self) -> bool {
        self.queued == 0
            && self.pending.is_empty()
            && self.incomplete.is_empty()
            && self.in_arriving == 0
            && self.out_arriving == [0, 0]
    }
}

/// What checked mode keeps of a command until it completes.
pub(crate) struct InFlight {
    pub id: u64,
    pub tag: u32,
    pub dir: Direction,
    pub order: Order,
    /// Its main-memory ranges, touching segments merged.
    pub ranges: Vec<(u64, u64)>,
}

pub(crate) struct Dma {
    /// The command's number on its SPE, in issue order.
    pub id: u64,
    pub order: Order,
    pub spe: usize,
    pub tag: u32,
    pub dir: Direction,
    pub segments: Vec<Segment>,
    /// For a put: the local-store bytes, taken at issue.
    pub data: Vec<u8>,
    /// Issued at; once the MFC takes it, when its command phase began.
    pub start: Cycles,
    /// Its effective addresses are another local store's (an SPE-to-SPE
    /// transfer over the EIB).
    pub eib: bool,
}

impl Dma {
    pub(crate) fn bytes(&self) -> u64 {
        self.segments.iter().map(|s| s.size as u64).sum()
    }
}

/// A 128-byte line as the atomic units see it: which core's atomic cache
/// holds it, and until when an atomic command on it is under way; with
/// shared lock lines (`LockLines::Shared`), every core holding a copy and
/// until when reads of it are under way.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct LockLine {
    pub owner: Option<usize>,
    pub busy_until: Cycles,
    /// One bit a core (PPE 0, SPE n at n + 1).
    pub holders: u64,
    /// Until when the misses queued on the line hold it: the line goes to
    /// one atomic cache at a time, each taking it for a claim's time.
    pub reads_until: Cycles,
    /// The core whose partial-line DMA put claimed the line last, while no
    /// other core has stored to it or taken a copy since.
    pub writer: Option<usize>,
}

impl LockLine {
    /// When a claim made at `now` may start: after a claim under way and
    /// the misses queued before it have had the line.
    pub fn claim_start(&self, now: Cycles) -> Cycles {
        now.max(self.busy_until).max(self.reads_until)
    }
}

/// What ends when a flow on the memory interface ends.
pub(crate) enum Flowing {
    /// An SPE's DMA command: its completion follows after the latency.
    Spe(Box<Dma>),
    /// The PPE's own access: the PPE resumes.
    Ppe,
}

pub(crate) enum EventKind {
    /// The MFC has done a command's command phase: its data goes onto the
    /// memory interface.
    FlowStart(Box<Dma>),
    /// An SPE-to-SPE transfer's data, started at the given cycle, is
    /// through the EIB.
    EibDone(Box<Dma>, Cycles),
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
    /// `cfg.cost`, shared with programs that read their rates.
    pub cost: std::rc::Rc<super::CostModel>,
    pub mem: MainMemory,
    pub cores: Vec<Core>,
    pub spes: Vec<SpeState>,
    pub(crate) events: BinaryHeap<Reverse<Event>>,
    seq: u64,
    /// The memory interface every core's traffic shares.
    pub memif: MemoryInterface,
    /// What each flow on the interface is, by flow id.
    pub flows: Vec<(u64, Flowing)>,
    /// Cores resumed so far (seeds the order of equal clocks).
    pub resumes: u64,
    /// Lock lines that atomic commands have touched, by line number.
    pub lines: std::collections::HashMap<u64, LockLine>,
    /// The line the PPE's last lwarx reserved (its address), until a
    /// store by any core to the line.
    pub ppe_reservation: Option<u64>,
    pub trace: Option<Trace>,
}

impl Machine {
    pub fn new(cfg: CellConfig) -> Self {
        let spes = (0..cfg.spes).map(|_| SpeState::new(&cfg)).collect();
        let cores = (0..=cfg.spes)
            .map(|_| Core {
                clock: Cycles::ZERO,
                status: Status::Done,
                counters: CoreCounters::default(),
            })
            .collect();
        Machine {
            cost: std::rc::Rc::new(cfg.cost.clone()),
            mem: MainMemory::new(cfg.main_memory_bytes),
            memif: MemoryInterface::new(
                cfg.cost.memory_bandwidth,
                cfg.cost.memory_shared_bandwidth,
                cfg.cost.eib_capacity(cfg.spes),
                cfg.cost.ls_port_bandwidth,
            ),
            flows: Vec::new(),
            resumes: 0,
            lines: Default::default(),
            ppe_reservation: None,
            trace: cfg.trace.then(|| Trace::new(cfg.spes, cfg.cost.clock_hz)),
            cfg,
            cores,
            spes,
            events: BinaryHeap::new(),
            seq: 0,
        }
    }

    /// Trace row of a core (0 PPE, 1 + 2i SPE i) and of SPE i's MFC.
    pub(crate) fn row(core: usize) -> usize {
        if core == PPE { 0 } else { 1 + 2 * (core - 1) }
    }

    pub fn span(&mut self, core: usize, kind: SpanKind, start: Cycles, end: Cycles) {
        if let Some(t) = &mut self.trace {
            t.push(Self::row(core), kind, start, end, None);
        }
    }

    /// The tag groups of `mask` with no command of SPE `spe` outstanding.
    pub fn tags_done(&self, spe: usize, mask: u32) -> u32 {
        let st = &self.spes[spe];
        (0..32)
            .filter(|&t| mask >> t & 1 == 1 && st.outstanding[t] == 0)
            .fold(0u32, |a, t| a | 1 << t)
    }

    /// Charges `cycles` of a program's computation on `core` (none in the
    /// functional mode: `CostModel::charge_compute`).
    pub fn compute(&mut self, core: usize, cycles: Cycles) {
        let cycles = match self.cost.charge_compute {
            true => cycles,
            false => Cycles::ZERO,
        };
        self.busy(core, cycles, SpanKind::Compute);
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

    /// An atomic command of `core` on the lock line holding `ea`: it waits
    /// while another atomic command on the line is under way (commands on
    /// one line are served one at a time, in the order they are made),
    /// then takes `hit` cycles if the line is in this core's atomic cache,
    /// or `miss` cycles to bring it over (from main memory or another
    /// core's atomic cache), and the line is this core's.
    pub fn lock_line(&mut self, core: usize, ea: Ea, hit: Cycles, miss: Cycles) {
        let now = self.cores[core].clock;
        let line = self.lines.entry(ea.0 / 128).or_default();
        let start = now.max(line.busy_until);
        let cost = if line.owner == Some(core) { hit } else { miss };
        line.owner = Some(core);
        line.busy_until = start + cost;
        self.cache_line(core, ea.0 / 128);
        self.charge_atomic(core, now, start, cost);
    }

    /// Shared lock lines: a getllar of `core` on the line holding `ea`. A
    /// copy in its atomic cache costs `hit`; otherwise it waits for a claim
    /// under way and for the other cores' misses to have had the line (it
    /// goes to one atomic cache at a time, each holding it for `hold`
    /// cycles) and brings the line over in `miss` cycles.
    pub fn read_line(&mut self, core: usize, ea: Ea, hit: Cycles, miss: Cycles) {
        let now = self.cores[core].clock;
        let hold = match self.cfg.cost.lock_lines {
            LockLines::Shared { claim_cycles } => claim_cycles,
            LockLines::Exclusive => miss,
        };
        let line = self.lines.entry(ea.0 / 128).or_default();
        let (start, cost) = if line.holders >> core & 1 == 1 {
            (now, hit)
        } else {
            let start = line.claim_start(now);
            line.reads_until = start + hold;
            line.holders |= 1 << core;
            (start, miss)
        };
        self.cache_line(core, ea.0 / 128);
        self.charge_atomic(core, now, start, cost);
    }

    /// `line` is now the most recently used of `core`'s atomic cache; a
    /// line beyond the cache's capacity leaves it, and with it any
    /// reservation on it (the PPE's own updates go through its L2: no
    /// limit).
    fn cache_line(&mut self, core: usize, line: u64) {
        let Some(capacity) = self.cfg.cost.atomic_cache_lines else {
            return;
        };
        if core == PPE {
            return;
        }
        let st = &mut self.spes[core - 1];
        st.atomic_cache.retain(|&l| l != line);
        st.atomic_cache.push_back(line);
        while st.atomic_cache.len() > capacity {
            let out = st.atomic_cache.pop_front().expect("over capacity");
            if st.reservation.is_some_and(|r| r / 128 == out) {
                st.reservation = None;
            }
            if let Some(l) = self.lines.get_mut(&out) {
                l.holders &= !(1 << core);
                if l.owner == Some(core) {
                    l.owner = None;
                }
            }
        }
    }

    /// Shared lock lines: a store of `core` to the line holding `ea`
    /// (putllc holding its reservation, putlluc, the PPE's own update). The
    /// only holder stores in `hit` cycles; otherwise the store claims the
    /// line, after any claim and read under way, in `claim` cycles. Every
    /// other copy and reservation of the line is lost; the line is this
    /// core's alone.
    pub fn claim_line(&mut self, core: usize, ea: Ea, hit: Cycles, claim: Cycles) {
        let now = self.cores[core].clock;
        let line = self.lines.entry(ea.0 / 128).or_default();
        let (start, cost) = if line.holders == 1 << core {
            (now.max(line.busy_until), hit)
        } else {
            (line.claim_start(now), claim)
        };
        line.busy_until = start + cost;
        self.lose_reservations(ea, 128);
        self.lines.entry(ea.0 / 128).or_default().holders = 1 << core;
        self.cache_line(core, ea.0 / 128);
        self.charge_atomic(core, now, start, cost);
    }

    /// A store of `core` to the lock line holding `ea` (putllc holding its
    /// reservation, putlluc): every reservation of the line is lost, and
    /// the store costs what the lock-line model says (`hit` or `miss` for
    /// exclusive lines, `hit` or the claim for shared ones).
    pub fn store_line(&mut self, core: usize, ea: Ea, hit: Cycles, miss: Cycles) {
        match self.cfg.cost.lock_lines {
            LockLines::Exclusive => {
                self.lose_reservations(ea, 128);
                self.lock_line(core, ea, hit, miss);
            }
            LockLines::Shared { claim_cycles } => self.claim_line(core, ea, hit, claim_cycles),
        }
    }

    /// `core` waited from `now` to `start` for a lock line, then worked on
    /// it for `cost` cycles.
    fn charge_atomic(&mut self, core: usize, now: Cycles, start: Cycles, cost: Cycles) {
        let wait = start - now;
        let c = &mut self.cores[core];
        c.clock = start + cost;
        c.counters.atomic += wait + cost;
        c.counters.atomic_wait += wait;
        self.span(core, SpanKind::Atomic, now, start + cost);
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

    /// Any store to main memory `ea..ea+len` loses every reservation on
    /// the 128-byte lines it touches.
    pub fn lose_reservations(&mut self, ea: Ea, len: u64) {
        let (first, last) = (ea.0 / 128, (ea.0 + len.max(1) - 1) / 128);
        if !self.lines.is_empty() {
            for l in first..=last {
                if let Some(line) = self.lines.get_mut(&l) {
                    line.owner = None;
                    line.holders = 0;
                    line.writer = None;
                }
            }
        }
        for s in &mut self.spes {
            if let Some(line) = s.reservation
                && (first..=last).contains(&(line / 128))
            {
                s.reservation = None;
            }
        }
        if self
            .ppe_reservation
            .is_some_and(|l| (first..=last).contains(&(l / 128)))
        {
            self.ppe_reservation = None;
        }
    }

    pub(crate) fn apply(&mut self, at: Cycles, kind: EventKind) -> Result<(), CellError> {
        match kind {
            EventKind::FlowStart(d) => self.start_flow(d, at),
            EventKind::EibDone(d, data_start) => {
                self.end_transfer(d, data_start, at - data_start, at);
            }
            EventKind::DmaDone(d) => {
                let mut offset = 0usize;
                for s in &d.segments {
                    let n = s.size as usize;
                    let own = s.ls.0 as usize..s.ls.0 as usize + n;
                    let other =
                        s.ea.local_store()
                            .map(|(t, off)| (t, off as usize..off as usize + n));
                    match (d.dir, other) {
                        (Direction::Get, None) => {
                            let src = self.mem.read(s.ea, n as u64)?.to_vec();
                            self.spes[d.spe].ls.bytes_mut()[own].copy_from_slice(&src);
                        }
                        (Direction::Get, Some((t, r))) => {
                            let src = self.spes[t].ls.bytes()[r].to_vec();
                            self.spes[d.spe].ls.bytes_mut()[own].copy_from_slice(&src);
                        }
                        (Direction::Put, None) => {
                            self.mem.write(s.ea, &d.data[offset..offset + n])?;
                            // The lines this put claimed stay its SPE's.
                            let claimed: Vec<u64> = partial_lines(s.ea.0, s.size)
                                .filter(|l| {
                                    self.lines.get(l).and_then(|l| l.writer) == Some(d.spe + 1)
                                })
                                .collect();
                            self.lose_reservations(s.ea, n as u64);
                            for l in claimed {
                                self.lines.entry(l).or_default().writer = Some(d.spe + 1);
                            }
                        }
                        (Direction::Put, Some((t, r))) => {
                            self.spes[t].ls.bytes_mut()[r]
                                .copy_from_slice(&d.data[offset..offset + n]);
                        }
                    }
                    offset += n;
                }
                let st = &mut self.spes[d.spe];
                st.queued -= 1;
                st.outstanding[d.tag as usize] -= 1;
                st.incomplete.retain(|c| c.id != d.id);
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
                st.out_mbox[which as usize].push_back((value, at));
                self.wake_if(PPE, at, |w| match *w {
                    Wait::OutMbox(k, b) => (k, b) == (spe, which),
                    Wait::AnyOutMbox(mask) => which == OutBox::Out && mask >> spe & 1 == 1,
                    _ => false,
                });
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

/// The 128-byte lines that `size` bytes at `ea` write only part of.
pub(crate) fn partial_lines(ea: u64, size: u32) -> impl Iterator<Item = u64> {
    let end = ea + size as u64;
    let (first, last) = (ea / 128, (end.max(ea + 1) - 1) / 128);
    (first..=last).filter(move |&l| ea > l * 128 || end < (l + 1) * 128)
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
