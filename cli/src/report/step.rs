//! Progress of long steps on stderr, a terminal or not: a step that takes
//! more than [`QUIET_FOR`] says so while it runs, in one line (on a
//! terminal the line ends with the step's time when it is done); a quick
//! step prints nothing. Tested through the command (`cli/tests/cli/quiet.rs`:
//! a slow cast on the Cell says what it is doing on a stderr that is not a
//! terminal).

use std::sync::mpsc;
use std::time::{Duration, Instant};

/// How long a step runs before it says what it is doing.
pub const QUIET_FOR: Duration = Duration::from_millis(1500);

/// Runs `work`; if it takes longer than [`QUIET_FOR`], `what` goes to
/// stderr while it runs ("what …", and on a terminal " 3.2 s" after it
/// when done).
pub fn step<T>(what: &str, work: impl FnOnce() -> T) -> T {
    use std::io::IsTerminal;
    let terminal = std::io::stderr().is_terminal();
    let start = Instant::now();
    let (done, wait) = mpsc::channel::<()>();
    let said = std::thread::scope(|scope| {
        let watcher = scope.spawn(move || match wait.recv_timeout(QUIET_FOR) {
            Err(mpsc::RecvTimeoutError::Timeout) => {
                match terminal {
                    true => eprint!("{what} …"),
                    false => eprintln!("{what} …"),
                }
                true
            }
            _ => false,
        });
        let out = work();
        // The watcher is gone once it has spoken: then the send fails.
        let _ = done.send(());
        (watcher.join().unwrap_or(false), out)
    });
    let (said, out) = said;
    if said && terminal {
        eprintln!(" {:.1} s", start.elapsed().as_secs_f64());
    }
    out
}
