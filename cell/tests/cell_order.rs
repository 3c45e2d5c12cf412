//! Ordering of DMA commands and transfers between local stores. The MFC
//! may run queued commands in any order but for fences and barriers within
//! a tag group: checked mode reports two commands in flight whose outcome
//! depends on their order, the fenced and barrier forms wait for what they
//! must, and a get or put whose effective address is another SPE's local
//! store moves over the EIB, not through the memory interface.

use std::cell::RefCell;
use std::rc::Rc;

use cellbih_cell::{Cell, CellConfig, CellError, Cycles, Ea, LsAddr, Order, Segment, Spe};

/// Runs `program` on SPE 0 of a one-SPE machine (checked or not) with a
/// 128-byte line of main memory; returns the run's cycles or its error.
fn run_one<F, Fut>(checked: bool, program: F) -> Result<Cycles, CellError>
where
    F: FnOnce(Spe, Ea) -> Fut,
    Fut: Future<Output = Result<(), CellError>> + 'static,
{
    let mut cfg = CellConfig::ps3().with_spes(1);
    cfg.checked = checked;
    // Resident: the cycles below are the program's alone.
    cfg.resident = true;
    let mut cell = Cell::new(cfg)?;
    let ea = cell.memory_mut().alloc("line", 256, 128)?;
    cell.spawn_spe(0, move |spe| program(spe, ea));
    Ok(cell.run()?.cycles)
}

#[test]
fn a_get_behind_an_unfinished_put_of_the_same_bytes_needs_a_fence() {
    // Same tag, no fence: the get could overtake the put.
    let e = run_one(true, |spe, ea| async move {
        let b = spe.ls_alloc(256, 128)?;
        spe.put(b, ea, 128, 2).await?;
        spe.get(b.offset(128), ea, 128, 2).await?;
        spe.wait_tag(2).await
    })
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("a get (tag 2) issued while the put of ea")
            && e.contains("use the fenced or barrier form"),
        "{e}"
    );
    // Another tag: a fence would not help.
    let e = run_one(true, |spe, ea| async move {
        let b = spe.ls_alloc(256, 128)?;
        spe.put(b, ea, 128, 2).await?;
        spe.get_ordered(Order::Fence, line_after(b, ea), 3).await?;
        spe.wait_tags(0b1100, cellbih_cell::WaitMode::All)
            .await
            .map(|_| ())
    })
    .unwrap_err()
    .to_string();
    assert!(e.contains("wait for its tag group first"), "{e}");
    // Gets of the same bytes do not conflict, nor do disjoint bytes.
    run_one(true, |spe, ea| async move {
        let b = spe.ls_alloc(512, 128)?;
        spe.get(b, ea, 128, 0).await?;
        spe.get(b.offset(128), ea, 128, 1).await?;
        spe.put(b.offset(256), ea.offset(128), 128, 2).await?;
        spe.wait_tags(0b111, cellbih_cell::WaitMode::All)
            .await
            .map(|_| ())
    })
    .unwrap();
    // Unchecked mode does not look.
    run_one(false, |spe, ea| async move {
        let b = spe.ls_alloc(256, 128)?;
        spe.put(b, ea, 128, 2).await?;
        spe.get(b.offset(128), ea, 128, 2).await?;
        spe.wait_tag(2).await
    })
    .unwrap();
}

/// A fenced get waits for the put before it to complete, and reads what
/// the put wrote. By hand: the put is issued at 12, its data moves 44–60
/// and it completes at 444 (latency 256, write acknowledgement 128); the
/// getf, issued at 24, starts its command phase at 444, moves its data
/// 476–492, completes at 748; the tag read takes 6 more. Unfenced
/// (unchecked), the get would start at 60 and complete at 364: the run
/// ends when the put does, at 450.
#[test]
fn a_fenced_get_waits_for_the_put_before_it_and_reads_its_bytes() {
    let seen = Rc::new(RefCell::new(0u32));
    let s = seen.clone();
    let cycles = run_one(true, move |spe, ea| async move {
        let b = spe.ls_alloc(256, 128)?;
        spe.ls_write(b, &[7u32; 32])?;
        spe.put(b, ea, 128, 2).await?;
        spe.get_ordered(Order::Fence, line_after(b, ea), 2).await?;
        spe.wait_tag(2).await?;
        *s.borrow_mut() = spe.ls_read::<u32>(b.offset(128), 1)?[0];
        Ok(())
    })
    .unwrap();
    assert_eq!(*seen.borrow(), 7);
    assert_eq!(cycles, Cycles(754));
    let plain = run_one(false, |spe, ea| async move {
        let b = spe.ls_alloc(256, 128)?;
        spe.put(b, ea, 128, 2).await?;
        spe.get(b.offset(128), ea, 128, 2).await?;
        spe.wait_tag(2).await
    })
    .unwrap();
    assert_eq!(plain, Cycles(450));
}

/// A barrier orders the commands after it too: a plain get issued after a
/// putb of the same bytes is fine, and waits for it.
#[test]
fn a_barrier_orders_the_commands_after_it() {
    let cycles = run_one(true, |spe, ea| async move {
        let b = spe.ls_alloc(256, 128)?;
        spe.put_ordered(
            Order::Barrier,
            Segment {
                ls: b,
                ea,
                size: 128,
            },
            4,
        )
        .await?;
        spe.get(b.offset(128), ea, 128, 4).await?;
        spe.wait_tag(4).await
    })
    .unwrap();
    assert_eq!(cycles, Cycles(754));
}

