//! The moved triangles found by the SPEs while the rebuild streams them
//! (`--find-moved spe`), beside the paper's search on the PPE (section 3:
//! after Algorithm 1, the PPE scans the enclosing node's interval by
//! geometry id). A local update rebuilds the whole interval, so its SPEs
//! stream every record of it anyway: each record's geometry id is tested
//! against a bitmap of the moved geometries in the local store, and a
//! moved one is replaced in the stream by its new record, got by DMA from
//! the moved records the application wrote. Charged: the test a record
//! (`KernelRates::spe_find_slot`), the replacement a moved record
//! (`spe_find_moved`), and the moved records' transfers, on the build's
//! SPEs, before its own work (the stream itself is the build's). The deep
//! update's descent needs the moved slots before anything is built, so it
//! scans on the PPE either way.

use serde::Serialize;

use crate::cell::{Cell, CellConfig, CellError, Label, WaitMode};
use crate::kernels::rates::RateOverrides;
use crate::spe::layout::TriRecord;

/// Where an update finds the moved triangles of the enclosing interval.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FindMoved {
    /// The paper's: the PPE scans the interval by geometry id.
    #[default]
    Ppe,
    /// The SPEs, as the rebuild streams the interval (local updates).
    Spe,
}

impl FindMoved {
    pub const ALL: [FindMoved; 2] = [FindMoved::Ppe, FindMoved::Spe];

    pub fn name(self) -> &'static str {
        match self {
            FindMoved::Ppe => "ppe",
            FindMoved::Spe => "spe",
        }
    }

    pub fn from_name(name: &str) -> Option<FindMoved> {
        FindMoved::ALL.into_iter().find(|f| f.name() == name)
    }
}

/// The SPEs' share of a search: the interval's records tested, and the
/// moved ones replaced, by the SPEs that streamed the interval (the
/// rebuild's).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SpeFind {
    pub slots: u64,
    pub moved: u64,
    pub spes: usize,
}

/// Bytes of one transfer of moved records.
const CHUNK: u64 = 16 * 1024;

/// Spawns the search on SPEs `0 .. work.spes` of `cell`: each tests its
/// share of the slots and gets and puts in place its share of the moved
/// records.
pub fn spawn(cell: &mut Cell, work: SpeFind, rates: &RateOverrides) -> Result<(), CellError> {
    let (k, spes) = (rates.kernels(), work.spes.max(1));
    let bytes = (work.moved * size_of::<TriRecord>() as u64).next_multiple_of(128);
    let moved_at = match bytes {
        0 => None,
        _ => Some(cell.memory_mut().alloc(
            Label::new("update", "moved triangles' records"),
            bytes,
            128,
        )?),
    };
    let chunks = bytes.div_ceil(CHUNK);
    for spe in 0..spes {
        let share = |n: u64| n / spes as u64 + u64::from((spe as u64) < n % spes as u64);
        let (slots, moved) = (share(work.slots), share(work.moved));
        let mine: Vec<u64> = (spe as u64..chunks).step_by(spes).collect();
        cell.spawn_spe(spe, move |s| async move {
            s.compute_items(k.spe_find_slot, slots);
            s.compute_items(k.spe_find_moved, moved);
            if let Some(at) = moved_at {
                let buf = s.ls_alloc(CHUNK as u32, 128)?;
                for c in mine {
                    let size = (bytes - c * CHUNK).min(CHUNK) as u32;
                    s.get(buf, at.offset(c * CHUNK), size, 0).await?;
                    s.wait_tags(1, WaitMode::All).await?;
                }
            }
            Ok(())
        });
    }
    Ok(())
}

/// The search run alone on a Cell configured by `cfg`: its simulated ms
/// and the bytes it moved.
pub fn alone(
    work: SpeFind,
    cfg: &CellConfig,
    rates: &RateOverrides,
) -> Result<(f64, u64), CellError> {
    let mut cell = Cell::new(cfg.clone())?;
    spawn(&mut cell, work, rates)?;
    let run = cell.run()?;
    let bytes = (run.cores.iter())
        .map(|(_, c)| c.bytes_get + c.bytes_put)
        .sum();
    Ok((run.ms, bytes))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::rates::{Code, KernelRates};

    /// The search costs its records' tests and replacements, shared by the
    /// SPEs, and the moved records' transfers; tuned code is cheaper.
    #[test]
    fn the_search_is_its_tests_and_replacements_shared_by_the_spes() {
        let cfg = CellConfig {
            resident: true,
            ..CellConfig::ps3().with_spes(1)
        };
        let rates = RateOverrides::default();
        let work = SpeFind {
            slots: 100_000,
            moved: 0,
            spes: 1,
        };
        let (ms, bytes) = alone(work, &cfg, &rates).unwrap();
        let k = KernelRates::PS3;
        let want = (k.spe_find_slot.0 * 100_000) as f64 / cfg.cost.clock_hz * 1e3;
        assert!((ms - want).abs() < 1e-9 && bytes == 0, "{ms} vs {want}");
        let six = SpeFind { spes: 6, ..work };
        let six = alone(six, &cfg.clone().with_spes(6), &rates).unwrap().0;
        assert!((six * 6.0 / ms - 1.0).abs() < 0.01, "{six} vs {ms}");
        let moved = SpeFind {
            moved: 2000,
            ..work
        };
        let (with, bytes) = alone(moved, &cfg, &rates).unwrap();
        assert_eq!(bytes, (2000 * 48u64).next_multiple_of(128));
        assert!(with > ms + (k.spe_find_moved.0 * 2000) as f64 / cfg.cost.clock_hz * 1e3);
        let tuned = alone(work, &cfg, &rates.with_code(Code::Tuned)).unwrap().0;
        assert!(tuned < ms / 3.0, "{tuned} vs {ms}");
    }
}
