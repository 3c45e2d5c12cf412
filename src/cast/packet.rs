//! Packets of coherent rays on the SPE (Benthin, Wald, Scherbaum &
//! Friedrich, "Ray Tracing on the Cell Processor", RT 2006): the rays of a
//! packet share one traversal — one node read through the software cache
//! for all of them, the SPU's 4-wide SIMD over four rays at a time — and
//! each ray keeps its own interval and its own active bit, so a node none
//! of its rays needs is never visited and a ray is tested only where its
//! own traversal would go. A packet whose rays' directions differ in sign
//! on some axis (their near children differ) is cast ray by ray.
//!
//! Each ray answers exactly as the single-ray walk does, and with the same
//! cost: it is active at a node exactly when its own walk visits that node
//! with that interval (the same near-first order, the same pop bound), so
//! its hit, its nodes visited and its triangles tested are the single
//! ray's (tested against the single-ray caster and brute force).

use glam::{DVec3, Vec3};

use super::CastRates;
use super::walk::{At, InLeaf, InNode, Reach, Read, Step};
use crate::bih::{
    BihNode, Hit, Ray, RayStats, Shear, closer, descend, pop_bound, root_interval, test_sheared,
};
use crate::cell::CellError;
use crate::scene::Triangle;
use crate::spe::layout::TriRecord;

/// Whether `rays` can share one traversal: every direction has the same
/// sign on each axis, so every ray has the same near child at every node.
pub(super) fn coherent(rays: &[Ray]) -> bool {
    let sign = |r: &Ray| r.dir.to_array().map(f64::is_sign_negative);
    rays.iter().all(|r| sign(r) == sign(&rays[0]))
}

/// A node kept for later and the rays that will enter it (each ray's
/// entry checked against its best hit when it is taken, as a single ray's
/// stack entry is); their intervals follow in [`PacketWalk::kept`].
#[derive(Clone, Copy)]
struct Entry {
    node: u32,
    rays: u64,
}

/// One packet's traversal, resumable where it reads memory.
pub(super) struct PacketWalk {
    /// The packet's first ray's place in its tile.
    pub first: usize,
    rays: Vec<Ray>,
    inv: Vec<DVec3>,
    /// Each ray's shear for the watertight triangle test.
    shears: Vec<Shear>,
    /// The quads (bit `q`: rays `4q .. 4q + 4`) whose rays' shears
    /// permute the axes differently: their triangle vertices are picked
    /// lane by lane.
    mixed: u64,
    neg: [bool; 3],
    /// Each ray's interval at the current node.
    tn: Vec<f64>,
    tf: Vec<f64>,
    pub best: Vec<Option<Hit>>,
    best_t: Vec<f64>,
    pub stats: Vec<RayStats>,
    /// The rays active at the current node.
    mask: u64,
    stack: Vec<Entry>,
    /// Each entry's intervals, one per ray of the packet.
    kept: Vec<(f64, f64)>,
    node: u32,
    at: At,
    read: Read,
    /// Nodes the packet visited and the quads of rays it stepped there.
    pub nodes: u64,
    pub quads: u64,
}

impl PacketWalk {
    /// The walk of `rays` (coherent: [`coherent`]), the first of them at
    /// place `first` of the tile.
    pub fn new(first: usize, rays: Vec<Ray>, max_depth: u32) -> Self {
        let n = rays.len();
        let shears: Vec<Shear> = rays.iter().map(Shear::of).collect();
        let mut mixed = 0u64;
        for (q, quad) in shears.chunks(4).enumerate() {
            let differ = quad.iter().any(|s| s.axes() != quad[0].axes());
            mixed |= (differ as u64) << q;
        }
        PacketWalk {
            first,
            inv: rays.iter().map(|r| DVec3::ONE / r.dir).collect(),
            shears,
            mixed,
            neg: rays[0].dir.to_array().map(f64::is_sign_negative),
            tn: vec![0.0; n],
            tf: vec![0.0; n],
            best: vec![None; n],
            best_t: rays.iter().map(|r| r.tmax).collect(),
            stats: vec![RayStats::default(); n],
            rays,
            mask: 0,
            stack: Vec::with_capacity(max_depth as usize + 2),
            kept: Vec::with_capacity((max_depth as usize + 2) * n),
            node: 0,
            at: At::Setup,
            read: Read::new(),
            nodes: 0,
            quads: 0,
        }
    }

