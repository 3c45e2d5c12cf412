//! Scenes: triangles, the geometry id each carries, and where they come from.
//!
//! A scene is a list of triangles in a fixed order; a triangle's index in
//! that list is its *id* everywhere (trees, hits, the CLI's CSV files). Each
//! triangle also carries a *geometry id*: the OBJ object or group it came
//! from, or the procedural part (a sphere, a car door) it belongs to. The
//! local update moves and replaces triangles by geometry id.
//!
//! Every coordinate is finite: NaN and infinities are rejected when a scene
//! is made, with an error that names the element. Zero-area triangles are
//! legal (real meshes have them); rays never hit them.

pub mod extremes;
pub mod manifest;
mod obj;
pub mod procedural;
pub(crate) mod rng;
pub mod zoo;

use std::path::{Path, PathBuf};

use glam::{Affine3A, DVec3, Vec3};
use thiserror::Error;

pub use obj::{load_obj_file, parse_obj};
pub use rng::SplitMix64;

use crate::aabb::Aabb;

/// One triangle: three vertices, 36 bytes, no padding.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Triangle {
    pub v: [Vec3; 3],
}
const _: () = assert!(std::mem::size_of::<Triangle>() == 36);

impl Triangle {
    pub fn new(a: Vec3, b: Vec3, c: Vec3) -> Self {
        Triangle { v: [a, b, c] }
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::new(
            self.v[0].min(self.v[1]).min(self.v[2]),
            self.v[0].max(self.v[1]).max(self.v[2]),
        )
    }

    /// Zero area: the cross product of two edges is exactly zero in double
    /// precision (the vertices coincide or are collinear).
    /// (Written without `array::map`, which is not always inlined: its
    /// out-of-line copy cost `Tracer::new` a store-forwarding stall a
    /// triangle.)
    #[inline]
    pub fn is_degenerate(&self) -> bool {
        let [a, b, c] = [
            self.v[0].as_dvec3(),
            self.v[1].as_dvec3(),
            self.v[2].as_dvec3(),
        ];
        (b - a).cross(c - a) == DVec3::ZERO
    }
}

/// Why a scene could not be made. Every variant names the input and, where
/// there is one, the line and element at fault.
#[derive(Debug, Error)]
pub enum SceneError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not an OBJ file: {why}")]
    NotObj { path: String, why: String },
    #[error("{path}:{line}: {what}")]
    Malformed {
        path: String,
        line: usize,
        what: String,
    },
    #[error("{path}: {what}")]
    Invalid { path: String, what: String },
    #[error("{name}: the scene has no triangles")]
    Empty { name: String },
    #[error(
        "{name}: triangle {triangle} has a non-finite coordinate {value} (vertex {corner} of the triangle)"
    )]
    NonFinite {
        name: String,
        triangle: usize,
        corner: usize,
        value: f32,
    },
    #[error("unknown scene '{spec}': {why}")]
    Unknown { spec: String, why: String },
}

/// Triangles in id order, each with its geometry id.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub triangles: Vec<Triangle>,
    /// `geometry_ids[i]` is the geometry id of triangle `i`.
    pub geometry_ids: Vec<u32>,
    /// Name of each geometry id (OBJ object/group name, or procedural part).
    pub geometry_names: Vec<String>,
    bounds: Aabb,
}

impl Scene {
    /// Makes a scene, checking that it has triangles and that every
    /// coordinate is finite.
    pub fn new(
        name: impl Into<String>,
        triangles: Vec<Triangle>,
        geometry_ids: Vec<u32>,
        geometry_names: Vec<String>,
    ) -> Result<Self, SceneError> {
        let name = name.into();
        assert_eq!(triangles.len(), geometry_ids.len());
        assert!(
            geometry_ids
                .iter()
                .all(|&g| (g as usize) < geometry_names.len()),
            "geometry id without a name"
        );
        if triangles.is_empty() {
            return Err(SceneError::Empty { name });
        }
        for (i, t) in triangles.iter().enumerate() {
            for (corner, p) in t.v.iter().enumerate() {
                if let Some(&value) = p.to_array().iter().find(|c| !c.is_finite()) {
                    return Err(SceneError::NonFinite {
                        name,
                        triangle: i,
                        corner,
                        value,
                    });
                }
            }
        }
        let bounds = triangles
            .iter()
            .fold(Aabb::EMPTY, |b, t| b.union(t.bounds()));
        Ok(Scene {
            name,
            triangles,
            geometry_ids,
            geometry_names,
            bounds,
        })
    }

