//! Morton keys and the top of the tree from sorted keys (section 5: "a
//! pre-processing step using Morton curves is performed to find regions of
//! primitives that then could be built-up totally independent"; Lauterbach
//! et al. 2009, Karras 2012). Plain functions over plain data, shared by
//! the host reference below and the SPE programs.
//!
//! Two bit orders ([`KeyOrder`]):
//!
//! - **The global heuristic's order.** The builder halves its candidate box
//!   at the middle of the longest axis ([`super::split::choose_split`]).
//!   A key bit here is exactly that halving, made along the triangle's own
//!   path: start from the scene box, take its longest axis and its `f32`
//!   midpoint as the builder computes them, set the bit when the
//!   triangle's box center is not below it (the builder's own test), keep
//!   the half the center lies in, and go on. Two triangles share a key
//!   prefix exactly when the builder puts them in the same candidate cell,
//!   so the binary radix tree of the sorted keys — a node where a range's
//!   keys first differ; a bit that all keys of a range share is a halving
//!   with one empty side, which makes no node — is the top of the
//!   baseline's tree. Where halving stops making progress in `f32` (a cell
//!   too thin to split), the rest of the key is zeros: the range shares the
//!   whole key and is finished by the global heuristic itself.
//! - **Round robin x, y, z** (LBVH): the center quantised on a grid over
//!   the scene box, the axes' bits interleaved. Another tree, cheaper keys:
//!   its quality cost is what the knob measures.
//!
//! Keys are 32 or 64 bits wide ([`KeySpec::bits`]); a range whose keys are
//! all equal is finished by the global heuristic from its candidate cell
//! ([`KeySpec::cell`]).

use glam::{Vec3, Vec3A};

use super::recursion::Item;
use super::split::{Side, choose_split, clip_planes, partition, side_of};
use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, BihNode};
use crate::scene::Scene;

/// The order of a key's bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum KeyOrder {
    /// Each bit one halving of the global heuristic: the baseline's tree.
    GlobalHeuristic,
    /// x, y, z in turn on a uniform grid (LBVH): another tree.
    RoundRobin,
}

/// How keys are made: their order and width, over the scene box `scene`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeySpec {
    pub order: KeyOrder,
    /// 32 or 64.
    pub bits: u32,
    pub scene: Aabb,
}

/// The midpoint of `lo..hi` as the builder computes it.
#[inline]
pub(super) fn mid(lo: f32, hi: f32) -> f32 {
    lo * 0.5 + hi * 0.5
}

impl KeySpec {
    /// Keys of `bits` bits in the global heuristic's order over `scene`.
    pub fn global_heuristic(scene: Aabb, bits: u32) -> KeySpec {
        KeySpec {
            order: KeyOrder::GlobalHeuristic,
            bits,
            scene,
        }
    }

    /// Grid bits per axis of the round-robin order (10 or 21).
    fn grid_bits(&self) -> u32 {
        self.bits / 3
    }

    /// The key of a triangle whose box center is `c`, in the low
    /// [`KeySpec::bits`] bits.
    pub fn key(&self, c: Vec3A) -> u64 {
        match self.order {
            KeyOrder::GlobalHeuristic => {
                let mut cell = self.scene;
                let mut key = 0u64;
                for i in 0..self.bits {
                    let Some((axis, plane)) = halving(&cell) else {
                        return key.unbounded_shl(self.bits - i);
                    };
                    let right = c[axis] >= plane;
                    key = key << 1 | right as u64;
                    if right {
                        cell.min[axis] = plane;
                    } else {
                        cell.max[axis] = plane;
                    }
                }
                key
            }
            KeyOrder::RoundRobin => {
                let g = self.grid_bits();
                let cells = (1u64 << g) as f64;
                let (lo, ext) = (self.scene.min.as_dvec3(), self.scene.extent_f64());
                let q = |a: usize| -> u64 {
                    if ext[a] <= 0.0 {
                        return 0;
                    }
                    let t = (c[a] as f64 - lo[a]) / ext[a] * cells;
                    (t.max(0.0) as u64).min((1 << g) - 1)
                };
                let (x, y, z) = (q(0), q(1), q(2));
                let mut key = 0u64;
                for b in (0..g).rev() {
                    for v in [x, y, z] {
                        key = key << 1 | (v >> b & 1);
                    }
                }
                key << (self.bits - 3 * g)
            }
        }
    }

