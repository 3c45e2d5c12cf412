//! The cost model: every rate the emulator charges, in one table, each with
//! its source or calibration (`docs/cost-model.md` sets them beside the
//! published measurements). The machine charges its own operations — DMA,
//! mailboxes, signals, the atomic unit, PPE memory access — from these
//! rates the moment a program calls them; programs charge only their
//! compute, through [`Spe::compute`](super::Spe::compute) with cycles they
//! take from their own named kernel rates, which live with the programs,
//! not here.

use super::clock::Cycles;

/// Bandwidth as bytes per 10^12 cycles, so that all timing is integer
/// arithmetic and the same on every host. The grid is fine enough that
/// every bandwidth of six significant digits from [`Bandwidth::MIN_GB_PER_S`]
/// to [`Bandwidth::MAX_GB_PER_S`] at 3.2 GHz lies on it exactly (0.001 GB/s
/// is 312,500,000 of these units; a last digit at that scale, 3,125).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Bandwidth {
    pub bytes_per_tcycle: u64,
}

/// Cycles in the bandwidth grid's unit (10^12).
const TCYCLE: u128 = 1_000_000_000_000;

impl Bandwidth {
    /// The least bandwidth a rate may be set to (`--rate`), in GB/s.
    pub const MIN_GB_PER_S: f64 = 0.001;
    /// The greatest, in GB/s.
    pub const MAX_GB_PER_S: f64 = 10_000.0;

    /// `gb_per_s` (10^9 bytes per second) at a clock of `hz`.
    pub fn from_gb_per_s(gb_per_s: f64, hz: f64) -> Self {
        Bandwidth {
            bytes_per_tcycle: (gb_per_s * 1e9 / hz * 1e12).round() as u64,
        }
    }

    /// Whether the bandwidth is infinite (`bytes_per_tcycle == 0`, the
    /// functional mode's "free").
    pub fn is_free(self) -> bool {
        self.bytes_per_tcycle == 0
    }

    /// Cycles to move `bytes`, rounded up; 0 for an infinite bandwidth.
    /// Saturates at `u64::MAX` cycles (the machine reports that as an
    /// overflow of simulated time).
    pub fn cycles(self, bytes: u64) -> Cycles {
        if self.is_free() {
            return Cycles::ZERO;
        }
        let c = (bytes as u128 * TCYCLE).div_ceil(self.bytes_per_tcycle as u128);
        Cycles(u64::try_from(c).unwrap_or(u64::MAX))
    }

    /// Bytes a cycle.
    pub fn bytes_per_cycle(self) -> f64 {
        self.bytes_per_tcycle as f64 / TCYCLE as f64
    }

    pub fn gb_per_s(self, hz: f64) -> f64 {
        self.bytes_per_cycle() * hz / 1e9
    }

    /// The bandwidth as `--rate` spells it: GB/s at `hz`, the shortest
    /// decimal (of six significant digits or more) that gives it back.
    pub fn text(self, hz: f64) -> String {
        let g = self.gb_per_s(hz);
        let back = |t: &str| {
            t.parse()
                .is_ok_and(|x: f64| Self::from_gb_per_s(x, hz) == self)
        };
        (5..17)
            .map(|digits| {
                format!(
                    "{}",
                    format!("{g:.digits$e}").parse::<f64>().expect("a number")
                )
            })
            .find(|t| back(t))
            .unwrap_or_else(|| format!("{g}"))
    }
}

