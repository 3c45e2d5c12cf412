//! The strategies on the emulated Cell: each returns the one tree type,
//! read back from emulated main memory. `ppe_naive` runs the host
//! builder's recursion on the PPE, so its tree must equal the host tree node
//! for node; every run of the same input gives the same cycles.
//! (Validity and agreement with brute force for every builder are in
//! bih_props.rs, which loops over `BuilderKind::ALL`.)

mod common;

use cellbih::bih::BihConfig;
use cellbih::build::BuilderKind;
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
        let host = BuilderKind::Host.build(s, &BihConfig::default()).unwrap();
        let ppe = BuilderKind::PpeNaive
            .build(s, &BihConfig::default())
            .unwrap();
        assert_eq!(ppe.bih, host.bih, "{}", s.name);
        let sim = ppe.simulated.expect("an emulated build reports its run");
        assert!(sim.run.cycles.0 > 0);
        assert_eq!(sim.stats.nodes as usize, host.bih.nodes.len());
    }
}

#[test]
fn an_emulated_build_gives_the_same_cycles_every_run() {
    let s = scene::load("rtperf:10000:1", None).unwrap();
    let a = BuilderKind::PpeNaive
        .build(&s, &BihConfig::default())
        .unwrap()
        .simulated
        .unwrap();
    let b = BuilderKind::PpeNaive
        .build(&s, &BihConfig::default())
        .unwrap()
        .simulated
        .unwrap();
    assert_eq!(a.run.cycles, b.run.cycles);
    assert_eq!(format!("{:?}", a.run.cores), format!("{:?}", b.run.cores));
}

/// The PPE build's time is its kernel charges plus its memory traffic.
#[test]
fn ppe_naive_time_is_kernels_plus_traffic() {
    let s = scene::load("car", None).unwrap();
    let r = BuilderKind::PpeNaive
        .build(&s, &BihConfig::default())
        .unwrap();
    let sim = r.simulated.unwrap();
    let k = cellbih::cell::CostModel::ps3();
    let compute = k.kernels.ppe_partition_item.0 * sim.stats.items_partitioned
        + k.kernels.ppe_node.0 * sim.stats.nodes;
    // Read the triangle array, write it back sorted, write the nodes.
    let traffic = k.ppe_memory_bandwidth.cycles(48 * s.len() as u64).0 * 2
        + k.ppe_memory_bandwidth.cycles(12 * sim.stats.nodes).0;
    assert_eq!(sim.run.cycles.0, compute + traffic);
}
