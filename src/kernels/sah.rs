//! Binned SAH split choice — the high-quality end of the speed/accuracy
//! trade (not in the paper, whose builders all use the global
//! heuristic of [`super::split::choose_split`]).
//!
//! Binning after Wald ("On fast construction of SAH-based bounding volume
//! hierarchies", RT 2007): on each axis on which the node's box centers
//! differ, `bins` equal bins over the centers' bounds; one pass over the
//! node's triangles counts each bin and unions the boxes of its triangles;
//! two sweeps give, for the plane between bins `i` and `i + 1`, the
//! surface-area cost `area(left) · n_left + area(right) · n_right`. The
//! cheapest plane wins (ties: the lower axis, then the lower plane). The
//! split is the partition's own test (a triangle goes left when its box
//! center is below the plane), so the BIH's clip planes come out of the
//! partition as with the global heuristic.
//!
//! Numerics: bin positions and areas are computed in `f64` (a scene 1e15
//! wide has areas of 1e30 and counts up to 1e9 multiply them); a plane is
//! kept only if, rounded to `f32`, it still has a center on each side
//! (`cmin < plane <= cmax`), which guarantees that the partition separates.
//! When no plane qualifies, [`sah_split`] returns `None` and the builder
//! falls back to the global heuristic.

use glam::{DVec3, Vec3A};

use super::split::{Boxed, Split, choose_split_counted};
use crate::aabb::Aabb;

pub use crate::bih::{DEFAULT_BINS, MAX_BINS};

/// Bins per axis for a requested count: clamped to `2..=MAX_BINS`.
pub fn bins_per_axis(bins: u32) -> u32 {
    bins.clamp(2, MAX_BINS)
}

/// The cheapest plane by binned SAH for `items`, whose box centers `centers`
/// bounds, or `None` when no candidate plane separates them in `f32`.
pub fn sah_split<T: Boxed>(items: &[T], centers: &Aabb, bins: u32) -> Option<Split> {
    let mut b = Bins::new(centers, bins);
    b.add(items);
    b.choose()
}

/// The bins of one node: filled by one pass over its triangles (in as many
/// pieces as it comes in: an SPE bins a local-store block at a time), then
/// swept for the cheapest plane.
#[derive(Clone)]
pub struct Bins {
    centers: Aabb,
    lo: DVec3,
    ext: DVec3,
    /// Bins per unit of length, by axis; 0 on an axis where centers
    /// coincide.
    scale: DVec3,
    bin: Vec<[Bin; 3]>,
}

impl Bins {
    /// Empty bins (`bins`, clamped to 2..=[`MAX_BINS`], on each axis) over
    /// `centers`, the bounds of the node's box centers.
    pub fn new(centers: &Aabb, bins: u32) -> Self {
        let bins = bins_per_axis(bins) as usize;
        let ext = centers.extent_f64();
        Bins {
            centers: *centers,
            lo: centers.min.as_dvec3(),
            ext,
            scale: DVec3::select(ext.cmpgt(DVec3::ZERO), bins as f64 / ext, DVec3::ZERO),
            bin: vec![[Bin::EMPTY; 3]; bins],
        }
    }

    /// Bins `items` (their centers must lie in the bins' centers box).
    pub fn add<T: Boxed>(&mut self, items: &[T]) {
        let index = BinIndex {
            lo: self.lo,
            scale: self.scale,
            last: self.bin.len() - 1,
        };
        let bin = &mut self.bin[..];
        // Each item is loaded one item ahead of its bins' updates (its load
        // need not wait behind the stores of the item before). With the
        // packed index this took 12–21 % off the host's SAH builds with
        // large nodes; alone it gained nothing (docs/tradeoff.md).
        let Some(first) = items.first() else { return };
        let (mut lo, mut hi) = (first.lo(), first.hi());
        for next in items[1..].iter().map(Some).chain([None]) {
            let (l, h) = (lo, hi);
            if let Some(n) = next {
                (lo, hi) = (n.lo(), n.hi());
            }
            let k = index.of(l * 0.5 + h * 0.5); // Boxed::center
            for a in 0..3 {
                bin[k[a]][a].add(l, h);
            }
        }
    }