    /// A scene whose triangles are all one geometry.
    pub fn from_triangles(
        name: impl Into<String>,
        triangles: Vec<Triangle>,
    ) -> Result<Self, SceneError> {
        let n = triangles.len();
        Scene::new(name, triangles, vec![0; n], vec!["all".into()])
    }

    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The box of all triangles: the root region of every BIH.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    pub fn degenerate_count(&self) -> usize {
        self.triangles.iter().filter(|t| t.is_degenerate()).count()
    }

    /// Moves the triangles `ids` by `transform`, in place, for moving
    /// objects. The scene box is refreshed incrementally: grown by the moved
    /// triangles, and recomputed by a full pass only when a moved triangle
    /// touched the old box (it may have shrunk). A non-finite result is an
    /// error and leaves the scene as it was.
    pub fn transform_triangles(
        &mut self,
        ids: &[u32],
        transform: &Affine3A,
    ) -> Result<(), SceneError> {
        let moved: Vec<Triangle> = ids
            .iter()
            .map(|&i| Triangle {
                v: self.triangles[i as usize]
                    .v
                    .map(|p| transform.transform_point3(p)),
            })
            .collect();
        for (&i, t) in ids.iter().zip(&moved) {
            for (corner, p) in t.v.iter().enumerate() {
                if let Some(&value) = p.to_array().iter().find(|c| !c.is_finite()) {
                    return Err(SceneError::NonFinite {
                        name: self.name.clone(),
                        triangle: i as usize,
                        corner,
                        value,
                    });
                }
            }
        }
        let mut touched = false;
        for (&i, t) in ids.iter().zip(moved) {
            let old = self.triangles[i as usize].bounds();
            touched |= old.min.cmpeq(self.bounds.min).any() || old.max.cmpeq(self.bounds.max).any();
            self.bounds = self.bounds.union(t.bounds());
            self.triangles[i as usize] = t;
        }
        if touched {
            self.bounds = self
                .triangles
                .iter()
                .fold(Aabb::EMPTY, |b, t| b.union(t.bounds()));
        }
        Ok(())
    }

    /// Puts back triangles saved before [`Scene::transform_triangles`], and
    /// the scene box of that time.
    pub(crate) fn restore(&mut self, saved: Vec<(u32, Triangle)>, bounds: Aabb) {
        for (i, t) in saved {
            self.triangles[i as usize] = t;
        }
        self.bounds = bounds;
    }
}

/// The default scene, shipped in `scenes/default.obj` and embedded in the
/// binary so that it runs on a fresh clone with no data.
pub const DEFAULT_SCENE_OBJ: &str = include_str!("../../scenes/default.obj");

/// Where the loader's warnings go: the front end's function (which prints
/// them), set once with [`on_warning`]; until then they are kept for
/// [`warnings`].
static WARNING_SINK: std::sync::OnceLock<fn(&str)> = std::sync::OnceLock::new();

/// Warnings said while no sink was set, in order.
static WARNINGS: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());

/// Sends every later warning of the loader (a mesh that differs from the
/// manifest's) to `sink`, which a front end sets once at start-up to say
/// them; the library itself never prints. A second call is ignored.
pub fn on_warning(sink: fn(&str)) {
    let _ = WARNING_SINK.set(sink);
}

/// The warnings said while no sink was set ([`on_warning`]).
pub fn warnings() -> Vec<String> {
    WARNINGS.lock().unwrap_or_else(|e| e.into_inner()).clone()
}

