//! The host builder: the recursive in-place build of Wächter & Keller with
//! the global heuristic, on the host CPU, no emulation. It is the reference
//! every other builder is checked against, and the one the local update
//! uses when no strategy is named.

use glam::{Vec3A, Vec4};

use super::kernels::{Boxed, Side, choose_split, clip_planes, partition, side_of};
use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, BihNode};
use crate::scene::Scene;

/// A triangle as the host builder sorts it: its box and id, 32 bytes, two
/// SIMD lanes of four. The id rides in the fourth lane of `lo` (as bits).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct PrimRef {
    lo_id: Vec4,
    hi: Vec4,
}

impl Boxed for PrimRef {
    #[inline]
    fn lo(&self) -> Vec3A {
        Vec3A::from_vec4(self.lo_id)
    }
    #[inline]
    fn hi(&self) -> Vec3A {
        Vec3A::from_vec4(self.hi)
    }
}

impl PrimRef {
    pub fn new(id: u32, b: Aabb) -> Self {
        PrimRef {
            lo_id: b.min.extend(f32::from_bits(id)),
            hi: b.max.extend(0.0),
        }
    }

    pub fn id(&self) -> u32 {
        self.lo_id.w.to_bits()
    }
}

/// Builds the tree of `scene` in one host thread.
pub fn build(scene: &Scene, cfg: &BihConfig) -> Bih {
    let refs = scene
        .triangles
        .iter()
        .enumerate()
        .map(|(i, t)| PrimRef::new(i as u32, t.bounds()))
        .collect();
    build_refs(refs, scene.bounds(), cfg)
}

/// Builds a tree over `refs` with `region` as the scene box of the global
/// heuristic (the whole scene, or one node's region in a local update).
pub fn build_refs(mut refs: Vec<PrimRef>, region: Aabb, cfg: &BihConfig) -> Bih {
    assert!(cfg.max_depth <= BihConfig::MAX_SUPPORTED_DEPTH);
    let all = side_of(&refs);
    let mut b = Builder {
        refs: &mut refs,
        nodes: Vec::with_capacity(all.count * 2 / cfg.leaf_size.max(1) as usize + 1),
        cfg,
    };
    b.nodes.push(BihNode::default());
    b.node(0, 0, all.count, region, &all, 0);
    let nodes = b.nodes;
    Bih {
        nodes,
        prim_ids: refs.iter().map(PrimRef::id).collect(),
        bounds: region,
        config: *cfg,
    }
}

struct Builder<'a> {
    refs: &'a mut [PrimRef],
    nodes: Vec<BihNode>,
    cfg: &'a BihConfig,
}

impl Builder<'_> {
    /// Fills node `id` for `refs[first .. first + count]`.
    fn node(
        &mut self,
        id: usize,
        first: usize,
        count: usize,
        mut candidate: Aabb,
        side: &Side,
        depth: u32,
    ) {
        let leaf = BihNode::leaf(first as u32, count as u32);
        if count <= self.cfg.leaf_size as usize || depth >= self.cfg.max_depth {
            self.nodes[id] = leaf;
            return;
        }
        let Some(split) = choose_split(&mut candidate, &side.centers()) else {
            self.nodes[id] = leaf;
            return;
        };
        let (l, r) = partition(&mut self.refs[first..first + count], split);
        debug_assert!(l.count > 0 && r.count > 0);
        let children = self.nodes.len();
        self.nodes.push(BihNode::default());
        self.nodes.push(BihNode::default());
        let [cl, cr] = clip_planes(split.axis, &l, &r);
        self.nodes[id] = BihNode::inner(children as u32, split.axis, cl, cr);
        let (mut lc, mut rc) = (candidate, candidate);
        lc.max[split.axis] = split.plane;
        rc.min[split.axis] = split.plane;
        self.node(children, first, l.count, lc, &l, depth + 1);
        self.node(children + 1, first + l.count, r.count, rc, &r, depth + 1);
    }
}
