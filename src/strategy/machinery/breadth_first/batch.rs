//! `spe_bfs`'s jobs made in blocks (section 2, Fig. 2): each job's node
//! chosen (leaf, clip node, split), small intervals **agglomerated** into
//! batches that travel in one get and one put (or DMA lists), large ones
//! streamed through Fig. 1's five buffers, binned SAH's binning where the
//! records are.

use super::{Job, SpeBuilder};
use crate::aabb::Aabb;
use crate::bih::BihNode;
use crate::cell::{CellError, ListElement, WaitMode};
use crate::kernels::cutoff::Clip;
use crate::kernels::decide::{Decision, NodeView, decide};
use crate::kernels::sah::Bins;
use crate::kernels::split::{Split, partition};
use crate::spe::fig1::{partition_in_place, stream_fold};
use crate::spe::layout::TriRecord;
use crate::strategy::machinery::coop::Descriptor;

/// What a job makes: a leaf, a clip node (the empty-space cut-off: no
/// triangle moves), or an inner node that splits its interval (with the
/// candidate box the split was chosen in), its plane chosen by the global
/// heuristic from the job alone, or by binned SAH once its triangles are
/// in the local store (`Sah`).
enum Make {
    Leaf,
    Clip(Clip),
    Split(Split, Aabb),
    Sah(Aabb),
}

impl Make {
    /// A split's plane (`None`: binned SAH, not chosen yet) and candidate.
    fn split(&self) -> Option<(Option<Split>, Aabb)> {
        match *self {
            Make::Split(s, cand) => Some((Some(s), cand)),
            Make::Sah(cand) => Some((None, cand)),
            Make::Leaf | Make::Clip(_) => None,
        }
    }
}

/// A job of the current agglomerated batch and what it will make.
struct Pending {
    job: Job,
    make: Make,
}

/// An agglomerated batch: its jobs, and the runs of the triangle array it
/// moves (record ranges). One run, the span of its intervals, unless DMA
/// lists gather several.
#[derive(Default)]
struct Batch {
    jobs: Vec<Pending>,
    runs: Vec<(u32, u32)>,
}

impl Batch {
    /// Records the runs move.
    fn records(&self) -> u32 {
        self.runs.iter().map(|(f, e)| e - f).sum()
    }

    /// The smallest range holding every run.
    fn extent(&self) -> Option<(u32, u32)> {
        let first = self.runs.iter().map(|r| r.0).min()?;
        Some((first, self.runs.iter().map(|r| r.1).max()?))
    }
}

/// What a block of jobs comes to: batches, and large intervals streamed
/// through Fig. 1, in job order.
enum Step {
    Batch(Batch),
    Large(Job, Option<Split>, Aabb),
    /// A job finished in the local store (`--finish local`).
    Local(Job),
}

