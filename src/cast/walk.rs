//! The state a walk of the SPE caster resumes from (section 5's ray
//! casting on the SPEs): where a ray's traversal stopped ([`Step`]), where
//! a walk — one ray's or a packet's — goes on ([`At`]), and the bytes it
//! reads through the software cache ([`Read`]). The one-ray walk
//! (`program`) and the packet walk (`packet`) both stand on it.

use super::Job;
use crate::bih::{BihNode, Hit};
use crate::cell::{CellError, Ea, Spe};
use crate::spe::layout::TriRecord;
use crate::spe::software_cache::{LINE, Lookup, SoftwareCache};

/// What a walk works with while it runs: its SPE, the SPE's software
/// cache, the job, and the cache's tag group its misses are fetched by.
pub(super) struct Reach<'a> {
    pub spe: &'a Spe,
    pub cache: &'a mut SoftwareCache,
    pub job: &'a Job,
    pub group: u32,
}

/// Where a ray's traversal stopped.
pub(super) enum Step {
    /// Its closest hit.
    Done(Option<Hit>),
    /// Waiting for a line that tag group `.0` brings.
    Wait(u32),
    /// Its line's set is full of lines in use.
    Full,
}

/// Where a walk (a [`Walk`], or a packet's) resumes.
#[derive(Clone, Copy)]
pub(super) enum At {
    Setup,
    Node,
    NodeRead,
    Leaf { k: u32, end: u32 },
    IdRead { k: u32, end: u32 },
    RecordRead { k: u32, end: u32 },
}

impl At {
    /// The first triangle of leaf `nd`.
    pub(super) fn leaf(nd: &BihNode) -> At {
        let (first, count) = nd.leaf_range();
        At::Leaf {
            k: first,
            end: first + count,
        }
    }
}

/// Where a walk in a leaf goes next ([`Read::in_leaf`]).
pub(super) enum InLeaf {
    /// The leaf's triangles are done: pop the next node.
    Ended,
    /// A line is on its way, or its set is full.
    Stopped(Step),
    /// A read started: go on there.
    Goes(At),
    /// Triangle `k` of the leaf's `..end`: its record, read.
    Record { rec: TriRecord, k: u32, end: u32 },
}

/// What a walk at `At::NodeRead` does next.
pub(super) enum InNode {
    /// A line is on its way, or its set is full.
    Stopped(Step),
    /// The node is a leaf: its first triangle.
    Leaf(At),
    /// The inner node, read.
    Inner(BihNode),
}

/// The bytes a walk reads: a node or a triangle record, line by line.
pub(super) struct Read {
    ea: u64,
    len: usize,
    done: usize,
    /// The slot whose line it waits for.
    waiting: Option<u32>,
    pub(super) buf: [u8; size_of::<TriRecord>()],
}

impl Read {
    /// Starts the read of node `id`; the walk goes on there.
    pub(super) fn node_at(&mut self, job: &Job, id: u32) -> At {
        let size = size_of::<BihNode>();
        self.start(job.nodes.offset(id as u64 * size as u64), size);
        At::NodeRead
    }

    /// The node under way: read on, and step into it if it is a leaf.
    pub(super) async fn in_node(&mut self, on: &mut Reach<'_>) -> Result<InNode, CellError> {
        if let Some(stop) = self.fetch(on).await? {
            return Ok(InNode::Stopped(stop));
        }
        let nd: BihNode = bytemuck::pod_read_unaligned(&self.buf[..size_of::<BihNode>()]);
        Ok(match nd.is_leaf() {
            true => InNode::Leaf(At::leaf(&nd)),
            false => InNode::Inner(nd),
        })
    }

    /// Starts the read of triangle `k` of a leaf's `..end`: its id first
    /// where the records lie in the scene's order, else its record.
    pub(super) fn triangle_at(&mut self, job: &Job, k: u32, end: u32) -> At {
        if let Some(ids) = job.ids {
            self.start(ids.offset(4 * k as u64), 4);
            return At::IdRead { k, end };
        }
        self.record_at(job, k, k, end)
    }

    /// Starts the read of the record the id just read names.
    pub(super) fn record_of_id(&mut self, job: &Job, k: u32, end: u32) -> At {
        let id = u32::from_le_bytes(self.buf[..4].try_into().expect("4 bytes"));
        self.record_at(job, id, k, end)
    }

    /// Starts the read of record `place` for triangle `k` of `..end`.
    fn record_at(&mut self, job: &Job, place: u32, k: u32, end: u32) -> At {
        let size = size_of::<TriRecord>();
        self.start(job.records.offset(place as u64 * size as u64), size);
        At::RecordRead { k, end }
    }

    /// The record just read.
    pub(super) fn record(&self) -> TriRecord {
        bytemuck::pod_read_unaligned(&self.buf)
    }

    pub(super) fn new() -> Self {
        Read {
            ea: 0,
            len: 0,
            done: 0,
            waiting: None,
            buf: [0; size_of::<TriRecord>()],
        }
    }

    /// Starts a read of `len` bytes at `at`.
    pub(super) fn start(&mut self, at: Ea, len: usize) {
        (self.ea, self.len, self.done) = (at.0, len, 0);
    }

    /// Reads the bytes through the cache, line by line; a line on its way
    /// stops it (`Some`), to resume at that line.
    pub(super) async fn fetch(&mut self, on: &mut Reach<'_>) -> Result<Option<Step>, CellError> {
        let (rd, spe, group) = (self, on.spe, on.group);
        let cache = &mut *on.cache;
        while rd.done < rd.len {
            let at = rd.ea + rd.done as u64;
            let n = ((LINE - at % LINE) as usize).min(rd.len - rd.done);
            let slot = match rd.waiting.take() {
                Some(slot) => {
                    cache.unpin(slot);
                    slot
                }
                None => match cache.lookup(spe, at / LINE, group).await? {
                    Lookup::Ready(slot) => slot,
                    Lookup::Fetching { slot, tag } => {
                        cache.pin(slot);
                        rd.waiting = Some(slot);
                        return Ok(Some(Step::Wait(tag)));
                    }
                    Lookup::Full => return Ok(Some(Step::Full)),
                },
            };
            cache.copy(spe, slot, at, &mut rd.buf[rd.done..rd.done + n])?;
            rd.done += n;
        }
        Ok(None)
    }
}

impl Read {
    /// A walk at `at`, in a leaf (`At::Leaf`, `IdRead` or `RecordRead`):
    /// starts the next read, goes on with the one under way, or hands over
    /// the record read. The one-ray walk and the packet walk both step
    /// through their leaves by it.
    pub(super) async fn in_leaf(
        &mut self,
        at: At,
        on: &mut Reach<'_>,
    ) -> Result<InLeaf, CellError> {
        let job = on.job;
        Ok(match at {
            At::Leaf { k, end } if k == end => InLeaf::Ended,
            At::Leaf { k, end } => InLeaf::Goes(self.triangle_at(job, k, end)),
            At::IdRead { k, end } => match self.fetch(on).await? {
                Some(stop) => InLeaf::Stopped(stop),
                None => InLeaf::Goes(self.record_of_id(job, k, end)),
            },
            At::RecordRead { k, end } => match self.fetch(on).await? {
                Some(stop) => InLeaf::Stopped(stop),
                None => InLeaf::Record {
                    rec: self.record(),
                    k,
                    end,
                },
            },
            At::Setup | At::Node | At::NodeRead => unreachable!("a walk in a leaf"),
        })
    }
}
