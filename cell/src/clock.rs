//! Virtual time. Every core of the machine has its own clock in cycles of
//! the 3.2 GHz core clock; nothing in the emulator reads the host's time.

use std::fmt;
use std::ops::{Add, AddAssign, Sub};

/// A count of core clock cycles (3.2 GHz on the PS3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
pub struct Cycles(pub u64);

impl Cycles {
    pub const ZERO: Cycles = Cycles(0);

    /// Milliseconds at `hz` cycles per second.
    pub fn ms(self, hz: f64) -> f64 {
        self.0 as f64 / hz * 1e3
    }

    /// Microseconds at `hz` (the unit of Chrome trace timestamps).
    pub fn us(self, hz: f64) -> f64 {
        self.0 as f64 / hz * 1e6
    }

    /// The last cycle time can reach: a clock there has overflowed.
    pub const END: Cycles = Cycles(u64::MAX);

    /// `items` times `rate`, saturating at [`Cycles::END`].
    pub const fn times(rate: Cycles, items: u64) -> Cycles {
        Cycles(rate.0.saturating_mul(items))
    }

    pub fn saturating_sub(self, o: Cycles) -> Cycles {
        Cycles(self.0.saturating_sub(o.0))
    }
}

/// Time never wraps: a sum past `u64::MAX` cycles (about 182 years at
/// 3.2 GHz) stays there, and the executor ends the run with
/// [`CellError::TimeOverflow`](super::CellError::TimeOverflow) when a
/// clock reaches it.
impl Add for Cycles {
    type Output = Cycles;
    fn add(self, o: Cycles) -> Cycles {
        Cycles(self.0.saturating_add(o.0))
    }
}

impl AddAssign for Cycles {
    fn add_assign(&mut self, o: Cycles) {
        *self = *self + o;
    }
}

impl Sub for Cycles {
    type Output = Cycles;
    fn sub(self, o: Cycles) -> Cycles {
        Cycles(self.0 - o.0)
    }
}

impl fmt::Display for Cycles {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} cycles", self.0)
    }
}
