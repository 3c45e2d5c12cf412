//! Updates after objects move: the paper's intelligent local update
//! (section 3, Algorithm 1) and the deeper update its section 5 proposes.
//!
//! An [`Updater`] holds a scene and its tree. Each [`Updater::step`] takes
//! one frame of [`Move`]s and brings the tree up to date by one [`Method`]:
//!
//! - `local` — the paper's: the EBB of the moved objects' old and new
//!   states; a complete rebuild if the scene box changed; else Algorithm 1
//!   finds the enclosing node ([`local`]), the moved triangles are found in
//!   its interval by geometry id, its subtree is deleted and its interval
//!   rebuilt with the node's region as the scene box, and grafted in place;
//! - `deep` — section 5's proposal: below the enclosing node, descend
//!   further, keep the subtrees the moved geometry does not touch, rebuild
//!   only the touched ones, and move the kept subtrees' triangle ranges to
//!   their new places (`deep.rs`);
//! - `rebuild` — a complete rebuild every frame, the reference.
//!
//! The rebuilds run on the updater's builder, host or emulated Cell; for an
//! emulated builder the report carries the simulated time of the rebuilds.
//!
//! Node slots freed by deleted subtrees are reused (children come in
//! adjacent pairs, so the free list holds pairs); the node array never
//! shrinks, as an ObjectArena's would not.

pub mod animation;
pub mod builds;
mod deep;
pub mod local;
mod plan;
pub mod ppe;
mod report;
pub mod spe_find;

use std::time::Instant;

use serde::Serialize;
use thiserror::Error;

pub use animation::{Animation, MAX_FRAMES, Move, apply};
pub use local::{Enclosing, Stop, enclosing_node, interval};
pub use plan::Plan;
pub use ppe::{Array, PpeMemory, PpeRates, PpeWork};
pub use report::{Summary, UpdateReport};
pub use spe_find::{FindMoved, SpeFind};

use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, BihNode};
use crate::cell::CellError;
use crate::kernels::recursion::{PrimRef, build_items};
use crate::registry::{Build, BuilderKind};
use crate::scene::{Scene, SceneError, Triangle};

/// How a frame's moves are brought into the tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    Local,
    Deep,
    Rebuild,
}

impl Method {
    pub const ALL: &'static [Method] = &[Method::Local, Method::Deep, Method::Rebuild];

    pub fn name(self) -> &'static str {
        match self {
            Method::Local => "local",
            Method::Deep => "deep",
            Method::Rebuild => "rebuild",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|m| m.name() == name)
    }
}

#[derive(Debug, Error)]
pub enum UpdateError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Cell(#[from] CellError),
}

/// The emulated builders the update experiments report simulated time on,
/// by column prefix: the PPE, where the paper's update ran (section 3), and
/// one SPE, the baseline.
pub const SIMULATED_BUILDERS: [(&str, BuilderKind); 2] = [
    ("ppe", BuilderKind::PPE_NAIVE),
    ("bfs", BuilderKind::SPE_BFS),
];

/// Plays `anim` on a fresh updater of `scene` that builds as `build`
/// asks; returns the updater after the last frame and every frame's report.
pub fn play(
    scene: &Scene,
    anim: &Animation,
    build: &Build,
    method: Method,
) -> Result<(Updater, Vec<UpdateReport>), UpdateError> {
    let mut u = Updater::new(scene.clone(), build.clone(), method)?;
    let reports = anim
        .frames
        .iter()
        .map(|m| u.step(m))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((u, reports))
}

/// The objects moved by [`Updater::move_objects`].
struct Moved {
    moved: Vec<bool>,
    ebb: Aabb,
    saved: Vec<(u32, Triangle)>,
    saved_box: Aabb,
}

/// A subtree built for grafting, and its simulated time if emulated.
struct Piece {
    bih: Bih,
    timed: Option<Timed>,
    log: Option<builds::BuildLog>,
}

/// What an emulated build cost: its simulated ms and the bytes its DMA
/// moved.
#[derive(Clone, Copy)]
struct Timed {
    ms: f64,
    dma_bytes: u64,
    /// SPEs the build ran on.
    spes: usize,
}