/// Every rate of the machine. Units are in the names: `_cycles` are core
/// cycles at [`CostModel::clock_hz`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CostModel {
    /// Core clock of PPE and SPEs: 3.2 GHz (CBE handbook).
    pub clock_hz: f64,
    /// SPU cycles to issue one MFC command (the channel writes of
    /// `mfc_get`): Kistler et al. 2006 measured "less than 4 ns", 12.8 cycles.
    pub dma_issue_cycles: Cycles,
    /// Cycles the MFC spends on each command before its data moves
    /// (calibrated: pipelined 1 KiB transfers reach 80% of peak, as
    /// Jiménez-González et al. 2007 report near-peak from 1024 B).
    pub mfc_command_cycles: Cycles,
    /// Extra MFC cycles per element of a DMA list (estimate, half a command).
    pub mfc_list_element_cycles: Cycles,
    /// Fixed latency from the end of a transfer's data phase to its
    /// completion: with issue, command and data of a 128-byte get this gives
    /// 316 cycles (98.8 ns), inside Kistler et al.'s "under 100 ns".
    pub dma_latency_cycles: Cycles,
    /// Peak bandwidth of one SPE's MFC: 25.6 GB/s (Kistler et al. 2006).
    pub spe_bandwidth: Bandwidth,
    /// One SPE-to-SPE transfer over the EIB (a get or put whose effective
    /// address is another SPE's local store): 25.6 GB/s, one SPE link
    /// (Kistler et al. 2006 measured SPE-to-SPE transfers at the link's
    /// 25.6 GB/s and about 200 GB/s for all SPEs together, so transfers
    /// between different pairs are modelled as not contending).
    pub eib_bandwidth: Bandwidth,
    /// The memory interface shared by every core: XDR, 25.6 GB/s peak
    /// (CBE handbook); transfers of all SPEs queue on it in issue order.
    pub memory_bandwidth: Bandwidth,
    /// One SPU channel instruction (read a mailbox, a tag status, a
    /// signal): an estimate of a few cycles.
    pub channel_cycles: Cycles,
    /// From a mailbox write to the value being readable on the other side
    /// (an MMIO transaction over the EIB): estimated as one 128-byte
    /// transfer's latency; unsourced, see docs/cost-model.md.
    pub mailbox_latency_cycles: Cycles,
    /// Cycles the PPE spends on one MMIO access (mailbox or signal).
    pub ppe_mmio_cycles: Cycles,
    /// From a signal send to the value in the target's register (same
    /// estimate as mailboxes: the SDK guide says one-to-one signals and
    /// mailboxes perform alike).
    pub signal_latency_cycles: Cycles,
    /// getllar of a line not in this SPE's atomic cache: the line is
    /// brought from main memory or another core's atomic cache. Estimate:
    /// costed as a 128-byte DMA get (Kistler et al.'s cache-line figure).
    /// With the legacy model's exclusive lock lines, a putlluc of a line
    /// another core holds moves it at the same cost.
    pub getllar_cycles: Cycles,
    /// An atomic command on a line already in this SPE's atomic cache, or
    /// a putllc that fails because the reservation is known lost. Estimate:
    /// IBM's patent application US 2009/0077322 describes a getllar hit as
    /// a data-only transfer through the bus node (no command or snoop
    /// phase): costed as half a 128-byte DMA's latency.
    pub atomic_hit_cycles: Cycles,
    /// One wake-up of a PPE thread waiting in libspe2's event handler for
    /// any of several SPEs' mailboxes (`spe_event_wait`, an epoll system
    /// call): estimate, about 1 µs.
    pub ppe_event_cycles: Cycles,
    /// One allocation of main memory by the PPE program (a `malloc` of a
    /// block from the heap): estimate.
    pub ppe_alloc_cycles: Cycles,
    /// The PPE's own atomic update (lwarx/stwcx. on a line): estimate.
    pub ppe_atomic_cycles: Cycles,
    /// A PPE load or store whose line neither cache holds
    /// ([`crate::ppe_cache`]): the L2's lookup (36 cycles, a chained L2
    /// hit timed on a PS3) and the line's round trip through the memory
    /// interface as a get sees it without the SPU's issue and the MFC's
    /// command (`dma_latency_cycles` and 128 bytes at `memory_bandwidth`:
    /// 256 + 16), 308 cycles (96 ns). No PPE miss to XDR timed on a PS3
    /// was found: an estimate, half to twice.
    pub ppe_memory_cycles: Cycles,
    /// The PPE's bandwidth to main memory through its caches, for the
    /// bytes a PPE program reads or writes explicitly.
    pub ppe_memory_bandwidth: Bandwidth,
    /// Whether the programs' compute is charged: their kernel rates are
    /// their own (the library's `kernels::rates`, and beside each strategy);
    /// the functional mode charges none.
    pub charge_compute: bool,
    /// The memory interface's sustained bandwidth while transfers of more
    /// than one core share it; a lone stream still reaches
    /// `memory_bandwidth`. Set from 6 SPEs streaming 16 KiB gets, 2 or 8
    /// in flight: 22.83 GB/s (cellmark §4.1, §2.3.2); the puts and the
    /// smaller gets are held out (`validate`). What takes the rest of the
    /// peak: DRAM refresh, bank conflicts between independent streams and
    /// the controller's read/write turnarounds (cellmark §4.2).
    /// `ps3_legacy()` keeps the peak here.
    pub memory_shared_bandwidth: Bandwidth,
    /// A transfer to or from main memory moves whole 128-byte lines on
    /// the interface: each element's lines, however few of their bytes it
    /// needs (the bus and the memory controller work in 128-byte lines;
    /// CBE handbook, "DMA transfers": best at 128-byte alignment). Off
    /// (`ps3_legacy()`): its own bytes.
    pub memory_whole_lines: bool,
    /// The EIB's sustained capacity for concurrent transfers between local
    /// stores: 3 disjoint pairs reading each other move 114.73 GB/s
    /// together (cellmark §3.1; its PMU shows all four rings 66–77 % busy:
    /// arbitration, not ring imbalance). `None` (`ps3_legacy()`): unlimited.
    pub eib_total_bandwidth: Option<Bandwidth>,
    /// One direction of a local store's port to the EIB, shared by every
    /// transfer between local stores that reads (out) or writes (in) it:
    /// one reader already saturates it at 23.58 GB/s and five readers
    /// share 23.71 (cellmark §3.2–3.3; one pair over all 30: 22.97–23.60,
    /// §3.4). `None` (`ps3_legacy()`): a transfer goes at its link's rate.
    pub ls_port_bandwidth: Option<Bandwidth>,
    /// A put completes when its write is acknowledged: this many cycles
    /// after the latency a get sees (an address-only bus transaction,
    /// costed like `atomic_hit_cycles`: half a 128-byte DMA's latency).
    /// SpuTest's 6 SPEs putting 32 bytes and waiting see 152 ns per put
    /// (`task_put.c`), against about 103 ns without it. 0 (`ps3_legacy()`): a put
    /// completes like a get.
    pub put_ack_cycles: Cycles,
    /// How the atomic caches hold lock lines.
    pub lock_lines: LockLines,
    /// Lines one SPE's atomic cache holds: 4 (512 bytes; Calver 2007,
    /// "Atomic cache unit", from programming the PS3). An atomic command on
    /// a fifth line evicts the least recently used one, and with it any
    /// reservation on it, so a getllar cycling over 5 lines always misses.
    /// `None` (`ps3_legacy()`): unlimited.
    pub atomic_cache_lines: Option<usize>,
    /// A DMA put that writes part of a 128-byte line of main memory claims
    /// the line first, like a putlluc (`LockLines::Shared`'s
    /// `claim_cycles`, one claim after another on a line), unless its SPE
    /// already holds it; a put of whole lines claims nothing. Measured:
    /// six SPEs putting 32 bytes into one line take 66.4 ns a put together
    /// (SpuTest `task_put.c` before 2024: 6 × 10 M puts in 3984 ms), as
    /// their putllucs do (64.2 ns); into their own lines, 152 ns a put and
    /// its wait, each. Off (`ps3_legacy()`): puts claim nothing.
    pub partial_puts_claim: bool,
    /// The EIB's sustained capacity for concurrent transfers between local
    /// stores when the machine has more than 6 SPEs (a Cell blade; a PS3
    /// program gets 6): "almost 200 GB/s" over 8 SPEs in collective
    /// patterns (Kistler, Perrone & Petrini 2006). `None`:
    /// `eib_total_bandwidth` for any number of SPEs.
    pub eib_total_bandwidth_blade: Option<Bandwidth>,
    /// The PPE's cycles to start one SPE program and join it (create the
    /// context, upload the program, start it; wait for its end): a real
    /// PS3 starts, runs and joins a trivial SPU task every 2.61 µs (SpuTest
    /// `test_avalanche.c`: 1,048,576 SPURS tasks in 2740 ms on 6 SPUs).
    /// The PPE starts a run's programs one after another, each SPE's
    /// program beginning when its start is through; nothing is charged
    /// where programs stay resident between runs
    /// ([`CellConfig::resident`](super::CellConfig::resident)). 0
    /// (`ps3_legacy()`): programs start at once. Its uses: every program a
    /// run starts (a build's, the caster's) and each program switch of a
    /// frame in section 5's arrangement — a renderer starts its programs
    /// as tasks of a SPURS instance it keeps. Band: up to 80 µs a program
    /// ([`CostModel::SPE_START_GROUP`]), each started as an SPU thread
    /// group through the OS.
    pub spe_start_cycles: Cycles,
    /// Extra cycles per PPE–SPE mailbox hand-off when the programs reach
    /// the mailboxes through the operating system, not by raw MMIO: the
    /// PS3 kernel's thread-mode SPUs take 5.8 µs one way, 11.6 µs a round
    /// trip (cellmark §3.6: a system call on each side and the event
    /// queue's scheduling), where the raw path is under 1 µs. 0: raw
    /// hardware (the default: the paper's builders ran under Linux with
    /// libspe2, whose problem-state mailbox access is raw MMIO).
    pub mailbox_os_cycles: Cycles,
    /// Whether the mailboxes are reached through the PS3 kernel
    /// ([`CostModel::with_ps3_kernel_mailboxes`], `--mailboxes
    /// ps3-kernel`), whatever `mailbox_os_cycles` is set to: a name the
    /// settings report, not a rate.
    pub os_mailboxes: bool,
}

