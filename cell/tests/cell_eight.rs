//! The emulator with eight SPEs at work: the memory interface shared as the
//! hardware shares it (a small get among large streams costs its latency
//! plus a fair share, not the whole queue), contended lock lines, and a
//! functional mode in which every SPE takes part.

use std::cell::RefCell;
use std::rc::Rc;

use cellbih_cell::{Cell, CellConfig, CostModel, Cycles, Ea};

/// The work of one job in these tests: the emulator's tests stand without
/// the library's kernel rates, so a job costs the PS3 value of the
/// library's `spe_job` rate (200 cycles), named here once.
const JOB_WORK: Cycles = Cycles(200);

/// Eight SPEs, `streaming` of which stream double-buffered 16 KiB gets
/// (`chunks` each) while SPE 7 does `probes` lone 128-byte gets, each
/// waited for. Returns the cycles of each lone get.
fn lone_gets_under_load(streaming: usize, chunks: u64, probes: usize) -> Vec<u64> {
    let cfg = CellConfig::ps3().with_spes(8);
    let mut cell = Cell::new(cfg).unwrap();
    let per = chunks * 16384;
    let base = cell
        .memory_mut()
        .alloc("streams", per * streaming as u64 + 128, 128)
        .unwrap();
    for id in 0..streaming {
        let start = base.offset(id as u64 * per);
        cell.spawn_spe(id, move |spe| async move {
            let bufs = [spe.ls_alloc(16384, 128)?, spe.ls_alloc(16384, 128)?];
            spe.get(bufs[0], start, 16384, 0).await?;
            for k in 0..chunks {
                let b = (k % 2) as usize;
                if k + 1 < chunks {
                    let ea = start.offset((k + 1) * 16384);
                    spe.get(bufs[1 - b], ea, 16384, 1 - b as u32).await?;
                }
                spe.wait_tag(b as u32).await?;
            }
            Ok(())
        });
    }
    let times = Rc::new(RefCell::new(Vec::new()));
    let out = times.clone();
    let probe: Ea = base.offset(per * streaming as u64);
    cell.spawn_spe(7, move |spe| async move {
        let b = spe.ls_alloc(128, 128)?;
        // Let the streams get going first.
        spe.compute(Cycles(5_000));
        for _ in 0..probes {
            let t = spe.now();
            spe.get(b, probe, 128, 0).await?;
            spe.wait_tag(0).await?;
            out.borrow_mut().push((spe.now() - t).0);
            spe.compute(Cycles(1_000));
        }
        Ok(())
    });
    cell.run().unwrap();
    times.take()
}

#[test]
fn a_lone_small_get_under_load_costs_its_latency_plus_a_fair_share() {
    let idle = lone_gets_under_load(0, 0, 1)[0];
    // Issue 12 + command 32 + 128 B at 8 B/cycle + latency 256 + the
    // channel read of the tag status 6.
    assert_eq!(idle, 12 + 32 + 16 + 256 + 6);
    let loaded = lone_gets_under_load(7, 64, 20);
    assert_eq!(loaded.len(), 20);
    let shared = CostModel::ps3().memory_shared_bandwidth;
    for &t in &loaded {
        // Its data shares the interface with at most seven streams: at
        // worst an eighth of the sustained 22.83 GB/s, 144 cycles instead
        // of 16.
        assert_eq!(shared.cycles(8 * 128), Cycles(144));
        assert!(
            t > idle && t <= idle - 16 + 144,
            "a 128-byte get took {t} cycles under load (idle {idle})"
        );
    }
}

/// The same program, with every SPE streaming, gives the same cycles each
/// run: sharing is integer arithmetic in a fixed order.
#[test]
fn sharing_the_interface_is_deterministic() {
    let a = lone_gets_under_load(7, 16, 5);
    let b = lone_gets_under_load(7, 16, 5);
    assert_eq!(a, b);
}

/// Eight SPEs take `jobs` jobs from one fetch-and-add counter; returns how
/// many each took, and the run's cycles.
fn shared_queue(cost: CostModel, jobs: u32) -> (Vec<u32>, Cycles) {
    let mut cfg = CellConfig::ps3().with_spes(8);
    cfg.cost = cost;
    let mut cell = Cell::new(cfg).unwrap();
    let counter = cell.memory_mut().alloc("job counter", 128, 128).unwrap();
    let taken = Rc::new(RefCell::new(vec![0u32; 8]));
    for id in 0..8 {
        let taken = taken.clone();
        cell.spawn_spe(id, move |spe| async move {
            let line = spe.ls_alloc(128, 128)?;
            loop {
                let job = spe.atomic_fetch_add_u32(line, counter, 1).await?;
                if job >= jobs {
                    return Ok(());
                }
                taken.borrow_mut()[id] += 1;
                // A job's work (free in functional mode).
                spe.compute(JOB_WORK);
            }
        });
    }
    let r = cell.run().unwrap();
    (taken.take(), r.cycles)
}

