//! SIGINT and SIGTERM. The first asks the run to stop after the current step:
//! it writes a checkpoint and every output, says where, and the process exits
//! with 128 + the signal (130 / 143). A second signal ends the process at once.
//! Under MPI the request travels in the per-step collective
//! (`Parallel::agree`), so every rank stops at the same step even when only
//! one rank was signalled.
//!
//! Only the `talus` binary installs the handlers; a library user that does not
//! call [`install`] keeps its own signal handling.

use signal_hook::consts::{SIGINT, SIGTERM};
use signal_hook::flag;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

struct Flags {
    any: Arc<AtomicBool>,
    which: Arc<AtomicUsize>,
}

fn flags() -> &'static Flags {
    static F: OnceLock<Flags> = OnceLock::new();
    F.get_or_init(|| Flags { any: Arc::new(AtomicBool::new(false)), which: Arc::new(AtomicUsize::new(0)) })
}

/// Install the handlers for SIGINT and SIGTERM.
pub fn install() -> std::io::Result<()> {
    let f = flags();
    for sig in [SIGINT, SIGTERM] {
        // registered first, so it runs before the flag is set: exits only on the second signal
        flag::register_conditional_shutdown(sig, exit_code(sig) as i32, Arc::clone(&f.any))?;
        flag::register(sig, Arc::clone(&f.any))?;
        flag::register_usize(sig, Arc::clone(&f.which), sig as usize)?;
    }
    Ok(())
}

/// The signal received on this process, if any.
pub fn requested() -> Option<i32> {
    match flags().which.load(Ordering::Relaxed) {
        0 => None,
        s => Some(s as i32),
    }
}

/// The process exit code after a stop by `sig`: 128 + sig.
pub fn exit_code(sig: i32) -> u8 {
    (128 + sig).clamp(0, 255) as u8
}

/// The signal's name, for messages and the summary.
pub fn name(sig: i32) -> String {
    match sig {
        SIGINT => "SIGINT".into(),
        SIGTERM => "SIGTERM".into(),
        s => format!("signal {s}"),
    }
}
