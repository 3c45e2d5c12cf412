//! The scene a command reads (`--scene`, `--data`), and the checks that it
//! and a cast on the Cell fit the emulated Cell's main memory before any
//! work.

use std::path::{Path, PathBuf};

use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{self, Scene};

use crate::Res;

#[derive(clap::Args)]
pub struct SceneArg {
    /// default | rtperf:N[:SEED] (N up to 50,000,000) | car | cup | a mesh
    /// name in the data directory (bunny, dragon, …) | a path to an .obj or
    /// .obj.gz file | a zoo scene: ground:MESH:SCALE, stadium:MESH[:SCALE],
    /// clusters:K:N[:SEED], row:MESH:K, soup:N[:SEED], city:K[:SEED].
    #[arg(long, default_value = "default")]
    pub scene: String,
    /// Directory of real meshes (bunny, dragon, …); default: $CELLBIH_DATA.
    #[arg(long)]
    pub data: Option<PathBuf>,
}

impl SceneArg {
    /// The scene's file, by option, where `--scene` names one here: no
    /// output may replace it.
    pub fn input(&self) -> Option<(&'static str, &Path)> {
        let path = Path::new(&self.scene);
        path.is_file().then_some(("--scene", path))
    }

    /// Before any work: an `rtperf:N` scene that does not fit in the
    /// emulated Cell's main memory — its triangle records (48 bytes each,
    /// every emulated build uploads them) or, with `cast_rays`, what the
    /// cast on the Cell takes — is refused at once, not after the scene is
    /// made and the build has run out of room. Other scenes are checked by
    /// [`check_memory`] once loaded.
    pub fn check_fits(&self, c: &Build, cast_rays: Option<usize>) -> Res<()> {
        match scene::procedural::rtperf_triangles(&self.scene) {
            Some(n) => check_memory(&self.scene, (n, 0), cast_rays, c, Default::default()),
            None => Ok(()),
        }
    }

    /// The scene; a built-in name that is also a file here is the built-in
    /// scene, and the note says so (and how to read the file).
    pub fn load(&self) -> Res<Scene> {
        let s = scene::load(&self.scene, self.data.as_deref())?;
        let path = Path::new(&self.scene);
        // A file's scene is named by the file (`x.obj`); a built-in one's
        // name never ends so.
        let from_file = [".obj", ".obj.gz"].iter().any(|e| self.scene.ends_with(e));
        if path.is_file() && s.name == self.scene && !self.scene.contains('/') && !from_file {
            eprintln!(
                "note: '{0}' is the built-in scene {0}; the file {0} here is not read (give ./{0} to read it)",
                self.scene
            );
        }
        Ok(s)
    }
}

/// [`check_memory`] once the tree is built: its nodes and the records as
/// its build left them, beside the cast's rays.
pub fn check_built(
    scene: &Scene,
    report: &cellbih::registry::BuildReport,
    cast_rays: Option<usize>,
    c: &Build,
) -> Res<()> {
    let size = (scene.len(), report.bih.nodes.len());
    check_memory(&scene.name, size, cast_rays, c, report.record_order())
}

/// Refuses, naming what and `--memory-mib`, a scene of `triangles` that
/// the emulated Cell's main memory cannot hold: the build's triangle
/// records (an emulated builder), or the cast's tree, triangles, rays and
/// hits (`cast_rays`: rays cast on the Cell; `nodes` 0 before the tree is
/// built, a lower bound).
pub fn check_memory(
    scene: &str,
    (triangles, nodes): (usize, usize),
    cast_rays: Option<usize>,
    c: &Build,
    order: cellbih::cast::RecordOrder,
) -> Res<()> {
    let have = c.cell.main_memory_bytes;
    let least = c.builder.least_memory(triangles, &c.tree, c.cell.spes);
    if c.builder.emulated() && least > have {
        let floor = BuilderKind::PPE_NAIVE.least_memory(triangles, &c.tree, c.cell.spes);
        let what = match least > floor {
            true => format!("their records, {}'s buffers, the fewest nodes", c.builder),
            false => "their records and the fewest nodes".into(),
        };
        return Err(format!(
            "{scene}: building its {triangles} triangles takes at least {} MiB ({what}), \
             more than the emulated Cell's {} MiB (--memory-mib): nothing built",
            least.div_ceil(1 << 20),
            have >> 20
        )
        .into());
    }
    if let Some(rays) = cast_rays {
        let need = cellbih::cast::memory_needed(nodes, triangles, rays, order);
        if need > have {
            let (least, fits, done) = match nodes {
                0 => ("at least ", "above", "nothing built or cast"),
                _ => ("", "from", "the tree was built, nothing cast"),
            };
            // Rounded up: "needs 257 MiB, has 257" must not happen.
            return Err(format!(
                "{scene}: the cast on the Cell ({rays} rays) needs {least}{} MiB of its main \
                 memory for the tree, {triangles} triangles as the build left them, the rays \
                 and their hits; the emulated Cell has {} MiB (--memory-mib: {fits} {} up): {done}",
                need.div_ceil(1 << 20),
                have >> 20,
                need.div_ceil(1 << 20),
            )
            .into());
        }
    }
    Ok(())
}

/// `--camera`: where the rays come from.
#[derive(clap::Args)]
pub struct CameraArg {
    /// Where the camera stands: default (the scene's own viewpoint inside
    /// it where it has one — Sponza's atrium, Šibenik's nave — else the
    /// whole scene from outside), framing (the whole scene from outside),
    /// a viewpoint by name (atrium, nave), or EX,EY,EZ:AX,AY,AZ[:FOV] (an
    /// eye, the point it looks at, the vertical field of view in degrees,
    /// 45 unless given)
    #[arg(long = "camera", value_parser = cellbih::render::View::parse, default_value = "default")]
    pub view: cellbih::render::View,
}