/// SPE 0 puts 16 KiB into SPE 1's local store through its effective
/// address; SPE 1 reads it after a signal. The transfer takes the same
/// cycles whether or not six other SPEs stream from main memory meanwhile:
/// the EIB, not the memory interface, carries it, at the rate of the local
/// stores' ports (23.6 GB/s: 2222 cycles), and the put completes with its
/// write acknowledgement (128 cycles after the latency).
#[test]
fn a_put_into_another_local_store_goes_over_the_eib() {
    let run = |streams: usize| -> (u64, u32) {
        let mut cell = Cell::new(CellConfig::ps3().with_spes(8)).unwrap();
        let base = cell
            .memory_mut()
            .alloc("streams", 6 * 64 * 16384, 128)
            .unwrap();
        for id in 2..2 + streams {
            let start = base.offset((id - 2) as u64 * 64 * 16384);
            cell.spawn_spe(id, move |spe| async move {
                let b = spe.ls_alloc(16384, 128)?;
                for k in 0..64 {
                    spe.get(b, start.offset(k * 16384), 16384, 0).await?;
                    spe.wait_tag(0).await?;
                }
                Ok(())
            });
        }
        let took = Rc::new(RefCell::new(0u64));
        let t = took.clone();
        cell.spawn_spe(0, move |spe| async move {
            let b = spe.ls_alloc(16384, 128)?;
            spe.ls_write(b, &[9u32; 4096])?;
            spe.compute(Cycles(20_000));
            let start = spe.now();
            // SPE 1's receive buffer is its first allocation: 32 KiB in.
            spe.put(b, Ea::of_local_store(1, 32 * 1024), 16384, 0)
                .await?;
            spe.wait_tag(0).await?;
            *t.borrow_mut() = (spe.now() - start).0;
            spe.send_signal(1, 1, 1).await
        });
        let got = Rc::new(RefCell::new(0u32));
        let g = got.clone();
        cell.spawn_spe(1, move |spe| async move {
            let b = spe.ls_alloc(16384, 128)?;
            assert_eq!(b.0, 32 * 1024);
            spe.read_signal(1).await?;
            *g.borrow_mut() = spe.ls_read::<u32>(b.offset(16380), 1)?[0];
            Ok(())
        });
        cell.run().unwrap();
        (*took.borrow(), *got.borrow())
    };
    let (alone, got) = run(0);
    assert_eq!(got, 9);
    assert_eq!(alone, 12 + 32 + 2222 + 256 + 128 + 6);
    assert_eq!(run(6), (alone, 9));
}

#[test]
fn a_local_store_address_must_name_an_spe_and_fit_its_store() {
    for (ea, msg) in [
        (Ea::of_local_store(5, 0), "there is no SPE 5"),
        (Ea::of_local_store(1, 256 * 1024 - 64), "runs past"),
    ] {
        let mut cell = Cell::new(CellConfig::ps3().with_spes(2)).unwrap();
        cell.spawn_spe(0, move |spe| async move {
            let b = spe.ls_alloc(128, 128)?;
            spe.get(b, ea, 128, 0).await?;
            spe.wait_tag(0).await
        });
        let e = cell.run().unwrap_err().to_string();
        assert!(e.contains(msg), "{e}");
    }
}

/// A DMA list's elements land as the handbook says: each at the local
/// address reached so far with its effective address's low four bits, the
/// address advancing by the element's size or by 16 for smaller ones.
#[test]
fn dma_list_elements_land_at_rounded_local_addresses() {
    use cellbih_cell::ListElement;
    let mut cell = Cell::new(CellConfig::ps3().with_spes(1)).unwrap();
    let words: Vec<u32> = (0..64).collect();
    let ea = cell.memory_mut().alloc_pod("words", &words, 128).unwrap();
    let got = Rc::new(RefCell::new(Vec::new()));
    let g = got.clone();
    cell.spawn_spe(0, move |spe| async move {
        let b = spe.ls_alloc(256, 128)?;
        let list = [
            ListElement {
                ea: ea.offset(4),
                size: 4,
            }, // word 1 → b + 4
            ListElement {
                ea: ea.offset(40),
                size: 8,
            }, // words 10, 11 → b + 16 + 8
            ListElement {
                ea: ea.offset(64),
                size: 32,
            }, // words 16..24 → b + 32
            ListElement {
                ea: ea.offset(128),
                size: 4,
            }, // word 32 → b + 64
        ];
        spe.getl(b, &list, 0).await?;
        spe.wait_tag(0).await?;
        *g.borrow_mut() = spe.ls_read::<u32>(b, 20)?;
        Ok(())
    });
    cell.run().unwrap();
    let v = got.borrow();
    assert_eq!(v[1], 1);
    assert_eq!((v[6], v[7]), (10, 11));
    assert_eq!(v[8..16].to_vec(), (16..24).collect::<Vec<u32>>());
    assert_eq!(v[16], 32);
    // Bytes the list skipped stay as they were.
    assert_eq!((v[0], v[4], v[5]), (0, 0, 0));
}

/// The 128 bytes after the line at `b` in the local store, to or from the
/// line at `ea`.
fn line_after(b: LsAddr, ea: Ea) -> Segment {
    Segment {
        ls: b.offset(128),
        ea,
        size: 128,
    }
}
