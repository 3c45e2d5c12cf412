//! The emulator's rules: every DMA violation is an error naming the command;
//! queues, mailboxes and signals block where the hardware blocks; lost
//! reservations; deadlocks end the run; checked mode catches races; the
//! same program gives the same cycles every time; hand-computed timings.

use cellbih_cell::{
    Cell, CellConfig, CellError, Cycles, Ea, ListElement, LsAddr, Reservation, RunReport, WaitMode,
};

type Program = std::pin::Pin<Box<dyn std::future::Future<Output = Result<(), CellError>>>>;
type Case = (&'static str, Box<dyn Fn(cellbih_cell::Spe, Ea) -> Program>);

/// A case of a rule: the words its error must hold, and the program (one
/// SPE's, given the SPE and a 64 KiB buffer in main memory) that breaks it.
macro_rules! case {
    ($says:literal, |$s:ident, $ea:ident| $body:block) => {
        (
            $says,
            Box::new(|$s: cellbih_cell::Spe, $ea: Ea| -> Program { Box::pin(async move $body) })
                as Box<dyn Fn(cellbih_cell::Spe, Ea) -> Program>,
        )
    };
}

/// A PS3 whose programs are resident: these tests time the programs
/// alone (starting them is tested in `cell_contention.rs`).
fn ps3() -> CellConfig {
    CellConfig {
        resident: true,
        ..CellConfig::ps3()
    }
}

fn cell(spes: usize) -> Cell {
    Cell::new(ps3().with_spes(spes)).unwrap()
}

/// Runs one SPE program that issues a single command and returns its error.
fn dma_error(f: impl FnOnce(cellbih_cell::Spe, Ea) -> Program) -> String {
    let mut c = cell(1);
    let ea = c.memory_mut().alloc("test buffer", 64 * 1024, 128).unwrap();
    c.spawn_spe(0, move |spe| f(spe, ea));
    c.run().unwrap_err().to_string()
}

#[test]
fn every_dma_rule_violation_names_the_command() {
    let cases: Vec<Case> = vec![
        case!("3 bytes is not 1, 2, 4, 8 or a multiple of 16", |s, ea| {
            let b = s.ls_alloc(128, 128)?;
            s.get(b, ea, 3, 0).await
        }),
        case!("over the 16 KiB limit", |s, ea| {
            let b = s.ls_alloc(32768, 128)?;
            s.get(b, ea, 32768, 0).await
        }),
        case!("must be 16-byte aligned on both sides", |s, ea| {
            let b = s.ls_alloc(256, 128)?;
            s.get(b, ea.offset(8), 64, 0).await
        }),
        case!("agree in their low 4 bits", |s, ea| {
            let b = s.ls_alloc(256, 128)?;
            s.get(b.offset(4), ea.offset(8), 4, 0).await
        }),
        case!("must be 8-byte aligned", |s, ea| {
            let b = s.ls_alloc(256, 128)?;
            s.put(b.offset(4), ea.offset(4), 8, 0).await
        }),
        case!("tag 32 is not a tag group", |s, ea| {
            let b = s.ls_alloc(256, 128)?;
            s.get(b, ea, 16, 32).await
        }),
        case!("a transfer of 0 bytes", |s, ea| {
            let b = s.ls_alloc(256, 128)?;
            s.get(b, ea, 0, 0).await
        }),
        case!("outside what was allocated", |s, ea| {
            let b = s.ls_alloc(256, 128)?;
            s.get(b, ea.offset(64 * 1024), 16, 0).await
        }),
        (
            "runs past the 262144-byte local store",
            Box::new(|s, ea| {
                Box::pin(async move { s.get(LsAddr(256 * 1024 - 16), ea, 32, 0).await })
            }),
        ),
        case!("a DMA list holds 1 to 2048 elements, not 2049", |s, ea| {
            let b = s.ls_alloc(1024, 128)?;
            s.getl(b, &vec![ListElement { ea, size: 16 }; 2049], 0)
                .await
        }),
        case!("mfc_getl", |s, ea| {
            let b = s.ls_alloc(1024, 128)?;
            s.getl(
                b,
                &[
                    ListElement { ea, size: 16 },
                    ListElement {
                        ea: ea.offset(4),
                        size: 16,
                    },
                ],
                0,
            )
            .await
        }),
    ];
    for (want, f) in cases {
        let e = dma_error(f);
        assert!(e.contains(want), "expected '{want}' in: {e}");
        assert!(
            e.starts_with("SPE 0:") || e.starts_with("main memory"),
            "{e}"
        );
    }
}

#[test]
fn a_full_local_store_says_what_is_in_use() {
    let mut c = cell(1);
    c.spawn_spe(0, |spe| async move {
        spe.ls_alloc(200 * 1024, 128)?;
        spe.ls_alloc(40 * 1024, 128)?;
        Ok(())
    });
    let e = c.run().unwrap_err().to_string();
    assert_eq!(
        e,
        "SPE 0: local store full: asked 40960 bytes aligned to 128, 237568 of 262144 in use (32768 reserved for code and stack)"
    );
}

/// Simulated time never wraps: a charge that would carry a clock past
/// 2^64 cycles ends the run with an error naming the core, and the
/// largest sum below it is kept exactly.
#[test]
fn time_past_2_64_cycles_is_an_error_not_a_wrapped_clock() {
    let mut c = cell(1);
    c.spawn_spe(0, |spe| async move {
        spe.compute_items(Cycles(1 << 40), 1 << 23);
        spe.compute_items(Cycles(1 << 40), 1 << 23);
        spe.compute(Cycles(1));
        Ok(())
    });
    let e = c.run().unwrap_err();
    assert!(matches!(e, CellError::TimeOverflow { .. }), "{e}");
    assert!(e.to_string().contains("on SPE 0"), "{e}");
    let mut c = cell(1);
    c.spawn_spe(0, |spe| async move {
        spe.compute_items(Cycles(1 << 40), 1 << 23);
        spe.compute_items(Cycles(1 << 40), (1 << 23) - 1);
        Ok(())
    });
    let r = c.run().unwrap();
    assert_eq!(r.cycles, Cycles((1u64 << 63) + ((1 << 63) - (1 << 40))));
}

#[test]
fn main_memory_runs_out_like_a_ps3() {
    let c = cell(1);
    c.memory_mut().alloc("test buffer", 200 << 20, 128).unwrap();
    let e = c
        .memory_mut()
        .alloc("job spill", 100 << 20, 128)
        .unwrap_err();
    assert!(matches!(e, CellError::OutOfMemory { .. }), "{e}");
    assert_eq!(
        e.to_string(),
        "main memory full: job spill asked 104857600 bytes, 209715200 of 268435456 in use \
         (largest so far: test buffer 209715200 bytes)"
    );
}

/// One SPE, one 16 KiB get, wait: issue + command + data + latency +
/// the channel read of the tag status.
#[test]
fn one_get_costs_what_the_model_says() {
    let cfg = ps3();
    let k = cfg.cost.clone();
    let mut c = Cell::new(cfg.with_spes(1)).unwrap();
    let ea = c.memory_mut().alloc("test buffer", 16384, 128).unwrap();
    c.spawn_spe(0, move |spe| async move {
        let b = spe.ls_alloc(16384, 128)?;
        spe.get(b, ea, 16384, 5).await?;
        spe.wait_tag(5).await
    });
    let r = c.run().unwrap();
    let data = k.spe_bandwidth.cycles(16384);
    assert_eq!(
        data,
        Cycles(2048),
        "25.6 GB/s at 3.2 GHz is 8 bytes a cycle"
    );
    let want =
        k.dma_issue_cycles + k.mfc_command_cycles + data + k.dma_latency_cycles + k.channel_cycles;
    assert_eq!(want, Cycles(12 + 32 + 2048 + 256 + 6));
    assert_eq!(r.cycles, want);
    let spe = &r.cores[1].1;
    assert_eq!((spe.gets, spe.bytes_get), (1, 16384));
    assert_eq!(spe.dma_wait, Cycles(32 + 2048 + 256));
    // A 128-byte get completes within Kistler et al.'s 100 ns.
    let line = k.dma_issue_cycles
        + k.mfc_command_cycles
        + k.spe_bandwidth.cycles(128)
        + k.dma_latency_cycles;
    assert!(line.ms(k.clock_hz) * 1e6 < 100.0, "{line}");
}

/// Two SPEs get 16 KiB at the same moment: their data shares the memory
/// interface, each at half its sustained bandwidth for several streams.
#[test]
fn two_spes_share_the_memory_interface() {
    let k = cellbih_cell::CostModel::ps3();
    let mut c = cell(2);
    let ea = c.memory_mut().alloc("test buffer", 32768, 128).unwrap();
    for id in 0..2 {
        c.spawn_spe(id, move |spe| async move {
            let b = spe.ls_alloc(16384, 128)?;
            spe.get(b, ea.offset(id as u64 * 16384), 16384, 0).await?;
            spe.wait_tag(0).await
        });
    }
    let r = c.run().unwrap();
    // Both data phases start at 12 + 32 and share 22.83 GB/s (7.134 bytes
    // a cycle): 32 KiB in 4594 cycles, then the 256-cycle latency and the
    // 6-cycle channel read.
    let both = k.memory_shared_bandwidth.cycles(32768);
    assert_eq!(both, Cycles(4594));
    assert_eq!(r.cycles, Cycles(12 + 32 + 4594 + 256 + 6));
    for (_, spe) in &r.cores[1..] {
        // Sharing cost each what its data would not have taken alone.
        let alone = k.memory_bandwidth.cycles(16384);
        assert_eq!(spe.memory_wait, both - alone);
        assert_eq!(spe.dma_wait, Cycles(32 + 4594 + 256));
    }
}

#[test]
fn a_full_command_queue_stalls_the_issuer() {
    let mut c = cell(1);
    let ea = c.memory_mut().alloc("test buffer", 17 * 1024, 128).unwrap();
    c.spawn_spe(0, move |spe| async move {
        let b = spe.ls_alloc(17 * 1024, 128)?;
        for i in 0..17u32 {
            spe.get(b.offset(i * 1024), ea.offset(i as u64 * 1024), 1024, i)
                .await?;
        }
        // Without the stall the 17th would issue at 17 × 12 cycles; it had
        // to wait for the first command to complete.
        let first_done = Cycles(12 + 32 + 128 + 256);
        assert!(
            spe.now() > first_done,
            "issued at {} before the first get completed",
            spe.now()
        );
        spe.wait_tags(u32::MAX >> 15, WaitMode::All).await?;
        Ok(())
    });
    let r = c.run().unwrap();
    assert!(r.cores[1].1.dma_wait > Cycles::ZERO);
}

#[test]
fn mailboxes_keep_their_depths_and_block() {
    let mut c = cell(1);
    c.spawn_ppe(|ppe| async move {
        // Six writes into a 4-deep inbound mailbox: the fifth blocks until
        // the SPE reads.
        for v in 1..=6 {
            ppe.write_in_mbox(0, v).await?;
        }
        let mut got = Vec::new();
        for _ in 0..3 {
            got.push(ppe.read_out_mbox(0).await?);
        }
        assert_eq!(got, vec![21, 22, 23]);
        Ok(())
    });
    c.spawn_spe(0, |spe| async move {
        spe.compute(Cycles(50_000)); // a slow reader
        let mut seen = Vec::new();
        for _ in 0..6 {
            seen.push(spe.read_in_mbox().await);
        }
        assert_eq!(seen, vec![1, 2, 3, 4, 5, 6], "FIFO order");
        // Outbound holds one value: the second write waits for the PPE.
        for v in 21..=23 {
            spe.write_out_mbox(v).await;
        }
        Ok(())
    });
    let r = c.run().unwrap();
    assert!(
        r.cores[0].1.mailbox_wait >= Cycles(40_000),
        "the PPE waited on the full inbound mailbox: {:?}",
        r.cores[0].1
    );
}

#[test]
fn signals_overwrite_or_or() {
    let mut c = cell(2);
    c.spawn_ppe(|ppe| async move {
        ppe.send_signal(0, 1, 0b01).await?;
        ppe.send_signal(0, 1, 0b10).await?;
        ppe.send_signal(0, 2, 0b01).await?;
        ppe.send_signal(0, 2, 0b10).await?;
        Ok(())
    });
    c.spawn_spe(0, |spe| async move {
        spe.compute(Cycles(10_000));
        assert_eq!(spe.read_signal(1).await?, 0b10, "register 1 overwrites");
        assert_eq!(spe.read_signal(2).await?, 0b11, "register 2 ORs");
        // SPE 1 signals SPE 0; the read blocks until it arrives.
        assert_eq!(spe.read_signal(1).await?, 7);
        Ok(())
    });
    c.spawn_spe(1, |spe| async move {
        spe.compute(Cycles(30_000));
        spe.send_signal(0, 1, 7).await
    });
    let r = c.run().unwrap();
    assert!(r.cores[1].1.mailbox_wait > Cycles::ZERO);
}

#[test]
fn a_reservation_is_lost_when_another_core_writes_the_line() {
    let mut c = cell(2);
    let line = c.memory_mut().alloc("test buffer", 128, 128).unwrap();
    c.spawn_spe(0, move |spe| async move {
        let b = spe.ls_alloc(128, 128)?;
        spe.getllar(b, line).await?;
        spe.compute(Cycles(5_000)); // SPE 1 writes the line meanwhile
        assert_eq!(spe.putllc(b, line).await?, Reservation::Lost);
        spe.getllar(b, line).await?;
        assert_eq!(spe.putllc(b, line).await?, Reservation::Stored);
        Ok(())
    });
    c.spawn_spe(1, move |spe| async move {
        let b = spe.ls_alloc(128, 128)?;
        spe.compute(Cycles(1_000));
        spe.putlluc(b, line).await
    });
    let r = c.run().unwrap();
    assert_eq!(r.cores[1].1.reservations_lost, 1);
}

/// Six SPEs increment one shared counter: every increment lands, and the
/// contention shows as lost reservations.
#[test]
fn contended_atomic_adds_all_land() {
    let mut c = cell(6);
    let counter = c.memory_mut().alloc("test buffer", 128, 128).unwrap();
    for id in 0..6 {
        c.spawn_spe(id, move |spe| async move {
            let b = spe.ls_alloc(128, 128)?;
            for _ in 0..50 {
                spe.atomic_fetch_add_u32(b, counter.offset(8), 1).await?;
            }
            Ok(())
        });
    }
    let r = c.run().unwrap();
    assert_eq!(
        c.memory().read_pod::<u32>(counter.offset(8), 1).unwrap()[0],
        300
    );
    let lost: u64 = r.cores.iter().map(|(_, k)| k.reservations_lost).sum();
    assert!(lost > 0, "six SPEs on one line must collide");
}

#[test]
fn a_deadlock_ends_the_run_and_says_who_waits_for_what() {
    let mut c = cell(1);
    c.spawn_ppe(|ppe| async move { ppe.read_out_mbox(0).await.map(|_| ()) });
    c.spawn_spe(0, |spe| async move {
        spe.read_in_mbox().await;
        Ok(())
    });
    let e = c.run().unwrap_err().to_string();
    assert!(e.starts_with("deadlock at cycle"), "{e}");
    assert!(
        e.contains("PPE waits for a value in SPE 0's Out mailbox"),
        "{e}"
    );
    assert!(
        e.contains("SPE 0 waits for a value in its inbound mailbox"),
        "{e}"
    );
}

#[test]
fn checked_mode_catches_reads_and_writes_of_buffers_in_flight() {
    let mut c = cell(1);
    let ea = c.memory_mut().alloc("test buffer", 1024, 128).unwrap();
    c.spawn_spe(0, move |spe| async move {
        let b = spe.ls_alloc(1024, 128)?;
        spe.get(b, ea, 1024, 3).await?;
        spe.with_ls(b, 4, |v: &[u32]| v[0]).map(|_| ())
    });
    let e = c.run().unwrap_err().to_string();
    assert!(
        e.contains("the program reads ls") && e.contains("(tag 3) is not waited for"),
        "{e}"
    );

    let mut c = cell(1);
    let ea = c.memory_mut().alloc("test buffer", 1024, 128).unwrap();
    c.spawn_spe(0, move |spe| async move {
        let b = spe.ls_alloc(1024, 128)?;
        spe.put(b, ea, 1024, 1).await?;
        spe.ls_write(b, &[1u32])
    });
    let e = c.run().unwrap_err().to_string();
    assert!(e.contains("the program writes ls"), "{e}");

    let mut c = cell(1);
    let ea = c
        .memory_mut()
        .alloc_pod("test input", &[42u32; 256], 128)
        .unwrap();
    c.spawn_spe(0, move |spe| async move {
        let b = spe.ls_alloc(1024, 128)?;
        spe.get(b, ea, 1024, 3).await?;
        spe.wait_tag(3).await?;
        assert_eq!(spe.ls_read::<u32>(b, 256)?, vec![42; 256]);
        Ok(())
    });
    c.run().unwrap();
}

/// A put's bytes reach main memory only when it completes: another SPE that
/// reads the place earlier sees the old value.
#[test]
fn puts_become_visible_when_they_complete() {
    let mut c = cell(2);
    let ea = c
        .memory_mut()
        .alloc_pod("test input", &[1u32; 4], 128)
        .unwrap();
    c.spawn_spe(0, move |spe| async move {
        let b = spe.ls_alloc(16, 16)?;
        spe.ls_write(b, &[2u32; 4])?;
        spe.compute(Cycles(2_000));
        spe.put(b, ea, 16, 0).await?;
        spe.wait_tag(0).await
    });
    c.spawn_spe(1, move |spe| async move {
        let b = spe.ls_alloc(32, 16)?;
        spe.get(b, ea, 16, 0).await?; // done before the put is issued: old data
        spe.wait_tag(0).await?;
        assert_eq!(spe.ls_read::<u32>(b, 4)?, vec![1; 4]);
        spe.compute(Cycles(5_000));
        spe.get(b.offset(16), ea, 16, 1).await?; // after the put: new data
        spe.wait_tag(1).await?;
        assert_eq!(spe.ls_read::<u32>(b.offset(16), 4)?, vec![2; 4]);
        Ok(())
    });
    c.run().unwrap();
}

/// Six SPEs stream, share a queue counter and signal each other; the run is
/// repeated, and repeated inside rayon pools of 1 and 2 threads.
fn busy_program() -> (RunReport, Vec<u32>) {
    let mut c = cell(6);
    let data = c
        .memory_mut()
        .alloc_pod("test input", &(0..6 * 8192u32).collect::<Vec<_>>(), 128)
        .unwrap();
    let next = c.memory_mut().alloc("test buffer", 128, 128).unwrap();
    let out = c
        .memory_mut()
        .alloc("test buffer", 6 * 8192 * 4, 128)
        .unwrap();
    for id in 0..6 {
        c.spawn_spe(id, move |spe| async move {
            let line = spe.ls_alloc(128, 128)?;
            let buf = spe.ls_alloc(4096, 128)?;
            loop {
                let job = spe.atomic_fetch_add_u32(line, next, 1).await?;
                if job >= 48 {
                    return Ok(());
                }
                let at = job as u64 * 4096;
                spe.get(buf, data.offset(at), 4096, 0).await?;
                spe.wait_tag(0).await?;
                spe.with_ls_mut(buf, 1024, |v: &mut [u32]| {
                    v.iter_mut()
                        .for_each(|x| *x = x.wrapping_mul(3) + id as u32)
                })?;
                spe.compute(Cycles(1024 * (1 + id as u64)));
                spe.put(buf, out.offset(at), 4096, 0).await?;
                spe.wait_tag(0).await?;
            }
        });
    }
    let r = c.run().unwrap();
    let v = c.memory().read_pod(out, 6 * 8192).unwrap();
    (r, v)
}

#[test]
fn the_same_program_gives_the_same_cycles_and_bytes() {
    let (a, va) = busy_program();
    let (b, vb) = busy_program();
    assert_eq!(a.cycles, b.cycles);
    assert_eq!(va, vb);
    assert_eq!(format!("{:?}", a.cores), format!("{:?}", b.cores));
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let runs: Vec<_> = pool.install(|| {
            use rayon::prelude::*;
            (0..4).into_par_iter().map(|_| busy_program()).collect()
        });
        for (r, v) in runs {
            assert_eq!(r.cycles, a.cycles, "{threads} host threads");
            assert_eq!(v, va);
        }
    }
}

