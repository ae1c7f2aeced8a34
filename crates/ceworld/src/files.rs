//! Files written and read safely. A file is written to a fresh temporary file in the target's
//! folder (created exclusively, so concurrent writers never share one), flushed and synced, then
//! renamed over the target: a reader sees the old file or the new one, whole, never a mix, and
//! an interruption leaves the target untouched. A target that exists and is not a regular file
//! is refused (a directory, a device such as `/dev/null`, a socket, a pipe); a symbolic link is
//! written through: the file it points to is replaced, the link stays. Reads refuse a file over
//! a stated size before reading it. Errors name the path the caller gave, never the temporary
//! file; the temporary files a killed writer left beside the same target are removed by the next
//! write. [`check_writable`] tells before a long run whether its outputs can be written.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

/// The file that `path` (given as `what`) names for writing: itself, or where its symbolic
/// links lead; an error naming `what` when it exists and is not a regular file.
fn target(what: &str, path: &Path) -> Result<PathBuf> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let mut resolved = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&resolved) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(resolved),
            Err(e) => return Err(io(e)),
            Ok(meta) if meta.file_type().is_symlink() => {
                let link = std::fs::read_link(&resolved).map_err(io)?;
                resolved = match resolved.parent() {
                    Some(dir) if link.is_relative() => dir.join(link),
                    _ => link,
                };
            }
            Ok(meta) if meta.is_file() => return Ok(resolved),
            Ok(meta) => {
                return Err(not_regular(what, path, &resolved, &meta, "a regular file to write, or a new name"));
            }
        }
    }
    Err(Error::invalid(what, format!("{} (too many levels of symbolic links)", path.display())))
}

/// The folder and file name of the file `path` (given as `what`) names for writing.
fn place(what: &str, path: &Path) -> Result<(PathBuf, PathBuf, String)> {
    let target = target(what, path)?;
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = target.file_name().map_or_else(|| "file".into(), |n| n.to_string_lossy().into_owned());
    Ok((target, dir, name))
}

/// A fresh temporary file beside `name` in `dir`, created exclusively: `.NAME.PID.N.NANOS.tmp`.
fn temporary(path: &Path, dir: &Path, name: &str) -> Result<(File, PathBuf)> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
    loop {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(format!(".{name}.{}.{n}.{nanos}.tmp", std::process::id()));
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(file) => return Ok((file, tmp)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(source) => return Err(Error::Io { path: path.to_path_buf(), source }),
        }
    }
}

/// Refuses, before any work, a `path` (given as `what`: the option or argument, which the
/// error names) that cannot be written: a missing or read-only folder, a directory, a device
/// (it creates and removes a temporary file beside it).
pub fn check_writable(what: &str, path: &Path) -> Result<()> {
    let (_, dir, name) = place(what, path)?;
    let (file, tmp) = temporary(path, &dir, &name)?;
    drop(file);
    let _ = std::fs::remove_file(&tmp);
    Ok(())
}

