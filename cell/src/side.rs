//! One machine, two sides: a side (the PPE and some SPEs) runs programs
//! one after another while the programs of the other SPEs run throughout,
//! all in one virtual time, so the two meet at the memory interface, the
//! EIB and the lock lines as they would on the hardware. This is how the
//! paper's arrangement (section 4: one SPE updates the tree while the
//! others render) runs on one emulated Cell: the builder's programs, build
//! after build, on SPEs `0 .. b` and the PPE; the casters on `b .. n`.
//!
//! Between two runs of a side the host may set up main memory (a build's
//! input), outside simulated time, as it does before any run. A program
//! started on an SPE finds it as a new SPURS task does: an empty local
//! store, an idle MFC, empty mailboxes. No program start is charged (the
//! programs stay resident: [`CellConfig::resident`](super::CellConfig)).

use super::clock::Cycles;
use super::machine::{self, Machine, SpeState, Task};
use super::{Cell, CellError, RunReport, executor};

/// The cores of one side: the PPE or not, and a range of SPEs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Side {
    pub ppe: bool,
    pub spes: std::ops::Range<usize>,
}

impl Side {
    /// Core numbers (the PPE is core 0, SPE `i` core `i + 1`).
    fn cores(&self) -> impl Iterator<Item = usize> + '_ {
        (self.ppe.then_some(machine::PPE))
            .into_iter()
            .chain(self.spes.clone().map(|s| s + 1))
    }

    fn holds(&self, core: usize) -> bool {
        match core.checked_sub(1) {
            None => self.ppe,
            Some(spe) => self.spes.contains(&spe),
        }
    }

    /// Its programs have ended and nothing of its SPEs is on its way.
    fn done(&self, m: &Machine, slots: &[Option<Task>]) -> bool {
        self.cores().all(|c| slots[c].is_none()) && self.spes.clone().all(|s| m.spes[s].quiet())
    }
}

impl Cell {
    /// Starts the programs spawned since the last run, then runs every
    /// program (those part-run before too) until the programs on `side`
    /// have ended and their transfers are through; the others stay where
    /// virtual-time order left them, for the next call. Programs spawned
    /// on `side` start together at the latest clock of its cores (the end
    /// of what ran there before); programs spawned elsewhere at their
    /// core's clock. Returns the cycle the side ended at. [`Cell::finish`]
    /// runs what is left and reports the whole.
    pub fn run_side(&mut self, side: &Side) -> Result<Cycles, CellError> {
        let spes = self.m.borrow().spes.len();
        if side.spes.end > spes {
            return Err(CellError::Config(format!(
                "a side of SPEs {:?}: the machine has {spes}",
                side.spes
            )));
        }
        if self.since.is_none() {
            self.since = Some(self.align());
        }
        let tasks = std::mem::take(&mut self.tasks);
        {
            let mut m = self.m.borrow_mut();
            let start = (side.cores()).map(|c| m.cores[c].clock).max();
            for (core, task) in tasks {
                if self.running[core].is_some() {
                    return Err(CellError::Program {
                        core: machine::core_name(core),
                        msg: "a program was spawned where one still runs".into(),
                    });
                }
                if let Some(spe) = core.checked_sub(1) {
                    m.settle(std::iter::once(core), Cycles::ZERO);
                    m.spes[spe] = SpeState::new(&m.cfg);
                }
                if let Some(start) = start.filter(|_| side.holds(core)) {
                    m.settle(std::iter::once(core), start);
                }
                self.running[core] = Some(task);
            }
        }
        executor::execute(&self.m, &mut self.running, |m, slots| side.done(m, slots))?;
        let mut m = self.m.borrow_mut();
        let last_transfer = (side.spes.clone())
            .flat_map(|s| m.spes[s].tag_done.into_iter().chain(m.spes[s].barrier_done))
            .max();
        let end = (side.cores().map(|c| m.cores[c].clock))
            .chain(last_transfer)
            .max()
            .unwrap_or_default();
        m.settle(side.cores(), end);
        Ok(end)
    }