impl Timed {
    fn of(s: &crate::strategy::Simulated) -> Option<Timed> {
        s.run.timed.then(|| Timed {
            spes: s.spes_used.max(1),
            ms: s.run.ms,
            dma_bytes: (s.run.cores.iter())
                .map(|(_, c)| c.bytes_get + c.bytes_put)
                .sum(),
        })
    }

    fn charge(self, r: &mut UpdateReport) {
        *r.build_ms.get_or_insert(0.0) += self.ms;
        r.dma_bytes += self.dma_bytes;
    }
}

/// A scene, its tree, and how the tree follows moving objects.
#[derive(Clone)]
pub struct Updater {
    pub scene: Scene,
    pub bih: Bih,
    /// The build request every build of the update makes (the first tree,
    /// complete rebuilds, rebuilt subtrees): builder, tree, Cell, knobs.
    pub build: Build,
    pub method: Method,
    /// Deep update: a touched subtree of at most this many triangles is
    /// rebuilt whole instead of descended into.
    pub deep_stop_below: usize,
    /// Simulated time of the first tree's build, for an emulated builder.
    pub first_build_ms: Option<f64>,
    /// Where the builder leaves the triangle records (the first build's).
    pub records: crate::spe::layout::RecordOrder,
    /// Where a local update finds the moved triangles of its interval.
    pub find_moved: FindMoved,
    /// The emulated builds of the last step, in the order their trees went
    /// in, and the SPEs' search before them (`find_moved` spe).
    pub builds: Vec<builds::BuildLog>,
    pub spe_find: Option<SpeFind>,
    /// Triangle ids of each geometry id.
    members: Vec<Vec<u32>>,
    /// First slot of each free pair of node slots.
    free: Vec<u32>,
    /// The PPE's caches, as the update's steps meet them.
    ppe_memory: PpeMemory,
}

/// The default of [`Updater::deep_stop_below`]: four leaves' worth.
pub const DEEP_STOP_BELOW: usize = 48;

impl Updater {
    /// Builds the first tree of `scene` as `build` asks; every later build
    /// of the update makes the same request.
    pub fn new(scene: Scene, build: Build, method: Method) -> Result<Self, UpdateError> {
        let first = build.run(&scene)?;
        let first_build_ms = (first.simulated.as_ref())
            .filter(|s| s.run.timed)
            .map(|s| s.run.ms);
        let records = first.record_order();
        let timed = build.builder.emulated() && build.cell.cost.charge_compute;
        let bih = first.bih;
        let mut members = vec![Vec::new(); scene.geometry_names.len()];
        for (i, &g) in scene.geometry_ids.iter().enumerate() {
            members[g as usize].push(i as u32);
        }
        Ok(Updater {
            scene,
            bih,
            build,
            method,
            deep_stop_below: DEEP_STOP_BELOW,
            first_build_ms,
            records,
            find_moved: FindMoved::Ppe,
            builds: Vec::new(),
            spe_find: None,
            members,
            free: Vec::new(),
            ppe_memory: PpeMemory::new(timed),
        })
    }