/// Removes the temporary files of `name` in `dir` that a writer killed before it renamed them
/// left behind (those of processes that no longer run).
fn remove_stale(dir: &Path, name: &str) {
    #[cfg(unix)]
    {
        let prefix = format!(".{name}.");
        let Ok(entries) = std::fs::read_dir(dir) else { return };
        for entry in entries.flatten() {
            let file = entry.file_name().to_string_lossy().into_owned();
            let Some(rest) = file.strip_prefix(&prefix).and_then(|r| r.strip_suffix(".tmp")) else { continue };
            let Some(pid) = rest.split('.').next().and_then(|p| p.parse::<libc::pid_t>().ok()) else { continue };
            if rest.split('.').count() != 3 || pid <= 0 || pid as u32 == std::process::id() {
                continue;
            }
            // SAFETY: signal 0 only asks whether the process exists.
            let gone = unsafe { libc::kill(pid, 0) } == -1
                && std::io::Error::last_os_error().raw_os_error() == Some(libc::ESRCH);
            if gone {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
    #[cfg(not(unix))]
    let _ = (dir, name);
}

/// Writes `path` through a unique temporary file in its folder, synced, then renamed over it.
pub fn write_atomic(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>) -> Result<()> {
    let (target, dir, name) = place("path", path)?;
    let (file, tmp) = temporary(path, &dir, &name)?;
    let written = (|| -> std::io::Result<()> {
        let mut out = BufWriter::with_capacity(1 << 20, file);
        write(&mut out)?;
        out.flush()?;
        out.into_inner().map_err(std::io::IntoInnerError::into_error)?.sync_all()?;
        std::fs::rename(&tmp, &target)
    })();
    if let Err(source) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::Io { path: path.to_path_buf(), source });
    }
    remove_stale(&dir, &name);
    // Make the rename itself durable (best effort: not every system can sync a folder).
    if let Ok(d) = File::open(&dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// `path` opened for reading, refused unless it is a regular file (after its links): a
/// directory, a device such as `/dev/zero`, a socket or a FIFO is refused at once, without
/// blocking on a FIFO's open or reading a device to exhaustion.
pub fn open_regular(path: &Path, what: &str) -> Result<File> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let mut options = OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // A FIFO's open would wait for a writer; a regular file ignores the flag.
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    if !meta.is_file() {
        let linked = std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink());
        let resolved =
            if linked { std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()) } else { path.into() };
        return Err(not_regular(what, path, &resolved, &meta, "a file to read"));
    }
    Ok(file)
}

/// The refusal of `path` (the name the caller gave; `resolved`, where its links lead, is named
/// too when it differs), which is a directory, a device, a socket or a pipe.
fn not_regular(what: &str, path: &Path, resolved: &Path, meta: &std::fs::Metadata, expected: &str) -> Error {
    let kind = if meta.is_dir() { "a directory" } else { "not a regular file (a device, socket or pipe)" };
    let link = if resolved == path { String::new() } else { format!(" (a link to {})", resolved.display()) };
    Error::invalid(what, format!("{}{link} is {kind} (expected {expected})", path.display()))
}

/// The bytes of `path` (a regular file: [`open_regular`]), refused when it holds more than
/// `max_bytes`: the read stops there, whatever size the file reports.
pub fn read_limited(path: &Path, max_bytes: u64, what: &str) -> Result<Vec<u8>> {
    use std::io::Read;
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let too_big = |size: String| {
        Error::invalid(what, format!("{} has {size} bytes (at most {max_bytes} are read)", path.display()))
    };
    let file = open_regular(path, what)?;
    let size = file.metadata().map_err(io)?.len();
    if size > max_bytes {
        return Err(too_big(size.to_string()));
    }
    let mut bytes = Vec::with_capacity(usize::try_from(size).unwrap_or(0));
    file.take(max_bytes.saturating_add(1)).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_big(format!("more than {max_bytes}")));
    }
    Ok(bytes)
}

/// Where `path` leads, absolute: its symbolic links followed (a dangling link to where it
/// points), its folder made canonical where it exists. Two paths that lead to one place name one
/// file, existing or to be created; a checkpoint records its run's outputs so.
pub fn resolved(path: &Path) -> PathBuf {
    let target = target("path", path).unwrap_or_else(|_| path.to_path_buf());
    let absolute = std::path::absolute(&target).unwrap_or(target);
    match (absolute.parent(), absolute.file_name()) {
        (Some(dir), Some(name)) => std::fs::canonicalize(dir).map_or_else(|_| absolute.clone(), |d| d.join(name)),
        _ => absolute,
    }
}

/// Whether `a` and `b` name one file: the same place ([`resolved`]), or one existing file (its
/// device and inode: hard links too).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    resolved(a) == resolved(b)
}

/// Refuses an output `path` (given as `option`) that is an existing file (links followed),
/// where replacing it was not asked: `how` says how to ask (`"give --force"`, `"give
/// overwrite=True"`). What is not a regular file is left to the writer's refusal.
pub fn check_new(option: &str, path: &Path, how: &str) -> Result<()> {
    if std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return Err(Error::invalid(
            option,
            format!("{} exists ({how} to replace it, or another name)", path.display()),
        ));
    }
    Ok(())
}

