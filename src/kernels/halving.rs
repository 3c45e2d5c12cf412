//! The global heuristic's halvings of a scene box as tables, for Morton
//! keys in its order (section 5's Morton route; [`super::morton`]): a key
//! is then table lookups and comparisons instead of a halving a bit
//! ([`KeySpec::key`]), the same key for every finite center.
//!
//! Two forms. Usually every cell at one depth halves the **same axis**
//! (halving a box at the middle of its longest axis gives two boxes of the
//! same shape, up to `f32`'s rounding), and a cell's plane on an axis
//! depends only on the halvings made on that axis before (the midpoint of
//! its interval there): the halvings are then three one-dimensional trees,
//! one an axis, of a few dozen planes each, and a key is three short
//! descents in tables that stay in L1, each code's bits spread to their
//! places in the key (`Form::Separable`). Where `f32`'s rounding makes
//! cells of one depth disagree on the axis (near-ties of extents), or a
//! cell too thin to halve ends its keys early, one entry a cell
//! (`Form::Cells`: `2^bits` entries, a chain of dependent loads from L2
//! a key).

use glam::Vec3A;

use super::morton::{KeyOrder, KeySpec, halving, mid};
use crate::aabb::Aabb;

/// The global heuristic's halvings of a scene box, down to
/// [`KeySpec::bits`] halvings, for the keys of [`KeySpec::key`]; eight
/// centers' keys are computed side by side ([`HalvingTable::keys`]).
pub struct HalvingTable {
    bits: u32,
    form: Form,
}

enum Form {
    /// Every depth halves one axis in every cell, and no cell stalls: per
    /// axis, the tree of its planes.
    Separable([AxisTree; 3]),
    /// Per cell of the implicit binary tree (cell `k` has children `2k`
    /// and `2k + 1`, the root is 1): its plane and axis. A cell `f32`
    /// cannot halve (and every cell below it) has the plane +∞: no finite
    /// center is on its right, so the key ends in zeros.
    Cells(Vec<(f32, u32)>),
}

/// The halvings of one axis, as an implicit binary tree of `2^depth - 1`
/// planes (node `k` has children `2k` and `2k + 1`, the root is 1; entry 0
/// unused), and for each of the `2^depth` codes a descent ends in, its
/// bits in their places in the key.
#[derive(Default)]
struct AxisTree {
    depth: u32,
    planes: Vec<f32>,
    spread: Vec<u64>,
}

impl HalvingTable {
    /// Widest keys a table is made for (2^20 cells, 8 MiB, in the cells'
    /// form).
    pub const MAX_BITS: u32 = 20;

    /// The table of `spec`'s halvings; `None` for round-robin keys or keys
    /// wider than [`Self::MAX_BITS`].
    pub fn new(spec: &KeySpec) -> Option<HalvingTable> {
        if spec.order != KeyOrder::GlobalHeuristic || spec.bits > Self::MAX_BITS {
            return None;
        }
        let form = match separable(spec) {
            Some(axes) => Form::Separable(axes),
            None => Form::Cells(cells(spec)),
        };
        Some(HalvingTable {
            bits: spec.bits,
            form,
        })
    }

    /// [`Self::new`] in the cells' form, whatever the box (tests compare
    /// the two forms).
    pub fn new_cells(spec: &KeySpec) -> Option<HalvingTable> {
        let mut t = Self::new(spec)?;
        t.form = Form::Cells(cells(spec));
        Some(t)
    }

    /// Whether the table is in the separable form (three trees of an
    /// axis's planes).
    pub fn is_separable(&self) -> bool {
        matches!(self.form, Form::Separable(_))
    }

    /// [`KeySpec::key`] of a triangle whose box center is `c`.
    #[inline]
    pub fn key(&self, c: Vec3A) -> u64 {
        let mut keys = [0];
        self.keys(&[c], &mut keys);
        keys[0]
    }

