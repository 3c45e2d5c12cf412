//! The Memory Flow Controller's rules for DMA commands (CBE Programming
//! Handbook, "DMA transfers"; CELL-FACTS.md), checked when a command is
//! issued. A violation is an error that names the command, its addresses
//! and its size.
//!
//! - size 1, 2, 4 or 8 bytes, or a multiple of 16 up to 16 KiB;
//! - below 16 bytes: local and effective address naturally aligned and
//!   agreeing in their low four bits; from 16 bytes: both 16-byte aligned;
//! - tag group 0–31;
//! - a DMA list of at most 2048 elements, each element obeying the rules
//!   above, its local-store side starting 16-byte aligned: each element goes
//!   to the current local address with its low four bits taken from the
//!   element's effective address, and the address then advances by the
//!   element's size, or by 16 for elements under 16 bytes (CBE Programming
//!   Handbook, DMA-list transfers; RPCS3's MFC does the same);
//! - at most 16 commands in an SPE's queue: issuing on a full queue stalls.
//!
//! Ordering: the MFC may run the commands in its queue in any order, except
//! that a *fenced* command (`getf`, `putf`) runs after every command issued
//! before it in its tag group, and a *barrier* command (`getb`, `putb`)
//! also before every command issued after it in its tag group. The model
//! runs commands in issue order, and times fences and barriers by waiting
//! for those commands to complete; checked mode reports two commands in
//! flight that touch the same main memory (one of them a put) and are not
//! ordered so — their outcome would depend on an order the hardware does
//! not promise. Not modelled: the list stall-and-notify flag.

use super::{CellError, Ea, LsAddr};

/// Largest transfer of one command or list element.
pub const MAX_TRANSFER: u32 = 16 * 1024;
/// Entries of an SPE's MFC command queue.
pub const QUEUE_DEPTH: usize = 16;
/// Tag groups 0..32.
pub const TAG_GROUPS: u32 = 32;
/// Elements of one DMA list.
pub const MAX_LIST_ELEMENTS: usize = 2048;

/// One element of a DMA list: where in main memory, how many bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ListElement {
    pub ea: Ea,
    pub size: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Main memory → local store.
    Get,
    /// Local store → main memory.
    Put,
}

impl std::fmt::Display for Direction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Direction::Get => "get",
            Direction::Put => "put",
        })
    }
}

/// How a command is ordered against the others of its tag group.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    /// No ordering: `mfc_get`, `mfc_put`.
    Plain,
    /// After every earlier command of the tag group: `mfc_getf`, `mfc_putf`.
    Fence,
    /// After every earlier, and before every later, command of the tag
    /// group: `mfc_getb`, `mfc_putb`.
    Barrier,
}

/// How `wait_tags` waits on its mask.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WaitMode {
    /// Until every group in the mask has no command outstanding.
    All,
    /// Until at least one group in the mask has none outstanding.
    Any,
}

/// One transfer of a command: `size` bytes between `ls` and `ea`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Segment {
    pub ls: LsAddr,
    pub ea: Ea,
    pub size: u32,
}

pub(crate) fn command_name(dir: Direction, list: bool) -> &'static str {
    match (dir, list) {
        (Direction::Get, false) => "mfc_get",
        (Direction::Put, false) => "mfc_put",
        (Direction::Get, true) => "mfc_getl",
        (Direction::Put, true) => "mfc_putl",
    }
}

/// Checks one transfer against the size and alignment rules.
pub(crate) fn check_segment(
    spe: usize,
    cmd: &'static str,
    s: Segment,
    tag: u32,
) -> Result<(), CellError> {
    let err = |why: String| CellError::Dma {
        spe,
        cmd,
        ls: s.ls,
        ea: s.ea,
        size: s.size,
        why,
    };
    if tag >= TAG_GROUPS {
        return Err(err(format!("tag {tag} is not a tag group (0–31)")));
    }
    match s.size {
        0 => return Err(err("a transfer of 0 bytes".into())),
        1 | 2 | 4 | 8 => {
            let sz = s.size as u64;
            if !(s.ls.0 as u64).is_multiple_of(sz) || !s.ea.0.is_multiple_of(sz) {
                return Err(err(format!(
                    "a {sz}-byte transfer must be {sz}-byte aligned on both sides"
                )));
            }
            if s.ls.0 as u64 & 15 != s.ea.0 & 15 {
                return Err(err("below 16 bytes the local and effective addresses must agree in their low 4 bits".into()));
            }
        }
        n if n % 16 == 0 && n <= MAX_TRANSFER => {
            if !s.ls.0.is_multiple_of(16) || !s.ea.0.is_multiple_of(16) {
                return Err(err(
                    "transfers of 16 bytes or more must be 16-byte aligned on both sides".into(),
                ));
            }
        }
        n if n > MAX_TRANSFER => {
            return Err(err(format!(
                "{n} bytes is over the 16 KiB limit of one transfer"
            )));
        }
        n => {
            return Err(err(format!(
                "{n} bytes is not 1, 2, 4, 8 or a multiple of 16"
            )));
        }
    }
    Ok(())
}

/// The transfers of a DMA list whose local-store side starts at `ls`
/// (16-byte aligned): element `k` goes to the local address reached so far
/// with its effective address's low four bits; the address advances by
/// `max(size, 16)`.
pub(crate) fn list_segments(
    spe: usize,
    dir: Direction,
    ls: LsAddr,
    list: &[ListElement],
    tag: u32,
) -> Result<Vec<Segment>, CellError> {
    let cmd = command_name(dir, true);
    if list.is_empty() || list.len() > MAX_LIST_ELEMENTS {
        return Err(CellError::Dma {
            spe,
            cmd,
            ls,
            ea: list.first().map_or(Ea(0), |e| e.ea),
            size: list.iter().map(|e| e.size).sum(),
            why: format!(
                "a DMA list holds 1 to {MAX_LIST_ELEMENTS} elements, not {}",
                list.len()
            ),
        });
    }
    if !ls.0.is_multiple_of(16) {
        return Err(CellError::Dma {
            spe,
            cmd,
            ls,
            ea: list[0].ea,
            size: list.iter().map(|e| e.size).sum(),
            why: "a DMA list's local-store address must be 16-byte aligned".into(),
        });
    }
    let mut at = ls;
    let mut out = Vec::with_capacity(list.len());
    for e in list {
        let s = Segment {
            ls: LsAddr(at.0 | (e.ea.0 & 15) as u32),
            ea: e.ea,
            size: e.size,
        };
        check_segment(spe, cmd, s, tag)?;
        out.push(s);
        at = at.offset(e.size.max(16));
    }
    Ok(out)
}
