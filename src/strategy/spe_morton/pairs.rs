//! `spe_morton`'s key pairs (keys and sort buffers sized to the scene): a Morton key and the index of its triangle record, 8 bytes
//! (a 32-bit key, the index) for keys of up to 32 bits, 16 (a 64-bit key,
//! the index, 4 bytes of padding) beyond; and their DMA. The MFC moves 8
//! bytes only as one 8-byte transfer whose local-store address agrees
//! with the effective address in its low four bits, and larger runs only
//! as 16-byte-aligned multiples of 16 (`cell::mfc`): a run of 8-byte pairs
//! goes as an 8-byte head, a middle, an 8-byte tail.

use crate::cell::{CellError, Ea, ListElement, LsAddr, MAX_TRANSFER, Spe};

/// A key and the index of its triangle record, as an SPE works on them.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct KeyRec {
    pub key: u64,
    pub index: u32,
}

/// How key pairs lie in memory.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pairs {
    /// Bytes of a pair: 8 or 16.
    pub bytes: usize,
}

/// Pairs a DMA block of a stream holds: 1,024 of either width (a scatter's
/// staging of 8-byte pairs takes up to 16 bytes each: 16 KiB).
pub(super) const PAIRS_PER_BLOCK: usize = 1024;

impl Pairs {
    /// The narrowest pairs that hold `bits`-bit keys.
    pub fn for_bits(bits: u32) -> Self {
        Pairs {
            bytes: if bits <= 32 { 8 } else { 16 },
        }
    }

    /// The `u32` word of a pair that holds the index.
    pub fn index_word(&self) -> usize {
        if self.bytes == 8 { 1 } else { 2 }
    }

    fn words(&self) -> usize {
        self.bytes / 4
    }

    /// The pairs as the words memory holds (little-endian keys).
    pub fn encode(&self, pairs: &[KeyRec]) -> Vec<u32> {
        let mut w = Vec::with_capacity(pairs.len() * self.words());
        for p in pairs {
            match self.bytes {
                8 => w.extend([p.key as u32, p.index]),
                _ => w.extend([p.key as u32, (p.key >> 32) as u32, p.index, 0]),
            }
        }
        w
    }

    /// The pairs in `words`.
    pub fn decode(&self, words: &[u32]) -> Vec<KeyRec> {
        (words.chunks_exact(self.words()))
            .map(|w| match self.bytes {
                8 => KeyRec {
                    key: w[0] as u64,
                    index: w[1],
                },
                _ => KeyRec {
                    key: w[0] as u64 | (w[1] as u64) << 32,
                    index: w[2],
                },
            })
            .collect()
    }

    /// Reads `count` pairs from the local store at `ls`.
    pub fn read(&self, spe: &Spe, ls: LsAddr, count: usize) -> Result<Vec<KeyRec>, CellError> {
        Ok(self.decode(&spe.ls_read::<u32>(ls, count * self.words())?))
    }

    /// Writes `pairs` to the local store at `ls`.
    pub fn write(&self, spe: &Spe, ls: LsAddr, pairs: &[KeyRec]) -> Result<(), CellError> {
        spe.ls_write(ls, &self.encode(pairs))
    }
}

/// Where data for `ea` starts in a 16-byte-aligned local-store buffer at
/// `base`: at the same low four bits.
pub(super) fn ls_for(base: LsAddr, ea: Ea) -> LsAddr {
    base.offset((ea.0 & 15) as u32)
}

/// The pieces of `bytes` (a multiple of 8) from `ea` (8-byte aligned) that
/// the MFC moves: an 8-byte head where `ea` is not 16-byte aligned, runs of
/// 16-byte multiples of at most 16 KiB, an 8-byte tail.
fn pieces(ea: Ea, bytes: usize) -> Vec<(u64, u32)> {
    let (mut at, end) = (ea.0, ea.0 + bytes as u64);
    let mut out = Vec::new();
    if at % 16 != 0 && at < end {
        out.push((at, 8));
        at += 8;
    }
    while end - at >= 16 {
        let len = ((end - at) & !15).min(MAX_TRANSFER as u64);
        out.push((at, len as u32));
        at += len;
    }
    if at < end {
        out.push((at, 8));
    }
    out
}

/// Gets (`put` false) or puts `bytes` between main memory at `ea` and the
/// local store at `ls_for(base, ea)`, under `tag`.
pub(super) async fn span(
    spe: &Spe,
    base: LsAddr,
    ea: Ea,
    bytes: usize,
    put: bool,
    tag: u32,
) -> Result<(), CellError> {
    let ls = ls_for(base, ea);
    for (at, len) in pieces(ea, bytes) {
        let here = ls.offset((at - ea.0) as u32);
        match put {
            true => spe.put(here, Ea(at), len, tag).await?,
            false => spe.get(here, Ea(at), len, tag).await?,
        }
    }
    Ok(())
}

/// One putl's staging and list for `runs` (each the address of its first
/// place and its bytes) by the MFC's list rule: an element under 16 bytes
/// sits at its address's low four bits of the next 16-byte slot, a larger
/// one at the slot itself.
pub(super) fn stage_list(runs: &[(Ea, Vec<u8>)]) -> (Vec<u8>, Vec<ListElement>) {
    let (mut staged, mut list) = (Vec::new(), Vec::new());
    for (ea, data) in runs {
        for (at, len) in pieces(*ea, data.len()) {
            let from = (at - ea.0) as usize;
            let bytes = &data[from..from + len as usize];
            let slot = staged.len();
            match len < 16 {
                true => {
                    staged.resize(slot + 16, 0);
                    let pos = slot + (at % 16) as usize;
                    staged[pos..pos + 8].copy_from_slice(bytes);
                }
                false => staged.extend_from_slice(bytes),
            }
            list.push(ListElement {
                ea: Ea(at),
                size: len,
            });
        }
    }
    (staged, list)
}

