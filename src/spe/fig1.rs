//! The SPE's in-place streaming partition of the paper's Fig. 1 (section 2).
//!
//! One SPE partitions an interval of main memory in place, writing every
//! element straight to its final side so that nothing is recombined later.
//! An interval that fits one 16 KiB DMA is loaded, partitioned and written
//! back whole. A larger one streams through five local-store buffers:
//!
//! 1. buffers A and C load blocks from the end of the interval, B and D from
//!    its beginning;
//! 2. the elements in D are partitioned;
//! 3. D and OUT swap: OUT is written back, its left-side elements to the
//!    beginning of the interval and its right-side elements to the end;
//! 4. the buffers rotate (D ← C, C ← B, B ← A) and A, the former OUT, takes
//!    the next block — from the beginning or the end, whichever has less
//!    room between what was read and what was written, so that no element
//!    is overwritten before it is in the local store.
//!
//! Every write is checked against that invariant: a violation is an error,
//! never silent corruption. A put that would land on bytes a get is still
//! reading first waits for that get (real code would fence it).

use bytemuck::Pod;

use crate::cell::{CellError, Cycles, Ea, LsAddr, Spe};
use crate::kernels::split::{Boxed, Side, Split, partition, side_of};

/// Bytes of one streaming block: the largest single DMA.
pub const BLOCK_BYTES: u32 = 16 * 1024;

/// The five buffers of Fig. 1, allocated once per SPE program.
pub struct Fig1Buffers {
    bufs: [LsAddr; 5],
    /// The first of the five buffers' tag groups.
    tags: u32,
}

impl Fig1Buffers {
    pub fn alloc(spe: &Spe) -> Result<Self, CellError> {
        let mut bufs = [LsAddr(0); 5];
        for b in &mut bufs {
            *b = spe.ls_alloc(BLOCK_BYTES, 128)?;
        }
        let tags = spe.tags("Fig. 1 buffers A-D, OUT", 5)?;
        Ok(Fig1Buffers { bufs, tags })
    }

    /// Buffer `i` (0..5; A, B, C, D, OUT at the start), for programs that
    /// use the buffers between partitions.
    pub fn buffer(&self, i: usize) -> LsAddr {
        self.bufs[i]
    }

    /// The tag group of buffer `i`.
    pub fn tag(&self, i: usize) -> u32 {
        self.tags + i as u32
    }
}

/// A block in a buffer: where it came from and how many elements it holds.
#[derive(Clone, Copy, Default)]
struct Block {
    /// Physical buffer 0..5 (its tag group: `Fig1Buffers::tag`).
    buf: usize,
    from: u64,
    len: u64,
}

/// Where the partition of an interval ended: `left` elements moved to its
/// beginning, the rest after them, and what each side holds.
pub struct Partitioned {
    pub left: Side,
    pub right: Side,
}

