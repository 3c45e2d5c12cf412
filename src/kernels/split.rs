//! The two kernels every BIH builder of this crate shares, host and SPE
//! alike: the split choice of the *global heuristic* and the in-place
//! partition. Plain functions over plain data, so that a host builder calls
//! them on a whole array and an SPE program on a local-store block.
//!
//! Global heuristic (Wächter & Keller 2006, section 3.1): halve the
//! *candidate* box (initially the scene box, not the triangles' box) at the
//! middle of its longest side; a triangle goes left when the center of its
//! box lies below the plane. When every center falls on one side, no node is
//! emitted: the candidate is replaced by the half that holds them and halved
//! again. Because the partition also gathers each side's bounds of centers,
//! such empty halvings are decided here without another pass over the
//! triangles — the tree is the one the repeated-partition formulation gives.

use glam::Vec3A;

use crate::aabb::Aabb;

/// A split: triangles whose box center is `< plane` on `axis` go left.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Split {
    pub axis: usize,
    pub plane: f32,
}

impl Split {
    /// Whether `it` goes left: its box center is below the plane.
    #[inline(always)]
    pub fn goes_left<T: Boxed>(self, it: &T) -> bool {
        mid(it.lo()[self.axis], it.hi()[self.axis]) < self.plane
    }

    /// Partitions `items[from..to]` with two pointers (a right item is
    /// swapped to the end); returns where the right ones start.
    fn two_pointer<T: Boxed>(self, items: &mut [T], from: usize, to: usize) -> usize {
        let (mut i, mut j) = (from, to);
        while i < j {
            if self.goes_left(&items[i]) {
                i += 1;
            } else {
                j -= 1;
                items.swap(i, j);
            }
        }
        i
    }

    /// The children's candidate boxes: `candidate` cut at the plane.
    pub fn candidates(self, candidate: Aabb) -> [Aabb; 2] {
        let (mut left, mut right) = (candidate, candidate);
        left.max[self.axis] = self.plane;
        right.min[self.axis] = self.plane;
        [left, right]
    }
}

/// Anything with an axis-aligned box that a partition can move about.
pub trait Boxed: Copy {
    fn lo(&self) -> Vec3A;
    fn hi(&self) -> Vec3A;
    /// The box center, computed as `lo/2 + hi/2` so that it neither
    /// overflows nor leaves the box.
    #[inline]
    fn center(&self) -> Vec3A {
        self.lo() * 0.5 + self.hi() * 0.5
    }
}

/// The midpoint of `lo..hi`, in the same overflow-free form as centers.
#[inline]
fn mid(lo: f32, hi: f32) -> f32 {
    lo * 0.5 + hi * 0.5
}

/// Chooses the next split by the global heuristic, halving `candidate` in
/// place past every empty split. `centers` bounds the box centers of the
/// triangles to split. Returns `None` when the centers all coincide (no
/// split can separate them). A returned split always puts at least one
/// triangle on each side.
///
/// Termination: every halving strictly shrinks the candidate; when `f32`
/// precision stops it shrinking, the plane falls back to the largest center
/// on that axis (if centers differ there) or the axis is collapsed so another
/// is chosen.
pub fn choose_split(candidate: &mut Aabb, centers: &Aabb) -> Option<Split> {
    choose_split_counted(candidate, centers, &mut 0)
}

