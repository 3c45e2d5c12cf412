//! The job of the breadth-first builders (section 2, Fig. 2): a node to
//! make and its interval of the triangle array.

use glam::Vec3;

use crate::aabb::Aabb;
use crate::bih::BihConfig;
use crate::kernels::split::Side;
use crate::strategy::machinery::work_queue::WorkQueue;

/// One job: a node to make and its interval of the triangle array. Its
/// first 64 bytes are the paper's job and all that travels, unless the
/// empty-space cut-off is on: then the node's region and its triangles' box
/// travel too, 128 bytes a job (`Job::bytes`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Job {
    pub first: u32,
    pub count: u32,
    /// The node id this job fills.
    pub node: u32,
    pub depth: u32,
    /// The candidate box of the global heuristic.
    pub candidate: [[f32; 3]; 2],
    /// Bounds of the interval's box centers.
    pub centers: [[f32; 3]; 2],
    /// The empty-space cut-off only: the node's region (the box its
    /// ancestors' planes leave it) ...
    pub(super) region: [[f32; 3]; 2],
    /// ... and the union of its triangles' boxes.
    pub(super) bounds: [[f32; 3]; 2],
    pub(super) pad: [u32; 4],
}
const _: () = assert!(size_of::<Job>() == 128);

/// An `Aabb` as two arrays, and back.
fn pack(b: Aabb) -> [[f32; 3]; 2] {
    [b.min.to_array(), b.max.to_array()]
}
fn unpack(b: [[f32; 3]; 2]) -> Aabb {
    Aabb::new(Vec3::from_array(b[0]), Vec3::from_array(b[1]))
}

impl Job {
    /// A job whose region is its candidate box (the root's; others get
    /// theirs with [`Job::in_region`]).
    pub(in crate::strategy) fn new(
        first: usize,
        count: usize,
        node: usize,
        depth: u32,
        cand: Aabb,
        side: &Side,
    ) -> Self {
        Job {
            first: first as u32,
            count: count as u32,
            node: node as u32,
            depth,
            candidate: pack(cand),
            centers: pack(side.centers()),
            region: pack(cand),
            bounds: pack(side.bounds()),
            pad: [0; 4],
        }
    }

    /// This job with the region `region`.
    pub(in crate::strategy) fn in_region(self, region: Aabb) -> Self {
        Job {
            region: pack(region),
            ..self
        }
    }

    /// Bytes one job takes in `WorkA`/`WorkB` and main memory with `cfg`:
    /// the paper's 64, or 128 with the empty-space cut-off.
    pub(in crate::strategy) fn bytes(cfg: &BihConfig) -> usize {
        if cfg.empty_cut.is_some() { 128 } else { 64 }
    }

    /// Bytes `WorkAPPE` (and `WorkBPPE`) need for a subtree of
    /// `triangles` with `cfg` ([`WorkQueue::spill_bytes_for`]).
    pub(in crate::strategy) fn spill_bytes_for(triangles: usize, cfg: &BihConfig) -> u64 {
        WorkQueue::<Job>::spill_bytes_for(triangles, cfg.leaf_size, Job::bytes(cfg))
    }

    pub(in crate::strategy) fn candidate(&self) -> Aabb {
        unpack(self.candidate)
    }
    pub(in crate::strategy) fn centers(&self) -> Aabb {
        unpack(self.centers)
    }
    pub(in crate::strategy) fn region(&self) -> Aabb {
        unpack(self.region)
    }
    pub(in crate::strategy) fn bounds(&self) -> Aabb {
        unpack(self.bounds)
    }
}
