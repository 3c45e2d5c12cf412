//! The host benches' scenes: the default scene and, when CELLBIH_DATA is
//! set, bunny and dragon (said so when it is not).

use cellbih::scene::{self, Scene};

pub fn default_bunny_dragon() -> Vec<Scene> {
    let mut v = vec![scene::load("default", None).unwrap()];
    match scene::data_dir(None) {
        Some(dir) => {
            for name in ["bunny", "dragon"] {
                v.push(scene::load(name, Some(&dir)).unwrap());
            }
        }
        None => eprintln!("CELLBIH_DATA is not set: benchmarking the default scene only"),
    }
    v
}