/// [`choose_split`], adding one to `stalls` for each halving `f32` could
/// not make (the candidate stopped shrinking, so the plane fell back to the
/// centers or the axis was collapsed): what `cli/experiments/extremes.rs`
/// reports.
pub fn choose_split_counted(
    candidate: &mut Aabb,
    centers: &Aabb,
    stalls: &mut u64,
) -> Option<Split> {
    if centers.min == centers.max {
        return None;
    }
    // The halvings assume the candidate holds the centers. The global
    // heuristic keeps that true of every candidate it makes (a no-op
    // there); a candidate made another way (approximate sorting's
    // buckets: a bucket's triangles' centers spill out of the bucket's
    // half) is grown to them, or the halvings below would stall and peel
    // off one center per level down to the depth limit.
    *candidate = candidate.union(*centers);
    loop {
        let axis = candidate.longest_axis();
        let (lo, hi) = (candidate.min[axis], candidate.max[axis]);
        let (cmin, cmax) = (centers.min[axis], centers.max[axis]);
        let plane = mid(lo, hi);
        if cmin < plane && plane <= cmax {
            return Some(Split { axis, plane });
        }
        if cmax < plane && plane < hi {
            candidate.max[axis] = plane; // all left: go on with the lower half
            continue;
        }
        if cmin >= plane && plane > lo {
            candidate.min[axis] = plane; // all right: go on with the upper half
            continue;
        }
        // Halving makes no progress (f32 precision) or the candidate does
        // not hold the centers on this axis.
        *stalls += 1;
        if cmin < cmax {
            return Some(Split { axis, plane: cmax });
        }
        if lo == hi {
            // Collapsed already: any axis on which the centers differ.
            let axis = (0..3).find(|&a| centers.min[a] < centers.max[a]).unwrap();
            return Some(Split {
                axis,
                plane: centers.max[axis],
            });
        }
        candidate.min[axis] = cmin;
        candidate.max[axis] = cmin;
    }
}

/// What a partition learned about one side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Side {
    pub count: usize,
    /// The union of the side's triangle boxes.
    pub lo: Vec3A,
    pub hi: Vec3A,
    /// The bounds of the side's box centers.
    pub center_lo: Vec3A,
    pub center_hi: Vec3A,
}

impl Side {
    pub const EMPTY: Side = Side {
        count: 0,
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
        center_lo: Vec3A::INFINITY,
        center_hi: Vec3A::NEG_INFINITY,
    };

    #[inline]
    pub fn add(&mut self, lo: Vec3A, hi: Vec3A, center: Vec3A) {
        self.count += 1;
        self.lo = self.lo.min(lo);
        self.hi = self.hi.max(hi);
        self.center_lo = self.center_lo.min(center);
        self.center_hi = self.center_hi.max(center);
    }

    /// The side made of both sides' items.
    #[must_use]
    pub fn merge(self, o: Side) -> Side {
        Side {
            count: self.count + o.count,
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
            center_lo: self.center_lo.min(o.center_lo),
            center_hi: self.center_hi.max(o.center_hi),
        }
    }

    /// The union of the side's triangle boxes.
    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.lo.into(), self.hi.into())
    }

    /// The bounds of the side's box centers.
    pub fn centers(&self) -> Aabb {
        Aabb::new(self.center_lo.into(), self.center_hi.into())
    }
}

/// The clip planes of a split whose sides are `left` and `right`: the left
/// side's largest box maximum and the right side's smallest box minimum.
pub fn clip_planes(axis: usize, left: &Side, right: &Side) -> [f32; 2] {
    [left.hi[axis], right.lo[axis]]
}

/// Items classified per block of the partition: offsets fit in a `u8`.
const BLOCK: usize = 64;

