//! The local store: 256 KiB per SPE holding the program's code, stack and
//! data together. A program allocates its buffers here (after the room
//! reserved for code and stack); running out is an error that says what was
//! asked and what is in use, never a resize.

use std::fmt;

use super::CellError;

/// An address in one SPE's local store.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct LsAddr(pub u32);

impl LsAddr {
    pub fn offset(self, bytes: u32) -> LsAddr {
        LsAddr(self.0 + bytes)
    }
}

impl fmt::Display for LsAddr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ls {:#07x}", self.0)
    }
}

pub struct LocalStore {
    /// `u128` words keep the store 16-byte aligned on the host, so typed
    /// views of 16-byte aligned buffers are plain casts.
    words: Vec<u128>,
    size: u32,
    /// The words are out on loan to a `with_ls` closure.
    lent: bool,
    reserved: u32,
    next: u32,
    pub(crate) high_water: u32,
}

impl LocalStore {
    pub fn new(size: u32, reserved: u32) -> Self {
        assert!(size.is_multiple_of(16) && reserved <= size);
        LocalStore {
            words: vec![0; size as usize / 16],
            size,
            lent: false,
            reserved,
            next: reserved,
            high_water: reserved,
        }
    }

    pub fn size(&self) -> u32 {
        self.size
    }

    /// Lends the store's words to a closure that runs outside the
    /// machine's borrow (so that it may call the SPE's other methods); a
    /// second loan before [`LocalStore::give_back`] is an error.
    pub(crate) fn lend(&mut self, spe: usize) -> Result<Vec<u128>, CellError> {
        if self.lent {
            return Err(CellError::Program {
                core: format!("SPE {spe}"),
                msg: "with_ls / with_ls_mut / ls_read / ls_write called inside a with_ls \
                      closure: the local store is already lent to it (copy out what you \
                      need first)"
                    .into(),
            });
        }
        self.lent = true;
        Ok(std::mem::take(&mut self.words))
    }

    pub(crate) fn give_back(&mut self, words: Vec<u128>) {
        debug_assert!(self.lent);
        self.words = words;
        self.lent = false;
    }

    pub fn bytes(&self) -> &[u8] {
        bytemuck::cast_slice(&self.words)
    }

    pub fn bytes_mut(&mut self) -> &mut [u8] {
        bytemuck::cast_slice_mut(&mut self.words)
    }

    /// Allocates `size` bytes aligned to `align` (a power of two, at most
    /// 128; DMA wants 16, and 128 is best).
    pub fn alloc(&mut self, spe: usize, size: u32, align: u32) -> Result<LsAddr, CellError> {
        assert!(align.is_power_of_two() && align <= 128);
        let start = self.next.next_multiple_of(align);
        let end = start as u64 + size as u64;
        if end > self.size() as u64 {
            return Err(CellError::LocalStoreFull {
                spe,
                asked: size,
                align,
                in_use: self.next,
                reserved: self.reserved,
                capacity: self.size(),
            });
        }
        self.next = end as u32;
        self.high_water = self.high_water.max(self.next);
        Ok(LsAddr(start))
    }

    /// Frees every buffer allocated since `mark` (an address `alloc` gave,
    /// or [`LocalStore::mark`]).
    pub fn release_to(&mut self, mark: u32) {
        assert!(mark >= self.reserved && mark <= self.next);
        self.next = mark;
    }

    pub fn mark(&self) -> u32 {
        self.next
    }

    /// The byte range `[addr, addr + len)`, or an error naming it.
    pub(crate) fn check_range(
        &self,
        spe: usize,
        addr: LsAddr,
        len: u64,
    ) -> Result<std::ops::Range<usize>, CellError> {
        let end = addr.0 as u64 + len;
        if end > self.size() as u64 {
            return Err(CellError::LocalStoreRange {
                spe,
                addr,
                len,
                size: self.size(),
            });
        }
        Ok(addr.0 as usize..end as usize)
    }
}
