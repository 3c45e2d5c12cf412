//! Moving objects: a [`Move`] transforms every triangle of one geometry id
//! (an OBJ object or group, a procedural part) by an affine transform; an
//! [`Animation`] is a deterministic sequence of frames of moves.
//!
//! The paper's scenes move like this (section 4.2): rtPerf moves a number of
//! spheres by a predefined scheme (Fig. 3); carVis moves parts of the car
//! apart and back; cupVis moves its lone glass, so every real move changes
//! the scene box. Some moves are *marked* but do nothing (the identity):
//! the paper's Table 2 counts those as updates that change nothing.

use glam::{Affine3A, Vec3};

use crate::scene::rng::SplitMix64;
use crate::scene::{Scene, SceneError};

/// One object moved: every triangle of `geometry` transformed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Move {
    pub geometry: u32,
    pub transform: Affine3A,
}

impl Move {
    /// A move that is marked but does nothing.
    pub fn marked(geometry: u32) -> Self {
        Move {
            geometry,
            transform: Affine3A::IDENTITY,
        }
    }

    pub fn translate(geometry: u32, by: Vec3) -> Self {
        Move {
            geometry,
            transform: Affine3A::from_translation(by),
        }
    }

    pub fn is_identity(&self) -> bool {
        self.transform == Affine3A::IDENTITY
    }
}

/// The scene after `moves`, applied in order. An unknown geometry id or a
/// transform that makes a coordinate non-finite is an error.
pub fn apply(scene: &Scene, moves: &[Move]) -> Result<Scene, SceneError> {
    let mut out = scene.clone();
    for m in moves {
        check_geometry(scene, m.geometry)?;
        if m.is_identity() {
            continue;
        }
        let ids: Vec<u32> = (0..scene.len() as u32)
            .filter(|&i| scene.geometry_ids[i as usize] == m.geometry)
            .collect();
        out.transform_triangles(&ids, &m.transform)?;
    }
    Ok(out)
}

/// An error unless `scene` has geometry id `g`.
pub(crate) fn check_geometry(scene: &Scene, g: u32) -> Result<(), SceneError> {
    if g as usize >= scene.geometry_names.len() {
        return Err(SceneError::Invalid {
            path: scene.name.clone(),
            what: format!(
                "a move of geometry id {g}, but the scene has {} geometries",
                scene.geometry_names.len()
            ),
        });
    }
    Ok(())
}

/// A named, deterministic sequence of frames of moves.
#[derive(Clone, Debug)]
pub struct Animation {
    pub name: String,
    pub frames: Vec<Vec<Move>>,
}

/// The most frames an animation has: every frame's moves are made before
/// the first one is played (about 100 bytes a frame, with its report).
pub const MAX_FRAMES: usize = 100_000;

/// The geometry ids of `scene` whose names `wanted` accepts, or an error
/// saying what `animation` moves and which scene has it.
fn parts_named(
    scene: &Scene,
    animation: &str,
    what: &str,
    wanted: impl Fn(&str) -> bool,
) -> Result<Vec<u32>, String> {
    let ids: Vec<u32> = (0..scene.geometry_names.len() as u32)
        .filter(|&g| wanted(&scene.geometry_names[g as usize]))
        .collect();
    if ids.is_empty() {
        return Err(format!(
            "animation '{animation}' moves {what}, and scene '{}' has no such geometry \
             (its geometries: {}); use --scene {animation}",
            scene.name,
            names_preview(scene)
        ));
    }
    Ok(ids)
}

fn names_preview(scene: &Scene) -> String {
    let n = scene.geometry_names.len();
    let mut s: Vec<&str> = scene
        .geometry_names
        .iter()
        .take(5)
        .map(String::as_str)
        .collect();
    if n > 5 {
        s.push("…");
    }
    s.join(", ")
}

