//! The strategies on the emulated Cell: each returns the one tree type,
//! read back from emulated main memory. `ppe_naive` runs the host
//! builder's recursion on the PPE, so its tree must equal the host tree node
//! for node; every run of the same input gives the same cycles.
//! (Validity and agreement with brute force for every builder are in
//! bih_props.rs, which loops over `BuilderKind::ALL`.)

mod common;

use cellbih::bih::{Bih, BihConfig, SplitChoice};
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene;

#[test]
fn ppe_naive_builds_the_host_tree() {
    let scenes = vec![
        scene::load("default", None).unwrap(),
        scene::load("car", None).unwrap(),
        scene::load("cup", None).unwrap(),
        scene::load("rtperf:20000:4", None).unwrap(),
        common::make_scene(2000, 15, 1, 0, 2),
        common::make_scene(2000, -15, 0, 3, 5),
    ];
    for s in &scenes {
        let host = Build::new(BuilderKind::HOST).run(s).unwrap();
        let ppe = Build::new(BuilderKind::PPE_NAIVE).run(s).unwrap();
        assert_eq!(ppe.bih, host.bih, "{}", s.name);
        let sim = ppe.simulated.expect("an emulated build reports its run");
        assert!(sim.run.cycles.0 > 0);
        assert_eq!(sim.stats.nodes as usize, host.bih.nodes.len());
    }
}

/// The same nodes, and every leaf holding the same set of triangles (the
/// order inside a side depends on the partition algorithm).
fn same_tree_up_to_leaf_order(a: &cellbih::bih::Bih, b: &cellbih::bih::Bih) -> Result<(), String> {
    if a.nodes != b.nodes {
        let i = a
            .nodes
            .iter()
            .zip(&b.nodes)
            .position(|(x, y)| x != y)
            .unwrap_or(a.nodes.len().min(b.nodes.len()));
        return Err(format!(
            "node arrays differ first at node {i} ({} vs {} nodes)",
            a.nodes.len(),
            b.nodes.len()
        ));
    }
    for n in a.nodes.iter().filter(|n| n.is_leaf()) {
        let (f, c) = n.leaf_range();
        let r = f as usize..(f + c) as usize;
        let (mut x, mut y) = (a.prim_ids[r.clone()].to_vec(), b.prim_ids[r].to_vec());
        x.sort_unstable();
        y.sort_unstable();
        if x != y {
            return Err(format!("leaf at {f} holds different triangles"));
        }
    }
    Ok(())
}

/// The settings the builders that build the quality knobs are compared
/// with the host on: the paper's tree, the empty-space cut-off at two
/// thresholds, binned SAH alone (8 bins) and with the cut-off (16).
const SETTINGS: [BihConfig; 6] = [
    BihConfig::DEFAULT,
    BihConfig {
        empty_cut: Some(10),
        ..BihConfig::DEFAULT
    },
    BihConfig {
        empty_cut: Some(30),
        leaf_size: 4,
        ..BihConfig::DEFAULT
    },
    BihConfig {
        split: SplitChoice::BinnedSah { bins: 8, above: 0 },
        ..BihConfig::DEFAULT
    },
    BihConfig::SAH_CUT,
    // Binned SAH above 40 triangles, the global heuristic below.
    BihConfig {
        split: SplitChoice::BinnedSah {
            bins: 16,
            above: 40,
        },
        ..BihConfig::SAH_CUT
    },
];