    /// The cheapest plane between two bins that separates the centers in
    /// `f32` (ties: the lower axis, then the lower plane), or `None`.
    pub fn choose(&self) -> Option<Split> {
        let (bins, lo, ext) = (self.bin.len(), self.lo, self.ext);
        let mut best: Option<(f64, Split)> = None;
        for a in (0..3).filter(|&a| self.scale[a] > 0.0) {
            // right[i]: bins i.. together.
            let mut right = vec![Bin::EMPTY; bins];
            let mut acc = Bin::EMPTY;
            for i in (0..bins).rev() {
                acc.merge(&self.bin[i][a]);
                right[i] = acc;
            }
            let mut left = Bin::EMPTY;
            for i in 0..bins - 1 {
                left.merge(&self.bin[i][a]);
                let r = &right[i + 1];
                if left.count == 0 || r.count == 0 {
                    continue;
                }
                let plane = (lo[a] + ext[a] * (i + 1) as f64 / bins as f64) as f32;
                if !(self.centers.min[a] < plane && plane <= self.centers.max[a]) {
                    continue;
                }
                let cost = left.area() * left.count as f64 + r.area() * r.count as f64;
                if best.is_none_or(|(c, _)| cost < c) {
                    best = Some((cost, Split { axis: a, plane }));
                }
            }
        }
        best.map(|(_, s)| s)
    }

    /// The split of every builder's binned SAH: the cheapest binned plane,
    /// or, where none separates in `f32`, the global heuristic's in
    /// `candidate` (halved in place; `stalls` counts the halvings `f32`
    /// could not make). `None` only when the centers coincide.
    pub fn choose_or_halve(&self, candidate: &mut Aabb, stalls: &mut u64) -> Option<Split> {
        (self.choose()).or_else(|| choose_split_counted(candidate, &self.centers, stalls))
    }

    /// Bins per axis.
    pub fn per_axis(&self) -> usize {
        self.bin.len()
    }

    /// The bins as they travel between cores: axis-major, each a count
    /// and a box in 32 bytes.
    pub fn records(&self) -> Vec<BinRecord> {
        (0..3)
            .flat_map(|a| self.bin.iter().map(move |b| b[a].record()))
            .collect()
    }

    /// Adds bins another core filled over the same centers box
    /// ([`Bins::records`]).
    pub fn add_records(&mut self, records: &[BinRecord]) {
        let n = self.bin.len();
        assert_eq!(records.len(), 3 * n, "three axes of {n} bins");
        for (i, r) in records.iter().enumerate() {
            self.bin[i % n][i / n].merge(&Bin::of_record(r));
        }
    }

    /// Bytes the bins take in a local store: per bin and axis a count and a
    /// box, two quadwords.
    pub fn ls_bytes(bins: u32) -> u32 {
        bins_per_axis(bins) * 3 * 32
    }
}

/// A center's bin on each axis: `(c - lo) · scale` in `f64`, truncated and
/// clamped to `0..=last` — what `as` casts and `min(last)` give.
///
/// On x86_64 the same `f64` arithmetic runs two lanes at a time (SSE2,
/// which every x86_64 has) and truncates with packed instructions: the
/// three scalar float-to-integer conversions a center cost most of the
/// binning when our host runs on its slow side (docs/tradeoff.md). Both
/// ways give the same bins (a test compares them), so the tree does not
/// depend on the host.
struct BinIndex {
    lo: DVec3,
    scale: DVec3,
    last: usize,
}

impl BinIndex {
    /// The portable way, and the reference of the x86_64 one.
    #[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
    #[inline]
    fn of_scalar(&self, c: Vec3A) -> [usize; 3] {
        let k = ((c.as_dvec3() - self.lo) * self.scale).as_uvec3();
        k.to_array().map(|k| (k as usize).min(self.last))
    }

    #[cfg(not(target_arch = "x86_64"))]
    #[inline]
    fn of(&self, c: Vec3A) -> [usize; 3] {
        self.of_scalar(c)
    }

