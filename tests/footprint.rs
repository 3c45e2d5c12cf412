//! Memory modelled to the scene: every emulated build reports its main
//! memory by purpose (every buffer named, none unknown), its local stores'
//! high-water marks, and a level-by-level build never needs more
//! WorkAPPE than the bound it is sized by; a build that does not fit fails
//! naming the buffer and the sizes.

use cellbih::bih::BihConfig;
use cellbih::cell::CellConfig;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene;
use cellbih::spe::footprint::{Purpose, widest_level, work_ppe_jobs};
use cellbih::strategy::Knobs;

#[test]
fn every_buffer_has_a_purpose_and_the_sums_add_up() {
    for name in ["default", "car", "rtperf:20000"] {
        let s = scene::load(name, None).unwrap();
        for leaf in [1, 12] {
            let cfg = BihConfig {
                leaf_size: leaf,
                ..BihConfig::default()
            };
            for &b in BuilderKind::ALL.iter().filter(|b| b.emulated()) {
                let r = Build::new(b).with_tree(cfg).run(&s).unwrap();
                let sim = r.simulated.unwrap();
                let f = sim.footprint;
                assert!(
                    f.unknown.is_empty(),
                    "{b}: buffers without a purpose: {:?}",
                    f.unknown
                );
                let sum: u64 = f.by_purpose.iter().map(|(_, b)| b).sum();
                assert!(
                    sum <= f.total && f.total - sum < 128 * 64,
                    "{b}: {sum} of {}",
                    f.total
                );
                // At least the records, 48 bytes each, and the tree's nodes.
                assert!(
                    f.bytes(Purpose::TriangleRecords) >= 48 * s.len() as u64,
                    "{b}"
                );
                let tree = 12 * r.bih.nodes.len() as u64;
                assert!(f.bytes(Purpose::Nodes) >= tree, "{b}");
                assert_eq!(f.unused_node_bytes, f.bytes(Purpose::Nodes) - tree, "{b}");
                // Each SPE the build used holds buffers beyond the code and
                // stack reserved in its local store; the others hold none.
                let reserved = CellConfig::ps3().ls_reserved_bytes;
                assert_eq!(f.ls_high_water.len(), 6);
                for (spe, &h) in f.ls_high_water.iter().enumerate() {
                    match spe < sim.spes_used {
                        true => assert!(h > reserved + 16 * 1024, "{b}: {:?}", f.ls_high_water),
                        false => assert_eq!(h, reserved, "{b}: SPE {spe} unused"),
                    }
                }
                // The widest level within the bound WorkAPPE is sized by.
                assert!(
                    f.work_ppe_needed <= work_ppe_jobs(s.len(), leaf) as u64,
                    "{b}"
                );
                assert_eq!(f.work_ppe_needed, widest_level(&r.bih));
            }
        }
    }
}

/// the cooperative top partitions in place, so a builder that
/// offers `--coop-partition` keeps one array of triangle records by
/// default (as the baseline does) and two only with `scratch`; and the
/// ObjectArena pool is sized to the tree (under a node a triangle here,
/// six SPEs' part-filled blocks included, against the 2n + 1 slots it
/// used to hold).
#[test]
fn the_in_place_top_keeps_one_record_array_and_the_pool_fits_the_tree() {
    let s = scene::load("rtperf:200000", None).unwrap();
    let cell = CellConfig {
        cost: cellbih::cell::CostModel::functional(),
        checked: false,
        ..CellConfig::ps3()
    };
    let record = 48 * s.len() as u64;
    let mut checked = 0;
    for &b in BuilderKind::ALL.iter().filter(|b| b.multi_spe()) {
        let f = |knobs: &Knobs| {
            let r = Build::new(b).on(&cell).with_knobs(knobs).run(&s);
            r.unwrap().simulated.unwrap().footprint
        };
        let nodes = f(&Knobs::default()).bytes(Purpose::Nodes);
        assert!(nodes < 12 * s.len() as u64, "{b}: {nodes} bytes of nodes");
        if b.knob("coop-partition").is_err() {
            continue;
        }
        let records = |k: &Knobs| f(k).bytes(Purpose::TriangleRecords);
        assert_eq!(records(&Knobs::default()), record, "{b}: in place");
        let mut scratch = Knobs::default();
        b.set_knob(&mut scratch, "coop-partition", "scratch")
            .unwrap();
        assert_eq!(records(&scratch), 2 * record, "{b}: scratch");
        checked += 1;
    }
    assert!(checked > 0, "no builder offers --coop-partition");
}
