//! cellbih: building Bounding Interval Hierarchies (BIH) on an emulated Cell
//! Broadband Engine — a PPE and 6–8 SPEs whose 256 KiB local stores reach
//! memory only by DMA — and measuring what each construction strategy costs
//! (simulated PS3 time, deterministic) and what tree it gives. It reproduces
//! Weier, Roth & Hinkenjann (2009): the emulator ([`cell`]), the paper's
//! four builders and its local update, and runs the paper's section 5
//! strategies on 1–8 SPEs.
//!
//! The parts, from the bottom up: [`scene`] (triangles), [`bih`] (the one
//! tree type: nodes, traversal, validation), [`kernels`] (the plain
//! functions host and SPE code share), [`cell`] (the emulator, which knows
//! nothing of trees), [`host`] (builders on the host's cores), [`spe`]
//! (the SPE toolkit both the builders and the ray caster stand on),
//! [`strategy`] (programs for the emulated Cell), and on top of both
//! families the [`registry`] of builders, which every command, test, bench
//! and experiment iterates. Then [`update`] (section 3's local update),
//! [`quality`] and [`render`]. The library does not print, parse
//! arguments or exit: the `cellbih` command, the experiments and their
//! harness are the `cellbih-cli` crate (`cli/`), and the emulator is the
//! `cellbih-cell` crate (`cell/`), re-exported here as [`cell`].
//!
//! Load a scene, build its tree with a builder of the registry on the
//! emulated PS3 (one [`registry::Build`] request), check the tree, and cast a ray through it:
//!
//! ```
//! use cellbih::bih::{BihConfig, Ray, RayStats, Tracer, brute_force_closest};
//! use cellbih::registry::{Build, BuilderKind};
//! use glam::DVec3;
//!
//! let scene = cellbih::scene::load("default", None)?;
//! let spe_bfs = BuilderKind::from_name("spe_bfs").expect("the baseline is registered");
//! // A build request: the builder with the paper's tree on the PS3 model
//! // (`with_tree`, `on`, `with_knobs` change it).
//! let report = Build::new(spe_bfs).with_tree(BihConfig::default()).run(&scene)?;
//! report.bih.validate(&scene)?;
//! let simulated = report.simulated.as_ref().expect("an emulated builder reports its run");
//! println!("{} nodes in {:.2} simulated ms", report.bih.nodes.len(), simulated.run.ms);
//!
//! let center = scene.bounds().center().as_dvec3();
//! let ray = Ray::new(center - DVec3::new(0.0, 0.0, 1e3), DVec3::Z);
//! let hit = Tracer::new(&report.bih, &scene).closest(&ray, &mut RayStats::default());
//! let expected = brute_force_closest(&scene, &ray);
//! assert!(hit.is_some(), "the ray aims at the scene's center");
//! assert_eq!(hit.map(|h| h.t), expected.map(|h| h.t));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The README and `docs/` say how to run the `cellbih` command, the
//! experiments and the benches; `docs/adding-a-strategy.md` how to add a
//! builder.

pub mod aabb;
pub mod bih;
pub mod cast;
pub use cellbih_cell as cell;
pub mod frame;
pub mod host;
pub mod kernels;
pub mod quality;
pub mod rays_csv;
pub mod registry;
pub mod render;
pub mod scene;
pub mod spe;
pub mod strategy;
pub mod text_input;
pub mod update;
pub mod words;
