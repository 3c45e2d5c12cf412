//! The two-phase job queue of Fig. 2 (section 2): the jobs of the tree
//! level being built are read from `WorkA`, the jobs of the next level are
//! collected in `WorkB`, two 16 KiB local-store buffers. A full `WorkB` is
//! written to main memory (`WorkBPPE`), synchronously as in the paper; when
//! a level spilled, the next one reads its jobs back block by block, and
//! `WorkAPPE` and `WorkBPPE` swap roles. While a whole level fits in `WorkB`
//! — the first levels — nothing travels: the local-store buffers swap.
//!
//! Section 5's improvement, a knob (`double`): a second `WorkB`, so that a
//! full one is written back while the other fills (no synchronous spill),
//! and a second `WorkA`, into which the next block of a spilled level is
//! read while the current one is built. Off, the queue is the paper's.
//!
//! For a queue shared by several SPEs (`spe_bfs_shared`), `WorkB` spills
//! to places reserved by fetch-and-add in one next-level array
//! ([`WorkQueue::share`]).

use std::marker::PhantomData;

use bytemuck::Pod;

use crate::cell::{CellError, Ea, LsAddr, Spe, WaitMode};

/// Bytes of `WorkA` and of `WorkB`: one 16 KiB transfer.
pub const WORK_BYTES: u32 = 16 * 1024;

/// Where the jobs of the level being built are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// All in `WorkA` in the local store, this many.
    Local(usize),
    /// In `WorkAPPE`, this many.
    InMemory(usize),
}

/// Where a shared queue's `WorkB` goes: the next level's job array, at
/// places reserved by fetch-and-add on the `u32` counter at `counter`
/// (through the 128-byte local-store line `line`).
#[derive(Clone, Copy, Debug)]
pub struct SharedSpill {
    pub to: Ea,
    /// Jobs the array at `to` holds.
    pub capacity: u32,
    pub counter: Ea,
    pub line: LsAddr,
}

/// `jobs` as they travel: the first `stride` bytes of each (a job type may
/// hold fields that travel only with some settings).
pub fn to_wire<J: Pod>(jobs: &[J], stride: usize) -> Vec<u8> {
    debug_assert!(stride <= size_of::<J>() && stride.is_multiple_of(16));
    let mut v = Vec::with_capacity(jobs.len() * stride);
    for j in jobs {
        v.extend_from_slice(&bytemuck::bytes_of(j)[..stride]);
    }
    v
}

/// Jobs from their first `stride` bytes each (the rest zero).
pub fn from_wire<J: Pod>(bytes: &[u8], stride: usize) -> Vec<J> {
    (bytes.chunks_exact(stride))
        .map(|c| {
            let mut j = J::zeroed();
            bytemuck::bytes_of_mut(&mut j)[..stride].copy_from_slice(c);
            j
        })
        .collect()
}

/// `WorkAPPE` and `WorkBPPE` (Fig. 2): the two areas of main memory a
/// queue spills its levels to, and the bytes each holds (a level that
/// would spill past them is an error, not a write over the next buffer).
#[derive(Clone, Copy, Debug)]
pub struct WorkPpe {
    pub areas: [Ea; 2],
    pub bytes: u64,
}

impl WorkPpe {
    /// The two areas from `a` to `b` and from `b` on, `b - a` bytes each.
    pub fn between(a: Ea, b: Ea) -> Self {
        WorkPpe {
            areas: [a, b],
            bytes: b.0 - a.0,
        }
    }
}

/// One SPE's `WorkA`/`WorkB` with their spill areas `WorkAPPE`/`WorkBPPE`,
/// for jobs of type `J`, each `stride` bytes in the local store and in main
/// memory.
pub struct WorkQueue<'a, J> {
    spe: &'a Spe,
    stride: usize,
    /// The local-store buffers: two, or four when double-buffered.
    work: Vec<LsAddr>,
    /// `WorkA` is `work[a]`; `WorkB` is `work[b[0]]` (and `work[b[1]]`,
    /// the one being written back, when double-buffered); `work[a_next]`
    /// receives the next block of `WorkA` when double-buffered.
    a: usize,
    b: [usize; 2],
    a_next: usize,
    /// The block of the level read ahead into `work[a_next]`.
    prefetched: Option<usize>,
    /// `WorkAPPE` is `work_ppe.areas[a_ppe]`, `WorkBPPE` the other.
    work_ppe: WorkPpe,
    a_ppe: usize,
    /// Jobs in `WorkB` now, and blocks of it written to `WorkBPPE` this level.
    b_len: usize,
    b_spilled: usize,
    /// Tag groups: one per buffer.
    tags: u32,
    double: bool,
    shared: Option<SharedSpill>,
    _job: PhantomData<J>,
}

