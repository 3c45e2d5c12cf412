//! The paper's arrangement on one emulated Cell (section 4: one SPE
//! updates the tree while the other SPEs render): a frame's update runs on
//! the PPE and SPEs `0 .. b` — the PPE's search, the copy into the tree's
//! other copy, the SPEs' search where they make it, its builds one after
//! another ([`Updater::builds`]), the PPE's graft — while the casters render on SPEs `b .. n`, in one virtual
//! time, so that the two sides meet at the memory interface, the EIB and
//! the lock lines as on the hardware ([`crate::cell::Side`]). The builds
//! run again here as the update ran them alone, and each must give the
//! same tree (its fingerprint), as simulated time never changes a tree.
//!
//! The casters read the tree the update made, as the frame loop pairs a
//! frame's update with the render of its tree (in steady state the render
//! of one tree overlaps the update that makes the next; the two differ by
//! one frame's moves, not in kind).

use crate::cast::{CastReport, Casting, in_camera_order};
use crate::cell::{Cell, CellConfig, CellError, Cycles, Side, WaitMode};
use crate::render::Camera;
use crate::strategy::{self, On};
use crate::update::Updater;
use crate::update::builds::{fingerprint, sub_scene};

use super::{FrameConfig, FrameError};

/// A frame of the paper's arrangement run on one Cell: the update's and
/// the render's simulated ms, each from the frame's start, and the cast.
pub struct Beside {
    pub update_ms: f64,
    pub render_ms: f64,
    /// The casters alone on the same Cell with the same deal of tiles as
    /// beside the update (each SPE the same tiles in the same order):
    /// what the render beside is never faster than. The render alone with
    /// its own deal may be slower or faster than either (the tiles' order
    /// moves the cache's hits).
    pub render_same_deal_ms: f64,
    pub cast: CastReport,
}

/// The one-Cell runs' timelines of a frame loop whose Cell keeps a trace
/// (the paper's arrangement), each placed at its frame's start.
pub(super) struct Timeline {
    pub trace: Option<crate::cell::Trace>,
    frame_start_ms: f64,
    hz: f64,
}

impl Timeline {
    pub fn of(cfg: &FrameConfig) -> Self {
        let cell = &cfg.build.cell;
        let hz = cell.cost.clock_hz;
        Timeline {
            trace: (cell.trace && !cfg.all_spes_build())
                .then(|| crate::cell::Trace::empty(cell.spes, hz)),
            frame_start_ms: 0.0,
            hz,
        }
    }

    /// A frame's one-Cell run, if it kept a timeline.
    pub fn add(&mut self, run: Option<crate::cell::Trace>) {
        if let (Some(t), Some(run)) = (&mut self.trace, run) {
            t.append(
                run,
                Cycles((self.frame_start_ms * self.hz / 1e3).round() as u64),
            );
        }
    }

    /// The next frame starts `frame_ms` later.
    pub fn next_frame(&mut self, frame_ms: f64) {
        self.frame_start_ms += frame_ms;
    }
}

/// What the update side does beside its builds: the PPE's search before
/// them and its graft after (simulated ms, as [`crate::update::ppe`]
/// prices them), and the bytes copied into the tree's other copy first.
pub struct UpdateSide {
    pub find_ms: f64,
    pub apply_ms: f64,
    pub copy_bytes: u64,
}

/// Bytes of one transfer of the copy into the tree's other copy.
const COPY_CHUNK: u32 = 16 * 1024;

/// Runs the update `u` made last (its builds, and `side`) on the PPE and
/// the frame's `build_spes` SPEs while the others cast `cam`'s rays
/// through the tree it left.
pub fn side_by_side(
    u: &Updater,
    side: &UpdateSide,
    cam: &Camera,
    cfg: &FrameConfig,
) -> Result<Beside, FrameError> {
    let b = cfg.build_spes;
    let n = cfg.spes();
    let mut cell = Cell::new(CellConfig {
        resident: true,
        ..cfg.build.cell.clone()
    })?;
    let hz = cfg.build.cell.cost.clock_hz;
    let cycles = |ms: f64| Cycles((ms * hz / 1e3).round() as u64);
    let builder = Side {
        ppe: true,
        spes: 0..b,
    };
    let mut update_end = Cycles::ZERO;
    let mut casting = None;
    let mut same_deal_ms = 0.0;
    let cast = in_camera_order(cam, &cfg.cast, |rays| -> Result<CastReport, FrameError> {
        let on_cell = (&u.bih, &u.scene, u.records);
        casting = Some(Casting::launch(&mut cell, on_cell, rays, &cfg.cast, b..n)?);
        // The PPE's search (Algorithm 1, the scan, the descent).
        let find = cycles(side.find_ms);
        cell.spawn_ppe(move |ppe| async move {
            ppe.compute(find);
            Ok(())
        });
        cell.run_side(&builder)?;
        copy(&mut cell, side.copy_bytes, b)?;
        cell.run_side(&builder)?;
        // The SPEs' search of the moved triangles (`--find-moved spe`).
        if let Some(work) = u.spe_find {
            crate::update::spe_find::spawn(&mut cell, work, &cfg.build.rates)?;
            cell.run_side(&builder)?;
        }
        for log in &u.builds {
            let whole;
            let scene = match &log.ids {
                None => &u.scene,
                Some(ids) => {
                    whole = sub_scene(&u.scene, ids).map_err(crate::update::UpdateError::from)?;
                    &whole
                }
            };
            let spawn = (cfg.build.builder.spawn()).expect("the frame's builder is emulated");
            let on = On {
                spes: b,
                knobs: &cfg.build.knobs,
                rates: &cfg.build.rates,
            };
            let launched = strategy::launch(spawn, &mut cell, scene, (log.region, &log.cfg), &on)?;
            cell.run_side(&builder)?;
            let o = (launched.readback)()?;
            let bih = strategy::land(
                &cell,
                &o,
                scene.len(),
                launched.triangles,
                (log.region, &log.cfg),
            )?;
            if fingerprint(&bih) != log.fingerprint {
                return Err(FrameError::Cell(CellError::Program {
                    core: "frame".into(),
                    msg: format!(
                        "a build of {} triangles beside the casters gave another tree than alone: \
                         simulated time must never change a tree",
                        scene.len()
                    ),
                }));
            }
        }
        // The PPE's graft.
        let apply = cycles(side.apply_ms);
        cell.spawn_ppe(move |ppe| async move {
            ppe.compute(apply);
            Ok(())
        });
        update_end = cell.run_side(&builder)?;
        let render_end = cell.run_side(&Side {
            ppe: false,
            spes: b..n,
        })?;
        let run = cell.finish()?;
        let mut r = casting.take().expect("launched").land(&cell, run)?;
        r.run.cycles = render_end;
        r.run.ms = render_end.ms(hz);
        same_deal_ms = alone_with_deal(cfg, on_cell, rays, &r)?;
        Ok(r)
    })?;
    Ok(Beside {
        update_ms: update_end.ms(hz),
        render_ms: cast.run.ms,
        render_same_deal_ms: same_deal_ms,
        cast,
    })
}

