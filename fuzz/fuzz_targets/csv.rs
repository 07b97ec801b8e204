//! The data-file reader: any bytes are read as a CSV file (`DataSet::read_csv`, which also
//! decodes the text) and must give a data set or an error with a message, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(
    init: {
        // libFuzzer's hook aborts on any panic, even one the code under test catches on
        // purpose (fmi2-schema guards quick-xml's parser); uncaught panics still abort, as
        // libfuzzer-sys wraps the target in catch_unwind.
        std::panic::set_hook(Box::new(|info| eprintln!("{info}")));
    },
    |data: &[u8]| {
    // The string entry point first (fast), then the file entry point for the encodings.
    if let Ok(text) = std::str::from_utf8(data) {
        check(estimator::data::DataSet::parse_csv(text));
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("data.csv");
    std::fs::write(&path, data).expect("write");
    check(estimator::data::DataSet::read_csv(&path));
});

fn check(result: Result<estimator::data::DataSet, estimator::EstimatorError>) {
    match result {
        Ok(d) => {
            // What the reader accepts, the rest of the tool relies on.
            assert!(d.len() >= 2);
            let dt = d.sample_period();
            assert!(dt.is_finite() && dt > 0.0, "accepted a data set with sample period {dt}");
            assert!(d.vout.iter().chain(&d.time).all(|v| v.is_finite()));
        }
        Err(e) => assert!(!e.to_string().trim().is_empty()),
    }
}