impl<'a, J: Pod> WorkQueue<'a, J> {
    /// Jobs per buffer, each `stride` bytes.
    pub fn per_buffer(stride: usize) -> usize {
        WORK_BYTES as usize / stride
    }

    /// Bytes of main memory `WorkAPPE` (and `WorkBPPE`) need for levels of
    /// up to `jobs` jobs of `stride` bytes.
    pub fn spill_bytes(jobs: usize, stride: usize) -> u64 {
        (jobs.div_ceil(Self::per_buffer(stride)) * WORK_BYTES as usize) as u64
    }

    /// Bytes `WorkAPPE` (and `WorkBPPE`) need for a subtree of `triangles`
    /// with leaves of `leaf_size`, jobs of `stride` bytes: room for the
    /// widest level it can have ([`crate::spe::footprint::work_ppe_jobs`]), not
    /// for one job per triangle as the paper sizes them.
    pub fn spill_bytes_for(triangles: usize, leaf_size: u32, stride: usize) -> u64 {
        let jobs = crate::spe::footprint::work_ppe_jobs(triangles, leaf_size);
        Self::spill_bytes(jobs, stride)
    }

    /// Allocates `WorkA` and `WorkB` in `spe`'s local store (and their
    /// second buffers if `double`) for jobs of `stride` bytes, spilling to
    /// `work_ppe` in main memory.
    pub fn new(
        spe: &'a Spe,
        work_ppe: WorkPpe,
        double: bool,
        stride: usize,
    ) -> Result<Self, CellError> {
        let buffers = if double { 4 } else { 2 };
        let work = (0..buffers)
            .map(|_| spe.ls_alloc(WORK_BYTES, 128))
            .collect::<Result<Vec<_>, _>>()?;
        let tags = if double {
            spe.tags("WorkA/WorkB", 4)?
        } else {
            spe.tag("WorkA/WorkB")?
        };
        Ok(WorkQueue {
            spe,
            stride,
            work,
            a: 0,
            b: if double { [1, 2] } else { [1, 1] },
            a_next: if double { 3 } else { 0 },
            prefetched: None,
            work_ppe,
            a_ppe: 0,
            b_len: 0,
            b_spilled: 0,
            tags,
            double,
            shared: None,
            _job: PhantomData,
        })
    }

    /// The tag group of buffer `i` (all share one when not double-buffered).
    fn tag(&self, i: usize) -> u32 {
        if self.double {
            self.tags + i as u32
        } else {
            self.tags
        }
    }

    /// Jobs per buffer.
    pub fn per(&self) -> usize {
        Self::per_buffer(self.stride)
    }

    /// Bytes of one job.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Writes `jobs` into the local store at `at`.
    fn write_ls(&self, at: LsAddr, jobs: &[J]) -> Result<(), CellError> {
        self.spe.ls_write(at, &to_wire(jobs, self.stride))
    }

    /// Reads `count` jobs from the local store at `at`.
    fn read_ls(&self, at: LsAddr, count: usize) -> Result<Vec<J>, CellError> {
        let bytes = self.spe.ls_read::<u8>(at, count * self.stride)?;
        Ok(from_wire(&bytes, self.stride))
    }

    /// The first level: `root` alone, in `WorkA`.
    pub fn start(&mut self, root: J) -> Result<Level, CellError> {
        self.write_ls(self.work[self.a], &[root])?;
        Ok(Level::Local(1))
    }

    /// Points `WorkAPPE`/`WorkBPPE` at other areas (between levels).
    pub fn set_spill(&mut self, work_ppe: WorkPpe) {
        self.work_ppe = work_ppe;
        self.a_ppe = 0;
    }

