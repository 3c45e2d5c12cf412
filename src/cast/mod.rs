//! Ray casting on the emulated Cell: the render half of DESIGN.md's "The
//! whole frame on the Cell" (the paper's ray tracer rendered on
//! the SPEs between tree updates, section 4). The tree's nodes (12 bytes
//! each), the triangle records as the build left them (48 bytes, each
//! with its triangle id: in the tree's leaf order, or in the scene's order
//! with a column of ids in leaf order, [`RecordOrder`]) and the rays (64
//! bytes) are in emulated main memory; every SPE runs `program`'s caster,
//! reading nodes, ids and triangles through a
//! [`SoftwareCache`](crate::spe::software_cache::SoftwareCache) in its
//! local store, and the hits (32 bytes) come back by DMA. The answers are
//! the host tracer's (`bih::Tracer`), ray for ray; the time is simulated
//! PS3 time, in the same currency as a build's.

mod casting;
mod packet;
mod program;
mod walk;

pub use crate::spe::software_cache::{CacheConfig, CacheRates, CacheStats};
pub use casting::Casting;
pub use program::SpeCast;

use glam::DVec3;

use crate::aabb::Aabb;
use crate::bih::{Bih, Hit, Ray, RayStats};
use crate::cell::{Cell, CellConfig, CellError, Ea, RunReport, Trace};
use crate::kernels::rates::RateOverrides;

mod rates;
use crate::render::Camera;
use crate::scene::Scene;
pub use crate::spe::layout::RecordOrder;
use crate::spe::layout::TriRecord;
pub use rates::CastRates;

/// A ray in main memory: 64 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CellRay {
    pub origin: [f64; 3],
    pub dir: [f64; 3],
    pub tmin: f64,
    pub tmax: f64,
}
const _: () = assert!(size_of::<CellRay>() == 64);

impl CellRay {
    fn of(r: &Ray) -> Self {
        CellRay {
            origin: r.origin.to_array(),
            dir: r.dir.to_array(),
            tmin: r.tmin,
            tmax: r.tmax,
        }
    }

    fn ray(&self) -> Ray {
        Ray {
            origin: DVec3::from_array(self.origin),
            dir: DVec3::from_array(self.dir),
            tmin: self.tmin,
            tmax: self.tmax,
        }
    }
}

/// A ray's answer in main memory: 32 bytes; `prim` is `u32::MAX` for a
/// miss; `cost` is nodes visited + triangles tested.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CellHit {
    pub prim: u32,
    pub cost: u32,
    pub t: f64,
    pub u: f64,
    pub v: f64,
}
const _: () = assert!(size_of::<CellHit>() == 32);

impl CellHit {
    fn of(hit: Option<Hit>, cost: u32) -> Self {
        match hit {
            Some(h) => CellHit {
                prim: h.prim,
                cost,
                t: h.t,
                u: h.u,
                v: h.v,
            },
            None => CellHit {
                prim: u32::MAX,
                cost,
                t: 0.0,
                u: 0.0,
                v: 0.0,
            },
        }
    }

    fn hit(&self) -> Option<Hit> {
        (self.prim != u32::MAX).then_some(Hit {
            prim: self.prim,
            t: self.t,
            u: self.u,
            v: self.v,
        })
    }
}

/// Which arithmetic the caster is charged for. The emulation computes in
/// `f64` either way (so that it answers exactly as the host tracer, at the
/// numerical extremes too); what changes is the SPU kernel whose time is
/// charged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Precision {
    /// Single-precision SIMD, as Cell ray tracers ran (Benthin et al.
    /// 2006): the default.
    Single,
    /// Double precision, as the emulated kernel computes: on the PS3's
    /// SPU a double-precision instruction issues once every 7 cycles.
    Double,
}

/// How the rays are cast.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct CastConfig {
    pub cache: CacheConfig,
    /// Rays a tile holds: an SPE takes a tile from the shared counter,
    /// gets its rays in one DMA and puts its hits in one (1 to 256).
    pub tile_rays: u32,
    /// The arithmetic charged.
    pub precision: Precision,
    /// Rays an SPE keeps in flight (1 to 16): with more than one, a ray
    /// whose line is on its way yields to another (Benthin et al.'s
    /// "software hyperthreading"); with one, the SPE waits for each miss.
    /// With packets, the packets (or lone rays) in flight.
    pub rays_in_flight: u32,
    /// Rays traced together as one packet: each `w × h` consecutive rays
    /// of a tile ([`cast_camera`] orders a camera's rays so that they are
    /// a block of the image); 1 × 1: every ray alone.
    pub packet: Packet,
    /// The code class and the rates moved by name (`--code`, `--rate`).
    #[serde(skip)]
    pub rates: RateOverrides,
}

