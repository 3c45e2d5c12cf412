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
    if centers.min == centers.max {
        return None;
    }
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

/// Partitions `items` in place: those whose center is below `split.plane`
/// first. Returns both sides' counts and bounds. Deterministic; each item is
/// looked at once (two pointers: a right-side item is swapped to the end).
///
/// PERF: on the dragon (871,414 triangles) this two-pointer form was faster
/// than a branchless Lomuto form (which swaps every item) with either
/// branching or indexed side updates: 139–155 ms vs 155–207 ms for the
/// whole build.
pub fn partition<T: Boxed>(items: &mut [T], split: Split) -> (Side, Side) {
    let (mut left, mut right) = (Side::EMPTY, Side::EMPTY);
    let (mut i, mut j) = (0, items.len());
    while i < j {
        let it = items[i];
        let (lo, hi) = (it.lo(), it.hi());
        let c = lo * 0.5 + hi * 0.5;
        if c[split.axis] < split.plane {
            left.add(lo, hi, c);
            i += 1;
        } else {
            right.add(lo, hi, c);
            j -= 1;
            items.swap(i, j);
        }
    }
    (left, right)
}

/// Bounds and centers of a set, as a partition would report it.
pub fn side_of<T: Boxed>(items: &[T]) -> Side {
    let mut s = Side::EMPTY;
    for it in items {
        s.add(it.lo(), it.hi(), it.center());
    }
    s
}
