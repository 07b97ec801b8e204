#!/usr/bin/env python3
"""Writes the small committed seed corpora of the fuzz targets (fuzz/corpus/*/seed-*).

Run from anywhere: `python3 fuzz/make_seeds.py`. Deterministic; re-running rewrites the same
files. Seeds are small on purpose: libFuzzer mutates them, it does not need big inputs.
"""
import io
import os
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def put(target, name, data):
    path = os.path.join(HERE, "corpus", target, "seed-" + name)
    if isinstance(data, str):
        data = data.encode("utf-8")
    with open(path, "wb") as f:
        f.write(data)


# ---- CSV ------------------------------------------------------------------------------------
GOOD = "# fs = 330000\n# U = 12\n# io = 1\ntime,duty,vout,il\n0,0.4,4.7,1.1\n3.0303e-6,0.6,4.8,0.9\n6.0606e-6,0.6,4.9,1.0\n"
put("csv", "good.csv", GOOD)
put("csv", "crlf.csv", GOOD.replace("\n", "\r\n"))
put("csv", "bom.csv", "\ufeff" + GOOD)
put("csv", "utf16.csv", GOOD.encode("utf-16"))
put("csv", "latin1.csv", ("# note = \u00b5F\n" + GOOD).encode("latin-1"))
put("csv", "quoted.csv", '# U = 12\n# io = 1\n"time","duty","vout"\n"0","0.5","5"\n"1e-6","0.5","5.1"\n')
put("csv", "multiline.csv", '# U = 12\n# io = 1\ntime,duty,vout,note\n0,0.5,5,"a\nb"\n1e-6,0.5,abc,x\n')
put("csv", "huge.csv", "# U = 12\n# io = 1\ntime,duty,vout\n-1e308,0.5,5\n1e308,0.5,5\n")
put("csv", "rload.csv", "# U = 12\n# io = 1\n# rload = 10\ntime,duty,vout,rload\n0,0.5,5,10\n1e-6,0.5,5,10\n")
put("csv", "blank.csv", "# U = 12\n# io = 1\ntime,duty,vout\n0,0.5,5\n\n1e-6,0.5,5\n2e-6,0.5,x\n")

# ---- modelDescription -----------------------------------------------------------------------
with open(os.path.join(ROOT, "modelDescription", "modelDescription.xml"), encoding="utf-8") as f:
    buck = f.read()
put("model_description", "buck.xml", buck)
MINI = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{g}">
  <CoSimulation modelIdentifier="M" canGetAndSetFMUstate="true"/>
  <UnitDefinitions><Unit name="V"><BaseUnit kg="1" m="2" s="-3" A="-1"/></Unit></UnitDefinitions>
  <TypeDefinitions><SimpleType name="E"><Enumeration><Item name="a" value="1"/></Enumeration></SimpleType></TypeDefinitions>
  <ModelVariables>
    <ScalarVariable name="u" valueReference="0" causality="input"><Real start="0" unit="V"/></ScalarVariable>
    <ScalarVariable name="e" valueReference="1" causality="parameter" variability="fixed"><Enumeration declaredType="E" start="1"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="2" causality="output"><Real/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="3" dependencies="1"/></Outputs></ModelStructure>
</fmiModelDescription>
"""
put("model_description", "mini.xml", MINI)
put("model_description", "fmi1.xml", """<?xml version="1.0"?>
<fmiModelDescription fmiVersion="1.0" modelName="M" modelIdentifier="M" guid="{g}" numberOfContinuousStates="0" numberOfEventIndicators="0">
  <ModelVariables><ScalarVariable name="y" valueReference="0" causality="output"><Real/></ScalarVariable></ModelVariables>
  <Implementation><CoSimulation_StandAlone><Capabilities/></CoSimulation_StandAlone></Implementation>
</fmiModelDescription>
""")
put("model_description", "fmi3.xml", """<?xml version="1.0"?>
<fmiModelDescription fmiVersion="3.0" modelName="M" instantiationToken="{g}">
  <CoSimulation modelIdentifier="M"/>
  <ModelVariables><Float64 name="y" valueReference="0" causality="output"/></ModelVariables>
  <ModelStructure><Output valueReference="0"/></ModelStructure>
