//! Arguments the commands refuse before any work, by name: sizes past
//! their limits, quality knobs a builder does not build, strategy knobs it
//! does not take (every knob of the registry with every builder), options
//! that need another (`--sah-bins` without `--split sah`, a timing model
//! with `--mode functional`), small inputs that deserve a plain answer; and
//! help that says what every option does.

use std::time::Duration;

use crate::common::{
    assert_fails_with, assert_ok, assert_says, cellbih, fill, line, one_ray, run_limited, stderr,
    stdout, text_file, tmp,
};

#[test]
fn sizes_past_their_limits_are_refused_at_once() {
    let exe = env!("CARGO_BIN_EXE_cellbih");
    let limit = Duration::from_secs(20);
    for (args, msg) in [
        (
            &["info", "--scene", "rtperf:4000000000"][..],
            "rtperf takes at most 50000000 triangles",
        ),
        (
            &["info", "--scene", "rtperf:18446744073709551615"][..],
            "rtperf takes at most 50000000 triangles",
        ),
        (
            &line("update --scene car --animation car --frames 1000000000")[..],
            "1000000000 is not between 0 and 100000",
        ),
        (
            &line("update --scene car --animation car --frames 18446744073709551615")[..],
            "is not between 0 and 100000",
        ),
        (
            &["build", "--max-depth", "127"][..],
            "127 is not between 0 and 126",
        ),
        (
            &["build", "--leaf-size", "0"][..],
            "0 is less than 1: give a whole number of at least 1",
        ),
        (&["build", "--spes", "17"][..], "17 is not between 1 and 16"),
        // A knob's range is its table's, checked once, when it is set.
        (
            &line("build --builder spe_bfs_private --deal-per-spe 17")[..],
            "builder spe_bfs_private: --deal-per-spe 17: auto or 1 to 16",
        ),
        (
            &line("build --builder spe_morton --digit-bits 3")[..],
            "--digit-bits 3: 4 to 11",
        ),
        (
            &line("build --builder spe_morton --key-bits 48")[..],
            "--key-bits is auto, 16, 24, 32 or 64, not '48'",
        ),
        (
            &line("build --builder ppe_approx --approx-cells 0")[..],
            "--approx-cells 0: 1 to 1024",
        ),
        (
            &line("build --builder spe_bfs_shared --agglomerate 0")[..],
            "--agglomerate 0: 1 to 256",
        ),
    ] {
        assert_fails_with(&run_limited(exe, args, limit), msg);
    }
}

#[test]
fn help_says_what_every_option_does() {
    let top = stdout(&cellbih(&line("--help")));
    assert!(
        top.contains("With no command, runs the demo") && top.contains("cellbih-demo.png"),
        "{top}"
    );
    for (cmd, options) in [
        ("raycast", &["--rays", "--out", "--data"][..]),
        ("render", &line("--out --heatmap --width --height")[..]),
        ("update", &["--frames", "--seed"][..]),
        ("build", &["--trace", "--max-depth"][..]),
    ] {
        let help = stdout(&cellbih(&[cmd, "--help"]));
        for opt in options {
            // Each option's line is followed by words, not by the next option.
            let line = help
                .lines()
                .find(|l| l.trim_start().starts_with(opt))
                .unwrap_or_else(|| panic!("{cmd} --help has no {opt}"));
            let described = line.split_whitespace().count() > 2
                || help
                    .lines()
                    .skip_while(|l| !l.trim_start().starts_with(opt))
                    .nth(1)
                    .is_some_and(|next| !next.trim_start().starts_with('-'));
            assert!(described, "{cmd} {opt} has no help text:\n{help}");
        }
    }
    assert!(stdout(&cellbih(&line("build --help"))).contains("at most 126"));
    assert!(stdout(&cellbih(&line("build --help"))).contains("bytes"));
    let builders = stdout(&cellbih(&line("builders --help")));
    assert!(!builders.contains("--data"), "{builders}");
}

