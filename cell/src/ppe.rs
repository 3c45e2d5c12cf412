//! What the PPE program calls: allocation and access of main memory, the
//! MMIO side of every SPE's mailboxes and signals, and its own atomic
//! update. The PPE reaches main memory directly (through its caches),
//! charged at the PPE's memory bandwidth.

use std::cell::RefCell;
use std::rc::Rc;

use super::clock::Cycles;
use super::executor::Yield;
use super::executor::block_on;
use super::machine::{EventKind, Machine, OutBox, PPE, Status, Wait};
use super::trace::SpanKind;
use super::{CellError, CostModel, Ea, LockLines};

/// The PPE program's handle on the machine.
pub struct Ppe {
    pub(crate) m: Rc<RefCell<Machine>>,
}

impl Ppe {
    pub fn now(&self) -> Cycles {
        self.m.borrow().cores[PPE].clock
    }

    /// The machine's cost model, shared.
    pub fn cost(&self) -> std::rc::Rc<CostModel> {
        self.m.borrow().cost.clone()
    }

    /// Charges `items` items of a kernel at `rate` cycles each.
    pub fn compute_items(&self, rate: Cycles, items: u64) {
        self.compute(Cycles::times(rate, items));
    }

    /// Number of SPEs of the machine.
    pub fn spes(&self) -> usize {
        self.m.borrow().spes.len()
    }

    /// Charges `cycles` of PPE computation (none in the functional mode:
    /// [`CostModel::charge_compute`]).
    pub fn compute(&self, cycles: Cycles) {
        self.m.borrow_mut().compute(PPE, cycles);
    }

    async fn sync(&self) {
        self.m.borrow_mut().cores[PPE].status = Status::Ready;
        Yield::new().await;
    }

    /// Yields until the machine has made the PPE ready again (after a
    /// blocking access of main memory).
    async fn until_ready(&self) {
        while self.m.borrow().cores[PPE].status != Status::Ready {
            Yield::new().await;
        }
    }

    fn check_spe(&self, m: &Machine, spe: usize) -> Result<(), CellError> {
        if spe >= m.spes.len() {
            return Err(CellError::Program {
                core: "PPE".into(),
                msg: format!("there is no SPE {spe}"),
            });
        }
        Ok(())
    }

    /// Allocates `size` bytes of main memory aligned to `align` for the
    /// buffer `what` (named in the error if memory is full); charged
    /// `ppe_alloc_cycles`.
    pub async fn alloc(
        &self,
        what: impl Into<crate::Label>,
        size: u64,
        align: u64,
    ) -> Result<Ea, CellError> {
        let what = what.into();
        self.sync().await;
        let mut m = self.m.borrow_mut();
        let c = m.cfg.cost.ppe_alloc_cycles;
        m.busy(PPE, c, SpanKind::Compute);
        m.mem.alloc(what, size, align)
    }

    /// Reads `count` values at `ea`, charged at the PPE's memory bandwidth.
    pub async fn read_pod<T: bytemuck::Pod>(
        &self,
        ea: Ea,
        count: usize,
    ) -> Result<Vec<T>, CellError> {
        self.sync().await;
        let v = {
            let mut m = self.m.borrow_mut();
            let v = m.mem.read_pod(ea, count)?;
            m.ppe_access((count * size_of::<T>()) as u64);
            v
        };
        self.until_ready().await;
        Ok(v)
    }

    /// Writes `values` at `ea`; loses any SPE reservation on those lines.
    pub async fn write_pod<T: bytemuck::Pod>(&self, ea: Ea, values: &[T]) -> Result<(), CellError> {
        self.sync().await;
        {
            let mut m = self.m.borrow_mut();
            m.mem.write_pod(ea, values)?;
            let bytes = size_of_val(values) as u64;
            m.lose_reservations(ea, bytes);
            m.ppe_access(bytes);
        }
        self.until_ready().await;
        Ok(())
    }

    /// Atomically adds `delta` to the `u32` at `ea` (lwarx/stwcx.); returns
    /// the old value. With shared lock lines, as the instructions do it:
    /// the lwarx reads the line — free where the PPE holds a copy, else
    /// in its turn behind the misses under way, brought over in
    /// `getllar_cycles` like an SPE's getllar — and reserves it; the
    /// stwcx. stores if no core wrote the line since (as the only holder
    /// in `ppe_atomic_cycles`, else claiming it), and the pair is retried
    /// if one did. Loses SPE reservations on the line.
    pub async fn atomic_fetch_add_u32(&self, ea: Ea, delta: u32) -> Result<u32, CellError> {
        loop {
            self.sync().await;
            {
                let mut m = self.m.borrow_mut();
                let c = m.cfg.cost.ppe_atomic_cycles;
                if m.cfg.cost.lock_lines == LockLines::Exclusive {
                    let old: u32 = m.mem.read_pod(ea, 1)?[0];
                    m.mem.write_pod(ea, &[old.wrapping_add(delta)])?;
                    // The line comes to the PPE; commands on it are
                    // served in turn.
                    m.store_line(PPE, ea, c, c);
                    return Ok(old);
                }
                let miss = m.cfg.cost.getllar_cycles;
                m.read_line(PPE, ea, Cycles::ZERO, miss);
                m.ppe_reservation = Some(ea.0);
            }
            self.sync().await;
            let mut m = self.m.borrow_mut();
            if m.ppe_reservation != Some(ea.0) {
                continue;
            }
            let old: u32 = m.mem.read_pod(ea, 1)?[0];
            m.mem.write_pod(ea, &[old.wrapping_add(delta)])?;
            let c = m.cfg.cost.ppe_atomic_cycles;
            m.store_line(PPE, ea, c, c);
            return Ok(old);
        }
    }

