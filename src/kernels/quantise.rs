//! Morton keys at the cost of a key, not of its bits (section 5's Morton
//! route; [`super::morton`]): a key in the global heuristic's order from
//! the center quantised once an axis, exact wherever the center is not
//! within rounding of a halving plane, and settled by the halvings
//! themselves ([`KeySpec::key`]) where it is.
//!
//! Why it holds. Halving a box at the middle of its longest axis gives two
//! boxes of one shape, up to `f32`'s rounding; while the bounds on every
//! cell's extents leave no doubt which axis is longest, every cell of a
//! depth halves the same axis, and an axis halved `d` times has its planes
//! near the dyadic points `lo + ext · j / 2^d`: each plane is
//! `fl(l/2 + h/2)` of planes that are themselves off by at most
//! `(d − 1) · u / 2` (`u`: one `f32` ulp of the axis's largest magnitude),
//! so it is off by at most `d · u / 2`. A center more than that (and the
//! quantisation's own rounding) away from the two dyadic points around it
//! is between the same two planes; its leaf among the axis's `2^d`
//! intervals is then `floor((c − lo) / ext · 2^d)`, and that code's bits,
//! first halving first, are the key's bits of that axis, spread to the
//! depths that halve it. Nothing here is fitted: the key is always
//! [`KeySpec::key`]'s (checked by the tests at the extremes).
//!
//! Where the bounds leave a depth's axis in doubt (extents within rounding
//! of a power of two of each other: a square floor's box after two
//! halvings), the axes' intervals are enumerated and decide, as
//! [`super::halving`]'s tables do. Where the cells of a depth truly
//! disagree, a cell may be too thin to halve, or the quantisation's
//! rounding reaches a quarter of a cell, the keys of that spec are not
//! quantised at all: each is [`KeySpec::key`]'s, halving by halving
//! ([`QuantisedKeys::covers`]).

use glam::Vec3A;

use super::halving::longest;
use super::morton::{KeyOrder, KeySpec};

/// The quantisation of a [`KeySpec`]'s keys: per axis where it starts, its
/// scale to codes, its margin, and the key bits its code's bits go to.
#[derive(Clone, Debug)]
pub struct QuantisedKeys {
    spec: KeySpec,
    /// `None`: the halvings' axes are not the same in every cell down to
    /// the key's last bit (every key is settled).
    axes: Option<[Axis; 3]>,
    /// Halvings made to find its axes (where their extents tie).
    setup: u64,
}

#[derive(Clone, Debug, Default)]
struct Axis {
    lo: f32,
    /// `2^depth / ext`: from a coordinate's offset to its code.
    scale: f32,
    /// Halvings of this axis in the key.
    depth: u32,
    /// Within this much of a code's ends (in codes), a center is settled.
    margin: f32,
    /// The key bit of each of its halvings, first first.
    places: Vec<u32>,
}

/// What keying a batch did: keys settled by halving, out of all.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Keyed {
    pub keys: u64,
    pub settled: u64,
}

/// Depths an axis is quantised to at most: beyond, `f32`'s rounding of the
/// code reaches a quarter of a cell.
const MOST_DEPTH: u32 = 20;

impl QuantisedKeys {
    /// The quantisation of `spec`'s keys.
    pub fn new(spec: &KeySpec) -> QuantisedKeys {
        let (axes, setup) = match spec.order {
            KeyOrder::GlobalHeuristic => halvings(spec),
            KeyOrder::RoundRobin => (None, 0),
        };
        QuantisedKeys {
            spec: *spec,
            axes,
            setup,
        }
    }

    /// The halvings made to find the axes, once per spec (each as much
    /// work as a key bit).
    pub fn setup_halvings(&self) -> u64 {
        self.setup
    }

    /// Whether keys are quantised (else each is settled by halving; the
    /// round-robin order is a grid's quantisation already).
    pub fn covers(&self) -> bool {
        self.axes.is_some() || self.spec.order == KeyOrder::RoundRobin
    }

    /// The key's width.
    pub fn bits(&self) -> u32 {
        self.spec.bits
    }

    /// The key of a triangle whose box center is `c` ([`KeySpec::key`]'s),
    /// and whether it had to be settled by halving.
    #[inline]
    pub fn key(&self, c: Vec3A) -> (u64, bool) {
        let Some(axes) = &self.axes else {
            let settled = self.spec.order == KeyOrder::GlobalHeuristic;
            return (self.spec.key(c), settled);
        };
        let mut key = 0u64;
        for (a, axis) in axes.iter().enumerate() {
            if axis.depth == 0 {
                continue;
            }
            let t = (c[a] - axis.lo).max(0.0) * axis.scale;
            let last = (1u32 << axis.depth) - 1;
            let code = (t as u32).min(last);
            let frac = t - code as f32;
            let near_low = code > 0 && frac < axis.margin;
            let near_high = code < last && frac > 1.0 - axis.margin;
            if near_low || near_high {
                return (self.spec.key(c), true);
            }
            for (i, &place) in axis.places.iter().enumerate() {
                let bit = code >> (axis.depth as usize - 1 - i) & 1;
                key |= (bit as u64) << place;
            }
        }
        (key, false)
    }

