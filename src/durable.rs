//! Files that survive a kill: whole files replaced atomically (written to a
//! temporary file in the same folder, flushed, synced, renamed over the old
//! one), and CSV series that a restart continues instead of recreating.
//!
//! A kill at any moment leaves either the old file or the new one, never a
//! mixture; every write error (the last buffered bytes included) is an error
//! that names the file.

use crate::error::TalusError;
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

/// The temporary name a file is written under before it replaces `path`.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().map(|n| n.to_os_string()).unwrap_or_default();
    name.push(".partial");
    path.with_file_name(name)
}

/// Replace `path` by the bytes `write` produces: temporary file, flush, fsync,
/// rename, fsync of the folder. On any error the old file is untouched.
pub fn write_atomic(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>) -> Result<(), TalusError> {
    let tmp = partial_path(path);
    let io = |what: &str, e| TalusError::io(format!("{what} {}", tmp.display()), e);
    let f = File::create(&tmp).map_err(|e| io("cannot create", e))?;
    let mut w = BufWriter::new(f);
    write(&mut w).map_err(|e| io("writing", e))?;
    let f = w.into_inner().map_err(|e| io("writing", e.into_error()))?;
    f.sync_all().map_err(|e| io("syncing", e))?;
    drop(f);
    rename_durably(&tmp, path)
}

/// Make the finished file `tmp` (written by a library that writes its own
/// files, HDF5) durable and rename it over `path`, as [`write_atomic`] does.
pub fn sync_rename(tmp: &Path, path: &Path) -> Result<(), TalusError> {
    let f = File::open(tmp).map_err(|e| TalusError::io(format!("cannot open {}", tmp.display()), e))?;
    f.sync_all().map_err(|e| TalusError::io(format!("syncing {}", tmp.display()), e))?;
    drop(f);
    rename_durably(tmp, path)
}

/// Rename the synced file `tmp` over `path`, then sync the folder so that
/// the rename itself is durable (a folder that cannot be opened for syncing,
/// on some file systems, is not an error).
fn rename_durably(tmp: &Path, path: &Path) -> Result<(), TalusError> {
    std::fs::rename(tmp, path).map_err(|e| TalusError::io(format!("cannot rename {} to {}", tmp.display(), path.display()), e))?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
    }
    Ok(())
}

/// A CSV series written row by row and flushed at every `flush`.
pub struct Series {
    path: PathBuf,
    out: BufWriter<File>,
}

impl Series {
    /// Open the series at `path` with `header`. Without `resume_step` the file
    /// is created anew. With it (a restart), the rows already there are kept up
    /// to and including that step (column `step_column`), the rest dropped (a
    /// run killed after its last checkpoint wrote them, or a partial last line),
    /// and new rows are appended. A file whose header differs is refused.
    pub fn open(path: &Path, header: &str, step_column: usize, resume_step: Option<u64>) -> Result<Series, TalusError> {
        let keep = match resume_step {
            Some(s) if path.exists() => Some(kept_rows(path, header, step_column, s)?),
            _ => None,
        };
        write_atomic(path, |w| {
            writeln!(w, "{header}")?;
            for row in keep.iter().flatten() {
                writeln!(w, "{row}")?;
            }
            Ok(())
        })?;
        let f = OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| TalusError::io(format!("cannot open {}", path.display()), e))?;
        Ok(Series { path: path.to_path_buf(), out: BufWriter::new(f) })
    }

    pub fn row(&mut self, line: &str) -> Result<(), TalusError> {
        writeln!(self.out, "{line}").map_err(|e| TalusError::io(format!("writing {}", self.path.display()), e))
    }

    /// Push the rows written so far to the file (every output interval).
    pub fn flush(&mut self) -> Result<(), TalusError> {
        self.out.flush().map_err(|e| TalusError::io(format!("writing {}", self.path.display()), e))
    }
}

/// The rows of an existing series at or before `step`.
fn kept_rows(path: &Path, header: &str, step_column: usize, step: u64) -> Result<Vec<String>, TalusError> {
    let f = File::open(path).map_err(|e| TalusError::io(format!("cannot read {}", path.display()), e))?;
    let mut lines = BufReader::new(f).lines();
    let first = lines.next().transpose().map_err(|e| TalusError::io(format!("reading {}", path.display()), e))?;
    if let Some(h) = first.filter(|h| h != header) {
        return Err(TalusError::Input(format!(
            "{}: its columns ({h}) are not the ones this case writes ({header}); restart into another --out folder",
            path.display()
        )));
    }
    let width = header.split(',').count();
    let mut rows = Vec::new();
    for line in lines {
        let line = line.map_err(|e| TalusError::io(format!("reading {}", path.display()), e))?;
        let fields: Vec<&str> = line.split(',').collect();
        // a row cut short by a kill has fewer fields (or an unparsable step): dropped
        let row_step = fields.get(step_column).and_then(|s| s.parse::<u64>().ok());
        match row_step {
            Some(s) if fields.len() == width && s <= step => rows.push(line),
            _ => break,
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_resumed_series_keeps_rows_up_to_the_step_and_drops_a_cut_line() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("s.csv");
        std::fs::write(&p, "t,step,x\n0,0,1\n1,10,2\n2,20,3\n3,30,4\n4,4").unwrap();
        let mut s = Series::open(&p, "t,step,x", 1, Some(20)).unwrap();
        s.row("3,30,9").unwrap();
        s.flush().unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "t,step,x\n0,0,1\n1,10,2\n2,20,3\n3,30,9\n");
    }

    #[test]
    fn a_series_with_other_columns_is_refused_on_resume() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("s.csv");
        std::fs::write(&p, "t,step,y\n0,0,1\n").unwrap();
        let e = Series::open(&p, "t,step,x", 1, Some(0)).err().unwrap().to_string();
        assert!(e.contains("s.csv") && e.contains("t,step,y") && e.contains("another --out"), "{e}");
    }

    #[test]
    fn an_atomic_write_that_fails_leaves_the_old_file() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("a.bin");
        std::fs::write(&p, b"old").unwrap();
        let e = write_atomic(&p, |_| Err(std::io::Error::other("disk full"))).err().unwrap().to_string();
        assert!(e.contains("a.bin.partial") && e.contains("disk full"), "{e}");
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
    }
}
