//! Whole-or-nothing outputs (SPEC §6): everything is written under a temporary name in the
//! target's own folder and renamed into place only once complete, so an error, a panic or a
//! kill never leaves a partial file or folder where the output belongs.
//!
//! The temporary name is `.NAME.partial-PID-XXXXXX`. What is left of it when the process
//! ends early is removed as well:
//! - SIGINT, SIGTERM and SIGHUP: [`remove_unfinished_on_signal`] (called by `fsm` first)
//!   removes this process's staged outputs, then exits with 128 + the signal's number;
//! - a `kill -9` or a power cut: the next output staged in the same folder removes the
//!   staged outputs whose process is no longer running, and says so on stderr. "Running"
//!   means `/proc/PID` exists (Linux): on a folder shared with other machines, an output
//!   another host is staging would look abandoned, so do not point two machines' runs at
//!   one folder at once.

use std::ffi::OsString;
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use tempfile::{NamedTempFile, TempDir};

use crate::error::{Error, IoContext, Result};

/// The folder a target lives in (`.` for a bare file name).
fn parent_of(target: &Path) -> &Path {
    match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// `.NAME.partial-PID-` : temporary names are hidden, say what they will become and which
/// process writes them.
fn temp_prefix(target: &Path, tag: &str) -> OsString {
    let mut prefix = OsString::from(".");
    prefix.push(target.file_name().unwrap_or_else(|| "output".as_ref()));
    prefix.push(tag);
    prefix.push(format!("{}-", std::process::id()));
    prefix
}

/// Staged outputs of this process not yet committed: (temporary path, target).
static UNFINISHED: Mutex<Vec<(PathBuf, PathBuf)>> = Mutex::new(Vec::new());

fn unfinished() -> MutexGuard<'static, Vec<(PathBuf, PathBuf)>> {
    // A panic while holding it leaves the list as it was: still the right list.
    UNFINISHED.lock().unwrap_or_else(|e| e.into_inner())
}

/// Keeps a staged output on the list of [`UNFINISHED`] ones while it lives.
struct Unfinished(PathBuf);

impl Unfinished {
    fn new(temp: &Path, target: &Path) -> Self {
        unfinished().push((temp.to_path_buf(), target.to_path_buf()));
        Unfinished(temp.to_path_buf())
    }

    /// Takes it off the list (under the caller's lock).
    fn forget(list: &mut Vec<(PathBuf, PathBuf)>, temp: &Path) {
        list.retain(|(t, _)| t != temp);
    }
}

impl Drop for Unfinished {
    fn drop(&mut self) {
        Unfinished::forget(&mut unfinished(), &self.0);
    }
}

/// On SIGINT, SIGTERM or SIGHUP, removes every staged output of this process not yet
/// committed, says so on stderr, and exits with 128 + the signal's number. A commit under
/// way finishes first (it holds the list), so the target is either whole or untouched.
pub fn remove_unfinished_on_signal() -> io::Result<()> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])?;
    std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                let name = match signal {
                    SIGINT => "SIGINT",
                    SIGTERM => "SIGTERM",
                    _ => "SIGHUP",
                };
                exit_removing_unfinished(name, 128 + signal, true);
            }
        })?;
    Ok(())
}

/// Removes every staged output of this process not yet committed, says so on stderr (`fsm:
/// stopped by {cause}: …`; with nothing to remove, `fsm: stopped by {cause}` only when
/// `say_stopped`) and exits with `code`. A commit under way finishes first (it holds the
/// list), so the target is either whole or untouched. For a run that cannot go on: a signal,
/// or a reader that closed the tool's standard output.
pub fn exit_removing_unfinished(cause: &str, code: i32, say_stopped: bool) -> ! {
    // Held until the process ends: nothing is committed after this.
    let list = unfinished();
    for (temp, target) in list.iter() {
        match remove_entry(temp) {
            Ok(()) => eprintln!(
                "fsm: stopped by {cause}: unfinished {} removed",
                target.display()
            ),
            Err(e) => eprintln!(
                "fsm: stopped by {cause}: could not remove the unfinished {}: {e}",
                temp.display()
            ),
        }
    }
    if list.is_empty() && say_stopped {
        eprintln!("fsm: stopped by {cause}");
    }
    std::process::exit(code)
}