/// A quality knob a builder does not build is refused by name, saying which
/// builders build it; out-of-range knob values are refused by the parser.
#[test]
fn quality_knobs_a_builder_does_not_build_are_refused_by_name() {
    for knob in [&["--split", "sah"][..], &["--empty-cut", "10"]] {
        let mut args = vec!["build", "--builder", "spe_morton"];
        args.extend_from_slice(knob);
        let out = cellbih(&args);
        assert_fails_with(&out, "builder spe_morton builds the paper's split choice");
        // Every builder that builds the setting is named, from the registry.
        let cfg = match knob[0] {
            "--split" => cellbih::bih::BihConfig::SAH_CUT,
            _ => cellbih::bih::BihConfig {
                empty_cut: Some(10),
                ..Default::default()
            },
        };
        for b in cellbih::registry::BuilderKind::ALL
            .iter()
            .filter(|b| b.builds(&cfg))
        {
            assert!(
                stderr(&out).contains(&format!("{b},"))
                    || stderr(&out).contains(&format!("{b} build")),
                "{b}: {}",
                stderr(&out)
            );
        }
    }
    // Those that build them are named, in the registry's order, the SPE
    // builders among them.
    let out = cellbih(&line("build --builder ppe_approx --split sah"));
    let named: Vec<&str> = (cellbih::registry::BuilderKind::ALL.iter())
        .filter(|b| b.builds(&cellbih::bih::BihConfig::SAH_CUT))
        .map(|b| b.name())
        .collect();
    assert!(named.contains(&"spe_bfs"), "{named:?}");
    let named = format!("{} build", named.join(", "));
    assert_says(&out, &named);
    for bad in [
        &["--empty-cut", "100"][..],
        &["--empty-cut", "0"],
        &["--sah-bins", "1"],
    ] {
        let mut args = vec!["build"];
        args.extend_from_slice(bad);
        assert!(!cellbih(&args).status.success(), "{bad:?} was accepted");
    }
    let out = cellbih(&line(
        "build --builder ppe_naive --split sah --empty-cut 10",
    ));
    assert_ok(&out);
    assert!(stdout(&out).contains("simulated"), "{}", stdout(&out));
}

/// Binned SAH's options without `--split sah` are refused, not ignored;
/// with it, `--sah-above` builds (and the report names the setting).
#[test]
fn binned_sah_options_need_split_sah() {
    for knob in [&["--sah-above", "64"][..], &["--sah-bins", "8"]] {
        let mut args = vec!["build"];
        args.extend_from_slice(knob);
        assert_fails_with(&cellbih(&args), "apply to --split sah only");
    }
    let out = cellbih(&line("build --split sah --sah-above 64"));
    assert_ok(&out);
}

/// The functional mode has no timing: the options that choose a timing
/// model or its rates are refused with it, by name, even when they give
/// the default.
#[test]
fn timing_models_are_refused_in_the_functional_mode() {
    let given = [
        ["--model", "legacy"],
        ["--model", "measured"],
        ["--mailboxes", "ps3-kernel"],
        ["--mailboxes", "raw"],
        ["--code", "paper"],
        ["--rate", "spe_job=100"],
    ];
    for extra in given {
        let mut args = vec!["build", "--builder", "spe_bfs", "--mode", "functional"];
        args.extend(extra);
        let out = cellbih(&args);
        assert_fails_with(
            &out,
            &format!(
                "--mode functional has no timing: {} does not apply",
                extra[0]
            ),
        );
    }
}

/// A rate is set by the name `cellbih rates` lists, from the command line
/// or a file, and moves the figure; a name that is no rate, a value that
/// is not one, or a file line without `=` is refused by name before any
/// build; a command that charges no kernel refuses a kernel's rate.
#[test]
fn rates_are_set_by_name_and_refused_when_they_name_nothing() {
    let ms = |extra: &[&str]| -> f64 {
        let mut args = vec!["build", "--builder", "spe_bfs", "--format", "json"];
        args.extend(extra);
        let out = cellbih(&args);
        assert_ok(&out);
        let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        doc["simulated_ms"].as_f64().unwrap()
    };
    let base = ms(&[]);
    assert!(ms(&["--rate", "spe_partition_item=200"]) > base);
    let (compiled, tuned) = (ms(&["--code", "compiled"]), ms(&["--code", "tuned"]));
    assert!(tuned < base / 2.0);
    // Compiled C: dearer than tuned SIMD, a little cheaper than the
    // paper's code (3.49 against 4 × each count).
    assert!(
        tuned < compiled && compiled < base,
        "{tuned} {compiled} {base}"
    );
    assert!(ms(&["--rate", "memory_shared_bandwidth=5"]) >= base);
    let file = text_file(
        "slow.rates",
        "# slower partitions\nspe_partition_item = 200\n",
    );
    assert_eq!(
        ms(&["--rates", &file]),
        ms(&["--rate", "spe_partition_item=200"])
    );
    // --rate after the file wins.
    assert_eq!(
        ms(&["--rates", &file, "--rate", "spe_partition_item=161"]),
        base
    );
    for (extra, says) in [
        (
            vec!["--rate", "spe_jbo=1"],
            "no rate named spe_jbo (did you mean spe_job?)",
        ),
        (vec!["--rate", "spe_job"], "--rate spe_job: NAME=VALUE"),
        (
            vec!["--rate", "spe_job=fast"],
            "spe_job=fast: a whole number of cycles",
        ),
        (vec!["--rate", "memory_bandwidth=0"], "a bandwidth in GB/s"),
    ] {
        let mut args = vec!["build", "--builder", "spe_bfs"];
        args.extend(extra);
        assert_fails_with(&cellbih(&args), says);
    }
    let bad = text_file("bad.rates", "spe_job 100\n");
    assert_fails_with(
        &cellbih(&["build", "--builder", "spe_bfs", "--rates", &bad]),
        "bad.rates:1: 'spe_job 100': a line is NAME = VALUE",
    );
}

