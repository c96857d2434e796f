//! Atomic output files (SPEC §7: "outputs are atomic").
//!
//! [`AtomicFile`] writes to a hidden temporary file in the target's own directory and renames it
//! over the target in [`AtomicFile::commit`]. The temporary file lives beside the target (not in
//! `/tmp`) because a rename is only atomic within one file system. If the `AtomicFile` is dropped
//! without a commit (an error, a panic, Ctrl-C unwinding), the temporary file is removed and the
//! target is untouched, so a failed run never leaves a partial output behind. The temporary file
//! is created and removed by the `tempfile` crate (`NamedTempFile`), which also picks an unused
//! name.
//!
//! An output that resolves to one of the run's inputs is refused up front: the rename would
//! replace the input with a half-derived copy of itself.
//!
//! A process killed outright (SIGKILL, power loss) runs no destructor, so its temporary file
//! stays behind: hidden, named `.NAME.PID.XXXXXX.tmp` after the target and the writing process,
//! never under the target's own name. The next [`AtomicFile::create`] of the same target removes
//! such leftovers whose process no longer runs (on Linux, where `/proc` tells; elsewhere they are
//! left for the user). A temporary file of a live process is never touched.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// A file being written that appears at its target path only when [`commit`](Self::commit)ted.
///
/// # Example
///
/// ```
/// use std::io::Write;
/// use lidarqa_io::AtomicFile;
///
/// let dir = tempfile::tempdir().unwrap();
/// let target = dir.path().join("out.csv");
/// let mut file = AtomicFile::create(&target, &[] as &[&std::path::Path]).unwrap();
/// writeln!(file, "id,x,y,z").unwrap();
/// assert!(!target.exists()); // nothing visible yet
/// file.commit().unwrap();
/// assert_eq!(std::fs::read_to_string(&target).unwrap(), "id,x,y,z\n");
/// ```
#[derive(Debug)]
pub struct AtomicFile {
    target: PathBuf,
    temp: tempfile::NamedTempFile,
}

impl AtomicFile {
    /// Starts writing `target`, refusing if it resolves to any of `inputs`.
    ///
    /// The comparison canonicalises both sides (symbolic links, `..`, relative paths), and for a
    /// target that already exists also compares the files themselves, so `./a.las`, `a.las`
    /// and a link to it are all recognised as the same file.
    ///
    /// # Errors
    /// [`Error::OutputIsInput`] naming the input; [`Error::Io`] naming the target when its
    /// directory does not exist or is not writable.
    pub fn create<P: AsRef<Path>>(target: impl AsRef<Path>, inputs: &[P]) -> Result<Self> {
        let target = target.as_ref();
        check_not_an_input(target, inputs)?;
        let dir = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let name = target
            .file_name()
            .ok_or_else(|| {
                Error::io(
                    target,
                    std::io::Error::new(
                        std::io::ErrorKind::InvalidInput,
                        "output path has no file name",
                    ),
                )
            })?
            .to_string_lossy()
            .into_owned();
        remove_stale_temps(&dir, &name);
        // Hidden, recognisable name: `.out.laz.PID.XXXXXX.tmp`.
        let temp = tempfile::Builder::new()
            .prefix(&format!(".{name}.{}.", std::process::id()))
            .suffix(".tmp")
            .tempfile_in(&dir)
            .map_err(|e| Error::io(target, e))?;
        Ok(AtomicFile {
            target: target.to_path_buf(),
            temp,
        })
    }

    /// The path the file will have after [`commit`](Self::commit).
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// The hidden temporary file being written now.
    pub fn temp_path(&self) -> &Path {
        self.temp.path()
    }

    /// Flushes the data to disk and renames the temporary file over the target.
    ///
    /// On Unix the file gets mode 0644 (or the existing target's mode), not the 0600 of a
    /// temporary file, so that outputs are readable like any other file the user writes.
    ///
    /// # Errors
    /// [`Error::Io`] naming the target; the temporary file is then removed.
    pub fn commit(self) -> Result<()> {
        let AtomicFile { target, temp } = self;
        temp.as_file()
            .sync_all()
            .map_err(|e| Error::io(&target, e))?;
        set_output_permissions(temp.path(), &target).map_err(|e| Error::io(&target, e))?;
        temp.persist(&target)
            .map_err(|e| Error::io(&target, e.error))?;
        Ok(())
    }

    fn file(&mut self) -> &mut File {
        self.temp.as_file_mut()
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file().write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file().flush()
    }
}

impl Seek for AtomicFile {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.file().seek(pos)
    }
}

