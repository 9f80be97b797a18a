//! The cell index of a compiled scene, read as a stream.
//!
//! The index has an entry per cell of the whole scene (16 bytes decoded;
//! about 800,000 of them in a 1.5-million-triangle city). A processor
//! needs the entries of its own cells only, so the index is never held
//! whole on the way to them: [`IndexAt::scan`] reads it through a small
//! buffer, checking its checksum, its length and that every entry lies
//! within the file, and hands each entry to its caller, which keeps the
//! ones it wants. Opening a scene scans it once to check it; reading a
//! processor's cells scans it again for their entries.
//!
//! The checksum covers the whole index, so it is known only at the end:
//! where an entry cannot be decoded, the scan reads on to the end and
//! reports the checksum (the file is damaged) if that does not match
//! either, and the entry's error otherwise.

use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::{Error, Result, SourceLoc};

/// Where a cell lies in the file. Its length is a `u32` (16 bytes an
/// entry decoded instead of 24); the encoding is the same varint as a
/// `u64`'s, so files written with a 64-bit length read alike.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CellEntry {
    pub offset: u64,
    pub len: u32,
    pub crc: u32,
}

/// An error in compiled scene `path` at byte `offset`.
pub(super) fn file_error(path: &Path, offset: u64, reason: impl std::fmt::Display) -> Error {
    Error::parse(
        SourceLoc::new(path, 0),
        format!("compiled scene, byte {offset}: {reason}"),
    )
}

/// Bytes of the buffer the index is read through.
const CHUNK: usize = 64 << 10;

/// Most bytes one entry takes (varints: 10 for the offset, 5 for each
/// `u32`), and the sequence's length.
const MAX_ENTRY: usize = 20;

/// Where a compiled scene's index lies, and what it was checked to hold.
#[derive(Debug, Clone, Copy)]
pub(super) struct IndexAt {
    /// Its first byte in the file.
    pub(super) offset: u64,
    pub(super) len: u64,
    pub(super) crc: u32,
    /// Its entries (set by [`IndexAt::check`]).
    pub(super) cells: usize,
}

impl IndexAt {
    /// Scans the index once (see [`IndexAt::scan`]) and records how many
    /// entries it has, which must be `cells`.
    pub(super) fn check(
        mut self,
        path: &Path,
        file: &std::fs::File,
        file_len: u64,
        cells: usize,
    ) -> Result<IndexAt> {
        let n = self.scan(path, file, file_len, |_, _| {})?;
        if n != cells {
            return Err(file_error(
                path,
                self.offset,
                format!("the index has {n} cells, the skeleton {cells}"),
            ));
        }
        self.cells = n;
        Ok(self)
    }

    /// Reads the index from `file` (of `file_len` bytes) through a buffer
    /// of [`CHUNK`] bytes, handing each entry, with its cell's number, to
    /// `keep`; returns the number of entries. An error (checksum, an entry
    /// that cannot be decoded or lies beyond the file's end, bytes left
    /// over) names the file, the byte offset and why; `keep` may have seen
    /// entries before it, which the caller must not use then.
    pub(super) fn scan(
        &self,
        path: &Path,
        file: &std::fs::File,
        file_len: u64,
        mut keep: impl FnMut(usize, CellEntry),
    ) -> Result<usize> {
        let mut reader = file;
        reader
            .seek(SeekFrom::Start(self.offset))
            .map_err(|e| Error::io(path, e))?;
        let mut st = Stream {
            reader,
            path,
            hasher: crc32fast::Hasher::new(),
            buf: vec![0u8; CHUNK],
            lo: 0,
            hi: 0,
            unread: self.len,
        };
        // The offset in the index of `st.buf[st.lo]`.
        let mut pos = 0u64;
        let mut failed: Option<Error> = None;
        let mut count: Option<usize> = None;
        let mut k = 0usize;
        loop {
            // Refilled where it may hold less than a whole entry.
            if st.hi - st.lo < MAX_ENTRY && st.unread > 0 {
                st.fill()?;
            }
            let at = self.offset + pos;
            let bytes = &st.buf[st.lo..st.hi];
            let used = match count {
                None => match postcard::take_from_bytes::<u64>(bytes) {
                    Ok((n, rest)) => {
                        count = Some(usize::try_from(n).unwrap_or(usize::MAX));
                        bytes.len() - rest.len()
                    }
                    Err(e) => {
                        failed = Some(file_error(path, at, format!("cannot decode: {e}")));
                        break;
                    }
                },
                Some(n) if k == n => break,
                Some(_) => match postcard::take_from_bytes::<CellEntry>(bytes) {
                    Ok((e, rest)) => {
                        if e.offset
                            .checked_add(e.len.into())
                            .is_none_or(|end| end > file_len)
                        {
                            failed = Some(file_error(
                                path,
                                file_len,
                                format!(
                                    "truncated: cell {k} lies at bytes {}..{}, the file has {file_len}",
                                    e.offset,
                                    e.offset.saturating_add(e.len.into())
                                ),
                            ));
                            break;
                        }
                        keep(k, e);
                        k += 1;
                        bytes.len() - rest.len()
                    }
                    Err(e) => {
                        failed = Some(file_error(path, at, format!("cannot decode: {e}")));
                        break;
                    }
                },
            };
            st.lo += used;
            pos += used as u64;
        }
        let left = (st.hi - st.lo) as u64 + st.unread;
        // The rest of the index, for its checksum.
        while st.unread > 0 {
            st.lo = st.hi;
            st.fill()?;
        }
        if st.hasher.finalize() != self.crc {
            return Err(file_error(
                path,
                self.offset,
                "the checksum of the cell index does not match (damaged file)",
            ));
        }
        if let Some(e) = failed {
            return Err(e);
        }
        if left > 0 {
            return Err(file_error(
                path,
                self.offset + pos,
                format!("{left} bytes left over after the data"),
            ));
        }
        Ok(k)
    }