    /// Applies one frame of moves to the scene and brings the tree up to
    /// date. On an error (an unknown geometry, a non-finite result, a
    /// builder's error) the scene is as it was and the tree valid for it.
    pub fn step(&mut self, moves: &[Move]) -> Result<UpdateReport, UpdateError> {
        let start = Instant::now();
        self.builds.clear();
        self.spe_find = None;
        self.ppe_memory.cold();
        let mut r = UpdateReport {
            moves: moves.len(),
            ..UpdateReport::default()
        };
        if moves.is_empty() {
            r.host_ms = ms(start);
            return Ok(r);
        }
        let Moved {
            moved,
            ebb,
            saved,
            saved_box,
        } = self.move_objects(moves, &mut r)?;

        let done = if self.method == Method::Rebuild || self.scene.bounds() != self.bih.bounds {
            self.full_rebuild(&mut r)
        } else {
            let mem = &self.ppe_memory;
            let enc = enclosing_node(&mut self.bih, &ebb, &mut |n| {
                mem.load(Array::Nodes, n as u64)
            });
            r.depth = enc.depth;
            r.stop = Some(enc.stop);
            let (first, end) = interval(&self.bih, enc.node);
            r.interval = end - first;
            let on_spes = self.method == Method::Local && self.find_moved == FindMoved::Spe;
            r.ppe_find += found(&enc, if on_spes { 0 } else { r.interval });
            if !on_spes {
                self.scan_loads((first, end));
            }
            r.ppe_find.loads += self.ppe_memory.take();
            let moved_slots = self.moved_slots(&moved, (first, end));
            assert_eq!(
                moved_slots.len(),
                r.transformed,
                "Algorithm 1 lost moved triangles: the enclosing node's interval \
                 must hold every one"
            );
            match self.method {
                Method::Local => {
                    let ids = &self.bih.prim_ids[first..end];
                    self.build_subtree(ids, enc.region, enc.depth)
                        .and_then(|piece| {
                            let spes = piece.timed.filter(|_| on_spes).map(|t| t.spes);
                            if let Some(spes) = spes {
                                self.find_on_spes(spes, &mut r)?;
                            }
                            self.install(enc.node, first, &piece, &mut r);
                            Ok(())
                        })
                }
                Method::Deep => deep::update(self, &enc, (first, end), &moved_slots, &mut r),
                Method::Rebuild => unreachable!(),
            }
        };
        // Every build runs before the tree is touched, so a builder error
        // (from the emulated Cell) leaves the old tree, valid for the old
        // scene (planes Algorithm 1 widened stay valid): put the scene back.
        if let Err(e) = done {
            self.scene.restore(saved, saved_box);
            return Err(e);
        }
        r.ppe_apply.loads += self.ppe_memory.take();
        if self.build.builder.emulated() && self.build.cell.cost.charge_compute {
            let cost = &self.build.cell.cost;
            let rates = &self.build.rates;
            r.ppe_find_ms = r.ppe_find.ms(cost, rates);
            r.ppe_apply_ms = r.ppe_apply.ms(cost, rates);
            r.simulated_ms = Some(r.build_ms.unwrap_or(0.0) + r.ppe_find_ms + r.ppe_apply_ms);
        }
        r.host_ms = ms(start);
        Ok(r)
    }

    /// The moved triangles of the interval found by the `spes` SPEs of
    /// its rebuild as they stream it ([`spe_find`]), run on the build's
    /// Cell and charged to the rebuild.
    fn find_on_spes(&mut self, spes: usize, r: &mut UpdateReport) -> Result<(), UpdateError> {
        let work = SpeFind {
            slots: r.interval as u64,
            moved: r.transformed as u64,
            spes,
        };
        let (ms, dma_bytes) = spe_find::alone(work, &self.build.cell, &self.build.rates)?;
        (r.spe_find, r.spe_find_ms) = (work, ms);
        *r.build_ms.get_or_insert(0.0) += ms;
        r.dma_bytes += dma_bytes;
        self.spe_find = Some(work);
        Ok(())
    }

    /// Moves the objects of `moves` in the scene: which geometries moved,
    /// the EBB (their boxes before and after), and what to restore on an
    /// error. Counts the transformed triangles into `r`.
    fn move_objects(&mut self, moves: &[Move], r: &mut UpdateReport) -> Result<Moved, UpdateError> {
        let mut moved = vec![false; self.members.len()];
        let mut ebb = Aabb::EMPTY;
        for m in moves {
            animation::check_geometry(&self.scene, m.geometry)?;
            if !std::mem::replace(&mut moved[m.geometry as usize], true) {
                r.transformed += self.members[m.geometry as usize].len();
                ebb = ebb.union(self.geometry_box(m.geometry));
            }
        }
        let (saved, saved_box) = (self.moved_triangles(&moved), self.scene.bounds());
        for m in moves.iter().filter(|m| !m.is_identity()) {
            if let Err(e) = self
                .scene
                .transform_triangles(&self.members[m.geometry as usize], &m.transform)
            {
                self.scene.restore(saved, saved_box);
                return Err(e.into());
            }
        }
        for (g, _) in moved.iter().enumerate().filter(|(_, m)| **m) {
            ebb = ebb.union(self.geometry_box(g as u32));
        }
        Ok(Moved {
            moved,
            ebb,
            saved,
            saved_box,
        })
    }

