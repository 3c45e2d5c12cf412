//! The SPE toolkit: what the SPE programs of both the builders
//! ([`crate::strategy`]) and the ray caster ([`crate::cast`]) stand on, so
//! that neither imports the other — the triangle records' layout in main
//! memory ([`layout`]), Fig. 1's five-buffer streaming partition
//! ([`fig1`]), the software cache an SPE reads main memory through
//! ([`software_cache`]: the caster's, and `spe_bfs_shared`'s job queue's as
//! a knob), the counting barrier ([`barrier`]) and the memory footprint by
//! purpose ([`footprint`]). Written against the emulator's API
//! ([`crate::cell`]) and the shared kernels; it knows no strategy.

pub mod barrier;
pub mod fig1;
pub mod footprint;
pub mod layout;
pub mod software_cache;