    /// The keys of `centers` into `keys`; what it did.
    pub fn keys(&self, centers: &[Vec3A], keys: &mut [u64]) -> Keyed {
        let mut settled = 0;
        for (k, &c) in keys.iter_mut().zip(centers) {
            let (key, s) = self.key(c);
            *k = key;
            settled += s as u64;
        }
        Keyed {
            keys: centers.len() as u64,
            settled,
        }
    }
}

/// One `f32` ulp at the largest magnitude of `lo..hi`, in `f64`.
fn ulp(lo: f32, hi: f32) -> f64 {
    let m = lo.abs().max(hi.abs());
    (f32::from_bits(m.to_bits() + 1) - m) as f64
}

/// Axes halved at most this many times are enumerated where the bounds
/// on their extents leave the longest axis in doubt (2^16 intervals).
const MOST_ENUMERATED: u32 = 16;

/// The axes of `spec`'s halvings if every depth down to the key's last bit
/// halves one axis in every cell and no cell is too thin to halve, and the
/// halvings made to know it (each as much work as a key bit): the bounds
/// on every cell's extents decide each depth's axis, and where they leave
/// it in doubt (extents a power of two apart, a square floor's), the
/// axes' intervals enumerated do, as [`super::halving`] does.
fn halvings(spec: &KeySpec) -> (Option<[Axis; 3]>, u64) {
    let s = spec.scene;
    let ext = |a: usize| s.max[a] as f64 - s.min[a] as f64;
    let u = |a: usize| ulp(s.min[a], s.max[a]);
    // Planes of magnitudes this small halve inexactly (subnormal halves).
    let normal = |a: usize| s.min[a].abs().max(s.max[a].abs()) >= 2f32.powi(-100);
    let mut depth = [0u32; 3];
    let mut places: [Vec<u32>; 3] = Default::default();
    let mut halved = 0;
    for d in 0..spec.bits {
        // Each axis's extents lie within `err` of `ext / 2^depth`.
        let bounds = |a: usize| {
            let w = ext(a) / (1u64 << depth[a]) as f64;
            let err = depth[a] as f64 * u(a) + w * 1e-12;
            match depth[a] {
                0 => (w, w),
                _ => (w - err, w + err),
            }
        };
        let mut b = [bounds(0), bounds(1), bounds(2)];
        let mut a = longest(b);
        if a.is_none() && depth.iter().all(|&k| k <= MOST_ENUMERATED) {
            for (x, w) in b.iter_mut().enumerate() {
                let (widths, made) = enumerated(s.min[x], s.max[x], depth[x]);
                *w = widths;
                halved += made;
            }
            a = longest(b);
        }
        let Some(a) = a else {
            return (None, halved);
        };
        let thin = b[a].0 <= 2.0 * u(a);
        if thin || !normal(a) || depth[a] == MOST_DEPTH {
            return (None, halved);
        }
        depth[a] += 1;
        places[a].push(spec.bits - 1 - d);
    }
    let axes = std::array::from_fn(|a| {
        let d = depth[a];
        let cells = (1u64 << d) as f64;
        // The planes' rounding, and the code's (two `f32` roundings of a
        // value below 2^d), in codes.
        let margin = (d as f64 / 2.0 + 2.0) * u(a) * cells / ext(a).max(f64::MIN_POSITIVE)
            + cells * 2f64.powi(-22);
        Axis {
            lo: s.min[a],
            scale: (cells / ext(a)) as f32,
            depth: d,
            margin: margin as f32,
            places: std::mem::take(&mut places[a]),
        }
    });
    let margins_fit = axes.iter().all(|x: &Axis| x.depth == 0 || x.margin < 0.25);
    (margins_fit.then_some(axes), halved)
}