    /// The slots of `first .. end` that hold triangles of the geometries
    /// flagged in `moved` (found by geometry id: their coordinates were
    /// already replaced in the scene).
    fn moved_slots(&self, moved: &[bool], (first, end): (usize, usize)) -> Vec<usize> {
        (first..end)
            .filter(|&s| moved[self.scene.geometry_ids[self.bih.prim_ids[s] as usize] as usize])
            .collect()
    }

    /// The scan's loads of `first .. end` through the PPE's caches: each
    /// slot's triangle id, its geometry id, that geometry's moved flag.
    fn scan_loads(&self, (first, end): (usize, usize)) {
        for s in first..end {
            let id = self.bih.prim_ids[s];
            let g = self.scene.geometry_ids[id as usize];
            self.ppe_memory.load(Array::PrimIds, s as u64);
            self.ppe_memory.load(Array::GeometryIds, id as u64);
            self.ppe_memory.load(Array::Moved, g as u64);
        }
    }

    fn full_rebuild(&mut self, r: &mut UpdateReport) -> Result<(), UpdateError> {
        let b = self.build.run(&self.scene)?;
        if self.build.builder.emulated() {
            self.builds.push(builds::BuildLog {
                ids: None,
                region: self.scene.bounds(),
                cfg: b.bih.config,
                fingerprint: builds::fingerprint(&b.bih),
            });
        }
        self.bih = b.bih;
        self.free.clear();
        r.full_rebuild = true;
        r.rebuilt = self.scene.len();
        r.pieces = 1;
        if let Some(t) = b.simulated.as_ref().and_then(Timed::of) {
            t.charge(r);
        }
        Ok(())
    }

    /// The triangles of the geometries flagged in `moved`, with their ids.
    fn moved_triangles(&self, moved: &[bool]) -> Vec<(u32, Triangle)> {
        let flagged = moved.iter().enumerate().filter(|(_, m)| **m);
        flagged
            .flat_map(|(g, _)| &self.members[g])
            .map(|&i| (i, self.scene.triangles[i as usize]))
            .collect()
    }

    /// The box of geometry `g`'s triangles as they are now.
    fn geometry_box(&self, g: u32) -> Aabb {
        self.members[g as usize].iter().fold(Aabb::EMPTY, |b, &i| {
            b.union(self.scene.triangles[i as usize].bounds())
        })
    }

    /// The simulated time of one small subtree build, as an update's
    /// pieces are built: the first `n` triangles of the tree's order in the
    /// scene box (`None` for a builder that is not emulated). A renderer
    /// can take it before its first frame, to learn what a build costs
    /// whatever its size; nothing is changed.
    pub fn probe_piece(&self, n: usize) -> Result<Option<f64>, UpdateError> {
        let ids = &self.bih.prim_ids[..n.min(self.bih.prim_ids.len())];
        let region = (ids.iter()).fold(Aabb::EMPTY, |b, &i| {
            b.union(self.scene.triangles[i as usize].bounds())
        });
        Ok(self.build_subtree(ids, region, 0)?.timed.map(|t| t.ms))
    }

    /// A subtree over the triangles `ids` for a node at `depth` whose
    /// region is `region`, by the updater's builder (the depth limit counts
    /// from the tree's root).
    fn build_subtree(&self, ids: &[u32], region: Aabb, depth: u32) -> Result<Piece, UpdateError> {
        let cfg = BihConfig {
            max_depth: self.bih.config.max_depth - depth,
            ..self.bih.config
        };
        let (bih, timed, log) = self.build_piece(ids, region, &cfg)?;
        Ok(Piece { bih, timed, log })
    }

