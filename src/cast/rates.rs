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
    /// hit written to the tile's buffer: 20 SPU cycles single, 300
    /// double. The watertight test's shear adds 8: `|d|` (1 mask), the
    /// largest axis (2 compares, 2 selects), the swap on its sign (1
    /// compare, 1 select), `s` (1 multiply by the reciprocal already
    /// made), the origin permuted (3 shuffles and a control word's load,
    /// odd, beside them); in double 23 (the multiply at 7 cycles, the 4
    /// compares on bit patterns at 3 integer instructions each, the 4
    /// selects). Counted 28 single, 323 double.
    pub ray_setup: Cycles,
    /// Per node visited, inner or leaf: decode (axis, child, clips: 3
    /// odd), the axis' origin and reciprocal picked (2 shuffles), two plane
    /// distances (2 even), near/far by the sign (2 selects), the widening
    /// (2 multiplies), the interval compares and min/max (4), the stack
    /// push or pop (2 odd), the branch. Counted 16 single; 100 double
    /// (about 10 double-precision operations at one every 7 cycles, the
    /// compares on the bit patterns: the SPU has no double compare).
    pub node_step: Cycles,
    /// Per triangle tested: the watertight test four triangles a vector
    /// (Woop, Benthin & Wald 2013; the vertices' components picked in the
    /// ray's axis order by address, free) — the vertices less the origin
    /// (9 subtracts), sheared (6 multiply-subtracts) and scaled (3
    /// multiplies), the edge functions (3 multiplies, 3 multiply-subtracts),
    /// the determinant (2), the sign tests (6 compares, 4 ands and ors),
    /// the determinant's check (2), the ties' check (3 compares, 1 or,
    /// its branch rarely taken), `t`'s numerator (1 multiply, 2 fused
    /// adds), reciprocal (4) and product (1), its range (2 compares, 1
    /// and), the closest-hit update (3): 56 even-pipe instructions for
    /// four, counted 14 single; 230 double (two triangles a vector, about
    /// 30 double-precision instructions a triangle, as for
    /// Möller–Trumbore, whose count this matches).
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
    /// bits (2), the hits written (4 stores, odd): 44 single, 600 double
    /// (two double vectors, each the single ray's arithmetic). The four
    /// rays' shears add 20: `|d|` (3 masks), the largest axis (2
    /// compares, 2 selects), the swap on its sign (1 compare, 2 selects),
    /// the direction's and origin's components picked lane by lane (8
    /// selects), `s` (2 multiplies); in double 74 (37 a double vector:
    /// the 2 multiplies at 7 cycles, the compares on bit patterns and the
    /// selects). Counted 64 single, 674 double.
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
    /// vector (9 shuffles, odd). Counted 9.
    pub packet_triangle: Cycles,
    /// Per quad of rays with an active ray, per triangle: the watertight
    /// test's edge functions four rays a vector (the splatted vertices
    /// picked in the quad's axis order, free) — the vertices less each
    /// origin (9 subtracts), sheared (6 multiply-subtracts), the edge
    /// functions (3 multiplies, 3 multiply-subtracts), the determinant
    /// (2), the sign tests (6 compares, 4 ands and ors), the determinant's
    /// check (2), the ties' check (3 compares, 1 or), the mask's branch
    /// (1, hinted not taken): 40 even-pipe instructions. Counted 40
    /// single; 399 double (two double vectors: the 23 arithmetic
    /// instructions at 7 cycles, 322; the 11 compares on bit patterns at 3
    /// integer instructions, the ors and the branch, 77).
    pub packet_triangle_quad: Cycles,
    /// Per quad of rays with a ray whose line meets the triangle (its
    /// edge functions agree), per triangle: the rest, behind the mask's
    /// branch — the depths (3 multiplies), `t`'s numerator (1 multiply, 2
    /// fused adds), reciprocal (4) and product (1), its range (2 compares,
    /// 1 and), the closest-hit update of `t`, id, `u`, `v` (4 selects),
    /// and the taken branch's 18-cycle miss. Counted 36 single; 208
    /// double (two vectors: 12 arithmetic instructions at 7 cycles, 168;
    /// the compares on bit patterns and the selects, 22; the miss, 18).
    pub packet_triangle_hit_quad: Cycles,
    /// Per quad of rays whose shears permute the axes differently (rays
    /// whose largest direction component differs), per triangle: the nine
    /// vertex components picked lane by lane (2 selects each). Counted 18
    /// single, 36 double (the selects on each of two vectors).
    pub packet_triangle_mixed: Cycles,
}

/// The caster's kernels' counts (SPU cycles, [`CastRates`]' fields give
/// each) in one precision: ray setup, node step, triangle test, packet
/// setup a quad, packet node, packet node a quad, packet triangle, packet
/// triangle a quad, packet triangle a mixed quad, packet triangle a quad
/// that meets it.
struct Counts([u64; 10]);

impl Precision {
    /// Counted in single precision; in double, a double-precision
    /// instruction issues once every 7 cycles and a packet's quad is two
    /// double vectors.
    const fn counts(self) -> Counts {
        match self {
            Precision::Single => Counts([28, 16, 14, 64, 8, 12, 9, 40, 18, 36]),
            Precision::Double => Counts([323, 100, 230, 674, 8, 200, 9, 399, 36, 208]),
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
            packet_triangle_mixed: at(8),
            packet_triangle_hit_quad: at(9),
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
            packet_triangle_mixed: band(8),
            packet_triangle_hit_quad: band(9),
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