    /// Atomic compare-and-swap on the `u32` at `ea` (lwarx, compare,
    /// stwcx. if equal); returns the value found. A failed compare only
    /// reads the line: its copy comes to the PPE (a miss costs
    /// `getllar_cycles`, as an SPE's does); a swap stores like
    /// [`Ppe::atomic_fetch_add_u32`].
    pub async fn atomic_cas_u32(&self, ea: Ea, expected: u32, new: u32) -> Result<u32, CellError> {
        self.sync().await;
        let mut m = self.m.borrow_mut();
        let old: u32 = m.mem.read_pod(ea, 1)?[0];
        let c = m.cfg.cost.ppe_atomic_cycles;
        if old == expected {
            m.mem.write_pod(ea, &[new])?;
            m.store_line(PPE, ea, c, c);
        } else {
            match m.cfg.cost.lock_lines {
                LockLines::Exclusive => m.lock_line(PPE, ea, c, c),
                LockLines::Shared { .. } => {
                    let miss = m.cfg.cost.getllar_cycles;
                    m.read_line(PPE, ea, c, miss);
                }
            }
        }
        Ok(old)
    }

    /// Writes SPE `spe`'s inbound mailbox; blocks while it holds 4 values
    /// (libspe's blocking write; a raw MMIO write would overwrite the last).
    pub async fn write_in_mbox(&self, spe: usize, value: u32) -> Result<(), CellError> {
        self.check_spe(&self.m.borrow(), spe)?;
        self.sync().await;
        block_on(&self.m, PPE, Wait::InMboxFull(spe), |m| {
            let st = &m.spes[spe];
            (st.in_mbox.len() + st.in_arriving < 4).then_some(())
        })
        .await;
        let mut m = self.m.borrow_mut();
        m.spes[spe].in_arriving += 1;
        let c = m.cfg.cost.ppe_mmio_cycles;
        m.busy(PPE, c, SpanKind::Issue);
        m.cores[PPE].counters.mailbox_messages += 1;
        let at =
            m.cores[PPE].clock + m.cfg.cost.mailbox_latency_cycles + m.cfg.cost.mailbox_os_cycles;
        m.schedule(at, EventKind::InMbox { spe, value });
        Ok(())
    }

    async fn read_out(&self, spe: usize, which: OutBox) -> Result<u32, CellError> {
        self.check_spe(&self.m.borrow(), spe)?;
        self.sync().await;
        let v = block_on(&self.m, PPE, Wait::OutMbox(spe, which), |m| {
            m.spes[spe].out_mbox[which as usize].pop_front()
        })
        .await;
        self.after_out_read(spe, which);
        Ok(v.0)
    }

    /// Charges the MMIO read of an outbound mailbox and frees its slot.
    fn after_out_read(&self, spe: usize, which: OutBox) {
        let mut m = self.m.borrow_mut();
        let c = m.cfg.cost.ppe_mmio_cycles;
        m.busy(PPE, c, SpanKind::Issue);
        let now = m.cores[PPE].clock;
        m.wake_if(spe + 1, now, |w| *w == Wait::OutMboxFull(which));
    }

    /// Reads SPE `spe`'s outbound mailbox; blocks while it is empty.
    pub async fn read_out_mbox(&self, spe: usize) -> Result<u32, CellError> {
        self.read_out(spe, OutBox::Out).await
    }

    /// Reads SPE `spe`'s outbound interrupt mailbox; blocks while empty.
    pub async fn read_out_intr_mbox(&self, spe: usize) -> Result<u32, CellError> {
        self.read_out(spe, OutBox::OutIntr).await
    }

