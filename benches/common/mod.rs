//! What the benches share: their scenes and the simulated-time measurement.
//! Each bench uses one of the two.
#![allow(dead_code, unused_macros, unused_imports)]

pub mod scenes;
pub mod simulated;