#[test]
fn in_functional_mode_every_spe_takes_jobs_from_a_shared_queue() {
    let (taken, cycles) = shared_queue(CostModel::functional(), 4000);
    assert_eq!(taken.iter().sum::<u32>(), 4000);
    assert_eq!(cycles, Cycles::ZERO);
    // Equal clocks are broken in a seeded order, so every SPE wins its
    // share of the races for the counter's line.
    assert!(taken.iter().all(|&n| n > 250), "{taken:?}");
    assert_eq!(shared_queue(CostModel::functional(), 4000).0, taken);
}

/// A spin-wait makes progress in functional mode: SPE 0 polls a flag with
/// getllar until SPE 1, which first does some work, sets it.
#[test]
fn in_functional_mode_a_spin_wait_lets_the_others_run() {
    let mut cfg = CellConfig::ps3().with_spes(2);
    cfg.cost = CostModel::functional();
    let mut cell = Cell::new(cfg).unwrap();
    let flag = cell.memory_mut().alloc("flag", 128, 128).unwrap();
    let polls = Rc::new(RefCell::new(0u32));
    let p = polls.clone();
    cell.spawn_spe(0, move |spe| async move {
        let line = spe.ls_alloc(128, 128)?;
        loop {
            spe.getllar(line, flag).await?;
            *p.borrow_mut() += 1;
            if spe.ls_read::<u32>(line, 1)?[0] == 1 {
                return Ok(());
            }
        }
    });
    cell.spawn_spe(1, move |spe| async move {
        let line = spe.ls_alloc(128, 128)?;
        for _ in 0..10 {
            spe.getllar(line, flag).await?;
        }
        spe.ls_write(line, &[1u32; 32])?;
        spe.putlluc(line, flag).await
    });
    cell.run().unwrap();
    assert!(*polls.borrow() >= 10, "SPE 0 polled while SPE 1 worked");
}

/// In timed mode the counter's lock line moves from SPE to SPE: attempts
/// serialise on the line, some reservations are lost, and both show in
/// the counters.
#[test]
fn a_contended_lock_line_serialises_and_shows_in_the_counters() {
    let mut cfg = CellConfig::ps3().with_spes(8);
    cfg.trace = false;
    let mut cell = Cell::new(cfg).unwrap();
    let counter = cell.memory_mut().alloc("job counter", 128, 128).unwrap();
    for id in 0..8 {
        cell.spawn_spe(id, move |spe| async move {
            let line = spe.ls_alloc(128, 128)?;
            while spe.atomic_fetch_add_u32(line, counter, 1).await? < 800 {
                spe.compute(Cycles(50));
            }
            Ok(())
        });
    }
    let r = cell.run().unwrap();
    let spes = &r.cores[1..];
    let lost: u64 = spes.iter().map(|(_, c)| c.reservations_lost).sum();
    let waited: u64 = spes.iter().map(|(_, c)| c.atomic_wait.0).sum();
    assert!(lost > 0, "eight SPEs on one line lose reservations");
    assert!(waited > 0, "and wait for the line");
    assert_eq!(
        cell.memory().read_pod::<u32>(counter, 1).unwrap()[0],
        808,
        "every SPE's last fetch-and-add happened once"
    );
}

/// A PPE serving eight SPEs waits on any SPE's mailbox (libspe2's event
/// handler) and reads the values in the order they arrived, so the SPE
/// that asked first is served first whatever its number; each read costs
/// the event wake-up and the MMIO read.
#[test]
fn a_ppe_waiting_on_any_mailbox_serves_spes_in_arrival_order() {
    let mut cell = Cell::new(CellConfig::ps3().with_spes(8)).unwrap();
    for id in 0..8 {
        cell.spawn_spe(id, move |spe| async move {
            // SPE 7 asks first, SPE 0 last.
            spe.compute(Cycles(10_000 * (8 - id as u64)));
            spe.write_out_mbox(100 + id as u32).await;
            Ok(())
        });
    }
    let order = Rc::new(RefCell::new(Vec::new()));
    let seen = order.clone();
    cell.spawn_ppe(move |ppe| async move {
        let all: Vec<usize> = (0..8).collect();
        for _ in 0..8 {
            let (spe, v) = ppe.wait_any_out_mbox(&all).await?;
            assert_eq!(v, 100 + spe as u32);
            seen.borrow_mut().push(spe);
        }
        Ok(())
    });
    let r = cell.run().unwrap();
    assert_eq!(*order.borrow(), vec![7, 6, 5, 4, 3, 2, 1, 0]);
    let k = CostModel::ps3();
    // The PPE is busy with eight wake-ups and eight MMIO reads.
    assert_eq!(
        r.cores[0].1.busy,
        Cycles(8 * (k.ppe_event_cycles.0 + k.ppe_mmio_cycles.0))
    );
}