/// How the atomic caches hold lock lines (getllar, putllc, putlluc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum LockLines {
    /// Every atomic command takes the line exclusively, one after another
    /// (`ps3_legacy()`: the model before the validated one; a
    /// holder's putllc pays the miss cost).
    Exclusive,
    /// As the atomic caches share them: a getllar is a read several SPEs
    /// hold at once, but a line is sent to one atomic cache at a time (a
    /// miss costs `getllar_cycles` after any claim or other miss on the line
    /// under way, and a claim waits for misses in progress: many SPEs
    /// polling a line that one writes fetch it one after another; SpuTest's
    /// ring of the PPE and 6 SPEs handing one lock line on takes 420 ns a
    /// hand-off, `task_spuspinlock.c`); a putllc or
    /// putlluc by the only holder costs `atomic_hit_cycles`; otherwise it
    /// claims the line — the others' copies and reservations are lost —
    /// in `claim_cycles`, claims one after another. Measured: 6 SPEs
    /// storing one line by putlluc take 64.2 ns a store together, 385 ns
    /// each (SpuTest `task_putlluc.c`): 205 cycles a claim.
    Shared { claim_cycles: Cycles },
}

impl CostModel {
    /// The PlayStation 3, with the sources above: the model held against
    /// measurements of real PS3s with several SPEs (`docs/validation.md`:
    /// `validate` holds it to every figure). The default of every command.
    pub fn ps3() -> Self {
        let hz = 3.2e9;
        CostModel {
            // The 22.83 GB/s measured, to the byte per 1,000 cycles (the
            // grid the model's figures were generated on).
            memory_shared_bandwidth: Bandwidth::from_gb_per_s(22.8288, hz),
            memory_whole_lines: true,
            // The 114.73 GB/s measured, on the same grid.
            eib_total_bandwidth: Some(Bandwidth::from_gb_per_s(114.7296, hz)),
            ls_port_bandwidth: Some(Bandwidth::from_gb_per_s(23.6, hz)),
            put_ack_cycles: Cycles(128),
            lock_lines: LockLines::Shared {
                claim_cycles: Cycles(205),
            },
            atomic_cache_lines: Some(4),
            partial_puts_claim: true,
            eib_total_bandwidth_blade: Some(Bandwidth::from_gb_per_s(200.0, hz)),
            // 2.61 µs at 3.2 GHz.
            spe_start_cycles: Cycles(8362),
            ..CostModel::ps3_legacy()
        }
    }

