//! Inputs a new user gets wrong, and outputs that must not collide: every
//! line of a text input is bounded (a file without newlines is refused by
//! its line, never read until memory runs out), two outputs of one run
//! never name one file, a file-size limit is an error that cleans up.

mod common;

use std::time::Duration;

use common::{assert_fails_with, cellbih, run_limited, stderr, tmp};

const EXE: &str = env!("CARGO_BIN_EXE_cellbih");

#[test]
fn a_text_input_without_newlines_is_refused_by_its_line() {
    let limit = Duration::from_secs(20);
    let out = run_limited(
        EXE,
        &["raycast", "--rays", "/dev/zero", "--out", "-"],
        limit,
    );
    assert_fails_with(&out, "/dev/zero:1: it is not text");
    let out = run_limited(EXE, &["info", "--scene", "/dev/zero"], limit);
    assert_fails_with(&out, "it is not text: it starts with NUL bytes only");

    // A line of two megabytes, after a good first line.
    let long = tmp("long-line.csv");
    let mut text = b"ox,oy,oz,dx,dy,dz,tmin,tmax\n".to_vec();
    text.extend(std::iter::repeat_n(b'1', 2 << 20));
    std::fs::write(&long, &text).unwrap();
    let out = run_limited(
        EXE,
        &["raycast", "--rays", long.to_str().unwrap(), "--out", "-"],
        limit,
    );
    assert_fails_with(&out, ":2: longer than 1 MiB without a newline");
    let obj = tmp("long-line.obj");
    let mut text = b"v 0 0 0\n".to_vec();
    text.extend(std::iter::repeat_n(b'#', 2 << 20));
    std::fs::write(&obj, &text).unwrap();
    let out = run_limited(EXE, &["info", "--scene", obj.to_str().unwrap()], limit);
    assert_fails_with(&out, "long-line.obj:2: a line longer than 1 MiB");
    assert!(
        !stderr(&out).contains("memory allocation"),
        "{}",
        stderr(&out)
    );

    // UTF-32 is named as such (it was called UTF-16).
    let utf32 = tmp("utf32.obj");
    let text: Vec<u8> = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
        .bytes()
        .flat_map(|b| [b, 0, 0, 0])
        .collect();
    std::fs::write(&utf32, text).unwrap();
    let out = cellbih(&["info", "--scene", utf32.to_str().unwrap()]);
    assert_fails_with(&out, "it is UTF-32 text");
}
