//! What the emulated builders share beyond the SPE toolkit ([`crate::spe`]):
//! the ObjectArena ([`arena`]; the PPE side of a pool that grows:
//! [`pool_server`]), the WorkA/WorkB job queue of Fig. 2 ([`work_queue`]),
//! the baseline's breadth-first loop over it ([`breadth_first`]), section
//! 2's cooperative partition ([`coop`]), and the top levels of the
//! multi-SPE strategies and their ObjectArena pool ([`top`]), and section
//! 5's breadth-first program with its policies as values ([`policies`]).

pub mod arena;
pub mod arena_words;
pub mod breadth_first;
pub mod coop;
pub mod forecast;
pub mod node_writes;
pub mod policies;
pub mod pool_server;
pub mod top;
pub mod work_queue;
