//! Ctrl-C, SIGTERM and SIGHUP: one handler per process that asks the running command to
//! stop, so that QEMU is killed and its socket folder removed on every way a user or a
//! service manager ends `supine`, not only Ctrl-C at a terminal.
//!
//! Commands that poll (replay, monitor, demo) watch the flag from [`stop_flag`] and wind
//! down through their QEMU guard. Commands that block on a device's answer (flash
//! `--qemu`) register QEMU with [`KillOnSignal`]: the handler kills it, the blocked read
//! ends, and the guard removes the folder on the way out.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;

/// The process's stop flag, set by the handler.
static STOP: OnceLock<Arc<AtomicBool>> = OnceLock::new();
/// QEMU processes the handler kills (their ids, while their guards are alive).
static TO_KILL: Mutex<Vec<u32>> = Mutex::new(Vec::new());

/// The flag that SIGINT, SIGTERM and SIGHUP set, with the handler installed on first use.
///
/// If another handler was installed first (a library caller), the signals keep whatever
/// that caller set up, and the flag is only set by [`request_stop`].
pub fn stop_flag() -> Arc<AtomicBool> {
    Arc::clone(STOP.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let _ = ctrlc::set_handler(request_stop);
        flag
    }))
}

/// Whether a stop was requested.
pub fn stop_requested() -> bool {
    STOP.get().is_some_and(|f| f.load(Ordering::Relaxed))
}

/// What the handler does: sets the flag, then kills every registered QEMU.
pub fn request_stop() {
    if let Some(flag) = STOP.get() {
        flag.store(true, Ordering::Relaxed);
    }
    let pids = TO_KILL.lock().unwrap_or_else(|p| p.into_inner());
    for &pid in pids.iter() {
        if let Ok(pid) = i32::try_from(pid) {
            let _ = kill(Pid::from_raw(pid), Signal::SIGKILL);
        }
    }
}

/// Keeps a QEMU process on the handler's kill list while alive. Drop it before the QEMU
/// guard reaps the process (declare it after the guard), so that no reused id is killed.
#[derive(Debug)]
pub struct KillOnSignal {
    pid: u32,
}

impl KillOnSignal {
    /// Registers `pid` (installing the handler if needed); kills it at once if a stop was
    /// already requested.
    pub fn new(pid: u32) -> Self {
        stop_flag();
        TO_KILL.lock().unwrap_or_else(|p| p.into_inner()).push(pid);
        if stop_requested() {
            request_stop();
        }
        Self { pid }
    }
}

impl Drop for KillOnSignal {
    fn drop(&mut self) {
        let mut pids = TO_KILL.lock().unwrap_or_else(|p| p.into_inner());
        pids.retain(|&p| p != self.pid);
    }
}
