//! What an SPE program calls, as SPE C code calls spu_mfcio.h: its clock,
//! its local store, the MFC (get, put, lists, tag waits), its mailboxes and
//! signals, and the atomic unit. Every call that reaches outside the local
//! store is `async`: it is where the executor may run other cores first.

use std::cell::RefCell;
use std::rc::Rc;

use super::clock::Cycles;
use super::executor::Yield;
use super::executor::block_on;
use super::machine::{Machine, OutBox, PPE, Wait, ls_range};
use super::mfc::{self, Direction, ListElement, Order, QUEUE_DEPTH, Segment, WaitMode};
use super::trace::{CoreCounters, SpanKind};
use super::{CellError, CostModel, Ea, LockLines, LsAddr};

/// The outcome of a conditional store ([`Spe::putllc`]).
#[must_use = "a lost reservation means the store did not happen"]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reservation {
    /// The line was still reserved: the store happened.
    Stored,
    /// Another core wrote the line since getllar: nothing was stored.
    Lost,
}

/// An SPE program's handle on its SPE.
pub struct Spe {
    pub(crate) m: Rc<RefCell<Machine>>,
    pub(crate) id: usize,
}

impl Spe {
    fn core(&self) -> usize {
        self.id + 1
    }

    /// This SPE's number, 0-based.
    pub fn id(&self) -> usize {
        self.id
    }

    /// This SPE's clock.
    pub fn now(&self) -> Cycles {
        self.m.borrow().cores[self.core()].clock
    }

    /// This SPE's counters so far (where its cycles went, what it moved):
    /// a program that reports its phases takes their differences.
    pub fn counters(&self) -> CoreCounters {
        self.m.borrow().cores[self.core()].counters.clone()
    }

    /// The machine's cost model (for programs that derive their own compute
    /// charges from machine rates); shared, not copied.
    pub fn cost(&self) -> Rc<CostModel> {
        self.m.borrow().cost.clone()
    }

    /// Charges `cycles` of computation on the local store (none in the
    /// functional mode: [`CostModel::charge_compute`]).
    pub fn compute(&self, cycles: Cycles) {
        self.m.borrow_mut().compute(self.core(), cycles);
    }

    /// Charges `items` items of a kernel at `rate` cycles each (the
    /// program's named rate).
    pub fn compute_items(&self, rate: Cycles, items: u64) {
        self.compute(Cycles::times(rate, items));
    }

