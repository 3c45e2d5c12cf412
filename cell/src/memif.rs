//! The memory interface (the MIC and its XDR channels) that the traffic of
//! every core shares: 25.6 GB/s on the PS3 (CBE handbook).
//!
//! The hardware moves data in 128-byte packets from many requesters,
//! interleaved; so a small transfer among large ones waits for a few
//! packets, not for whole commands. Modelled as the fluid limit of that
//! round robin — processor sharing with max-min fairness: at every moment
//! the active transfers ("flows") split the interface's bandwidth equally,
//! except that no flow goes faster than its own link (an SPE's MFC,
//! 25.6 GB/s; the PPE's path to memory), the surplus going to the others
//! (water-filling). A flow's share changes whenever a flow starts or ends.
//! Against packet-level round robin this differs by less than one packet
//! (16 cycles) per transfer.
//!
//! Arithmetic is integer, so time is the same on every host: a flow's
//! remaining data is kept in units of 1/(10^12 · [`SHARE_SCALE`]) byte and
//! rates in those units per cycle; `SHARE_SCALE` = lcm(1..=17), so an equal
//! share among up to 17 requesters (16 SPEs and the PPE) is exact. A lone
//! flow takes exactly `Bandwidth::cycles(bytes)` of its own link or of the
//! interface, whichever is slower — what the model charged before sharing.

use super::clock::Cycles;
use super::cost::Bandwidth;

/// lcm(1, 2, …, 17).
pub(crate) const SHARE_SCALE: u128 = 12_252_240;

/// A byte in the units flows are kept in: a bandwidth's grid (bytes per
/// 10^12 cycles) times [`SHARE_SCALE`].
const UNITS_A_BYTE: u128 = 1_000_000_000_000 * SHARE_SCALE;

/// What a flow moves through: the memory interface, the EIB, and each
/// SPE's local-store port (one direction each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Resource {
    Memory,
    Eib,
    /// Data leaving SPE `n`'s local store over the EIB.
    LsOut(usize),
    /// Data entering SPE `n`'s local store over the EIB.
    LsIn(usize),
}

/// One transfer on the fabric.
#[derive(Clone, Debug)]
pub(crate) struct Flow {
    pub id: u64,
    /// The core that moves it (the memory interface's sustained ceiling
    /// applies while flows of more than one core share it).
    core: usize,
    /// What it moves through.
    uses: Vec<Resource>,
    /// Data still to move, in 1/[`UNITS_A_BYTE`] byte.
    rem: u128,
    /// The flow's own link limit per cycle, same units (`u128::MAX`: none).
    link: u128,
    /// Current rate per cycle.
    rate: u128,
    /// When the flow started, and the cycles it would take alone.
    pub started: Cycles,
    pub alone: Cycles,
}

/// The shared interfaces: their bandwidths and the flows on them.
pub(crate) struct MemoryInterface {
    /// The memory interface per cycle in the units above, for one core's
    /// flows and for several cores' (its sustained multi-stream ceiling);
    /// 0 means free (functional).
    capacity: u128,
    shared_capacity: u128,
    /// The EIB's capacity for concurrent transfers, and one direction of a
    /// local store's port (`u128::MAX`: unlimited).
    eib: u128,
    ls_port: u128,
    /// Time up to which every flow's progress is accounted.
    now: Cycles,
    flows: Vec<Flow>,
    next_id: u64,
}

fn per_cycle(b: Bandwidth) -> u128 {
    if b.is_free() {
        u128::MAX
    } else {
        b.bytes_per_tcycle as u128 * SHARE_SCALE
    }
}

impl MemoryInterface {
    /// The memory interface at `bandwidth` (at `shared` while several
    /// cores' transfers share it), and the EIB and local-store ports at
    /// their limits (`None`: unlimited).
    pub fn new(
        bandwidth: Bandwidth,
        shared: Bandwidth,
        eib: Option<Bandwidth>,
        ls_port: Option<Bandwidth>,
    ) -> Self {
        let free = bandwidth.is_free();
        MemoryInterface {
            capacity: if free { 0 } else { per_cycle(bandwidth) },
            shared_capacity: if free { 0 } else { per_cycle(shared) },
            eib: eib.map_or(u128::MAX, per_cycle),
            ls_port: ls_port.map_or(u128::MAX, per_cycle),
            now: Cycles::ZERO,
            flows: Vec::new(),
            next_id: 0,
        }
    }

