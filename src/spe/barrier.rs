//! The counting barrier of the multi-SPE strategies (section 5's shared
//! structures live on the atomic unit): every SPE adds one to an arrivals
//! counter on one lock line by fetch-and-add; the last to arrive in a round
//! (the count reaches rounds × SPEs, so the counter is never reset) may do
//! the round's closing work and then signals every other SPE on signal
//! register 2, on which they wait. Used by the cooperative partition, the
//! shared job queue's level ends and `spe_morton`'s phases.

use crate::cell::{CellError, Ea, LsAddr, Spe};

/// One SPE's view of a barrier: the arrivals line and the rounds passed.
#[derive(Clone, Copy)]
pub struct Barrier {
    arrivals: Ea,
    spes: usize,
    rounds: u32,
}

impl Barrier {
    /// A barrier of `spes` SPEs counting on the lock line at `arrivals`.
    pub fn new(arrivals: Ea, spes: usize) -> Self {
        Barrier {
            arrivals,
            spes,
            rounds: 0,
        }
    }

    /// Arrives (through the local-store line `line`); true for the last SPE
    /// of the round, which must [`release`](Self::release) the others.
    pub async fn arrive(&mut self, spe: &Spe, line: LsAddr) -> Result<bool, CellError> {
        self.rounds += 1;
        let old = spe.atomic_fetch_add_u32(line, self.arrivals, 1).await?;
        Ok(old + 1 == self.rounds * self.spes as u32)
    }

    /// The last to arrive: lets every other SPE go on.
    pub async fn release(&self, spe: &Spe) -> Result<(), CellError> {
        for to in (0..self.spes).filter(|&s| s != spe.id()) {
            spe.send_signal(to, 2, 1).await?;
        }
        Ok(())
    }

    /// Waits until every SPE has arrived.
    pub async fn wait(&mut self, spe: &Spe, line: LsAddr) -> Result<(), CellError> {
        if self.arrive(spe, line).await? {
            self.release(spe).await
        } else {
            spe.read_signal(2).await.map(|_| ())
        }
    }
}
