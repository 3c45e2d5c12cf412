//! cellbih: building Bounding Interval Hierarchies on an emulated Cell
//! Broadband Engine, and measuring what each construction strategy costs and
//! what tree it gives. See `README.md` and `../shared/DESIGN.md`.

pub mod aabb;
pub mod bih;
pub mod cell;
pub mod host;
pub mod kernels;
pub mod output;
pub mod quality;
pub mod rays_csv;
pub mod registry;
pub mod render;
pub mod report;
pub mod scene;
pub mod strategy;
pub mod update;
