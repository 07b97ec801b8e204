//! Replays the committed reproducers of the scope fuzz target (`fuzz/regressions/scope/`),
//! read as the target reads them (the contract's names, or a scope's export with its channels
//! named) and reduced at 330 kHz: each must end in a clean error containing the text of its
//! `.expect` sidecar, never a panic, a hang or an allocation without bound. See
//! `fuzz/README.md`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

use capture::{Capture, Named, reduce};

#[test]
fn every_scope_reproducer_is_a_clear_error() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/regressions/scope");
    let named = |column, header, scale| Named { column, header, scale };
    let scope = [named("time", "TIME", None), named("vout", "CH1", None), named("il", "CH2", Some(10.0)), named("sw", "CH3", None)];
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "expect") {
            continue;
        }
        let expect = std::fs::read_to_string(path.with_extension("csv.expect")).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let cap = Capture::parse_csv(&text).or_else(|_| Capture::parse_csv_with(&text, &scope)).expect("the reproducer reads as a capture");
        let err = reduce(&cap, Some(330e3)).expect_err(&format!("{} was reduced", path.display())).to_string();
        assert!(err.contains(expect.trim_end()), "{}: {err:?} lacks {expect:?}", path.display());
        n += 1;
    }
    assert!(n >= 2, "only {n} reproducers found in {}", dir.display());
}
