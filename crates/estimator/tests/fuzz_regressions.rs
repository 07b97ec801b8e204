//! Replays the committed reproducers of the CSV fuzz target (`fuzz/regressions/csv/`): each
//! file must be refused with a clean error containing the text of its `.expect` sidecar,
//! never a panic. See `fuzz/README.md`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

use estimator::data::DataSet;

#[test]
fn every_csv_reproducer_is_a_clear_error() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/regressions/csv");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "expect") {
            continue;
        }
        let expect = std::fs::read_to_string(path.with_extension(format!("{}.expect", path.extension().unwrap().to_str().unwrap()))).unwrap();
        let expect = expect.trim_end_matches('\n');
        let err = DataSet::read_csv(&path).expect_err(&format!("{} was accepted", path.display())).to_string();
        assert!(err.contains(expect), "{}: {err:?} lacks {expect:?}", path.display());
        assert!(err.contains(path.file_name().unwrap().to_str().unwrap()), "{err:?} does not name the file");
        n += 1;
    }
    assert!(n >= 6, "only {n} reproducers found in {}", dir.display());
}
