//! An emulated Cell Broadband Engine: a PPE and 1–16 SPEs (6 on a PS3),
//! each SPE with a 256 KiB local store that reaches main memory only by DMA.
//!
//! It models what a BIH build feels of the hardware and nothing more (no
//! SPU instruction set): main memory ([`memory`]), local stores
//! ([`local_store`]), the MFC's DMA rules and timing ([`mfc`]), mailboxes,
//! signals and the atomic unit ([`Spe`], [`Ppe`]), and virtual time
//! ([`clock`], [`cost`]). Programs are `async` blocks written against
//! [`Spe`] and [`Ppe`] the way SPE C code is written against spu_mfcio.h;
//! `machine` holds the cores' state and the event queue, and `executor` the
//! discrete-event loop that runs the programs in virtual-time order,
//! deterministically. Counters and a Chrome-trace
//! timeline come from [`trace`].
//!
//! This module imports nothing from trees, scenes or strategies.
//!
//! ```
//! use cellbih_cell::{Cell, CellConfig, Ea, WaitMode};
//!
//! // Six SPEs sum 6 × 64 KiB of u32 in main memory with double-buffered
//! // 16 KiB gets, and put their partial sums back.
//! let mut cell = Cell::new(CellConfig::ps3()).unwrap();
//! let n = 6 * 16384usize;
//! let data: Vec<u32> = (0..n as u32).collect();
//! let input = cell.memory_mut().alloc_pod("input", &data, 128).unwrap();
//! let sums = cell.memory_mut().alloc("sums", 6 * 16, 128).unwrap();
//! for id in 0..6 {
//!     cell.spawn_spe(id, move |spe| async move {
//!         let chunk = 16384u32; // bytes per get
//!         let bufs = [spe.ls_alloc(chunk, 128)?, spe.ls_alloc(chunk, 128)?];
//!         let out = spe.ls_alloc(16, 16)?;
//!         let base = input.offset(id as u64 * 65536);
//!         let mut sum = 0u64;
//!         spe.get(bufs[0], base, chunk, 0).await?;
//!         for i in 0..4u32 {
//!             let b = (i % 2) as usize;
//!             if i + 1 < 4 {
//!                 spe.get(bufs[1 - b], base.offset((i as u64 + 1) * chunk as u64), chunk, 1 - b as u32).await?;
//!             }
//!             spe.wait_tags(1 << b, WaitMode::All).await?;
//!             sum += spe.with_ls(bufs[b], 4096, |v: &[u32]| v.iter().map(|&x| x as u64).sum::<u64>())?;
//!         }
//!         spe.ls_write(out, &[sum, 0u64])?;
//!         spe.put(out, sums.offset(id as u64 * 16), 16, 2).await?;
//!         spe.wait_tags(1 << 2, WaitMode::All).await?;
//!         Ok(())
//!     });
//! }
//! let report = cell.run().unwrap();
//! let parts: Vec<u64> = cell.memory().read_pod(sums, 12).unwrap();
//! let total: u64 = parts.iter().step_by(2).sum();
//! assert_eq!(total, (n as u64 - 1) * n as u64 / 2);
//! assert!(report.cycles.0 > 0);
//! ```

pub mod clock;
pub mod cost;
mod dma;
mod executor;
pub mod local_store;
pub(crate) mod machine;
mod memif;
pub mod memory;
pub mod mfc;
mod ppe;
pub mod ppe_cache;
mod side;
mod spe;
pub mod trace;

use std::cell::{Ref, RefCell, RefMut};
use std::future::Future;
use std::rc::Rc;

use thiserror::Error;

pub use clock::Cycles;
pub use cost::{Bandwidth, CostModel, LockLines, MAX_RATE_CYCLES, parse_cycles, parse_gb_per_s};
pub use local_store::LsAddr;
pub use memory::{Allocation, Ea, Label, MainMemory};
pub use mfc::{ListElement, MAX_LIST_ELEMENTS, MAX_TRANSFER, Order, Segment, WaitMode};
pub use ppe::Ppe;
pub use side::Side;
pub use spe::{Reservation, Spe};
pub use trace::{CoreCounters, Trace};

