//! Extraction of an FMU archive that cannot write outside its folder and stops zip bombs early.
use std::fs::{self, File};
use std::io::{self, BufReader, Read};
use std::path::Path;

use crate::ImportError;

/// Most entries an FMU archive may have.
pub const MAX_ENTRIES: usize = 100_000;
/// Most bytes an FMU archive may expand to (2 GiB).
pub const MAX_TOTAL_SIZE: u64 = 2 << 30;

/// Bounds on what one archive may expand to.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Limits {
    pub(crate) entries: usize,
    pub(crate) bytes: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Self { entries: MAX_ENTRIES, bytes: MAX_TOTAL_SIZE }
    }
}

/// Extracts every entry of `archive` below `dest`, checking limits before writing anything.
///
/// The sizes declared in the zip directory are checked first; the bytes actually written are
/// counted too, because a hostile archive can declare small sizes and inflate to more.
pub(crate) fn extract(archive: &Path, dest: &Path, limits: Limits) -> Result<(), ImportError> {
    let zip_err = |source| ImportError::Zip { path: archive.to_path_buf(), source };
    let too_large = |reason: String| ImportError::TooLarge { path: archive.to_path_buf(), reason };
    let file = File::open(archive).map_err(|source| ImportError::Io { path: archive.to_path_buf(), source })?;
    let mut zip = zip::ZipArchive::new(BufReader::new(file)).map_err(zip_err)?;

    if zip.len() > limits.entries {
        return Err(too_large(format!("{} entries, more than the limit of {}", zip.len(), limits.entries)));
    }
    let mut declared: u64 = 0;
    for i in 0..zip.len() {
        let entry = zip.by_index_data(i).map_err(zip_err)?;
        if entry.enclosed_name().is_none() {
            return Err(ImportError::UnsafeEntry { entry: String::from_utf8_lossy(entry.name_raw()).into_owned() });
        }
        declared = declared.saturating_add(entry.size());
    }
    if declared > limits.bytes {
        return Err(too_large(format!("{declared} bytes uncompressed, more than the limit of {} bytes", limits.bytes)));
    }

    let mut written: u64 = 0;
    for i in 0..zip.len() {
        let mut entry = zip.by_index(i).map_err(zip_err)?;
        let Some(relative) = entry.enclosed_name() else {
            return Err(ImportError::UnsafeEntry { entry: String::from_utf8_lossy(entry.name_raw()).into_owned() });
        };
        let out = dest.join(relative);
        let io_err = |source| ImportError::Io { path: out.clone(), source };
        if entry.is_dir() {
            fs::create_dir_all(&out).map_err(io_err)?;
            continue;
        }
        if let Some(parent) = out.parent() {
            fs::create_dir_all(parent).map_err(|source| ImportError::Io { path: parent.to_path_buf(), source })?;
        }
        // Symlink entries are written as plain files holding the link text: never followed.
        let mut file = File::create(&out).map_err(io_err)?;
        let budget = limits.bytes - written;
        let n = io::copy(&mut (&mut entry).take(budget.saturating_add(1)), &mut file).map_err(io_err)?;
        written += n;
        if written > limits.bytes {
            return Err(too_large(format!("it inflates to more than {} bytes although its directory declares {declared}", limits.bytes)));
        }
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use std::io::Write;

    use super::*;

    fn make_zip(dir: &Path, entries: &[(&str, &[u8])]) -> std::path::PathBuf {
        let path = dir.join("t.zip");
        let mut zip = zip::ZipWriter::new(File::create(&path).unwrap());
        let opts = zip::write::SimpleFileOptions::default();
        for (name, data) in entries {
            zip.start_file(*name, opts).unwrap();
            zip.write_all(data).unwrap();
        }
        zip.finish().unwrap();
        path
    }

    #[test]
    fn extracts_nested_files() {
        let tmp = tempfile::tempdir().unwrap();
        let zip = make_zip(tmp.path(), &[("a.txt", b"A"), ("resources/sub/b.txt", b"BB")]);
        let out = tmp.path().join("out");
        extract(&zip, &out, Limits::default()).unwrap();
        assert_eq!(fs::read(out.join("a.txt")).unwrap(), b"A");
        assert_eq!(fs::read(out.join("resources/sub/b.txt")).unwrap(), b"BB");
    }

    #[test]
    fn refuses_entries_escaping_the_folder_before_writing_anything() {
        for evil in ["../evil", "a/../../evil"] {
            let tmp = tempfile::tempdir().unwrap();
            let zip = make_zip(tmp.path(), &[("ok.txt", b"fine"), (evil, b"x")]);
            let out = tmp.path().join("out");
            let err = extract(&zip, &out, Limits::default()).unwrap_err();
            assert!(matches!(&err, ImportError::UnsafeEntry { entry } if entry == evil), "{evil}: {err}");
            assert!(!out.join("ok.txt").exists(), "{evil}: nothing may be written");
            assert!(!tmp.path().join("evil").exists());
        }
    }

    #[test]
    fn absolute_entries_land_inside_the_folder() {
        // `enclosed_name` strips the root: "/etc/evil" becomes "etc/evil" below `dest`.
        let tmp = tempfile::tempdir().unwrap();
        let zip = make_zip(tmp.path(), &[("/etc/fmi2-import-evil", b"x")]);
        let out = tmp.path().join("out");
        extract(&zip, &out, Limits::default()).unwrap();
        assert!(out.join("etc/fmi2-import-evil").is_file());
        assert!(!Path::new("/etc/fmi2-import-evil").exists());
    }

    #[test]
    fn refuses_too_many_entries() {
        let tmp = tempfile::tempdir().unwrap();
        let zip = make_zip(tmp.path(), &[("a", b""), ("b", b""), ("c", b"")]);
        let err = extract(&zip, &tmp.path().join("out"), Limits { entries: 2, bytes: 100 }).unwrap_err();
        assert!(err.to_string().contains("3 entries, more than the limit of 2"), "{err}");
    }

    #[test]
    fn refuses_too_many_bytes() {
        let tmp = tempfile::tempdir().unwrap();
        let zip = make_zip(tmp.path(), &[("a", &[0; 60]), ("b", &[0; 60])]);
        let err = extract(&zip, &tmp.path().join("out"), Limits { entries: 10, bytes: 100 }).unwrap_err();
        assert!(matches!(err, ImportError::TooLarge { .. }), "{err}");
        assert!(err.to_string().contains("120 bytes uncompressed, more than the limit of 100 bytes"), "{err}");
    }

    #[test]
    fn not_a_zip_is_a_zip_error() {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("x.fmu");
        fs::write(&path, b"definitely not a zip archive").unwrap();
        let err = extract(&path, &tmp.path().join("out"), Limits::default()).unwrap_err();
        assert!(matches!(err, ImportError::Zip { .. }), "{err}");
    }
}
