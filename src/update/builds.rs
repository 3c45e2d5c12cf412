//! The builds an update step ran (a complete rebuild, or each rebuilt
//! interval of section 3's local update and section 5's deep update), kept
//! so that the frame loop can run them again on one Cell beside the
//! casters, as the paper's arrangement has them (one SPE updates while the
//! others render): which triangles, the region that served as scene box,
//! the tree's settings, and a fingerprint of the tree the build gave, for
//! the run beside the casters to be checked against (simulated time never
//! changes a tree).

use std::hash::{Hash, Hasher};

use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig};
use crate::scene::{Scene, SceneError};

/// One build of an update step.
#[derive(Clone, Debug)]
pub struct BuildLog {
    /// The triangles built, by id in the scene as the step left it (`None`:
    /// all of them, a complete rebuild), in the order the build took them.
    pub ids: Option<Vec<u32>>,
    pub region: Aabb,
    pub cfg: BihConfig,
    /// [`fingerprint`] of the tree the build gave (its own triangle
    /// numbering: 0 is the first of `ids`).
    pub fingerprint: u64,
}

/// A hash of a tree's nodes and triangle order.
pub fn fingerprint(bih: &Bih) -> u64 {
    let mut h = std::hash::DefaultHasher::new();
    bytemuck::cast_slice::<_, u8>(&bih.nodes).hash(&mut h);
    bih.prim_ids.hash(&mut h);
    h.finish()
}

/// The scene of the triangles `ids` of `scene` (in that order), as a
/// build of an interval takes them.
pub fn sub_scene(scene: &Scene, ids: &[u32]) -> Result<Scene, SceneError> {
    Scene::new(
        format!("{} (interval)", scene.name),
        ids.iter().map(|&i| scene.triangles[i as usize]).collect(),
        ids.iter()
            .map(|&i| scene.geometry_ids[i as usize])
            .collect(),
        scene.geometry_names.clone(),
    )
}