    /// The PS3 model before the validated one (`--model legacy`): the
    /// memory interface at its peak for any number of SPEs, transfers
    /// between local stores unlimited by ports or the EIB, exclusive lock
    /// lines, puts without a write acknowledgement (`--model legacy`;
    /// `docs/validation.md` says which figures it fails).
    pub fn ps3_legacy() -> Self {
        let hz = 3.2e9;
        CostModel {
            clock_hz: hz,
            dma_issue_cycles: Cycles(12),
            mfc_command_cycles: Cycles(32),
            mfc_list_element_cycles: Cycles(16),
            dma_latency_cycles: Cycles(256),
            spe_bandwidth: Bandwidth::from_gb_per_s(25.6, hz),
            memory_bandwidth: Bandwidth::from_gb_per_s(25.6, hz),
            eib_bandwidth: Bandwidth::from_gb_per_s(25.6, hz),
            channel_cycles: Cycles(6),
            mailbox_latency_cycles: Cycles(316),
            ppe_mmio_cycles: Cycles(100),
            signal_latency_cycles: Cycles(316),
            getllar_cycles: Cycles(316),
            atomic_hit_cycles: Cycles(128),
            ppe_event_cycles: Cycles(3200),
            ppe_alloc_cycles: Cycles(300),
            ppe_atomic_cycles: Cycles(100),
            ppe_memory_cycles: Cycles(308),
            ppe_memory_bandwidth: Bandwidth::from_gb_per_s(6.4, hz),
            charge_compute: true,
            memory_shared_bandwidth: Bandwidth::from_gb_per_s(25.6, hz),
            memory_whole_lines: false,
            eib_total_bandwidth: None,
            ls_port_bandwidth: None,
            put_ack_cycles: Cycles::ZERO,
            lock_lines: LockLines::Exclusive,
            mailbox_os_cycles: Cycles::ZERO,
            os_mailboxes: false,
            atomic_cache_lines: None,
            partial_puts_claim: false,
            eib_total_bandwidth_blade: None,
            spe_start_cycles: Cycles::ZERO,
        }
    }

