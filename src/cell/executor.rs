//! The executor: runs every core's program in virtual-time order.
//!
//! It always resumes the ready core with the smallest clock (ties: PPE,
//! then SPE 0, 1, …), after applying every event (DMA completion, mailbox
//! or signal arrival) due at or before that time. When no core is ready and
//! no event is pending while programs remain, the run ends with a deadlock
//! error that says who waits for what; it never hangs.

use std::cmp::Reverse;
use std::future::Future;
use std::pin::Pin;
use std::task::{Context, Poll, Waker};

use super::CellError;
use super::clock::Cycles;
use super::machine::{Machine, Status, Task};

impl Machine {
    fn earliest_ready(&self) -> Option<(Cycles, usize)> {
        self.cores
            .iter()
            .enumerate()
            .filter(|(_, c)| c.status == Status::Ready)
            .map(|(i, c)| (c.clock, i))
            .min()
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

/// Runs `tasks` (core index, program) to completion in virtual-time order.
/// Returns the cycle at which the last core or transfer finished.
pub(crate) fn execute(
    m: &std::rc::Rc<std::cell::RefCell<Machine>>,
    tasks: Vec<(usize, Task)>,
) -> Result<Cycles, CellError> {
    let mut slots: Vec<Option<Task>> = (0..m.borrow().cores.len()).map(|_| None).collect();
    let mut end = Cycles::ZERO;
    {
        let mut mm = m.borrow_mut();
        for (core, task) in tasks {
            mm.cores[core].status = Status::Ready;
            slots[core] = Some(task);
        }
    }
    let mut cx = Context::from_waker(Waker::noop());
    loop {
        let (ready, event_at) = {
            let mm = m.borrow();
            (mm.earliest_ready(), mm.events.peek().map(|e| e.0.at))
        };
        let take_event = match (ready, event_at) {
            (_, None) => false,
            (None, Some(_)) => true,
            (Some((t, _)), Some(e)) => e <= t,
        };
        if take_event {
            let mut mm = m.borrow_mut();
            let Reverse(ev) = mm.events.pop().expect("peeked");
            end = end.max(ev.at);
            mm.apply(ev.at, ev.kind)?;
            continue;
        }
        let Some((_, core)) = ready else {
            if slots.iter().all(Option::is_none) {
                break;
            }
            return Err(m.borrow().deadlock());
        };
        let task = slots[core].as_mut().expect("a ready core has a program");
        match task.as_mut().poll(&mut cx) {
            Poll::Pending => {}
            Poll::Ready(result) => {
                slots[core] = None;
                let mut mm = m.borrow_mut();
                mm.cores[core].status = Status::Done;
                end = end.max(mm.cores[core].clock);
                result?;
            }
        }
    }
    let mut mm = m.borrow_mut();
    for c in &mut mm.cores {
        c.counters.idle += end.saturating_sub(c.clock);
        c.clock = end;
    }
    let high_water: Vec<u32> = mm.spes.iter().map(|s| s.ls.high_water).collect();
    for (i, hw) in high_water.into_iter().enumerate() {
        mm.cores[i + 1].counters.ls_high_water = hw;
    }
    Ok(end)
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