/// Status reads never block: counts of the mailboxes, a pending signal,
/// the immediate tag status; each charged one channel (SPE) or MMIO (PPE)
/// access.
#[test]
fn status_reads_answer_without_blocking() {
    let mut cell = Cell::new(CellConfig::ps3().with_spes(1)).unwrap();
    let ea = cell.memory_mut().alloc("buffer", 16384, 128).unwrap();
    let seen = Rc::new(RefCell::new(Vec::new()));
    let s = seen.clone();
    cell.spawn_spe(0, move |spe| async move {
        let b = spe.ls_alloc(16384, 128)?;
        let v = spe.in_mbox_count().await;
        s.borrow_mut().push(v);
        let v = spe.out_mbox_room().await;
        s.borrow_mut().push(v);
        let v = spe.signal_pending(1).await? as u32;
        s.borrow_mut().push(v);
        spe.get(b, ea, 16384, 3).await?;
        // In flight: tag 3 not done, tag 4 (nothing issued) done.
        let v = spe.tag_status_immediate(0b11000).await;
        s.borrow_mut().push(v);
        spe.wait_tag(3).await?;
        let v = spe.tag_status_immediate(0b11000).await;
        s.borrow_mut().push(v);
        // The PPE's value has arrived by now.
        let v = spe.in_mbox_count().await;
        s.borrow_mut().push(v);
        Ok(())
    });
    let ppe_seen = seen.clone();
    cell.spawn_ppe(move |ppe| async move {
        let v = 100 + ppe.in_mbox_room(0).await?;
        ppe_seen.borrow_mut().push(v);
        ppe.write_in_mbox(0, 7).await?;
        let v = 200 + ppe.out_mbox_count(0).await?;
        ppe_seen.borrow_mut().push(v);
        Ok(())
    });
    cell.run().unwrap();
    let v = seen.borrow().clone();
    assert!(v.contains(&104), "the PPE saw 4 free inbound slots: {v:?}");
    assert!(v.contains(&200), "and no outbound value: {v:?}");
    let spe: Vec<u32> = v.into_iter().filter(|&x| x < 100).collect();
    assert_eq!(spe, vec![0, 1, 0, 0b10000, 0b11000, 1]);
}

/// Touching the local store from inside a `with_ls` closure is an error
/// that says so, not a panic; the SPE's other methods work there.
#[test]
fn with_ls_inside_with_ls_is_a_clear_error() {
    let mut cell = Cell::new(CellConfig::ps3().with_spes(1)).unwrap();
    let err = Rc::new(RefCell::new(String::new()));
    let e = err.clone();
    cell.spawn_spe(0, move |spe| async move {
        let b = spe.ls_alloc(128, 128)?;
        let inner = spe.with_ls(b, 4, |_: &[u32]| {
            spe.compute(Cycles(5));
            spe.ls_read::<u32>(b, 1)
        })?;
        *e.borrow_mut() = inner.unwrap_err().to_string();
        // The store is back after the closure.
        assert_eq!(spe.ls_read::<u32>(b, 1)?, vec![0]);
        Ok(())
    });
    cell.run().unwrap();
    assert!(
        err.borrow().contains("inside a with_ls closure"),
        "{}",
        err.borrow()
    );
}

/// Tag groups by name: the same name gives the same groups, names get
/// consecutive groups in order of first use, and running out is an error.
#[test]
fn tags_are_allocated_by_name() {
    let mut cell = Cell::new(CellConfig::ps3().with_spes(1)).unwrap();
    cell.spawn_spe(0, move |spe| async move {
        assert_eq!(spe.tags("buffers", 5)?, 0);
        assert_eq!(spe.tag("jobs")?, 5);
        assert_eq!(spe.tags("buffers", 5)?, 0);
        assert!(spe.tags("buffers", 2).is_err());
        assert_eq!(spe.tags("many", 26)?, 6);
        let e = spe.tag("one more").unwrap_err().to_string();
        assert!(e.contains("no 1 tag groups left for 'one more'"), "{e}");
        Ok(())
    });
    cell.run().unwrap();
}