/// spe_dfs runs the same recursion with the partitions on SPE 0 (Fig. 1):
/// the same nodes as the host tree and the same triangles in every leaf
/// (Fig. 1 orders a side differently from the host's two-pointer pass), and
/// the work shows on the SPE; with the empty-space cut-off too (the PPE
/// makes the clip nodes) and binned SAH (the SPE bins, the PPE sweeps).
#[test]
fn spe_dfs_builds_the_host_tree_with_the_partitions_on_an_spe() {
    for (s, cfg) in [
        scene::load("default", None).unwrap(),
        scene::load("cup", None).unwrap(),
        scene::load("rtperf:30000:2", None).unwrap(),
        common::make_scene(3000, 15, 1, 1, 3),
        common::make_scene(3000, -15, 0, 2, 4),
    ]
    .iter()
    .flat_map(|s| SETTINGS.map(|c| (s, c)))
    {
        let host = Build::new(BuilderKind::HOST).with_tree(cfg).run(s).unwrap();
        let dfs = Build::new(BuilderKind::SPE_DFS)
            .with_tree(cfg)
            .run(s)
            .unwrap();
        same_tree_up_to_leaf_order(&dfs.bih, &host.bih)
            .unwrap_or_else(|e| panic!("{} {cfg:?}: {e}", s.name));
        let sim = dfs.simulated.as_ref().unwrap();
        assert_eq!(
            sim.stats.clip_nodes > 0,
            cfg.empty_cut.is_some(),
            "{}",
            s.name
        );
        let run = &sim.run;
        let spe = &run.cores[1].1;
        assert!(
            spe.bytes_get >= 48 * s.len() as u64,
            "the SPE streamed the array at least once"
        );
        assert!(
            run.cores[0].1.mailbox_wait.0 > 0,
            "the PPE waited for the SPE"
        );
    }
}

/// spe_bfs, the baseline, makes the host tree's splits level by level: the
/// same tree with its nodes numbered breadth first. The scenes are large
/// enough for every path of the program: levels wider than WorkB (spilled
/// to WorkBPPE), intervals over 16 KiB (Fig. 1) and under (agglomerated),
/// several ObjectArena blocks. The PPE only allocates. With the empty-space
/// cut-off too (its jobs carry their regions), and with binned SAH (each
/// split job bins its triangles in the local store, or in one more stream
/// through Fig. 1's buffers when they do not fit).
#[test]
fn spe_bfs_builds_the_host_tree_breadth_first() {
    for (s, cfg) in [
        scene::load("default", None).unwrap(),
        scene::load("car", None).unwrap(),
        scene::load("rtperf:40000:2", None).unwrap(),
        common::make_scene(3000, 15, 1, 1, 3),
        common::make_scene(3000, -15, 0, 2, 4),
        common::make_scene(500, 0, 0, 0, 9),
    ]
    .iter()
    .flat_map(|s| SETTINGS.map(|c| (s, c)))
    {
        let host = Build::new(BuilderKind::HOST).with_tree(cfg).run(s).unwrap();
        let bfs = Build::new(BuilderKind::SPE_BFS)
            .with_tree(cfg)
            .run(s)
            .unwrap();
        common::same_tree_structure(&bfs.bih, &host.bih)
            .unwrap_or_else(|e| panic!("{} {cfg:?}: {e}", s.name));
        // Breadth first: a node's children come after every node of its level.
        let depth_of = node_depths(&bfs.bih);
        assert!(
            depth_of.windows(2).all(|w| w[0] <= w[1]),
            "{}: node ids are not in level order",
            s.name
        );
        let sim = bfs.simulated.unwrap();
        let (ppe, spe) = (&sim.run.cores[0].1, &sim.run.cores[1].1);
        assert!(
            ppe.busy.0 * 100 < spe.busy.0,
            "{}: the PPE did more than allocate ({} vs {} cycles)",
            s.name,
            ppe.busy.0,
            spe.busy.0
        );
        assert_eq!(sim.stats.nodes as usize, host.bih.nodes.len());
    }
}

/// The depth of every node, by node id.
fn node_depths(b: &Bih) -> Vec<u32> {
    let mut d = vec![u32::MAX; b.nodes.len()];
    d[0] = 0;
    for i in 0..b.nodes.len() {
        let n = b.nodes[i];
        if !n.is_leaf() {
            let c = n.left_child() as usize;
            d[c] = d[i] + 1;
            d[c + 1] = d[i] + 1;
        }
    }
    d
}