    /// The keys of the box centers `centers` into `keys`, eight at a time.
    pub fn keys(&self, centers: &[Vec3A], keys: &mut [u64]) {
        const LANES: usize = 8;
        for (cs, ks) in centers.chunks(LANES).zip(keys.chunks_mut(LANES)) {
            let mut c = [[0f32; 3]; LANES];
            for (to, from) in c.iter_mut().zip(cs) {
                *to = from.to_array();
            }
            match &self.form {
                Form::Separable(axes) => {
                    let mut key = [0u64; LANES];
                    for (a, t) in axes.iter().enumerate() {
                        let mut k = [1usize; LANES];
                        for _ in 0..t.depth {
                            for (k, c) in k.iter_mut().zip(&c) {
                                *k = 2 * *k + (c[a] >= t.planes[*k]) as usize;
                            }
                        }
                        for (key, k) in key.iter_mut().zip(k) {
                            *key |= t.spread[k - (1 << t.depth)];
                        }
                    }
                    ks.copy_from_slice(&key[..ks.len()]);
                }
                Form::Cells(cells) => {
                    let mut k = [1usize; LANES];
                    for _ in 0..self.bits {
                        for (k, c) in k.iter_mut().zip(&c) {
                            let (plane, axis) = cells[*k];
                            *k = 2 * *k + (c[axis as usize] >= plane) as usize;
                        }
                    }
                    for (to, k) in ks.iter_mut().zip(k) {
                        *to = k as u64 & ((1u64 << self.bits) - 1);
                    }
                }
            }
        }
    }
}

/// The separable form of `spec`'s halvings, or `None` when the cells of
/// some depth do not all halve one axis, or one cannot be halved.
fn separable(spec: &KeySpec) -> Option<[AxisTree; 3]> {
    let s = spec.scene;
    // Each axis's intervals at its present depth, left to right.
    let mut intervals: [Vec<(f32, f32)>; 3] = std::array::from_fn(|a| vec![(s.min[a], s.max[a])]);
    let mut axes: [AxisTree; 3] = Default::default();
    // The key bits each axis's halvings set, first halving first.
    let mut places: [Vec<u32>; 3] = Default::default();
    for t in axes.iter_mut() {
        t.planes.push(f32::NAN);
    }
    for d in 0..spec.bits {
        // The extremes of each axis's extents over its intervals, as
        // `Aabb::longest_axis` measures them (in f64).
        let ext = |a: usize| {
            (intervals[a].iter()).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &(l, h)| {
                let e = h as f64 - l as f64;
                (lo.min(e), hi.max(e))
            })
        };
        // The axis every combination of intervals takes.
        let a = longest([ext(0), ext(1), ext(2)])?;
        let mut next = Vec::with_capacity(2 * intervals[a].len());
        for &(lo, hi) in &intervals[a] {
            let plane = mid(lo, hi);
            if !(lo < plane && plane < hi) {
                return None;
            }
            axes[a].planes.push(plane);
            next.extend([(lo, plane), (plane, hi)]);
        }
        intervals[a] = next;
        places[a].push(spec.bits - 1 - d);
    }
    for (t, places) in axes.iter_mut().zip(&places) {
        t.depth = places.len() as u32;
        t.spread = (0..1u64 << t.depth)
            .map(|code| {
                (places.iter().enumerate())
                    .map(|(i, &p)| (code >> (t.depth as usize - 1 - i) & 1) << p)
                    .fold(0, |k, b| k | b)
            })
            .collect();
    }
    Some(axes)
}

/// The axis `Aabb::longest_axis`'s rule (x if not shorter than y and z,
/// else y if not shorter than z, else z) takes in every cell whose extents
/// lie within `b` (each axis's least and most), if one.
pub(super) fn longest(b: [(f64, f64); 3]) -> Option<usize> {
    let [(n0, x0), (n1, x1), (n2, x2)] = b;
    match () {
        _ if n0 >= x1 && n0 >= x2 => Some(0),
        _ if x0 < n1 && n1 >= x2 => Some(1),
        _ if x0 < n2 && x1 < n2 => Some(2),
        _ => None,
    }
}

/// The cells' form of `spec`'s halvings: `2^bits` entries.
fn cells(spec: &KeySpec) -> Vec<(f32, u32)> {
    let mut cells = vec![(f32::INFINITY, 0); 1 << spec.bits];
    fill(&mut cells, 1, spec.scene);
    cells
}

