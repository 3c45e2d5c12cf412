//! A cast set up on a Cell: its inputs put in main memory and a caster
//! spawned on each SPE of a range (section 4's ray casting on the SPEs),
//! then its answers read back once the Cell has run. [`super::cast_on_cell`]
//! runs one on a Cell of its own; the frame loop runs one beside a
//! builder's programs on one Cell (the paper's arrangement).

use std::rc::Rc;

use super::program::{self, SpeCast};
use super::{CastConfig, CastRates, CastReport, RecordOrder, TAIL};
use super::{CellHit, CellRay, Job};
use crate::bih::{Bih, Ray};
use crate::cell::{Cell, CellError, Ea, Exit, Label, MainMemory, RunReport};
use crate::scene::Scene;
use crate::spe::layout::{self, TriRecord};

/// A cast whose casters are spawned.
pub struct Casting {
    exits: Vec<Exit<(SpeCast, Vec<u32>)>>,
    hits: Ea,
    count: usize,
}

impl Casting {
    /// Puts the tree `bih` over `scene` (its triangles as its build left
    /// them, `order`) and `rays` into `cell`'s main memory, and spawns a
    /// caster on each SPE of `spes`, every one taking tiles.
    pub fn launch(
        cell: &mut Cell,
        on: (&Bih, &Scene, RecordOrder),
        rays: &[Ray],
        cfg: &CastConfig,
        spes: std::ops::Range<usize>,
    ) -> Result<Casting, CellError> {
        Self::launch_dealt(cell, on, rays, cfg, spes, None)
    }

    /// [`Casting::launch`], the tiles dealt as `deal` says (each caster's,
    /// in order: another run's [`CastReport::deal`]) where it is given: each
    /// caster still takes from the counter as often (the same lock-line
    /// traffic) but casts the tile dealt to it. So a run beside other
    /// programs and one alone can be compared with the same work on each
    /// SPE, in the same order.
    pub fn launch_dealt(
        cell: &mut Cell,
        (bih, scene, order): (&Bih, &Scene, RecordOrder),
        rays: &[Ray],
        cfg: &CastConfig,
        spes: std::ops::Range<usize>,
        deal: Option<Vec<Vec<u32>>>,
    ) -> Result<Casting, CellError> {
        if !(1..=CastConfig::MAX_TILE_RAYS).contains(&cfg.tile_rays) {
            return Err(CellError::Config(format!(
                "{} rays a tile: 1 to {}",
                cfg.tile_rays,
                CastConfig::MAX_TILE_RAYS
            )));
        }
        if !(1..=CastConfig::MAX_RAYS_IN_FLIGHT).contains(&cfg.rays_in_flight) {
            return Err(CellError::Config(format!(
                "{} rays in flight: 1 to {}",
                cfg.rays_in_flight,
                CastConfig::MAX_RAYS_IN_FLIGHT
            )));
        }
        let p = cfg.packet;
        if !(1..=8).contains(&p.w)
            || !(1..=8).contains(&p.h)
            || !cfg.tile_rays.is_multiple_of(p.rays())
        {
            return Err(CellError::Config(format!(
                "packets of {p} rays: each side 1 to 8, and a tile's {} rays a whole number of packets",
                cfg.tile_rays
            )));
        }
        cfg.cache.sets().map_err(CellError::Config)?;
        assert_eq!(bih.prim_ids.len(), scene.len(), "tree and scene differ");
        let all = layout::records(scene);
        let records: Vec<TriRecord> = match order {
            RecordOrder::LeafOrder => bih.prim_ids.iter().map(|&p| all[p as usize]).collect(),
            RecordOrder::InputWithIds => all,
        };
        let label = |name: &str| Label::new("ray casting", name);
        let job = {
            let mut m = cell.memory_mut();
            let nodes = padded(&mut m, label("nodes"), &bih.nodes)?;
            let recs = padded(
                &mut m,
                label(match order {
                    RecordOrder::LeafOrder => "triangles in leaf order",
                    RecordOrder::InputWithIds => "triangles in the scene's order",
                }),
                &records,
            )?;
            let ids = match order {
                RecordOrder::LeafOrder => None,
                RecordOrder::InputWithIds => Some(padded(
                    &mut m,
                    label("triangle ids in leaf order"),
                    &bih.prim_ids,
                )?),
            };
            let cell_rays: Vec<CellRay> = rays.iter().map(CellRay::of).collect();
            let ray_ea = m.alloc_pod(label("rays"), &cell_rays, 128)?;
            let hits = m.alloc(
                label("hits"),
                (rays.len() * size_of::<CellHit>()) as u64,
                128,
            )?;
            let counter = m.alloc(label("tile counter"), 128, 128)?;
            Job {
                nodes,
                records: recs,
                ids,
                rays: ray_ea,
                hits,
                counter,
                ray_count: rays.len() as u64,
                bounds: bih.bounds,
                max_depth: bih.config.max_depth,
                tile_rays: cfg.tile_rays,
                rays_in_flight: cfg.rays_in_flight,
                packet_rays: cfg.packet.rays(),
                cache: cfg.cache,
                rates: CastRates::of(cfg.precision, &cfg.rates),
                deal,
            }
        };
        let (hits, count) = (job.hits, rays.len());
        let job = Rc::new(job);
        let exits = (spes.enumerate())
            .map(|(k, spe)| {
                let job = job.clone();
                cell.spawn_spe(spe, move |s| program::caster(s, job, k))
            })
            .collect();
        Ok(Casting { exits, hits, count })
    }

    /// The answers, once `cell` has run the casters (`run`: that run's
    /// report).
    pub fn land(self, cell: &Cell, run: RunReport) -> Result<CastReport, CellError> {
        let (spes, deal) = (self.exits.iter().enumerate())
            .map(|(i, e)| e.take(&format!("ray caster {i}")))
            .collect::<Result<Vec<_>, _>>()?
            .into_iter()
            .unzip();
        let out: Vec<CellHit> = cell.memory().read_pod(self.hits, self.count)?;
        Ok(CastReport {
            hits: out.iter().map(CellHit::hit).collect(),
            costs: out.iter().map(|h| h.cost).collect(),
            run,
            spes,
            deal,
            trace: cell.take_trace(),
        })
    }
}

/// `values` in main memory, their allocation padded by [`TAIL`] (a cache
/// line's get near the end stays inside it) and aligned to 128 bytes.
fn padded<T: bytemuck::Pod>(
    m: &mut MainMemory,
    label: Label,
    values: &[T],
) -> Result<Ea, CellError> {
    let at = m.alloc(label, size_of_val(values) as u64 + TAIL, 128)?;
    m.write_pod(at, values)?;
    Ok(at)
}