/// Every emulated builder, run twice: the same cycles, the same counters,
/// the same node array.
#[test]
fn an_emulated_build_gives_the_same_cycles_and_tree_every_run() {
    let s = scene::load("rtperf:10000:1", None).unwrap();
    // Every emulated builder with the paper's settings and with the quality
    // knobs it builds, binned SAH on every node and only above 40
    // triangles (--sah-above 40).
    let above = BihConfig {
        split: SplitChoice::BinnedSah {
            bins: 16,
            above: 40,
        },
        ..BihConfig::SAH_CUT
    };
    let mut runs = BuilderKind::every_run(BihConfig::SAH_CUT);
    runs.extend(
        BuilderKind::every_run(above)
            .into_iter()
            .filter(|(_, c)| *c == above),
    );
    assert!(runs.iter().any(|(b, c)| b.emulated() && *c == above));
    for (b, cfg) in runs.into_iter().filter(|(b, _)| b.emulated()) {
        let run = || Build::new(b).with_tree(cfg).run(&s).unwrap();
        let (x, y) = (run(), run());
        assert_eq!(x.bih, y.bih, "{}", b.name());
        let (x, y) = (x.simulated.unwrap(), y.simulated.unwrap());
        assert_eq!(x.run.cycles, y.run.cycles, "{}", b.name());
        assert_eq!(
            format!("{:?}", x.run.cores),
            format!("{:?}", y.run.cores),
            "{}",
            b.name()
        );
    }
}

/// The PPE build's time is its kernel charges (its bounds pass over every
/// record, its partitions, its nodes), its memory traffic and the
/// allocation of the node array.
#[test]
fn ppe_naive_time_is_kernels_plus_traffic() {
    let s = scene::load("car", None).unwrap();
    let built = Build::new(BuilderKind::PPE_NAIVE).run(&s).unwrap();
    let sim = built.simulated.unwrap();
    let k = cellbih::cell::CostModel::ps3();
    let r = cellbih::kernels::rates::KernelRates::PS3;
    let compute = r.ppe_bounds_item.0 * s.len() as u64
        + r.ppe_partition_item.0 * sim.stats.items_partitioned
        + r.ppe_node.0 * sim.stats.nodes;
    // Read the triangle array, write it back sorted, write the nodes.
    let traffic = k.ppe_memory_bandwidth.cycles(48 * s.len() as u64).0 * 2
        + k.ppe_memory_bandwidth.cycles(12 * sim.stats.nodes).0;
    // The records through the PPE's caches: the bounds pass and every
    // split's pass, a load a 128-byte line each.
    let mut passes = cellbih::strategy::ppe_passes::Passes::cold();
    passes.partitions(&built.bih.nodes, |_| true);
    let loads = passes.loads();
    let lines = |first: u64, end: u64| (48 * end).div_ceil(128) - 48 * first / 128;
    let mut expected = lines(0, s.len() as u64);
    let mut stack = vec![0u32];
    let nodes = &built.bih.nodes;
    // Each node's interval from its leaves, each split counted once.
    fn span(nodes: &[cellbih::bih::BihNode], id: u32) -> Option<(u64, u64)> {
        let n = nodes[id as usize];
        if n.is_leaf() {
            let (f, c) = n.leaf_range();
            return (c > 0).then_some((f as u64, (f + c) as u64));
        }
        let (l, r) = (span(nodes, n.left_child()), span(nodes, n.left_child() + 1));
        match (l, r) {
            (Some(l), Some(r)) => Some((l.0.min(r.0), l.1.max(r.1))),
            (l, r) => l.or(r),
        }
    }
    while let Some(id) = stack.pop() {
        let n = nodes[id as usize];
        if n.is_leaf() {
            continue;
        }
        let c = n.left_child();
        if let (Some(_), Some(_)) = (span(nodes, c), span(nodes, c + 1)) {
            let (f, e) = span(nodes, id).unwrap();
            expected += lines(f, e);
        }
        stack.extend([c, c + 1]);
    }
    assert_eq!(loads.total(), expected, "{loads:?}");
    // The first pass finds nothing cached; a scene past the L1 misses it.
    assert!(loads.memory >= lines(0, s.len() as u64), "{loads:?}");
    assert!(loads.l1 + loads.l2 > 0, "{loads:?}");
    let caches = cellbih::kernels::ppe_rates::loads_cycles(&loads, &k).0;
    assert_eq!(
        sim.run.cycles.0,
        compute + traffic + caches + k.ppe_alloc_cycles.0
    );
}