use machine::{Machine, Task};

/// How a signal-notification register combines a new value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum SignalMode {
    /// One-to-one: the new value replaces the old.
    Overwrite,
    /// Many-to-one: the new bits are ORed in.
    Or,
}

/// The machine's shape and rates.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CellConfig {
    /// SPEs available (a PS3 program has 6).
    pub spes: usize,
    pub local_store_bytes: u32,
    /// Local store kept for the program's code and stack.
    pub ls_reserved_bytes: u32,
    pub main_memory_bytes: u64,
    pub cost: CostModel,
    /// Report reads of local-store bytes whose get was not waited for, and
    /// writes over bytes an unfinished get or put uses.
    pub checked: bool,
    /// Keep the timeline for a Chrome trace.
    pub trace: bool,
    pub signal_modes: [SignalMode; 2],
    /// The SPE programs stay resident between runs (a frame loop's
    /// programs, started once): a run charges no start-up
    /// ([`CostModel::spe_start_cycles`]).
    pub resident: bool,
}

impl CellConfig {
    /// The PlayStation 3: 6 SPEs, 256 KiB local stores (32 KiB kept for
    /// code and stack), 256 MiB of main memory, checked mode on.
    pub fn ps3() -> Self {
        CellConfig {
            spes: 6,
            local_store_bytes: 256 * 1024,
            ls_reserved_bytes: 32 * 1024,
            main_memory_bytes: 256 * 1024 * 1024,
            cost: CostModel::ps3(),
            checked: true,
            trace: false,
            signal_modes: [SignalMode::Overwrite, SignalMode::Or],
            resident: false,
        }
    }

    pub fn with_spes(mut self, spes: usize) -> Self {
        self.spes = spes;
        self
    }
}

/// Everything that can go wrong on the machine. Each names the core, the
/// command and the addresses involved.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CellError {
    #[error("SPE {spe}: {cmd} ls {:#x} {ea} size {size}: {why}", ls.0)]
    Dma {
        spe: usize,
        cmd: &'static str,
        ls: LsAddr,
        ea: Ea,
        size: u32,
        why: String,
    },
    #[error(
        "SPE {spe}: local store full: asked {asked} bytes aligned to {align}, {in_use} of {capacity} in use ({reserved} reserved for code and stack)"
    )]
    LocalStoreFull {
        spe: usize,
        asked: u32,
        align: u32,
        in_use: u32,
        reserved: u32,
        capacity: u32,
    },
    #[error("SPE {spe}: {addr} + {len} bytes runs past the {size}-byte local store")]
    LocalStoreRange {
        spe: usize,
        addr: LsAddr,
        len: u64,
        size: u32,
    },
    #[error("SPE {spe}: {addr} is not aligned to {align} bytes for this type")]
    LsAlign {
        spe: usize,
        addr: LsAddr,
        align: usize,
    },
    #[error("SPE {spe}: {what}")]
    Race { spe: usize, what: String },
    #[error(
        "main memory: {len} bytes at {ea} are outside what was allocated (up to {allocated_end})"
    )]
    BadAddress { ea: Ea, len: u64, allocated_end: Ea },
    #[error(
        "main memory full: {what} asked {asked} bytes, {in_use} of {capacity} in use (largest so far: {largest})"
    )]
    OutOfMemory {
        /// The buffer that asked.
        what: String,
        asked: u64,
        in_use: u64,
        capacity: u64,
        /// The largest allocations so far, by name and size.
        largest: String,
    },
    #[error("deadlock at cycle {}: every core is blocked: {}", at.0, waits.join("; "))]
    Deadlock { at: Cycles, waits: Vec<String> },
    #[error("{core}: {msg}")]
    Program { core: String, msg: String },
    #[error("{0}")]
    Config(String),
    #[error(
        "simulated time passed 2^64 cycles (about 182 years at 3.2 GHz) on {core}: \
         a rate is too large for this run"
    )]
    TimeOverflow { core: String },
}