    /// The candidate cell of the keys that share their first `depth` bits
    /// with `key`: the scene box halved along the key's path. The global
    /// heuristic's order makes the builder's own candidate box; round robin
    /// its grid cell (a candidate that holds the cell's centers).
    pub fn cell(&self, key: u64, depth: u32) -> Aabb {
        let mut cell = self.scene;
        for i in 0..depth {
            let right = key >> (self.bits - 1 - i) & 1 == 1;
            let split = match self.order {
                KeyOrder::GlobalHeuristic => match halving(&cell) {
                    Some(s) => s,
                    None => return cell,
                },
                KeyOrder::RoundRobin => {
                    let axis = (i % 3) as usize;
                    if i >= 3 * self.grid_bits() {
                        return cell;
                    }
                    (axis, mid(cell.min[axis], cell.max[axis]))
                }
            };
            let (axis, plane) = split;
            if right {
                cell.min[axis] = plane;
            } else {
                cell.max[axis] = plane;
            }
        }
        cell
    }

    /// The keys of a range that share their whole key, made again within
    /// the range's own cell: the spec whose scene box is `cell` carried on
    /// through every halving that the box of the range's centers
    /// (`lo..hi`) lies wholly on one side of — empty halvings, which make
    /// no node and cost no key bit — to the first halving that parts them.
    /// With the global heuristic's order that is the builder's own
    /// candidate box there, so the new keys' binary radix tree goes on
    /// being the baseline's tree. Round robin starts a new grid over the
    /// centers' box within the cell. Returns the spec and the empty
    /// halvings it skipped. `None` where `cell` cannot be halved any more.
    pub fn within(&self, cell: Aabb, lo: Vec3A, hi: Vec3A) -> Option<(KeySpec, u32)> {
        let mut cell = cell;
        halving(&cell)?;
        let mut skipped = 0;
        match self.order {
            KeyOrder::GlobalHeuristic => {
                while let Some((axis, plane)) = halving(&cell) {
                    if hi[axis] < plane {
                        cell.max[axis] = plane;
                    } else if lo[axis] >= plane {
                        cell.min[axis] = plane;
                    } else {
                        break;
                    }
                    skipped += 1;
                }
            }
            KeyOrder::RoundRobin => {
                // The centers' box, clamped into the cell (a center the
                // grid rounded into the cell may lie a hair outside it).
                let (a, b) = (cell.min, cell.max);
                cell = Aabb::new(Vec3::from(lo).clamp(a, b), Vec3::from(hi).clamp(a, b));
            }
        }
        Some((
            KeySpec {
                scene: cell,
                ..*self
            },
            skipped,
        ))
    }
}

/// Whether the builder can halve `cell` (in `f32`).
pub fn can_halve(cell: &Aabb) -> bool {
    halving(cell).is_some()
}

/// The builder's halving of `cell` (its longest axis and `f32` midpoint),
/// or `None` when the midpoint does not fall strictly inside (`f32` cannot
/// halve it any more).
pub(super) fn halving(cell: &Aabb) -> Option<(usize, f32)> {
    let axis = cell.longest_axis();
    let (lo, hi) = (cell.min[axis], cell.max[axis]);
    let plane = mid(lo, hi);
    (lo < plane && plane < hi).then_some((axis, plane))
}

/// Where the sorted `keys` (of width `bits`) split: the first bit at which
/// they differ, and the index of the first key with that bit set. `None`
/// when they are all equal.
pub fn split_of(keys: &[u64], bits: u32) -> Option<(u32, usize)> {
    let (first, last) = (*keys.first()?, *keys.last()?);
    let diff = first ^ last;
    if diff == 0 {
        return None;
    }
    let bit = diff.leading_zeros() - (64 - bits);
    let mask = 1u64 << (bits - 1 - bit);
    Some((bit, keys.partition_point(|k| k & mask == 0)))
}

/// The host reference of the Morton route: keys for `items` (their box
/// centers), a stable sort by key, then the tree from the sorted keys — a
/// node where a range's keys first differ, clip planes from each side's
/// bounds — finished by the global heuristic where a range shares its
/// whole key. Leaf size and depth limit as the builder's. Returns the
/// nodes (children adjacent, root 0); `items` end in the tree's order.
pub fn build_from_keys<T: Item>(items: &mut [T], spec: &KeySpec, cfg: &BihConfig) -> Vec<BihNode> {
    let mut keys: Vec<u64> = items.iter().map(|t| spec.key(t.center())).collect();
    let mut sorted = items.to_vec();
    super::radix::sort(&mut keys, &mut sorted, spec.bits, 8);
    items.copy_from_slice(&sorted);
    let mut nodes = vec![BihNode::default()];
    let all = side_of(items);
    let mut b = FromKeys {
        items,
        keys: &keys,
        spec,
        cfg,
        nodes: &mut nodes,
    };
    b.node(0, 0, all.count, 0, &all, 0);
    nodes
}