    /// [`CostModel::ps3`] with the mailboxes reached through the
    /// PS3 kernel (thread-mode SPUs, an event queue): 11.6 µs a round
    /// trip (cellmark §3.6).
    pub fn with_ps3_kernel_mailboxes(self) -> Self {
        // 5.8 µs one way, less the raw path's hand-off.
        let one_way = (5.8e-6 * self.clock_hz) as u64;
        CostModel {
            mailbox_os_cycles: Cycles(one_way - self.mailbox_latency_cycles.0),
            os_mailboxes: true,
            ..self
        }
    }

    /// The EIB's capacity for a machine of `spes` SPEs.
    pub fn eib_capacity(&self, spes: usize) -> Option<Bandwidth> {
        match self.eib_total_bandwidth_blade {
            Some(blade) if spes > 6 => Some(blade),
            _ => self.eib_total_bandwidth,
        }
    }

    /// The machine's rates that are estimates (no published measurement
    /// pins them), by name: what the sensitivity report moves, from half to
    /// twice their value.
    pub const ESTIMATES: &'static [Estimate] = estimates!(
        mfc_list_element_cycles,
        channel_cycles,
        mailbox_latency_cycles,
        ppe_mmio_cycles,
        signal_latency_cycles,
        getllar_cycles,
        atomic_hit_cycles,
        ppe_event_cycles,
        ppe_alloc_cycles,
        ppe_atomic_cycles,
        ppe_memory_cycles,
        put_ack_cycles,
    );

    /// This model with the estimate `name` ([`CostModel::ESTIMATES`]) at
    /// `value` cycles; `None` for a name that is not one.
    pub fn with_estimate(&self, name: &str, value: Cycles) -> Option<CostModel> {
        let e = Self::ESTIMATES.iter().find(|e| e.name == name)?;
        let mut c = self.clone();
        *(e.at)(&mut c) = value;
        Some(c)
    }

    /// The value of the estimate `name`.
    pub fn estimate(&self, name: &str) -> Option<Cycles> {
        let e = Self::ESTIMATES.iter().find(|e| e.name == name)?;
        Some(*(e.at)(&mut self.clone()))
    }

    /// The functional mode: every machine operation is free, so a run
    /// checks correctness (DMA rules, synchronization, deadlocks) as fast
    /// as the host allows, and its cycle counts mean nothing.
    pub fn functional() -> Self {
        let free = Bandwidth {
            bytes_per_tcycle: 0,
        };
        CostModel {
            clock_hz: 3.2e9,
            dma_issue_cycles: Cycles::ZERO,
            mfc_command_cycles: Cycles::ZERO,
            mfc_list_element_cycles: Cycles::ZERO,
            dma_latency_cycles: Cycles::ZERO,
            spe_bandwidth: free,
            memory_bandwidth: free,
            eib_bandwidth: free,
            channel_cycles: Cycles::ZERO,
            mailbox_latency_cycles: Cycles::ZERO,
            ppe_mmio_cycles: Cycles::ZERO,
            signal_latency_cycles: Cycles::ZERO,
            getllar_cycles: Cycles::ZERO,
            atomic_hit_cycles: Cycles::ZERO,
            ppe_event_cycles: Cycles::ZERO,
            ppe_alloc_cycles: Cycles::ZERO,
            ppe_atomic_cycles: Cycles::ZERO,
            ppe_memory_cycles: Cycles::ZERO,
            ppe_memory_bandwidth: free,
            charge_compute: false,
            memory_shared_bandwidth: free,
            // The legacy rules: nothing to charge.
            ..CostModel::ps3_legacy()
        }
    }
}

