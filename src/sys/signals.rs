//! SIGINT and SIGTERM: stopping leaves no temporary file behind.
//!
//! The rule: a file being written exists under a temporary name ([`crate::sys::atomic`]) that is
//! registered here ([`track`]) until it is renamed or removed. [`install`] starts a thread that
//! waits for SIGINT and SIGTERM (through `signal-hook`'s safe iterator); on a signal it removes
//! every registered temporary file and exits with `128 + signal` (130 for SIGINT, 143 for
//! SIGTERM), the shell's convention. It holds the registry's lock while it does, so no rename
//! can race it: a file is either complete under its own name or gone.
//!
//! A render that can stop gracefully (it saves a checkpoint, see `strahl render --resume`)
//! calls [`graceful`] while its tiles are traced: then the first signal only sets
//! [`stop_requested`] (the tiles under way finish, the checkpoint is saved, strahl ends with a
//! message), and a second signal exits at once as above.
//!
//! SIGKILL and power loss cannot be caught: a `.strahl-HOST-PID-START-N.tmp` file left beside an
//! output can only come from those, and is safe to delete (the output it was meant to replace is
//! untouched); a later run on the same host removes it ([`crate::sys::temporary`]).

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use signal_hook::consts::{SIGINT, SIGTERM};
use signal_hook::iterator::Signals;

static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
static GRACEFUL: AtomicBool = AtomicBool::new(false);
static STOP: AtomicBool = AtomicBool::new(false);

/// Starts the watcher thread (once per process; later calls do nothing).
pub fn install() -> std::io::Result<()> {
    static INSTALLED: AtomicBool = AtomicBool::new(false);
    if INSTALLED.swap(true, Ordering::SeqCst) {
        return Ok(());
    }
    let mut signals = Signals::new([SIGINT, SIGTERM])?;
    std::thread::Builder::new().name("strahl-signals".into()).spawn(move || {
        for signal in signals.forever() {
            if GRACEFUL.load(Ordering::SeqCst) && !STOP.swap(true, Ordering::SeqCst) {
                continue; // the render stops at its next tile and saves its checkpoint
            }
            let temporaries = TEMPORARIES.lock().unwrap_or_else(|p| p.into_inner());
            for path in temporaries.iter() {
                let _ = std::fs::remove_file(path);
            }
            // Exit with the lock held: no temporary file can be renamed after this point.
            std::process::exit(128 + signal);
        }
    })?;
    Ok(())
}

/// While `on`, the first signal only sets [`stop_requested`] instead of exiting.
pub fn graceful(on: bool) {
    GRACEFUL.store(on, Ordering::SeqCst);
}

/// Set by the first signal of a graceful stretch.
pub fn stop_requested() -> &'static AtomicBool {
    &STOP
}

/// Registers a temporary file, to be removed if a signal ends the process.
pub fn track(path: &Path) {
    TEMPORARIES.lock().unwrap_or_else(|p| p.into_inner()).push(path.to_path_buf());
}

/// Runs `finish` (renames or removals of `paths`) and forgets `paths`, with the registry
/// locked, so a signal cannot interrupt in between (a signal that arrives meanwhile is handled
/// once `finish` is done: two outputs renamed in one `finish` are both renamed, or neither).
pub fn untrack<T>(paths: &[&Path], finish: impl FnOnce() -> T) -> T {
    let mut temporaries = TEMPORARIES.lock().unwrap_or_else(|p| p.into_inner());
    let result = finish();
    temporaries.retain(|p| !paths.contains(&p.as_path()));
    result
}
