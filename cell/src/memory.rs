//! Main memory: the effective-address space the PPE allocates in. SPE
//! programs never touch it directly; they reach it by DMA through their MFC.
//! Allocation is a bump allocator (a PS3 program's arenas are freed
//! wholesale); running out is an error that says how much is in use.

use std::fmt;

use super::CellError;

/// An effective address in main memory.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    PartialOrd,
    Ord,
    Hash,
    bytemuck::Pod,
    bytemuck::Zeroable,
)]
#[repr(transparent)]
pub struct Ea(pub u64);

impl Ea {
    pub fn offset(self, bytes: u64) -> Ea {
        Ea(self.0 + bytes)
    }
}

impl fmt::Display for Ea {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ea {:#x}", self.0)
    }
}

/// Where the SPEs' local stores appear in the effective-address space (as
/// each SPE's local-store alias in the problem-state area does on a Cell),
/// far above main memory: SPE `i`'s at `LS_WINDOW_BASE + i ·
/// LS_WINDOW_STRIDE`. A DMA whose effective address falls there moves data
/// between local stores over the EIB, not through the memory interface.
pub const LS_WINDOW_BASE: u64 = 0x4000_0000_0000;
/// Effective-address span of one local-store window.
pub const LS_WINDOW_STRIDE: u64 = 0x10_0000;

impl Ea {
    /// The effective address of byte `offset` of SPE `spe`'s local store.
    pub fn of_local_store(spe: usize, offset: u32) -> Ea {
        Ea(LS_WINDOW_BASE + spe as u64 * LS_WINDOW_STRIDE + offset as u64)
    }

    /// The SPE and local-store offset this address names, if it lies in a
    /// local-store window.
    pub fn local_store(self) -> Option<(usize, u32)> {
        let off = self.0.checked_sub(LS_WINDOW_BASE)?;
        let spe = off / LS_WINDOW_STRIDE;
        (spe < 64).then_some((spe as usize, (off % LS_WINDOW_STRIDE) as u32))
    }
}

/// The first address handed out: the page at 0 stays unmapped, so that a
/// zero effective address is always an error.
const BASE: u64 = 0x1000;

pub struct MainMemory {
    bytes: Vec<u8>,
    capacity: u64,
    high_water: u64,
    /// Every allocation in order: its name and size (what a footprint by
    /// purpose is made of).
    log: Vec<Allocation>,
}

/// What a program calls a buffer of main memory, and the group it files
/// it under: an opaque label the emulator only carries into its report (a
/// program groups its buffers by what they are for, and reports add them
/// up by group). A plain name is in no group (`""`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Label {
    pub group: &'static str,
    pub name: String,
}

impl Label {
    pub fn new(group: &'static str, name: impl Into<String>) -> Self {
        Label {
            group,
            name: name.into(),
        }
    }
}

impl From<&str> for Label {
    fn from(name: &str) -> Self {
        Label::new("", name)
    }
}

/// One allocation of main memory: the name its program gave it, the group
/// it filed it under, its size, and the alignment padding before it.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Allocation {
    pub what: String,
    pub group: &'static str,
    pub bytes: u64,
    pub padding: u64,
}

impl MainMemory {
    pub fn new(capacity: u64) -> Self {
        MainMemory {
            bytes: Vec::new(),
            capacity,
            high_water: 0,
            log: Vec::new(),
        }
    }

    /// Allocates `size` bytes aligned to `align` (a power of two), zeroed;
    /// `what` names the buffer in the error when memory is full.
    pub fn alloc(
        &mut self,
        what: impl Into<Label>,
        size: u64,
        align: u64,
    ) -> Result<Ea, CellError> {
        let Label { group, name: what } = what.into();
        assert!(
            align.is_power_of_two(),
            "alignment {align} is not a power of two"
        );
        let start = (BASE + self.bytes.len() as u64).next_multiple_of(align);
        let end = start + size;
        if end - BASE > self.capacity {
            let mut by_size: Vec<&Allocation> = self.log.iter().collect();
            by_size.sort_by_key(|a| std::cmp::Reverse(a.bytes));
            let largest: Vec<String> = (by_size.iter().take(3))
                .map(|a| format!("{} {} bytes", a.what, a.bytes))
                .collect();
            return Err(CellError::OutOfMemory {
                what,
                asked: size,
                in_use: self.bytes.len() as u64,
                capacity: self.capacity,
                largest: if largest.is_empty() {
                    "nothing yet".into()
                } else {
                    largest.join(", ")
                },
            });
        }
        let padding = start - (BASE + self.bytes.len() as u64);
        // Exactly what is asked: doubling a buffer of gigabytes would ask
        // the host for twice the emulated memory.
        let grow = (end - BASE) as usize - self.bytes.len();
        self.bytes.reserve_exact(grow);
        self.bytes.resize((end - BASE) as usize, 0);
        self.high_water = self.high_water.max(end - BASE);
        self.log.push(Allocation {
            what,
            group,
            bytes: size,
            padding,
        });
        Ok(Ea(start))
    }

    /// Every allocation so far, in order.
    pub fn allocations(&self) -> &[Allocation] {
        &self.log
    }

    /// Bytes allocated so far.
    pub fn in_use(&self) -> u64 {
        self.bytes.len() as u64
    }

    pub fn capacity(&self) -> u64 {
        self.capacity
    }

    fn range(&self, ea: Ea, len: u64) -> Result<std::ops::Range<usize>, CellError> {
        let end = ea.0.checked_add(len);
        match end {
            Some(end) if ea.0 >= BASE && end <= BASE + self.bytes.len() as u64 => {
                Ok((ea.0 - BASE) as usize..(end - BASE) as usize)
            }
            _ => Err(CellError::BadAddress {
                ea,
                len,
                allocated_end: Ea(BASE + self.bytes.len() as u64),
            }),
        }
    }

    pub fn read(&self, ea: Ea, len: u64) -> Result<&[u8], CellError> {
        let r = self.range(ea, len)?;
        Ok(&self.bytes[r])
    }

    pub fn write(&mut self, ea: Ea, data: &[u8]) -> Result<(), CellError> {
        let r = self.range(ea, data.len() as u64)?;
        self.bytes[r].copy_from_slice(data);
        Ok(())
    }

    /// Typed copy of `count` values at `ea` (any alignment).
    pub fn read_pod<T: bytemuck::Pod>(&self, ea: Ea, count: usize) -> Result<Vec<T>, CellError> {
        let bytes = self.read(ea, (count * std::mem::size_of::<T>()) as u64)?;
        Ok(bytemuck::pod_collect_to_vec(bytes))
    }

    pub fn write_pod<T: bytemuck::Pod>(&mut self, ea: Ea, values: &[T]) -> Result<(), CellError> {
        self.write(ea, bytemuck::cast_slice(values))
    }

    /// Allocates room for `values` (the buffer `what`) and copies them in.
    pub fn alloc_pod<T: bytemuck::Pod>(
        &mut self,
        what: impl Into<Label>,
        values: &[T],
        align: u64,
    ) -> Result<Ea, CellError> {
        let ea = self.alloc(what, std::mem::size_of_val(values) as u64, align)?;
        self.write_pod(ea, values)?;
        Ok(ea)
    }
}
