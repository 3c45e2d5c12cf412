//! The empty-space cut-off (Wächter & Keller 2006, section 3.2; Sunflow's
//! BIH), the kernel every builder that builds it shares, host and SPE alike:
//! when a node's triangles leave a gap of more than a threshold of its
//! *region* (the box its ancestors' planes leave it, what a ray must enter)
//! on one side of one axis, a **clip node** cuts the gap off before the node
//! splits. A clip node is an inner node whose empty child is a leaf of no
//! triangles behind a plane at ∓∞ (traversal never enters it: a ray leaves
//! that child before it enters, see `bih/traverse.rs`), and whose other
//! child is the node again, its region cut to its triangles on that side.
//! The candidate box of the global heuristic is left as it is, so the planes
//! below are the ones the node would have had.
//!
//! A builder needs, per node, its region and the bounds of its triangles:
//! the host recursion passes them down; the SPE builders' jobs carry them
//! (`strategy::machinery::breadth_first::Job`, 128 bytes instead of 64 when the cut-off is
//! on).

use crate::aabb::Aabb;

/// A gap to cut off: on `axis`, below the triangles (`low`) or above.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cut {
    pub axis: usize,
    pub low: bool,
}

/// A clip node as every builder makes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clip {
    pub axis: usize,
    /// The inner node's planes: `[-inf, lo]` (gap below) or `[hi, +inf]`.
    pub planes: [f32; 2],
    /// Which child (0 or 1) is the empty leaf; the other is the node again.
    pub empty: usize,
    /// Where the empty leaf's range of no triangles starts: before the
    /// node's triangles (gap below) or after them, so that leaf ranges stay
    /// in tree order (the local update relies on it).
    pub leaf_at: usize,
    /// The full child's region.
    pub region: Aabb,
}

/// The widest gap between `region` and the triangles' `bounds` that is
/// more than `percent` of the region's extent on its axis, if any (ties: the
/// lower axis, the low side). In `f64`: extents may pass `f32::MAX`.
pub fn empty_gap(region: &Aabb, bounds: &Aabb, percent: u32) -> Option<Cut> {
    let threshold = percent as f64 / 100.0;
    let mut best: Option<(f64, Cut)> = None;
    for axis in 0..3 {
        let ext = region.max[axis] as f64 - region.min[axis] as f64;
        if !(ext > 0.0 && ext.is_finite()) {
            continue;
        }
        let gaps = [
            (bounds.min[axis] as f64 - region.min[axis] as f64, true),
            (region.max[axis] as f64 - bounds.max[axis] as f64, false),
        ];
        for (gap, low) in gaps {
            let f = gap / ext;
            if f > threshold && best.is_none_or(|(b, _)| f > b) {
                best = Some((f, Cut { axis, low }));
            }
        }
    }
    best.map(|(_, c)| c)
}

impl Cut {
    /// The clip node that cuts this gap off a node of `count` triangles
    /// from `first`, whose region is `region` and triangles' box `bounds`.
    pub fn clip(self, mut region: Aabb, bounds: &Aabb, first: usize, count: usize) -> Clip {
        let a = self.axis;
        if self.low {
            region.min[a] = bounds.min[a];
            Clip {
                axis: a,
                planes: [f32::NEG_INFINITY, bounds.min[a]],
                empty: 0,
                leaf_at: first,
                region,
            }
        } else {
            region.max[a] = bounds.max[a];
            Clip {
                axis: a,
                planes: [bounds.max[a], f32::INFINITY],
                empty: 1,
                leaf_at: first + count,
                region,
            }
        }
    }
}

/// The regions of a split node's children: `region` cut at the left
/// child's plane `planes[0]` (its maximum) and the right child's
/// `planes[1]` (its minimum) on `axis`.
pub fn child_regions(region: Aabb, axis: usize, planes: [f32; 2]) -> [Aabb; 2] {
    let (mut l, mut r) = (region, region);
    l.max[axis] = l.max[axis].min(planes[0]);
    r.min[axis] = r.min[axis].max(planes[1]);
    [l, r]
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn a_gap_over_the_threshold_is_cut_on_its_side_and_none_under_it() {
        let region = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        // z: 60 % empty below; y: 10 % above.
        let mut bounds = Aabb::new(Vec3::new(0.0, 0.0, 6.0), Vec3::new(10.0, 9.0, 10.0));
        assert_eq!(
            empty_gap(&region, &bounds, 50),
            Some(Cut { axis: 2, low: true })
        );
        assert_eq!(
            empty_gap(&region, &bounds, 5),
            Some(Cut { axis: 2, low: true })
        );
        assert_eq!(empty_gap(&region, &bounds, 60), None);
        bounds.min.z = 0.0;
        assert_eq!(
            empty_gap(&region, &bounds, 5),
            Some(Cut {
                axis: 1,
                low: false
            })
        );
        assert_eq!(empty_gap(&region, &bounds, 10), None);
    }

    #[test]
    fn a_clip_cuts_the_region_to_the_triangles_and_places_its_empty_leaf_on_the_gap_side() {
        let region = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        let bounds = Aabb::new(Vec3::new(0.0, 0.0, 6.0), Vec3::new(10.0, 9.0, 10.0));
        let low = Cut { axis: 2, low: true }.clip(region, &bounds, 5, 3);
        assert_eq!(low.planes, [f32::NEG_INFINITY, 6.0]);
        assert_eq!((low.empty, low.leaf_at), (0, 5));
        assert_eq!(low.region.min.z, 6.0);
        let high = Cut {
            axis: 1,
            low: false,
        }
        .clip(region, &bounds, 5, 3);
        assert_eq!(high.planes, [9.0, f32::INFINITY]);
        assert_eq!((high.empty, high.leaf_at), (1, 8));
        assert_eq!(high.region.max.y, 9.0);
        // The z gap is gone; the next cut is the 10 % on y, then none.
        let next = empty_gap(&low.region, &bounds, 5);
        assert_eq!(
            next,
            Some(Cut {
                axis: 1,
                low: false
            })
        );
        let done = next.unwrap().clip(low.region, &bounds, 5, 3).region;
        assert_eq!(empty_gap(&done, &bounds, 5), None);
    }

    #[test]
    fn child_regions_never_grow_the_parent_region() {
        let region = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        let [l, r] = child_regions(region, 0, [12.0, -1.0]);
        assert_eq!((l.max.x, r.min.x), (10.0, 0.0));
        let [l, r] = child_regions(region, 0, [4.0, 6.0]);
        assert_eq!((l.max.x, r.min.x), (4.0, 6.0));
    }
}
