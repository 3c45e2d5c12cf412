//! The SPE ray caster (issue 27): each SPE takes tiles of rays from a
//! shared counter (a fetch-and-add on a lock line), gets the tile's rays,
//! casts each through the tree in main memory — nodes and triangle
//! records read through its [`SoftwareCache`] — and puts the tile's hits
//! back. The traversal is the host tracer's, step for step (the same
//! `bih::traverse` node step, culling and tie rule), so it answers as the
//! host tracer and brute force do.

use std::rc::Rc;

use glam::{DVec3, Vec3};

use super::cache::{CacheStats, SoftwareCache};
use super::{CastRates, CellHit, CellRay, Job};
use crate::bih::{
    BihNode, Hit, Ray, RayStats, closer, descend, intersect_triangle, pop_bound, root_interval,
};
use crate::cell::{CellError, Spe};
use crate::scene::Triangle;
use crate::strategy::machinery::layout::TriRecord;

/// What one SPE did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SpeCast {
    /// Tiles it took from the shared counter.
    pub tiles: u64,
    pub rays: RayStats,
    pub cache: CacheStats,
}

/// The caster's program on one SPE.
pub(super) async fn caster(spe: Spe, job: Rc<Job>) -> Result<SpeCast, CellError> {
    let mut cache = SoftwareCache::new(&spe, job.cache, job.rates)?;
    let line = spe.ls_alloc(128, 128)?;
    let tile = job.tile_rays;
    let rays_ls = spe.ls_alloc(tile * size_of::<CellRay>() as u32, 128)?;
    let hits_ls = spe.ls_alloc(tile * size_of::<CellHit>() as u32, 128)?;
    let tag = spe.tag("ray tiles")?;
    let mut done = SpeCast::default();
    loop {
        let t = spe.atomic_fetch_add_u32(line, job.counter, 1).await? as u64;
        let first = t * tile as u64;
        if first >= job.ray_count {
            break;
        }
        done.tiles += 1;
        let n = (job.ray_count - first).min(tile as u64) as usize;
        let ray_bytes = (n * size_of::<CellRay>()) as u32;
        let ray_ea = job.rays.offset(first * size_of::<CellRay>() as u64);
        spe.get(rays_ls, ray_ea, ray_bytes, tag).await?;
        spe.wait_tag(tag).await?;
        let rays: Vec<CellRay> = spe.ls_read(rays_ls, n)?;
        let mut hits = Vec::with_capacity(n);
        for r in &rays {
            let mut stats = RayStats::default();
            let hit = cast(&spe, &mut cache, &job, &r.ray(), &mut stats).await?;
            let cost = (stats.nodes_visited + stats.triangles_tested) as u32;
            hits.push(CellHit::of(hit, cost));
            done.rays += stats;
        }
        spe.ls_write(hits_ls, &hits)?;
        let hit_bytes = (n * size_of::<CellHit>()) as u32;
        let hit_ea = job.hits.offset(first * size_of::<CellHit>() as u64);
        spe.put(hits_ls, hit_ea, hit_bytes, tag).await?;
        // The next tile's hits reuse the buffer: this put must be done.
        spe.wait_tag(tag).await?;
    }
    done.cache = cache.stats;
    Ok(done)
}

/// The closest hit of `ray`: `Tracer::closest`'s traversal over the tree
/// in main memory, through the cache.
async fn cast(
    spe: &Spe,
    cache: &mut SoftwareCache,
    job: &Job,
    ray: &Ray,
    stats: &mut RayStats,
) -> Result<Option<Hit>, CellError> {
    let r: &CastRates = &job.rates;
    spe.compute(r.ray_setup);
    stats.rays += 1;
    let inv = DVec3::ONE / ray.dir;
    let Some((t0, t1)) = root_interval(&job.bounds, ray, inv) else {
        return Ok(None);
    };
    let neg = [
        ray.dir.x.is_sign_negative(),
        ray.dir.y.is_sign_negative(),
        ray.dir.z.is_sign_negative(),
    ];
    let mut stack: Vec<(u32, f64, f64)> = Vec::with_capacity(job.max_depth as usize + 2);
    let mut best: Option<Hit> = None;
    let mut best_t = ray.tmax;
    let (mut node, mut tn, mut tf) = (0u32, t0, t1);
    let mut buf = [0u8; size_of::<TriRecord>()];
    loop {
        stats.nodes_visited += 1;
        spe.compute(r.node_step);
        let nd: BihNode = {
            let at = job.nodes.offset(node as u64 * size_of::<BihNode>() as u64);
            cache.read(spe, at, &mut buf[..12]).await?;
            bytemuck::pod_read_unaligned(&buf[..12])
        };
        if nd.is_leaf() {
            let (first, count) = nd.leaf_range();
            for k in first..first + count {
                let at = job.records.offset(k as u64 * size_of::<TriRecord>() as u64);
                cache.read(spe, at, &mut buf).await?;
                let rec: TriRecord = bytemuck::pod_read_unaligned(&buf);
                spe.compute(r.triangle_test);
                stats.triangles_tested += 1;
                let tri = Triangle {
                    v: rec.v.map(Vec3::from_array),
                };
                if let Some((t, u, v)) = intersect_triangle(&tri, ray, ray.tmin, best_t)
                    && closer(t, rec.id, best)
                {
                    best = Some(Hit {
                        prim: rec.id,
                        t,
                        u,
                        v,
                    });
                    best_t = t;
                }
            }
        } else {
            let s = descend(&nd, ray, inv, neg, tn, tf);
            if s.go_near {
                if s.go_far {
                    stack.push((s.far, s.far_tn, tf));
                }
                (node, tf) = (s.near, s.near_tf);
                continue;
            } else if s.go_far {
                (node, tn) = (s.far, s.far_tn);
                continue;
            }
        }
        // Pop the next node that may still hold a closer hit.
        loop {
            let Some((n, a, b)) = stack.pop() else {
                return Ok(best);
            };
            let bound = pop_bound(best_t);
            if a <= bound {
                (node, tn, tf) = (n, a, b.min(bound));
                break;
            }
        }
    }
}
