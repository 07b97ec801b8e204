//! The FMU archive reader: any bytes as an `.fmu` file are extracted into a fresh folder and
//! read (`Fmu::open`); the result is an FMU whose binary path stays inside its folder, or an
//! error with a message. Nothing may be written outside the extraction folder.
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
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("x.fmu");
    std::fs::write(&path, data).expect("write");
    match fmi2_import::Fmu::open(&path) {
        Ok(fmu) => {
            let root = fmu.dir().to_path_buf();
            let binary = fmu.binary_path();
            // No `..` component and below the folder: a modelIdentifier cannot point elsewhere.
            assert!(
                binary.starts_with(&root) && !binary.components().any(|c| matches!(c, std::path::Component::ParentDir)),
                "binary path {} leaves {}",
                binary.display(),
                root.display()
            );
            assert_eq!(binary.parent().and_then(|p| p.file_name()).and_then(|n| n.to_str()), Some("linux64"));
            let _ = fmu.value_reference("vout");
            let _ = fmu.resource_uri();
        }
        Err(e) => assert!(!e.to_string().trim().is_empty()),
    }
    // The archive's folder holds only the archive: extraction went to the temp folder.
    let names: Vec<_> = std::fs::read_dir(dir.path()).expect("list").map(|e| e.expect("entry").file_name()).collect();
    assert_eq!(names, ["x.fmu"], "something was written beside the archive");
});