/// The one rule of every command's files: no output is the same file as another output or as an
/// input (`(option, path)` pairs; links followed, hard links seen), so that no result is written
/// over another or over what the command reads.
pub fn check_distinct(inputs: &[(&str, &Path)], outputs: &[(&str, &Path)]) -> Result<()> {
    for (i, (option, path)) in outputs.iter().enumerate() {
        let others = outputs[..i].iter().map(|o| (o, "written")).chain(inputs.iter().map(|o| (o, "read")));
        for ((other, other_path), role) in others {
            if same_file(path, other_path) {
                let link = if path == other_path { String::new() } else { format!(" ({})", other_path.display()) };
                return Err(Error::invalid(
                    *option,
                    format!(
                        "{} is the file that {other}{link} names, {role} by the same command (expected another name)",
                        path.display()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// `bytes` in lowercase hex (a digest as files and checkpoints record it).
pub fn hex(bytes: &[u8]) -> String {
    use std::fmt::Write as _;
    bytes.iter().fold(String::with_capacity(2 * bytes.len()), |mut hex, b| {
        let _ = write!(hex, "{b:02x}");
        hex
    })
}

/// Why `shown`, a path that is not UTF-8, is refused where a world's parameters record it (they
/// are JSON text: the path would become another name, and "no such file").
pub fn not_utf8(shown: &str) -> String {
    format!("{shown} is not valid UTF-8 (expected a path written in UTF-8: rename or link the file)")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh folder of the system's temporary one, removed with all in it when dropped.
    struct TempDir(PathBuf);

    impl std::ops::Deref for TempDir {
        type Target = PathBuf;
        fn deref(&self) -> &PathBuf {
            &self.0
        }
    }

    impl AsRef<Path> for TempDir {
        fn as_ref(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn temp_dir(name: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("ceworld-files-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    #[test]
    fn a_write_replaces_the_file_whole_and_leaves_no_temporary() {
        let dir = temp_dir("whole");
        let path = dir.join("a.json");
        write_atomic(&path, |w| w.write_all(b"first")).unwrap();
        write_atomic(&path, |w| w.write_all(b"second")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        let failed = write_atomic(&path, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("interrupted"))
        });
        assert!(failed.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"second", "a failed write leaves the old file");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "no temporary file is left");
    }

    #[test]
    fn devices_and_directories_are_refused_and_links_written_through() {
        let dir = temp_dir("kinds");
        let e = write_atomic(&dir, |w| w.write_all(b"x")).unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt;
            let e = write_atomic(Path::new("/dev/null"), |w| w.write_all(b"x")).unwrap_err().to_string();
            assert!(e.contains("not a regular file"), "{e}");
            assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device());
            let real = dir.join("real.json");
            std::fs::write(&real, b"old").unwrap();
            let link = dir.join("link.json");
            std::os::unix::fs::symlink("real.json", &link).unwrap();
            write_atomic(&link, |w| w.write_all(b"new")).unwrap();
            assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink(), "the link stays");
            assert_eq!(std::fs::read(&real).unwrap(), b"new", "its file is replaced");
        }
    }

    #[test]
    fn concurrent_writers_never_mix_their_files() {
        let dir = temp_dir("concurrent");
        let path = dir.join("shared.txt");
        write_atomic(&path, |w| w.write_all(&vec![b'a'; 100_000])).unwrap();
        std::thread::scope(|s| {
            for byte in [b'b', b'c', b'd'] {
                let path = &path;
                s.spawn(move || {
                    for _ in 0..20 {
                        write_atomic(path, |w| w.write_all(&vec![byte; 100_000])).unwrap();
                    }
                });
            }
            let path = &path;
            s.spawn(move || {
                for _ in 0..200 {
                    let bytes = std::fs::read(path).unwrap();
                    assert_eq!(bytes.len(), 100_000);
                    assert!(bytes.iter().all(|&b| b == bytes[0]), "a mixed file");
                }
            });
        });
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    }

    #[test]
    fn unwritable_paths_are_found_before_any_work_and_named_as_given() {
        let dir = temp_dir("writable");
        let missing = dir.join("no-such-folder").join("p.json");
        for bad in [missing.clone(), dir.clone()] {
            let e = check_writable("--out", &bad).unwrap_err().to_string();
            assert!(e.contains(&bad.display().to_string()) && !e.contains(".tmp"), "{e}");
        }
        // A directory is refused naming the option that gave it.
        let e = check_writable("--out", &dir).unwrap_err().to_string();
        assert!(e.starts_with("invalid --out: ") && e.contains("is a directory"), "{e}");
        let e = write_atomic(&missing, |out| out.write_all(b"x")).unwrap_err().to_string();
        assert!(e.contains(&missing.display().to_string()) && !e.contains(".tmp"), "{e}");
        let fine = dir.join("p.json");
        check_writable("--out", &fine).unwrap();
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "the probe leaves nothing");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn a_write_removes_the_temporaries_a_killed_writer_left() {
        let dir = temp_dir("stale");
        // A process that has ended: its pid runs nothing now.
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let stale = dir.join(format!(".p.json.{dead}.0.123.tmp"));
        let other = dir.join(format!(".q.json.{dead}.0.123.tmp"));
        let mine = dir.join(format!(".p.json.{}.99.123.tmp", std::process::id()));
        for f in [&stale, &other, &mine] {
            std::fs::write(f, b"partial").unwrap();
        }
        write_atomic(&dir.join("p.json"), |out| out.write_all(b"whole")).unwrap();
        assert!(!stale.exists(), "the dead writer's temporary of this target is removed");
        assert!(other.exists() && mine.exists(), "another target's and a live writer's stay");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn devices_fifos_and_directories_are_refused_on_read_at_once() {
        let dir = temp_dir("read-kinds");
        let fifo = dir.join("fifo");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid C string; mkfifo only creates the node.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let link = dir.join("link-to-zero");
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        for path in [Path::new("/dev/zero"), link.as_path(), fifo.as_path(), dir.as_path()] {
            let e = read_limited(path, 1 << 30, "policy file").unwrap_err().to_string();
            assert!(e.contains("policy file") && e.contains(&path.display().to_string()), "{e}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn outputs_that_name_an_input_or_each_other_are_refused() {
        let dir = temp_dir("distinct");
        let (a, b) = (dir.join("a.json"), dir.join("b.json"));
        std::fs::write(&a, b"policy").unwrap();
        std::os::unix::fs::symlink("a.json", dir.join("link.json")).unwrap();
        std::fs::hard_link(&a, dir.join("hard.json")).unwrap();
        std::os::unix::fs::symlink("new.json", dir.join("dangling.json")).unwrap();
        let sub = dir.join("sub");
        std::fs::create_dir(&sub).unwrap();
        let via_dots = sub.join("..").join("a.json");
        let inputs = [("FILE", a.as_path())];
        for same in [a.clone(), dir.join("link.json"), dir.join("hard.json"), via_dots] {
            let e = check_distinct(&inputs, &[("--pg", same.as_path())]).unwrap_err().to_string();
            assert!(e.contains("--pg") && e.contains("FILE") && e.contains("read by the same command"), "{e}");
        }
        // Two outputs, one file to be created (once through a dangling link).
        let new = dir.join("new.json");
        for (x, y) in [(&new, &new), (&dir.join("dangling.json"), &new)] {
            let e = check_distinct(&[], &[("--out", x), ("--history", y)]).unwrap_err().to_string();
            assert!(e.contains("--history") && e.contains("--out") && e.contains("written"), "{e}");
        }
        check_distinct(&inputs, &[("--out", b.as_path()), ("--history", new.as_path())]).unwrap();
        assert_eq!(resolved(&dir.join("dangling.json")), resolved(&new));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn reads_over_the_limit_are_refused_before_reading() {
        let dir = temp_dir("limit");
        let path = dir.join("big");
        std::fs::write(&path, vec![b' '; 1000]).unwrap();
        assert_eq!(read_limited(&path, 1000, "policy file").unwrap().len(), 1000);
        let e = read_limited(&path, 999, "policy file").unwrap_err().to_string();
        assert!(e.contains("1000 bytes (at most 999"), "{e}");
    }
}