</fmiModelDescription>
""")
put("model_description", "entities.xml", """<?xml version="1.0"?>
<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">]>
<fmiModelDescription fmiVersion="2.0" modelName="&lol2;" guid="{g}&amp;&#x41;">
  <CoSimulation modelIdentifier="M"/>
  <ModelVariables/>
  <ModelStructure/>
</fmiModelDescription>
""")
put("model_description", "nested.xml", MINI.replace("<ModelStructure>", "<Vendor>" + "<a>" * 200 + "</a>" * 200 + "</Vendor><ModelStructure>"))

# ---- FMU archives ---------------------------------------------------------------------------
def zipped(entries, compression=zipfile.ZIP_DEFLATED):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression) as z:
        for name, data in entries:
            info = zipfile.ZipInfo(name)
            info.compress_type = compression
            if name.startswith("link"):
                info.external_attr = (0o120777 << 16)  # a symlink entry
            z.writestr(info, data)
    return buf.getvalue()

put("fmu_archive", "mini.fmu", zipped([("modelDescription.xml", MINI), ("resources/r.txt", "r")]))
put("fmu_archive", "stored.fmu", zipped([("modelDescription.xml", MINI)], zipfile.ZIP_STORED))
put("fmu_archive", "slip.fmu", zipped([("modelDescription.xml", MINI), ("../evil", "x")]))
put("fmu_archive", "absolute.fmu", zipped([("modelDescription.xml", MINI), ("/tmp/evil", "x")]))
put("fmu_archive", "symlink.fmu", zipped([("link", "/etc/passwd"), ("modelDescription.xml", MINI)]))
put("fmu_archive", "duplicate.fmu", zipped([("modelDescription.xml", MINI), ("modelDescription.xml", "<x/>")]))
put("fmu_archive", "dir-file.fmu", zipped([("a/", ""), ("a", "x"), ("modelDescription.xml", MINI)]))
put("fmu_archive", "empty.fmu", zipped([]))
put("fmu_archive", "identifier.fmu", zipped([("modelDescription.xml", MINI.replace('modelIdentifier="M"', 'modelIdentifier="../../x"'))]))

# ---- Oscilloscope captures ------------------------------------------------------------------
# Three periods of a 100 kHz, duty-0.3 switch node at 20 samples per period, in the contract's
# names and as a scope's export (preamble, quoted channel names, a units row).
ROWS = [(i * 5e-7, 5.0 + 0.01 * (i % 20), 0.5 + 0.05 * (i % 20), 12.0 if i % 20 < 6 else 0.0) for i in range(60)]
put("scope", "plain.csv", "# fs = 100000\ntime,vout,il,sw\n" + "".join(f"{t!r},{v!r},{c!r},{w!r}\n" for t, v, c, w in ROWS))
put("scope", "tek.csv", 'Model,MSO54\nHorizontal Units,s\n"TIME","CH1","CH2","CH3"\nsecond,Volt,Volt,Volt\n'
    + "".join(f"{t!r},{v!r},{c / 10!r},{w!r}\n" for t, v, c, w in ROWS))
put("scope", "rigol.csv", "X,CH1,CH2,CH3,Start,Increment,\nSequence,Volt,Volt,Volt,0.0,5e-07\n"
    + "".join(f"{k},{v!r},{c!r},{w!r},\n" for k, (t, v, c, w) in enumerate(ROWS)))
# One channel per file: a LeCroy's trace (notes, then `Time,Ampl`) and a Tektronix TDS's (no
# header row, settings beside the samples).
put("scope", "lecroy.txt", "LECROYWR104Xi,51234,Waveform\nSegments,1,SegmentSize,60\nSegment,TrigTime,TimeSinceSegment1\n"
    "#1,27-Nov-2026 10:11:12,0\nTime,Ampl\n" + "".join(f"{t!r},{w!r}\n" for t, v, c, w in ROWS))
TDS = ["Record Length,6.000000e+01,", "Sample Interval,5.000000e-07,", "Trigger Point,0.0e+00,", ",,", "Source,CH3,", "Vertical Units,V,"]
put("scope", "tds.csv", "".join(f"{TDS[k] if k < len(TDS) else ',,'},{t!r},{w!r},\r\n" for k, (t, v, c, w) in enumerate(ROWS)))
