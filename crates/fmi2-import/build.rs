//! Compiles the C shim that turns the FMU's variadic logger call into a formatted string.
fn main() {
    println!("cargo:rerun-if-changed=csrc/logger.c");
    cc::Build::new().file("csrc/logger.c").warnings(true).extra_warnings(true).compile("fmi2_import_logger");
}