fn fill(cells: &mut [(f32, u32)], k: usize, cell: Aabb) {
    if k >= cells.len() {
        return;
    }
    let Some((axis, plane)) = halving(&cell) else {
        return; // This cell and those below keep the plane +∞.
    };
    cells[k] = (plane, axis as u32);
    let (mut l, mut r) = (cell, cell);
    l.max[axis] = plane;
    r.min[axis] = plane;
    fill(cells, 2 * k, l);
    fill(cells, 2 * k + 1, r);
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use proptest::prelude::*;

    fn spec(lo: Vec3, hi: Vec3, bits: u32) -> KeySpec {
        KeySpec::global_heuristic(Aabb::new(lo, hi), bits)
    }

    /// A box of ordinary proportions takes the separable form, and a box
    /// whose halvings stall in `f32` the cells' form, each with the
    /// halvings' own keys.
    #[test]
    fn the_forms_are_taken_where_they_hold() {
        let ordinary = spec(Vec3::new(-1.0, 2.0, 0.5), Vec3::new(3.0, 4.5, 7.0), 16);
        let table = HalvingTable::new(&ordinary).unwrap();
        assert!(table.is_separable());
        let thin = spec(Vec3::ZERO, Vec3::new(1.0, 1e-30, 1e-30), 20);
        // x the longest axis, one ulp wide: its midpoint rounds to a face.
        let ulp = f32::from_bits(1.0f32.to_bits() + 1);
        let stalls = spec(Vec3::new(1.0, 0.0, 0.0), Vec3::new(ulp, 1e-8, 1e-8), 20);
        assert!(!HalvingTable::new(&stalls).unwrap().is_separable());
        assert_eq!(stalls.key(Vec3A::new(ulp, 1e-8, 1e-8)), 0, "a stalled key");
        for s in [ordinary, thin, stalls] {
            let table = HalvingTable::new(&s).unwrap();
            for i in 0..200 {
                let t = Vec3A::new(i as f32 / 199.0, (i * 7 % 200) as f32 / 199.0, 0.37);
                let c = Vec3A::from(s.scene.min) + t * Vec3A::from(s.scene.extent());
                assert_eq!(table.key(c), s.key(c), "{c:?} in {:?}", s.scene);
            }
        }
    }

    proptest::proptest! {
        /// Both forms' keys are the halvings' own, on boxes from thin to
        /// huge, centers inside and on the faces.
        #[test]
        fn the_halving_table_gives_the_same_keys(
            lo in proptest::array::uniform3(-1e15f32..1e15),
            ext in proptest::array::uniform3(prop_oneof![Just(0.0f32), 1e-30f32..1e-20, 1e-6f32..1e6, 1e20f32..1e30]),
            ts in proptest::collection::vec(proptest::array::uniform3(prop_oneof![Just(0.0f32), Just(1.0f32), 0.0f32..1.0]), 1..40),
            bits in 1u32..=20,
        ) {
            let lo = Vec3::from(lo);
            let hi = lo + Vec3::from(ext);
            let spec = spec(lo, hi, bits);
            let table = HalvingTable::new(&spec).unwrap();
            let cells = HalvingTable::new_cells(&spec).unwrap();
            for t in ts {
                let c = Vec3A::from(lo) + Vec3A::from(t) * (Vec3A::from(hi) - Vec3A::from(lo));
                prop_assert_eq!(table.key(c), spec.key(c), "{:?}", c);
                prop_assert_eq!(cells.key(c), spec.key(c), "{:?}", c);
            }
        }

        /// Extents within a few ulps of each other, off the origin: where
        /// rounding may make cells of one depth take different axes.
        #[test]
        fn near_ties_give_the_same_keys(
            lo in proptest::array::uniform3(-1e3f32..1e3),
            e in 1e-3f32..1e3,
            ulps in proptest::array::uniform3(-3i32..=3),
            ts in proptest::collection::vec(proptest::array::uniform3(0.0f32..1.0), 1..40),
            bits in 8u32..=20,
        ) {
            let lo = Vec3::from(lo);
            let ext = ulps.map(|u| f32::from_bits((e.to_bits() as i32 + u) as u32));
            let hi = lo + Vec3::from(ext);
            let spec = spec(lo, hi, bits);
            let table = HalvingTable::new(&spec).unwrap();
            for t in ts {
                let c = Vec3A::from(lo) + Vec3A::from(t) * (Vec3A::from(hi) - Vec3A::from(lo));
                prop_assert_eq!(table.key(c), spec.key(c), "{:?}", c);
            }
        }
    }
}
