//! File digests (size + BLAKE3) and seeds derived from a tile id.
//!
//! A manifest records the digest of every input so that a run can tell a changed input from
//! the one that was planned, and a tile report records the digest of the output it vouches for,
//! so that a truncated or replaced output is never taken as complete.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::io::Read;
use std::path::Path;

/// Size and BLAKE3 hash of a file's bytes.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileDigest {
    /// Length, bytes.
    pub size: u64,
    /// BLAKE3 of the content, 64 lowercase hex digits.
    pub blake3: String,
}

impl FileDigest {
    /// Reads `path` once and hashes it.
    ///
    /// # Errors
    /// An I/O error naming the file.
    pub fn of_file(path: &Path) -> Result<FileDigest> {
        let io = |source| {
            Error::Io(lidarqa_io::Error::Io {
                path: path.to_path_buf(),
                source,
            })
        };
        let mut f = std::fs::File::open(path).map_err(io)?;
        let mut hasher = blake3::Hasher::new();
        let mut buf = vec![0u8; 1 << 20];
        let mut size = 0u64;
        loop {
            let n = f.read(&mut buf).map_err(io)?;
            if n == 0 {
                break;
            }
            size += n as u64;
            hasher.update(&buf[..n]);
        }
        Ok(FileDigest {
            size,
            blake3: hasher.finalize().to_hex().to_string(),
        })
    }

    /// Whether `path` still has this digest: the size is compared first (a stat), the hash
    /// only when the sizes agree. A missing or unreadable file is `false`.
    pub fn matches(&self, path: &Path) -> bool {
        match std::fs::metadata(path) {
            Ok(m) if m.is_file() && m.len() == self.size => {
                FileDigest::of_file(path).is_ok_and(|d| d == *self)
            }
            _ => false,
        }
    }
}

/// The seed of a tile's random draws: the first 8 bytes (little endian) of BLAKE3 of its id,
/// so a tile gets the same seed whichever machine, process or order runs it (SPEC §9).
///
/// ```
/// use lidarqa_pipeline::seed_for_tile;
/// assert_eq!(seed_for_tile("tile_0_0"), seed_for_tile("tile_0_0"));
/// assert_ne!(seed_for_tile("tile_0_0"), seed_for_tile("tile_0_1"));
/// ```
pub fn seed_for_tile(id: &str) -> u64 {
    let h = blake3::hash(id.as_bytes());
    let mut b = [0u8; 8];
    b.copy_from_slice(&h.as_bytes()[..8]);
    u64::from_le_bytes(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digest_of_known_content_and_mismatch_on_change() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.bin");
        std::fs::write(&p, b"abc").unwrap();
        let d = FileDigest::of_file(&p).unwrap();
        assert_eq!(d.size, 3);
        // BLAKE3("abc") from the reference implementation's test vectors.
        assert_eq!(
            d.blake3,
            "6437b3ac38465133ffb63b75273a8db548c558465d79db03fd359c6cd5bd9d85"
        );
        assert!(d.matches(&p));
        std::fs::write(&p, b"abd").unwrap();
        assert!(!d.matches(&p));
        std::fs::remove_file(&p).unwrap();
        assert!(!d.matches(&p));
    }
}
