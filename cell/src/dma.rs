//! The MFC's commands on their way: a DMA command is issued, waits its turn
//! in its SPE's MFC (one command at a time: command phase, then data), moves
//! its data over the memory interface that every core shares
//! ([`super::memif`]), and completes after the latency; the PPE's own
//! accesses of main memory share the same interface. Checked mode's race
//! checks live here too. Timing is in `docs/cost-model.md`.

use super::clock::Cycles;
use super::machine::{
    Dma, EventKind, Flowing, InFlight, Machine, PPE, Status, Unwaited, Wait, partial_lines,
};
use super::memif::Resource;
use super::mfc::{Direction, Order, Segment};
use super::trace::SpanKind;
use super::{CellError, LockLines, LsAddr};

impl Machine {
    /// Issues a DMA command for SPE `spe` (queue space already checked):
    /// charges the issue and hands the command to the MFC, which starts it
    /// now or after the commands before it.
    pub fn issue_dma(
        &mut self,
        spe: usize,
        dir: Direction,
        order: Order,
        segments: Vec<Segment>,
        tag: u32,
    ) -> Result<(), CellError> {
        let core = spe + 1;
        // Every segment must lie inside the local store and inside main
        // memory or another SPE's local store, all of one kind.
        let eib = segments[0].ea.local_store().is_some();
        for s in &segments {
            self.spes[spe].ls.check_range(spe, s.ls, s.size as u64)?;
            let err = |why: String| CellError::Dma {
                spe,
                cmd: super::mfc::command_name(dir, segments.len() > 1),
                ls: s.ls,
                ea: s.ea,
                size: s.size,
                why,
            };
            match s.ea.local_store() {
                Some(_) if !eib => {
                    return Err(err("a list mixes main memory and local stores".into()));
                }
                None if eib => {
                    return Err(err("a list mixes local stores and main memory".into()));
                }
                Some((t, off)) => {
                    if t >= self.spes.len() {
                        return Err(err(format!(
                            "there is no SPE {t} whose local store this is"
                        )));
                    }
                    self.spes[t]
                        .ls
                        .check_range(t, LsAddr(off), s.size as u64)
                        .map_err(|e| err(e.to_string()))?;
                }
                None => {
                    self.mem
                        .read(s.ea, s.size as u64)
                        .map_err(|e| err(e.to_string()))?;
                }
            }
        }
        let ranges = merged(segments.iter().map(|s| (s.ea.0, s.ea.0 + s.size as u64)));
        if self.cfg.checked {
            self.check_overlap_at_issue(spe, dir, &segments)?;
            self.check_order(spe, dir, order, tag, &ranges)?;
        }
        let bytes: u64 = segments.iter().map(|s| s.size as u64).sum();
        let mut data = Vec::new();
        if dir == Direction::Put {
            data.reserve(bytes as usize);
            let ls = self.spes[spe].ls.bytes();
            for s in &segments {
                data.extend_from_slice(&ls[s.ls.0 as usize..(s.ls.0 + s.size) as usize]);
            }
        }
        let issue = self.cfg.cost.dma_issue_cycles;
        self.busy(core, issue, SpanKind::Issue);
        let issued = self.cores[core].clock;
        let st = &mut self.spes[spe];
        st.queued += 1;
        st.outstanding[tag as usize] += 1;
        st.issued += 1;
        let id = st.issued;
        if self.cfg.checked {
            st.incomplete.push(InFlight {
                id,
                tag,
                dir,
                order,
                ranges,
            });
        }
        // One unwaited range per run of touching segments (a list's local
        // side is contiguous), so checked mode stays linear in list length.
        let mut runs: Vec<(u32, u32)> = Vec::new();
        for s in &segments {
            match runs.last_mut() {
                Some(r) if r.1 == s.ls.0 => r.1 += s.size,
                _ => runs.push((s.ls.0, s.ls.0 + s.size)),
            }
        }
        for (lo, hi) in runs {
            st.unwaited.push(Unwaited { tag, dir, lo, hi });
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
        let dma = Dma {
            id,
            order,
            spe,
            tag,
            dir,
            segments,
            data,
            start: issued,
            eib,
        };
        if self.spes[spe].mfc_busy {
            self.spes[spe].pending.push_back(dma);
        } else {
            let start = issued.max(self.spes[spe].mfc_free);
            self.begin_command(dma, start);
        }
        Ok(())
    }

    /// The MFC takes `dma` at `start`: after its command phase (and one
    /// step per extra list element) its data goes onto the interface.
    fn begin_command(&mut self, mut dma: Dma, start: Cycles) {
        // Every earlier command has moved its data by now (the MFC runs
        // them in issue order); a fence or barrier waits for them to
        // complete, and every command waits for an earlier barrier's.
        let st = &self.spes[dma.spe];
        let t = dma.tag as usize;
        let mut start = start.max(st.barrier_done[t]);
        if dma.order != Order::Plain {
            start = start.max(st.tag_done[t]);
        }
        let cost = &self.cfg.cost;
        let setup = cost.mfc_command_cycles
            + Cycles(cost.mfc_list_element_cycles.0 * (dma.segments.len() as u64 - 1));
        self.spes[dma.spe].mfc_busy = true;
        dma.start = start;
        self.schedule(start + setup, EventKind::FlowStart(Box::new(dma)));
    }

    /// A command's data starts to move at `at`.
    pub(crate) fn start_flow(&mut self, dma: Box<Dma>, at: Cycles) {
        let cost = &self.cfg.cost;
        let fabric = cost.eib_total_bandwidth.is_some() || cost.ls_port_bandwidth.is_some();
        if dma.eib && (!fabric || self.memif.is_free()) {
            // Local store to local store over the EIB: the SPEs' links set
            // the pace, the memory interface is not involved.
            let c = cost.eib_bandwidth.cycles(dma.bytes());
            return self.schedule(at + c, EventKind::EibDone(dma, at));
        }
        if self.memif.is_free() {
            return self.end_transfer(dma, at, Cycles::ZERO, at);
        }
        let core = dma.spe + 1;
        let id = if dma.eib {
            // Through the EIB, out of one local store's port and into
            // another's.
            let (peer, _) = dma.segments[0].ea.local_store().expect("an EIB transfer");
            let (from, to) = match dma.dir {
                Direction::Get => (peer, dma.spe),
                Direction::Put => (dma.spe, peer),
            };
            let uses = vec![Resource::Eib, Resource::LsOut(from), Resource::LsIn(to)];
            let link = cost.eib_bandwidth;
            self.memif.start_through(at, core, uses, dma.bytes(), link)
        } else {
            let bytes = match cost.memory_whole_lines {
                true => dma.segments.iter().map(|s| lines_of(s.ea.0, s.size)).sum(),
                false => dma.bytes(),
            };
            self.memif.start(at, core, bytes, cost.spe_bandwidth)
        };
        self.flows.push((id, Flowing::Spe(dma)));
    }

    /// Ends every flow of the memory interface due at `at`.
    pub(crate) fn finish_flows(&mut self, at: Cycles) {
        for f in self.memif.finish_due(at) {
            let k = self
                .flows
                .iter()
                .position(|(id, _)| *id == f.id)
                .expect("every flow is known");
            match self.flows.remove(k).1 {
                Flowing::Spe(dma) => self.end_transfer(dma, f.started, f.alone, at),
                Flowing::Ppe => self.end_ppe_access(f.started, f.alone, at),
            }
        }
    }

    /// `dma`'s data, on the interface from `data_start`, is through at
    /// `at`; it would have taken `alone` cycles with the interface to
    /// itself. The command completes after the latency; the MFC takes the
    /// next one.
    pub(crate) fn end_transfer(
        &mut self,
        dma: Box<Dma>,
        data_start: Cycles,
        alone: Cycles,
        at: Cycles,
    ) {
        let spe = dma.spe;
        let shared = (at - data_start).saturating_sub(alone);
        self.cores[spe + 1].counters.memory_wait += shared;
        let ack = match dma.dir {
            Direction::Put => self.cfg.cost.put_ack_cycles,
            Direction::Get => Cycles::ZERO,
        };
        let claimed = self.claim_partial_lines(&dma, at);
        let done = claimed + self.cfg.cost.dma_latency_cycles + ack;
        if let Some(t) = &mut self.trace {
            let mut label = format!("{} {} B tag {}", dma.dir, dma.bytes(), dma.tag);
            if shared > Cycles::ZERO {
                label += &format!(", +{} cycles sharing memory", shared.0);
            }
            t.push(
                Self::row(spe + 1) + 1,
                SpanKind::Transfer,
                dma.start,
                done,
                Some(label),
            );
        }
        let st = &mut self.spes[spe];
        st.mfc_free = at;
        st.mfc_busy = false;
        let t = dma.tag as usize;
        st.tag_done[t] = st.tag_done[t].max(done);
        if dma.order == Order::Barrier {
            st.barrier_done[t] = st.barrier_done[t].max(done);
        }
        if let Some(next) = st.pending.pop_front() {
            let start = at.max(next.start);
            self.begin_command(next, start);
        }
        self.schedule(done, EventKind::DmaDone(dma));
    }

    /// A put's data reaches main memory at `at`: each line it writes only
    /// part of is claimed first unless its SPE already holds it
    /// ([`CostModel::partial_puts_claim`](super::CostModel)), one claim
    /// after another on a line. Returns when the last claim is through.
    fn claim_partial_lines(&mut self, dma: &Dma, at: Cycles) -> Cycles {
        let cost = &self.cfg.cost;
        let LockLines::Shared { claim_cycles } = cost.lock_lines else {
            return at;
        };
        if dma.dir != Direction::Put || dma.eib || !cost.partial_puts_claim {
            return at;
        }
        let core = dma.spe + 1;
        let mut through = at;
        for s in &dma.segments {
            for l in partial_lines(s.ea.0, s.size) {
                let line = self.lines.entry(l).or_default();
                if line.writer != Some(core) || line.holders & !(1 << core) != 0 {
                    let start = line.claim_start(at);
                    line.busy_until = start + claim_cycles;
                    line.holders = 0;
                    line.writer = Some(core);
                    through = through.max(line.busy_until);
                }
            }
        }
        through
    }

    /// The PPE moves `bytes` to or from main memory at its clock, sharing
    /// the interface: it blocks until the access is through.
    pub(crate) fn ppe_access(&mut self, bytes: u64) {
        let now = self.cores[PPE].clock;
        let link = self.cfg.cost.ppe_memory_bandwidth;
        if bytes == 0 {
            return;
        }
        if self.memif.is_free() {
            let c = link.cycles(bytes);
            return self.busy(PPE, c, SpanKind::Compute);
        }
        let id = self.memif.start(now, PPE, bytes, link);
        self.flows.push((id, Flowing::Ppe));
        self.block(PPE, Wait::Memory);
    }

    /// The PPE's access from `since` is through at `at`: the time it would
    /// have taken alone is busy, the rest waiting for the interface.
    fn end_ppe_access(&mut self, since: Cycles, alone: Cycles, at: Cycles) {
        let shared = (at - since).saturating_sub(alone);
        let c = &mut self.cores[PPE];
        c.status = Status::Ready;
        c.clock = at;
        c.counters.busy += at - since - shared;
        c.counters.memory_wait += shared;
        self.span(PPE, SpanKind::Compute, since, at - shared);
        self.span(PPE, SpanKind::MemoryWait, at - shared, at);
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

    /// Checked mode: a command that touches main memory an earlier,
    /// incomplete command of this SPE touches (one of them a put) must be
    /// ordered after it: same tag group, and a fence or barrier on the new
    /// command or a barrier between them. Otherwise the MFC may run the two
    /// in either order.
    fn check_order(
        &self,
        spe: usize,
        dir: Direction,
        order: Order,
        tag: u32,
        ranges: &[(u64, u64)],
    ) -> Result<(), CellError> {
        let earlier = &self.spes[spe].incomplete;
        for (k, e) in earlier.iter().enumerate() {
            if e.dir == Direction::Get && dir == Direction::Get {
                continue;
            }
            let Some(&(lo, hi)) = e
                .ranges
                .iter()
                .find(|a| ranges.iter().any(|b| a.0 < b.1 && b.0 < a.1))
            else {
                continue;
            };
            let barrier_between = earlier[k..]
                .iter()
                .any(|b| b.tag == tag && b.order == Order::Barrier);
            let ordered = e.tag == tag && (order != Order::Plain || barrier_between);
            if !ordered {
                let how = if e.tag == tag {
                    "use the fenced or barrier form (getf/putf, getb/putb)"
                } else {
                    "wait for its tag group first (a fence orders only within a tag group)"
                };
                return Err(CellError::Race {
                    spe,
                    what: format!(
                        "a {dir} (tag {tag}) issued while the {} of ea {lo:#x}..{hi:#x} (tag {}) is \
                         not complete: the MFC may run them in either order; {how}",
                        e.dir, e.tag
                    ),
                });
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

/// Bytes of the whole 128-byte lines that `size` bytes at `ea` touch.
fn lines_of(ea: u64, size: u32) -> u64 {
    if size == 0 {
        return 0;
    }
    let (first, last) = (ea / 128, (ea + size as u64 - 1) / 128);
    (last - first + 1) * 128
}

/// Ranges in order with the touching ones merged.
fn merged(ranges: impl Iterator<Item = (u64, u64)>) -> Vec<(u64, u64)> {
    let mut out: Vec<(u64, u64)> = Vec::new();
    for (lo, hi) in ranges {
        match out.last_mut() {
            Some(r) if r.1 == lo => r.1 = hi,
            _ => out.push((lo, hi)),
        }
    }
    out
}
