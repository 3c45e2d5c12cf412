//! The threads that run an experiment's jobs side by side have room for
//! several emulations on one stack: a thread that waits for a job it
//! handed to another pool (a build in a pool of one) runs other jobs
//! meanwhile on the same stack. With rayon's default 2 MiB a full
//! `tradeoff` run overflowed its stack; this test asks for 16 MiB of stack
//! in a job and aborts (failing) on a smaller one.

use cellbih_cli::args::ThreadsArg;
use cellbih_cli::report::side_by_side;

/// Recurses `depth` times with 64 KiB of stack a frame; returns a sum the
/// optimiser cannot drop.
#[inline(never)]
fn deep(depth: u32) -> u64 {
    let frame = std::hint::black_box([depth as u8; 64 * 1024]);
    match depth {
        0 => frame[1] as u64,
        _ => deep(depth - 1) + frame[depth as usize % frame.len()] as u64,
    }
}

#[test]
fn jobs_side_by_side_have_room_for_deep_stacks() {
    ThreadsArg { threads: Some(2) }.install().unwrap();
    // 256 frames of 64 KiB: 16 MiB, eight times rayon's default stack.
    let sums = side_by_side("deep", &[256u32, 255, 200, 256], |&d| deep(d));
    // Each frame holds its depth's byte.
    let want = |d: u32| (1..=d).map(|k| (k % 256) as u64).sum::<u64>();
    assert_eq!(sums, vec![want(256), want(255), want(200), want(256)]);
}
