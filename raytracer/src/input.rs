//! Reading input files safely: every file the program reads (scenes and
//! their includes, OBJ and MTL files, data, function, font, BSDF, picture,
//! octree and mesh files, view files) goes through [`read_input`], which
//!
//! - refuses anything that is not a regular file (a directory, a FIFO, a
//!   device such as `/dev/zero`), so that no input can hang a load or make
//!   it read without end;
//! - refuses files larger than a cap ([`MAX_INPUT_BYTES`], 2 GiB, for
//!   scene data; [`MAX_VIEW_BYTES`], 1 MiB, for view files), checked both
//!   before and while reading (a file that grows is cut off at the cap and
//!   refused).
//!
//! Errors are `std::io::Error`s with a message saying which limit was hit,
//! so each caller keeps its own "cannot read ... file" wording and location.

use std::io::{self, Read};
use std::path::Path;

/// The largest scene, OBJ, MTL, data, picture, font, function, BSDF,
/// octree or mesh file read (2 GiB).
pub const MAX_INPUT_BYTES: u64 = 2 << 30;

/// The largest view file read (1 MiB): a view file holds a few lines.
pub const MAX_VIEW_BYTES: u64 = 1 << 20;

fn too_large(cap: u64) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("file larger than the {} limit", human(cap)),
    )
}

fn human(cap: u64) -> String {
    if cap >= 1 << 30 && cap % (1 << 30) == 0 {
        format!("{} GiB", cap >> 30)
    } else if cap >= 1 << 20 && cap % (1 << 20) == 0 {
        format!("{} MiB", cap >> 20)
    } else {
        format!("{cap} bytes")
    }
}

/// Checks that `path` names a regular file (following symbolic links) of
/// at most `cap` bytes, without opening it (opening a FIFO would block).
pub fn check_input(path: &Path, cap: u64) -> io::Result<()> {
    let meta = std::fs::metadata(path)?;
    let kind = meta.file_type();
    if kind.is_dir() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "is a directory, not a file",
        ));
    }
    if !kind.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "not a regular file (a device, FIFO or socket cannot be read as input)",
        ));
    }
    if meta.len() > cap {
        return Err(too_large(cap));
    }
    Ok(())
}

/// Reads a whole input file of at most `cap` bytes; see the module notes.
pub fn read_input(path: &Path, cap: u64) -> io::Result<Vec<u8>> {
    check_input(path, cap)?;
    let file = std::fs::File::open(path)?;
    // The file may have been replaced between the check and the open.
    if !file.metadata()?.file_type().is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "not a regular file",
        ));
    }
    read_capped(file, cap)
}

/// Reads a stream (standard input) to its end, refusing more than `cap`
/// bytes.
pub fn read_capped(r: impl Read, cap: u64) -> io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    r.take(cap.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > cap {
        return Err(too_large(cap));
    }
    Ok(bytes)
}

/// [`read_input`] as text; bytes that are not UTF-8 are replaced (Radiance
/// reads bytes, so Latin-1 comments do not reject a file).
pub fn read_input_text(path: &Path, cap: u64) -> io::Result<String> {
    let bytes = read_input(path, cap)?;
    Ok(match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => String::from_utf8_lossy(e.as_bytes()).into_owned(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_devices_directories_and_large_files() {
        let e = read_input(Path::new("/dev/zero"), MAX_INPUT_BYTES).unwrap_err();
        assert!(e.to_string().contains("not a regular file"), "{e}");
        let e = read_input(Path::new("/"), MAX_INPUT_BYTES).unwrap_err();
        assert!(e.to_string().contains("directory"), "{e}");
        let dir = std::env::temp_dir().join(format!("hybrid-rt-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("big.rad");
        std::fs::write(&f, vec![b'#'; 100]).unwrap();
        let e = read_input(&f, 99).unwrap_err();
        assert!(
            e.to_string().contains("larger than the 99 bytes limit"),
            "{e}"
        );
        assert_eq!(read_input(&f, 100).unwrap().len(), 100);
        // A FIFO without a writer would block an open(): it is refused first.
        #[cfg(unix)]
        {
            let fifo = dir.join("pipe.rad");
            let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
            // SAFETY: a valid NUL-terminated path.
            assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
            let e = read_input(&fifo, MAX_INPUT_BYTES).unwrap_err();
            assert!(e.to_string().contains("not a regular file"), "{e}");
        }
        let e = read_capped(&[0u8; 10][..], 9).unwrap_err();
        assert!(e.to_string().contains("limit"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
