//! The SPE ray caster: each SPE takes tiles of rays from a
//! shared counter (a fetch-and-add on a lock line), gets the tile's rays,
//! casts each through the tree in main memory — nodes and triangle
//! records read through its [`SoftwareCache`] — and puts the tile's hits
//! back. The traversal is the host tracer's, step for step (the same
//! `bih::traverse` node step, culling and tie rule), so it answers as the
//! host tracer and brute force do.
//!
//! Each ray's traversal is a [`Walk`] that stops where it reads memory.
//! With one ray in flight an SPE waits for each miss; with several
//! (`rays_in_flight`, Benthin et al. 2006's "software hyperthreading") a
//! ray whose line is on its way yields to the next ray of the tile that
//! can go on, and the SPE waits only when none can.

use std::rc::Rc;

use glam::{DVec3, Vec3};

use super::packet::{self, PacketWalk};
use super::walk::{At, InLeaf, InNode, Reach, Read, Step};
use super::{CastRates, CellHit, CellRay, Job};
use crate::bih::{
    BihNode, Hit, Ray, RayStats, Shear, closer, descend, intersect_sheared, pop_bound,
    root_interval,
};
use crate::cell::{CellError, Spe, WaitMode};
use crate::scene::Triangle;
use crate::spe::software_cache::{CacheStats, SoftwareCache};

/// What one SPE did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SpeCast {
    /// Tiles it took from the shared counter.
    pub tiles: u64,
    pub rays: RayStats,
    pub cache: CacheStats,
    /// Times it went on with another ray while a miss was under way.
    pub switches: u64,
    /// Packets it cast as one (`--packet`), the nodes they visited, and
    /// the quads of rays they stepped there.
    pub packets: u64,
    pub packet_nodes: u64,
    pub packet_quads: u64,
}

/// The caster's program on one SPE, the `k`-th caster: what it did, and
/// the tiles it cast in order.
pub(super) async fn caster(
    spe: Spe,
    job: Rc<Job>,
    k: usize,
) -> Result<(SpeCast, Vec<u32>), CellError> {
    let in_flight = job.rays_in_flight;
    let mut cache = SoftwareCache::new(&spe, job.cache, job.rates.cache, in_flight)?;
    let line = spe.ls_alloc(128, 128)?;
    let tile = job.tile_rays;
    let rays_ls = spe.ls_alloc(tile * size_of::<CellRay>() as u32, 128)?;
    let hits_ls = spe.ls_alloc(tile * size_of::<CellHit>() as u32, 128)?;
    // Each ray in flight keeps its traversal stack (16 bytes an entry).
    spe.ls_alloc(in_flight * (job.max_depth + 2) * 16, 16)?;
    let tag = spe.tag("ray tiles")?;
    let mut done = SpeCast::default();
    let mut taken = Vec::new();
    let mut dealt = job.deal.as_ref().map(|d| d[k].iter());
    loop {
        let counted = spe.atomic_fetch_add_u32(line, job.counter, 1).await?;
        let t = match &mut dealt {
            None => counted,
            Some(tiles) => tiles.next().copied().unwrap_or(u32::MAX),
        } as u64;
        let first = t * tile as u64;
        if first >= job.ray_count {
            break;
        }
        done.tiles += 1;
        taken.push(t as u32);
        let n = (job.ray_count - first).min(tile as u64) as usize;
        let ray_bytes = (n * size_of::<CellRay>()) as u32;
        let ray_ea = job.rays.offset(first * size_of::<CellRay>() as u64);
        spe.get(rays_ls, ray_ea, ray_bytes, tag).await?;
        spe.wait_tag(tag).await?;
        let rays: Vec<CellRay> = spe.ls_read(rays_ls, n)?;
        let hits = cast_tile(&spe, &mut cache, &job, &rays, &mut done).await?;
        spe.ls_write(hits_ls, &hits)?;
        let hit_bytes = (n * size_of::<CellHit>()) as u32;
        let hit_ea = job.hits.offset(first * size_of::<CellHit>() as u64);
        spe.put(hits_ls, hit_ea, hit_bytes, tag).await?;
        // The next tile's hits reuse the buffer: this put must be done.
        spe.wait_tag(tag).await?;
    }
    done.cache = cache.stats;
    Ok((done, taken))
}

/// Where a ray in flight stands.
#[derive(Clone, Copy, PartialEq, Eq)]
enum State {
    /// It can go on (or start the tile's next ray).
    Ready,
    /// Its line is on its way by this tag group.
    Waiting(u32),
    /// Its line's set had no way to take it: it looks again after a fetch.
    Full,
    /// No ray left in the tile for it.
    Idle,
}