/// Every strategy knob of the registry, given to every builder: built by
/// the builders whose table holds it, refused by the others with an error
/// naming the knob and the builders that take it, nothing built.
#[test]
fn a_knob_is_taken_by_the_builders_that_declare_it_and_refused_by_the_rest() {
    use cellbih::registry::BuilderKind;
    let mut knobs: Vec<&cellbih::strategy::Knob> = (BuilderKind::ALL.iter())
        .flat_map(|b| b.knobs().iter().copied())
        .collect();
    knobs.sort_by_key(|k| k.name);
    knobs.dedup_by_key(|k| k.name);
    assert!(!knobs.is_empty(), "the registry declares no knob");
    for &b in BuilderKind::ALL {
        for k in &knobs {
            let flag = format!("--{}", k.name);
            let mut args = vec!["build", "--scene", "default", "--builder", b.name()];
            if b.emulated() {
                args.extend(["--mode", "functional"]);
            }
            args.push(flag.as_str());
            if !k.is_flag() {
                args.push(k.sweep[0]);
            }
            let out = cellbih(&args);
            let takes = b.knobs().iter().any(|t| t.name == k.name);
            if takes {
                assert!(out.status.success(), "{b} {flag}: {}", stderr(&out));
                continue;
            }
            let err = stderr(&out);
            assert!(!out.status.success(), "{b} took {flag} silently");
            assert!(
                stdout(&out).is_empty(),
                "{b} {flag} built: {}",
                stdout(&out)
            );
            assert!(err.contains(&flag), "{b} {flag}: {err}");
            for taker in BuilderKind::ALL.iter().filter(|t| t.knobs().contains(k)) {
                assert!(
                    err.contains(taker.name()),
                    "{b} {flag} names no {taker}: {err}"
                );
            }
        }
    }
}

