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

    pub fn saturating_sub(self, o: Cycles) -> Cycles {
        Cycles(self.0.saturating_sub(o.0))
    }
}

impl Add for Cycles {
    type Output = Cycles;
    fn add(self, o: Cycles) -> Cycles {
        Cycles(self.0 + o.0)
    }
}

impl AddAssign for Cycles {
    fn add_assign(&mut self, o: Cycles) {
        self.0 += o.0;
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