/// The DMA list that gathers the records of `pairs` (by their indices,
/// records of `RECORD` bytes from `tris`) into consecutive places: one
/// element a run of records consecutive in memory (at most
/// [`MAX_TRANSFER`] bytes), not one a record, so that a run moves each
/// 128-byte line once (a range whose keys tie keeps its records' order:
/// the radix sort is stable).
pub(super) fn gather_list(tris: Ea, pairs: &[KeyRec]) -> Vec<ListElement> {
    let record = super::RECORD as u32;
    let mut list: Vec<ListElement> = Vec::new();
    let mut next = None;
    for k in pairs {
        let ea = tris.offset(k.index as u64 * record as u64);
        match list.last_mut() {
            Some(last) if next == Some(k.index) && last.size + record <= MAX_TRANSFER => {
                last.size += record;
            }
            _ => list.push(ListElement { ea, size: record }),
        }
        next = k.index.checked_add(1);
    }
    list
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records consecutive in memory are gathered by one element, up to
    /// the largest transfer; any other order starts a new one.
    #[test]
    fn a_gather_list_takes_a_run_of_records_in_one_element() {
        let pairs = |ix: &[u32]| -> Vec<KeyRec> {
            ix.iter().map(|&index| KeyRec { key: 0, index }).collect()
        };
        let r = super::super::RECORD as u32;
        let list = gather_list(Ea(1024), &pairs(&[3, 4, 5, 9, 8, 10]));
        let got: Vec<(u64, u32)> = list.iter().map(|e| (e.ea.0, e.size)).collect();
        let at = |i: u32| 1024 + (i * r) as u64;
        assert_eq!(
            got,
            vec![(at(3), 3 * r), (at(9), r), (at(8), r), (at(10), r)]
        );
        let run: Vec<u32> = (0..1000).collect();
        let list = gather_list(Ea(0), &pairs(&run));
        assert!(list.iter().all(|e| e.size <= MAX_TRANSFER));
        assert_eq!(list.iter().map(|e| e.size).sum::<u32>(), 1000 * r);
        assert_eq!(
            list.len(),
            (1000 * r).div_ceil(MAX_TRANSFER / r * r) as usize
        );
    }

    #[test]
    fn runs_of_eight_byte_pairs_split_into_transfers_the_mfc_takes() {
        assert_eq!(pieces(Ea(8), 8), vec![(8, 8)]);
        assert_eq!(pieces(Ea(8), 40), vec![(8, 8), (16, 32)]);
        assert_eq!(pieces(Ea(16), 40), vec![(16, 32), (48, 8)]);
        assert_eq!(pieces(Ea(24), 48), vec![(24, 8), (32, 32), (64, 8)]);
        let big = pieces(Ea(0), 40 * 1024);
        assert_eq!(big.len(), 3);
        assert!(
            big.iter()
                .all(|&(a, l)| a % 16 == 0 && l as usize <= 16 * 1024)
        );
    }

    #[test]
    fn a_staged_list_puts_every_byte_at_its_place() {
        let runs = vec![
            (Ea(8), vec![1u8; 24]),
            (Ea(64), vec![2u8; 8]),
            (Ea(200), vec![3u8; 8]),
        ];
        let (staged, list) = stage_list(&runs);
        // Replay the list as the MFC does into a memory image.
        let mut memory = vec![0u8; 256];
        let mut cursor = 0usize;
        for e in &list {
            let ls = match e.size < 16 {
                true => cursor + (e.ea.0 % 16) as usize,
                false => cursor,
            };
            let (a, n) = (e.ea.0 as usize, e.size as usize);
            memory[a..a + n].copy_from_slice(&staged[ls..ls + n]);
            cursor += n.max(16);
        }
        assert!(memory[8..32].iter().all(|&b| b == 1));
        assert!(memory[64..72].iter().all(|&b| b == 2));
        assert!(memory[200..208].iter().all(|&b| b == 3));
        assert_eq!(memory.iter().filter(|&&b| b != 0).count(), 40);
    }

    #[test]
    fn pairs_round_trip_in_both_widths() {
        let pairs = [
            KeyRec {
                key: 0xdead_beef,
                index: 7,
            },
            KeyRec {
                key: 1,
                index: u32::MAX,
            },
        ];
        for bits in [16, 32] {
            let p = Pairs::for_bits(bits);
            assert_eq!(p.bytes, 8);
            let back = p.decode(&p.encode(&pairs));
            assert_eq!(
                back.iter().map(|k| (k.key, k.index)).collect::<Vec<_>>(),
                [(0xdead_beef, 7), (1, u32::MAX)]
            );
        }
        let wide = Pairs::for_bits(64);
        let k = [KeyRec {
            key: u64::MAX - 5,
            index: 3,
        }];
        assert_eq!(wide.decode(&wide.encode(&k))[0].key, u64::MAX - 5);
        assert_eq!(wide.encode(&k)[wide.index_word()], 3);
    }
}
