//! Scratch directories that are removed on every way out: when dropped, by
//! [`clean_up_on_termination_signals`] on Ctrl-C, `SIGTERM` or `SIGHUP`,
//! and, for one left by a process that was killed outright, by the next
//! process that makes a scratch directory of the same kind.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Scratch directories and child processes to remove or kill when a
/// termination signal arrives.
static LIVE: Mutex<Live> = Mutex::new(Live {
    dirs: Vec::new(),
    children: Vec::new(),
});

struct Live {
    dirs: Vec<PathBuf>,
    children: Vec<u32>,
}

/// Set once a termination signal has arrived: the signal thread is cleaning
/// up and will exit with `128 + signal`.
static TERMINATING: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether a termination signal is being handled. A program about to exit
/// on its own (a candidate it was waiting for was just killed, say) waits
/// instead, so that the exit code is the signal's: see
/// [`exit_unless_terminating`].
pub fn terminating() -> bool {
    TERMINATING.load(Ordering::SeqCst)
}

/// `std::process::exit(code)`, unless a termination signal is being
/// handled: then the signal's thread exits (with `128 + signal`) and this
/// thread waits for it.
pub fn exit_unless_terminating(code: i32) -> ! {
    while terminating() {
        std::thread::park_timeout(std::time::Duration::from_secs(1));
    }
    std::process::exit(code)
}

fn live() -> std::sync::MutexGuard<'static, Live> {
    LIVE.lock().unwrap_or_else(|e| e.into_inner())
}

/// A directory `KIND-PID-N` in the system's temporary directory, removed
/// with everything in it when dropped.
#[derive(Debug)]
pub struct ScratchDir {
    path: PathBuf,
}

impl ScratchDir {
    /// A new, empty scratch directory for `kind` (a name like
    /// `mfcbeam-conform`). Directories of the same kind whose process no
    /// longer runs are removed first.
    pub fn new(kind: &str) -> io::Result<Self> {
        static MADE: AtomicUsize = AtomicUsize::new(0);
        let base = std::env::temp_dir();
        remove_stale(&base, kind);
        let path = base.join(format!(
            "{kind}-{}-{}",
            std::process::id(),
            MADE.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = fs::remove_dir_all(&path);
        // registered before it exists, so that a signal in between removes it
        live().dirs.push(path.clone());
        if let Err(e) = fs::create_dir_all(&path) {
            live().dirs.retain(|d| d != &path);
            return Err(e);
        }
        Ok(Self { path })
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.path);
        live().dirs.retain(|d| d != &self.path);
    }
}

/// A child process to kill if a termination signal arrives while it runs
/// (a candidate that hangs would otherwise outlive the run).
pub fn register_child(pid: u32) {
    live().children.push(pid);
}

/// The child has been waited for.
pub fn unregister_child(pid: u32) {
    live().children.retain(|&p| p != pid);
}

/// Remove the directories `KIND-PID-N` in `base` whose process is gone.
fn remove_stale(base: &Path, kind: &str) {
    let numbered = |n: &str| n.parse::<usize>().is_ok();
    super::atomic::for_stale_entries(base, &format!("{kind}-"), '-', numbered, |path| {
        let _ = fs::remove_dir_all(path);
    });
}

/// Remove every live scratch directory and kill every registered child
/// (what a termination signal does before the process exits).
#[cfg(unix)]
fn clean_up_now() {
    let live = live();
    #[cfg(unix)]
    for &pid in &live.children {
        if let Ok(pid) = libc::pid_t::try_from(pid) {
            // SAFETY: kill has no memory effects; a stale pid at worst
            // gets ESRCH.
            unsafe { libc::kill(pid, libc::SIGKILL) };
        }
    }
    for d in &live.dirs {
        let _ = fs::remove_dir_all(d);
    }
}

/// On Ctrl-C (`SIGINT`), `SIGTERM` and `SIGHUP`: remove the live scratch
/// directories, kill the registered children, and exit with `128 + signal`
/// (as a shell reports a process killed by it). Call it first in `main`,
/// before any thread starts: it blocks these signals in the calling thread
/// (and so in every thread started after it) and waits for them in a thread
/// of its own. Child processes start with the signals unblocked (the
/// standard library resets the mask).
#[cfg(unix)]
pub fn clean_up_on_termination_signals() {
    // SAFETY: a sigset_t is plain data, initialised by sigemptyset.
    let mut set: libc::sigset_t = unsafe { std::mem::zeroed() };
    // SAFETY: set is a valid sigset_t; the calls only change the mask.
    let blocked = unsafe {
        libc::sigemptyset(&mut set);
        for s in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
            libc::sigaddset(&mut set, s);
        }
        libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut()) == 0
    };
    if !blocked {
        return;
    }
    std::thread::spawn(move || loop {
        let mut signal = 0;
        // SAFETY: set and signal are valid for the call.
        if unsafe { libc::sigwait(&set, &mut signal) } == 0 {
            TERMINATING.store(true, Ordering::SeqCst);
            clean_up_now();
            std::process::exit(128 + signal);
        }
    });
}

/// Nothing to do where there are no such signals.
#[cfg(not(unix))]
pub fn clean_up_on_termination_signals() {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scratch_directory_goes_with_its_owner_and_a_dead_process_one_with_the_next() {
        let kind = "mfcbeam-scratch-test";
        // no process has this pid (above Linux's pid_max)
        let stale = std::env::temp_dir().join(format!("{kind}-2147483632-0"));
        fs::create_dir_all(stale.join("sub")).unwrap();
        let unrelated = std::env::temp_dir().join(format!("{kind}-notapid"));
        fs::create_dir_all(&unrelated).unwrap();
        let dir = ScratchDir::new(kind).unwrap();
        assert!(!stale.exists(), "the dead process's directory is removed");
        assert!(unrelated.exists());
        let path = dir.path().to_path_buf();
        fs::write(path.join("f"), "x").unwrap();
        assert!(live().dirs.contains(&path));
        drop(dir);
        assert!(!path.exists());
        assert!(!live().dirs.contains(&path));
        fs::remove_dir_all(&unrelated).unwrap();
    }
}
