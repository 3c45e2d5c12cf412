//! What the emulated strategies share: the triangle records' layout in main
//! memory ([`layout`]), Fig. 1's five-buffer streaming partition ([`fig1`]),
//! the ObjectArena ([`arena`]; the PPE side of a pool that grows:
//! [`pool_server`]), the counting barrier ([`barrier`]), the
//! WorkA/WorkB job queue of Fig. 2 ([`work_queue`]), the baseline's
//! breadth-first loop over it ([`breadth_first`]), section 2's cooperative
//! partition ([`coop`]), the top levels of the multi-SPE strategies and
//! their ObjectArena pool ([`top`]), the memory footprint by purpose
//! ([`footprint`]) and the software cache an SPE reads main memory through
//! ([`software_cache`]: the ray caster's, and `spe_bfs_shared`'s job
//! queue's as a knob).

pub mod arena;
pub mod barrier;
pub mod breadth_first;
pub mod coop;
pub mod fig1;
pub mod footprint;
pub mod layout;
pub mod pool_server;
pub mod software_cache;
pub mod top;
pub mod work_queue;