    /// The active rays of `mask`, by their place in the packet.
    fn each(mask: u64) -> impl Iterator<Item = usize> {
        (0..64).filter(move |i| mask >> i & 1 == 1)
    }

    /// Quads of four rays (in the packet's order) with a ray in `mask`:
    /// the SIMD steps a node or a triangle takes.
    fn quads_of(&self, mask: u64) -> u64 {
        (0..self.rays.len().div_ceil(4))
            .filter(|q| mask >> (4 * q) & 0xF != 0)
            .count() as u64
    }

    /// Of the quads with a ray in `mask`, those whose rays' axes differ.
    fn mixed_quads(&self, mask: u64) -> u64 {
        (0..self.rays.len().div_ceil(4))
            .filter(|q| mask >> (4 * q) & 0xF != 0 && self.mixed >> q & 1 == 1)
            .count() as u64
    }

    /// Goes on until every ray is done (`Step::Done`, the hits in
    /// [`PacketWalk::best`]) or the packet waits for memory.
    pub async fn run(&mut self, on: &mut Reach<'_>) -> Result<Step, CellError> {
        let (spe, job) = (on.spe, on.job);
        let r: &CastRates = &job.rates;
        loop {
            match self.at {
                At::Setup => {
                    let n = self.rays.len();
                    spe.compute_items(r.packet_setup_quad, n.div_ceil(4) as u64);
                    for (i, ray) in self.rays.iter().enumerate() {
                        self.stats[i].rays += 1;
                        if let Some((t0, t1)) = root_interval(&job.bounds, ray, self.inv[i]) {
                            (self.tn[i], self.tf[i]) = (t0, t1);
                            self.mask |= 1 << i;
                        }
                    }
                    if self.mask == 0 {
                        return Ok(Step::Done(None));
                    }
                    self.node = 0;
                    self.at = At::Node;
                }
                At::Node => {
                    for i in Self::each(self.mask) {
                        self.stats[i].nodes_visited += 1;
                    }
                    let q = self.quads_of(self.mask);
                    spe.compute(r.packet_node);
                    spe.compute_items(r.packet_node_quad, q);
                    (self.nodes, self.quads) = (self.nodes + 1, self.quads + q);
                    self.at = self.read.node_at(job, self.node);
                }
                At::NodeRead => match self.read.in_node(on).await? {
                    InNode::Stopped(stop) => return Ok(stop),
                    InNode::Leaf(at) => self.at = at,
                    InNode::Inner(nd) => {
                        if !self.step(&nd) && !self.pop() {
                            return Ok(Step::Done(None));
                        }
                    }
                },
                At::Leaf { .. } | At::IdRead { .. } | At::RecordRead { .. } => {
                    let (rec, k, end) = match self.read.in_leaf(self.at, on).await? {
                        InLeaf::Ended if !self.pop() => return Ok(Step::Done(None)),
                        InLeaf::Ended => continue,
                        InLeaf::Stopped(stop) => return Ok(stop),
                        InLeaf::Goes(at) => {
                            self.at = at;
                            continue;
                        }
                        InLeaf::Record { rec, k, end } => (rec, k, end),
                    };
                    spe.compute(r.packet_triangle);
                    spe.compute_items(r.packet_triangle_quad, self.quads_of(self.mask));
                    spe.compute_items(r.packet_triangle_mixed, self.mixed_quads(self.mask));
                    let meets = self.test(&rec);
                    spe.compute_items(r.packet_triangle_hit_quad, self.quads_of(meets));
                    self.at = At::Leaf { k: k + 1, end };
                }
            }
        }
    }