/// Removes `.{name}.PID.XXXXXX.tmp` files in `dir` left by processes that no longer run
/// (killed before they could commit or clean up). Best effort: errors are ignored, since a
/// leftover is harmless and the new output does not depend on it.
fn remove_stale_temps(dir: &Path, name: &str) {
    let prefix = format!(".{name}.");
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(file_name) = file_name.to_str() else {
            continue;
        };
        let Some(rest) = file_name
            .strip_prefix(&prefix)
            .and_then(|r| r.strip_suffix(".tmp"))
        else {
            continue;
        };
        let Some(Ok(pid)) = rest.split_once('.').map(|(pid, _)| pid.parse::<u32>()) else {
            continue;
        };
        if pid != std::process::id() && process_is_gone(pid) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// True only when the process certainly does not exist (Linux `/proc`); false when unsure.
fn process_is_gone(pid: u32) -> bool {
    let proc = Path::new("/proc");
    cfg!(target_os = "linux") && proc.join("self").exists() && !proc.join(pid.to_string()).exists()
}

#[cfg(unix)]
fn set_output_permissions(temp: &Path, target: &Path) -> std::io::Result<()> {
    use std::os::unix::fs::PermissionsExt;
    let mode = match std::fs::metadata(target) {
        Ok(m) => m.permissions().mode() & 0o7777,
        Err(_) => 0o644,
    };
    std::fs::set_permissions(temp, std::fs::Permissions::from_mode(mode))
}

#[cfg(not(unix))]
fn set_output_permissions(_temp: &Path, _target: &Path) -> std::io::Result<()> {
    Ok(())
}

/// Resolves `path` as far as it exists: the canonical parent directory joined with the file name
/// (the output usually does not exist yet, and `canonicalize` needs an existing path).
fn resolve(path: &Path) -> PathBuf {
    resolved(path)
}

/// Refuses an output path that is one of the inputs.
///
/// # Errors
/// [`Error::OutputIsInput`] naming the output and the input it equals.
pub fn check_not_an_input<P: AsRef<Path>>(output: impl AsRef<Path>, inputs: &[P]) -> Result<()> {
    InputSet::new(inputs).check(output)
}

/// A run's inputs, resolved once, against which many outputs are checked (a manifest of
/// thousands of tiles checks each output in constant time, not against every input).
#[derive(Debug, Clone, Default)]
pub struct InputSet {
    by_path: std::collections::HashMap<PathBuf, PathBuf>,
    by_id: std::collections::HashMap<(u64, u64), PathBuf>,
}

impl InputSet {
    /// The inputs, as given (they are named so in messages).
    pub fn new<P: AsRef<Path>>(inputs: &[P]) -> InputSet {
        let mut set = InputSet::default();
        for input in inputs {
            let input = input.as_ref();
            set.by_path
                .entry(resolve(input))
                .or_insert_with(|| input.to_path_buf());
            if let Some(id) = file_id(input) {
                set.by_id.entry(id).or_insert_with(|| input.to_path_buf());
            }
        }
        set
    }

    /// Refuses `output` when it resolves to one of the inputs (another spelling, a link).
    ///
    /// # Errors
    /// [`Error::OutputIsInput`] naming the output and the input it equals.
    pub fn check(&self, output: impl AsRef<Path>) -> Result<()> {
        let output = output.as_ref();
        let hit = self
            .by_path
            .get(&resolve(output))
            .or_else(|| file_id(output).and_then(|id| self.by_id.get(&id)));
        match hit {
            Some(input) => Err(Error::OutputIsInput {
                path: output.to_path_buf(),
                input: input.clone(),
            }),
            None => Ok(()),
        }
    }
}

/// Refuses a file given twice among `inputs` (the same path, another spelling of it, a link to
/// it), before any work: its points would count twice.
///
/// # Errors
/// [`Error::DuplicateInput`] naming both spellings.
pub fn check_distinct_inputs<P: AsRef<Path>>(inputs: &[P]) -> Result<()> {
    let mut seen = InputSet::default();
    for input in inputs {
        let input = input.as_ref();
        if let Err(Error::OutputIsInput { input: first, .. }) = seen.check(input) {
            return Err(Error::DuplicateInput {
                path: input.to_path_buf(),
                first,
            });
        }
        seen.by_path.insert(resolve(input), input.to_path_buf());
        if let Some(id) = file_id(input) {
            seen.by_id.insert(id, input.to_path_buf());
        }
    }
    Ok(())
}

/// The output in `dir` of each input (`dir/<input's file name>`), refused before any work when
/// two inputs would write one output, or an output would be any of `inputs` or `others`.
///
/// # Errors
/// [`Error::OutputClash`] naming both inputs; [`Error::OutputIsInput`];
/// [`Error::Io`] for an input path without a file name.
pub fn outputs_in_dir<P: AsRef<Path>, Q: AsRef<Path>>(
    dir: &Path,
    inputs: &[P],
    others: &[Q],
) -> Result<Vec<PathBuf>> {
    let mut all: Vec<&Path> = inputs.iter().map(AsRef::as_ref).collect();
    all.extend(others.iter().map(AsRef::as_ref));
    let all = InputSet::new(&all);
    let mut outputs: Vec<PathBuf> = Vec::with_capacity(inputs.len());
    let mut first_of: std::collections::HashMap<PathBuf, usize> = Default::default();
    for (k, input) in inputs.iter().enumerate() {
        let input = input.as_ref();
        let name = input.file_name().ok_or_else(|| {
            Error::io(
                input,
                std::io::Error::new(std::io::ErrorKind::InvalidInput, "no file name"),
            )
        })?;
        let out = dir.join(name);
        if let Some(&i) = first_of.get(&out) {
            return Err(Error::OutputClash {
                output: out,
                first: inputs[i].as_ref().to_path_buf(),
                second: input.to_path_buf(),
            });
        }
        all.check(&out)?;
        first_of.insert(out.clone(), k);
        outputs.push(out);
    }
    Ok(outputs)
}

/// The one output guard (SPEC §7), called by every command before any work: each of `outputs`
/// (files, summaries, reports; a directory's files named one by one) is resolved through
/// symbolic links and `..` and refused when it is one of `inputs` or another of `outputs`.
///
/// # Errors
/// [`Error::OutputIsInput`] naming the output and the input; [`Error::OutputTwice`] naming both
/// outputs.
pub fn check_outputs<P: AsRef<Path>, Q: AsRef<Path>>(outputs: &[P], inputs: &[Q]) -> Result<()> {
    let read = InputSet::new(inputs);
    let mut written = InputSet::default();
    for output in outputs {
        let output = output.as_ref();
        read.check(output)?;
        if let Err(Error::OutputIsInput { input: other, .. }) = written.check(output) {
            return Err(Error::OutputTwice {
                path: output.to_path_buf(),
                other,
            });
        }
        written
            .by_path
            .insert(resolve(output), output.to_path_buf());
        if let Some(id) = file_id(output) {
            written.by_id.insert(id, output.to_path_buf());
        }
    }
    Ok(())
}

/// `path` resolved through symbolic links and `..` as far as it exists (the canonical deepest
/// existing ancestor joined with the rest): where a write to `path` would land.
pub fn resolved(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut existing = abs.as_path();
    let mut rest: Vec<&std::ffi::OsStr> = Vec::new();
    loop {
        if let Ok(c) = existing.canonicalize() {
            let mut out = c;
            for part in rest.iter().rev() {
                if *part == ".." {
                    out.pop();
                } else if *part != "." {
                    out.push(part);
                }
            }
            return out;
        }
        match (existing.parent(), existing.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name);
                existing = parent;
            }
            _ => return abs,
        }
    }
}

