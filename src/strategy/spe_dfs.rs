//! `spe_dfs` — the paper's depth-first construction (section 2, Table 1):
//! "only sorting is done on the SPE, the recursion and creation of nodes is
//! still entirely done on the PPE".
//!
//! The PPE chooses each split by the global heuristic, writes the job (the
//! interval and the plane) to main memory and signals SPE 0. The SPE fetches
//! the job by DMA, partitions the interval of the triangle array in place
//! with the five-buffer stream of Fig. 1 ([`crate::spe::fig1`]), puts back the
//! split index and the fitted values of both sides (the left's rightmost and
//! the right's leftmost, with the sides' bounds of centers), and tells the
//! PPE through its outbound mailbox. With these the PPE makes the node and
//! recurses. A first job streams the whole array once for the root's bounds.
//!
//! The recursion is the host builder's, in the same depth-first order, so
//! the tree equals the host tree node for node. With the empty-space
//! cut-off ([`crate::kernels::cutoff`]) the PPE makes the clip nodes: it
//! knows each node's region and its triangles' box, and a clip node moves
//! no triangle. With binned SAH ([`crate::kernels::sah`]) each split takes
//! one more job: the SPE streams the interval through two of Fig. 1's
//! buffers, bins it and puts the bins back; the PPE sweeps them (a job is
//! then 64 bytes: the interval's bounds of centers travel with it).

use crate::spe::footprint::Purpose;

use glam::Vec3A;

use super::machinery::work_queue::{from_wire, to_wire};
use super::{Output, Readback, Setup};
use crate::aabb::Aabb;
use crate::bih::{BihConfig, BihNode, SplitChoice};
use crate::cell::{Cell, CellError, Ea, Ppe, Spe};
use crate::kernels::cutoff::child_regions;
use crate::kernels::decide::{Decision, NodeView, decide};
use crate::kernels::rates::KernelRates;
use crate::kernels::recursion::BuildStats;
use crate::kernels::sah::Bins;
use crate::kernels::split::{Side, Split, clip_planes};
use crate::spe::fig1::{Fig1Buffers, partition_in_place, stream_bounds, stream_fold};
use crate::spe::layout::TriRecord;

const STOP: u32 = 0;
const PARTITION: u32 = 1;
const BOUNDS: u32 = 2;
/// Binned SAH: bin the interval, put the bins back.
const BINS: u32 = 3;
/// The largest DMA transfer.
const MAX_PUT: u32 = 16 * 1024;

/// A job in main memory: the paper's 32 bytes, 64 with binned SAH (the
/// interval's bounds of centers and the bin count travel too).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct DfsJob {
    kind: u32,
    first: u32,
    count: u32,
    axis: u32,
    plane: f32,
    pad: [u32; 3],
    centers: [[f32; 3]; 2],
    bins: u32,
    pad2: u32,
}

impl DfsJob {
    /// Bytes of a job that travel with `cfg`.
    fn bytes(cfg: &BihConfig) -> usize {
        match cfg.split {
            SplitChoice::BinnedSah { .. } => 64,
            SplitChoice::GlobalHeuristic => 32,
        }
    }
}

/// One side of a partition as the SPE reports it: 80 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct SideRecord {
    count: u32,
    pad: [u32; 3],
    lo: [f32; 4],
    hi: [f32; 4],
    center_lo: [f32; 4],
    center_hi: [f32; 4],
}

impl SideRecord {
    fn from_side(s: &Side) -> Self {
        let f = |v: Vec3A| v.extend(0.0).to_array();
        SideRecord {
            count: s.count as u32,
            pad: [0; 3],
            lo: f(s.lo),
            hi: f(s.hi),
            center_lo: f(s.center_lo),
            center_hi: f(s.center_hi),
        }
    }

    fn to_side(self) -> Side {
        let f = |a: [f32; 4]| Vec3A::new(a[0], a[1], a[2]);
        Side {
            count: self.count as usize,
            lo: f(self.lo),
            hi: f(self.hi),
            center_lo: f(self.center_lo),
            center_hi: f(self.center_hi),
        }
    }
}

/// `spe_dfs` in the registry of builders.
pub const STRATEGY: super::Strategy = super::Strategy::new(
    "spe_dfs",
    "depth first: PPE recursion, one SPE partitions each interval with Fig. 1's five buffers (Table 1, column 3)",
    spawn,
)
.with_quality(crate::bih::Quality::ALL);

fn spawn(cell: &mut Cell, setup: &Setup, cfg: &BihConfig) -> Result<Readback, CellError> {
    let (tris, n, region, cfg) = (setup.triangles, setup.count, setup.region, *cfg);
    let rates = setup.rates.kernels();
    let x = Exchange::alloc(cell, &cfg)?;
    cell.spawn_spe(0, move |spe| partitions(spe, x, tris, rates));
    let ppe = cell.spawn_ppe(move |ppe| recursion(ppe, x, n, region, cfg, rates));
    Ok(Box::new(move || ppe.take("PPE")))
}

