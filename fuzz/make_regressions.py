#!/usr/bin/env python3
"""Writes the committed reproducers of the fuzzing findings (fuzz/regressions/<target>/X) with
the text their error must contain (X.expect); `cargo test` replays them
(crates/estimator/tests/fuzz_regressions.rs, crates/fmi2-import/tests/fuzz_regressions.rs,
crates/capture/tests/fuzz_regressions.rs).
Files found by a fuzzer run are copied in by hand from fuzz/artifacts/ with their .expect."""
import io, os, sys, zipfile
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
HERE = os.path.dirname(os.path.abspath(__file__))

def put(target, name, data, expect):
    d = os.path.join(HERE, "regressions", target)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode("utf-8")
    open(os.path.join(d, name), "wb").write(data)
    open(os.path.join(d, name + ".expect"), "w", encoding="utf-8").write(expect + "\n")

H = "# U = 12\n# io = 1\n"
put("csv", "blank-line-shifts-line-number.csv", H + "time,duty,vout\n0,0.5,5\n\n1e-6,0.5,5\n2e-6,0.5,x\n", 'line 7: column `vout` value "x"')
put("csv", "quoted-newline-shifts-line-number.csv", H + 'time,duty,vout,note\n0,0.5,5,"a\nb"\n1e-6,0.5,abc,x\n', 'line 6: column `vout` value "abc"')
put("csv", "infinite-sample-period.csv", H + "time,duty,vout\n-1e308,0.5,5\n1e308,0.5,5\n", "the sample period is not a finite number")
put("csv", "utf16.csv", (H + "time,duty,vout\n0,0.5,5\n1e-6,0.5,5\n").encode("utf-16"), "UTF-16")
put("csv", "latin1-micro.csv", ("# Cl = 1 \u00b5F\n" + H + "time,duty,vout\n0,0.5,5\n1e-6,0.5,5\n").encode("latin-1"), "line 1: byte 9 (0xb5) is not UTF-8")
put("csv", "huge-number.csv", H + "time,duty,vout\n0,0.5,1e999\n1e-6,0.5,5\n", 'line 4: column `vout` value "1e999" is not finite')

# Scope captures reduced at a given fs (finding 5): times spanning far more periods than the
# capture has samples asked for one boundary per period (1e6 s at 330 kHz: 3.3e11, out of
# memory), and times where a period is below their resolution never advanced (a hang).
put("scope", "many-periods.csv", "TIME,CH1\n0,1\n1e-6,1\n1e6,1\n", "too few samples per period")
put("scope", "period-below-resolution.csv", "time,vout\n1e20,1\n1.0000000000001e20,1\n1.0000000000002e20,1\n", "too few samples per period")

MINI = open(os.path.join(HERE, "corpus", "model_description", "seed-mini.xml"), encoding="utf-8").read()
put("model_description", "fmi1.xml", open(os.path.join(HERE, "corpus", "model_description", "seed-fmi1.xml")).read(), 'fmiVersion is "1.0"; only FMI 2.0 is supported')
put("model_description", "fmi3.xml", open(os.path.join(HERE, "corpus", "model_description", "seed-fmi3.xml")).read(), 'fmiVersion is "3.0"; only FMI 2.0 is supported')
put("model_description", "identifier-with-path.xml", MINI.replace('modelIdentifier="M"', 'modelIdentifier="../../../tmp/evil"'), 'modelIdentifier "../../../tmp/evil" is not a plain file name')
put("model_description", "entity-expansion.xml", open(os.path.join(HERE, "corpus", "model_description", "seed-entities.xml")).read(), "not valid FMI 2.0")

def zipped(entries):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in entries:
            z.writestr(zipfile.ZipInfo(name), data)
    return buf.getvalue()

put("fmu_archive", "identifier-with-path.fmu", zipped([("modelDescription.xml", MINI.replace('modelIdentifier="M"', 'modelIdentifier="../../x"'))]), 'modelIdentifier "../../x" is not a plain file name')
put("fmu_archive", "zip-slip.fmu", zipped([("modelDescription.xml", MINI), ("../evil", "x")]), 'entry "../evil" escapes the extraction folder')
put("fmu_archive", "no-model-description.fmu", zipped([("resources/r.txt", "r")]), "no modelDescription.xml at its root")
put("fmu_archive", "empty.fmu", zipped([]), "no modelDescription.xml at its root")
put("fmu_archive", "not-a-zip.fmu", b"PK\x03\x04 truncated", "is not a valid FMU (zip) archive")