/// The least and most extent (in `f64`, as `Aabb::longest_axis` measures
/// it) of the intervals of `lo..hi` halved `depth` times, and the halvings
/// made; a width of 0 where an interval cannot be halved.
fn enumerated(lo: f32, hi: f32, depth: u32) -> ((f64, f64), u64) {
    let mut intervals = vec![(lo, hi)];
    for _ in 0..depth {
        let mut next = Vec::with_capacity(2 * intervals.len());
        for &(l, h) in &intervals {
            let m = super::morton::mid(l, h);
            if !(l < m && m < h) {
                return ((0.0, f64::INFINITY), 0);
            }
            next.extend([(l, m), (m, h)]);
        }
        intervals = next;
    }
    let widths = (intervals.iter()).fold((f64::INFINITY, 0f64), |(n, x), &(l, h)| {
        let w = h as f64 - l as f64;
        (n.min(w), x.max(w))
    });
    (widths, (1u64 << depth) - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aabb::Aabb;
    use glam::Vec3;
    use proptest::prelude::*;

    fn spec(lo: Vec3, hi: Vec3, bits: u32) -> KeySpec {
        KeySpec::global_heuristic(Aabb::new(lo, hi), bits)
    }

    /// The planes a center meets on its path, as [`KeySpec::key`] halves:
    /// points exactly on them.
    fn planes_on_path(spec: &KeySpec, c: Vec3A) -> Vec<Vec3A> {
        let mut cell = spec.scene;
        let mut out = Vec::new();
        for _ in 0..spec.bits {
            let Some((axis, plane)) = super::super::morton::halving(&cell) else {
                break;
            };
            let mut on = c;
            on[axis] = plane;
            out.push(on);
            let below = f32::from_bits(plane.to_bits().wrapping_sub(1));
            on[axis] = if plane > 0.0 { below } else { -below.abs() };
            out.push(on);
            if c[axis] >= plane {
                cell.min[axis] = plane;
            } else {
                cell.max[axis] = plane;
            }
        }
        out
    }

    /// An ordinary box is quantised down to every width up to 32 bits, a
    /// square floor's too (its ties enumerated), a box too thin to halve
    /// is not, and only centers near a plane are settled.
    #[test]
    fn ordinary_boxes_and_floors_are_quantised() {
        let ordinary = spec(Vec3::new(-1.3, 2.0, 0.5), Vec3::new(3.0, 4.5, 7.7), 32);
        let q = QuantisedKeys::new(&ordinary);
        assert!(q.covers());
        assert_eq!(q.setup_halvings(), 0, "no tie to enumerate");
        let floor = spec(
            Vec3::new(-1e3, 0.0, -1e3),
            Vec3::new(1e3, 1.7, 1e3 + 0.3),
            24,
        );
        let f = QuantisedKeys::new(&floor);
        assert!(f.covers() && f.setup_halvings() > 0, "{f:?}");
        let ulp = f32::from_bits(1.0f32.to_bits() + 1);
        let thin = spec(Vec3::new(1.0, 0.0, 0.0), Vec3::new(ulp, 1e-8, 1e-8), 16);
        assert!(!QuantisedKeys::new(&thin).covers());
        let wide = spec(Vec3::new(-1.3, 2.0, 0.5), Vec3::new(3.0, 4.5, 7.7), 64);
        assert!(!QuantisedKeys::new(&wide).covers(), "21 halvings an axis");
        let mut settled = 0;
        for i in 0..10_000 {
            let t = Vec3A::new(
                (i * 7919 % 10_000) as f32 / 1e4,
                (i * 104_729 % 10_000) as f32 / 1e4,
                (i * 1_299_709 % 10_000) as f32 / 1e4,
            );
            let c = Vec3A::from(ordinary.scene.min) + t * Vec3A::from(ordinary.scene.extent());
            let (key, s) = q.key(c);
            assert_eq!(key, ordinary.key(c), "{c:?}");
            settled += s as u32;
        }
        assert!(settled < 500, "{settled} of 10,000 settled");
    }

    proptest::proptest! {
        /// The quantised key is the halvings' own: boxes from 1e-15 to
        /// 1e15 and thin, near-ties, every width, centers anywhere inside,
        /// on the faces, exactly on a halving plane and one ulp below it.
        #[test]
        fn quantised_keys_are_the_halvings_own(
            lo in proptest::array::uniform3(prop_oneof![-1e15f32..1e15, -1.0f32..1.0, Just(0.0f32)]),
            ext in proptest::array::uniform3(prop_oneof![Just(0.0f32), 1e-15f32..1e-12, 1e-6f32..1e6, 1e12f32..1e15]),
            tie in proptest::option::of((0usize..3, 0u32..12, -3i32..=3)),
            ts in proptest::collection::vec(proptest::array::uniform3(prop_oneof![Just(0.0f32), Just(1.0f32), 0.0f32..1.0]), 1..12),
            bits in prop_oneof![Just(16u32), Just(24), Just(32), Just(64), 1u32..64],
        ) {
            let mut ext = ext;
            if let Some((a, p, ulps)) = tie {
                // Another axis's extent a power of two times this one's,
                // give or take a few ulps.
                let b = (a + 1) % 3;
                let e = ext[b] * 2f32.powi(p as i32);
                ext[a] = f32::from_bits((e.to_bits() as i32 + ulps).max(0) as u32);
            }
            let lo = Vec3::from(lo);
            let hi = lo + Vec3::from(ext);
            let spec = spec(lo, hi.max(lo), bits);
            let q = QuantisedKeys::new(&spec);
            for t in ts {
                let c = Vec3A::from(spec.scene.min)
                    + Vec3A::from(t) * (Vec3A::from(spec.scene.max) - Vec3A::from(spec.scene.min));
                let c = c.clamp(spec.scene.min.into(), spec.scene.max.into());
                let mut centers = vec![c];
                centers.extend(planes_on_path(&spec, c).into_iter().map(|p| {
                    p.clamp(spec.scene.min.into(), spec.scene.max.into())
                }));
                for c in centers {
                    prop_assert_eq!(q.key(c).0, spec.key(c), "{:?} in {:?}", c, spec.scene);
                }
            }
        }
    }
}
