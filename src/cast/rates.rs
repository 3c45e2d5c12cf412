//! The SPE ray caster's compute rates (section 5's whole frame on the
//! Cell): each kernel counted on the SPU's two pipelines in single and
//! double precision and charged in the run's code class, named `cast.…`
//! so that a run may set them (`--rate`).

use super::{CacheRates, Precision};
use crate::cell::Cycles;
use crate::kernels::rates::{Code, Count, Rate, RateOverrides, overridden};

/// The caster's compute rates, per SPE. The kernels' rates are derived
/// from SPU instruction counts (issue cycles on the two pipelines) and
/// scaled by the partition's fitted/derived ratio like every new kernel;
/// the cache's are a published measurement of an SPU software cache
/// (`docs/cost-model.md`, "The code class").
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct CastRates {
    /// Per ray: the reciprocal direction (an estimate and a Newton step a
    /// component; in double precision a single-precision seed and two
    /// Newton steps), the signs, the slab test of the tree's box (6
    /// subtracts, 6 multiplies, 6 compares and selects, the widening), the
    /// hit written to the tile's buffer. Counted 20 SPU cycles single, 300
    /// double.
    pub ray_setup: Cycles,
    /// Per node visited, inner or leaf: decode (axis, child, clips: 3
    /// odd), the axis' origin and reciprocal picked (2 shuffles), two plane
    /// distances (2 even), near/far by the sign (2 selects), the widening
    /// (2 multiplies), the interval compares and min/max (4), the stack
    /// push or pop (2 odd), the branch. Counted 16 single; 100 double
    /// (about 10 double-precision operations at one every 7 cycles, the
    /// compares on the bit patterns: the SPU has no double compare).
    pub node_step: Cycles,
    /// Per triangle tested: Möller–Trumbore four triangles a vector —
    /// edges (6), `p = d × e2` (6), determinant (3), `s` (3), `u` (3),
    /// `q = s × e1` (6), `v` (3), `t` (3), reciprocal (3), compares and
    /// masks (8), closest-hit update (3): about 55 even-pipe instructions
    /// for four, counted 14 single; 230 double (two triangles a vector,
    /// about 30 double-precision instructions a triangle).
    pub triangle_test: Cycles,
    /// The software cache's own code (Codeplay's measured cache).
    pub cache: CacheRates,
    /// Per switch to another ray while a miss is under way (rays in
    /// flight): the running ray's state stored (4 quadword stores) and the
    /// next one's loaded (4 loads and their 6-cycle latency), the
    /// unhinted branch to where it stopped (the SPU's branch-miss penalty,
    /// "approximately 18-19 cycles", SDK 3.0 programmer's guide). Counted
    /// 32 in either precision.
    pub ray_switch: Cycles,
    /// Packets (`--packet`), per quad of a packet's rays (four rays a
    /// SIMD vector): the reciprocal directions (3 estimates and 3 Newton
    /// steps, 12 even), the slab test of the tree's box (28), the active
    /// bits (2), the hits written (4 stores, odd). Counted 44 single; 600
    /// double (two double vectors, each the single ray's arithmetic).
    pub packet_setup_quad: Cycles,
    /// Per node a packet visits: decode (3 odd), the clip planes splatted
    /// (2 shuffles), the any-active test and its branch (1), the stack's
    /// push or pop of the node and its mask (2 odd). Counted 8.
    pub packet_node: Cycles,
    /// Per quad of rays with an active ray at a node the packet visits:
    /// the axis' origins and reciprocals picked (2 loads), the two plane
    /// distances (2 multiply-subtracts), the widening (2), the interval
    /// compares (2) and masks (2), the near and far intervals' min and max
    /// (2 selects), the far interval stored (2 odd): 10 even, 6 odd,
    /// dual-issued. Counted 12 single, 200 double.
    pub packet_node_quad: Cycles,
    /// Per triangle a packet tests: its vertices splatted across the
    /// vector (9 shuffles, odd), its two edges (6 even, beside them).
    /// Counted 9.
    pub packet_triangle: Cycles,
    /// Per quad of rays with an active ray, per triangle: Möller–Trumbore
    /// four rays a vector and the closest-hit update of `t`, id, `u`, `v`
    /// (4 selects): about 48 even-pipe instructions. Counted 48 single,
    /// 460 double.
    pub packet_triangle_quad: Cycles,
}

/// The caster's kernels' counts (SPU cycles, [`CastRates`]' fields give
/// each) in one precision: ray setup, node step, triangle test, packet
/// setup a quad, packet node, packet node a quad, packet triangle, packet
/// triangle a quad.
struct Counts([u64; 8]);

impl Precision {
    /// Counted in single precision; in double, a double-precision
    /// instruction issues once every 7 cycles and a packet's quad is two
    /// double vectors.
    const fn counts(self) -> Counts {
        match self {
            Precision::Single => Counts([20, 16, 14, 44, 8, 12, 9, 48]),
            Precision::Double => Counts([300, 100, 230, 600, 8, 200, 9, 460]),
        }
    }

    /// The caster's rates when charged for this arithmetic in the class
    /// `code` (the software cache's lookup and miss are measured: the same
    /// in both).
    pub fn rates(self, code: Code) -> CastRates {
        let c = self.counts().0;
        let at = |i: usize| code.charge(Count::of(c[i]));
        CastRates {
            ray_setup: at(0),
            node_step: at(1),
            triangle_test: at(2),
            cache: CacheRates::of(code),
            ray_switch: code.charge(Count::of(RAY_SWITCH)),
            packet_setup_quad: at(3),
            packet_node: at(4),
            packet_node_quad: at(5),
            packet_triangle: at(6),
            packet_triangle_quad: at(7),
        }
    }
}

/// A switch to another ray on a miss: 4 quadword stores and 4 loads (odd
/// pipe), the loads' 6-cycle latency, the SPU's 18-cycle branch-miss
/// penalty: 32, in either precision.
const RAY_SWITCH: u64 = 32;

impl CastRates {
    /// The caster's rates in `precision` and the class `code`, each named
    /// (`cast.…`) and banded; the software cache's are its own
    /// ([`CacheRates::table`], `cache.…`).
    pub fn table(precision: Precision, code: Code) -> Vec<Rate<CastRates>> {
        let c = precision.counts().0;
        let band = |i: usize| code.band(Count::of(c[i]));
        crate::rate_table!(CastRates, "cast.", {
            ray_setup: band(0),
            node_step: band(1),
            triangle_test: band(2),
            ray_switch: code.band(Count::of(RAY_SWITCH)),
            packet_setup_quad: band(3),
            packet_node: band(4),
            packet_node_quad: band(5),
            packet_triangle: band(6),
            packet_triangle_quad: band(7),
        })
        .to_vec()
    }

    /// The rates of a cast: `precision`'s in the class of `rates`, with
    /// its overrides.
    pub fn of(precision: Precision, rates: &RateOverrides) -> CastRates {
        let code = rates.code();
        let cast = overridden(precision.rates(code), &Self::table(precision, code), rates);
        CastRates {
            cache: CacheRates::with(rates),
            ..cast
        }
    }
}