/// A packet's shape, in rays: `w × h`, 1 to 8 each.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Packet {
    pub w: u32,
    pub h: u32,
}

impl Packet {
    /// Every ray alone.
    pub const SINGLE: Packet = Packet { w: 1, h: 1 };

    /// Rays a packet holds.
    pub fn rays(self) -> u32 {
        self.w * self.h
    }

    /// Reads `WxH` (each 1 to 8).
    pub fn parse(s: &str) -> Result<Packet, String> {
        let bad = || format!("--packet {s}: W×H rays, each 1 to 8 (e.g. 4x4)");
        let (w, h) = s.split_once(['x', 'X', '×']).ok_or_else(bad)?;
        let (w, h): (u32, u32) = (w.parse().map_err(|_| bad())?, h.parse().map_err(|_| bad())?);
        if !(1..=8).contains(&w) || !(1..=8).contains(&h) {
            return Err(bad());
        }
        Ok(Packet { w, h })
    }
}

impl std::fmt::Display for Packet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.w, self.h)
    }
}

impl CastConfig {
    pub const DEFAULT: CastConfig = CastConfig {
        cache: CacheConfig::SDK,
        tile_rays: 64,
        precision: Precision::Single,
        rays_in_flight: 1,
        packet: Packet { w: 4, h: 4 },
        rates: RateOverrides::PAPER,
    };

    /// This cast with the code class and rates of `rates` (a build's).
    pub fn with_rates(self, rates: &RateOverrides) -> Self {
        CastConfig {
            rates: *rates,
            ..self
        }
    }

    /// The most rays a tile holds: 256 rays are one 16 KiB get.
    pub const MAX_TILE_RAYS: u32 = 256;

    /// The most rays in flight: one tag group each, and an MFC queue
    /// holds 16 commands.
    pub const MAX_RAYS_IN_FLIGHT: u32 = 16;
}

/// What the SPEs read: where everything is, and how to cast.
pub(crate) struct Job {
    nodes: Ea,
    records: Ea,
    /// The ids in leaf order, where the records are in the scene's order.
    ids: Option<Ea>,
    rays: Ea,
    hits: Ea,
    /// The next tile's number, in its own lock line.
    counter: Ea,
    ray_count: u64,
    bounds: Aabb,
    max_depth: u32,
    tile_rays: u32,
    rays_in_flight: u32,
    /// Rays a packet holds (1: every ray alone).
    packet_rays: u32,
    cache: CacheConfig,
    rates: CastRates,
    /// The tiles each caster casts, in order, where they are dealt (a
    /// replay of another run's deal: [`Casting::launch_dealt`]); `None`:
    /// each takes the next from the counter.
    deal: Option<Vec<Vec<u32>>>,
}

/// What casting the rays on the Cell gave and cost.
#[derive(Clone, Debug)]
pub struct CastReport {
    /// Each ray's closest hit, in the rays' order.
    pub hits: Vec<Option<Hit>>,
    /// Each ray's nodes visited + triangles tested.
    pub costs: Vec<u32>,
    pub run: RunReport,
    /// What each SPE did, by SPE.
    pub spes: Vec<SpeCast>,
    /// The tiles each SPE cast, in the order it took them: the deal, which
    /// [`Casting::launch_dealt`] replays.
    pub deal: Vec<Vec<u32>>,
    /// The timeline, if the Cell's config asked for it.
    pub trace: Option<Trace>,
}

impl CastReport {
    /// Every SPE's ray statistics together.
    pub fn stats(&self) -> RayStats {
        let mut s = RayStats::default();
        for w in &self.spes {
            s += w.rays;
        }
        s
    }

    /// Every SPE's cache together.
    pub fn cache(&self) -> CacheStats {
        let mut s = CacheStats::default();
        for w in &self.spes {
            s += w.cache;
        }
        s
    }

    /// Rays per second of simulated time (`None` untimed).
    pub fn rays_per_s(&self) -> Option<f64> {
        (self.run.timed && self.run.ms > 0.0).then(|| self.hits.len() as f64 / (self.run.ms / 1e3))
    }

    /// The SPEs' shares of the run (mean over SPEs): busy, waiting for
    /// DMA, in the atomic unit; and the least and most busy SPE.
    pub fn shares(&self) -> Shares {
        let total = self.run.cycles.0.max(1) as f64;
        let spes = &self.run.cores[1..];
        let n = spes.len().max(1) as f64;
        let mean = |f: &dyn Fn(&crate::cell::CoreCounters) -> u64| {
            spes.iter().map(|(_, c)| f(c) as f64 / total).sum::<f64>() / n
        };
        let busy: Vec<f64> = (spes.iter())
            .map(|(_, c)| c.busy.0 as f64 / total)
            .collect();
        Shares {
            busy: mean(&|c| c.busy.0),
            dma_wait: mean(&|c| c.dma_wait.0),
            atomic: mean(&|c| c.atomic.0),
            busy_min: busy.iter().copied().fold(f64::INFINITY, f64::min),
            busy_max: busy.iter().copied().fold(0.0, f64::max),
        }
    }
}