#[test]
fn functional_mode_gives_the_same_bytes_at_no_cost() {
    let mut cfg = ps3().with_spes(1);
    cfg.cost = cellbih_cell::CostModel::functional();
    let mut c = Cell::new(cfg).unwrap();
    let ea = c
        .memory_mut()
        .alloc_pod("test input", &[7u32; 64], 128)
        .unwrap();
    c.spawn_spe(0, move |spe| async move {
        let b = spe.ls_alloc(256, 128)?;
        spe.get(b, ea, 256, 0).await?;
        spe.wait_tag(0).await?;
        spe.with_ls_mut(b, 64, |v: &mut [u32]| v.iter_mut().for_each(|x| *x += 1))?;
        spe.put(b, ea, 256, 0).await?;
        spe.wait_tag(0).await
    });
    let r = c.run().unwrap();
    assert_eq!(r.cycles, Cycles::ZERO);
    assert_eq!(c.memory().read_pod::<u32>(ea, 64).unwrap(), vec![8; 64]);
}

/// The rustdoc example's program (six SPEs, double-buffered 16 KiB gets,
/// four per SPE) with its cycle count worked out by hand. The six start
/// together and share the interface equally, so they move in lock step:
/// each of four rounds is a command phase (32 cycles, the interface idle)
/// and six gets' data at the sustained 22.83 GB/s (13,780 cycles); then
/// the last latency and the channel read of the tag.
#[test]
fn six_spes_summing_take_the_cycles_worked_out_by_hand() {
    let k = cellbih_cell::CostModel::ps3();
    let mut c = cell(6);
    let n = 6 * 4 * 4096usize;
    let input = c
        .memory_mut()
        .alloc_pod("test input", &(0..n as u32).collect::<Vec<_>>(), 128)
        .unwrap();
    let sums = std::rc::Rc::new(std::cell::RefCell::new(vec![0u64; 6]));
    for id in 0..6 {
        let sums = sums.clone();
        c.spawn_spe(id, move |spe| async move {
            let bufs = [spe.ls_alloc(16384, 128)?, spe.ls_alloc(16384, 128)?];
            let base = input.offset(id as u64 * 65536);
            spe.get(bufs[0], base, 16384, 0).await?;
            for i in 0..4u32 {
                let b = (i % 2) as usize;
                if i + 1 < 4 {
                    spe.get(
                        bufs[1 - b],
                        base.offset((i as u64 + 1) * 16384),
                        16384,
                        1 - b as u32,
                    )
                    .await?;
                }
                spe.wait_tag(b as u32).await?;
                sums.borrow_mut()[id] += spe.with_ls(bufs[b], 4096, |v: &[u32]| {
                    v.iter().map(|&x| x as u64).sum::<u64>()
                })?;
            }
            Ok(())
        });
    }
    let r = c.run().unwrap();
    let total: u64 = sums.borrow().iter().sum();
    assert_eq!(total, (n as u64 - 1) * n as u64 / 2);
    let data = k.memory_shared_bandwidth.cycles(6 * 16384);
    let want = k.dma_issue_cycles.0
        + 4 * (k.mfc_command_cycles.0 + data.0)
        + k.dma_latency_cycles.0
        + k.channel_cycles.0;
    assert_eq!(want, 12 + 4 * (32 + 13_780) + 256 + 6);
    assert_eq!(r.cycles.0, want);
    // 6 × 64 KiB in 55,522 cycles: 22.7 GB/s, the sustained 22.83 less the
    // command phases, the first issue and the last latency.
    let gbs = (6 * 65536) as f64 / (r.cycles.0 as f64 / 3.2e9) / 1e9;
    assert!(gbs > 22.5 && gbs < 22.83, "{gbs}");
}