/// Where one run's time went.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RunReport {
    /// From the start of the run to the last core's (or transfer's) end.
    pub cycles: Cycles,
    pub ms: f64,
    /// PPE first, then SPE 0, 1, ….
    pub cores: Vec<(String, CoreCounters)>,
    /// Every allocation of main memory, in order.
    pub memory: Vec<Allocation>,
    /// Main memory in use at the end (allocations and their padding).
    pub memory_bytes: u64,
    /// Whether the run was timed (the functional mode charges nothing:
    /// its cycles and ms mean nothing).
    pub timed: bool,
    /// The memory interface's bandwidth while cores share it: the least
    /// time a run's bytes need there.
    pub memory_shared: Bandwidth,
}

/// The machine: memory, cores, and the programs spawned on them.
pub struct Cell {
    m: Rc<RefCell<Machine>>,
    /// Programs spawned for the next run, by core.
    tasks: Vec<(usize, Task)>,
    /// Programs part-run by [`Cell::run_side`], by core, and the cycle the
    /// first of those runs started at.
    running: Vec<Option<Task>>,
    since: Option<Cycles>,
}

impl Cell {
    pub fn new(cfg: CellConfig) -> Result<Self, CellError> {
        if !(1..=16).contains(&cfg.spes) {
            return Err(CellError::Config(format!(
                "{} SPEs: the model takes 1 to 16",
                cfg.spes
            )));
        }
        if !cfg.local_store_bytes.is_multiple_of(128)
            || cfg.ls_reserved_bytes >= cfg.local_store_bytes
        {
            return Err(CellError::Config(
                "the local store must be a multiple of 128 bytes, larger than its reserved part"
                    .into(),
            ));
        }
        Ok(Cell {
            running: (0..=cfg.spes).map(|_| None).collect(),
            since: None,
            m: Rc::new(RefCell::new(Machine::new(cfg))),
            tasks: Vec::new(),
        })
    }

    pub fn config(&self) -> CellConfig {
        self.m.borrow().cfg.clone()
    }

    /// Main memory, for setting up inputs before a run and reading results
    /// after it (the host side, outside simulated time).
    pub fn memory(&self) -> Ref<'_, MainMemory> {
        Ref::map(self.m.borrow(), |m| &m.mem)
    }

    pub fn memory_mut(&self) -> RefMut<'_, MainMemory> {
        RefMut::map(self.m.borrow_mut(), |m| &mut m.mem)
    }

    /// Sets the PPE's program for the next run; what it returns is in the
    /// [`Exit`] once it has ended.
    pub fn spawn_ppe<F, Fut, T>(&mut self, program: F) -> Exit<T>
    where
        F: FnOnce(Ppe) -> Fut,
        Fut: Future<Output = Result<T, CellError>> + 'static,
        T: 'static,
    {
        let (exit, fut) = Exit::wrap(program(Ppe { m: self.m.clone() }));
        self.tasks.retain(|(c, _)| *c != machine::PPE);
        self.tasks.push((machine::PPE, Box::pin(fut)));
        exit
    }

    /// Sets SPE `spe`'s program for the next run; what it returns is in
    /// the [`Exit`] once it has ended (as libspe2's `spe_context_run`
    /// returns the program's stop code).
    pub fn spawn_spe<F, Fut, T>(&mut self, spe: usize, program: F) -> Exit<T>
    where
        F: FnOnce(Spe) -> Fut,
        Fut: Future<Output = Result<T, CellError>> + 'static,
        T: 'static,
    {
        assert!(spe < self.m.borrow().spes.len(), "there is no SPE {spe}");
        let (exit, fut) = Exit::wrap(program(Spe {
            m: self.m.clone(),
            id: spe,
        }));
        self.tasks.retain(|(c, _)| *c != spe + 1);
        self.tasks.push((spe + 1, Box::pin(fut)));
        exit
    }

    /// Runs the spawned programs to completion. All clocks start together
    /// at the latest clock of any earlier run.
    pub fn run(&mut self) -> Result<RunReport, CellError> {
        if self.since.is_some() {
            return Err(CellError::Config(
                "programs are part-run (run_side): end them with Cell::finish".into(),
            ));
        }
        let start = self.align();
        let tasks = std::mem::take(&mut self.tasks);
        self.start_programs(start, &tasks);
        let mut slots: Vec<Option<Task>> = (0..self.running.len()).map(|_| None).collect();
        for (core, task) in tasks {
            slots[core] = Some(task);
        }
        let end = executor::execute(&self.m, &mut slots, |_, _| false)?;
        let cores = slots.len();
        self.m.borrow_mut().settle(0..cores, end);
        Ok(self.report(start, end))
    }

    /// Every core's clock brought to the latest, counters cleared: where a
    /// run starts.
    fn align(&mut self) -> Cycles {
        let mut m = self.m.borrow_mut();
        let start = m.cores.iter().map(|c| c.clock).max().unwrap_or_default();
        for c in &mut m.cores {
            c.clock = start;
            c.counters = CoreCounters::default();
        }
        start
    }

    fn report(&self, start: Cycles, end: Cycles) -> RunReport {
        let m = self.m.borrow();
        let cycles = end.saturating_sub(start);
        RunReport {
            timed: m.cfg.cost.charge_compute,
            cycles,
            ms: cycles.ms(m.cfg.cost.clock_hz),
            cores: m
                .cores
                .iter()
                .enumerate()
                .map(|(i, c)| (machine::core_name(i), c.counters.clone()))
                .collect(),
            memory: m.mem.allocations().to_vec(),
            memory_bytes: m.mem.in_use(),
            memory_shared: m.cfg.cost.memory_shared_bandwidth,
        }
    }

    /// The timeline (if the config asked for it), taken out of the machine:
    /// write it with [`Trace::write_chrome`].
    pub fn take_trace(&self) -> Option<Trace> {
        let mut m = self.m.borrow_mut();
        let fresh = m.trace.as_ref().map(|t| Trace::new(t.spes, t.hz));
        std::mem::replace(&mut m.trace, fresh)
    }
}