/// The machine rates only transfers between local stores (the EIB and the
/// local stores' ports) and the PPE's atomics charge: no build, cast or
/// update of the library makes either; `validate`'s kernels do.
pub const FABRIC_AND_PPE_ATOMICS: [&str; 5] = [
    "eib_bandwidth",
    "eib_total_bandwidth",
    "eib_total_bandwidth_blade",
    "ls_port_bandwidth",
    "ppe_atomic_cycles",
];

/// The most cycles any rate may be set to (`--rate`): 2^40, about 344 s
/// at 3.2 GHz for one operation or one item.
pub const MAX_RATE_CYCLES: u64 = 1 << 40;

/// A rate in cycles as `--rate` spells it: a whole number from 0 to
/// [`MAX_RATE_CYCLES`]; the error says what a value must be.
pub fn parse_cycles(value: &str) -> Result<Cycles, String> {
    match value.trim().parse::<u64>() {
        Ok(c) if c <= MAX_RATE_CYCLES => Ok(Cycles(c)),
        _ => Err(format!(
            "a whole number of cycles from 0 to {MAX_RATE_CYCLES} (2^40)"
        )),
    }
}

/// A bandwidth as `--rate` spells it, in GB/s: from
/// [`Bandwidth::MIN_GB_PER_S`] to [`Bandwidth::MAX_GB_PER_S`], a value the
/// model keeps as given (its grid's step is 3.2e-12 GB/s at 3.2 GHz: any
/// six significant digits); at a clock of `hz`. The error says what a
/// value must be.
pub fn parse_gb_per_s(value: &str, hz: f64) -> Result<Bandwidth, String> {
    let why = || {
        format!(
            "a bandwidth in GB/s from {} to {}, in steps of 3.2e-12 GB/s (any six \
             significant digits)",
            Bandwidth::MIN_GB_PER_S,
            Bandwidth::MAX_GB_PER_S
        )
    };
    let g: f64 = value.trim().parse().map_err(|_| why())?;
    if !(Bandwidth::MIN_GB_PER_S..=Bandwidth::MAX_GB_PER_S).contains(&g) {
        return Err(why());
    }
    // Kept exactly where the grid holds it: six significant digits always.
    let b = Bandwidth::from_gb_per_s(g, hz);
    match b.text(hz).parse::<f64>() == Ok(g) {
        true => Ok(b),
        false => Err(why()),
    }
}

