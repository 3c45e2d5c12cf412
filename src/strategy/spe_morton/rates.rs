//! `spe_morton`'s own kernels' rates (section 5's Morton route: the keys
//! and the radix sort), each derived from an instruction count on the
//! SPU's two pipelines and charged in the run's code class.

use glam::Vec3A;

use crate::cell::Cycles;
use crate::kernels::quantise::QuantisedKeys;
use crate::kernels::rates::{Code, Count, Rate, RateOverrides, overridden};

/// The rates of this strategy's own kernels, SPE cycles: each derived
/// from an instruction count on the SPU's two pipelines ([`COUNTS`]) and
/// charged in the run's code class ([`Code`]), `docs/cost-model.md`.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct MortonRates {
    /// Per triangle, once per key, four triangles a vector: the four
    /// records' 12 quadwords loaded and transposed (12 loads, 12 shuffles,
    /// odd pipe), their boxes' min and max (24 compares and selects) and
    /// centers (3 adds, 3 multiplies), the cell started at the scene box,
    /// the index vector bumped, the four key pairs assembled and stored (4
    /// shuffles, 4 stores): about 30 even and 30 odd, dual-issued 30 per
    /// four triangles. Counted 7.5 a triangle.
    pub key_setup: Cycles,
    /// Per triangle per key bit, four triangles a vector: the cell's three
    /// extents (3 subtracts), the longest axis (2 compares, 3 selects), that
    /// axis' bounds (4 selects), the midpoint (2), the center's coordinate
    /// (2 selects), the compare (1), the key's shift and or (2; 4 for
    /// 64-bit keys), the cell's update (6 selects, 3 ands): 28–30 even-pipe
    /// instructions per four triangles. Counted 7.5 a triangle. Charged
    /// for every bit of a key the quantisation settles (a center near a
    /// halving plane) or does not cover (`kernels::quantise`).
    pub key_bit: Cycles,
    /// Per triangle, once per key the quantisation covers, four triangles
    /// a vector, per axis: the offset and its scale (2), clamped at 0 (2),
    /// converted to a code and clamped to the last (3), back to a float
    /// and the fraction (2), the fraction against the margin at both ends
    /// and the code not at that end (6), the settle mask (1): 16 even; the
    /// three axes' masks gathered and branched on (2 even, 2 odd): 50 even
    /// per four triangles. Counted 12.5 a triangle.
    pub key_quantise: Cycles,
    /// Per triangle per key bit of a quantised key, four triangles a
    /// vector: the code's bit masked, shifted to its place and or-ed into
    /// the key's word (3 even). Counted 0.75, charged 0.8 a triangle.
    pub key_spread: Cycles,
    /// Per key of a radix-sort histogram step — the key loaded, the digit
    /// shifted and masked (2), its count loaded, bumped and stored, four
    /// count tables interleaved so that keys of one digit do not wait on
    /// each other's store: 3 even and 3 odd, dual-issued — and per entry of
    /// the prefix sum over the counts; the scatter pays it again per key
    /// and per digit of each block (about 1,024 keys), for the block's own
    /// histogram and prefix (its pairs staged in order of their places).
    /// Counted 3.
    pub radix_count: Cycles,
    /// Per key of a radix-sort scatter step: the digit (2), its offset
    /// loaded and bumped (1 even, 2 odd), the pair copied into the staging
    /// buffer in order of place (2 odd, 1 even), a DMA-list element where
    /// a run of places ends (about 1 even and 1 odd a key): 5 even, 5 odd,
    /// with a dependent load. Also per record of a gather list (address =
    /// base + 48 × index, an 8-byte element stored, the record's id stored
    /// over its pair's index: fewer instructions, charged the same).
    /// Counted 5.5.
    pub radix_scatter: Cycles,
    /// Per probe of a split's binary search over keys in the local store:
    /// the pair's address (1 even), its load (1 odd, 6 cycles to use),
    /// the bit masked and compared (2 even, dependent), the bounds
    /// selected (2 even) and the loop's branch (1 odd): a dependent chain
    /// of about 12 cycles, nothing to pair it with. Counted 12.
    pub key_probe: Cycles,
}

/// The instruction counts of [`MortonRates`]' kernels, in its fields'
/// order: key setup, key bit, key quantise, key spread, radix count,
/// radix scatter, key probe.
pub const COUNTS: [Count; 7] = [
    Count::tenths(75),
    Count::tenths(75),
    Count::tenths(125),
    Count::tenths(8),
    Count::of(3),
    Count::tenths(55),
    Count::of(12),
];

impl MortonRates {
    /// The PS3's in the class `code`.
    pub const fn of(code: Code) -> MortonRates {
        MortonRates {
            key_setup: code.charge(COUNTS[0]),
            key_bit: code.charge(COUNTS[1]),
            key_quantise: code.charge(COUNTS[2]),
            key_spread: code.charge(COUNTS[3]),
            radix_count: code.charge(COUNTS[4]),
            radix_scatter: code.charge(COUNTS[5]),
            key_probe: code.charge(COUNTS[6]),
        }
    }

    /// The keys of `centers` by `q` into `keys`, and what they cost: each
    /// its setup, and its quantisation and bits spread where `q` covers the
    /// spec; a key settled by halving (near a plane, or not covered) its
    /// bits halved one at a time.
    pub(super) fn keys(&self, q: &QuantisedKeys, centers: &[Vec3A], keys: &mut [u64]) -> Cycles {
        let done = q.keys(centers, keys);
        let bits = q.bits() as u64;
        let quantised = match q.covers() {
            true => self.key_quantise.0 + self.key_spread.0 * bits,
            false => 0,
        };
        let per_key = Cycles::times(Cycles(self.key_setup.0 + quantised), done.keys);
        per_key + Cycles::times(Cycles(self.key_bit.0 * bits), done.settled)
    }

    /// The rates of a run: its class, with its overrides.
    pub(super) fn with(overrides: &RateOverrides) -> Self {
        let code = overrides.code();
        overridden(Self::of(code), &Self::table(code), overrides)
    }

    /// Its rates, each derived, banded by [`Code::band`].
    pub fn table(code: Code) -> Vec<Rate<MortonRates>> {
        crate::rate_table!(MortonRates, "spe_morton.", {
            key_setup: code.band(COUNTS[0]),
            key_bit: code.band(COUNTS[1]),
            key_quantise: code.band(COUNTS[2]),
            key_spread: code.band(COUNTS[3]),
            radix_count: code.band(COUNTS[4]),
            radix_scatter: code.band(COUNTS[5]),
            key_probe: code.band(COUNTS[6]),
        })
        .to_vec()
    }
}

#[cfg(test)]
mod tests {
    use super::{Code, MortonRates};

    #[test]
    fn the_rate_table_names_every_rate_once() {
        for code in Code::ALL {
            crate::kernels::rates::check_table(
                MortonRates::of(code),
                &MortonRates::table(code),
                "spe_morton.",
            );
        }
    }
}
