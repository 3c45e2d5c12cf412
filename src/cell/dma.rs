//! The MFC's commands on their way: a DMA command is issued, waits its turn
//! in its SPE's MFC (one command at a time: command phase, then data), moves
//! its data over the memory interface that every core shares
//! ([`super::memif`]), and completes after the latency; the PPE's own
//! accesses of main memory share the same interface. Checked mode's race
//! checks live here too. Timing is in `docs/cost-model.md`.

use super::CellError;
use super::clock::Cycles;
use super::machine::{Dma, EventKind, Flowing, Machine, PPE, Status, Unwaited, Wait};
use super::mfc::{Direction, Segment};
use super::trace::SpanKind;

impl Machine {
    /// Issues a DMA command for SPE `spe` (queue space already checked):
    /// charges the issue and hands the command to the MFC, which starts it
    /// now or after the commands before it.
    pub fn issue_dma(
        &mut self,
        spe: usize,
        dir: Direction,
        segments: Vec<Segment>,
        tag: u32,
    ) -> Result<(), CellError> {
        let core = spe + 1;
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
            spe,
            tag,
            dir,
            segments,
            data,
            start: issued,
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
        let cost = &self.cfg.cost;
        let setup = cost.mfc_command_cycles
            + Cycles(cost.mfc_list_element_cycles.0 * (dma.segments.len() as u64 - 1));
        self.spes[dma.spe].mfc_busy = true;
        dma.start = start;
        self.schedule(start + setup, EventKind::FlowStart(Box::new(dma)));
    }

    /// A command's data starts to move at `at`.
    pub(crate) fn start_flow(&mut self, dma: Box<Dma>, at: Cycles) {
        if self.memif.is_free() {
            return self.end_transfer(dma, at, Cycles::ZERO, at);
        }
        let link = self.cfg.cost.spe_bandwidth;
        let id = self.memif.start(at, dma.bytes(), link);
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
    fn end_transfer(&mut self, dma: Box<Dma>, data_start: Cycles, alone: Cycles, at: Cycles) {
        let spe = dma.spe;
        let shared = (at - data_start).saturating_sub(alone);
        self.cores[spe + 1].counters.memory_wait += shared;
        let done = at + self.cfg.cost.dma_latency_cycles;
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
        if let Some(next) = st.pending.pop_front() {
            let start = at.max(next.start);
            self.begin_command(next, start);
        }
        self.schedule(done, EventKind::DmaDone(dma));
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
        let id = self.memif.start(now, bytes, link);
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
