//! One option of a frame tried on a copy of the updater (`super::play`):
//! its update, the cast of the tree it leaves, and the two times as the
//! arrangement has them — one after the other (section 5's), or side by
//! side on one Cell (the paper's: [`super::one_cell`]).

use super::charge::Charged;
use super::{FrameConfig, FrameError, one_cell};
use crate::cast::{CastReport, cast_camera};
use crate::cell::CellConfig;
use crate::update::{Method, Move, UpdateReport, Updater};

/// A frame's update and render, each run on a Cell of its own.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Alone {
    pub update_ms: f64,
    pub render_ms: f64,
    pub frame_ms: f64,
    /// The render alone with the deal of tiles it had beside the update
    /// ([`one_cell::Beside::render_same_deal_ms`]).
    pub render_same_deal_ms: f64,
}

/// A frame's update and render ms as its arrangement has them: one after
/// the other, each as it ran (section 5's), or side by side on one Cell
/// (the paper's: [`one_cell`]).
pub(super) struct Times {
    pub update_ms: f64,
    pub render_ms: f64,
    pub beside: Option<one_cell::Beside>,
}

/// The [`Times`] of an attempt charged `c`; `changed`: the bytes the tree's
/// other copy lacks before it.
pub(super) fn times(
    a: &Attempt,
    c: &Charged,
    changed: u64,
    cam: &crate::render::Camera,
    cfg: &FrameConfig,
) -> Result<Times, FrameError> {
    if cfg.all_spes_build() {
        // The casters' switch, where the builders' program ran.
        return Ok(Times {
            update_ms: c.update_ms,
            render_ms: a.cast.run.ms + c.switch_ms,
            beside: None,
        });
    }
    let side = one_cell::UpdateSide {
        find_ms: c.find_ms,
        apply_ms: c.ppe_ms - c.find_ms,
        copy_bytes: if c.copy_ms > 0.0 { changed } else { 0 },
    };
    let b = one_cell::side_by_side(&a.updater, &side, cam, cfg)?;
    Ok(Times {
        update_ms: b.update_ms,
        render_ms: b.render_ms,
        beside: Some(b),
    })
}

/// One option tried on a copy of the updater: the updater after it, its
/// update's report, and the frame's cast.
pub(super) struct Attempt {
    pub updater: Updater,
    pub report: UpdateReport,
    pub cast: CastReport,
}

pub(super) fn attempt(
    u: &Updater,
    method: Method,
    moves: &[Move],
    cam: &crate::render::Camera,
    cfg: &FrameConfig,
    render_cell: &CellConfig,
) -> Result<Attempt, FrameError> {
    let mut updater = u.clone();
    updater.method = method;
    let report = updater.step(moves)?;
    let cast = cast_camera(
        &updater.bih,
        &updater.scene,
        cam,
        &cfg.cast,
        render_cell,
        updater.records,
    )?;
    Ok(Attempt {
        updater,
        report,
        cast,
    })
}