/// ppe_approx: a valid tree over every triangle (validity and brute force
/// for every builder are in bih_props.rs), built with fewer PPE cycles than
/// the naive build because the upper levels sort buckets, not triangles; and
/// the naive finish really runs below the buckets.
#[test]
fn ppe_approx_sorts_buckets_then_finishes_naively_for_fewer_cycles() {
    for s in [
        scene::load("rtperf:20000:3", None).unwrap(),
        scene::load("car", None).unwrap(),
    ] {
        let cfg = BihConfig::default();
        let naive = Build::new(BuilderKind::PPE_NAIVE)
            .with_tree(cfg)
            .run(&s)
            .unwrap();
        let approx = Build::new(BuilderKind::PPE_APPROX)
            .with_tree(cfg)
            .run(&s)
            .unwrap();
        approx.bih.validate(&s).unwrap();
        assert_ne!(
            approx.bih, naive.bih,
            "{}: the upper levels split buckets",
            s.name
        );
        let (n, a) = (naive.simulated.unwrap(), approx.simulated.unwrap());
        assert!(
            a.run.cycles < n.run.cycles,
            "{}: {} vs {} cycles",
            s.name,
            a.run.cycles.0,
            n.run.cycles.0
        );
        assert!(a.stats.partitions > 0, "{}: no naive finish", s.name);
    }
}

/// The ObjectArena, shared by the SPE strategies: nodes emitted in the
/// order their ids were handed out come back at those ids, whether the PPE
/// allocates each block on request (the paper's mailbox protocol) or the
/// SPE takes blocks from a pool by fetch-and-add (no PPE at all). Ids are
/// handed out as a tree needs them, a root and then pairs of children; in
/// a pool a pair never straddles two blocks (slot 4,079 is skipped).
#[test]
fn the_object_arena_gives_back_its_nodes_from_either_block_source() {
    use cellbih::bih::BihNode;
    use cellbih::cell::{Cell, CellConfig, Ea};
    use cellbih::strategy::machinery::arena::{
        BLOCK_BYTES, BLOCK_NODES, BlockSource, ObjectArena, pieces, serve_blocks,
    };
    use std::cell::RefCell;
    use std::rc::Rc;

    const PAIRS: usize = 4_999; // 9,999 slots: three blocks, the last one partly
    let run = |pool: bool| -> (Vec<BihNode>, u64, usize) {
        let mut cell = Cell::new(CellConfig::ps3().with_spes(1)).unwrap();
        let source = if pool {
            let base = cell
                .memory_mut()
                .alloc("pool", 4 * BLOCK_BYTES, 128)
                .unwrap();
            let counter = cell.memory_mut().alloc("pool counter", 128, 128).unwrap();
            BlockSource::Pool {
                base,
                blocks: 4,
                counter,
                grows: false,
            }
        } else {
            BlockSource::Mailbox
        };
        let blocks: Rc<RefCell<(Vec<Ea>, usize)>> = Rc::default();
        let b = blocks.clone();
        cell.spawn_spe(0, move |spe| async move {
            let mut arena = ObjectArena::new(&spe, source)?;
            arena.open().await;
            let root = arena.alloc(1).await?;
            arena.emit(root, BihNode::leaf(root, 1)).await?;
            for _ in 0..PAIRS {
                let id = arena.alloc(2).await?;
                arena.emit(id, BihNode::leaf(id, 1)).await?;
                arena.emit(id + 1, BihNode::leaf(id + 1, 1)).await?;
            }
            let count = arena.allocated();
            *b.borrow_mut() = (arena.close(count).await?, count);
            Ok(())
        });
        if !pool {
            let b = blocks.clone();
            cell.spawn_ppe(move |ppe| async move {
                let (served, count) = serve_blocks(&ppe, 0).await?;
                assert_eq!(count, b.borrow().1);
                // Asked for one ahead: the last block served went unused.
                assert_eq!(served[..served.len() - 1], b.borrow().0);
                Ok(())
            });
        }
        let r = cell.run().unwrap();
        let (list, count) = blocks.borrow().clone();
        let mut nodes = Vec::new();
        for (ea, n) in pieces(&list, count) {
            nodes.extend(cell.memory().read_pod::<BihNode>(ea, n).unwrap());
        }
        (nodes, r.cores[0].1.mailbox_messages, count)
    };
    let (by_mailbox, ppe_messages, count) = run(false);
    assert_eq!(count, 1 + 2 * PAIRS);
    let want: Vec<BihNode> = (0..count as u32).map(|i| BihNode::leaf(i, 1)).collect();
    assert_eq!(by_mailbox, want);
    assert_eq!(ppe_messages, 4, "one answer per block, one ahead");
    let (by_pool, ppe_messages, count) = run(true);
    assert_eq!(count, 2 + 2 * PAIRS, "one slot skipped");
    let skipped = BLOCK_NODES - 1;
    for (i, n) in by_pool.iter().enumerate() {
        let want = if i == skipped {
            BihNode::default()
        } else {
            BihNode::leaf(i as u32, 1)
        };
        assert_eq!(*n, want, "slot {i}");
    }
    assert_eq!(ppe_messages, 0, "the pool needs no PPE");
}

