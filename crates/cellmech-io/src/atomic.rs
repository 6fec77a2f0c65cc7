//! Atomic file replacement: write a temporary file in the target's directory, flush, fsync,
//! then rename it over the target. A crash leaves either the old file or the new one, never a
//! half-written file (on file systems where `rename` is atomic, i.e. all POSIX local ones).

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::WriteError;

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Writes to `path` atomically through a writer handed to `fill`.
///
/// The writer is buffered; `fill` may write in small pieces. If `fill` fails, the temporary
/// file is removed and the target is left untouched.
pub fn write_atomic_with<F>(path: &Path, fill: F) -> Result<(), WriteError>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    let wrap = |source| WriteError {
        path: path.to_path_buf(),
        source,
    };
    let temp = temp_path(path, "tmp");
    let result = (|| {
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temp)?;
        let mut writer = BufWriter::new(file);
        fill(&mut writer)?;
        let file = writer.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        rename_durably(&temp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&temp);
    }
    result.map_err(wrap)
}

/// A fresh temporary path in the directory of `target`, keeping the extension `ext` (some
/// encoders choose the format by extension).
pub(crate) fn temp_path(target: &Path, ext: &str) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".to_string());
    let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
    let temp_name = format!(".{name}.{}-{n}.{ext}", std::process::id());
    match target.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.join(temp_name),
        _ => PathBuf::from(temp_name),
    }
}

/// Fsyncs an already written temporary file, renames it over `target` and fsyncs the
/// directory so that the rename itself is durable.
pub(crate) fn commit_temp(temp: &Path, target: &Path) -> io::Result<()> {
    File::open(temp)?.sync_all()?;
    rename_durably(temp, target)
}

/// Renames an already synced temporary file over `target` and fsyncs the directory.
fn rename_durably(temp: &Path, target: &Path) -> io::Result<()> {
    fs::rename(temp, target)?;
    #[cfg(unix)]
    {
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        // Directory fsync is best effort: some file systems refuse it.
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_util::scratch_dir;

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn writes_and_replaces_without_leftovers() {
        let dir = scratch_dir("atomic-replace");
        let target = dir.join("a.txt");
        write_atomic(&target, b"first").unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"first");
        write_atomic_with(&target, |w| {
            w.write_all(b"sec")?;
            w.write_all(b"ond")
        })
        .unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"second");
        assert_eq!(entries(&dir), vec!["a.txt".to_string()]);
    }

    #[test]
    fn failing_fill_keeps_old_content_and_removes_temp() {
        let dir = scratch_dir("atomic-fail");
        let target = dir.join("b.txt");
        write_atomic(&target, b"old").unwrap();
        let err = write_atomic_with(&target, |w| {
            w.write_all(b"partial new content")?;
            Err(io::Error::other("simulated crash"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("b.txt"), "{err}");
        assert!(err.to_string().contains("simulated crash"), "{err}");
        assert_eq!(fs::read(&target).unwrap(), b"old");
        assert_eq!(entries(&dir), vec!["b.txt".to_string()]);
    }

    #[test]
    fn missing_directory_is_an_error_naming_the_file() {
        let dir = scratch_dir("atomic-missing");
        let target = dir.join("no/such/dir/c.txt");
        let err = write_atomic(&target, b"x").unwrap_err();
        assert_eq!(err.path, target);
    }
}
