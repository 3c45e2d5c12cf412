//! The plain functions that host builders and SPE programs share (DESIGN.md
//! rule 3): the global heuristic's split choice and the in-place partition
//! ([`split`]), binned SAH ([`sah`]), the empty-space cut-off ([`cutoff`]),
//! the node decision ([`decide`]), the recursion written once over boxed
//! items ([`recursion`]), the bucket presort of approximate sorting
//! ([`approx`]), Morton keys ([`morton`]) and their halving tables
//! ([`halving`]) and their quantisation ([`quantise`]), the radix-sort passes ([`radix`]), and their compute
//! rates ([`rates`]; the PPE's update steps' in [`ppe_rates`]).
//! A host builder calls them on whole arrays, an SPE program on
//! local-store blocks.

pub mod approx;
pub mod cutoff;
pub mod decide;
pub mod halving;
pub mod morton;
pub mod ppe_rates;
pub mod quantise;
pub mod radix;
pub mod rates;
pub mod recursion;
pub mod sah;
pub mod split;
