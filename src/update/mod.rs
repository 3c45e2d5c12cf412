//! Updates after objects move (the paper's section 3, issue 5).
//!
//! So far: moving objects and the deterministic animations of the paper's
//! scenes ([`animation`]). Algorithm 1 (the EBB, the enclosing node, the
//! rebuild of its interval) and the deeper update build on these.

pub mod animation;

pub use animation::{Animation, Move, apply};