    /// Runs what [`Cell::run_side`] left, to completion, and reports the
    /// whole from the first of those runs.
    pub fn finish(&mut self) -> Result<RunReport, CellError> {
        let spes = self.m.borrow().spes.len();
        let end = self.run_side(&Side {
            ppe: true,
            spes: 0..spes,
        })?;
        let since = self.since.take().expect("run_side set it");
        Ok(self.report(since, end))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CellConfig, Ea, WaitMode};

    const CHUNK: u32 = 16384;

    /// A program that gets `chunks` chunks of `CHUNK` bytes from `from`,
    /// one after another, in a local store it fills almost whole.
    fn stream(cell: &mut Cell, spe: usize, from: Ea, chunks: u64) -> crate::Exit<Cycles> {
        cell.spawn_spe(spe, move |s| async move {
            let room = s.ls_alloc(12 * CHUNK, 128)?;
            for i in 0..chunks {
                s.get(room, from.offset(i % 12 * CHUNK as u64), CHUNK, 0)
                    .await?;
                s.wait_tags(1, WaitMode::All).await?;
            }
            Ok(s.now())
        })
    }

    fn machine() -> (Cell, Ea) {
        let cell = Cell::new(CellConfig {
            resident: true,
            ..CellConfig::ps3()
        })
        .unwrap();
        let data = cell
            .memory_mut()
            .alloc("data", 12 * CHUNK as u64, 128)
            .unwrap();
        (cell, data)
    }

    /// SPE 0 runs two programs one after the other (each fills most of the
    /// local store, so the second finds it empty again) while SPEs 1 to 5
    /// stream throughout: the side's programs follow each other, and they
    /// take longer than alone, because the others share the interface.
    fn two_on_one_side(others: bool) -> (Cycles, Cycles, Cycles) {
        let (mut cell, data) = machine();
        let side = Side {
            ppe: false,
            spes: 0..1,
        };
        if others {
            for spe in 1..6 {
                stream(&mut cell, spe, data, 400);
            }
        }
        let first = stream(&mut cell, 0, data, 100);
        let mid = cell.run_side(&side).unwrap();
        let second = stream(&mut cell, 0, data, 100);
        let end = cell.run_side(&side).unwrap();
        let first_end = first.take("first").unwrap();
        assert!(first_end <= mid);
        let second_end = second.take("second").unwrap();
        assert!(second_end > mid && second_end <= end);
        let report = cell.finish().unwrap();
        assert!(report.cycles >= end);
        (mid, end, report.cycles)
    }

    #[test]
    fn a_side_runs_programs_in_turn_beside_the_others() {
        let (mid, end, _) = two_on_one_side(false);
        // Alone, the two programs take the same time.
        assert_eq!(end.0 - mid.0, mid.0);
        let (cmid, cend, all) = two_on_one_side(true);
        assert!(cmid > mid && cend.0 - cmid.0 > mid.0, "{cmid:?} {cend:?}");
        // The same every run.
        assert_eq!(two_on_one_side(true), (cmid, cend, all));
    }

    #[test]
    fn a_program_spawned_where_one_runs_is_an_error() {
        let (mut cell, data) = machine();
        stream(&mut cell, 1, data, 400);
        stream(&mut cell, 0, data, 10);
        let side = Side {
            ppe: false,
            spes: 0..1,
        };
        cell.run_side(&side).unwrap();
        stream(&mut cell, 1, data, 10);
        let e = cell.run_side(&side).unwrap_err().to_string();
        assert!(e.contains("SPE 1") && e.contains("still runs"), "{e}");
        // And run() refuses to start over part-run programs.
        let (mut cell, data) = machine();
        stream(&mut cell, 1, data, 400);
        cell.run_side(&Side {
            ppe: true,
            spes: 0..0,
        })
        .unwrap();
        assert!(cell.run().unwrap_err().to_string().contains("finish"));
    }
}