/// Where a machine rate lives in the model, and its unit.
#[derive(Clone, Copy)]
pub enum Slot {
    /// Cycles.
    Cycles(fn(&mut CostModel) -> &mut Cycles),
    /// A bandwidth, set and shown in GB/s.
    Bandwidth(fn(&mut CostModel) -> &mut Bandwidth),
    /// A ceiling that may be absent (unlimited), set and shown in GB/s.
    Ceiling(fn(&mut CostModel) -> &mut Option<Bandwidth>),
    /// The shared lock lines' claim ([`LockLines::Shared`]), in cycles: a
    /// rate of the measured model only (the legacy model's lines are
    /// exclusive and claim nothing).
    Claim,
}

/// One of the machine's rates a user may set by name (`--rate`).
#[derive(Clone, Copy)]
pub struct MachineRate {
    pub name: &'static str,
    pub slot: Slot,
}

macro_rules! machine_rates {
    ($($kind:ident $field:ident),* ; $($extra:expr),* $(,)?) => {
        &[$(MachineRate {
            name: stringify!($field),
            slot: Slot::$kind(|c| &mut c.$field),
        },)* $($extra),*]
    };
}

impl CostModel {
    /// Every machine rate by name: cycles, or GB/s for a bandwidth.
    pub const RATES: &'static [MachineRate] = machine_rates!(
        Cycles dma_issue_cycles,
        Cycles mfc_command_cycles,
        Cycles mfc_list_element_cycles,
        Cycles dma_latency_cycles,
        Bandwidth spe_bandwidth,
        Bandwidth eib_bandwidth,
        Bandwidth memory_bandwidth,
        Cycles channel_cycles,
        Cycles mailbox_latency_cycles,
        Cycles ppe_mmio_cycles,
        Cycles signal_latency_cycles,
        Cycles getllar_cycles,
        Cycles atomic_hit_cycles,
        Cycles ppe_event_cycles,
        Cycles ppe_alloc_cycles,
        Cycles ppe_atomic_cycles,
        Cycles ppe_memory_cycles,
        Bandwidth ppe_memory_bandwidth,
        Bandwidth memory_shared_bandwidth,
        Ceiling eib_total_bandwidth,
        Ceiling ls_port_bandwidth,
        Cycles put_ack_cycles,
        Ceiling eib_total_bandwidth_blade,
        Cycles spe_start_cycles,
        Cycles mailbox_os_cycles;
        MachineRate { name: "claim_cycles", slot: Slot::Claim },
    );

    /// The machine rate `name` at `value` (cycles, or GB/s for a
    /// bandwidth); an error naming what is wrong where `value` is not one.
    /// `None` where no machine rate has that name.
    pub fn set_rate(&mut self, name: &str, value: &str) -> Option<Result<(), String>> {
        let rate = Self::RATES.iter().find(|r| r.name == name)?;
        let hz = self.clock_hz;
        let gb = |v: &str| parse_gb_per_s(v, hz).map_err(|why| format!("{name}={v}: {why}"));
        Some(match rate.slot {
            Slot::Cycles(at) => parse_cycles(value)
                .map(|c| *at(self) = c)
                .map_err(|why| format!("{name}={value}: {why}")),
            Slot::Bandwidth(at) => gb(value).map(|b| *at(self) = b),
            Slot::Ceiling(at) => match value.trim() {
                "unlimited" => {
                    *at(self) = None;
                    Ok(())
                }
                v => gb(v).map(|b| *at(self) = Some(b)),
            },
            Slot::Claim => match &mut self.lock_lines {
                LockLines::Shared { claim_cycles } => parse_cycles(value)
                    .map(|c| *claim_cycles = c)
                    .map_err(|why| format!("{name}={value}: {why}")),
                LockLines::Exclusive => Err(format!(
                    "{name}: the legacy model's lock lines are exclusive and claim nothing \
                     (--model measured claims them)"
                )),
            },
        })
    }

    /// The machine rate `name` as `--rate` spells it (cycles, or GB/s;
    /// `unlimited` for an absent ceiling).
    pub fn rate_text(&self, name: &str) -> Option<String> {
        let rate = Self::RATES.iter().find(|r| r.name == name)?;
        let mut c = self.clone();
        let gb = |b: Bandwidth| b.text(c.clock_hz);
        Some(match rate.slot {
            Slot::Cycles(at) => at(&mut c).0.to_string(),
            Slot::Bandwidth(at) => gb(*at(&mut c.clone())),
            Slot::Ceiling(at) => match *at(&mut c.clone()) {
                Some(b) => gb(b),
                None => "unlimited".into(),
            },
            Slot::Claim => match c.lock_lines {
                LockLines::Shared { claim_cycles } => claim_cycles.0.to_string(),
                LockLines::Exclusive => return None,
            },
        })
    }

    /// An SPE program started as an SPU thread group through the
    /// operating system, with its 256 KB local store copied in and out:
    /// 80 µs on a retail PS3 under GameOS (the `ripcord` project,
    /// `ports/ripcord-ps3/DECODE.md` §3: an empty one-SPE group 60 µs best
    /// of 10, worst 70; with the copies 80, worst 127). The high end of
    /// `spe_start_cycles`' band.
    pub const SPE_START_GROUP: Cycles = Cycles(256_000);

    /// The band a machine rate no measurement pins may lie in, as
    /// `--rate` spells its values, and why: an estimate from half to twice
    /// its value; the PPE's bandwidth for its own bytes between the L2
    /// reads cellmark's PPE page measured plain and with `dcbt` (2.75 and
    /// 8.4 GB/s). `None` for a measured or calibrated rate.
    pub fn band_text(&self, name: &str) -> Option<String> {
        if name == "ppe_memory_bandwidth" {
            return Some("2.75-8.4 (cellmark PPE)".into());
        }
        if name == "spe_start_cycles" {
            let (task, group) = (self.spe_start_cycles.0, Self::SPE_START_GROUP.0);
            return Some(format!("{task}-{group} (SPURS to OS group)"));
        }
        let v = self.estimate(name)?.0;
        Some(format!("{}-{} (estimate)", v / 2, v * 2))
    }

    /// The machine rates that differ between this model and `base`, by
    /// name, as `--rate` spells them.
    pub fn moved_from(&self, base: &CostModel) -> Vec<(&'static str, String)> {
        (Self::RATES.iter())
            .filter_map(|r| {
                let (mine, theirs) = (self.rate_text(r.name)?, base.rate_text(r.name)?);
                (mine != theirs).then_some((r.name, mine))
            })
            .collect()
    }
}

/// The table of estimates, each named by its field: a name written once.
macro_rules! estimates {
    ($($field:ident),* $(,)?) => {
        &[$(Estimate {
            name: stringify!($field),
            at: |c| &mut c.$field,
        }),*]
    };
}
use estimates;

/// One of the machine's estimates ([`CostModel::ESTIMATES`]): its name,
/// written once, and where it lives in the model.
pub struct Estimate {
    pub name: &'static str,
    pub at: fn(&mut CostModel) -> &mut Cycles,
}