/// Where the SPEs' time went ([`CastReport::shares`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Shares {
    pub busy: f64,
    pub dma_wait: f64,
    pub atomic: f64,
    pub busy_min: f64,
    pub busy_max: f64,
}

/// Room after each array, so that a fetch of whole lines (up to one 16 KiB
/// get) near its end stays inside it.
const TAIL: u64 = 16 * 1024;

/// Bytes of emulated main memory a cast takes: the tree's `nodes`, the
/// `triangles` (and, `order` [`RecordOrder::InputWithIds`], their ids),
/// the `rays` and their hits, the tile counter, each allocation padded and
/// aligned as [`cast_on_cell`] makes it. With `nodes` 0 and the records in
/// leaf order it is a lower bound, known before the tree is built.
pub fn memory_needed(nodes: usize, triangles: usize, rays: usize, order: RecordOrder) -> u64 {
    const ALIGN: u64 = 128;
    let ids = match order {
        RecordOrder::LeafOrder => 0,
        RecordOrder::InputWithIds => (triangles * 4) as u64 + TAIL,
    };
    let bytes = [
        (nodes * size_of::<crate::bih::BihNode>()) as u64 + TAIL,
        (triangles * size_of::<TriRecord>()) as u64 + TAIL,
        ids,
        (rays * size_of::<CellRay>()) as u64,
        (rays * size_of::<CellHit>()) as u64,
        128,
    ];
    bytes.iter().map(|b| b.next_multiple_of(ALIGN)).sum()
}

/// Casts `rays` through `bih` (built over `scene`) on a Cell configured by
/// `cell_cfg`, every SPE taking tiles: the closest hits, as the host
/// tracer gives them, and what it cost in simulated time.
///
/// The tree's triangles lie in main memory as its build left them
/// (`order`): the records in leaf order, or (`spe_morton`) in the scene's
/// order with a column of ids in leaf order, which the caster reads
/// through — each id a read through its cache — before the record it
/// names. Putting them there is the build's output, not the cast's work.
pub fn cast_on_cell(
    bih: &Bih,
    scene: &Scene,
    rays: &[Ray],
    cfg: &CastConfig,
    cell_cfg: &CellConfig,
    order: RecordOrder,
) -> Result<CastReport, CellError> {
    let mut cell = Cell::new(cell_cfg.clone())?;
    let casting = Casting::launch(&mut cell, (bih, scene, order), rays, cfg, 0..cell_cfg.spes)?;
    let run = cell.run()?;
    casting.land(&cell, run)
}

/// Casts `cam`'s rays (one a pixel) as [`cast_on_cell`] does, in the
/// order packets need: blocks of `cfg.packet`'s `w × h` pixels, block
/// after block along each band of `h` rows (with 1 × 1, the camera's
/// order). The answers come back in the camera's order
/// ([`Camera::rays`]). Where the image's sides are not whole blocks, the
/// blocks at its right and bottom edges are smaller and share packets
/// with their neighbours.
pub fn cast_camera(
    bih: &Bih,
    scene: &Scene,
    cam: &Camera,
    cfg: &CastConfig,
    cell_cfg: &CellConfig,
    order: RecordOrder,
) -> Result<CastReport, CellError> {
    in_camera_order(cam, cfg, |rays| {
        cast_on_cell(bih, scene, rays, cfg, cell_cfg, order)
    })
}

/// What `cast` makes of `cam`'s rays given in the order packets need (as
/// [`cast_camera`] gives them), its answers put back in the camera's order.
pub fn in_camera_order<E>(
    cam: &Camera,
    cfg: &CastConfig,
    cast: impl FnOnce(&[Ray]) -> Result<CastReport, E>,
) -> Result<CastReport, E> {
    let pixels = crate::render::block_order(cam.width, cam.height, cfg.packet.w, cfg.packet.h);
    let w = cam.width;
    let rays: Vec<Ray> = (pixels.iter()).map(|&i| cam.ray(i % w, i / w)).collect();
    let mut r = cast(&rays)?;
    let (mut hits, mut costs) = (vec![None; rays.len()], vec![0; rays.len()]);
    for (k, &i) in pixels.iter().enumerate() {
        (hits[i as usize], costs[i as usize]) = (r.hits[k], r.costs[k]);
    }
    (r.hits, r.costs) = (hits, costs);
    Ok(r)
}
