//! Reading input files safely: every file flexsurf reads (scenes, material files, NURBS bodies, OBJ meshes)
//! goes through [`read_text`], which opens a path only if it is a regular file (a FIFO, a device or a
//! directory is refused before it is opened, so reading never blocks), refuses files larger than
//! [`MAX_INPUT_BYTES`], reports invalid UTF-8 with its byte position, and never puts any of the file's contents
//! into an error message. While a [`recording`] is active, each file read is also recorded with its SHA-256
//! (the provenance of `summary.json`).

use sha2::{Digest, Sha256};
use std::cell::RefCell;
use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

/// The largest input file read (bytes): far above any scene, material, body or mesh file shipped (the
/// mannequin is 60 kB), far below what would exhaust memory.
pub const MAX_INPUT_BYTES: u64 = 64 << 20;

/// One file read: its path as given, its size and its SHA-256 (lower-case hex).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct InputFile {
    /// The path as it was opened.
    pub path: String,
    /// Size in bytes.
    pub bytes: u64,
    /// SHA-256 of the contents, lower-case hex.
    pub sha256: String,
}

thread_local! {
    static LOG: RefCell<Option<Vec<InputFile>>> = const { RefCell::new(None) };
}

/// Runs `f` and returns what it returned with the files it read through [`read_text`] (in the order read,
/// each path once). Recordings nest: an inner one's files are also the outer one's.
pub fn recording<T>(f: impl FnOnce() -> T) -> (T, Vec<InputFile>) {
    let outer = LOG.with(|l| l.borrow_mut().replace(Vec::new()));
    let value = f();
    let inner = LOG.with(|l| l.borrow_mut().take()).unwrap_or_default();
    if let Some(mut outer) = outer {
        for file in &inner {
            if !outer.contains(file) {
                outer.push(file.clone());
            }
        }
        LOG.with(|l| *l.borrow_mut() = Some(outer));
    }
    (value, inner)
}

/// SHA-256 of `bytes`, lower-case hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

/// `bytes` in lower-case hex.
pub fn hex(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(2 * bytes.len());
    for b in bytes {
        use std::fmt::Write as _;
        let _ = write!(s, "{b:02x}");
    }
    s
}

fn kind_name(ft: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if ft.is_socket() {
            return "a socket";
        }
        if ft.is_char_device() || ft.is_block_device() {
            return "a device";
        }
    }
    if ft.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

/// The bytes of the regular file at `path` (at most [`MAX_INPUT_BYTES`]). Errors name what is wrong, never
/// the contents.
pub fn read_bytes(path: &Path) -> io::Result<Vec<u8>> {
    read_bytes_limited(path, MAX_INPUT_BYTES)
}

/// As [`read_bytes`] with the size limit `limit` (bytes).
pub fn read_bytes_limited(path: &Path, limit: u64) -> io::Result<Vec<u8>> {
    // Stat first (following symlinks): opening a FIFO for reading would block until a writer appears.
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        let what = kind_name(meta.file_type());
        return Err(io::Error::new(io::ErrorKind::InvalidInput, format!("it is {what}, not a regular file")));
    }
    if meta.len() > limit {
        return Err(too_large(meta.len(), limit));
    }
    let file = File::open(path)?;
    // The path may have been replaced between the two calls: check what was opened.
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(io::Error::new(io::ErrorKind::InvalidInput, "it is not a regular file"));
    }
    let mut bytes = Vec::with_capacity(meta.len().min(limit) as usize);
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64, limit));
    }
    LOG.with(|l| {
        if let Some(log) = l.borrow_mut().as_mut() {
            let entry =
                InputFile { path: path.display().to_string(), bytes: bytes.len() as u64, sha256: sha256_hex(&bytes) };
            if !log.contains(&entry) {
                log.push(entry);
            }
        }
    });
    Ok(bytes)
}

fn too_large(bytes: u64, limit: u64) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidInput,
        format!("it is {bytes} bytes, larger than the {limit} bytes an input file may have"),
    )
}

/// The text of the regular file at `path` (see [`read_bytes`]); invalid UTF-8 is an error giving the byte
/// offset, line and column of the first bad byte.
pub fn read_text(path: &Path) -> io::Result<String> {
    let bytes = read_bytes(path)?;
    String::from_utf8(bytes).map_err(|e| {
        let offset = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let (line, column) = crate::scene::spans::line_col_bytes(bytes, offset);
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!("invalid UTF-8 at byte {offset} (line {line}, column {column})"),
        )
    })
}
