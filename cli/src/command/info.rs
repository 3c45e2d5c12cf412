//! `cellbih info`: a scene's triangles, geometry ids, bounds and
//! degenerate triangles.

use crate::Res;
use crate::args::InfoCommand;

/// Runs `cellbih info`.
pub fn run(args: InfoCommand) -> Res<()> {
    super::print::info(&args.scene.load()?, args.format)
}