/// [`build_from_keys`] over a whole scene, with the scene box as the first
/// cell: the host reference of the Morton route.
pub fn build_scene(scene: &Scene, order: KeyOrder, bits: u32, cfg: &BihConfig) -> Bih {
    let spec = KeySpec {
        order,
        bits,
        scene: scene.bounds(),
    };
    let mut refs: Vec<super::recursion::PrimRef> = (scene.triangles.iter().enumerate())
        .map(|(i, t)| super::recursion::PrimRef::new(i as u32, t.bounds()))
        .collect();
    let nodes = build_from_keys(&mut refs, &spec, cfg);
    Bih {
        nodes,
        prim_ids: refs.iter().map(Item::id).collect(),
        bounds: spec.scene,
        config: *cfg,
    }
}

struct FromKeys<'a, T> {
    items: &'a mut [T],
    keys: &'a [u64],
    spec: &'a KeySpec,
    cfg: &'a BihConfig,
    nodes: &'a mut Vec<BihNode>,
}

impl<T: Item> FromKeys<'_, T> {
    /// Fills node `id` for the range `first..first + count`, whose keys
    /// share at least their first `shared` bits, at node depth `depth`.
    fn node(
        &mut self,
        id: usize,
        first: usize,
        count: usize,
        shared: u32,
        side: &Side,
        depth: u32,
    ) {
        let leaf = BihNode::leaf(first as u32, count as u32);
        if self.cfg.ends_in_leaf(count, depth) {
            self.nodes[id] = leaf;
            return;
        }
        let range = first..first + count;
        let Some((bit, at)) = split_of(&self.keys[range.clone()], self.spec.bits) else {
            // One key: the global heuristic finishes from the key's cell.
            let mut cell = self.spec.cell(self.keys[first], self.spec.bits);
            let Some(split) = choose_split(&mut cell, &side.centers()) else {
                self.nodes[id] = leaf;
                return;
            };
            let (l, r) = partition(&mut self.items[range], split);
            let [lc, rc] = split.candidates(cell);
            return self.finish(id, first, split.axis, (&l, lc), (&r, rc), depth);
        };
        debug_assert!(bit >= shared);
        let (l, r) = (
            side_of(&self.items[first..first + at]),
            side_of(&self.items[first + at..first + count]),
        );
        let axis = self.axis_of(self.keys[first], bit);
        let children = self.push_pair();
        let [cl, cr] = clip_planes(axis, &l, &r);
        self.nodes[id] = BihNode::inner(children as u32, axis, cl, cr);
        self.node(children, first, at, bit + 1, &l, depth + 1);
        self.node(children + 1, first + at, count - at, bit + 1, &r, depth + 1);
    }

    /// The axis that bit `bit` of keys with `key`'s prefix halves.
    fn axis_of(&self, key: u64, bit: u32) -> usize {
        match self.spec.order {
            KeyOrder::GlobalHeuristic => self.spec.cell(key, bit).longest_axis(),
            KeyOrder::RoundRobin => (bit % 3) as usize,
        }
    }

    fn push_pair(&mut self) -> usize {
        let children = self.nodes.len();
        self.nodes.extend([BihNode::default(); 2]);
        children
    }

    /// Below a range that shares its whole key: the global heuristic's own
    /// recursion (as the host builder's), from the candidates `lc`, `rc`.
    fn finish(
        &mut self,
        id: usize,
        first: usize,
        axis: usize,
        (l, lc): (&Side, Aabb),
        (r, rc): (&Side, Aabb),
        depth: u32,
    ) {
        let children = self.push_pair();
        let [cl, cr] = clip_planes(axis, l, r);
        self.nodes[id] = BihNode::inner(children as u32, axis, cl, cr);
        let mut nodes = std::mem::take(self.nodes);
        let cfg = self.cfg;
        super::recursion::build_subtree(
            self.items,
            &mut nodes,
            children,
            first,
            l.count,
            lc,
            depth + 1,
            cfg,
        );
        super::recursion::build_subtree(
            self.items,
            &mut nodes,
            children + 1,
            first + l.count,
            r.count,
            rc,
            depth + 1,
            cfg,
        );
        *self.nodes = nodes;
    }
}