/// Partitions the `n` elements of type `T` at `ea` in place around `split`,
/// on SPE `spe`, charging `cycles_per_element` of compute per element.
pub async fn partition_in_place<T: Boxed + Pod>(
    spe: &Spe,
    bufs: &Fig1Buffers,
    ea: Ea,
    n: u64,
    split: Split,
    cycles_per_element: Cycles,
) -> Result<Partitioned, CellError> {
    let size = size_of::<T>() as u64;
    assert!(
        size.is_multiple_of(16),
        "elements must be a multiple of 16 bytes to travel by DMA"
    );
    let per_block = BLOCK_BYTES as u64 / size;
    let addr = |i: u64| ea.offset(i * size);
    let charge = |count: u64| spe.compute_items(cycles_per_element, count);

    if n <= per_block {
        // Small interval: load, partition, write back where it was.
        let b = bufs.bufs[0];
        if n == 0 {
            return Ok(Partitioned {
                left: Side::EMPTY,
                right: Side::EMPTY,
            });
        }
        spe.get(b, ea, (n * size) as u32, bufs.tag(0)).await?;
        spe.wait_tag(bufs.tag(0)).await?;
        let (left, right) =
            spe.with_ls_mut(b, n as usize, |items: &mut [T]| partition(items, split))?;
        charge(n);
        spe.put(b, ea, (n * size) as u32, bufs.tag(0)).await?;
        spe.wait_tag(bufs.tag(0)).await?;
        return Ok(Partitioned { left, right });
    }

    // Read pointers (next unread from the left, end of unread at the right)
    // and write pointers (next free slot at the left, end of free at the right).
    let (mut read_l, mut read_r) = (0u64, n);
    let (mut write_l, mut write_r) = (0u64, n);
    let load = async |buf: usize,
                      from_end: bool,
                      read_l: &mut u64,
                      read_r: &mut u64|
           -> Result<Block, CellError> {
        let len = per_block.min(*read_r - *read_l);
        let from = if from_end { *read_r - len } else { *read_l };
        if from_end {
            *read_r -= len
        } else {
            *read_l += len
        }
        if len > 0 {
            spe.get(
                bufs.bufs[buf],
                addr(from),
                (len * size) as u32,
                bufs.tag(buf),
            )
            .await?;
        }
        Ok(Block { buf, from, len })
    };
    // Step 1: A and C from the end, B and D from the beginning; D first.
    let d = load(3, false, &mut read_l, &mut read_r).await?;
    let c = load(2, true, &mut read_l, &mut read_r).await?;
    let b = load(1, false, &mut read_l, &mut read_r).await?;
    let a = load(0, true, &mut read_l, &mut read_r).await?;
    let (mut a, mut b, mut c, mut d) = (a, b, c, d);
    let mut out = Block {
        buf: 4,
        from: 0,
        len: 0,
    };
    let (mut left, mut right) = (Side::EMPTY, Side::EMPTY);

    while d.len > 0 {
        // Step 2: partition D.
        spe.wait_tag(bufs.tag(d.buf)).await?;
        let (l, r) = spe.with_ls_mut(bufs.bufs[d.buf], d.len as usize, |items: &mut [T]| {
            partition(items, split)
        })?;
        charge(d.len);
        left = left.merge(l);
        right = right.merge(r);
        // Step 3: D becomes OUT; its left part goes to the beginning of the
        // interval, its right part to the end.
        let (k, m) = (l.count as u64, r.count as u64);
        let unread = read_l < read_r;
        if unread && (write_l + k > read_l || write_r - m < read_r) {
            return Err(CellError::Program {
                core: format!("SPE {}", spe.id()),
                msg: format!(
                    "Fig. 1 partition would overwrite unread elements (read {read_l}..{read_r}, write {write_l}..{write_r}, block {k}+{m})"
                ),
            });
        }
        let ls_out = bufs.bufs[d.buf];
        for (dst, from_ls, count) in [(write_l, 0u64, k), (write_r - m, k, m)] {
            if count == 0 {
                continue;
            }
            wait_for_overlapping_gets(spe, bufs, &[a, b, c], dst, count).await?;
            spe.put(
                ls_out.offset((from_ls * size) as u32),
                addr(dst),
                (count * size) as u32,
                bufs.tag(d.buf),
            )
            .await?;
        }
        write_l += k;
        write_r -= m;
        // Step 4: rotate; A, the former OUT, takes the next block once its
        // own write-back is done, from the side with less room.
        spe.wait_tag(bufs.tag(out.buf)).await?;
        let next_buf = out.buf;
        out = d;
        (d, c, b) = (c, b, a);
        // (Once everything is read the write pointers pass the read ones
        // and nothing more is loaded: the choice no longer matters.)
        let from_end = write_r.saturating_sub(read_r) < read_l.saturating_sub(write_l);
        a = load(next_buf, from_end, &mut read_l, &mut read_r).await?;
        // Blocks that loaded nothing move to the back of the queue.
        if d.len == 0 && (c.len > 0 || b.len > 0 || a.len > 0) {
            let mut q = [c, b, a, d];
            q.sort_by_key(|x| x.len == 0);
            [d, c, b, a] = q;
        }
    }
    spe.wait_tag(bufs.tag(out.buf)).await?;
    debug_assert_eq!(write_l, write_r);
    debug_assert_eq!(left.count as u64, write_l);
    Ok(Partitioned { left, right })
}

/// Waits for any in-flight get whose source overlaps `dst..dst+count`.
async fn wait_for_overlapping_gets(
    spe: &Spe,
    bufs: &Fig1Buffers,
    blocks: &[Block],
    dst: u64,
    count: u64,
) -> Result<(), CellError> {
    for b in blocks {
        if b.len > 0 && b.from < dst + count && dst < b.from + b.len {
            spe.wait_tag(bufs.tag(b.buf)).await?;
        }
    }
    Ok(())
}

/// Streams the `n` elements at `ea` through two buffers and returns their
/// bounds (as a [`Side`]): the pass that gives the root's bounds of centers.
pub async fn stream_bounds<T: Boxed + Pod>(
    spe: &Spe,
    bufs: &Fig1Buffers,
    ea: Ea,
    n: u64,
    cycles_per_element: Cycles,
) -> Result<Side, CellError> {
    let merge = |side: &mut Side, items: &[T]| *side = side.merge(side_of(items));
    stream_fold(spe, bufs, ea, n, cycles_per_element, Side::EMPTY, merge).await
}

/// Streams the `n` records at `ea` through two of Fig. 1's buffers (the
/// next block's get issued before this one is looked at), folding each
/// block into `acc` with `fold` at `cycles_per_element`: the one read-only
/// pass [`stream_bounds`] and the binned SAH's binning make.
pub async fn stream_fold<T: Pod, A>(
    spe: &Spe,
    bufs: &Fig1Buffers,
    ea: Ea,
    n: u64,
    cycles_per_element: Cycles,
    mut acc: A,
    mut fold: impl FnMut(&mut A, &[T]),
) -> Result<A, CellError> {
    let size = size_of::<T>() as u64;
    let per_block = BLOCK_BYTES as u64 / size;
    let blocks = n.div_ceil(per_block);
    let len = |k: u64| per_block.min(n - k * per_block);
    if blocks == 0 {
        return Ok(acc);
    }
    spe.get(bufs.bufs[0], ea, (len(0) * size) as u32, bufs.tag(0))
        .await?;
    for k in 0..blocks {
        let b = (k % 2) as usize;
        if k + 1 < blocks {
            let next = ea.offset((k + 1) * per_block * size);
            spe.get(
                bufs.bufs[1 - b],
                next,
                (len(k + 1) * size) as u32,
                bufs.tag(1 - b),
            )
            .await?;
        }
        spe.wait_tag(bufs.tag(b)).await?;
        spe.with_ls(bufs.bufs[b], len(k) as usize, |items: &[T]| {
            fold(&mut acc, items)
        })?;
        spe.compute_items(cycles_per_element, len(k));
    }
    Ok(acc)
}