impl Animation {
    /// The animation `name` (`rtperf`, `car` or `cup`) of `frames` frames
    /// for `scene`, deterministic for `seed`. Each animation moves geometry
    /// by name — rtperf the spheres (`sphere…`), car every part but the
    /// `body`, cup the `glass` — and a scene without it is an error, as is
    /// more than [`MAX_FRAMES`] frames.
    pub fn named(name: &str, scene: &Scene, frames: usize, seed: u64) -> Result<Self, String> {
        if frames > MAX_FRAMES {
            return Err(format!(
                "{frames} frames: an animation has at most {MAX_FRAMES} frames"
            ));
        }
        let mut rng = SplitMix64::new(seed);
        let frames = match name {
            // rtPerf (Fig. 3): each frame moves one sphere, picked
            // pseudo-randomly, by up to one unit on each axis, so the
            // number of transformed triangles stays the same (200) at every
            // scene size, as in the paper's Fig. 3a; every fifth frame's
            // move is marked only.
            "rtperf" => {
                let spheres =
                    parts_named(scene, name, "rtPerf's spheres", |n| n.starts_with("sphere"))?;
                (0..frames)
                    .map(|f| {
                        let g = spheres[(rng.next_u64() % spheres.len() as u64) as usize];
                        let by = Vec3::new(
                            rng.range(-1.0, 1.0),
                            rng.range(-1.0, 1.0),
                            rng.range(-1.0, 1.0),
                        );
                        if f % 5 == 4 {
                            vec![Move::marked(g)]
                        } else {
                            vec![Move::translate(g, by)]
                        }
                    })
                    .collect()
            }
            // carVis: parts other than the body (geometry 0) move out from
            // the car's center by 0.05 units on one frame and back on the
            // next; every seventh frame is marked only.
            "car" => {
                parts_named(scene, name, "the car's parts around its 'body'", |n| {
                    n == "body"
                })?;
                let parts = parts_named(scene, name, "the car's parts besides its 'body'", |n| {
                    n != "body"
                })?;
                let center = scene.bounds().center();
                (0..frames)
                    .map(|f| {
                        let g = parts[(f / 2) % parts.len()];
                        let out = (part_center(scene, g) - center).normalize_or_zero() * 0.05;
                        if f % 7 == 6 {
                            vec![Move::marked(g)]
                        } else if f % 2 == 0 {
                            vec![Move::translate(g, out)]
                        } else {
                            vec![Move::translate(g, -out)]
                        }
                    })
                    .collect()
            }
            // cupVis: the lone glass moves 0.05 units along x and back, so
            // every real move changes the scene box; one frame in 25 is
            // marked only.
            "cup" => {
                let glass = parts_named(scene, name, "the 'glass'", |n| n == "glass")?[0];
                (0..frames)
                    .map(|f| {
                        let by = Vec3::new(if f % 2 == 0 { 0.05 } else { -0.05 }, 0.0, 0.0);
                        if f % 25 == 24 {
                            vec![Move::marked(glass)]
                        } else {
                            vec![Move::translate(glass, by)]
                        }
                    })
                    .collect()
            }
            // A real mesh with a moving part: the part that
            // [`Animation::prepare`] split off moves 0.5 % of the scene's
            // extent up and back down, every fifth frame marked only.
            "part" => {
                let part = parts_named(
                    scene,
                    name,
                    "a 'moving part' (Animation::prepare splits one off)",
                    |n| n == MOVING_PART,
                )?[0];
                let step = scene.bounds().extent().max_element() * 0.005;
                (0..frames)
                    .map(|f| {
                        let by = Vec3::new(0.0, if f % 2 == 0 { step } else { -step }, 0.0);
                        if f % 5 == 4 {
                            vec![Move::marked(part)]
                        } else {
                            vec![Move::translate(part, by)]
                        }
                    })
                    .collect()
            }
            _ => {
                return Err(format!(
                    "unknown animation '{name}': rtperf, car, cup or part"
                ));
            }
        };
        Ok(Animation {
            name: name.to_string(),
            frames,
        })
    }
}

/// The name of the geometry the `part` animation moves.
pub const MOVING_PART: &str = "moving part";

impl Animation {
    /// The scene animation `name` plays on: `scene` itself, but for `part`,
    /// which moves a piece of any mesh: a copy whose triangles nearest to a
    /// point a quarter of the way from the scene's center to its end along
    /// the longest axis — 2 % of them, at least one — form a geometry of
    /// their own, [`MOVING_PART`] (the paper's animated scenes were made
    /// of parts; a scanned mesh like the dragon is one piece).
    pub fn prepare(name: &str, scene: Scene) -> Result<Scene, SceneError> {
        if name != "part" {
            return Ok(scene);
        }
        let b = scene.bounds();
        let axis = b.extent().max_position();
        let mut p = b.center();
        p[axis] += b.extent()[axis] * 0.25;
        let mut by_distance: Vec<(f32, usize)> = (scene.triangles.iter().enumerate())
            .map(|(i, t)| (t.bounds().center().distance_squared(p), i))
            .collect();
        let n = (scene.len() / 50).max(1);
        by_distance.select_nth_unstable_by(n - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut ids = scene.geometry_ids.clone();
        let mut names = scene.geometry_names.clone();
        let part = names.len() as u32;
        names.push(MOVING_PART.to_string());
        for &(_, i) in &by_distance[..n] {
            ids[i] = part;
        }
        Scene::new(
            format!("{} (with a moving part)", scene.name),
            scene.triangles,
            ids,
            names,
        )
    }
}

/// The center of the box of geometry `g`'s triangles.
fn part_center(scene: &Scene, g: u32) -> Vec3 {
    let mut b = crate::aabb::Aabb::EMPTY;
    for (t, &id) in scene.triangles.iter().zip(&scene.geometry_ids) {
        if id == g {
            b = b.union(t.bounds());
        }
    }
    b.center()
}
