//! Replays the committed reproducers of the modelDescription and FMU-archive fuzz targets
//! (`fuzz/regressions/`): each must give a clean `Err` containing its `.expect` sidecar's text,
//! never a panic; plus the hostile inputs too big to commit (deep nesting, zip bombs), built
//! here. See `fuzz/README.md`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use fmi2_import::{Fmu, ImportError};

fn reproducers(target: &str) -> Vec<(PathBuf, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/regressions").join(target);
    let mut out = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "expect") {
            continue;
        }
        let mut sidecar = path.clone().into_os_string();
        sidecar.push(".expect");
        let expect = std::fs::read_to_string(&sidecar).unwrap().trim_end_matches('\n').to_owned();
        out.push((path, expect));
    }
    assert!(!out.is_empty(), "no reproducers in {}", dir.display());
    out
}

#[test]
fn every_model_description_reproducer_is_a_clear_error() {
    for (path, expect) in reproducers("model_description") {
        let dir = tempfile::tempdir().unwrap();
        std::fs::copy(&path, dir.path().join("modelDescription.xml")).unwrap();
        let err = Fmu::from_dir(dir.path()).expect_err(&format!("{} was accepted", path.display())).to_string();
        assert!(err.contains(&expect), "{}: {err:?} lacks {expect:?}", path.display());
    }
}

#[test]
fn every_archive_reproducer_is_a_clear_error() {
    for (path, expect) in reproducers("fmu_archive") {
        let err = Fmu::open(&path).expect_err(&format!("{} was accepted", path.display())).to_string();
        assert!(err.contains(&expect), "{}: {err:?} lacks {expect:?}", path.display());
    }
}

const MINI: &str = r#"<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{g}">
  <CoSimulation modelIdentifier="M"/>
  <ModelVariables><ScalarVariable name="y" valueReference="0" causality="output"><Real/></ScalarVariable></ModelVariables>
  <ModelStructure><Outputs><Unknown index="1"/></Outputs></ModelStructure>
</fmiModelDescription>"#;

/// 100 000 nested vendor elements: skipped without recursion (no stack overflow).
#[test]
fn deeply_nested_unknown_elements_do_not_overflow_the_stack() {
    let deep = format!("<Vendor>{}{}</Vendor><ModelStructure>", "<a>".repeat(100_000), "</a>".repeat(100_000));
    let xml = MINI.replacen("<ModelStructure>", &deep, 1);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("modelDescription.xml"), xml).unwrap();
    // Either reading is fine; a crash is not.
    match Fmu::from_dir(dir.path()) {
        Ok(fmu) => assert_eq!(fmu.model_identifier(), "M"),
        Err(e) => assert!(!e.to_string().is_empty()),
    }
}

/// A symlink entry is written as a plain file holding the link text: never followed.
#[test]
fn symlink_entries_are_plain_files() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("link.fmu");
    let mut zip = zip::ZipWriter::new(File::create(&path).unwrap());
    let opts = zip::write::SimpleFileOptions::default();
    zip.add_symlink("resources/passwd", "/etc/passwd", opts).unwrap();
    zip.start_file("modelDescription.xml", opts).unwrap();
    zip.write_all(MINI.as_bytes()).unwrap();
    zip.finish().unwrap();
    let fmu = Fmu::open(&path).unwrap();
    let link = fmu.dir().join("resources/passwd");
    let meta = std::fs::symlink_metadata(&link).unwrap();
    assert!(meta.file_type().is_file(), "{meta:?}");
    assert_eq!(std::fs::read_to_string(&link).unwrap(), "/etc/passwd");
}

/// A duplicate entry name: the later one wins or the archive is refused; nothing else.
#[test]
fn duplicate_entries_are_read_or_refused_cleanly() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("dup.fmu");
    // The zip crate's writer refuses duplicates: write the archive by hand with Python's
    // layout, i.e. two local headers and two directory entries of the same name.
    let bytes = include_bytes!("../../../fuzz/corpus/fmu_archive/seed-duplicate.fmu");
    std::fs::write(&path, bytes).unwrap();
    match Fmu::open(&path) {
        Ok(fmu) => assert_eq!(fmu.model_identifier(), "M"),
        Err(e) => assert!(!e.to_string().is_empty(), "{e:?}"),
    }
}

/// A zip bomb that declares its size (3 GiB of zeros in one entry, about 3 MB compressed):
/// refused from the directory before anything is written. Built here, not committed.
#[test]
fn a_declared_zip_bomb_is_refused_before_extraction() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("bomb.fmu");
    let mut zip = zip::ZipWriter::new(File::create(&path).unwrap());
    let opts = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated).compression_level(Some(9)).large_file(true);
    zip.start_file("modelDescription.xml", opts).unwrap();
    zip.write_all(MINI.as_bytes()).unwrap();
    zip.start_file("resources/zeros.bin", opts).unwrap();
    let block = vec![0u8; 1 << 20];
    for _ in 0..(3 << 10) {
        zip.write_all(&block).unwrap();
    }
    zip.finish().unwrap();
    let size = std::fs::metadata(&path).unwrap().len();
    assert!(size < 8 << 20, "{size} bytes");
    let err = Fmu::open(&path).unwrap_err();
    assert!(matches!(err, ImportError::TooLarge { .. }), "{err}");
    assert!(err.to_string().contains("more than the limit of 2147483648 bytes"), "{err}");
}

/// A zip bomb that lies: 64 MiB of zeros whose directory and local header declare 1 000
/// bytes. The zip reader stops at the declared size ("File is larger than its declared
/// uncompressed size") and the archive is refused, naming the entry's file.
#[test]
fn a_zip_entry_inflating_past_its_declared_size_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("liar.fmu");
    let mut zip = zip::ZipWriter::new(File::create(&path).unwrap());
    let opts = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    zip.start_file("modelDescription.xml", opts).unwrap();
    zip.write_all(MINI.as_bytes()).unwrap();
    zip.start_file("resources/zeros.bin", opts).unwrap();
    zip.write_all(&vec![0u8; 64 << 20]).unwrap();
    zip.finish().unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    // Patch the uncompressed size of the second entry in its local header (offset 22) and
    // central directory record (offset 24).
    let find_all = |sig: &[u8]| bytes.windows(4).enumerate().filter(|(_, w)| *w == sig).map(|(i, _)| i).collect::<Vec<_>>();
    let local = find_all(b"PK\x03\x04")[1];
    let central = find_all(b"PK\x01\x02")[1];
    for at in [local + 22, central + 24] {
        assert_eq!(u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()), 64 << 20);
        bytes[at..at + 4].copy_from_slice(&1000u32.to_le_bytes());
    }
    std::fs::write(&path, &bytes).unwrap();
    let err = Fmu::open(&path).unwrap_err().to_string();
    assert!(err.contains("zeros.bin") && err.contains("larger than its declared"), "{err}");
}

/// A 32 MiB attribute (a model name) is read like any other: no quadratic blow-up.
#[test]
fn a_huge_attribute_is_read() {
    let xml = MINI.replacen(r#"modelName="M""#, &format!(r#"modelName="{}""#, "x".repeat(32 << 20)), 1);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("modelDescription.xml"), xml).unwrap();
    let t = std::time::Instant::now();
    let fmu = Fmu::from_dir(dir.path()).unwrap();
    assert_eq!(fmu.model_description().model_name.len(), 32 << 20);
    assert!(t.elapsed().as_secs() < 10, "{:?}", t.elapsed());
}