/// Writes `text` to standard output (`fsm`'s `say!`). When the reader has closed it (`fsm
/// camera info | head -1`), the run ends quietly as a Unix tool's does on SIGPIPE, with exit
/// status 141 (128 + 13), after removing any output it had not committed; another write error
/// ends it with status 1.
pub fn write_stdout(text: std::fmt::Arguments) {
    let mut out = io::stdout().lock();
    if let Err(e) = out.write_fmt(text).and_then(|()| out.flush()) {
        if e.kind() == io::ErrorKind::BrokenPipe {
            exit_removing_unfinished("a closed standard output", 141, false);
        }
        eprintln!("fsm: error: writing to standard output: {e}");
        std::process::exit(1);
    }
}

/// Removes a file or a folder with everything in it; a folder another thread is still
/// writing into is tried again.
fn remove_entry(path: &Path) -> io::Result<()> {
    let mut tries = 0;
    loop {
        let result = match fs::symlink_metadata(path) {
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
            Err(e) => Err(e),
            Ok(m) if m.is_dir() => fs::remove_dir_all(path),
            Ok(_) => fs::remove_file(path),
        };
        match result {
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
            Err(_) if tries < 20 => {
                tries += 1;
                std::thread::sleep(std::time::Duration::from_millis(10));
            }
            other => return other,
        }
    }
}

/// Removes the staged outputs in `parent` that a process no longer running left behind
/// (killed with SIGKILL, a power cut), saying so on stderr. Entries of a running process
/// are left alone; where it cannot be told whether a process runs, nothing is removed.
fn remove_abandoned(parent: &Path) {
    // Linux: a running process has /proc/PID.
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = fs::read_dir(parent) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(abandoned_pid) else {
            continue;
        };
        if pid == std::process::id() || Path::new(&format!("/proc/{pid}")).exists() {
            continue;
        }
        let path = entry.path();
        match remove_entry(&path) {
            Ok(()) => eprintln!(
                "fsm: removed {}, left by an interrupted run (process {pid})",
                path.display()
            ),
            Err(e) => eprintln!(
                "fsm: {} was left by an interrupted run (process {pid}) and could not be removed: {e}",
                path.display()
            ),
        }
    }
}

/// The writing process of a staged output's name `.NAME.partial-PID-XXXXXX` (or
/// `.NAME.old-PID-XXXXXX`, a replaced folder moved aside).
fn abandoned_pid(name: &str) -> Option<u32> {
    let rest = name.strip_prefix('.')?;
    let (_, tail) = rest
        .rsplit_once(".partial-")
        .or_else(|| rest.rsplit_once(".old-"))?;
    let (pid, random) = tail.split_once('-')?;
    if pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) || random.is_empty() {
        return None;
    }
    pid.parse().ok()
}

/// A builder whose files and folders get the usual permissions (0666 / 0777 less the umask)
/// rather than the private 0600 / 0700 of temporary files: they become the outputs.
fn builder<'a>(prefix: &'a OsString, folder: bool) -> tempfile::Builder<'a, 'a> {
    let mut b = tempfile::Builder::new();
    b.prefix(prefix);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        b.permissions(fs::Permissions::from_mode(if folder {
            0o777
        } else {
            0o666
        }));
    }
    #[cfg(not(unix))]
    let _ = folder;
    b
}

/// A file being written; it appears at its target path only on [`StagedFile::commit`].
/// Dropping it uncommitted deletes the temporary file.
pub struct StagedFile {
    writer: BufWriter<NamedTempFile>,
    target: PathBuf,
    _unfinished: Unfinished,
}

impl StagedFile {
    /// Starts writing `target` (its folder must exist).
    pub fn create(target: &Path) -> Result<Self> {
        let parent = parent_of(target);
        remove_abandoned(parent);
        let prefix = temp_prefix(target, ".partial-");
        let temp = builder(&prefix, false)
            .tempfile_in(parent)
            .map_err(|e| cannot_stage(target, parent, e))?;
        Ok(StagedFile {
            _unfinished: Unfinished::new(temp.path(), target),
            writer: BufWriter::with_capacity(1 << 20, temp),
            target: target.to_path_buf(),
        })
    }

    /// The path the file will have once committed.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// The buffered writer (also `Seek`, for TIFF).
    pub fn writer(&mut self) -> &mut BufWriter<NamedTempFile> {
        &mut self.writer
    }