/// Says `why`, once per mesh `name` in a process (an experiment loads a
/// mesh more than once).
fn warn_once(name: &str, why: &str) {
    static WARNED: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    let mut warned = WARNED.lock().unwrap_or_else(|e| e.into_inner());
    if !warned.iter().any(|w| w == name) {
        warned.push(name.to_string());
        match WARNING_SINK.get() {
            Some(sink) => sink(why),
            None => WARNINGS
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push(why.to_string()),
        }
    }
}

/// The environment variable that names the data directory of real meshes.
pub const DATA_ENV: &str = "CELLBIH_DATA";

/// The data directory: the one given, else `$CELLBIH_DATA`, else none.
pub fn data_dir(given: Option<&Path>) -> Option<PathBuf> {
    given
        .map(Path::to_path_buf)
        .or_else(|| std::env::var_os(DATA_ENV).map(PathBuf::from))
}

/// Resolves a scene by its name on the command line:
///
/// - `default`: the embedded default scene;
/// - `rtperf:<triangles>[:<seed>]`, `car`, `cup`: procedural scenes
///   ([`procedural`]);
/// - `ground:dragon:1000`, `stadium:teapot`, `clusters:8:200000:1`, …:
///   the scene zoo ([`zoo`]);
/// - a path to an `.obj` or `.obj.gz` file;
/// - a bare name such as `bunny`: `<data dir>/<name>.obj.gz` (or `.obj`).
pub fn load(spec: &str, data: Option<&Path>) -> Result<Scene, SceneError> {
    if spec.trim().is_empty() {
        return Err(SceneError::Unknown {
            spec: spec.into(),
            why: format!(
                "no scene given: default, rtperf:N[:SEED], car, cup, a mesh name or file, \
                 or a zoo scene ({})",
                zoo::FORMS
            ),
        });
    }
    if spec == "default" {
        return parse_obj("default", DEFAULT_SCENE_OBJ.as_bytes());
    }
    if let Some(scene) = procedural::by_name(spec)? {
        return Ok(scene);
    }
    if let Some(scene) = zoo::by_name(spec, data)? {
        return Ok(scene);
    }
    let path = Path::new(spec);
    if path.exists() || spec.ends_with(".obj") || spec.ends_with(".obj.gz") {
        return load_obj_file(path);
    }
    let Some(dir) = data_dir(data) else {
        return Err(SceneError::Unknown {
            spec: spec.into(),
            why: format!(
                "not a file, not a procedural scene (default, rtperf:N[:SEED], car, cup), \
                 not a zoo scene ({}); to load a mesh by name give --data DIR or set {DATA_ENV}",
                zoo::FORMS
            ),
        });
    };
    for ext in ["obj.gz", "obj"] {
        let p = dir.join(format!("{spec}.{ext}"));
        if p.exists() {
            let text = obj::read_obj_text(&p)?;
            if let Some(why) = manifest::differs(spec, &text) {
                warn_once(spec, &why);
            }
            let file = p
                .file_name()
                .map(|n| n.to_string_lossy().trim_end_matches(".gz").to_string());
            return obj::parse_obj_named(
                &p.display().to_string(),
                &file.unwrap_or_default(),
                &text,
            );
        }
    }
    Err(SceneError::Unknown {
        spec: spec.into(),
        why: format!("no {spec}.obj.gz or {spec}.obj in {}", dir.display()),
    })
}

#[cfg(test)]
mod tests {
    /// With no sink set (the library's own tests set none), a warning is
    /// kept for `warnings`, once per mesh, and nothing is printed.
    #[test]
    fn a_warning_without_a_sink_is_kept_once() {
        super::warn_once("test-mesh-a", "mesh test-mesh-a differs");
        super::warn_once("test-mesh-a", "mesh test-mesh-a differs again");
        let said = super::warnings();
        assert_eq!(said.iter().filter(|w| w.contains("test-mesh-a")).count(), 1);
        assert!(said.contains(&"mesh test-mesh-a differs".to_string()));
    }
}
