//! The readers under fire: arbitrary bytes and mutated valid files fed to
//! the OBJ loader (plain and gzip'd) and to the rays CSV reader. Never a
//! panic, never a hang: a scene (or rays), or an error that names the file —
//! and the line, wherever the fault sits on one.

use std::io::Write;

use cellbih::rays_csv::read_rays;
use cellbih::scene::{SceneError, load_obj_file, parse_obj};
use proptest::prelude::*;

const VALID_OBJ: &str = "# two objects\no a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
f 1 2 3\nf 2 4 3\ng b\nv 0 0 1e15\nv -1.5e-15 2 1\nv 3 3 3\nf -3 -2 -1\nf 1/1 5/2/3 7//1 2\n";

const VALID_RAYS: &str = "ox,oy,oz,dx,dy,dz,tmin,tmax\n0,0,1,0,0,-1,0,inf\n\
0.25,0.25,-1,0,-0.0,2,0.5,10\n1e15,-1e-15,0,1,1,1,0,1e300\n";

/// Bytes the mutations splice in: the characters that matter to both
/// formats, and some that do not.
const PIECES: &[&str] = &[
    "v",
    "f",
    "o",
    "g",
    " ",
    "\n",
    "\r\n",
    "/",
    "-",
    ".",
    "0",
    "1",
    "9",
    "e",
    "e38",
    "e-45",
    "nan",
    "inf",
    "#",
    ",",
    "\u{feff}",
    "\u{0}",
    "\u{ff}",
    "99999999999999999999",
    "-0",
    "\t",
];

/// A mutation: at `at` (a fraction of the length), delete `del` bytes and
/// insert piece number `piece`.
fn mutations() -> impl Strategy<Value = Vec<(f64, usize, usize)>> {
    prop::collection::vec((0.0..1.0f64, 0usize..4, 0..PIECES.len()), 1..8)
}

fn mutate(text: &str, muts: &[(f64, usize, usize)]) -> Vec<u8> {
    let mut b = text.as_bytes().to_vec();
    for &(at, del, piece) in muts {
        let i = ((at * b.len() as f64) as usize).min(b.len());
        let j = (i + del).min(b.len());
        b.splice(i..j, PIECES[piece].bytes());
    }
    b
}

/// The error names `name`, and the line when it has one.
fn names_the_file(e: &SceneError, name: &str) -> Result<(), TestCaseError> {
    let msg = e.to_string();
    prop_assert!(msg.starts_with(name), "'{msg}' does not name {name}");
    if let SceneError::Malformed { line, .. } = e {
        prop_assert!(*line >= 1);
        let line_tag = format!("{name}:{line}:");
        prop_assert!(msg.starts_with(&line_tag), "'{msg}'");
    }
    Ok(())
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(bytes).unwrap();
    gz.finish().unwrap()
}

fn check_obj_file(bytes: &[u8], file: &str) -> Result<(), TestCaseError> {
    let dir = std::env::temp_dir().join(format!("cellbih-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(file);
    std::fs::write(&path, bytes).unwrap();
    let r = load_obj_file(&path);
    if let Err(e) = &r {
        names_the_file(e, &path.display().to_string())?;
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_are_a_scene_or_an_error_naming_the_file(
        bytes in prop::collection::vec(any::<u8>(), 0..400)
    ) {
        if let Err(e) = parse_obj("fuzz.obj", &bytes) {
            names_the_file(&e, "fuzz.obj")?;
        }
        if let Err(e) = read_rays("fuzz.csv", &bytes[..]) {
            prop_assert!(e.to_string().starts_with("fuzz.csv:"), "{e}");
        }
    }

    #[test]
    fn mutated_obj_files_load_or_name_the_file_and_line(muts in mutations()) {
        let bytes = mutate(VALID_OBJ, &muts);
        match parse_obj("m.obj", &bytes) {
            Ok(s) => {
                prop_assert!(!s.is_empty());
                prop_assert!(s.triangles.iter().all(|t| t.v.iter().all(|p| p.is_finite())));
            }
            Err(e) => names_the_file(&e, "m.obj")?,
        }
    }

    #[test]
    fn gzip_files_whole_cut_or_corrupt_load_or_name_the_file(
        muts in mutations(),
        cut in 0.0..1.0f64,
        flip in any::<(usize, u8)>(),
    ) {
        let gz = gzip(&mutate(VALID_OBJ, &muts));
        check_obj_file(&gz, "whole.obj.gz")?;
        check_obj_file(&gz[..(cut * gz.len() as f64) as usize], "cut.obj.gz")?;
        let mut bad = gz.clone();
        let i = 2 + flip.0 % (bad.len() - 2);
        bad[i] ^= flip.1 | 1;
        check_obj_file(&bad, "flipped.obj.gz")?;
    }

    #[test]
    fn mutated_ray_files_read_or_name_the_file_and_line(muts in mutations()) {
        let bytes = mutate(VALID_RAYS, &muts);
        match read_rays("m.csv", &bytes[..]) {
            Ok(rays) => {
                for r in rays {
                    prop_assert!(r.origin.is_finite() && r.dir.is_finite());
                    prop_assert!(r.dir.abs().max_element() >= f64::MIN_POSITIVE);
                    prop_assert!(!r.tmin.is_nan() && !r.tmax.is_nan());
                }
            }
            Err(e) => {
                let msg = e.to_string();
                let line: Option<usize> = msg
                    .strip_prefix("m.csv:")
                    .and_then(|rest| rest.split(':').next())
                    .and_then(|n| n.parse().ok());
                prop_assert!(line.is_some_and(|l| l >= 1), "'{msg}' names no line");
            }
        }
    }
}

/// The seeds of the mutations must reach both outcomes, or the properties
/// above say little: some mutated files still load, some do not.
#[test]
fn mutations_reach_both_outcomes() {
    let (mut ok, mut err) = (0, 0);
    let mut rng = cellbih::scene::SplitMix64::new(5);
    for _ in 0..400 {
        let muts: Vec<(f64, usize, usize)> = (0..1 + rng.next_u64() % 3)
            .map(|_| {
                (
                    rng.next_f32() as f64,
                    (rng.next_u64() % 3) as usize,
                    (rng.next_u64() % PIECES.len() as u64) as usize,
                )
            })
            .collect();
        match parse_obj("m.obj", &mutate(VALID_OBJ, &muts)) {
            Ok(_) => ok += 1,
            Err(_) => err += 1,
        }
    }
    assert!(ok > 20 && err > 20, "{ok} loaded, {err} failed");
}