    /// Flushes and renames the file into place (replacing an existing file).
    pub fn commit(self) -> Result<()> {
        let target = self.target;
        let temp = self
            .writer
            .into_inner()
            .map_err(|e| Error::io(&target, e.into_error()))?;
        temp.as_file().sync_all().at(&target)?;
        let mut list = unfinished();
        Unfinished::forget(&mut list, temp.path());
        temp.persist(&target)
            .map_err(|e| Error::io(&target, e.error))?;
        Ok(())
    }
}

impl Write for StagedFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.writer.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.writer.flush()
    }
}

/// Writes `bytes` to `target` whole or not at all.
pub fn write_file(target: &Path, bytes: &[u8]) -> Result<()> {
    let mut file = StagedFile::create(target)?;
    file.write_all(bytes).at(target)?;
    file.commit()
}

/// A folder being filled; it appears at its target path only on [`StagedDir::commit`].
/// Dropping it uncommitted deletes the temporary folder and everything in it.
pub struct StagedDir {
    temp: TempDir,
    target: PathBuf,
    replace: bool,
    _unfinished: Unfinished,
}

impl StagedDir {
    /// Starts filling `target`. A target that exists must be an empty folder, unless `replace`
    /// is set: then it is replaced as a whole on commit. Checked now, before any work.
    pub fn create(target: &Path, replace: bool) -> Result<Self> {
        check_target(target, replace)?;
        let parent = parent_of(target);
        if !parent.is_dir() {
            return Err(Error::io(
                parent,
                io::Error::new(
                    io::ErrorKind::NotFound,
                    "output folder's parent does not exist",
                ),
            ));
        }
        remove_abandoned(parent);
        let prefix = temp_prefix(target, ".partial-");
        let temp = builder(&prefix, true)
            .tempdir_in(parent)
            .map_err(|e| cannot_stage(target, parent, e))?;
        Ok(StagedDir {
            _unfinished: Unfinished::new(temp.path(), target),
            temp,
            target: target.to_path_buf(),
            replace,
        })
    }

    /// The temporary folder files are written into.
    pub fn path(&self) -> &Path {
        self.temp.path()
    }

    /// Path of `name` inside the temporary folder.
    pub fn file(&self, name: &str) -> PathBuf {
        self.temp.path().join(name)
    }

    /// The folder the outputs will have once committed.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Renames the folder into place.
    pub fn commit(self) -> Result<PathBuf> {
        check_target(&self.target, self.replace)?;
        // A signal waits for the renames below: the target ends whole, or as it was.
        let mut list = unfinished();
        Unfinished::forget(&mut list, self.temp.path());
        let target = self.target;
        let mut old = None;
        if target.exists() {
            if is_empty_dir(&target)? {
                fs::remove_dir(&target).at(&target)?;
            } else {
                // replace: move the old folder aside, then bring the new one in.
                let aside = tempfile::Builder::new()
                    .prefix(&temp_prefix(&target, ".old-"))
                    .tempdir_in(parent_of(&target))
                    .at(parent_of(&target))?
                    .keep();
                fs::remove_dir(&aside).at(&aside)?;
                fs::rename(&target, &aside).at(&target)?;
                old = Some(aside);
            }
        }
        let staged = self.temp.keep();
        if let Err(e) = fs::rename(&staged, &target) {
            let _ = fs::remove_dir_all(&staged);
            if let Some(old) = &old {
                let _ = fs::rename(old, &target);
            }
            return Err(Error::io(&target, e));
        }
        if let Some(old) = old {
            fs::remove_dir_all(&old).at(&old)?;
        }
        Ok(target)
    }
}

/// The error for a target whose folder takes no new entry (read-only, `/proc`, full): it
/// names the target, and the folder as the place that refused.
fn cannot_stage(target: &Path, parent: &Path, e: io::Error) -> Error {
    // The system's words without tempfile's "at path <random name>".
    let text = e.to_string();
    let system = text.split(" at path ").next().unwrap_or(&text);
    let why = format!(
        "cannot write into its folder {}: {system}",
        parent.display()
    );
    Error::io(target, io::Error::new(e.kind(), why))
}

fn is_empty_dir(path: &Path) -> Result<bool> {
    Ok(fs::read_dir(path).at(path)?.next().is_none())
}