/// Partitions `items` in place: those whose center is below `split.plane`
/// first. Returns both sides' counts and bounds. Deterministic; each item is
/// classified once.
///
/// The block partition of Edelkamp & Weiß ("BlockQuicksort: avoiding branch
/// mispredictions in quicksort", ESA 2016): a block of 64 items (`BLOCK`) at
/// each end is classified without branches, writing the offsets of the
/// misplaced ones (right items in the left block, left items in the right
/// block) to two small buffers; then misplaced pairs are swapped in a loop
/// whose branches are predictable. The tail (fewer than two blocks) runs the
/// plain two-pointer loop. Then one pass over each side gathers its bounds.
///
/// PERF: on the dragon the whole host build took about half the time of
/// the two-pointer loop that grew the bounds as it went (criterion,
/// `benches/host_build.rs`). Growing both sides' bounds inside the block
/// loop, by selecting which side each item grows, was slower than either:
/// the separate passes are
/// sequential and branch-free, and keep the classifying loop tiny.
pub fn partition<T: Boxed>(items: &mut [T], split: Split) -> (Side, Side) {
    // items[..l] are left and items[r..] right; a *loaded* block is
    // classified and lies inside [l, r): items[l..l + BLOCK] on the left,
    // items[r - BLOCK..r] on the right. `off_*[s..s + n]` are the offsets
    // of its misplaced items not yet swapped (n = 0: no block loaded).
    let (mut l, mut r) = (0, items.len());
    let (mut off_l, mut sl, mut nl) = ([0u8; BLOCK], 0, 0);
    let (mut off_r, mut sr, mut nr) = ([0u8; BLOCK], 0, 0);
    while r - l >= 2 * BLOCK {
        if nl == 0 {
            sl = 0;
            for (i, it) in items[l..l + BLOCK].iter().enumerate() {
                off_l[nl] = i as u8;
                nl += !split.goes_left(it) as usize;
            }
        }
        if nr == 0 {
            sr = 0;
            for (i, it) in items[r - BLOCK..r].iter().rev().enumerate() {
                off_r[nr] = i as u8;
                nr += split.goes_left(it) as usize;
            }
        }
        let m = nl.min(nr);
        for k in 0..m {
            items.swap(l + off_l[sl + k] as usize, r - 1 - off_r[sr + k] as usize);
        }
        (sl, nl, sr, nr) = (sl + m, nl - m, sr + m, nr - m);
        if nl == 0 {
            l += BLOCK;
        }
        if nr == 0 {
            r -= BLOCK;
        }
    }
    // At most one block is still loaded; the items between are not
    // classified yet.
    let (u0, u1) = match (nl > 0, nr > 0) {
        (true, _) => (l + BLOCK, r),
        (_, true) => (l, r - BLOCK),
        _ => (l, r),
    };
    let mut p = split.two_pointer(items, u0, u1);
    if nl > 0 {
        // Left items fill [l, p) but for the misplaced ones of the left
        // block; move those, highest first, to the end of that range.
        for k in (sl..sl + nl).rev() {
            p -= 1;
            items.swap(l + off_l[k] as usize, p);
        }
    } else if nr > 0 {
        // Right items fill [p, r) but for the misplaced ones of the right
        // block; move those, lowest position first, to the start of it.
        for k in (sr..sr + nr).rev() {
            items.swap(r - 1 - off_r[k] as usize, p);
            p += 1;
        }
    }
    // The sides' bounds, in one branch-free pass over each.
    (side_of(&items[..p]), side_of(&items[p..]))
}