/// What a ray in flight casts: one ray, or a packet of them.
enum Walker {
    One(Walk),
    Pack(PacketWalk),
}

/// A tile's rays as the caster takes them: each `job.packet_rays`
/// consecutive rays one packet where they can share a traversal, else
/// (and without packets) ray by ray; by their first ray and count.
fn units(job: &Job, rays: &[Ray]) -> Vec<(usize, usize)> {
    let p = job.packet_rays as usize;
    let mut out = Vec::with_capacity(rays.len());
    for (g, group) in rays.chunks(p).enumerate() {
        if p > 1 && packet::coherent(group) {
            out.push((g * p, group.len()));
        } else {
            out.extend((0..group.len()).map(|i| (g * p + i, 1)));
        }
    }
    out
}

/// Casts one tile's rays, `job.rays_in_flight` rays or packets at a time:
/// the hits in the rays' order.
async fn cast_tile(
    spe: &Spe,
    cache: &mut SoftwareCache,
    job: &Job,
    rays: &[CellRay],
    done: &mut SpeCast,
) -> Result<Vec<CellHit>, CellError> {
    let k = job.rays_in_flight as usize;
    let rays: Vec<Ray> = rays.iter().map(CellRay::ray).collect();
    let units = units(job, &rays);
    let mut hits = vec![CellHit::of(None, 0); rays.len()];
    let mut walks: Vec<Option<Walker>> = (0..k).map(|_| None).collect();
    let mut state = vec![State::Ready; k];
    let (mut next, mut last) = (0usize, 0usize);
    loop {
        // The ray that ran last goes on if it can; else the next one that
        // can, in turn.
        let Some(c) = (0..k)
            .map(|i| (last + i) % k)
            .find(|&c| state[c] == State::Ready)
        else {
            if state.iter().all(|&s| s == State::Idle) {
                return Ok(hits);
            }
            let outstanding = cache.outstanding();
            if outstanding == 0 && !state.contains(&State::Full) {
                // Every waiting ray waits for a get under way: a ray
                // waiting for none would wait for ever.
                return Err(CellError::Program {
                    core: format!("SPE {}", spe.id()),
                    msg: "ray caster: rays wait, but no cache fetch is under way".into(),
                });
            }
            if outstanding != 0 {
                let arrived = spe.wait_tags(outstanding, WaitMode::Any).await?;
                cache.arrived(arrived);
                for s in &mut state {
                    if matches!(*s, State::Waiting(t) if arrived >> t & 1 == 1) {
                        *s = State::Ready;
                    }
                }
            }
            for s in &mut state {
                if *s == State::Full {
                    *s = State::Ready;
                }
            }
            continue;
        };
        if c != last {
            spe.compute(job.rates.ray_switch);
            done.switches += 1;
            last = c;
        }
        let walker = match &mut walks[c] {
            Some(w) => w,
            slot => {
                let Some(&(first, n)) = units.get(next) else {
                    state[c] = State::Idle;
                    continue;
                };
                next += 1;
                slot.insert(match n {
                    1 => Walker::One(Walk::new(first, rays[first], job.max_depth)),
                    _ => {
                        let pack = rays[first..first + n].to_vec();
                        Walker::Pack(PacketWalk::new(first, pack, job.max_depth))
                    }
                })
            }
        };
        let on = &mut Reach {
            spe,
            cache: &mut *cache,
            job,
            group: c as u32,
        };
        let step = match walker {
            Walker::One(w) => w.run(on).await?,
            Walker::Pack(p) => p.run(on).await?,
        };
        state[c] = match step {
            Step::Done(hit) => {
                match walker {
                    Walker::One(w) => {
                        let cost = (w.stats.nodes_visited + w.stats.triangles_tested) as u32;
                        hits[w.index] = CellHit::of(hit, cost);
                        done.rays += w.stats;
                    }
                    Walker::Pack(p) => {
                        for (i, (best, st)) in p.best.iter().zip(&p.stats).enumerate() {
                            let cost = (st.nodes_visited + st.triangles_tested) as u32;
                            hits[p.first + i] = CellHit::of(*best, cost);
                            done.rays += *st;
                        }
                        done.packets += 1;
                        done.packet_nodes += p.nodes;
                        done.packet_quads += p.quads;
                    }
                }
                walks[c] = None;
                State::Ready
            }
            Step::Wait(tag) => State::Waiting(tag),
            Step::Full => State::Full,
        };
    }
}