    /// The entries of `cells` (ascending, each once), in that order: one
    /// scan of the index.
    pub(super) fn entries_of(
        &self,
        path: &Path,
        file: &std::fs::File,
        file_len: u64,
        cells: &[u32],
    ) -> Result<Vec<CellEntry>> {
        debug_assert!(cells.windows(2).all(|w| w[0] < w[1]));
        if let Some(&last) = cells.last() {
            if last as usize >= self.cells {
                return Err(file_error(
                    path,
                    self.offset,
                    format!("no cell {last} of {}", self.cells),
                ));
            }
        }
        let mut out = Vec::with_capacity(cells.len());
        let mut next = cells.iter().peekable();
        let n = self.scan(path, file, file_len, |k, e| {
            if next.peek().is_some_and(|&&c| c as usize == k) {
                out.push(e);
                next.next();
            }
        })?;
        // A file changed since it was opened.
        if out.len() != cells.len() {
            return Err(file_error(
                path,
                self.offset,
                format!(
                    "the index has {n} cells, {} when the file was opened",
                    self.cells
                ),
            ));
        }
        Ok(out)
    }

    /// Every entry, in order (a whole scene's load).
    pub(super) fn all(
        &self,
        path: &Path,
        file: &std::fs::File,
        file_len: u64,
    ) -> Result<Vec<CellEntry>> {
        let mut out = Vec::with_capacity(self.cells);
        self.scan(path, file, file_len, |_, e| out.push(e))?;
        Ok(out)
    }
}

/// The index being read: `buf[lo..hi]` read and not decoded, `unread`
/// bytes of it still in the file, `hasher` over every byte read.
struct Stream<'a> {
    reader: &'a std::fs::File,
    path: &'a Path,
    hasher: crc32fast::Hasher,
    buf: Vec<u8>,
    lo: usize,
    hi: usize,
    unread: u64,
}

impl Stream<'_> {
    /// Moves what is left to the front and reads as much as fits.
    fn fill(&mut self) -> Result<()> {
        self.buf.copy_within(self.lo..self.hi, 0);
        self.hi -= self.lo;
        self.lo = 0;
        let want =
            (self.buf.len() - self.hi).min(usize::try_from(self.unread).unwrap_or(usize::MAX));
        let new = &mut self.buf[self.hi..self.hi + want];
        self.reader
            .read_exact(new)
            .map_err(|e| Error::io(self.path, e))?;
        self.hasher.update(new);
        self.hi += want;
        self.unread -= want as u64;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An index of several buffers' worth, its entries of every varint
    /// length straddling the buffer's refills, read back whole and in
    /// part; and its errors.
    #[test]
    fn entries_straddling_the_buffer_read_alike_and_errors_name_the_offset() {
        let entries: Vec<CellEntry> = (0..20_000u64)
            .map(|k| CellEntry {
                offset: k * k * 7919 % (1 << 40),
                len: (k * 31 % 70_000) as u32,
                crc: (k.wrapping_mul(2_654_435_761)) as u32,
            })
            .collect();
        let bytes = postcard::to_stdvec(&entries).unwrap();
        assert!(bytes.len() > 3 * CHUNK, "{}", bytes.len());
        let dir = std::env::temp_dir().join(format!("hrt-index-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("index.bin");
        let pad = 100usize;
        let mut file_bytes = vec![0u8; pad];
        file_bytes.extend_from_slice(&bytes);
        std::fs::write(&path, &file_bytes).unwrap();
        let file = std::fs::File::open(&path).unwrap();
        let far = 1u64 << 41;
        let at = IndexAt {
            offset: pad as u64,
            len: bytes.len() as u64,
            crc: crc32fast::hash(&bytes),
            cells: 0,
        };
        let checked = at.check(&path, &file, far, entries.len()).unwrap();
        assert_eq!(checked.cells, entries.len());
        assert_eq!(checked.all(&path, &file, far).unwrap(), entries);
        let want: Vec<u32> = (0..20_000).step_by(9).chain([19_999]).collect();
        let got = checked.entries_of(&path, &file, far, &want).unwrap();
        let expect: Vec<CellEntry> = want.iter().map(|&k| entries[k as usize]).collect();
        assert_eq!(got, expect);
        let e = checked
            .entries_of(&path, &file, far, &[20_000])
            .unwrap_err()
            .to_string();
        assert!(e.contains("no cell 20000 of 20000"), "{e}");
        // Another count than the skeleton's.
        let e = at
            .check(&path, &file, far, entries.len() + 1)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("the index has 20000 cells, the skeleton 20001"),
            "{e}"
        );
        // An entry beyond the file's end.
        let e = at
            .check(&path, &file, 1000, entries.len())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("truncated: cell") && e.contains("index.bin"),
            "{e}"
        );
        // A damaged byte: the checksum, whatever the entries decode to.
        let wrong = IndexAt {
            crc: at.crc ^ 1,
            ..at
        };
        let e = wrong
            .check(&path, &file, far, entries.len())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("checksum of the cell index") && e.contains("byte 100"),
            "{e}"
        );
        // Bytes after the last entry.
        let longer = IndexAt {
            len: at.len + 3,
            crc: crc32fast::hash(&[&bytes[..], &[0, 0, 0]].concat()),
            ..at
        };
        std::fs::write(&path, [&file_bytes[..], &[0, 0, 0]].concat()).unwrap();
        let file = std::fs::File::open(&path).unwrap();
        let e = longer
            .check(&path, &file, far, entries.len())
            .unwrap_err()
            .to_string();
        assert!(e.contains("3 bytes left over"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
