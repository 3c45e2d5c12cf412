//! The executor: runs every core's program in virtual-time order.
//!
//! It always resumes the ready core with the smallest clock (ties broken in
//! a seeded order that rotates at every resume, the same every run: see
//! `earliest_ready`), after applying every event (DMA completion, mailbox
//! or signal arrival) due at or before that time. When no core is ready and
//! no event is pending while programs remain, the run ends with a deadlock
//! error that says who waits for what; it never hangs.

use std::cmp::Reverse;
use std::future::Future;
use std::pin::Pin;
use std::task::{Context, Poll, Waker};

use super::CellError;
use super::clock::Cycles;
use super::machine::{Machine, Status, Task, Wait};

impl Machine {
    /// The ready core with the smallest clock. Equal clocks are broken in
    /// a seeded order that changes at every resume (a hash of the number of
    /// resumes so far and the core): the same every run, and fair. So when
    /// clocks stand still (the functional mode, where machine operations
    /// are free) every core takes part, a spin-wait lets the others run,
    /// and no core wins every race for a lock line by its number alone (a
    /// fixed rotation would let the same core store first in every round).
    fn earliest_ready(&self) -> Option<(Cycles, usize)> {
        self.cores
            .iter()
            .enumerate()
            .filter(|(_, c)| c.status == Status::Ready)
            .min_by_key(|&(i, c)| (c.clock, tie_order(self.resumes, i)))
            .map(|(i, c)| (c.clock, i))
    }

    /// An error where `core`'s clock has passed the last cycle time can
    /// reach (its sums saturate there: [`Cycles::END`]).
    fn check_clock(&self, core: usize) -> Result<(), CellError> {
        match self.cores[core].clock == Cycles::END {
            true => Err(CellError::TimeOverflow {
                core: super::machine::core_name(core),
            }),
            false => Ok(()),
        }
    }

    fn deadlock(&self) -> CellError {
        let at = self.cores.iter().map(|c| c.clock).max().unwrap_or_default();
        let waits = self
            .cores
            .iter()
            .enumerate()
            .filter_map(|(i, c)| match c.status {
                Status::Blocked { why, .. } => Some(why.describe(i)),
                _ => None,
            })
            .collect();
        CellError::Deadlock { at, waits }
    }
}

/// Runs the programs of `slots` (by core) in virtual-time order, to
/// completion or until `enough` holds (checked before every step; the
/// programs left stay in `slots`, part-run). Returns the cycle of the last
/// step: the latest event applied or core ended.
pub(crate) fn execute(
    m: &std::rc::Rc<std::cell::RefCell<Machine>>,
    slots: &mut [Option<Task>],
    enough: impl Fn(&Machine, &[Option<Task>]) -> bool,
) -> Result<Cycles, CellError> {
    let mut end = Cycles::ZERO;
    {
        let mut mm = m.borrow_mut();
        for (core, slot) in slots.iter().enumerate() {
            if slot.is_some() && mm.cores[core].status == Status::Done {
                mm.cores[core].status = Status::Ready;
            }
        }
    }
    let mut cx = Context::from_waker(Waker::noop());
    loop {
        if enough(&m.borrow(), slots) {
            break;
        }
        let (ready, event_at, flow_end) = {
            let mm = m.borrow();
            (
                mm.earliest_ready(),
                mm.events.peek().map(|e| e.0.at),
                mm.memif.next_end(),
            )
        };
        // The machine's next event: a flow ending on the memory interface
        // (first, at equal times) or a scheduled one.
        let next = match (flow_end, event_at) {
            (Some(f), Some(e)) => Some((f.min(e), f <= e)),
            (Some(f), None) => Some((f, true)),
            (None, Some(e)) => Some((e, false)),
            (None, None) => None,
        };
        let take_event = match (ready, next) {
            (_, None) => false,
            (None, Some(_)) => true,
            (Some((t, _)), Some((e, _))) => e <= t,
        };
        if take_event {
            let (at, is_flow) = next.expect("an event");
            let mut mm = m.borrow_mut();
            end = end.max(at);
            if is_flow {
                mm.finish_flows(at);
            } else {
                let Reverse(ev) = mm.events.pop().expect("peeked");
                mm.apply(ev.at, ev.kind)?;
            }
            continue;
        }
        let Some((_, core)) = ready else {
            if slots.iter().all(Option::is_none) {
                break;
            }
            return Err(m.borrow().deadlock());
        };
        m.borrow_mut().resumes += 1;
        let task = slots[core].as_mut().expect("a ready core has a program");
        let poll = task.as_mut().poll(&mut cx);
        m.borrow().check_clock(core)?;
        match poll {
            Poll::Pending => {}
            Poll::Ready(result) => {
                slots[core] = None;
                let mut mm = m.borrow_mut();
                mm.cores[core].status = Status::Done;
                let clock = mm.cores[core].clock;
                end = end.max(clock);
                if let Some(spe) = core.checked_sub(1) {
                    // A PPE serving this SPE until it stops looks again.
                    mm.wake_if(
                        super::machine::PPE,
                        clock,
                        |w| matches!(*w, Wait::AnyOutMbox(mask) if mask >> spe & 1 == 1),
                    );
                }
                result?;
            }
        }
    }
    match end == Cycles::END {
        true => Err(CellError::TimeOverflow {
            core: "the memory interface".into(),
        }),
        false => Ok(end),
    }
}

impl Machine {
    /// Brings the clocks of `cores` up to `at`, counting the wait as idle,
    /// and records their SPEs' local-store high-water marks.
    pub(crate) fn settle(&mut self, cores: impl Iterator<Item = usize>, at: Cycles) {
        for core in cores {
            let c = &mut self.cores[core];
            c.counters.idle += at.saturating_sub(c.clock);
            c.clock = c.clock.max(at);
            if let Some(spe) = core.checked_sub(1) {
                let hw = self.spes[spe].ls.high_water;
                let c = &mut self.cores[core].counters;
                c.ls_high_water = c.ls_high_water.max(hw);
            }
        }
    }
}

/// Where core `core` stands among cores of equal clock after `resumes`
/// resumes: SplitMix64 of the two.
fn tie_order(resumes: u64, core: usize) -> u64 {
    let mut z = resumes
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(core as u64 + 1);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A future that is pending once: the point where a program hands control
/// back to the executor.
pub(crate) struct Yield(bool);

impl Yield {
    pub fn new() -> Self {
        Yield(false)
    }
}

impl Future for Yield {
    type Output = ();
    fn poll(mut self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<()> {
        if self.0 {
            Poll::Ready(())
        } else {
            self.0 = true;
            Poll::Pending
        }
    }
}

/// The one loop of every blocking channel (a full MFC queue, a tag wait,
/// mailboxes, signals): yields until `attempt` succeeds. While it fails,
/// `core` is blocked on `why`, and the machine makes it ready again when
/// something `why` names happens (a DMA completes, a value arrives, room is
/// made), so the attempt is retried only then.
pub(crate) async fn block_on<T>(
    m: &std::rc::Rc<std::cell::RefCell<Machine>>,
    core: usize,
    why: Wait,
    mut attempt: impl FnMut(&mut Machine) -> Option<T>,
) -> T {
    loop {
        {
            let mut mm = m.borrow_mut();
            if let Some(v) = attempt(&mut mm) {
                return v;
            }
            mm.block(core, why);
        }
        Yield::new().await;
    }
}