    /// `count` consecutive tag groups for the buffers called `name`,
    /// allocated on first use (from 0, in order of first use); the same
    /// name gives the same groups. An error when the 32 groups run out or
    /// the name was given another count.
    pub fn tags(&self, name: &'static str, count: u32) -> Result<u32, CellError> {
        let mut m = self.m.borrow_mut();
        let st = &mut m.spes[self.id];
        if let Some(&(_, first, n)) = st.tag_names.iter().find(|t| t.0 == name) {
            if n != count {
                return Err(CellError::Program {
                    core: format!("SPE {}", self.id),
                    msg: format!("tag groups '{name}' were allocated {n} at a time, not {count}"),
                });
            }
            return Ok(first);
        }
        let first = st.tag_names.last().map_or(0, |&(_, f, n)| f + n);
        if first + count > mfc::TAG_GROUPS {
            return Err(CellError::Program {
                core: format!("SPE {}", self.id),
                msg: format!(
                    "no {count} tag groups left for '{name}': {first} of 32 are taken ({})",
                    st.tag_names
                        .iter()
                        .map(|t| t.0)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            });
        }
        st.tag_names.push((name, first, count));
        Ok(first)
    }

    /// One tag group for `name` (see [`Spe::tags`]).
    pub fn tag(&self, name: &'static str) -> Result<u32, CellError> {
        self.tags(name, 1)
    }

    /// Hands control to the executor until this core is the earliest.
    async fn sync(&self) {
        self.m.borrow_mut().cores[self.core()].status = super::machine::Status::Ready;
        Yield::new().await;
    }

    // ---- local store -------------------------------------------------

    /// Allocates a local-store buffer of `size` bytes aligned to `align`.
    pub fn ls_alloc(&self, size: u32, align: u32) -> Result<LsAddr, CellError> {
        let id = self.id;
        self.m.borrow_mut().spes[id].ls.alloc(id, size, align)
    }

    /// The allocation mark, for [`Spe::ls_release_to`].
    pub fn ls_mark(&self) -> u32 {
        self.m.borrow().spes[self.id].ls.mark()
    }

    /// Bytes of the local store not yet allocated.
    pub fn ls_free_bytes(&self) -> u32 {
        let m = self.m.borrow();
        let ls = &m.spes[self.id].ls;
        ls.size() - ls.mark()
    }

    /// Frees every buffer allocated since `mark`.
    pub fn ls_release_to(&self, mark: u32) {
        self.m.borrow_mut().spes[self.id].ls.release_to(mark);
    }

    /// Runs `f` on `count` values of type `T` at `addr` (which must be
    /// aligned for `T`). Checked mode: an error if a get into these bytes
    /// has not been waited for. `f` may call this SPE's other synchronous
    /// methods (`compute`, `now`, …); touching the local store again from
    /// inside it is an error, not a panic.
    pub fn with_ls<T: bytemuck::Pod, R>(
        &self,
        addr: LsAddr,
        count: usize,
        f: impl FnOnce(&[T]) -> R,
    ) -> Result<R, CellError> {
        self.lend::<T, R>(addr, count, false, |bytes, r| {
            bytemuck::try_cast_slice(&bytes[r]).map(f)
        })
    }

    /// Runs `f` on `count` mutable values at `addr`. Checked mode: an error
    /// if a get or put of these bytes has not been waited for.
    pub fn with_ls_mut<T: bytemuck::Pod, R>(
        &self,
        addr: LsAddr,
        count: usize,
        f: impl FnOnce(&mut [T]) -> R,
    ) -> Result<R, CellError> {
        self.lend::<T, R>(addr, count, true, |bytes, r| {
            bytemuck::try_cast_slice_mut(&mut bytes[r]).map(f)
        })
    }

    /// Checks `count` values of `T` at `addr`, lends the local store to
    /// `f` outside the machine's borrow, and takes it back.
    fn lend<T, R>(
        &self,
        addr: LsAddr,
        count: usize,
        write: bool,
        f: impl FnOnce(&mut [u8], std::ops::Range<usize>) -> Result<R, bytemuck::PodCastError>,
    ) -> Result<R, CellError> {
        let (r, mut words) = {
            let mut m = self.m.borrow_mut();
            let bytes = (count * size_of::<T>()) as u64;
            let r = ls_range(self.id, &m, addr, bytes)?;
            m.check_ls_access(self.id, r.start as u32, r.end as u32, write)?;
            (r, m.spes[self.id].ls.lend(self.id)?)
        };
        let result = f(bytemuck::cast_slice_mut(&mut words), r);
        self.m.borrow_mut().spes[self.id].ls.give_back(words);
        result.map_err(|_| CellError::LsAlign {
            spe: self.id,
            addr,
            align: align_of::<T>(),
        })
    }

    /// Copies `count` values out of the local store.
    pub fn ls_read<T: bytemuck::Pod>(
        &self,
        addr: LsAddr,
        count: usize,
    ) -> Result<Vec<T>, CellError> {
        self.with_ls(addr, count, |s: &[T]| s.to_vec())
    }

    /// Copies `values` into the local store.
    pub fn ls_write<T: bytemuck::Pod>(&self, addr: LsAddr, values: &[T]) -> Result<(), CellError> {
        self.with_ls_mut(addr, values.len(), |s: &mut [T]| s.copy_from_slice(values))
    }

    // ---- MFC ---------------------------------------------------------

    async fn issue(
        &self,
        dir: Direction,
        segments: Vec<Segment>,
        tag: u32,
    ) -> Result<(), CellError> {
        self.issue_ordered(dir, Order::Plain, segments, tag).await
    }

    async fn issue_ordered(
        &self,
        dir: Direction,
        order: Order,
        segments: Vec<Segment>,
        tag: u32,
    ) -> Result<(), CellError> {
        self.sync().await;
        let mut segments = Some(segments);
        block_on(&self.m, self.core(), Wait::QueueFull, |m| {
            (m.spes[self.id].queued < QUEUE_DEPTH).then(|| {
                let segs = segments.take().expect("issued once");
                m.issue_dma(self.id, dir, order, segs, tag)
            })
        })
        .await
    }

    /// `mfc_getf` / `mfc_getb` (with `Order::Fence` / `Order::Barrier`): a
    /// get of `s` ordered after the earlier commands of its tag group (see
    /// [`mfc`](super::mfc)).
    pub async fn get_ordered(&self, order: Order, s: Segment, tag: u32) -> Result<(), CellError> {
        self.single(Direction::Get, order, s, tag).await
    }

    /// `mfc_putf` / `mfc_putb`: a put of `s` ordered after the earlier
    /// commands of its tag group.
    pub async fn put_ordered(&self, order: Order, s: Segment, tag: u32) -> Result<(), CellError> {
        self.single(Direction::Put, order, s, tag).await
    }

    /// `mfc_get`: `size` bytes from main memory at `ea` into the local store
    /// at `ls`, in tag group `tag`. The data is valid after
    /// [`Spe::wait_tags`] on the tag.
    pub async fn get(&self, ls: LsAddr, ea: Ea, size: u32, tag: u32) -> Result<(), CellError> {
        self.single(Direction::Get, Order::Plain, Segment { ls, ea, size }, tag)
            .await
    }

    /// `mfc_put`: `size` bytes from the local store at `ls` to main memory
    /// at `ea`. The buffer may be reused after waiting on the tag.
    pub async fn put(&self, ls: LsAddr, ea: Ea, size: u32, tag: u32) -> Result<(), CellError> {
        self.single(Direction::Put, Order::Plain, Segment { ls, ea, size }, tag)
            .await
    }

    /// One transfer, its rules checked, issued with `order`.
    async fn single(
        &self,
        dir: Direction,
        order: Order,
        s: Segment,
        tag: u32,
    ) -> Result<(), CellError> {
        mfc::check_segment(self.id, order_name(dir, order), s, tag)?;
        self.issue_ordered(dir, order, vec![s], tag).await
    }

    /// `mfc_getl`: gathers the list's pieces of main memory into one
    /// contiguous local-store range starting at `ls`. One queue entry.
    pub async fn getl(&self, ls: LsAddr, list: &[ListElement], tag: u32) -> Result<(), CellError> {
        let segs = mfc::list_segments(self.id, Direction::Get, ls, list, tag)?;
        self.issue(Direction::Get, segs, tag).await
    }

    /// `mfc_putl`: scatters a contiguous local-store range to the list's
    /// places in main memory. One queue entry.
    pub async fn putl(&self, ls: LsAddr, list: &[ListElement], tag: u32) -> Result<(), CellError> {
        let segs = mfc::list_segments(self.id, Direction::Put, ls, list, tag)?;
        self.issue(Direction::Put, segs, tag).await
    }

    /// Waits until the tag groups of `mask` have no command outstanding
    /// (all of them, or any one); returns the mask of those that have none.
    pub async fn wait_tags(&self, mask: u32, mode: WaitMode) -> Result<u32, CellError> {
        self.sync().await;
        let done = block_on(&self.m, self.core(), Wait::Tags { mask, mode }, |m| {
            let done = m.tags_done(self.id, mask);
            let ok = match mode {
                WaitMode::All => done == mask,
                WaitMode::Any => done != 0 || mask == 0,
            };
            ok.then_some(done)
        })
        .await;
        let mut m = self.m.borrow_mut();
        m.spes[self.id].unwaited.retain(|u| done >> u.tag & 1 == 0);
        let c = m.cfg.cost.channel_cycles;
        m.busy(self.core(), c, SpanKind::Issue);
        Ok(done)
    }

    /// `mfc_read_tag_status_immediate`: the groups of `mask` with no
    /// command outstanding, without waiting. It completes nothing for
    /// checked mode: the buffers count as waited for only after
    /// [`Spe::wait_tags`].
    pub async fn tag_status_immediate(&self, mask: u32) -> u32 {
        self.sync().await;
        let mut m = self.m.borrow_mut();
        let done = m.tags_done(self.id, mask);
        let c = m.cfg.cost.channel_cycles;
        m.busy(self.core(), c, SpanKind::Issue);
        done
    }

    /// Waits for every command of tag group `tag`.
    pub async fn wait_tag(&self, tag: u32) -> Result<(), CellError> {
        if tag >= mfc::TAG_GROUPS {
            return Err(CellError::Program {
                core: format!("SPE {}", self.id),
                msg: format!("tag {tag} is not 0–31"),
            });
        }
        self.wait_tags(1 << tag, WaitMode::All).await.map(|_| ())
    }

    // ---- mailboxes and signals ----------------------------------------

    /// Reads the SPU inbound mailbox (4 deep); blocks while it is empty.
    pub async fn read_in_mbox(&self) -> u32 {
        self.sync().await;
        let v = block_on(&self.m, self.core(), Wait::InMbox, |m| {
            m.spes[self.id].in_mbox.pop_front()
        })
        .await;
        let mut m = self.m.borrow_mut();
        let c = m.cfg.cost.channel_cycles;
        m.busy(self.core(), c, SpanKind::Issue);
        let now = m.cores[self.core()].clock;
        let me = self.id;
        m.wake_if(PPE, now, |w| *w == Wait::InMboxFull(me));
        v
    }

    /// `spu_stat_in_mbox`: values waiting in the inbound mailbox (0–4),
    /// without blocking.
    pub async fn in_mbox_count(&self) -> u32 {
        self.status_read(|m, id| m.spes[id].in_mbox.len() as u32)
            .await
    }

    /// `spu_stat_out_mbox`: room in the outbound mailbox (0 or 1).
    pub async fn out_mbox_room(&self) -> u32 {
        self.status_read(|m, id| {
            let st = &m.spes[id];
            (st.out_mbox[0].len() + st.out_arriving[0] == 0) as u32
        })
        .await
    }

    /// `spu_stat_signal1/2`: whether signal register `reg` (1 or 2) holds
    /// a signal, without reading (clearing) it.
    pub async fn signal_pending(&self, reg: u32) -> Result<bool, CellError> {
        let r = signal_index(reg)?;
        Ok(self
            .status_read(|m, id| m.spes[id].signals[r].pending as u32)
            .await
            == 1)
    }

    /// A channel-count read: synchronise, read, charge one channel access.
    async fn status_read(&self, read: impl FnOnce(&Machine, usize) -> u32) -> u32 {
        self.sync().await;
        let mut m = self.m.borrow_mut();
        let v = read(&m, self.id);
        let c = m.cfg.cost.channel_cycles;
        m.busy(self.core(), c, SpanKind::Issue);
        v
    }

    async fn write_out(&self, which: OutBox, value: u32) {
        self.sync().await;
        let w = which as usize;
        block_on(&self.m, self.core(), Wait::OutMboxFull(which), |m| {
            let st = &m.spes[self.id];
            (st.out_mbox[w].len() + st.out_arriving[w] < 1).then_some(())
        })
        .await;
        let mut m = self.m.borrow_mut();
        m.spes[self.id].out_arriving[w] += 1;
        let c = m.cfg.cost.channel_cycles;
        m.busy(self.core(), c, SpanKind::Issue);
        m.cores[self.core()].counters.mailbox_messages += 1;
        let at = m.cores[self.core()].clock
            + m.cfg.cost.mailbox_latency_cycles
            + m.cfg.cost.mailbox_os_cycles;
        m.schedule(
            at,
            super::machine::EventKind::OutMbox {
                spe: self.id,
                which,
                value,
            },
        );
    }

    /// Writes the SPU outbound mailbox (1 deep); blocks while it is full.
    pub async fn write_out_mbox(&self, value: u32) {
        self.write_out(OutBox::Out, value).await
    }

    /// Writes the SPU outbound interrupt mailbox (1 deep); blocks while full.
    pub async fn write_out_intr_mbox(&self, value: u32) {
        self.write_out(OutBox::OutIntr, value).await
    }

    /// Reads signal-notification register `reg` (1 or 2), clearing it;
    /// blocks while no signal is pending.
    pub async fn read_signal(&self, reg: u32) -> Result<u32, CellError> {
        let r = signal_index(reg)?;
        self.sync().await;
        let v = block_on(&self.m, self.core(), Wait::Signal(r), |m| {
            let s = &mut m.spes[self.id].signals[r];
            s.pending.then(|| {
                s.pending = false;
                std::mem::take(&mut s.value)
            })
        })
        .await;
        let mut m = self.m.borrow_mut();
        let c = m.cfg.cost.channel_cycles;
        m.busy(self.core(), c, SpanKind::Issue);
        Ok(v)
    }

    /// `mfc_sndsig`: sends `value` to signal register `reg` of SPE `target`.
    pub async fn send_signal(&self, target: usize, reg: u32, value: u32) -> Result<(), CellError> {
        let r = signal_index(reg)?;
        self.sync().await;
        let mut m = self.m.borrow_mut();
        if target >= m.spes.len() {
            return Err(CellError::Program {
                core: format!("SPE {}", self.id),
                msg: format!("no SPE {target} to signal"),
            });
        }
        let c = m.cfg.cost.dma_issue_cycles;
        m.busy(self.core(), c, SpanKind::Issue);
        let at = m.cores[self.core()].clock + m.cfg.cost.signal_latency_cycles;
        m.schedule(
            at,
            super::machine::EventKind::Signal {
                spe: target,
                reg: r,
                value,
            },
        );
        Ok(())
    }

    // ---- atomic unit -------------------------------------------------

    fn check_line(&self, cmd: &'static str, ls: LsAddr, ea: Ea) -> Result<(), CellError> {
        if !ls.0.is_multiple_of(128) || !ea.0.is_multiple_of(128) {
            return Err(CellError::Dma {
                spe: self.id,
                cmd,
                ls,
                ea,
                size: 128,
                why: "lock-line commands move one 128-byte line: both addresses must be 128-byte aligned".into(),
            });
        }
        Ok(())
    }

    /// `getllar`: loads the 128-byte line at `ea` into the local store at
    /// `ls` and reserves it.
    pub async fn getllar(&self, ls: LsAddr, ea: Ea) -> Result<(), CellError> {
        self.check_line("getllar", ls, ea)?;
        self.sync().await;
        let mut m = self.m.borrow_mut();
        let line = m.mem.read(ea, 128)?.to_vec();
        let r = ls_range(self.id, &m, ls, 128)?;
        m.check_ls_access(self.id, r.start as u32, r.end as u32, true)?;
        m.spes[self.id].ls.bytes_mut()[r].copy_from_slice(&line);
        m.spes[self.id].reservation = Some(ea.0);
        let (hit, miss) = (m.cfg.cost.atomic_hit_cycles, m.cfg.cost.getllar_cycles);
        match m.cfg.cost.lock_lines {
            LockLines::Exclusive => m.lock_line(self.core(), ea, hit, miss),
            LockLines::Shared { .. } => m.read_line(self.core(), ea, hit, miss),
        }
        Ok(())
    }

    /// `putllc`: stores the local-store line at `ls` to `ea` if this SPE
    /// still holds the reservation from its getllar.
    pub async fn putllc(&self, ls: LsAddr, ea: Ea) -> Result<Reservation, CellError> {
        self.check_line("putllc", ls, ea)?;
        self.sync().await;
        let mut m = self.m.borrow_mut();
        let (hit, miss) = (m.cfg.cost.atomic_hit_cycles, m.cfg.cost.getllar_cycles);
        if m.spes[self.id].reservation != Some(ea.0) {
            // The loss is known locally (the line was snooped away): the
            // command fails without touching the line.
            m.cores[self.core()].counters.reservations_lost += 1;
            m.spes[self.id].reservation = None;
            m.atomic(self.core(), hit);
            return Ok(Reservation::Lost);
        }
        let r = ls_range(self.id, &m, ls, 128)?;
        let data = m.spes[self.id].ls.bytes()[r].to_vec();
        m.mem.write(ea, &data)?;
        m.store_line(self.core(), ea, hit, miss);
        Ok(Reservation::Stored)
    }

    /// `putlluc`: stores the line unconditionally.
    pub async fn putlluc(&self, ls: LsAddr, ea: Ea) -> Result<(), CellError> {
        self.check_line("putlluc", ls, ea)?;
        self.sync().await;
        let mut m = self.m.borrow_mut();
        let r = ls_range(self.id, &m, ls, 128)?;
        let data = m.spes[self.id].ls.bytes()[r].to_vec();
        m.mem.write(ea, &data)?;
        let (hit, miss) = (m.cfg.cost.atomic_hit_cycles, m.cfg.cost.getllar_cycles);
        m.store_line(self.core(), ea, hit, miss);
        Ok(())
    }

    /// Atomically applies `f` to the 128-byte line at `ea` (its 32 words)
    /// with a getllar/putllc loop through the local-store buffer `line`;
    /// returns what `f` returned on the try that stored. Each lost
    /// reservation costs a retry.
    pub async fn atomic_update_line<R>(
        &self,
        line: LsAddr,
        ea: Ea,
        mut f: impl FnMut(&mut [u32]) -> R,
    ) -> Result<R, CellError> {
        loop {
            self.getllar(line, ea).await?;
            let r = self.with_ls_mut(line, 32, &mut f)?;
            if self.putllc(line, ea).await? == Reservation::Stored {
                return Ok(r);
            }
        }
    }

    /// Atomically applies `f` to the `u32` at `ea` (4-byte aligned);
    /// returns the old value ([`Spe::atomic_update_line`]).
    pub async fn atomic_update_u32(
        &self,
        line: LsAddr,
        ea: Ea,
        f: impl Fn(u32) -> u32,
    ) -> Result<u32, CellError> {
        let base = Ea(ea.0 & !127);
        let word = ((ea.0 & 127) / 4) as usize;
        if !ea.0.is_multiple_of(4) {
            return Err(CellError::Program {
                core: format!("SPE {}", self.id),
                msg: format!("{ea} is not 4-byte aligned"),
            });
        }
        self.atomic_update_line(line, base, |w: &mut [u32]| {
            let old = w[word];
            w[word] = f(old);
            old
        })
        .await
    }

    /// Atomic compare-and-swap on the `u32` at `ea`: stores `new` if the
    /// value is `expected`; returns the value found.
    pub async fn atomic_cas_u32(
        &self,
        line: LsAddr,
        ea: Ea,
        expected: u32,
        new: u32,
    ) -> Result<u32, CellError> {
        self.atomic_update_u32(line, ea, |v| if v == expected { new } else { v })
            .await
    }

    /// Atomic fetch-and-add on the `u32` at `ea`; returns the old value.
    pub async fn atomic_fetch_add_u32(
        &self,
        line: LsAddr,
        ea: Ea,
        delta: u32,
    ) -> Result<u32, CellError> {
        self.atomic_update_u32(line, ea, |v| v.wrapping_add(delta))
            .await
    }
}

fn order_name(dir: Direction, order: Order) -> &'static str {
    match (dir, order) {
        (Direction::Get, Order::Plain) => "mfc_get",
        (Direction::Get, Order::Fence) => "mfc_getf",
        (Direction::Get, Order::Barrier) => "mfc_getb",
        (Direction::Put, Order::Plain) => "mfc_put",
        (Direction::Put, Order::Fence) => "mfc_putf",
        (Direction::Put, Order::Barrier) => "mfc_putb",
    }
}

fn signal_index(reg: u32) -> Result<usize, CellError> {
    match reg {
        1 | 2 => Ok(reg as usize - 1),
        _ => Err(CellError::Program {
            core: "signal".into(),
            msg: format!("signal register {reg} is not 1 or 2"),
        }),
    }
}