    /// From now on `WorkB` spills into a shared next-level array (`None`:
    /// into `WorkBPPE` again). Between levels.
    pub fn share(&mut self, to: Option<SharedSpill>) {
        debug_assert!(self.b_len == 0);
        self.shared = to;
    }

    /// A level of `jobs` (at most [`Self::per`]) in `WorkA`, in place
    /// of the one there (between levels).
    pub fn restart_local(&mut self, jobs: &[J]) -> Result<Level, CellError> {
        debug_assert!(jobs.len() <= self.per() && self.b_len == 0);
        self.write_ls(self.work[self.a], jobs)?;
        Ok(Level::Local(jobs.len()))
    }

    /// Writes `jobs` (at most [`Self::per`]) to main memory at `ea`
    /// through `WorkB` (between levels, when `WorkB` is empty) and waits.
    pub async fn write_jobs(&mut self, jobs: &[J], ea: Ea) -> Result<(), CellError> {
        debug_assert!(jobs.len() <= self.per() && self.b_len == 0);
        let (b, tag) = (self.work[self.b[0]], self.tag(self.b[0]));
        self.write_ls(b, jobs)?;
        let bytes = (jobs.len() * self.stride) as u32;
        self.spe.put(b, ea, bytes, tag).await?;
        self.spe.wait_tag(tag).await
    }

    /// Writes `jobs` (at most [`Self::per`]) to main memory at `ea`
    /// through `WorkA` (a shared queue's take, once its jobs are read out
    /// of it) and waits.
    pub async fn put_taken(&mut self, jobs: &[J], ea: Ea) -> Result<(), CellError> {
        debug_assert!(jobs.len() <= self.per());
        let (a, tag) = (self.work[self.a], self.tag(self.a));
        self.write_ls(a, jobs)?;
        let bytes = (jobs.len() * self.stride) as u32;
        self.spe.put(a, ea, bytes, tag).await?;
        self.spe.wait_tag(tag).await
    }

    /// `count` jobs (at most [`Self::per`]) read from main memory at
    /// `ea` into `WorkA` (a shared queue's take).
    pub async fn read_jobs(&mut self, ea: Ea, count: usize) -> Result<Vec<J>, CellError> {
        debug_assert!(count <= self.per());
        let (a, tag) = (self.work[self.a], self.tag(self.a));
        self.spe
            .get(a, ea, (count * self.stride) as u32, tag)
            .await?;
        self.spe.wait_tag(tag).await?;
        self.read_ls(a, count)
    }

    /// Blocks of at most [`Self::per`] jobs the level is read in.
    pub fn blocks(&self, level: Level) -> usize {
        match level {
            Level::Local(_) => 1,
            Level::InMemory(total) => total.div_ceil(self.per()),
        }
    }

    /// The jobs of block `k` of `level`, read into `WorkA` (from `WorkAPPE`
    /// if the level spilled; double-buffered, the next block is read ahead).
    pub async fn load(&mut self, level: Level, k: usize) -> Result<Vec<J>, CellError> {
        let len = match level {
            Level::Local(len) => len,
            Level::InMemory(total) => {
                if self.prefetched == Some(k) {
                    self.prefetched = None;
                    std::mem::swap(&mut self.a, &mut self.a_next);
                    self.spe.wait_tag(self.tag(self.a)).await?;
                } else {
                    self.get_block(total, k, self.a).await?;
                    self.spe.wait_tag(self.tag(self.a)).await?;
                }
                if self.double && k + 1 < self.blocks(level) {
                    self.get_block(total, k + 1, self.a_next).await?;
                    self.prefetched = Some(k + 1);
                }
                self.per().min(total - k * self.per())
            }
        };
        self.read_ls(self.work[self.a], len)
    }

    /// Issues the get of block `k` of a level of `total` jobs in
    /// `WorkAPPE` into buffer `buf`.
    async fn get_block(&mut self, total: usize, k: usize, buf: usize) -> Result<(), CellError> {
        let len = self.per().min(total - k * self.per());
        let from = self.work_ppe.areas[self.a_ppe].offset((k * WORK_BYTES as usize) as u64);
        let bytes = (len * self.stride) as u32;
        self.spe
            .get(self.work[buf], from, bytes, self.tag(buf))
            .await
    }