/// `--key-bits auto`: the halvings the scene's regions need, a whole number
/// of radix digits. A region of `region_size` triangles is reached after
/// about log2(n / region_size) halvings where triangles spread evenly;
/// four bits more for the halvings a real scene spends on empty space and
/// uneven density. Measured (docs/morton.md, "Defaults"): on every scene up
/// to rtPerf 1M (16 bits by this rule) 16 bits were the fastest width with
/// regions of 256, and the tree is the baseline's at any width (ranges
/// that share their whole key are built by the breadth-first loop).
pub fn auto_key_bits(n: usize, region_size: usize, digit_bits: u32) -> u32 {
    let halvings = (n as f64 / region_size.max(1) as f64)
        .log2()
        .ceil()
        .max(0.0) as u32;
    (halvings + 4).next_multiple_of(digit_bits).clamp(16, 64)
}

/// `--region-size auto`: the smallest region, a power of two from 64 to
/// 1,024 triangles, that still gives the narrowest keys ([`auto_key_bits`]:
/// 16 bits while n / region is at most 2^12): n / 4,096 rounded up to a
/// power of two. Measured (docs/morton.md, "Defaults"; `spe_scaling`
/// without `--defaults-only` times every setting): smaller regions were
/// faster on every scene as long as the keys stayed 16 bits, and wider
/// keys cost more than smaller regions saved. At most 1,024: well
/// inside a local store (about 2,000 records), so that no region needs the
/// breadth-first loop; scenes above about 4 M triangles take wider keys.
pub fn auto_region_size(n: usize) -> usize {
    n.div_ceil(1 << 12).next_power_of_two().clamp(64, 1024)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn unit() -> Aabb {
        Aabb::new(Vec3::ZERO, Vec3::ONE)
    }

    #[test]
    fn auto_regions_are_the_smallest_that_keep_16_bit_keys() {
        for (n, region) in [
            (1, 64),
            (69_451, 64),
            (300_000, 128),
            (871_414, 256),
            (3_500_000, 1024),
            (50_000_000, 1024),
        ] {
            assert_eq!(auto_region_size(n), region, "{n} triangles");
        }
        for n in [1, 5_000, 262_144, 262_145, 1_000_000, 4_194_304] {
            assert_eq!(auto_key_bits(n, auto_region_size(n), 8), 16, "{n}");
            let half = auto_region_size(n) / 2;
            if half >= 64 {
                assert!(
                    auto_key_bits(n, half, 8) > 16,
                    "{n}: a smaller region keeps 16 bits"
                );
            }
        }
        assert_eq!(
            auto_key_bits(50_000_000, auto_region_size(50_000_000), 8),
            24
        );
    }

    #[test]
    fn global_heuristic_keys_follow_the_halvings() {
        // A 4 x 2 x 1 box: x is halved first, then x and y tie (2 x 2 x 1)
        // and ties go to the lower axis.
        let spec = KeySpec {
            order: KeyOrder::GlobalHeuristic,
            bits: 32,
            scene: Aabb::new(Vec3::ZERO, Vec3::new(4.0, 2.0, 1.0)),
        };
        let k = spec.key(Vec3A::new(3.0, 0.5, 0.5));
        // Bit 0: x >= 2 (1); bit 1: x in 2..4 halved at 3 (3 >= 3: 1);
        // bit 2: box 2 x 2 x 1 from x 3..4? No: 1 x 2 x 1, y is longest,
        // halved at 1 (0.5 < 1: 0).
        assert_eq!(k >> 29, 0b110);
        assert_eq!(
            spec.cell(k, 3),
            Aabb::new(Vec3::new(3.0, 0.0, 0.0), Vec3::new(4.0, 1.0, 1.0))
        );
    }

    #[test]
    fn a_cell_too_thin_to_halve_ends_the_key_with_zeros() {
        let x = 1.0f32;
        let next = f32::from_bits(x.to_bits() + 1);
        let spec = KeySpec {
            order: KeyOrder::GlobalHeuristic,
            bits: 64,
            scene: Aabb::new(Vec3::splat(x), Vec3::new(next, x, x)),
        };
        // The midpoint of two adjacent floats is one of them: no halving.
        assert_eq!(spec.key(Vec3A::new(next, x, x)), 0);
    }

    #[test]
    fn round_robin_keys_interleave_x_y_z() {
        let spec = KeySpec {
            order: KeyOrder::RoundRobin,
            bits: 32,
            scene: unit(),
        };
        // x in the upper half only: the first bit.
        assert_eq!(spec.key(Vec3A::new(0.75, 0.25, 0.25)) >> 29, 0b100);
        assert_eq!(spec.key(Vec3A::new(0.25, 0.75, 0.25)) >> 29, 0b010);
        assert_eq!(spec.key(Vec3A::new(0.25, 0.25, 0.75)) >> 29, 0b001);
        // The far corner is the largest key; the 2 bits below 30 are zero.
        assert_eq!(spec.key(Vec3A::ONE), (1 << 32) - 4);
    }

    #[test]
    fn split_of_finds_the_first_differing_bit() {
        let keys = [0b0001u64, 0b0011, 0b0100, 0b0110];
        assert_eq!(split_of(&keys, 4), Some((1, 2)));
        assert_eq!(split_of(&keys[..2], 4), Some((2, 1)));
        assert_eq!(split_of(&[5, 5], 4), None);
    }

    /// `--key-bits auto`: the halvings to regions of 256 plus four, whole
    /// 8-bit digits, at least 16 (every scene up to rtPerf 1M: 16 bits).
    #[test]
    fn auto_key_bits_follow_the_halvings_the_regions_need() {
        assert_eq!(auto_key_bits(6_320, 256, 8), 16);
        assert_eq!(auto_key_bits(871_306, 256, 8), 16);
        assert_eq!(auto_key_bits(1_000_000, 256, 8), 16);
        assert_eq!(auto_key_bits(4_000_000, 256, 8), 24);
        assert_eq!(auto_key_bits(4_000_000, 2048, 8), 16);
        assert_eq!(auto_key_bits(871_306, 1, 11), 33);
        assert_eq!(auto_key_bits(0, 256, 8), 16);
        assert_eq!(auto_key_bits(usize::MAX, 1, 8), 64);
    }

    /// Keys made again within a cell, past the halvings a cluster of
    /// centers does not straddle, continue the keys of the whole box: the
    /// long key's bits are the skipped halvings' sides, then the new key.
    #[test]
    fn keys_within_a_cell_continue_the_keys_of_the_whole_box() {
        let big = Aabb::new(Vec3::splat(-1000.0), Vec3::splat(1000.0));
        let whole = KeySpec {
            order: KeyOrder::GlobalHeuristic,
            bits: 16,
            scene: big,
        };
        let centers: Vec<Vec3A> = (0..200)
            .map(|i| {
                let t = i as f32 / 200.0;
                Vec3A::new(3.0 + t, 7.0 + t * t, 5.0 - t)
            })
            .collect();
        let lo = centers
            .iter()
            .fold(Vec3A::splat(f32::INFINITY), |a, &c| a.min(c));
        let hi = centers
            .iter()
            .fold(Vec3A::splat(f32::NEG_INFINITY), |a, &c| a.max(c));
        // Where 16 bits ran out: every center shares the key.
        let k0 = whole.key(centers[0]);
        assert!(centers.iter().all(|&c| whole.key(c) == k0));
        let cell = whole.cell(k0, 16);
        let (inner, skipped) = whole.within(cell, lo, hi).expect("the cell halves");
        assert!(skipped > 0, "the cluster is far smaller than its cell");
        assert!(inner.scene.contains_box(&Aabb::new(lo.into(), hi.into())));
        let long = KeySpec { bits: 64, ..whole };
        let skip = KeySpec {
            bits: 16 + skipped,
            ..whole
        };
        for &c in &centers {
            let prefix = skip.key(c);
            let want = long.key(c) >> (64 - 16 - skipped - 16);
            assert_eq!(prefix << 16 | inner.key(c), want);
        }
        // Round robin: a new grid over the centers' box, inside the cell.
        let rr = KeySpec {
            order: KeyOrder::RoundRobin,
            ..whole
        };
        let (grid, none) = rr.within(cell, lo, hi).unwrap();
        assert_eq!(none, 0);
        assert!(cell.contains_box(&grid.scene));
        // A cell that cannot be halved is not keyed again.
        let flat = Aabb::new(Vec3::ONE, Vec3::ONE);
        assert!(whole.within(flat, lo, hi).is_none());
    }
}