    /// Waits for a value in the outbound mailbox of any SPE of `spes`, as a
    /// PPE thread serving several SPEs waits in libspe2's event handler
    /// (`spe_event_wait` on SPE_EVENT_OUT_INTR_MBOX), and reads it: returns
    /// (SPE, value). When several hold one, the value that arrived first
    /// is read (ties: the lower SPE). Charged one event wake-up
    /// (`ppe_event_cycles`) and the MMIO read.
    pub async fn wait_any_out_mbox(&self, spes: &[usize]) -> Result<(usize, u32), CellError> {
        let mut mask = 0u64;
        for &s in spes {
            self.check_spe(&self.m.borrow(), s)?;
            mask |= 1 << s;
        }
        self.sync().await;
        let (spe, v) = block_on(&self.m, PPE, Wait::AnyOutMbox(mask), |m| {
            let k = (0..m.spes.len())
                .filter(|&k| mask >> k & 1 == 1)
                .filter_map(|k| m.spes[k].out_mbox[0].front().map(|&(_, at)| (at, k)))
                .min()?
                .1;
            let (v, _) = m.spes[k].out_mbox[0].pop_front().expect("a value");
            Some((k, v))
        })
        .await;
        {
            let mut m = self.m.borrow_mut();
            let c = m.cfg.cost.ppe_event_cycles;
            m.busy(PPE, c, SpanKind::Issue);
        }
        self.after_out_read(spe, OutBox::Out);
        Ok((spe, v))
    }

    /// As [`Ppe::wait_any_out_mbox`], for a PPE thread that serves `spes`
    /// until they stop (libspe2's event handler also reports
    /// SPE_EVENT_SPE_STOPPED): `None` once every SPE of `spes` has ended
    /// and no value is left. That last wake-up is not charged: it is the
    /// end of the run, which ends when its last core does.
    pub async fn wait_any_out_mbox_or_stop(
        &self,
        spes: &[usize],
    ) -> Result<Option<(usize, u32)>, CellError> {
        let mut mask = 0u64;
        for &s in spes {
            self.check_spe(&self.m.borrow(), s)?;
            mask |= 1 << s;
        }
        self.sync().await;
        let got = block_on(&self.m, PPE, Wait::AnyOutMbox(mask), |m| {
            let first = (0..m.spes.len())
                .filter(|&k| mask >> k & 1 == 1)
                .filter_map(|k| m.spes[k].out_mbox[0].front().map(|&(_, at)| (at, k)))
                .min();
            match first {
                Some((_, k)) => {
                    let (v, _) = m.spes[k].out_mbox[0].pop_front().expect("a value");
                    Some(Some((k, v)))
                }
                // Stopped, and no word of theirs still on its way.
                None => (0..m.spes.len())
                    .filter(|&k| mask >> k & 1 == 1)
                    .all(|k| {
                        m.cores[k + 1].status == super::machine::Status::Done
                            && m.spes[k].out_arriving[0] == 0
                    })
                    .then_some(None),
            }
        })
        .await;
        if let Some((spe, _)) = got {
            {
                let mut m = self.m.borrow_mut();
                let c = m.cfg.cost.ppe_event_cycles;
                m.busy(PPE, c, SpanKind::Issue);
            }
            self.after_out_read(spe, OutBox::Out);
        }
        Ok(got)
    }

    /// `spe_out_mbox_status`: values waiting in SPE `spe`'s outbound
    /// mailbox (0 or 1), without blocking; one MMIO read.
    pub async fn out_mbox_count(&self, spe: usize) -> Result<u32, CellError> {
        self.status_read(spe, |m| m.spes[spe].out_mbox[0].len() as u32)
            .await
    }

    /// `spe_in_mbox_status`: room in SPE `spe`'s inbound mailbox (0–4).
    pub async fn in_mbox_room(&self, spe: usize) -> Result<u32, CellError> {
        self.status_read(spe, |m| {
            let st = &m.spes[spe];
            (4 - st.in_mbox.len() - st.in_arriving) as u32
        })
        .await
    }

    async fn status_read(
        &self,
        spe: usize,
        read: impl FnOnce(&Machine) -> u32,
    ) -> Result<u32, CellError> {
        self.check_spe(&self.m.borrow(), spe)?;
        self.sync().await;
        let mut m = self.m.borrow_mut();
        let v = read(&m);
        let c = m.cfg.cost.ppe_mmio_cycles;
        m.busy(PPE, c, SpanKind::Issue);
        Ok(v)
    }

    /// Writes `value` to signal register `reg` (1 or 2) of SPE `spe`.
    pub async fn send_signal(&self, spe: usize, reg: u32, value: u32) -> Result<(), CellError> {
        self.check_spe(&self.m.borrow(), spe)?;
        if reg != 1 && reg != 2 {
            return Err(CellError::Program {
                core: "PPE".into(),
                msg: format!("signal register {reg} is not 1 or 2"),
            });
        }
        self.sync().await;
        let mut m = self.m.borrow_mut();
        let c = m.cfg.cost.ppe_mmio_cycles;
        m.busy(PPE, c, SpanKind::Issue);
        let at = m.cores[PPE].clock + m.cfg.cost.signal_latency_cycles;
        m.schedule(
            at,
            EventKind::Signal {
                spe,
                reg: reg as usize - 1,
                value,
            },
        );
        Ok(())
    }
}
