//! pythonfmu support, the safe half: recognising such FMUs and finding libpython.
//!
//! pythonfmu's binary (`libpythonfmu-export.so`, renamed to `<modelIdentifier>.so`) calls the
//! Python C API but does not link libpython, so libpython must already be loaded with
//! `RTLD_GLOBAL`. pythonfmu's builder (`pythonfmu/builder.py`, checked in 0.7.0) always writes
//! `resources/slavemodule.txt`, the name of the module the binary imports: that file marks a
//! pythonfmu FMU.
use std::path::{Path, PathBuf};
use std::process::Command;

/// Environment variable naming the libpython to load for pythonfmu FMUs; when set, nothing else
/// is tried.
pub const LIBPYTHON_ENV: &str = "FMI2_IMPORT_LIBPYTHON";

/// Whether the extracted FMU at `root` was built by pythonfmu.
pub(crate) fn is_pythonfmu(root: &Path) -> bool {
    root.join("resources").join("slavemodule.txt").is_file()
}

/// Prints `LIBDIR`, `INSTSONAME` and `LDLIBRARY`, one a line.
const SYSCONFIG: &str = "import sysconfig as s\nfor k in ('LIBDIR', 'INSTSONAME', 'LDLIBRARY'): print(s.get_config_var(k) or '')";

/// Where libpython may be, best first: [`LIBPYTHON_ENV`] alone when set; otherwise what the
/// `python3` on `PATH` reports, then well-known sonames for the dynamic loader to search.
pub(crate) fn libpython_candidates() -> Vec<PathBuf> {
    if let Some(path) = std::env::var_os(LIBPYTHON_ENV) {
        return vec![PathBuf::from(path)];
    }
    let mut out = Vec::new();
    if let Ok(run) = Command::new("python3").args(["-c", SYSCONFIG]).output()
        && run.status.success()
    {
        out.extend(parse_sysconfig(&String::from_utf8_lossy(&run.stdout)));
    }
    for minor in (8..=14).rev() {
        out.push(PathBuf::from(format!("libpython3.{minor}.so.1.0")));
        out.push(PathBuf::from(format!("libpython3.{minor}.so")));
    }
    let mut seen = std::collections::HashSet::new();
    out.retain(|p| seen.insert(p.clone()));
    out
}

/// Turns the output of [`SYSCONFIG`] into candidate paths (static `.a` libraries are skipped).
fn parse_sysconfig(text: &str) -> Vec<PathBuf> {
    let mut lines = text.lines().map(str::trim);
    let libdir = lines.next().unwrap_or_default();
    let mut out = Vec::new();
    for name in lines.take(2).filter(|n| !n.is_empty() && !n.ends_with(".a")) {
        if !libdir.is_empty() {
            out.push(Path::new(libdir).join(name));
        }
        out.push(PathBuf::from(name));
    }
    out
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn slavemodule_txt_marks_a_pythonfmu_fmu() {
        let tmp = tempfile::tempdir().unwrap();
        assert!(!is_pythonfmu(tmp.path()));
        std::fs::create_dir(tmp.path().join("resources")).unwrap();
        std::fs::write(tmp.path().join("resources/other.txt"), "x").unwrap();
        assert!(!is_pythonfmu(tmp.path()));
        std::fs::write(tmp.path().join("resources/slavemodule.txt"), "model").unwrap();
        assert!(is_pythonfmu(tmp.path()));
    }

    #[test]
    fn sysconfig_output_gives_full_paths_then_sonames() {
        let got = parse_sysconfig("/opt/py/lib\nlibpython3.11.so.1.0\nlibpython3.11.so\n");
        assert_eq!(got, ["/opt/py/lib/libpython3.11.so.1.0", "libpython3.11.so.1.0", "/opt/py/lib/libpython3.11.so", "libpython3.11.so"].map(PathBuf::from));
        // A static-only build has nothing to load.
        assert!(parse_sysconfig("/usr/lib\n\nlibpython3.11.a\n").is_empty());
        assert!(parse_sysconfig("").is_empty());
    }

    #[test]
    fn candidates_end_with_well_known_sonames() {
        if std::env::var_os(LIBPYTHON_ENV).is_some() {
            return; // the override replaces the search
        }
        let c = libpython_candidates();
        assert!(c.iter().any(|p| p == Path::new("libpython3.11.so.1.0")), "{c:?}");
    }
}
