//! `--threads` on the command line: a host-thread builder builds on the
//! threads asked (the serial builder's tree), the others refuse it.

use crate::common::fill;
use cellbih::registry::BuilderKind;

/// `--threads N` builds a host-thread builder on N threads (the report
/// says so) and is refused, naming the builders that take it, by a builder
/// that builds on one thread.
#[test]
fn threads_on_the_command_line() {
    for b in crate::common::host_threaded() {
        let out = crate::common::cellbih(&fill(
            "build --builder {} --threads 3 --format json",
            &[b.name()],
        ));
        crate::common::assert_ok(&out);
        let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(j["threads"], 3, "{b}");
        let serial =
            crate::common::cellbih(&crate::common::line("build --builder host --format json"));
        let s: serde_json::Value = serde_json::from_slice(&serial.stdout).unwrap();
        assert_eq!(j["quality"], s["quality"], "{b}: another tree than host's");
    }
    for b in BuilderKind::ALL.iter().filter(|b| !b.host_threads()) {
        let out = crate::common::cellbih(&["build", "--builder", b.name(), "--threads", "2"]);
        crate::common::assert_fails_with(&out, "--threads");
        for p in crate::common::host_threaded() {
            assert!(
                crate::common::stderr(&out).contains(p.name()),
                "{b}: {}",
                crate::common::stderr(&out)
            );
        }
    }
    let out = crate::common::cellbih(&crate::common::line("compare --threads 2 --format json"));
    crate::common::assert_ok(&out);
}