/// What a program returned, once it has ended: the handle
impl Cell {
    /// The PPE starts the run's SPE programs one after another, in SPE
    /// order, each in [`CostModel::spe_start_cycles`]; an SPE's program
    /// begins when its start is through, the PPE's own once all are.
    /// Nothing is charged for programs that stay resident
    /// ([`CellConfig::resident`]).
    fn start_programs(&mut self, start: Cycles, tasks: &[(usize, Task)]) {
        let mut m = self.m.borrow_mut();
        let each = m.cfg.cost.spe_start_cycles;
        if each == Cycles::ZERO || m.cfg.resident {
            return;
        }
        let mut spes: Vec<usize> = tasks
            .iter()
            .map(|t| t.0)
            .filter(|&c| c != machine::PPE)
            .collect();
        if spes.is_empty() {
            return;
        }
        spes.sort_unstable();
        for (k, &core) in spes.iter().enumerate() {
            let wait = Cycles(each.0 * (k as u64 + 1));
            m.cores[core].clock = start + wait;
            m.cores[core].counters.start = wait;
        }
        let all = Cycles(each.0 * spes.len() as u64);
        m.cores[machine::PPE].clock = start + all;
        m.cores[machine::PPE].counters.start = all;
        m.span(machine::PPE, trace::SpanKind::Compute, start, start + all);
    }
}

/// [`Cell::spawn_ppe`] and [`Cell::spawn_spe`] give back.
pub struct Exit<T>(Rc<RefCell<Option<T>>>);

impl<T: 'static> Exit<T> {
    /// The program `fut`, storing what it returns, and the handle to it.
    fn wrap(
        fut: impl Future<Output = Result<T, CellError>> + 'static,
    ) -> (Self, impl Future<Output = Result<(), CellError>> + 'static) {
        let slot = Rc::new(RefCell::new(None));
        let fill = slot.clone();
        let fut = async move {
            let value = fut.await?;
            *fill.borrow_mut() = Some(value);
            Ok(())
        };
        (Exit(slot), fut)
    }

    /// What the program returned; an error naming `who` if it has not
    /// ended (it was never run, or the run failed first).
    pub fn take(&self, who: &str) -> Result<T, CellError> {
        self.0
            .borrow_mut()
            .take()
            .ok_or_else(|| CellError::Program {
                core: who.to_string(),
                msg: "the program has not ended: nothing to read back".into(),
            })
    }
}