    /// Deletes the subtree at `node` and grafts `piece` there, its
    /// triangles at slots `first ..`.
    fn install(&mut self, node: u32, first: usize, piece: &Piece, r: &mut UpdateReport) {
        self.free_subtree(node);
        self.graft(node, &piece.bih, first as u32);
        r.rebuilt += piece.bih.prim_ids.len();
        r.pieces += 1;
        r.ppe_apply += PpeWork {
            nodes_written: piece.bih.nodes.len() as u64,
            ids_copied: piece.bih.prim_ids.len() as u64,
            ..PpeWork::default()
        };
        if let Some(t) = piece.timed {
            t.charge(r);
        }
        self.builds.extend(piece.log.clone());
    }

    /// A tree over the triangles `ids` (global ids, leaves from slot 0), by
    /// the updater's builder, and, if emulated, its simulated time and what
    /// it built.
    fn build_piece(
        &self,
        ids: &[u32],
        region: Aabb,
        cfg: &BihConfig,
    ) -> Result<(Bih, Option<Timed>, Option<builds::BuildLog>), UpdateError> {
        if ids.is_empty() {
            let empty = Bih {
                nodes: vec![BihNode::leaf(0, 0)],
                prim_ids: Vec::new(),
                bounds: region,
                config: *cfg,
            };
            return Ok((empty, None, None));
        }
        if self.build.builder == BuilderKind::HOST {
            let mut refs: Vec<PrimRef> = ids
                .iter()
                .map(|&i| PrimRef::new(i, self.scene.triangles[i as usize].bounds()))
                .collect();
            return Ok((build_items(&mut refs, region, cfg).0, None, None));
        }
        let sub = builds::sub_scene(&self.scene, ids)?;
        let b = (self.build.clone().with_tree(*cfg)).run_in(&sub, region)?;
        let mut bih = b.bih;
        let log = (b.simulated.is_some()).then(|| builds::BuildLog {
            ids: Some(ids.to_vec()),
            region,
            cfg: *cfg,
            fingerprint: builds::fingerprint(&bih),
        });
        for p in &mut bih.prim_ids {
            *p = ids[*p as usize];
        }
        Ok((bih, b.simulated.as_ref().and_then(Timed::of), log))
    }

    /// Puts the descendants of `node` on the free list.
    fn free_subtree(&mut self, node: u32) {
        let mut stack = vec![node];
        while let Some(id) = stack.pop() {
            let n = self.bih.nodes[id as usize];
            if !n.is_leaf() {
                let c = n.left_child();
                self.free.push(c);
                stack.extend([c, c + 1]);
            }
        }
    }

    /// A free pair of node slots, reused or appended.
    fn alloc_pair(&mut self) -> u32 {
        self.free.pop().unwrap_or_else(|| {
            let c = self.bih.nodes.len() as u32;
            self.bih.nodes.extend([BihNode::default(); 2]);
            c
        })
    }

    /// Writes `piece` into the tree: its root at `at` (the split axis and
    /// child pointer change with it), its other nodes in free pairs, its
    /// leaves shifted to start at slot `first`.
    fn graft(&mut self, at: u32, piece: &Bih, first: u32) {
        let mut stack = vec![(0u32, at)];
        let base = self.ppe_memory.new_piece(piece.nodes.len() as u64);
        while let Some((src, dst)) = stack.pop() {
            self.ppe_memory.load(Array::Piece, base + src as u64);
            self.ppe_memory.store(Array::Nodes, dst as u64);
            let n = piece.nodes[src as usize];
            self.bih.nodes[dst as usize] = if n.is_leaf() {
                let (f, c) = n.leaf_range();
                BihNode::leaf(f + first, c)
            } else {
                let pair = self.alloc_pair();
                let [cl, cr] = n.clip();
                stack.push((n.left_child(), pair));
                stack.push((n.left_child() + 1, pair + 1));
                BihNode::inner(pair, n.axis(), cl, cr)
            };
        }
        let f = first as usize;
        self.bih.prim_ids[f..f + piece.prim_ids.len()].copy_from_slice(&piece.prim_ids);
    }
}

/// The PPE's work of Algorithm 1 down to `enc` and of the scan of its
/// interval of `slots` triangles.
fn found(enc: &Enclosing, slots: usize) -> PpeWork {
    PpeWork {
        nodes_visited: enc.depth as u64 + 1,
        scanned: slots as u64,
        ..PpeWork::default()
    }
}

fn ms(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}