/// A pool that grows: past its blocks, the SPE asks the PPE for overflow
/// blocks (`PoolServer`), which lie a whole number of nodes past the pool's
/// base, so each node id is still its slot: node `id` is at base + 12 id.
#[test]
fn a_growing_object_arena_pool_keeps_ids_as_slots() {
    use cellbih::bih::BihNode;
    use cellbih::cell::{Cell, CellConfig, Ea};
    use cellbih::strategy::machinery::arena::{BLOCK_BYTES, BLOCK_NODES, BlockSource, ObjectArena};
    use cellbih::strategy::machinery::pool_server::PoolServer;
    use std::cell::RefCell;
    use std::rc::Rc;

    const PAIRS: usize = 4_999; // 9,999 slots: one pool block, two overflow
    let mut cell = Cell::new(CellConfig::ps3().with_spes(1)).unwrap();
    let base = cell.memory_mut().alloc("pool", BLOCK_BYTES, 128).unwrap();
    let counter = cell.memory_mut().alloc("pool counter", 128, 128).unwrap();
    // Something else between the pool and its overflow blocks.
    cell.memory_mut().alloc("other", 1000, 128).unwrap();
    let source = BlockSource::Pool {
        base,
        blocks: 1,
        counter,
        grows: true,
    };
    let ids: Rc<RefCell<Vec<u32>>> = Rc::default();
    let i = ids.clone();
    cell.spawn_spe(0, move |spe| async move {
        let mut arena = ObjectArena::new(&spe, source)?;
        let root = arena.alloc(1).await?;
        arena.emit(root, BihNode::leaf(root, 1)).await?;
        i.borrow_mut().push(root);
        for _ in 0..PAIRS {
            let id = arena.alloc(2).await?;
            arena.emit(id, BihNode::leaf(id, 1)).await?;
            arena.emit(id + 1, BihNode::leaf(id + 1, 1)).await?;
            i.borrow_mut().extend([id, id + 1]);
        }
        let count = arena.allocated();
        arena.close(count).await?;
        assert_eq!(arena.stats.overflow, 2);
        Ok(())
    });
    let reach =
        cell.spawn_ppe(move |ppe| async move { PoolServer::new(base, 1, 1).serve(&ppe).await });
    let r = cell.run().unwrap();
    let reach = reach.take("PPE").unwrap();
    assert_eq!(
        r.cores[0].1.mailbox_messages, 2,
        "one answer per overflow block"
    );
    let ids = ids.borrow();
    assert_eq!(ids.len(), 1 + 2 * PAIRS);
    assert!(
        ids[..BLOCK_NODES - 1]
            .iter()
            .copied()
            .eq(0..BLOCK_NODES as u32 - 1)
    );
    assert!(
        ids.iter().any(|&id| id as usize > 2 * BLOCK_NODES),
        "past the pool"
    );
    for &id in ids.iter() {
        let at = Ea(base.0 + id as u64 * 12);
        assert!(at.0 + 12 <= reach.0, "node {id} past the reach");
        let got = cell.memory().read_pod::<BihNode>(at, 1).unwrap();
        assert_eq!(got[0], BihNode::leaf(id, 1), "node {id}");
    }
}

