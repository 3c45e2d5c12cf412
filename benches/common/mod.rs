//! What the benches share: their scenes and the simulated-time measurement.
//! Each bench uses one of the two.
#![allow(dead_code)]

pub mod scenes;
pub mod simulated;
