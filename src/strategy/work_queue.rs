//! The two-phase job queue of Fig. 2 (section 2): the jobs of the tree
//! level being built are read from `WorkA`, the jobs of the next level are
//! collected in `WorkB`, two 16 KiB local-store buffers. A full `WorkB` is
//! written to main memory (`WorkBPPE`), synchronously as in the paper; when
//! a level spilled, the next one reads its jobs back block by block, and
//! `WorkAPPE` and `WorkBPPE` swap roles. While a whole level fits in `WorkB`
//! — the first levels — nothing travels: the local-store buffers swap.

use std::marker::PhantomData;

use bytemuck::Pod;

use crate::cell::{CellError, Ea, LsAddr, Spe};

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

/// One SPE's `WorkA`/`WorkB` with their spill areas `WorkAPPE`/`WorkBPPE`,
/// for jobs of type `J`.
pub struct WorkQueue<'a, J> {
    spe: &'a Spe,
    /// `WorkA` is `work[a]`, `WorkB` is `work[1 - a]`.
    work: [LsAddr; 2],
    a: usize,
    /// `WorkAPPE` is `work_ppe[a_ppe]`, `WorkBPPE` the other.
    work_ppe: [Ea; 2],
    a_ppe: usize,
    /// Jobs in `WorkB` now, and blocks of it written to `WorkBPPE` this level.
    b_len: usize,
    b_spilled: usize,
    tag: u32,
    _job: PhantomData<J>,
}

impl<'a, J: Pod> WorkQueue<'a, J> {
    /// Jobs per buffer.
    pub const PER_BUFFER: usize = WORK_BYTES as usize / size_of::<J>();

    /// Bytes of main memory `WorkAPPE` (and `WorkBPPE`) need for levels of
    /// up to `jobs` jobs.
    pub fn spill_bytes(jobs: usize) -> u64 {
        (jobs.div_ceil(Self::PER_BUFFER) * WORK_BYTES as usize) as u64
    }

    /// Allocates `WorkA` and `WorkB` in `spe`'s local store; `work_ppe` are
    /// `WorkAPPE` and `WorkBPPE` in main memory.
    pub fn new(spe: &'a Spe, work_ppe: [Ea; 2]) -> Result<Self, CellError> {
        Ok(WorkQueue {
            spe,
            work: [
                spe.ls_alloc(WORK_BYTES, 128)?,
                spe.ls_alloc(WORK_BYTES, 128)?,
            ],
            a: 0,
            work_ppe,
            a_ppe: 0,
            b_len: 0,
            b_spilled: 0,
            tag: spe.tag("WorkA/WorkB")?,
            _job: PhantomData,
        })
    }

    /// The first level: `root` alone, in `WorkA`.
    pub fn start(&mut self, root: J) -> Result<Level, CellError> {
        self.spe.ls_write(self.work[self.a], &[root])?;
        Ok(Level::Local(1))
    }

    /// Points `WorkAPPE`/`WorkBPPE` at other areas (between levels).
    pub fn set_spill(&mut self, work_ppe: [Ea; 2]) {
        self.work_ppe = work_ppe;
        self.a_ppe = 0;
    }

    /// A level of `jobs` (at most [`Self::PER_BUFFER`]) in `WorkA`, in place
    /// of the one there (between levels).
    pub fn restart_local(&mut self, jobs: &[J]) -> Result<Level, CellError> {
        debug_assert!(jobs.len() <= Self::PER_BUFFER && self.b_len == 0);
        self.spe.ls_write(self.work[self.a], jobs)?;
        Ok(Level::Local(jobs.len()))
    }

    /// Writes `jobs` (at most [`Self::PER_BUFFER`]) to main memory at `ea`
    /// through `WorkB` (between levels, when `WorkB` is empty) and waits.
    pub async fn write_jobs(&mut self, jobs: &[J], ea: Ea) -> Result<(), CellError> {
        debug_assert!(jobs.len() <= Self::PER_BUFFER && self.b_len == 0);
        let b = self.work[1 - self.a];
        self.spe.ls_write(b, jobs)?;
        let bytes = size_of_val(jobs) as u32;
        self.spe.put(b, ea, bytes, self.tag).await?;
        self.spe.wait_tag(self.tag).await
    }

    /// Blocks of at most [`Self::PER_BUFFER`] jobs the level is read in.
    pub fn blocks(level: Level) -> usize {
        match level {
            Level::Local(_) => 1,
            Level::InMemory(total) => total.div_ceil(Self::PER_BUFFER),
        }
    }

    /// The jobs of block `k` of `level`, read into `WorkA` (from `WorkAPPE`
    /// if the level spilled).
    pub async fn load(&mut self, level: Level, k: usize) -> Result<Vec<J>, CellError> {
        let len = match level {
            Level::Local(len) => len,
            Level::InMemory(total) => {
                let len = Self::PER_BUFFER.min(total - k * Self::PER_BUFFER);
                let from = self.work_ppe[self.a_ppe].offset((k * WORK_BYTES as usize) as u64);
                let bytes = (len * size_of::<J>()) as u32;
                self.spe
                    .get(self.work[self.a], from, bytes, self.tag)
                    .await?;
                self.spe.wait_tag(self.tag).await?;
                len
            }
        };
        self.spe.ls_read(self.work[self.a], len)
    }

    /// Appends a job of the next level to `WorkB`, writing `WorkB` to
    /// `WorkBPPE` when full.
    pub async fn push(&mut self, job: J) -> Result<(), CellError> {
        let at = self.work[1 - self.a].offset((self.b_len * size_of::<J>()) as u32);
        self.spe.ls_write(at, &[job])?;
        self.b_len += 1;
        if self.b_len == Self::PER_BUFFER {
            self.spill().await?;
        }
        Ok(())
    }

    /// The level is done: the next one is what `WorkB` collected (`None`
    /// when it is empty). Buffers swap roles.
    pub async fn end_level(&mut self) -> Result<Option<Level>, CellError> {
        let next = self.b_spilled * Self::PER_BUFFER + self.b_len;
        if next == 0 {
            return Ok(None);
        }
        let level = if self.b_spilled == 0 {
            // The first levels: the jobs stay in the local store.
            Level::Local(next)
        } else {
            if self.b_len > 0 {
                self.spill().await?;
            }
            self.a_ppe = 1 - self.a_ppe;
            Level::InMemory(next)
        };
        self.a = 1 - self.a;
        self.b_len = 0;
        self.b_spilled = 0;
        Ok(Some(level))
    }

    /// Writes `WorkB` to the next block of `WorkBPPE` and waits (the paper's
    /// write-back is synchronous).
    async fn spill(&mut self) -> Result<(), CellError> {
        let to =
            self.work_ppe[1 - self.a_ppe].offset((self.b_spilled * WORK_BYTES as usize) as u64);
        let bytes = (self.b_len * size_of::<J>()) as u32;
        self.spe
            .put(self.work[1 - self.a], to, bytes, self.tag)
            .await?;
        self.spe.wait_tag(self.tag).await?;
        self.b_spilled += 1;
        self.b_len = 0;
        Ok(())
    }
}