    #[cfg(target_arch = "x86_64")]
    #[inline]
    fn of(&self, c: Vec3A) -> [usize; 3] {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is in every x86_64 (the target's baseline), and these
        // intrinsics touch registers only.
        unsafe {
            let c: __m128 = c.into();
            let last = _mm_set1_pd(self.last as f64);
            // maxpd gives its second operand for a NaN, as `as` gives 0.
            let lanes = |c: __m128d, lo: __m128d, scale: __m128d| {
                let v = _mm_mul_pd(_mm_sub_pd(c, lo), scale);
                _mm_cvttpd_epi32(_mm_min_pd(_mm_max_pd(v, _mm_setzero_pd()), last))
            };
            let xy = lanes(
                _mm_cvtps_pd(c),
                _mm_set_pd(self.lo.y, self.lo.x),
                _mm_set_pd(self.scale.y, self.scale.x),
            );
            let z = lanes(
                _mm_cvtps_pd(_mm_movehl_ps(c, c)),
                _mm_set_sd(self.lo.z),
                _mm_set_sd(self.scale.z),
            );
            [
                _mm_cvtsi128_si32(xy) as usize,
                _mm_cvtsi128_si32(_mm_srli_si128::<4>(xy)) as usize,
                _mm_cvtsi128_si32(z) as usize,
            ]
        }
    }
}

/// A bin as it travels (DMA, main memory): 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BinRecord {
    lo: [f32; 3],
    count: u32,
    hi: [f32; 3],
    pad: u32,
}

/// One bin on one axis: how many centers fell in it and the union of their
/// triangles' boxes.
#[derive(Clone, Copy)]
struct Bin {
    count: u64,
    lo: Vec3A,
    hi: Vec3A,
}

impl Bin {
    const EMPTY: Bin = Bin {
        count: 0,
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
    };

    fn add(&mut self, lo: Vec3A, hi: Vec3A) {
        self.count += 1;
        self.lo = self.lo.min(lo);
        self.hi = self.hi.max(hi);
    }

    fn merge(&mut self, o: &Bin) {
        self.count += o.count;
        self.lo = self.lo.min(o.lo);
        self.hi = self.hi.max(o.hi);
    }

    fn record(&self) -> BinRecord {
        BinRecord {
            lo: self.lo.to_array(),
            count: self.count as u32,
            hi: self.hi.to_array(),
            pad: 0,
        }
    }

    fn of_record(r: &BinRecord) -> Bin {
        Bin {
            count: r.count as u64,
            lo: Vec3A::from_array(r.lo),
            hi: Vec3A::from_array(r.hi),
        }
    }

    /// Surface area of the box, in `f64`; 0 for an empty bin.
    fn area(&self) -> f64 {
        Aabb::new(self.lo.into(), self.hi.into()).surface_area()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::recursion::PrimRef;
    use crate::kernels::split::side_of;
    use glam::Vec3;

    fn unit_boxes(xs: &[f32]) -> Vec<PrimRef> {
        xs.iter()
            .enumerate()
            .map(|(i, &x)| {
                PrimRef::new(
                    i as u32,
                    Aabb::new(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 0.1, 0.1, 0.1)),
                )
            })
            .collect()
    }

    #[test]
    fn the_plane_falls_in_the_gap_between_two_clusters() {
        // Ten boxes near 0, ten near 100: the middle halving of the global
        // heuristic would also separate them, but so would many planes;
        // SAH must put the plane inside the gap, not through a cluster.
        let xs: Vec<f32> = (0..10)
            .map(|i| i as f32 * 0.2)
            .chain((0..10).map(|i| 100.0 + i as f32 * 0.2))
            .collect();
        let items = unit_boxes(&xs);
        let centers = side_of(&items).centers();
        let s = sah_split(&items, &centers, 16).unwrap();
        assert_eq!(s.axis, 0);
        assert!(s.plane > 2.0 && s.plane <= 100.05, "{s:?}");
    }

    #[test]
    fn an_outlier_is_cut_off_where_the_middle_halving_would_not() {
        // 99 boxes in [0, 1] and one at 1000: the middle of the centers'
        // span (500) cuts off the outlier too; with the outlier at 10, the
        // halving at 5 still does; SAH must also separate the outlier and
        // leave the cluster whole.
        let mut xs: Vec<f32> = (0..99).map(|i| i as f32 / 99.0).collect();
        xs.push(10.0);
        let items = unit_boxes(&xs);
        let centers = side_of(&items).centers();
        let s = sah_split(&items, &centers, 16).unwrap();
        let left = items.iter().filter(|it| it.center().x < s.plane).count();
        assert_eq!(left, 99, "{s:?}");
    }

