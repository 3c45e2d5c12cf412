//! What the strategies keep in emulated main memory, byte for byte. The
//! paper sorts the triangle array itself in place, each triangle carrying
//! its geometry id; every record is a multiple of 16 bytes so that whole
//! arrays travel by DMA.
//!
//! | record | bytes | layout |
//! |---|---|---|
//! | [`TriRecord`] | 48 | vertices v0, v1, v2 (9 × f32), geometry id (u32), triangle id (u32), 4 bytes of padding |
//! | `BihNode` | 12 | see `bih::node`; nodes are written in groups of 4 (48 bytes) |
//! | `spe_dfs` job | 32 | kind, first, count, axis (u32), plane (f32), 12 bytes of padding |
//! | `spe_dfs` side record | 80 | count (u32) + 12 bytes of padding, then box min, box max, center min, center max (4 × f32 each) |
//! | `spe_bfs` job | 64 | first, count, node id, depth (u32); candidate box min, max (6 × f32); bounds of centers min, max (6 × f32) |
//! | `spe_bfs` ObjectArena block | 48,960 | 4,080 nodes; node `id` is in block `id / 4080` at byte `(id % 4080) × 12` |

use super::footprint::Purpose;
use glam::Vec3A;

use crate::cell::{Cell, CellError, Ea};
use crate::kernels::recursion::Item;
use crate::kernels::split::Boxed;
use crate::scene::Scene;

/// Where a build leaves the triangle records for whatever reads the tree
/// next (the ray caster): a leaf `(first, count)` names places
/// `first..first + count` of the tree's triangle order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum RecordOrder {
    /// The records themselves in the tree's order (the in-place partition,
    /// `--permute`, a host build uploaded as it is).
    #[default]
    LeafOrder,
    /// The records in the scene's order and a column of triangle ids in
    /// the tree's order (`spe_morton`): a reader finds a leaf's triangles
    /// through the ids.
    InputWithIds,
}

/// One triangle in main memory: 48 bytes, 16-byte aligned in arrays.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TriRecord {
    pub v: [[f32; 3]; 3],
    pub geometry: u32,
    pub id: u32,
    pub pad: u32,
}
const _: () = assert!(size_of::<TriRecord>() == 48);

impl Boxed for TriRecord {
    #[inline]
    fn lo(&self) -> Vec3A {
        let [a, b, c] = self.v.map(Vec3A::from_array);
        a.min(b).min(c)
    }
    #[inline]
    fn hi(&self) -> Vec3A {
        let [a, b, c] = self.v.map(Vec3A::from_array);
        a.max(b).max(c)
    }
}

impl Item for TriRecord {
    fn id(&self) -> u32 {
        self.id
    }
}

/// The scene's triangles as records, in id order.
pub fn records(scene: &Scene) -> Vec<TriRecord> {
    scene
        .triangles
        .iter()
        .zip(&scene.geometry_ids)
        .enumerate()
        .map(|(i, (t, &g))| TriRecord {
            v: t.v.map(|p| p.to_array()),
            geometry: g,
            id: i as u32,
            pad: 0,
        })
        .collect()
}

/// Writes the scene's triangle array into main memory (128-byte aligned).
pub fn upload(cell: &Cell, scene: &Scene) -> Result<Ea, CellError> {
    cell.memory_mut().alloc_pod(
        Purpose::TriangleRecords.buffer("triangle records"),
        &records(scene),
        128,
    )
}
