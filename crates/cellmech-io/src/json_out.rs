//! JSON documents written atomically (pretty-printed, trailing newline).

use std::path::{Path, PathBuf};

use crate::atomic::write_atomic;
use crate::error::WriteError;

/// A value that cannot be written as JSON.
#[derive(Debug, thiserror::Error)]
pub enum JsonError {
    /// Serialisation failed (e.g. a map with non-string keys).
    #[error("{}: cannot serialise to JSON: {source}", path.display())]
    Serialize {
        /// The target file.
        path: PathBuf,
        /// The serde error.
        #[source]
        source: serde_json::Error,
    },
    /// Writing failed.
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// Serialises `value` as pretty JSON and writes it to `path` atomically. Non-finite floats
/// become `null` (serde_json's behaviour).
pub fn write_json_atomic<T: serde::Serialize + ?Sized>(
    path: &Path,
    value: &T,
) -> Result<(), JsonError> {
    let mut bytes = serde_json::to_vec_pretty(value).map_err(|source| JsonError::Serialize {
        path: path.to_path_buf(),
        source,
    })?;
    bytes.push(b'\n');
    write_atomic(path, &bytes)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::scratch_dir;
    use std::collections::BTreeMap;

    #[test]
    fn round_trips_a_summary() {
        let dir = scratch_dir("json");
        let path = dir.join("summary.json");
        let mut summary = BTreeMap::new();
        summary.insert("effective_modulus_kPa", 0.85);
        summary.insert("max_force_nN", 12.5);
        write_json_atomic(&path, &summary).unwrap();
        let back: BTreeMap<String, f64> =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(back["effective_modulus_kPa"], 0.85);
        assert_eq!(back["max_force_nN"], 12.5);
        let mut bad = BTreeMap::new();
        bad.insert((1, 2), 3);
        let err = write_json_atomic(&path, &bad).unwrap_err().to_string();
        assert!(
            err.contains("summary.json") && err.contains("serialise"),
            "{err}"
        );
    }
}