    /// Appends a job of the next level to `WorkB`, writing `WorkB` to
    /// `WorkBPPE` when full.
    pub async fn push(&mut self, job: J) -> Result<(), CellError> {
        let at = self.work[self.b[0]].offset((self.b_len * self.stride) as u32);
        self.write_ls(at, &[job])?;
        self.b_len += 1;
        if self.b_len == self.per() {
            self.spill().await?;
        }
        Ok(())
    }

    /// The level is done: the next one is what `WorkB` collected (`None`
    /// when it is empty). Buffers swap roles.
    pub async fn end_level(&mut self) -> Result<Option<Level>, CellError> {
        let next = self.b_spilled * self.per() + self.b_len;
        if next == 0 {
            return Ok(None);
        }
        let level = if self.b_spilled == 0 {
            // The first levels: the jobs stay in the local store.
            std::mem::swap(&mut self.a, &mut self.b[0]);
            Level::Local(next)
        } else {
            if self.b_len > 0 {
                self.spill().await?;
            }
            self.wait_spills().await?;
            self.a_ppe = 1 - self.a_ppe;
            if !self.double {
                // The paper's two buffers swap roles after every level.
                std::mem::swap(&mut self.a, &mut self.b[0]);
            }
            Level::InMemory(next)
        };
        if !self.double {
            self.b = [self.b[0]; 2];
        }
        self.b_len = 0;
        self.b_spilled = 0;
        Ok(Some(level))
    }

    /// A shared queue's level is done for this SPE: writes what `WorkB`
    /// holds and waits until every spill is in main memory.
    pub async fn flush_shared(&mut self) -> Result<(), CellError> {
        if self.b_len > 0 {
            self.spill().await?;
        }
        self.wait_spills().await?;
        self.b_spilled = 0;
        Ok(())
    }

    /// Double-buffered: waits for both `WorkB` write-backs (the next level
    /// reads what they wrote).
    async fn wait_spills(&mut self) -> Result<(), CellError> {
        if self.double {
            let mask = (1 << self.tag(self.b[0])) | (1 << self.tag(self.b[1]));
            self.spe.wait_tags(mask, WaitMode::All).await?;
        }
        Ok(())
    }

    /// Writes `WorkB` to the next block of `WorkBPPE` (or to its reserved
    /// place in a shared array): synchronously, as in the paper, or,
    /// double-buffered, while the other `WorkB` fills.
    async fn spill(&mut self) -> Result<(), CellError> {
        let bytes = (self.b_len * self.stride) as u32;
        let to = match self.shared {
            Some(s) => {
                let place = self
                    .spe
                    .atomic_fetch_add_u32(s.line, s.counter, self.b_len as u32)
                    .await?;
                if place as u64 + self.b_len as u64 > s.capacity as u64 {
                    return Err(CellError::Program {
                        core: format!("SPE {}", self.spe.id()),
                        msg: format!(
                            "the shared job queue's next level holds {} jobs; {} pushed",
                            s.capacity,
                            place as u64 + self.b_len as u64
                        ),
                    });
                }
                s.to.offset(place as u64 * self.stride as u64)
            }
            None => {
                let at = (self.b_spilled * WORK_BYTES as usize) as u64;
                if at + bytes as u64 > self.work_ppe.bytes {
                    return Err(CellError::Program {
                        core: format!("SPE {}", self.spe.id()),
                        msg: format!(
                            "WorkBPPE holds {} bytes; the level being built needs more",
                            self.work_ppe.bytes
                        ),
                    });
                }
                self.work_ppe.areas[1 - self.a_ppe].offset(at)
            }
        };
        let (b, tag) = (self.work[self.b[0]], self.tag(self.b[0]));
        self.spe.put(b, to, bytes, tag).await?;
        if self.double {
            // Fill the other buffer once its own write-back is done.
            self.b.swap(0, 1);
            self.spe.wait_tag(self.tag(self.b[0])).await?;
        } else {
            self.spe.wait_tag(tag).await?;
        }
        self.b_spilled += 1;
        self.b_len = 0;
        Ok(())
    }
}