/// Each knob of the registry's tables: its default is in its own range,
/// a knob shared by several tables is one declaration, each value it
/// sweeps is in range and not the default, and every builder that takes
/// the knob reads it: one of those values moves the builder's simulated
/// cycles or tree (a knob a builder forgot to read would move nothing) —
/// on the default scene, or with another of the builder's sweep settings,
/// or on a scene large enough for the job queues to spill.
#[test]
fn every_knob_table_states_its_range_and_each_sweep_value_moves_its_builders() {
    use cellbih::strategy::{Knob, Knobs};
    let scenes = ["default", "rtperf:60000"].map(|n| scene::load(n, None).unwrap());
    let cell = cellbih::cell::CellConfig::ps3();
    let mut seen: Vec<&'static Knob> = Vec::new();
    for &b in BuilderKind::ALL {
        // A pair of settings may not fit together (spe_morton
        // --region-size 8192 --double-buffer fills a local store): no
        // result, not a candidate.
        let run = |s: &scene::Scene, k: &Knobs| {
            let r = (Build::new(b).on(&cell).with_knobs(k).run(s)).ok()?;
            Some((r.simulated.unwrap().run.cycles, r.bih.nodes, r.bih.prim_ids))
        };
        for &k in b.knobs() {
            match seen.iter().find(|o| o.name == k.name) {
                // A strategy may reuse another's knob (the same row); two
                // different rows of one name would make one option mean two
                // things.
                Some(o) => assert_eq!(*o, k, "--{} declared twice, differently", k.name),
                None => seen.push(k),
            }
            if !k.is_flag() {
                let d = Knobs::default().with(k, &k.default_text());
                assert!(d.is_ok(), "--{}: default out of range: {d:?}", k.name);
            }
            assert!(!k.sweep.is_empty(), "--{} sweeps nothing", k.name);
            for v in k.sweep {
                assert_ne!(*v, k.default_text(), "--{} sweeps its default", k.name);
            }
            let others = b
                .sweeps()
                .into_iter()
                .filter(|o| o.given().all(|g| g.name != k.name));
            let others: Vec<Knobs> = others.collect();
            let moves = |s: &scene::Scene, o: &Knobs| {
                let Some(base) = run(s, o) else { return false };
                (k.sweep.iter())
                    .any(|v| run(s, &o.clone().with(k, v).unwrap()).is_some_and(|r| r != base))
            };
            let moved = (scenes.iter())
                .flat_map(|s| others.iter().map(move |o| (s, o)))
                .find(|(s, o)| moves(s, o));
            assert!(
                moved.is_some(),
                "{b} --{}: no sweep value moved anything",
                k.name
            );
        }
    }
    assert!(!seen.is_empty(), "the registry declares no knob");
}

/// The machine rates the front end refuses for every build
/// (`cost::FABRIC_AND_PPE_ATOMICS`: transfers between local stores and
/// the PPE's atomics) move no build of any emulated builder, on 1 and 8
/// SPEs: so that list cannot go stale while a builder starts to use them.
#[test]
fn no_build_charges_the_fabric_or_the_ppe_atomics() {
    use cellbih::cell::{CellConfig, cost::FABRIC_AND_PPE_ATOMICS};
    let s = scene::load("rtperf:6000:2", None).unwrap();
    for spes in [1, 8] {
        let base = CellConfig::ps3().with_spes(spes);
        let mut moved = base.clone();
        for name in FABRIC_AND_PPE_ATOMICS {
            let value = match name.ends_with("_cycles") {
                true => "100000",
                false => "0.01",
            };
            moved.cost.set_rate(name, value).unwrap().unwrap();
        }
        for &b in BuilderKind::ALL.iter().filter(|b| b.emulated()) {
            let cycles = |cell: &CellConfig| {
                let r = Build::new(b).on(cell).run(&s).unwrap();
                r.simulated.unwrap().run.cycles
            };
            assert_eq!(cycles(&base), cycles(&moved), "{b} on {spes} SPEs");
        }
    }
}