    /// Whether the interface costs nothing (the functional mode): flows
    /// then end the moment they start.
    pub fn is_free(&self) -> bool {
        self.capacity == 0
    }

    /// Starts a flow of `bytes` by `core` through the memory interface at
    /// `at` (not before the last event), limited by `link`; returns its id.
    pub fn start(&mut self, at: Cycles, core: usize, bytes: u64, link: Bandwidth) -> u64 {
        self.start_through(at, core, vec![Resource::Memory], bytes, link)
    }

    /// Starts a flow of `bytes` by `core` through `uses` at `at`, limited by
    /// `link`; returns its id.
    pub fn start_through(
        &mut self,
        at: Cycles,
        core: usize,
        uses: Vec<Resource>,
        bytes: u64,
        link: Bandwidth,
    ) -> u64 {
        debug_assert!(!self.is_free());
        self.advance(at);
        self.next_id += 1;
        let link = per_cycle(link);
        let alone_rate = (uses.iter()).fold(link, |r, &u| r.min(self.lone_capacity(u)));
        let alone = Cycles(
            (bytes as u128 * UNITS_A_BYTE)
                .div_ceil(alone_rate)
                .try_into()
                .expect("a transfer's time fits in 64 bits"),
        );
        self.flows.push(Flow {
            id: self.next_id,
            core,
            uses,
            rem: bytes as u128 * UNITS_A_BYTE,
            link,
            rate: 0,
            started: at,
            alone,
        });
        self.share();
        self.next_id
    }

    /// A resource's capacity for a flow alone on it.
    fn lone_capacity(&self, r: Resource) -> u128 {
        match r {
            Resource::Memory => self.capacity,
            Resource::Eib => self.eib,
            Resource::LsOut(_) | Resource::LsIn(_) => self.ls_port,
        }
    }

    /// When the next flow ends, if any is active.
    pub fn next_end(&self) -> Option<Cycles> {
        self.flows
            .iter()
            .map(|f| self.now + Cycles(u64::try_from(f.rem.div_ceil(f.rate)).unwrap_or(u64::MAX)))
            .min()
    }

    /// Advances to `at` (the time of [`next_end`](Self::next_end)) and
    /// returns the flows that end then, in the order they started.
    pub fn finish_due(&mut self, at: Cycles) -> Vec<Flow> {
        self.advance(at);
        let (done, active): (Vec<Flow>, Vec<Flow>) = self.flows.drain(..).partition(|f| f.rem == 0);
        self.flows = active;
        self.share();
        done
    }

    /// Moves every flow on by its rate up to `at`.
    fn advance(&mut self, at: Cycles) {
        debug_assert!(at >= self.now, "the interface never goes back in time");
        let dt = (at - self.now).0 as u128;
        for f in &mut self.flows {
            f.rem = f.rem.saturating_sub(f.rate.saturating_mul(dt));
        }
        self.now = at;
    }