/// Where the PPE and SPE 0 exchange a job and its answer in main memory.
#[derive(Clone, Copy)]
struct Exchange {
    job_ea: Ea,
    job_bytes: usize,
    /// The two sides' records of a partition (or the bounds).
    result_ea: Ea,
    /// Binned SAH: the bins SPE 0 filled (their bytes; none without SAH).
    bins: Option<u32>,
    bins_ea: Ea,
    bins_bytes: u32,
}

impl Exchange {
    fn alloc(cell: &mut Cell, cfg: &BihConfig) -> Result<Self, CellError> {
        let job_bytes = DfsJob::bytes(cfg);
        let job_ea = cell.memory_mut().alloc(
            Purpose::JobQueues.buffer("depth-first job"),
            job_bytes as u64,
            128,
        )?;
        let result_ea = cell.memory_mut().alloc(
            Purpose::JobQueues.buffer("side records"),
            2 * size_of::<SideRecord>() as u64,
            128,
        )?;
        // Binned SAH: where the SPE puts the bins it filled.
        let bins = match cfg.split {
            SplitChoice::BinnedSah { bins, .. } => Some(bins),
            SplitChoice::GlobalHeuristic => None,
        };
        let bins_bytes = bins.map_or(0, Bins::ls_bytes);
        let bins_ea = match bins {
            Some(_) => cell.memory_mut().alloc(
                Purpose::JobQueues.buffer("SAH bins"),
                bins_bytes as u64,
                128,
            )?,
            None => Ea(0),
        };
        Ok(Exchange {
            job_ea,
            job_bytes,
            result_ea,
            bins,
            bins_ea,
            bins_bytes,
        })
    }
}

/// SPE 0's program: on each signal it reads the job and partitions (or
/// bounds, or bins) the interval with Fig. 1's five buffers, and answers;
/// it ends on STOP.
async fn partitions(spe: Spe, x: Exchange, tris: Ea, k: KernelRates) -> Result<(), CellError> {
    let bufs = Fig1Buffers::alloc(&spe)?;
    let job_ls = spe.ls_alloc(x.job_bytes as u32, 128)?;
    let result_ls = spe.ls_alloc(2 * size_of::<SideRecord>() as u32, 128)?;
    let bins_ls = match x.bins {
        Some(_) => Some(spe.ls_alloc(x.bins_bytes, 128)?),
        None => None,
    };
    let job_tag = spe.tag("depth-first job and result")?;
    loop {
        spe.read_signal(1).await?;
        spe.get(job_ls, x.job_ea, x.job_bytes as u32, job_tag)
            .await?;
        spe.wait_tag(job_tag).await?;
        let job: DfsJob = from_wire(&spe.ls_read::<u8>(job_ls, x.job_bytes)?, x.job_bytes)[0];
        let at = tris.offset(job.first as u64 * size_of::<TriRecord>() as u64);
        let (left, right) = match job.kind {
            STOP => return Ok(()),
            BINS => {
                let centers = Aabb::new(job.centers[0].into(), job.centers[1].into());
                let empty = Bins::new(&centers, job.bins);
                let add = |b: &mut Bins, items: &[TriRecord]| b.add(items);
                let n = job.count as u64;
                let filled = stream_fold(&spe, &bufs, at, n, k.spe_bin_item, empty, add).await?;
                let ls = bins_ls.expect("binned SAH has its bins' place");
                spe.ls_write(ls, &filled.records())?;
                // In puts of at most 16 KiB (256 bins take 24 KiB).
                for at in (0..x.bins_bytes).step_by(MAX_PUT as usize) {
                    let size = MAX_PUT.min(x.bins_bytes - at);
                    spe.put(ls.offset(at), x.bins_ea.offset(at as u64), size, job_tag)
                        .await?;
                }
                spe.wait_tag(job_tag).await?;
                spe.write_out_mbox(1).await;
                continue;
            }
            BOUNDS => (
                stream_bounds::<TriRecord>(&spe, &bufs, at, job.count as u64, k.spe_bounds_item)
                    .await?,
                Side::EMPTY,
            ),
            _ => {
                let split = Split {
                    axis: job.axis as usize,
                    plane: job.plane,
                };
                let p = partition_in_place::<TriRecord>(
                    &spe,
                    &bufs,
                    at,
                    job.count as u64,
                    split,
                    k.spe_partition_item,
                )
                .await?;
                (p.left, p.right)
            }
        };
        spe.ls_write(
            result_ls,
            &[SideRecord::from_side(&left), SideRecord::from_side(&right)],
        )?;
        spe.put(
            result_ls,
            x.result_ea,
            2 * size_of::<SideRecord>() as u32,
            job_tag,
        )
        .await?;
        spe.wait_tag(job_tag).await?;
        spe.write_out_mbox(1).await;
    }
}