/// Bounds and centers of a set, as a partition would report it.
pub fn side_of<T: Boxed>(items: &[T]) -> Side {
    let mut s = Side::EMPTY;
    for it in items {
        s.add(it.lo(), it.hi(), it.center());
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[derive(Clone, Copy)]
    struct B(Vec3A, Vec3A);
    impl Boxed for B {
        fn lo(&self) -> Vec3A {
            self.0
        }
        fn hi(&self) -> Vec3A {
            self.1
        }
    }
    fn pt(x: f32, y: f32, z: f32) -> B {
        B(Vec3A::new(x, y, z), Vec3A::new(x, y, z))
    }

    #[test]
    fn empty_halvings_shrink_the_candidate_without_a_split() {
        // Centers in [0.1, 0.2] of a [0, 8] candidate: halve 8 → 4 → 2 → 1 → 0.5 → 0.25,
        // then the plane 0.125 separates them.
        let mut cand = Aabb::new(Vec3::ZERO, Vec3::new(8.0, 1.0, 1.0));
        let centers = Aabb::new(Vec3::new(0.1, 0.5, 0.5), Vec3::new(0.2, 0.5, 0.5));
        let s = choose_split(&mut cand, &centers).unwrap();
        assert_eq!(
            s,
            Split {
                axis: 0,
                plane: 0.125
            }
        );
        assert_eq!(cand.max.x, 0.25);
    }

    #[test]
    fn coincident_centers_cannot_be_split() {
        let c = Aabb::new(Vec3::splat(0.3), Vec3::splat(0.3));
        assert_eq!(
            choose_split(&mut Aabb::new(Vec3::ZERO, Vec3::ONE), &c),
            None
        );
    }

    #[test]
    fn adjacent_floats_still_split_when_halving_stalls() {
        for x in [1.0f32, 1e15, 1e-15, -3.0e7] {
            let next = f32::from_bits(x.to_bits() + 1);
            let (lo, hi) = if next > x { (x, next) } else { (next, x) };
            let mut cand = Aabb::new(Vec3::new(lo, 0.0, 0.0), Vec3::new(hi, 0.0, 0.0));
            let centers = cand;
            let s = choose_split(&mut cand, &centers).unwrap();
            let mut items = [pt(hi, 0.0, 0.0), pt(lo, 0.0, 0.0)];
            let (l, r) = partition(&mut items, s);
            assert_eq!((l.count, r.count), (1, 1), "x = {x}");
            assert_eq!(items[0].0.x, lo);
        }
    }

    #[test]
    fn a_flat_candidate_axis_moves_to_another_axis() {
        // Centers coincide on the longest candidate axis (x) but differ in y.
        let mut cand = Aabb::new(Vec3::ZERO, Vec3::new(100.0, 1.0, 0.0));
        let centers = Aabb::new(Vec3::new(50.0, 0.2, 0.0), Vec3::new(50.0, 0.7, 0.0));
        let s = choose_split(&mut cand, &centers).unwrap();
        assert_eq!(s.axis, 1);
        assert!(s.plane > 0.2 && s.plane <= 0.7);
    }

    proptest::proptest! {
        /// The block partition against a plain filter, at sizes spanning
        /// many blocks; sorted inputs leave one block pending at the end.
        #[test]
        fn the_block_partition_is_a_filter_with_both_sides_bounds(
            xs in proptest::collection::vec(0u16..1000, 0..700),
            plane in 0u16..1001,
            order in 0u8..3,
        ) {
            let mut xs = xs;
            match order {
                1 => xs.sort(),
                2 => xs.sort_by(|a, b| b.cmp(a)),
                _ => {}
            }
            // y carries the item's identity; centers are x + 0.25.
            let mut items: Vec<B> = xs
                .iter()
                .enumerate()
                .map(|(i, &x)| {
                    let (x, y) = (x as f32, i as f32);
                    B(Vec3A::new(x, y, 0.0), Vec3A::new(x + 0.5, y + 1.0, 2.0))
                })
                .collect();
            let split = Split { axis: 0, plane: plane as f32 };
            let (l, r) = partition(&mut items, split);
            let k = l.count;
            proptest::prop_assert_eq!(k + r.count, xs.len());
            proptest::prop_assert!(items[..k].iter().all(|b| b.center().x < split.plane));
            proptest::prop_assert!(items[k..].iter().all(|b| b.center().x >= split.plane));
            let mut ids: Vec<u32> = items.iter().map(|b| b.0.y as u32).collect();
            ids.sort_unstable();
            proptest::prop_assert!(ids.iter().copied().eq(0..xs.len() as u32), "not a permutation");
            proptest::prop_assert_eq!(l, side_of(&items[..k]));
            proptest::prop_assert_eq!(r, side_of(&items[k..]));
        }
    }

    #[test]
    fn partition_puts_centers_below_the_plane_first_and_fits_planes() {
        let mut items: Vec<B> = (0..100)
            .map(|i| pt((i * 37 % 100) as f32, 0.0, i as f32))
            .collect();
        let (l, r) = partition(
            &mut items,
            Split {
                axis: 0,
                plane: 42.5,
            },
        );
        assert_eq!((l.count, r.count), (43, 57));
        assert!(items[..43].iter().all(|b| b.0.x < 42.5));
        assert!(items[43..].iter().all(|b| b.0.x >= 42.5));
        assert_eq!(clip_planes(0, &l, &r), [42.0, 43.0]);
        let left_max_z = items[..43].iter().map(|b| b.0.z).fold(f32::MIN, f32::max);
        assert_eq!(l.centers().max.z, left_max_z);
    }
}
#[cfg(test)]
mod stall_tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn a_halving_f32_cannot_make_is_counted_and_still_splits() {
        // A candidate one f32 step wide at 1e7: its middle rounds to its
        // low face, so the halving stalls; the split falls back to the
        // largest center.
        let (a, b) = (1e7f32, 1e7f32 + 1.0);
        let mut cand = Aabb::new(Vec3::new(a, 0.0, 0.0), Vec3::new(b, 0.0, 0.0));
        let centers = cand;
        let mut stalls = 0;
        let s = choose_split_counted(&mut cand, &centers, &mut stalls).unwrap();
        assert_eq!((s.axis, s.plane, stalls), (0, b, 1));
        // A candidate that halves: no stall.
        let mut cand = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let centers = Aabb::new(Vec3::ZERO, Vec3::ONE);
        choose_split_counted(&mut cand, &centers, &mut stalls).unwrap();
        assert_eq!(stalls, 1);
    }
}