    /// Max-min fair rates (progressive filling): one flow at a time, the
    /// one whose bound is least — the smaller of its link and, on each
    /// resource it uses, an equal part of what is left there — takes that
    /// bound (ties: the smaller link, then the earlier flow). With one
    /// resource this is: flows in order of their link each take the smaller
    /// of their link and an equal part of what is left.
    fn share(&mut self) {
        let memory_cores = {
            let mut cores: Vec<usize> = (self.flows.iter())
                .filter(|f| f.uses.contains(&Resource::Memory))
                .map(|f| f.core)
                .collect();
            cores.sort_unstable();
            cores.dedup();
            cores.len()
        };
        let mut left: Vec<(Resource, u128, u128)> = Vec::new();
        for f in &self.flows {
            for &u in &f.uses {
                match left.iter_mut().find(|(r, ..)| *r == u) {
                    Some(e) => e.2 += 1,
                    None => {
                        let cap = match u {
                            Resource::Memory if memory_cores > 1 => self.shared_capacity,
                            _ => self.lone_capacity(u),
                        };
                        left.push((u, cap, 1));
                    }
                }
            }
        }
        let mut open: Vec<usize> = (0..self.flows.len()).collect();
        while !open.is_empty() {
            let bound = |f: &Flow| {
                (f.uses.iter()).fold(f.link, |b, u| {
                    let (_, l, n) = left.iter().find(|(r, ..)| r == u).unwrap();
                    b.min(l / n)
                })
            };
            let (k, rate) = (open.iter().enumerate())
                .map(|(k, &i)| (k, bound(&self.flows[i])))
                .min_by_key(|&(k, b)| {
                    let f = &self.flows[open[k]];
                    (b, f.link, f.id)
                })
                .expect("an open flow");
            let i = open.swap_remove(k);
            for u in &self.flows[i].uses {
                let e = left.iter_mut().find(|(r, ..)| r == u).unwrap();
                e.1 = e.1.saturating_sub(rate);
                e.2 -= 1;
            }
            self.flows[i].rate = rate.max(1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gbps(g: f64) -> Bandwidth {
        Bandwidth::from_gb_per_s(g, 3.2e9)
    }

    #[test]
    fn a_lone_flow_takes_what_the_bandwidth_says() {
        let mut m = MemoryInterface::new(gbps(25.6), gbps(25.6), None, None);
        let id = m.start(Cycles(100), 1, 16384, gbps(25.6));
        // 16 KiB at 8 bytes a cycle.
        assert_eq!(m.next_end(), Some(Cycles(100 + 2048)));
        let done = m.finish_due(Cycles(2148));
        assert_eq!(done.len(), 1);
        assert_eq!((done[0].id, done[0].alone), (id, Cycles(2048)));
        assert_eq!(m.next_end(), None);
        // A slower link sets the pace: 6.4 GB/s is 2 bytes a cycle.
        m.start(Cycles(3000), 1, 100, gbps(6.4));
        assert_eq!(m.next_end(), Some(Cycles(3050)));
    }

    /// A 128-byte flow that joins seven 16 KiB flows gets an eighth of the
    /// interface: 128 cycles, not the seven flows' 14,336.
    #[test]
    fn a_small_flow_among_large_ones_gets_a_fair_share() {
        let mut m = MemoryInterface::new(gbps(25.6), gbps(25.6), None, None);
        for _ in 0..7 {
            m.start(Cycles(0), 1, 16384, gbps(25.6));
        }
        let small = m.start(Cycles(0), 1, 128, gbps(25.6));
        assert_eq!(m.next_end(), Some(Cycles(128)));
        let done = m.finish_due(Cycles(128));
        assert_eq!(done.iter().map(|f| f.id).collect::<Vec<_>>(), [small]);
        // The seven moved 128 bytes each meanwhile; the rest, 16,256
        // bytes each at a seventh of 8 bytes a cycle, takes 14,224 cycles.
        assert_eq!(m.next_end(), Some(Cycles(128 + 14_224)));
        assert_eq!(m.finish_due(Cycles(14_352)).len(), 7);
    }

    /// Water-filling: a flow held to 2 bytes a cycle by its link leaves
    /// the other 6 of the 8.
    #[test]
    fn a_slow_link_leaves_its_surplus_to_the_others() {
        let mut m = MemoryInterface::new(gbps(25.6), gbps(25.6), None, None);
        m.start(Cycles(0), 1, 1000, gbps(6.4));
        let fast = m.start(Cycles(0), 1, 600, gbps(25.6));
        assert_eq!(m.next_end(), Some(Cycles(100)));
        assert_eq!(m.finish_due(Cycles(100))[0].id, fast);
        // The slow one moved 200 bytes; 800 left at 2 a cycle.
        assert_eq!(m.next_end(), Some(Cycles(500)));
    }
}
