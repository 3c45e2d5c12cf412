//! `cellbih update`'s printing and the animation options `update` and
//! `frame` share.

use serde_json::json;

use cellbih::registry::Settings;
use cellbih::scene::Scene;
use cellbih::update::{Animation, Method, Summary, Updater};

use crate::Res;
use crate::args::{
    AnimationArg, Format, PlayArgs, SceneArg, UpdateCommand, check_memory, parse_build,
};

/// Runs `cellbih update`.
pub fn run(args: UpdateCommand) -> Res<()> {
    let UpdateCommand {
        play: asked,
        frames,
        strategy,
        deep_stop_below,
        format,
    } = args;
    let c = parse_build(&asked.build, false)?;
    let method = Method::from_name(&strategy)
        .ok_or_else(|| format!("unknown --strategy '{strategy}': local, deep or rebuild"))?;
    let find_moved = asked.find_moved(
        method == Method::Local,
        &format!("--strategy {strategy}"),
        &c,
    )?;
    let PlayArgs { scene, anim, .. } = asked;
    if deep_stop_below.is_some() && method != Method::Deep {
        return Err(format!(
            "--deep-stop-below applies to --strategy deep only (here: {strategy})"
        )
        .into());
    }
    let deep_stop_below = deep_stop_below.unwrap_or(cellbih::update::DEEP_STOP_BELOW);
    let mut settings = anim
        .named(Settings::new(&c, None))
        .with("frames", frames)
        .with("strategy", strategy.as_str());
    if method == Method::Deep {
        settings = settings.with("deep-stop-below", deep_stop_below);
    }
    if method == Method::Local {
        settings = settings.with("find-moved", find_moved.name());
    }
    scene.check_fits(&c, None)?;
    let (s, anim) = anim.load(&scene, frames)?;
    check_memory(&s.name, (s.len(), 0), None, &c, Default::default())?;
    // The first build and every rebuild on the builder's threads.
    c.install(|| {
        let mut u = Updater::new(s, c.clone(), method).map_err(|e| e.to_string())?;
        u.deep_stop_below = deep_stop_below;
        u.find_moved = find_moved;
        play(&mut u, &anim, format, &c.describe(), &settings).map_err(|e| e.to_string())
    })??;
    Ok(())
}

impl AnimationArg {
    /// `settings` with the animation and its seed.
    pub fn named<'a>(&self, settings: Settings<'a>) -> Settings<'a> {
        settings
            .with("animation", self.animation.as_str())
            .with("seed", self.seed)
    }

    /// The scene as the animation plays it, and its frames.
    pub fn load(&self, scene: &SceneArg, frames: u64) -> Res<(Scene, Animation)> {
        let s = Animation::prepare(&self.animation, scene.load()?)?;
        let anim = Animation::named(&self.animation, &s, frames as usize, self.seed)?;
        Ok((s, anim))
    }
}

/// Plays `anim`, printing each frame; `builder` says which builder on what
/// ("builder host_shared on 2 host threads").
pub fn play(
    u: &mut Updater,
    anim: &Animation,
    format: Format,
    builder: &str,
    settings: &Settings,
) -> Res<()> {
    let text = matches!(format, Format::Text);
    if text {
        println!(
            "{} on {} ({}), {} update, {builder}",
            anim.name,
            u.scene.name,
            crate::report::count(u.scene.len() as u64, "triangle"),
            u.method.name(),
        );
        let line = format!("settings: {}", settings.line());
        println!("{}", crate::report::wrap(&line, 80));
        println!(
            "{:>5} {:>5} {:>7} {:>5} {:>12} {:>7} {:>7} {:>7} {:>8} {:>8}",
            "frame", "moves", "kind", "depth", "stop", "trans", "rec", "kept", "host ms", "sim ms"
        );
    }
    let mut reports = Vec::with_capacity(anim.frames.len());
    for (f, moves) in anim.frames.iter().enumerate() {
        let r = u.step(moves)?;
        if text {
            let kind = match (r.full_rebuild, moves.iter().all(|m| m.is_identity())) {
                (true, _) => "rebuild",
                (false, true) => "marked",
                (false, false) => "partial",
            };
            let stop = r.stop.map_or("-".to_string(), |s| format!("{s:?}"));
            let sim = r.simulated_ms.map_or("-".into(), |ms| format!("{ms:.3}"));
            println!(
                "{f:>5} {:>5} {kind:>7} {:>5} {stop:>12} {:>7} {:>7} {:>7} {:>8.3} {sim:>8}",
                r.moves, r.depth, r.transformed, r.rebuilt, r.kept, r.host_ms
            );
        }
        reports.push(r);
    }
    let sum = Summary::of(&reports);
    let sah = u.bih.quality().sah_cost;
    // A fresh build by the update's own builder, so that the comparison
    // shows what the update did to the tree, not how builders differ.
    let fresh = (u.build.run(&u.scene)?).bih.quality().sah_cost;
    if text {
        let Some(sum) = sum else {
            println!("\nno frames ran (--frames 0): nothing to sum up");
            println!("SAH cost of the tree {sah:.2}");
            return Ok(());
        };
        let ratio = sum.ratio.map_or("no complete rebuilds".to_string(), |r| {
            format!("ratio {r:.2}")
        });
        println!(
            "\nupdates {} · complete rebuilds {} · {ratio}",
            sum.updates, sum.rebuilds
        );
        let [lo, hi, avg] = sum.host_ms;
        println!("host ms per frame: min {lo:.3} · max {hi:.3} · mean {avg:.3}");
        if let Some([lo, hi, avg]) = sum.simulated_ms {
            println!("simulated ms per frame: min {lo:.3} · max {hi:.3} · mean {avg:.3}");
        }
        let line = format!(
            "mean triangles: transformed {:.1} · rebuilt {:.1} · difference {:.1} · kept {:.1}",
            sum.transformed, sum.rebuilt, sum.delta, sum.kept
        );
        println!("{}", crate::report::wrap(&line, 80));
        println!("mean depth of the subtrees rebuilt {:.2}", sum.depth);
        println!(
            "SAH cost after the last frame {sah:.2}, of a fresh build by {} {fresh:.2} ({:+.1}%)",
            u.build.builder,
            (sah / fresh - 1.0) * 100.0
        );
    } else {
        println!(
            "{}",
            json!({
                "settings": settings.to_json(), "deep_stop_below": u.deep_stop_below,
                "scene": u.scene.name, "triangles": u.scene.len(), "animation": anim.name,
                "method": u.method, "builder": u.build.builder.name(),
                "spes": u.build.builder.emulated().then_some(u.build.cell.spes), "frames": reports,
                "summary": sum, "sah_after": sah, "sah_fresh_build": fresh,
            })
        );
    }
    Ok(())
}