/// Hard links are different paths to one file; compare device and inode where we can.
#[cfg(unix)]
fn file_id(p: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(p).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn file_id(_p: &Path) -> Option<(u64, u64)> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn temp_file_is_hidden_and_beside_the_target() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.laz");
        let f = AtomicFile::create(&target, &[] as &[&Path]).unwrap();
        assert_eq!(f.temp_path().parent(), Some(dir.path()));
        let name = f.temp_path().file_name().unwrap().to_string_lossy();
        assert!(
            name.starts_with(&format!(".out.laz.{}.", std::process::id())),
            "{name}"
        );
        assert!(name.ends_with(".tmp"), "{name}");
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn leftovers_of_dead_processes_are_removed_and_live_ones_kept() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.laz");
        // A pid above the kernel's maximum (4194304) never runs.
        let dead = dir.path().join(".out.laz.4294967295.abc123.tmp");
        let live = dir
            .path()
            .join(format!(".out.laz.{}.def456.tmp", std::process::id()));
        let init = dir.path().join(".out.laz.1.ghi789.tmp");
        let other = dir.path().join(".other.laz.4294967295.abc123.tmp");
        for p in [&dead, &live, &init, &other] {
            std::fs::write(p, "partial").unwrap();
        }
        let f = AtomicFile::create(&target, &[] as &[&Path]).unwrap();
        assert!(!dead.exists());
        assert!(live.exists() && init.exists() && other.exists());
        f.commit().unwrap();
        assert!(target.exists());
    }

    #[test]
    fn drop_without_commit_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.txt");
        {
            let mut f = AtomicFile::create(&target, &[] as &[&Path]).unwrap();
            f.write_all(b"partial").unwrap();
            assert_eq!(entries(dir.path()).len(), 1);
        }
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn drop_without_commit_keeps_existing_target() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.txt");
        std::fs::write(&target, "old").unwrap();
        {
            let mut f = AtomicFile::create(&target, &[] as &[&Path]).unwrap();
            f.write_all(b"new and partial").unwrap();
        }
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "old");
        assert_eq!(entries(dir.path()), vec!["out.txt".to_string()]);
    }

    #[test]
    fn commit_replaces_target() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.txt");
        std::fs::write(&target, "old").unwrap();
        let mut f = AtomicFile::create(&target, &[] as &[&Path]).unwrap();
        f.write_all(b"new").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
        assert_eq!(entries(dir.path()), vec!["out.txt".to_string()]);
    }

    #[cfg(unix)]
    #[test]
    fn committed_file_is_world_readable() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.txt");
        AtomicFile::create(&target, &[] as &[&Path])
            .unwrap()
            .commit()
            .unwrap();
        let mode = std::fs::metadata(&target).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o644);
    }

    #[test]
    fn refuses_output_equal_to_input_through_another_spelling() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("strip.las");
        std::fs::write(&input, "las").unwrap();
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let other_spelling = dir.path().join("sub").join("..").join("strip.las");
        let err = AtomicFile::create(&other_spelling, &[&input]).unwrap_err();
        match &err {
            Error::OutputIsInput { path, input: i } => {
                assert_eq!(path, &other_spelling);
                assert_eq!(i, &input);
            }
            other => panic!("unexpected {other:?}"),
        }
        assert!(err.to_string().contains("strip.las"));
        assert_eq!(std::fs::read_to_string(&input).unwrap(), "las");
    }

    #[cfg(unix)]
    #[test]
    fn refuses_output_that_is_a_symlink_to_an_input() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.las");
        std::fs::write(&input, "las").unwrap();
        let link = dir.path().join("link.las");
        std::os::unix::fs::symlink(&input, &link).unwrap();
        assert!(matches!(
            AtomicFile::create(&link, &[&input]),
            Err(Error::OutputIsInput { .. })
        ));
    }

    #[test]
    fn the_same_input_twice_is_refused_in_any_spelling() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("s1.las");
        let b = dir.path().join("s2.las");
        std::fs::write(&a, "1").unwrap();
        std::fs::write(&b, "2").unwrap();
        assert!(check_distinct_inputs(&[&a, &b]).is_ok());
        let err = check_distinct_inputs(&[&a, &b, &a]).unwrap_err();
        assert!(matches!(err, Error::DuplicateInput { .. }), "{err:?}");
        let text = err.to_string();
        assert!(
            text.contains("s1.las") && text.contains("given twice"),
            "{text}"
        );
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let other = dir.path().join("sub").join("..").join("s2.las");
        assert!(check_distinct_inputs(&[&b, &other]).is_err());
        #[cfg(unix)]
        {
            let link = dir.path().join("link.las");
            std::os::unix::fs::symlink(&a, &link).unwrap();
            assert!(check_distinct_inputs(&[&a, &link]).is_err());
        }
    }

    #[test]
    fn two_inputs_with_one_file_name_are_refused_naming_both() {
        let dir = tempfile::tempdir().unwrap();
        for d in ["a", "b", "out"] {
            std::fs::create_dir(dir.path().join(d)).unwrap();
        }
        let a = dir.path().join("a").join("s1.laz");
        let b = dir.path().join("b").join("s1.laz");
        let c = dir.path().join("b").join("s2.laz");
        let out = dir.path().join("out");
        let none: &[&Path] = &[];
        let ok = outputs_in_dir(&out, &[&a, &c], none).unwrap();
        assert_eq!(ok, vec![out.join("s1.laz"), out.join("s2.laz")]);
        let err = outputs_in_dir(&out, &[&a, &c, &b], none).unwrap_err();
        let text = err.to_string();
        assert!(matches!(err, Error::OutputClash { .. }), "{err:?}");
        assert!(
            text.contains("a/s1.laz") && text.contains("b/s1.laz"),
            "{text}"
        );
        // Writing into the inputs' own directory is writing over them.
        std::fs::write(&a, "x").unwrap();
        let err = outputs_in_dir(&dir.path().join("a"), &[&a], none).unwrap_err();
        assert!(matches!(err, Error::OutputIsInput { .. }), "{err:?}");
    }

    #[test]
    fn accepts_a_different_output() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.las");
        std::fs::write(&input, "las").unwrap();
        assert!(AtomicFile::create(dir.path().join("out.las"), &[&input]).is_ok());
    }

    #[test]
    fn missing_directory_is_an_io_error_naming_the_target() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("nope").join("out.las");
        let err = AtomicFile::create(&target, &[] as &[&Path]).unwrap_err();
        assert!(matches!(err, Error::Io { .. }));
        assert!(err.to_string().contains("nope"));
    }
}