impl SpeBuilder<'_> {
    /// What `job` makes, decided from the job alone, in the host builder's
    /// order: a leaf by the size and depth rule, a clip node where the
    /// cut-off finds a gap, else a split (binned SAH: chosen later, where
    /// the records are).
    fn make(&self, job: &Job) -> Make {
        let view = NodeView {
            first: job.first as usize,
            count: job.count as usize,
            depth: job.depth,
            region: job.region(),
            bounds: job.bounds(),
            centers: job.centers(),
            candidate: job.candidate(),
        };
        match decide(&self.cfg, &view, &mut 0) {
            Decision::Leaf => Make::Leaf,
            Decision::Clip(clip) => Make::Clip(clip),
            Decision::Split(s, candidate) => Make::Split(s, candidate),
            Decision::Bin(_) => Make::Sah(view.candidate),
        }
    }

    /// Makes the nodes of `jobs` (consecutive jobs of one level, in node-id
    /// order), agglomerating small intervals. Each batch runs as soon as
    /// it is complete, or, prefetching, once the block is planned.
    pub(in crate::strategy) async fn process(&mut self, jobs: &[Job]) -> Result<(), CellError> {
        if self.dealt_level {
            // The jobs dealt to this SPE (one block: at most 128).
            self.dealt_starts = jobs.iter().map(|j| j.first).collect();
        }
        let k = self.rates;
        let per_block = (crate::spe::fig1::BLOCK_BYTES as usize / size_of::<TriRecord>()) as u32;
        let mut steps = Vec::new();
        let mut batch = Batch::default();
        for &job in jobs {
            self.jobs += 1;
            self.spe.compute(k.spe_job);
            if self.finishes_locally(&job) {
                self.step(Step::Batch(std::mem::take(&mut batch)), &mut steps)
                    .await?;
                self.step(Step::Local(job), &mut steps).await?;
                continue;
            }
            let make = self.make(&job);
            let Some((s, cand)) = make.split() else {
                batch.jobs.push(Pending { job, make });
                continue;
            };
            if job.count > per_block {
                // A large interval: stream it through Fig. 1's buffers.
                self.step(Step::Batch(std::mem::take(&mut batch)), &mut steps)
                    .await?;
                self.step(Step::Large(job, s, cand), &mut steps).await?;
                continue;
            }
            let end = job.first + job.count;
            if self.dma_lists {
                // Any intervals, up to one block in all: adjacent ones
                // merge into one run.
                if batch.records() + job.count > per_block
                    || batch.runs.len() == crate::cell::MAX_LIST_ELEMENTS
                {
                    self.step(Step::Batch(std::mem::take(&mut batch)), &mut steps)
                        .await?;
                }
                match batch.runs.last_mut() {
                    Some(run) if run.1 == job.first => run.1 = end,
                    _ => batch.runs.push((job.first, end)),
                }
            } else {
                // One span: it grows over the leaves between, but must not
                // reach over records another SPE owns (the start of
                // another dealt interval, or any gap in a shared queue).
                let span = batch.runs.first().copied();
                let grown = span.map_or((job.first, end), |(f, _)| (f, end));
                let foreign = span.is_some_and(|(f, e)| {
                    (self.strict_spans && job.first != e)
                        || self.dealt_starts.iter().any(|&r| f < r && r <= job.first)
                });
                // (A job before the span, as a shared queue may hand out,
                // does not grow it: a new batch.)
                let too_wide = grown.1.checked_sub(grown.0).is_none_or(|w| w > per_block);
                if too_wide || foreign {
                    self.step(Step::Batch(std::mem::take(&mut batch)), &mut steps)
                        .await?;
                    batch.runs = vec![(job.first, end)];
                } else {
                    batch.runs = vec![grown];
                }
            }
            batch.jobs.push(Pending { job, make });
        }
        self.step(Step::Batch(batch), &mut steps).await?;
        self.run_prefetching(steps).await?;
        if let Some(w) = self.node_writes.as_mut() {
            w.flush().await?;
        }
        Ok(())
    }

    /// Runs `step` now, or, prefetching, keeps it for
    /// [`SpeBuilder::run_prefetching`].
    async fn step(&mut self, step: Step, later: &mut Vec<Step>) -> Result<(), CellError> {
        if self.prefetch {
            later.push(step);
            return Ok(());
        }
        match step {
            Step::Batch(mut b) => {
                let buf = self.get_batch(&b).await?;
                self.finish_batch(&mut b, buf).await
            }
            Step::Large(job, s, cand) => self.large(&job, s, cand).await,
            Step::Local(job) => self.finish_local(&job).await,
        }
    }

    /// Runs planned steps, issuing each batch's get before the batch ahead
    /// of it is partitioned.
    async fn run_prefetching(&mut self, steps: Vec<Step>) -> Result<(), CellError> {
        let mut steps = steps.into_iter().peekable();
        let mut ready = None;
        while let Some(step) = steps.next() {
            match step {
                Step::Large(job, s, cand) => self.large(&job, s, cand).await?,
                Step::Local(job) => self.finish_local(&job).await?,
                Step::Batch(mut b) => {
                    let buf = match ready.take() {
                        Some(buf) => buf,
                        None => self.get_batch(&b).await?,
                    };
                    if let Some(Step::Batch(next)) = steps.peek() {
                        ready = Some(self.get_batch(next).await?);
                    }
                    self.finish_batch(&mut b, buf).await?;
                }
            }
        }
        Ok(())
    }

    /// Partitions a large interval: streamed through Fig. 1's buffers, or
    /// cooperatively by every SPE.
    async fn large(&mut self, job: &Job, s: Option<Split>, cand: Aabb) -> Result<(), CellError> {
        let k = self.rates;
        self.settle_local().await?;
        // Fig. 1 reuses the batches' buffers: their puts finish first.
        let batches = (0..self.batch_buffers()).fold(0, |m, b| m | 1 << self.fig1.tag(b));
        self.spe.wait_tags(batches, WaitMode::All).await?;
        let (s, cand) = match s {
            Some(s) => (s, cand),
            None => {
                // Binned SAH: one more pass, through two of Fig. 1's
                // buffers, to bin the interval.
                let bins = self.new_bins(job)?;
                let at = self.interval(job.first);
                let (spe, fig1) = (self.spe, &self.fig1);
                let add = |b: &mut Bins, items: &[TriRecord]| b.add(items);
                let n = job.count as u64;
                let bins = stream_fold(spe, fig1, at, n, k.spe_bin_item, bins, add).await?;
                self.sah_choose(job, &bins, cand)
            }
        };
        if let Some((coop, min)) = self.coop.as_mut()
            && job.count >= *min
        {
            // Every SPE partitions a share of it.
            let d = Descriptor {
                first: job.first,
                count: job.count,
                split: s,
            };
            let (l, r) = coop
                .lead(self.spe, &self.fig1, d, k.spe_partition_item)
                .await?;
            return self.split_node(job, s, cand, &l, &r).await;
        }
        let p = partition_in_place::<TriRecord>(
            self.spe,
            &self.fig1,
            self.interval(job.first),
            job.count as u64,
            s,
            k.spe_partition_item,
        )
        .await?;
        self.split_node(job, s, cand, &p.left, &p.right).await
    }

    /// Fig. 1 buffers the batches take turns in: two, three when
    /// prefetching (the next batch's get must not wait for the put of the
    /// batch before).
    fn batch_buffers(&self) -> usize {
        if self.prefetch { 3 } else { 2 }
    }

    /// Issues the get of the batch's runs (one get, or a DMA list) into the
    /// next batch buffer; returns the buffer (`None`: only leaves).
    async fn get_batch(&mut self, batch: &Batch) -> Result<Option<usize>, CellError> {
        let Some((first, end)) = batch.extent() else {
            return Ok(None);
        };
        self.settle_local().await?;
        let buf = self.batch_buf;
        self.batch_buf = (buf + 1) % self.batch_buffers();
        // The buffer's previous put must be done before it is reused; and
        // another buffer's, if it wrote records this batch reads (the MFC
        // does not order commands of different tag groups: a get could
        // overtake that put). The model runs commands in order, so this
        // wait is rare and costs only where needed.
        let tag = self.fig1.tag(buf);
        self.spe.wait_tag(tag).await?;
        for other in (0..self.batch_buffers()).filter(|&b| b != buf) {
            if let Some((f, e)) = self.batch_put[other]
                && f < end
                && first < e
            {
                self.spe.wait_tag(self.fig1.tag(other)).await?;
            }
        }
        let ls = self.fig1.buffer(buf);
        match &self.run_list(batch)[..] {
            [one] => self.spe.get(ls, one.ea, one.size, tag).await?,
            list => self.spe.getl(ls, list, tag).await?,
        }
        Ok(Some(buf))
    }

    /// The batch's runs as DMA-list elements.
    fn run_list(&self, batch: &Batch) -> Vec<ListElement> {
        let size = size_of::<TriRecord>() as u32;
        let run = |&(f, e): &(u32, u32)| ListElement {
            ea: self.interval(f),
            size: (e - f) * size,
        };
        batch.runs.iter().map(run).collect()
    }

    /// Waits for the batch's get (into `buf`), partitions its intervals,
    /// puts them back, then makes the batch's nodes in order.
    async fn finish_batch(
        &mut self,
        batch: &mut Batch,
        buf: Option<usize>,
    ) -> Result<(), CellError> {
        let size = size_of::<TriRecord>() as u32;
        let mut sides = Vec::with_capacity(batch.jobs.len());
        if let Some(buf) = buf {
            let (ls, tag) = (self.fig1.buffer(buf), self.fig1.tag(buf));
            self.spe.wait_tag(tag).await?;
            let rate = self.rates.spe_partition_item;
            // Where each run starts in the local store. Runs are in job
            // order (a job extends the last run or starts one), not in
            // address order: jobs a shared queue hands out need not be.
            let mut run = 0;
            let mut run_at = 0u32;
            for p in batch.jobs.iter() {
                if let Some((s, cand)) = p.make.split() {
                    while !(batch.runs[run].0..batch.runs[run].1).contains(&p.job.first) {
                        run_at += (batch.runs[run].1 - batch.runs[run].0) * size;
                        run += 1;
                    }
                    let at = ls.offset(run_at + (p.job.first - batch.runs[run].0) * size);
                    let count = p.job.count as usize;
                    let (s, cand) = match s {
                        Some(s) => (s, cand),
                        None => {
                            // Binned SAH on the records in the local store.
                            let mut bins = self.new_bins(&p.job)?;
                            self.spe
                                .with_ls(at, count, |items: &[TriRecord]| bins.add(items))?;
                            let k = self.rates;
                            self.spe.compute_items(k.spe_bin_item, count as u64);
                            self.sah_choose(&p.job, &bins, cand)
                        }
                    };
                    let (l, r) = self
                        .spe
                        .with_ls_mut(at, count, |items: &mut [TriRecord]| partition(items, s))?;
                    self.spe.compute_items(rate, count as u64);
                    sides.push((l, r, s, cand));
                }
            }
            match &self.run_list(batch)[..] {
                [one] => self.spe.put(ls, one.ea, one.size, tag).await?,
                list => self.spe.putl(ls, list, tag).await?,
            }
            self.batch_put[buf] = batch.extent();
        }
        let mut sides = sides.into_iter();
        for p in batch.jobs.drain(..) {
            match p.make {
                Make::Leaf => {
                    let leaf = BihNode::leaf(p.job.first, p.job.count);
                    self.emit(&p.job, leaf).await?;
                }
                Make::Clip(clip) => self.clip_node(&p.job, clip).await?,
                Make::Split(..) | Make::Sah(_) => {
                    let (l, r, s, cand) = sides.next().expect("one partition per split job");
                    self.split_node(&p.job, s, cand, &l, &r).await?;
                }
            }
        }
        Ok(())
    }

    /// Empty bins for `job`'s binned SAH choice (they live in the local
    /// store at `self.bins`).
    fn new_bins(&self, job: &Job) -> Result<Bins, CellError> {
        let Some(bins) = self.cfg.sah_bins(job.count as usize) else {
            unreachable!("binned SAH jobs only");
        };
        debug_assert!(self.bins.is_some());
        Ok(Bins::new(&job.centers(), bins))
    }

    /// Sweeps `job`'s filled bins for the cheapest plane (charged per bin
    /// and axis); the global heuristic in `cand` where no binned plane
    /// separates in `f32`, as the host builder does.
    fn sah_choose(&mut self, job: &Job, bins: &Bins, cand: Aabb) -> (Split, Aabb) {
        let k = self.rates;
        self.spe
            .compute_items(k.spe_sah_bin, 3 * bins.per_axis() as u64);
        self.stats.items_binned += job.count as u64;
        self.stats.sah_sweeps += 1;
        let mut cand = cand;
        let s = (bins.choose_or_halve(&mut cand, &mut 0)).expect("the job's centers differ");
        (s, cand)
    }
}