/// One ray's traversal: `Tracer::closest`'s, over the tree in main memory
/// through the cache, resumable where it reads memory.
struct Walk {
    /// The ray's place in its tile.
    index: usize,
    ray: Ray,
    inv: DVec3,
    /// The ray's shear for the watertight triangle test.
    shear: Shear,
    neg: [bool; 3],
    stack: Vec<(u32, f64, f64)>,
    best: Option<Hit>,
    best_t: f64,
    node: u32,
    tn: f64,
    tf: f64,
    at: At,
    read: Read,
    stats: RayStats,
}

impl Walk {
    fn new(index: usize, ray: Ray, max_depth: u32) -> Self {
        Walk {
            index,
            inv: DVec3::ONE / ray.dir,
            shear: Shear::of(&ray),
            neg: [
                ray.dir.x.is_sign_negative(),
                ray.dir.y.is_sign_negative(),
                ray.dir.z.is_sign_negative(),
            ],
            best_t: ray.tmax,
            ray,
            stack: Vec::with_capacity(max_depth as usize + 2),
            best: None,
            node: 0,
            tn: 0.0,
            tf: 0.0,
            at: At::Setup,
            read: Read::new(),
            stats: RayStats::default(),
        }
    }

    /// Goes on until the ray is done or waits for memory; a miss's get
    /// is started with the cache's tag group `group`.
    async fn run(&mut self, on: &mut Reach<'_>) -> Result<Step, CellError> {
        let (spe, job) = (on.spe, on.job);
        let r: &CastRates = &job.rates;
        loop {
            match self.at {
                At::Setup => {
                    spe.compute(r.ray_setup);
                    self.stats.rays += 1;
                    let Some((t0, t1)) = root_interval(&job.bounds, &self.ray, self.inv) else {
                        return Ok(Step::Done(None));
                    };
                    (self.node, self.tn, self.tf) = (0, t0, t1);
                    self.at = At::Node;
                }
                At::Node => {
                    self.stats.nodes_visited += 1;
                    spe.compute(r.node_step);
                    self.at = self.read.node_at(job, self.node);
                }
                At::NodeRead => match self.read.in_node(on).await? {
                    InNode::Stopped(stop) => return Ok(stop),
                    InNode::Leaf(at) => self.at = at,
                    InNode::Inner(nd) if !self.step(&nd) && !self.pop() => {
                        return Ok(Step::Done(self.best));
                    }
                    InNode::Inner(_) => {}
                },
                At::Leaf { .. } | At::IdRead { .. } | At::RecordRead { .. } => {
                    let (rec, k, end) = match self.read.in_leaf(self.at, on).await? {
                        InLeaf::Ended if !self.pop() => return Ok(Step::Done(self.best)),
                        InLeaf::Ended => continue,
                        InLeaf::Stopped(stop) => return Ok(stop),
                        InLeaf::Goes(at) => {
                            self.at = at;
                            continue;
                        }
                        InLeaf::Record { rec, k, end } => (rec, k, end),
                    };
                    spe.compute(r.triangle_test);
                    self.stats.triangles_tested += 1;
                    let tri = Triangle {
                        v: rec.v.map(Vec3::from_array),
                    };
                    let ray = &self.ray;
                    if let Some((t, u, v)) =
                        intersect_sheared(&tri, &self.shear, ray.tmin, self.best_t)
                        && closer(t, rec.id, self.best)
                    {
                        self.best = Some(Hit {
                            prim: rec.id,
                            t,
                            u,
                            v,
                        });
                        self.best_t = t;
                    }
                    self.at = At::Leaf { k: k + 1, end };
                }
            }
        }
    }

    /// The ray's step at inner node `nd`: on to the near child (keeping
    /// the far one where the ray enters it too) or to the far one; `false`
    /// when it enters neither.
    fn step(&mut self, nd: &BihNode) -> bool {
        let s = descend(nd, &self.ray, self.inv, self.neg, self.tn, self.tf);
        if s.go_near {
            if s.go_far {
                self.stack.push((s.far, s.far_tn, self.tf));
            }
            (self.node, self.tf) = (s.near, s.near_tf);
        } else if s.go_far {
            (self.node, self.tn) = (s.far, s.far_tn);
        } else {
            return false;
        }
        self.at = At::Node;
        true
    }

    /// Pops the next node that may still hold a closer hit; `false` when
    /// none is left.
    fn pop(&mut self) -> bool {
        while let Some((n, a, b)) = self.stack.pop() {
            let bound = pop_bound(self.best_t);
            if a <= bound {
                (self.node, self.tn, self.tf) = (n, a, b.min(bound));
                self.at = At::Node;
                return true;
            }
        }
        false
    }
}