/// Checks, before any work, that a single-file output may be written at `target`: the rule
/// of the output folders ([`StagedDir::create`]) for files. An existing file is refused unless
/// `replace` (`--force`), a folder always, and a missing parent folder is named.
pub fn check_file_target(target: &Path, replace: bool) -> Result<()> {
    let parent = parent_of(target);
    if !parent.is_dir() {
        return Err(Error::Usage(format!(
            "{}: its folder {} does not exist (create it first)",
            target.display(),
            parent.display()
        )));
    }
    match fs::metadata(target) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(Error::io(target, e)),
        Ok(m) if m.is_dir() => Err(Error::Usage(format!(
            "{}: is a folder, not a file",
            target.display()
        ))),
        Ok(_) if replace => Ok(()),
        Ok(_) => Err(Error::Usage(format!(
            "{}: file exists (choose another name, or --force to replace it)",
            target.display()
        ))),
    }
}

/// [`check_file_target`] for each of `targets`: a command's optional single-file outputs
/// (`fsm plan --out --wire`, `fsm calibrate target --report`, `fsm calibrate response --out`),
/// given as `Option`s or a list, all checked before any work in one call.
pub fn check_file_targets<'a>(
    targets: impl IntoIterator<Item = &'a Path>,
    replace: bool,
) -> Result<()> {
    targets
        .into_iter()
        .try_for_each(|target| check_file_target(target, replace))
}

/// [`check_file_target`] for an output made from the file `input`: `target` is refused when
/// it is that file, whatever `replace` says (`fsm calibrate import --in X --out X --force`
/// would replace what it reads), with `--out TARGET is {why}`. Here beside the rule it adds
/// to, rather than in the commands that take an input and an `--out` file.
pub fn check_file_target_not(target: &Path, input: &Path, replace: bool, why: &str) -> Result<()> {
    match (input.canonicalize(), target.canonicalize()) {
        (Ok(a), Ok(b)) if a == b => {
            Err(Error::Usage(format!("--out {} is {why}", target.display())))
        }
        _ => check_file_target(target, replace),
    }
}

fn check_target(target: &Path, replace: bool) -> Result<()> {
    match fs::metadata(target) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(Error::io(target, e)),
        Ok(m) if !m.is_dir() => Err(Error::Usage(format!(
            "{}: exists and is not a folder",
            target.display()
        ))),
        Ok(_) if replace || is_empty_dir(target)? => Ok(()),
        Ok(_) => Err(Error::Usage(format!(
            "{}: folder exists and is not empty (choose another output folder, or --force to replace it)",
            target.display()
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uncommitted_outputs_leave_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let file_target = dir.path().join("a.bin");
        let mut f = StagedFile::create(&file_target).unwrap();
        f.write_all(b"partial").unwrap();
        drop(f);
        let dir_target = dir.path().join("out");
        let d = StagedDir::create(&dir_target, false).unwrap();
        fs::write(d.file("x"), b"partial").unwrap();
        drop(d);
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn committed_outputs_appear_whole() {
        let dir = tempfile::tempdir().unwrap();
        let file_target = dir.path().join("a.bin");
        write_file(&file_target, b"whole").unwrap();
        assert_eq!(fs::read(&file_target).unwrap(), b"whole");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = fs::metadata(&file_target).unwrap().permissions().mode() & 0o777;
            // What a plain File::create gives under this process's umask.
            let plain = dir.path().join("plain");
            fs::write(&plain, b"").unwrap();
            let expected = fs::metadata(&plain).unwrap().permissions().mode() & 0o777;
            fs::remove_file(&plain).unwrap();
            assert_eq!(
                mode, expected,
                "outputs get the usual permissions, not 0600"
            );
        }
        let dir_target = dir.path().join("out");
        let d = StagedDir::create(&dir_target, false).unwrap();
        fs::write(d.file("x"), b"1").unwrap();
        d.commit().unwrap();
        assert_eq!(fs::read(dir_target.join("x")).unwrap(), b"1");
        // A non-empty folder is refused without replace, replaced with it.
        assert!(StagedDir::create(&dir_target, false).is_err());
        let d = StagedDir::create(&dir_target, true).unwrap();
        fs::write(d.file("y"), b"2").unwrap();
        d.commit().unwrap();
        assert!(!dir_target.join("x").exists());
        assert_eq!(fs::read(dir_target.join("y")).unwrap(), b"2");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 2);
    }
}