/// The PPE's program: the recursion, depth first, left first; each
/// interval's partition is SPE 0's job. Writes the nodes and returns them.
async fn recursion(
    ppe: Ppe,
    x: Exchange,
    n: usize,
    region: Aabb,
    cfg: BihConfig,
    k: KernelRates,
) -> Result<Output, CellError> {
    // One job on SPE 0, and its two sides.
    let send = async |job: DfsJob| -> Result<(), CellError> {
        ppe.write_pod(x.job_ea, &to_wire(&[job], x.job_bytes))
            .await?;
        ppe.send_signal(0, 1, 1).await?;
        ppe.read_out_mbox(0).await?;
        Ok(())
    };
    let ask = async |job: DfsJob| -> Result<(Side, Side), CellError> {
        send(job).await?;
        let r: Vec<SideRecord> = ppe.read_pod(x.result_ea, 2).await?;
        Ok((r[0].to_side(), r[1].to_side()))
    };
    // Binned SAH: SPE 0 bins the interval; the PPE sweeps the bins.
    let bins_of = async |first: usize, count: usize, centers: Aabb, bins: u32| {
        send(DfsJob {
            kind: BINS,
            first: first as u32,
            count: count as u32,
            centers: [centers.min.to_array(), centers.max.to_array()],
            bins,
            ..Default::default()
        })
        .await?;
        let mut b = Bins::new(&centers, bins);
        let records = ppe.read_pod(x.bins_ea, 3 * b.per_axis()).await?;
        b.add_records(&records);
        Ok::<_, CellError>(b)
    };
    let (all, _) = ask(DfsJob {
        kind: BOUNDS,
        count: n as u32,
        ..Default::default()
    })
    .await?;
    let mut nodes = vec![BihNode::default()];
    let mut stats = BuildStats::default();
    // Depth first, left first.
    let mut stack = vec![Pending {
        id: 0,
        first: 0,
        count: n,
        candidate: region,
        side: all,
        depth: 0,
        region,
    }];
    while let Some(Pending {
        id,
        first,
        count,
        mut candidate,
        side,
        depth,
        region,
    }) = stack.pop()
    {
        ppe.compute(k.ppe_node);
        let leaf = BihNode::leaf(first as u32, count as u32);
        let view = NodeView::of_side((first, count, depth), region, &side, candidate);
        let split = match decide(&cfg, &view, &mut 0) {
            Decision::Leaf => None,
            Decision::Clip(clip) => {
                // A clip node (the empty-space cut-off): no SPE work.
                stats.clip_nodes += 1;
                let full = clip.make_in(&mut nodes, id);
                stack.push(Pending {
                    id: full,
                    first,
                    count,
                    candidate,
                    side,
                    depth: depth + 1,
                    region: clip.region,
                });
                continue;
            }
            Decision::Split(split, c) => {
                candidate = c;
                Some(split)
            }
            Decision::Bin(bins) => {
                stats.items_binned += count as u64;
                stats.sah_sweeps += 1;
                let per_axis = crate::kernels::sah::bins_per_axis(bins) as u64;
                ppe.compute_items(k.ppe_sah_bin, 3 * per_axis);
                let b = bins_of(first, count, view.centers, bins).await?;
                b.choose_or_halve(&mut candidate, &mut 0)
            }
        };
        let Some(split) = split else {
            nodes[id] = leaf;
            continue;
        };
        let job = DfsJob {
            kind: PARTITION,
            first: first as u32,
            count: count as u32,
            axis: split.axis as u32,
            plane: split.plane,
            ..Default::default()
        };
        let (l, r) = ask(job).await?;
        stats.items_partitioned += count as u64;
        stats.partitions += 1;
        let children = nodes.len();
        nodes.push(BihNode::default());
        nodes.push(BihNode::default());
        let [cl, cr] = clip_planes(split.axis, &l, &r);
        nodes[id] = BihNode::inner(children as u32, split.axis, cl, cr);
        let [lc, rc] = split.candidates(candidate);
        let [lr, rr] = child_regions(region, split.axis, [cl, cr]);
        let d = depth + 1;
        stack.push(Pending {
            id: children + 1,
            first: first + l.count,
            count: r.count,
            candidate: rc,
            side: r,
            depth: d,
            region: rr,
        });
        stack.push(Pending {
            id: children,
            first,
            count: l.count,
            candidate: lc,
            side: l,
            depth: d,
            region: lr,
        });
    }
    // The SPE ends on STOP without an answer.
    let stop = DfsJob {
        kind: STOP,
        ..Default::default()
    };
    ppe.write_pod(x.job_ea, &to_wire(&[stop], x.job_bytes))
        .await?;
    ppe.send_signal(0, 1, 1).await?;
    let node_array = super::write_nodes(&ppe, &nodes).await?;
    stats.nodes = nodes.len() as u64;
    Ok(Output {
        nodes: vec![node_array],
        stats,
        spes: 1,
        ..Output::default()
    })
}

/// A node the PPE's depth-first loop has still to make: its slot, its
/// triangles (`first`, `count`), its candidate box, the side of its
/// parent's partition that holds them, its depth and its region.
struct Pending {
    id: usize,
    first: usize,
    count: usize,
    candidate: Aabb,
    side: Side,
    depth: u32,
    region: Aabb,
}
