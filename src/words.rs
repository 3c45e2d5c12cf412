//! Numbers in words for the library's messages and descriptions.

/// `n` and `noun`, plural unless `n` is 1: "1 SPE", "6 SPEs", "1 triangle".
pub fn count(n: impl Into<u64>, noun: &str) -> String {
    match n.into() {
        1 => format!("1 {noun}"),
        n => format!("{n} {noun}s"),
    }
}
