//! An FMU's binary runs in the process that loads it: a fault in its code (a null pointer, a
//! failed `assert`) would end a run with the shell's bare "Segmentation fault", whatever was
//! printed before. A command that loads an FMU therefore runs again in a child process (the
//! same executable and arguments, the same standard streams), and this process says how the
//! child ended when a signal ended it. The child's temporary files (the extracted FMU among
//! them) go to a folder of this process's that is removed however the child ended: a crashed
//! child cannot clean up after itself.
use std::path::Path;
use std::process::{Command, ExitCode, ExitStatus};

/// Set in the child's environment: the child runs the command itself.
const CHILD: &str = "BUCKID_FMU_CHILD";

/// Runs this command in a child process that loads the FMU at `fmu`, and returns how to exit:
/// the child's own exit code, or, when a signal ended it, 1 with an error naming the FMU and the
/// signal (an interrupt passes on as `128 + signal`). `None` inside the child, or where no child
/// can be started (the caller then runs the command in this process).
pub fn supervise(fmu: &Path) -> Option<ExitCode> {
    if std::env::var_os(CHILD).is_some() {
        return None;
    }
    let exe = std::env::current_exe().ok()?;
    let mut child = Command::new(exe);
    child.args(std::env::args_os().skip(1)).env(CHILD, "1");
    // Removed when dropped, after the child ended.
    let scratch = tempfile::Builder::new().prefix("buckid-").tempdir().ok();
    if let Some(dir) = &scratch {
        child.env("TMPDIR", dir.path());
    }
    let status = child.status().ok()?;
    Some(exit(status, fmu))
}

/// How to exit after the child ended with `status`.
fn exit(status: ExitStatus, fmu: &Path) -> ExitCode {
    if let Some(code) = status.code() {
        return ExitCode::from(u8::try_from(code).unwrap_or(1));
    }
    match signal(status) {
        Some(n) if INTERRUPTS.contains(&n) => ExitCode::from(u8::try_from(128 + n).unwrap_or(1)),
        n => {
            eprintln!("error: {}", crashed(fmu, n));
            ExitCode::FAILURE
        }
    }
}

/// Signals that stop a run from outside (hang-up, Ctrl-C, a closed pipe, `kill`): no fault of
/// the FMU's.
const INTERRUPTS: [i32; 4] = [1, 2, 13, 15];

/// What to say of a run of `fmu` ended by the signal `n`.
fn crashed(fmu: &Path, n: Option<i32>) -> String {
    let what = match n {
        Some(n) => match name(n) {
            Some((name, meaning)) => format!("signal {n} ({name}: {meaning})"),
            None => format!("signal {n}"),
        },
        None => "a signal".to_string(),
    };
    let culprit = if n == Some(9) { "" } else { ", a fault in the FMU's binary (buckid's own code is memory-safe Rust)" };
    format!("the run of the FMU {} was ended by {what}{culprit}; nothing more of it was written", fmu.display())
}

#[cfg(unix)]
fn signal(status: ExitStatus) -> Option<i32> {
    std::os::unix::process::ExitStatusExt::signal(&status)
}

#[cfg(not(unix))]
fn signal(_: ExitStatus) -> Option<i32> {
    None
}

/// Linux's name of the signal `n` and what it means for a run.
fn name(n: i32) -> Option<(&'static str, &'static str)> {
    if !cfg!(target_os = "linux") {
        return None;
    }
    Some(match n {
        4 => ("SIGILL", "an illegal instruction"),
        6 => ("SIGABRT", "the FMU aborted, e.g. a failed assert"),
        7 => ("SIGBUS", "a bad memory access"),
        8 => ("SIGFPE", "an arithmetic fault, e.g. an integer division by zero"),
        9 => ("SIGKILL", "killed from outside, e.g. out of memory"),
        11 => ("SIGSEGV", "an invalid memory access"),
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fault_names_the_fmu_and_the_signal() {
        let text = crashed(Path::new("plant.fmu"), Some(11));
        assert!(text.contains("plant.fmu") && text.contains("signal 11 (SIGSEGV: an invalid memory access)") && text.contains("FMU's binary"), "{text}");
        assert!(!crashed(Path::new("plant.fmu"), Some(9)).contains("FMU's binary"));
        assert!(crashed(Path::new("plant.fmu"), Some(42)).contains("by signal 42, a fault"));
    }
}