/// The casters of `beside` run again alone on a Cell like it (the same
/// SPEs, nothing else running), each casting the tiles it took beside the
/// update in the same order: their simulated ms.
fn alone_with_deal(
    cfg: &FrameConfig,
    on_cell: (
        &crate::bih::Bih,
        &crate::scene::Scene,
        crate::cast::RecordOrder,
    ),
    rays: &[crate::bih::Ray],
    beside: &CastReport,
) -> Result<f64, FrameError> {
    let mut cell = Cell::new(CellConfig {
        resident: true,
        trace: false,
        ..cfg.build.cell.clone()
    })?;
    let spes = cfg.build_spes..cfg.spes();
    let deal = Some(beside.deal.clone());
    let casting = Casting::launch_dealt(&mut cell, on_cell, rays, &cfg.cast, spes, deal)?;
    let run = cell.run()?;
    Ok(casting.land(&cell, run)?.run.ms)
}

/// Spawns on SPEs `0 .. spes` the copy of `bytes` into the tree's other
/// copy: each SPE gets its share through its local store, a chunk at a
/// time, and puts it back (two buffers: the get of one chunk overlaps the
/// put of the one before).
fn copy(cell: &mut Cell, bytes: u64, spes: usize) -> Result<(), CellError> {
    if bytes == 0 {
        return Ok(());
    }
    let padded = bytes.next_multiple_of(128);
    let (from, to) = {
        let mut m = cell.memory_mut();
        let label = |what| crate::cell::Label::new("frame", what);
        (
            m.alloc(label("tree, as the casters read it"), padded, 128)?,
            m.alloc(label("tree's other copy"), padded, 128)?,
        )
    };
    let chunks = padded.div_ceil(COPY_CHUNK as u64);
    for spe in 0..spes {
        let mine: Vec<u64> = (spe as u64..chunks).step_by(spes).collect();
        cell.spawn_spe(spe, move |s| async move {
            let bufs = [s.ls_alloc(COPY_CHUNK, 128)?, s.ls_alloc(COPY_CHUNK, 128)?];
            for (k, &c) in mine.iter().enumerate() {
                let (buf, tag) = (bufs[k % 2], (k % 2) as u32);
                let at = c * COPY_CHUNK as u64;
                let size = (padded - at).min(COPY_CHUNK as u64) as u32;
                // The buffer's last put is through before it is filled.
                s.wait_tags(1 << tag, WaitMode::All).await?;
                s.get(buf, from.offset(at), size, tag).await?;
                s.wait_tags(1 << tag, WaitMode::All).await?;
                s.put(buf, to.offset(at), size, tag).await?;
            }
            s.wait_tags(0b11, WaitMode::All).await?;
            Ok(())
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The copy simulated alone, on one SPE and on six, is within 5 % of
    /// the price the frame puts on it alone
    /// ([`super::super::charge::copy_ms`]: the bytes twice through the
    /// memory interface).
    #[test]
    fn the_copy_simulated_alone_is_near_its_price() {
        let bytes = 1 << 20;
        let cfg = CellConfig {
            resident: true,
            ..CellConfig::ps3()
        };
        let priced = super::super::charge::copy_ms(bytes, &cfg);
        for spes in [1, 6] {
            let mut cell = Cell::new(cfg.clone()).unwrap();
            copy(&mut cell, bytes, spes).unwrap();
            let ms = cell.run().unwrap().ms;
            assert!(
                (ms / priced - 1.0).abs() < 0.05,
                "{spes} SPEs: {ms} vs {priced}"
            );
        }
    }
}
