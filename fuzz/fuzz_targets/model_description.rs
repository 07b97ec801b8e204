//! The modelDescription parser: any text gives a description or a `SchemaError` with a
//! message; what parses can be checked and written back without a panic.
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
    let Ok(xml) = std::str::from_utf8(data) else { return };
    match fmi2_schema::ModelDescription::from_xml(xml) {
        Ok(md) => {
            let _ = md.problems();
            let _ = md.to_xml();
        }
        Err(e) => assert!(!e.to_string().trim().is_empty()),
    }
});