#[test]
fn compare_and_swap_stores_only_on_a_match() {
    let mut c = cell(1);
    let ea = c
        .memory_mut()
        .alloc_pod("test input", &[5u32; 32], 128)
        .unwrap();
    c.spawn_spe(0, move |spe| async move {
        let line = spe.ls_alloc(128, 128)?;
        assert_eq!(spe.atomic_cas_u32(line, ea.offset(4), 5, 9).await?, 5);
        assert_eq!(spe.atomic_cas_u32(line, ea.offset(4), 5, 11).await?, 9);
        Ok(())
    });
    c.run().unwrap();
    assert_eq!(c.memory().read_pod::<u32>(ea, 3).unwrap(), vec![5, 9, 5]);
}

/// A PPE serving SPEs until they stop (libspe2's event handler with
/// SPE_EVENT_SPE_STOPPED): it reads each word as it arrives, then learns
/// that every SPE has ended, and that last wake-up costs nothing: the run
/// ends with the last SPE, not after it.
#[test]
fn a_ppe_serves_until_every_spe_has_stopped_without_lengthening_the_run() {
    let mut c = cell(2);
    c.spawn_spe(0, |spe| async move {
        spe.compute(Cycles(1000));
        spe.write_out_mbox(7).await;
        Ok(())
    });
    c.spawn_spe(1, |spe| async move {
        spe.compute(Cycles(50_000));
        Ok(())
    });
    let served = c.spawn_ppe(|ppe| async move {
        let mut words = Vec::new();
        while let Some(got) = ppe.wait_any_out_mbox_or_stop(&[0, 1]).await? {
            words.push(got);
        }
        Ok(words)
    });
    let r = c.run().unwrap();
    assert_eq!(served.take("PPE").unwrap(), vec![(0, 7)]);
    let spe1_end = r.cores[2].1.busy;
    assert_eq!(r.cycles, spe1_end, "the run ends with SPE 1");
}
