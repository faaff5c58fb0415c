//! Atomic replacement of an output file: the old file or the complete new
//! one, never a part, and no temporary file left behind, also when the
//! process is killed while it writes.

use std::ffi::OsString;
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// The directory of `path` and its file name.
fn split(path: &Path) -> io::Result<(PathBuf, OsString)> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "not a file name"))?
        .to_os_string();
    Ok((dir, name))
}

/// The prefix of every temporary name for `name`: `.NAME.`, then the
/// process id, then `.tmp` (and the extension, for [`write_via`]).
fn temp_prefix(name: &OsString) -> String {
    format!(".{}.", name.to_string_lossy())
}

fn temp_path(dir: &Path, name: &OsString, extension: Option<&str>) -> PathBuf {
    let mut file = format!("{}{}.tmp", temp_prefix(name), std::process::id());
    if let Some(ext) = extension {
        file.push('.');
        file.push_str(ext);
    }
    dir.join(file)
}

/// Remove the temporary files of `name` that processes no longer running
/// left behind (killed between naming and renaming, or, without unnamed
/// files, while writing).
fn remove_stale(dir: &Path, name: &OsString) {
    let prefix = temp_prefix(name);
    for_stale_entries(
        dir,
        &prefix,
        '.',
        |tail| tail.starts_with("tmp"),
        |path| {
            let _ = fs::remove_file(path);
        },
    );
}

/// Call `remove` on each entry of `dir` named `PREFIX PID SEP TAIL` whose
/// `TAIL` passes `tail_ok` and whose process `PID` (not this one) no
/// longer runs.
pub(super) fn for_stale_entries(
    dir: &Path,
    prefix: &str,
    sep: char,
    tail_ok: impl Fn(&str) -> bool,
    mut remove: impl FnMut(&Path),
) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(rest) = file.to_str().and_then(|f| f.strip_prefix(prefix)) else {
            continue;
        };
        let Some((pid, tail)) = rest.split_once(sep) else {
            continue;
        };
        let Ok(pid) = pid.parse::<u32>() else {
            continue;
        };
        if tail_ok(tail) && pid != std::process::id() && !process_alive(pid) {
            remove(&entry.path());
        }
    }
}

#[cfg(unix)]
fn process_alive(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    // SAFETY: signal 0 only checks that the process exists.
    let r = unsafe { libc::kill(pid, 0) };
    r == 0 || io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH)
}

#[cfg(not(unix))]
fn process_alive(_pid: u32) -> bool {
    // cannot tell: keep it
    true
}

/// See [`super::write_atomic_with`].
pub(super) fn write(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> io::Result<()> {
    let (dir, name) = split(path)?;
    remove_stale(&dir, &name);
    let tmp = temp_path(&dir, &name, None);
    #[cfg(target_os = "linux")]
    if let Some(file) = unnamed::create(&dir) {
        let mut out = BufWriter::new(file);
        write(&mut out)?;
        let file = out.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        // named only now, complete; then renamed over the old file
        unnamed::link(&file, &tmp)?;
        return rename_or_remove(&tmp, path);
    }
    let result = (|| {
        let mut out = BufWriter::new(fs::File::create(&tmp)?);
        write(&mut out)?;
        let file = out.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()
    })();
    match result {
        Ok(()) => rename_or_remove(&tmp, path),
        Err(e) => {
            let _ = fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// See [`super::write_atomic_via`].
pub(super) fn write_via<E>(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> io::Result<Result<(), E>> {
    let (dir, name) = split(path)?;
    remove_stale(&dir, &name);
    let extension = path.extension().and_then(|e| e.to_str());
    let tmp = temp_path(&dir, &name, extension);
    match write(&tmp) {
        Ok(()) => rename_or_remove(&tmp, path).map(Ok),
        Err(e) => {
            let _ = fs::remove_file(&tmp);
            Ok(Err(e))
        }
    }
}

fn rename_or_remove(tmp: &Path, path: &Path) -> io::Result<()> {
    fs::rename(tmp, path).inspect_err(|_| {
        let _ = fs::remove_file(tmp);
    })
}

/// Unnamed files (`O_TMPFILE`, Linux 3.11 on most local file systems).
#[cfg(target_os = "linux")]
mod unnamed {
    use std::ffi::CString;
    use std::fs::{File, OpenOptions};
    use std::io;
    use std::os::unix::ffi::OsStrExt;
    use std::os::unix::fs::OpenOptionsExt;
    use std::os::unix::io::AsRawFd;
    use std::path::Path;

    /// An unnamed file in `dir`, or `None` where the file system has none.
    pub(super) fn create(dir: &Path) -> Option<File> {
        OpenOptions::new()
            .write(true)
            .custom_flags(libc::O_TMPFILE)
            .mode(0o644)
            .open(dir)
            .ok()
    }

    /// Give the unnamed `file` the name `path` (through its `/proc` link,
    /// which needs no privilege).
    pub(super) fn link(file: &File, path: &Path) -> io::Result<()> {
        let proc = CString::new(format!("/proc/self/fd/{}", file.as_raw_fd()))?;
        let to = CString::new(path.as_os_str().as_bytes())?;
        // SAFETY: both are NUL-terminated paths that outlive the call.
        let r = unsafe {
            libc::linkat(
                libc::AT_FDCWD,
                proc.as_ptr(),
                libc::AT_FDCWD,
                to.as_ptr(),
                libc::AT_SYMLINK_FOLLOW,
            )
        };
        if r == 0 {
            Ok(())
        } else {
            Err(io::Error::last_os_error())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("mfcbeam-atomic-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    fn names(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_leaves_nothing() {
        let d = dir("fail");
        let path = d.join("out.csv");
        write(&path, |w| w.write_all(b"old\n")).unwrap();
        let e = write(&path, |w| {
            w.write_all(b"half")?;
            Err(io::Error::other("disk full"))
        });
        assert!(e.is_err());
        assert_eq!(fs::read(&path).unwrap(), b"old\n");
        assert_eq!(names(&d), ["out.csv"]);
        let r: Result<(), &str> = write_via(&path, |p| {
            fs::write(p, "half").unwrap();
            Err("encoder failed")
        })
        .unwrap();
        assert_eq!(r, Err("encoder failed"));
        assert_eq!(names(&d), ["out.csv"]);
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_dead_process_temporary_file_is_removed_by_the_next_write() {
        let d = dir("stale");
        let path = d.join("fig.png");
        // no process has pid 0x7fff_fff0 (above Linux's pid_max)
        let stale = d.join(".fig.png.2147483632.tmp.png");
        let unrelated = d.join(".other.png.2147483632.tmp");
        fs::write(&stale, "x").unwrap();
        fs::write(&unrelated, "x").unwrap();
        write_via(&path, |p| fs::write(p, "new")).unwrap().unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"new");
        assert_eq!(names(&d), [".other.png.2147483632.tmp", "fig.png"]);
        fs::remove_dir_all(&d).unwrap();
    }
}