    #[test]
    fn binning_in_pieces_gives_the_plane_of_one_pass() {
        let xs: Vec<f32> = (0..100).map(|i| ((i * 37) % 101) as f32).collect();
        let items = unit_boxes(&xs);
        let centers = side_of(&items).centers();
        let mut b = Bins::new(&centers, 8);
        for piece in items.chunks(7) {
            b.add(piece);
        }
        assert_eq!(b.choose(), sah_split(&items, &centers, 8));
        assert!(b.choose().is_some());
        // Through their records (another core's bins), the same plane.
        let mut c = Bins::new(&centers, 8);
        c.add_records(&b.records());
        assert_eq!(c.choose(), b.choose());
    }

    #[test]
    fn centers_one_ulp_apart_split_at_the_upper_one() {
        let a = 1.0f32;
        let b = f32::from_bits(a.to_bits() + 1);
        let items: Vec<PrimRef> = [a, b]
            .iter()
            .enumerate()
            .map(|(i, &x)| PrimRef::new(i as u32, Aabb::new(Vec3::splat(x), Vec3::splat(x))))
            .collect();
        // Every candidate plane rounds to a or to b in f32; only those at b
        // separate, and one of them must be found.
        let centers = side_of(&items).centers();
        let s = sah_split(&items, &centers, 16).expect("a plane at b separates");
        assert_eq!(s.plane, b, "{s:?}");
        // Coinciding centers: nothing to split.
        let same = [items[0], items[0]];
        assert_eq!(sah_split(&same, &side_of(&same).centers(), 16), None);
    }

    /// A finite `f32` of any magnitude (subnormal to 3e38), or zero.
    fn any_f32() -> impl proptest::strategy::Strategy<Value = f32> {
        use proptest::num::f32::{NEGATIVE, NORMAL, POSITIVE, SUBNORMAL, ZERO};
        POSITIVE | NEGATIVE | NORMAL | SUBNORMAL | ZERO
    }

    proptest::proptest! {
        /// The bin index of this host (packed on x86_64) is the portable
        /// one, lane for lane, for centers in the box, on its faces and
        /// outside it, boxes flat on an axis included: trees do not depend
        /// on the host.
        #[test]
        fn the_bin_index_is_the_portable_one(
            a in proptest::array::uniform3(any_f32()),
            b in proptest::array::uniform3(any_f32()),
            c in proptest::array::uniform3(any_f32()),
            flat in 0usize..4,
            bins in 2u32..=MAX_BINS,
        ) {
            let (mut a, b) = (Vec3::from_array(a), Vec3::from_array(b));
            if flat < 3 {
                a[flat] = b[flat];
            }
            let centers = Aabb::new(a.min(b), a.max(b));
            let bb = Bins::new(&centers, bins);
            let index = BinIndex { lo: bb.lo, scale: bb.scale, last: bb.per_axis() - 1 };
            for c in [Vec3::from_array(c), centers.min, centers.max, centers.center()] {
                let c = Vec3A::from(c);
                proptest::prop_assert_eq!(index.of(c), index.of_scalar(c), "{:?} in {:?}", c, centers);
            }
        }
    }

    /// `--sah-above N`: nodes of at most N triangles take the global
    /// heuristic. Above every node's count the tree is the global
    /// heuristic's (with the same cut-off); at 0 it is binned SAH's; in
    /// between it is neither, and valid.
    #[test]
    fn sah_above_bins_only_the_nodes_above_it() {
        use crate::bih::{BihConfig, SplitChoice};
        use crate::host::build;
        let cfg = |above| BihConfig {
            split: SplitChoice::BinnedSah { bins: 16, above },
            ..BihConfig::SAH_CUT
        };
        assert_eq!(cfg(40).sah_bins(40), None);
        assert_eq!(cfg(40).sah_bins(41), Some(16));
        assert_eq!(BihConfig::DEFAULT.sah_bins(1 << 20), None);
        let s = crate::scene::procedural::rtperf(5_000, 3);
        let gh = BihConfig {
            split: SplitChoice::GlobalHeuristic,
            ..BihConfig::SAH_CUT
        };
        let n = s.len() as u32;
        assert_eq!(build(&s, &cfg(n)).nodes, build(&s, &gh).nodes);
        assert_eq!(
            build(&s, &cfg(0)).nodes,
            build(&s, &BihConfig::SAH_CUT).nodes
        );
        let mixed = build(&s, &cfg(64));
        mixed.validate(&s).unwrap();
        assert_ne!(mixed.nodes, build(&s, &gh).nodes);
        assert_ne!(mixed.nodes, build(&s, &cfg(0)).nodes);
    }
}