    /// The active rays at inner node `nd`: each ray's step, as its own
    /// walk takes it. Goes on to the near child (keeping the far one for
    /// the rays that enter it) or to the far one; `false` when no ray
    /// enters either.
    fn step(&mut self, nd: &BihNode) -> bool {
        let (mut near_rays, mut far_rays) = (0u64, 0u64);
        let (mut near, mut far) = (0, 0);
        let (mut near_tf, mut far_tn) = ([0.0f64; 64], [0.0f64; 64]);
        for i in Self::each(self.mask) {
            let s = descend(
                nd,
                &self.rays[i],
                self.inv[i],
                self.neg,
                self.tn[i],
                self.tf[i],
            );
            // The same children for every ray: their directions' signs agree.
            (near, far) = (s.near, s.far);
            (near_tf[i], far_tn[i]) = (s.near_tf, s.far_tn);
            near_rays |= (s.go_near as u64) << i;
            far_rays |= (s.go_far as u64) << i;
        }
        if near_rays != 0 {
            if far_rays != 0 {
                let base = self.kept.len();
                self.kept.resize(base + self.rays.len(), (0.0, 0.0));
                for i in Self::each(far_rays) {
                    self.kept[base + i] = (far_tn[i], self.tf[i]);
                }
                // A ray that goes to the far child only enters it after
                // the near child's rays, where its own walk goes at once:
                // nothing of its changes in between, and its entry passes
                // the check (a ray's interval never reaches beyond its
                // best hit).
                self.stack.push(Entry {
                    node: far,
                    rays: far_rays,
                });
            }
            for i in Self::each(near_rays) {
                self.tf[i] = near_tf[i];
            }
            (self.node, self.mask) = (near, near_rays);
            self.at = At::Node;
            return true;
        }
        if far_rays != 0 {
            for i in Self::each(far_rays) {
                self.tn[i] = far_tn[i];
            }
            (self.node, self.mask) = (far, far_rays);
            self.at = At::Node;
            return true;
        }
        false
    }

    /// Takes the next kept node that some ray still needs: the rays whose
    /// entry is not beyond their best hit (their interval cut there);
    /// `false` when none is left.
    fn pop(&mut self) -> bool {
        while let Some(e) = self.stack.pop() {
            let base = self.kept.len() - self.rays.len();
            let mut mask = 0u64;
            for i in Self::each(e.rays) {
                let (a, b) = self.kept[base + i];
                let bound = pop_bound(self.best_t[i]);
                if a <= bound {
                    (self.tn[i], self.tf[i]) = (a, b.min(bound));
                    mask |= 1 << i;
                }
            }
            self.kept.truncate(base);
            if mask != 0 {
                (self.node, self.mask) = (e.node, mask);
                self.at = At::Node;
                return true;
            }
        }
        false
    }

    /// The leaf's triangle `rec` against every active ray: the rays whose
    /// lines meet it (their quads go on from the edge tests to `t`).
    fn test(&mut self, rec: &TriRecord) -> u64 {
        let tri = Triangle {
            v: rec.v.map(Vec3::from_array),
        };
        let mut meets = 0u64;
        for i in Self::each(self.mask) {
            self.stats[i].triangles_tested += 1;
            let ray = &self.rays[i];
            let (line, hit) = test_sheared(&tri, &self.shears[i], ray.tmin, self.best_t[i]);
            meets |= (line as u64) << i;
            if let Some((t, u, v)) = hit
                && closer(t, rec.id, self.best[i])
            {
                self.best[i] = Some(Hit {
                    prim: rec.id,
                    t,
                    u,
                    v,
                });
                self.best_t[i] = t;
            }
        }
        meets
    }
}
