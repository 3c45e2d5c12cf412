//! The passes of an LSD radix sort of (key, value) pairs (section 5: "after
//! the Morton code construction a radix sort needs to be performed"; on
//! the Cell, CellSort and AA-sort). Plain functions over slices: an SPE
//! runs [`histogram`] on its slice of a pass's digit, the counts of every
//! SPE are prefix-summed ([`offsets`]), and each SPE runs [`scatter`] on
//! its slice from its own offsets; [`sort`] is the whole sort on one core.
//! Each pass is stable, so the passes sort by the whole key.

/// The digit of `key` that pass `pass` sorts by: `digit_bits` bits, the
/// lowest first.
#[inline]
pub fn digit(key: u64, pass: u32, digit_bits: u32) -> usize {
    ((key >> (pass * digit_bits)) & ((1 << digit_bits) - 1)) as usize
}

/// Passes that sort keys of `key_bits` bits by digits of `digit_bits`.
pub fn passes(key_bits: u32, digit_bits: u32) -> u32 {
    key_bits.div_ceil(digit_bits)
}

/// Adds the count of each digit value of `keys` in pass `pass` to `counts`
/// (`1 << digit_bits` of them).
pub fn histogram(keys: &[u64], pass: u32, digit_bits: u32, counts: &mut [u32]) {
    for &k in keys {
        counts[digit(k, pass, digit_bits)] += 1;
    }
}

/// The first output slot of each (digit, slice) from the counts of each
/// slice (`counts[slice][digit]`): digit-major, slices in order, so that
/// the scatter is stable across slices. Returned as `[slice][digit]`.
pub fn offsets(counts: &[Vec<u32>]) -> Vec<Vec<u32>> {
    let digits = counts.first().map_or(0, Vec::len);
    let mut out = vec![vec![0; digits]; counts.len()];
    let mut at = 0;
    for d in 0..digits {
        for (s, c) in counts.iter().enumerate() {
            out[s][d] = at;
            at += c[d];
        }
    }
    out
}

/// Moves each (key, value) of one slice to `out[offsets[digit]]`, bumping
/// the offset: the destination index of every pair, in order (what an SPE
/// turns into DMA-list elements).
pub fn scatter(keys: &[u64], pass: u32, digit_bits: u32, offsets: &mut [u32]) -> Vec<u32> {
    keys.iter()
        .map(|&k| {
            let d = digit(k, pass, digit_bits);
            let at = offsets[d];
            offsets[d] += 1;
            at
        })
        .collect()
}

/// Sorts `keys` (of `key_bits` bits) and their `values` together, stably,
/// by LSD passes of `digit_bits` bits on one core.
pub fn sort<T: Copy>(keys: &mut Vec<u64>, values: &mut Vec<T>, key_bits: u32, digit_bits: u32) {
    assert_eq!(keys.len(), values.len());
    for pass in 0..passes(key_bits, digit_bits) {
        let mut counts = vec![0u32; 1 << digit_bits];
        histogram(keys, pass, digit_bits, &mut counts);
        let mut at = offsets(&[counts]).remove(0);
        let to = scatter(keys, pass, digit_bits, &mut at);
        let (mut k2, mut v2) = (keys.clone(), values.clone());
        for (i, &t) in to.iter().enumerate() {
            k2[t as usize] = keys[i];
            v2[t as usize] = values[i];
        }
        (*keys, *values) = (k2, v2);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The passes sort stably, by one slice or by several whose
        /// offsets come from every slice's counts.
        #[test]
        fn the_passes_sort_stably(
            keys in proptest::collection::vec(any::<u64>(), 0..300),
            narrow in any::<bool>(),
            digit_bits in prop::sample::select(vec![4u32, 8, 11]),
            slices in 1usize..5,
        ) {
            let bits = if narrow { 32 } else { 64 };
            let keys: Vec<u64> = keys.iter().map(|k| if narrow { k >> 32 } else { *k } & 0xfff0_0000_ffff_ffff).collect();
            let mut want: Vec<(u64, u32)> = keys.iter().copied().zip(0..).collect();
            want.sort_by_key(|&(k, _)| k);
            let (mut k, mut v) = (keys.clone(), (0..keys.len() as u32).collect::<Vec<_>>());
            sort(&mut k, &mut v, bits, digit_bits);
            prop_assert_eq!(k.iter().copied().zip(v.iter().copied()).collect::<Vec<_>>(), want.clone());
            // The same pass by slices.
            let chunk = keys.len().div_ceil(slices).max(1);
            let (mut k, mut v) = (keys.clone(), (0..keys.len() as u32).collect::<Vec<_>>());
            for pass in 0..passes(bits, digit_bits) {
                let counts: Vec<Vec<u32>> = k.chunks(chunk).map(|c| {
                    let mut h = vec![0; 1 << digit_bits];
                    histogram(c, pass, digit_bits, &mut h);
                    h
                }).collect();
                let mut at = offsets(&counts);
                let (mut k2, mut v2) = (k.clone(), v.clone());
                for (s, c) in k.chunks(chunk).enumerate() {
                    for (i, t) in scatter(c, pass, digit_bits, &mut at[s]).into_iter().enumerate() {
                        k2[t as usize] = c[i];
                        v2[t as usize] = v[s * chunk + i];
                    }
                }
                (k, v) = (k2, v2);
            }
            prop_assert_eq!(k.iter().copied().zip(v.iter().copied()).collect::<Vec<_>>(), want);
        }
    }
}
