//! Programs for the emulated Cell, one file per strategy, named as the
//! paper names them. So far: the SPE's in-place streaming partition of
//! Fig. 1 ([`fig1`]), the kernel of the paper's SPE builders.

pub mod fig1;