/// Small words: a decimal cut-off says it wants a whole
/// percentage; a rays file's control bytes are escaped, not echoed to the
/// terminal; a file named like a built-in scene is not read silently.
#[test]
fn small_inputs_get_plain_answers() {
    let out = cellbih(&line("build --empty-cut 2.5"));
    assert_fails_with(&out, "a whole percentage is wanted (1 to 99), not 2.5");
    let rays = tmp("control.rays.csv");
    std::fs::write(
        &rays,
        "ox,oy,oz,dx,dy,dz,tmin,tmax\n0,0,\x1b[31m5,0,0,-1,0,inf\n",
    )
    .unwrap();
    let hits = tmp("control.hits.csv");
    let out = cellbih(&fill(
        "raycast --rays {} --out {}",
        &[rays.to_str().unwrap(), hits.to_str().unwrap()],
    ));
    assert_fails_with(&out, "\\u{1b}[31m5");
    assert!(
        !stderr(&out).contains('\x1b'),
        "a raw escape byte in: {}",
        stderr(&out)
    );
    let dir = tmp("shadow");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("car"), "not a mesh").unwrap();
    let out = crate::common::command(env!("CARGO_BIN_EXE_cellbih"))
        .args(["info", "--scene", "car"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_says(&out, "the file car here is not read");
}

/// An `rtperf:N` scene whose triangle records alone do not fit the
/// emulated memory is refused before the scene is made,
/// by every command that builds on the Cell; one that fits is not.
#[test]
fn a_procedural_scene_too_big_for_the_emulated_memory_is_refused_up_front() {
    let too_big = [
        "--scene",
        "rtperf:5000000",
        "--builder",
        "spe_bfs",
        "--memory-mib",
        "64",
    ];
    for cmd in [
        &["build"][..],
        &["render", "--out", "never.png"][..],
        &["frame", "--animation", "rtperf"][..],
    ] {
        let mut args = cmd.to_vec();
        args.extend(too_big);
        assert_fails_with(
            &cellbih(&args),
            "rtperf:5000000: building its 5000000 triangles takes at least 333 MiB (their records, spe_bfs's buffers, the fewest nodes), more than the emulated Cell's 64 MiB (--memory-mib): nothing built",
        );
    }
    let fits = cellbih(&line(
        "build --scene rtperf:1000 --builder spe_bfs --memory-mib 1",
    ));
    assert_ok(&fits);
}

/// A cast on the Cell that its main memory cannot hold is refused before
/// any work when even its lower bound (triangles, rays, hits) does not fit,
/// and after the build, before the cast, when the tree's nodes tip it over;
/// both name the cast and `--memory-mib`.
#[test]
fn a_cast_too_big_for_the_emulated_memory_is_refused_naming_it() {
    let out = cellbih(&line(
        "render --scene rtperf:6000000 --on-cell --out never.png",
    ));
    assert_fails_with(
        &out,
        "rtperf:6000000: the cast on the Cell (480000 rays) needs at least 319 MiB",
    );
    assert!(stderr(&out).contains("--memory-mib: above 319 up): nothing built or cast"));
    assert!(!std::path::Path::new("never.png").exists());

    // The default scene's host tree: enough rays that everything but the
    // nodes fits in 1 MiB, and the nodes do not.
    let s = cellbih::scene::load("default", None).unwrap();
    let nodes = cellbih::registry::Build::new(cellbih::registry::BuilderKind::HOST)
        .run(&s)
        .unwrap()
        .bih
        .nodes
        .len();
    let mib = 1 << 20;
    let rays = (1..200_000)
        .find(|&k| {
            cellbih::cast::memory_needed(0, s.len(), k, Default::default()) <= mib
                && cellbih::cast::memory_needed(nodes, s.len(), k, Default::default()) > mib
        })
        .expect("a ray count between the bounds");
    let mut csv = String::from("ox,oy,oz,dx,dy,dz,tmin,tmax\n");
    for _ in 0..rays {
        csv.push_str("0,1,8,0,0,-1,0,inf\n");
    }
    let file = tmp("cast-memory.rays.csv");
    std::fs::write(&file, csv).unwrap();
    let hits = tmp("cast-memory.hits.csv");
    let out = cellbih(&fill(
        "raycast --on-cell --memory-mib 1 --rays {} --out {}",
        &[file.to_str().unwrap(), hits.to_str().unwrap()],
    ));
    assert_fails_with(
        &out,
        &format!("default: the cast on the Cell ({rays} rays) needs 2 MiB"),
    );
    assert_says(
        &out,
        "(--memory-mib: from 2 up): the tree was built, nothing cast",
    );
    assert!(!hits.exists());
}

/// An option of the emulated Cell where nothing runs on it — a builder of
/// the host without `--on-cell` — is refused, naming it; with `--on-cell`
/// the cast uses it. `--deep-stop-below` needs the deep update.
#[test]
fn options_that_do_not_apply_are_refused_by_name() {
    let cell_options: [&[&str]; 5] = [
        &["--spes", "8"],
        &["--memory-mib", "1"],
        &["--mode", "timed"],
        &["--model", "legacy"],
        &["--mailboxes", "ps3-kernel"],
    ];
    let rays = one_ray("apply.rays.csv");
    let hits = tmp("apply.hits.csv");
    let (rays, hits) = (rays.as_str(), hits.to_str().unwrap());
    for b in cellbih::registry::BuilderKind::ALL
        .iter()
        .filter(|b| !b.emulated())
    {
        for option in cell_options {
            let name = option[0];
            for cmd in [
                &["build"][..],
                &["raycast", "--rays", rays, "--out", hits][..],
                &line("update --animation rtperf --frames 1")[..],
            ] {
                let mut args = cmd.to_vec();
                args.extend(["--builder", b.name()]);
                args.extend(option);
                let out = cellbih(&args);
                assert_fails_with(&out, name);
                assert_fails_with(&out, "nothing here runs on the emulated Cell");
            }
        }
        // Cast on the Cell, the Cell's options apply.
        let out = cellbih(&fill(
            "raycast --on-cell --rays {} --out {} --builder {} --spes 2",
            &[rays, hits, b.name()],
        ));
        assert_ok(&out);
    }
    let out = cellbih(&line("update --animation rtperf --deep-stop-below 10"));
    assert_fails_with(&out, "--deep-stop-below applies to --strategy deep only");
    let out = cellbih(&line(
        "update --animation rtperf --frames 1 --strategy deep --deep-stop-below 10",
    ));
    assert_ok(&out);
    // `--find-moved` needs a local update, and `spe` the SPEs.
    let out = cellbih(&line(
        "update --animation rtperf --strategy deep --find-moved spe",
    ));
    assert_fails_with(&out, "--find-moved applies to local updates");
    let out = cellbih(&line(
        "frame --animation rtperf --policy rebuild --find-moved ppe",
    ));
    assert_fails_with(&out, "here --policy rebuild");
    let out = cellbih(&line("update --animation rtperf --find-moved spe"));
    assert_fails_with(&out, "--find-moved spe: builder host builds on the host");
    let out = cellbih(&line("frame --animation rtperf --find-moved gpu"));
    assert_fails_with(
        &out,
        "invalid value 'gpu' for '--find-moved <FIND_MOVED>' [possible values: ppe, spe]",
    );
    assert_eq!(out.status.code(), Some(2));
    let out = cellbih(&line(
        "frame --animation rtperf --frames 1 --width 16 --height 16 --policy auto --find-moved spe",
    ));
    assert_ok(&out);
}

/// `frame` runs with its defaults: the baseline builds on the Cell.
#[test]
fn frame_runs_with_its_defaults() {
    let out = cellbih(&line(
        "frame --scene car --animation car --frames 1 --width 16 --height 16",
    ));
    assert_ok(&out);
    assert!(stdout(&out).contains("builder spe_bfs"), "{}", stdout(&out));
}

/// `--camera`: a viewpoint of another scene, a point that is not three
/// finite numbers, an eye on the point it looks at, a field of view out
/// of range — each refused at once, naming it; a camera given is named in
/// the settings line and changes the rays measured.
#[test]
fn cameras_are_checked_and_named() {
    let exe = env!("CARGO_BIN_EXE_cellbih");
    let limit = Duration::from_secs(20);
    for (camera, msg) in [
        ("atrium", "a viewpoint of sponza-dabrovic, not of default"),
        ("hall", "no such viewpoint"),
        ("1,2:3,4,5", "is not three finite numbers"),
        (
            "0,0,0:0,0,0",
            "the eye and the point looked at are the same",
        ),
        ("0,0,9:0,0,0:180", "degrees above 0, below 180"),
    ] {
        for command in [&["build"][..], &["render", "--out", "x.png"], &["compare"]] {
            let mut args = command.to_vec();
            args.extend(["--camera", camera]);
            let out = run_limited(exe, &args, limit);
            assert!(!out.status.success(), "{args:?}");
            assert!(stderr(&out).contains(msg), "{args:?}: {}", stderr(&out));
        }
    }
    let ray_line = |camera: &str| {
        let out = cellbih(&fill(
            "build --scene car --camera {} --format json",
            &[camera],
        ));
        assert_ok(&out);
        let doc: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
        assert_eq!(doc["settings"]["camera"], camera, "{doc}");
        // Nodes and triangles a ray (not the rays a second: a host timing).
        let p = &doc["rays"]["primary"];
        (
            p["nodes"].as_f64().unwrap(),
            p["triangles"].as_f64().unwrap(),
        )
    };
    assert_eq!(
        ray_line("default"),
        ray_line("framing"),
        "the car has no viewpoint of its own"
    );
    assert_ne!(ray_line("framing"), ray_line("0,0,0:1,0,0:60"));
}

/// Counts are said in words ("1 ray", "2 rays"), and a value an option
/// cannot take exits with status 2, wherever it is checked.
#[test]
fn counts_in_words_and_bad_values_exit_2() {
    let out = cellbih(&line(
        "raycast --rays - --out - --on-cell --packet 2x2 --tile-rays 1",
    ));
    assert_fails_with(&out, "--packet 2x2: a tile's 1 ray (--tile-rays) must be");
    assert_eq!(out.status.code(), Some(2));
    for args in [
        "render --on-cell --out x.png --cache-ways 0",
        "render --on-cell --out x.png --cache-ways 3",
        "frame --scene car --animation car --build-spes 0",
        "frame --scene car --animation car --build-spes 7",
        "frame --scene car --animation car --find-moved junk",
    ] {
        let out = cellbih(&line(args));
        assert_eq!(out.status.code(), Some(2), "{args}: {}", stderr(&out));
    }
}
