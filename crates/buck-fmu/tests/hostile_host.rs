//! The FMU under a hostile host: random call sequences through the exported `fmi2*` functions
//! (out of order, NaN/inf/huge values on every variable, bad value references, nvr 0 and null
//! pointers, corrupted and truncated serialized states, several instances), each case in its
//! own process so that a crash or a hang is counted, not fatal to the run. Every status is
//! checked against a model of the FMI 2.0 Co-Simulation state machine built from the committed
//! `modelDescription.xml` (ranges, causalities, types): fmi2Error for bad input or order, with a
//! logged message; fmi2Fatal (a panic inside the FMU) never.
//!
//! `cargo test -p buck-fmu --test hostile_host` runs 300 cases; `HOSTILE_CASES=N` more
//! (`scripts/fuzz`), `HOSTILE_SEED=S` a different range. `valgrind_payload` is the
//! deterministic lifecycle and error-path sequence run under valgrind.
//!
//! This file is an FFI file: it calls the FMU's C ABI with raw pointers, as a host does.
#![allow(clippy::unwrap_used, clippy::expect_used, unsafe_code)]

use std::collections::HashMap;
use std::ffi::{CStr, CString};
use std::process::{Command, Stdio};
use std::ptr;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use buck_fmu::ffi::*;
use fmi2_schema::{Causality, ModelDescription, VariableType};
use fmi2_sys::*;

// ---- Host side: logger, pseudo-random numbers, the variable table ---------------------------

/// Messages the FMU logged (category, message), shared by all instances of the process.
static LOG: Mutex<Vec<(String, String)>> = Mutex::new(Vec::new());

/// The logger the host hands the FMU. FMI declares it variadic; the FMU always calls it with
/// the format `"%s"` and one string, which on x86-64 System V (and AArch64 Linux) arrive in the
/// same registers as this fixed-argument function's sixth parameter.
unsafe extern "C" fn logger(_env: fmi2ComponentEnvironment, _name: fmi2String, _status: fmi2Status, category: fmi2String, _format: fmi2String, message: fmi2String) {
    // SAFETY: the FMU passes NUL-terminated strings valid for the call (checked non-null).
    let text = |s: fmi2String| if s.is_null() { String::new() } else { unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned() };
    LOG.lock().unwrap().push((text(category), text(message)));
}

fn callbacks(with_logger: bool) -> fmi2CallbackFunctions {
    type Fixed = unsafe extern "C" fn(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, fmi2String);
    type Variadic = unsafe extern "C" fn(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
    // SAFETY: both are plain function pointers of one size; see `logger` for the calling
    // convention that makes the variadic call land in the fixed-argument function.
    let log = unsafe { std::mem::transmute::<Fixed, Variadic>(logger) };
    fmi2CallbackFunctions { logger: if with_logger { Some(log) } else { None }, allocateMemory: None, freeMemory: None, stepFinished: None, componentEnvironment: ptr::null_mut() }
}

/// SplitMix64: a seeded, portable stream (no dependency).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn chance(&mut self, percent: u64) -> bool {
        self.next() % 100 < percent
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Real,
    Integer,
    Boolean,
}

/// One variable of the committed XML: what a host knows before loading the binary.
#[derive(Debug, Clone)]
struct Var {
    name: String,
    vr: u32,
    kind: Kind,
    causality: Causality,
    min: f64,
    max: f64,
    start: f64,
}

fn table() -> (Vec<Var>, String) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../modelDescription/modelDescription.xml");
    let md = ModelDescription::from_xml(&std::fs::read_to_string(path).unwrap()).unwrap();
    let vars = md
        .variables()
        .iter()
        .map(|v| {
            let (kind, min, max, start) = match &v.ty {
                VariableType::Real(r) => (Kind::Real, r.min.unwrap_or(f64::NEG_INFINITY), r.max.unwrap_or(f64::INFINITY), r.start.unwrap_or(0.0)),
                VariableType::Integer(i) => (Kind::Integer, i.min.map_or(f64::from(i32::MIN), f64::from), i.max.map_or(f64::from(i32::MAX), f64::from), f64::from(i.start.unwrap_or(0))),
                VariableType::Boolean(b) => (Kind::Boolean, 0.0, 1.0, f64::from(u8::from(b.start.unwrap_or(false)))),
                other => panic!("{}: unexpected type {other:?}", v.name),
            };
            Var { name: v.name.clone(), vr: v.value_reference, kind, causality: v.causality, min, max, start }
        })
        .collect();
    (vars, md.guid)
}

// ---- The expected behaviour: FMI 2.0 CS state machine (FMI 2.0 §4.2.4) ----------------------

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Instantiated,
    Init,
    StepComplete,
    Terminated,
    Error,
}
use Phase::*;

const OK: fmi2Status = fmi2Status::fmi2OK;
const ERROR: fmi2Status = fmi2Status::fmi2Error;
const DISCARD: fmi2Status = fmi2Status::fmi2Discard;

/// What the host knows of one instance.
#[derive(Debug, Clone)]
struct Model {
    phase: Phase,
    time: f64,
    /// Parameter/input values set so far, by value reference.
    values: HashMap<u32, f64>,
}

struct Live {
    c: fmi2Component,
    model: Model,
    /// FMU states taken from this instance, with the model at the time.
    states: Vec<(fmi2FMUstate, Model)>,
    /// Serialized states (bytes, model at the time).
    blobs: Vec<(Vec<u8>, Model)>,
    /// The host gave a logger: every fmi2Error must come with a message.
    logs: bool,
    /// States this instance freed: using one again must be refused, not a use after free.
    freed: Vec<fmi2FMUstate>,
}

/// The harness of one case: the variable table, a random stream and the instances.
struct Host {
    vars: Vec<Var>,
    guid: CString,
    rng: Rng,
    live: Vec<Live>,
    /// `(operation, expected, got, what the FMU logged)` of every mismatch.
    wrong: Vec<String>,
    calls: u64,
    /// The instance being operated on has a logger.
    logs: bool,
    /// `fmi2DoStep` calls that returned fmi2OK.
    steps_ok: u64,
}

const MAX_LIVE: usize = 3;

/// Values a hostile host tries on every variable.
fn nasty(rng: &mut Rng, v: &Var) -> f64 {
    if rng.chance(50) {
        // A valid value half of the time, so that sequences get past the set calls.
        return if v.min.is_finite() && v.max.is_finite() && rng.chance(50) {
            let x = v.min + (v.max - v.min) * rng.unit();
            if v.kind == Kind::Real { x } else { x.round() }
        } else {
            v.start
        };
    }
    match rng.below(14) {
        0 => f64::NAN,
        1 => f64::INFINITY,
        2 => f64::NEG_INFINITY,
        3 => f64::MAX,
        4 => -f64::MAX,
        5 => f64::MIN_POSITIVE / 4.0, // subnormal
        6 => 0.0,
        7 => -1.0,
        8 => 1e300,
        9 if v.min.is_finite() => v.min,
        10 if v.max.is_finite() => v.max,
        11 if v.min.is_finite() && v.max.is_finite() => {
            let x = v.min + (v.max - v.min) * rng.unit();
            if v.kind == Kind::Real { x } else { x.round() }
        }
        12 => v.start * (0.5 + rng.unit()),
        _ => v.start,
    }
}

impl Host {
    fn new(seed: u64) -> Self {
        let (vars, guid) = table();
        Host { vars, guid: CString::new(guid).unwrap(), rng: Rng(seed), live: Vec::new(), wrong: Vec::new(), calls: 0, logs: true, steps_ok: 0 }
    }

    /// A real variable's value as the host last set it (else its start).
    fn real(&self, m: &Model, name: &str) -> f64 {
        let v = self.vars.iter().find(|v| v.name == name).unwrap();
        m.values.get(&v.vr).copied().unwrap_or(v.start)
    }

    fn fs(&self, m: &Model) -> f64 {
        self.real(m, "fs")
    }

    /// Checks a status; an error must come with a logged message (there is an instance to log).
    fn expect(&mut self, op: &str, want: &[fmi2Status], got: fmi2Status, logged: bool) {
        self.calls += 1;
        let log: Vec<(String, String)> = std::mem::take(&mut *LOG.lock().unwrap());
        if !want.contains(&got) {
            self.wrong.push(format!("{op}: expected {want:?}, got {got:?}; log {log:?}"));
        } else if got == ERROR && logged && self.logs && !log.iter().any(|(c, m)| c == "logStatusError" && !m.is_empty()) {
            self.wrong.push(format!("{op}: fmi2Error without a logged message"));
        }
    }

    /// Applies the phase mask: `Err(())` (and the model in `Error`) when not allowed.
    fn allowed(m: &mut Model, phases: &[Phase]) -> bool {
        if phases.contains(&m.phase) {
            true
        } else {
            m.phase = Error;
            false
        }
    }

    fn instantiate(&mut self) {
        let valid_name = !self.rng.chance(5);
        let valid_guid = !self.rng.chance(10);
        let co_sim = !self.rng.chance(5);
        let with_callbacks = !self.rng.chance(5);
        let logs = !self.rng.chance(5);
        let cb = callbacks(logs);
        let name = CString::new(format!("hostile{}", self.rng.below(100))).unwrap();
        let guid = if valid_guid { self.guid.clone() } else { CString::new("{00000000-bad-guid}").unwrap() };
        let guid_ptr = if self.rng.chance(3) { ptr::null() } else { guid.as_ptr() };
        // SAFETY: every pointer is null or a NUL-terminated string / callback struct alive for the call.
        let c = unsafe {
            fmi2Instantiate(
                if valid_name { name.as_ptr() } else { ptr::null() },
                if co_sim { fmi2Type::fmi2CoSimulation } else { fmi2Type::fmi2ModelExchange },
                guid_ptr,
                c"file:///nonexistent".as_ptr(),
                if with_callbacks { &cb } else { ptr::null() },
                0,
                fmi2Boolean::from(self.rng.chance(30)),
            )
        };
        self.calls += 1;
        LOG.lock().unwrap().clear();
        let should = valid_name && valid_guid && co_sim && !guid_ptr.is_null();
        match (should, c.is_null()) {
            (true, false) => self.live.push(Live {
                c,
                model: Model { phase: Instantiated, time: 0.0, values: HashMap::new() },
                states: Vec::new(),
                blobs: Vec::new(),
                logs: logs && with_callbacks,
                freed: Vec::new(),
            }),
            (false, true) => {}
            (true, true) => self.wrong.push("fmi2Instantiate returned null for valid arguments".into()),
            (false, false) => {
                self.wrong.push(format!("fmi2Instantiate accepted name {valid_name} guid {valid_guid} cs {co_sim}"));
                // SAFETY: a component the FMU just returned, freed once.
                unsafe { fmi2FreeInstance(c) };
            }
        }
    }

    fn free(&mut self, i: usize) {
        let mut l = self.live.swap_remove(i);
        for (mut s, _) in l.states.drain(..) {
            if self.rng.chance(50) {
                // SAFETY: a live component and a state it made, freed once.
                let st = unsafe { fmi2FreeFMUstate(l.c, &mut s) };
                self.expect("fmi2FreeFMUstate", &[OK], st, false);
            }
        }
        // SAFETY: a live component, freed once (states left are the FMU's to free).
        unsafe { fmi2FreeInstance(l.c) };
        self.calls += 1;
        LOG.lock().unwrap().clear();
    }

    /// One random operation on instance `i`.
    fn operate(&mut self, i: usize) {
        let c = self.live[i].c;
        self.logs = self.live[i].logs;
        let mut m = self.live[i].model.clone();
        // Drift toward simulating: a purely random walk spends most calls in the error phase.
        let op = match m.phase {
            Error if self.rng.chance(40) => 4,
            Instantiated if self.rng.chance(25) => 1,
            Init if self.rng.chance(30) => 2,
            StepComplete if self.rng.chance(30) => 9,
            _ => self.rng.below(16),
        };
        match op {
            0 => {
                let start = [0.0, 1.5, -3.0, f64::NAN, f64::INFINITY, 1e300][self.rng.below(6)];
                // SAFETY: a live component; scalars only.
                let st = unsafe { fmi2SetupExperiment(c, 0, 0.0, start, 0, 0.0) };
                let want = if !Self::allowed(&mut m, &[Instantiated]) || !start.is_finite() {
                    m.phase = Error;
                    ERROR
                } else {
                    m.time = start;
                    OK
                };
                self.expect(&format!("fmi2SetupExperiment({start})"), &[want], st, true);
            }
            1 => {
                // SAFETY: a live component.
                let st = unsafe { fmi2EnterInitializationMode(c) };
                let want = if Self::allowed(&mut m, &[Instantiated]) {
                    m.phase = Init;
                    OK
                } else {
                    ERROR
                };
                self.expect("fmi2EnterInitializationMode", &[want], st, true);
            }
            2 => {
                // SAFETY: a live component.
                let st = unsafe { fmi2ExitInitializationMode(c) };
                let want = if Self::allowed(&mut m, &[Init]) {
                    m.phase = StepComplete;
                    OK
                } else {
                    ERROR
                };
                self.expect("fmi2ExitInitializationMode", &[want], st, true);
            }
            3 => {
                // SAFETY: a live component.
                let st = unsafe { fmi2Terminate(c) };
                let want = if Self::allowed(&mut m, &[StepComplete]) {
                    m.phase = Terminated;
                    OK
                } else {
                    ERROR
                };
                self.expect("fmi2Terminate", &[want], st, true);
            }
            4 if op == 4 && (m.phase == Error || self.rng.chance(30)) => {
                // SAFETY: a live component.
                let st = unsafe { fmi2Reset(c) };
                m = Model { phase: Instantiated, time: 0.0, values: HashMap::new() };
                self.expect("fmi2Reset", &[OK], st, true);
            }
            5 | 6 => self.set(c, &mut m),
            7 | 8 => self.get(c, &mut m),
            9..=11 => self.step(c, &mut m),
            12 => self.state(i, c, &mut m),
            13 => self.serialized(i, c, &mut m),
            14 => self.status(c, &mut m),
            _ => self.misc(c, &mut m),
        }
        self.live[i].model = m;
    }

    fn pick_vrs(&mut self, kind: Kind) -> Vec<u32> {
        let n = [0, 1, 1, 2, 3, 5][self.rng.below(6)];
        (0..n)
            .map(|_| match self.rng.below(20) {
                0 => u32::MAX,
                1 => self.vars.len() as u32 + self.rng.below(5) as u32,
                2 | 3 => self.vars[self.rng.below(self.vars.len())].vr, // any type
                _ => {
                    let of_kind: Vec<u32> = self.vars.iter().filter(|v| v.kind == kind).map(|v| v.vr).collect();
                    of_kind[self.rng.below(of_kind.len())]
                }
            })
            .collect()
    }

    fn set(&mut self, c: fmi2Component, m: &mut Model) {
        let kind = [Kind::Real, Kind::Integer, Kind::Boolean][self.rng.below(3)];
        let vrs = self.pick_vrs(kind);
        let values: Vec<f64> = vrs
            .iter()
            .map(|&vr| match self.vars.iter().find(|v| v.vr == vr).cloned() {
                Some(v) => nasty(&mut self.rng, &v),
                None => 0.0,
            })
            .collect();
        let null = !vrs.is_empty() && self.rng.chance(5);
        // The FMU's verdict, value by value, as FMI 2.0 and the XML say.
        let mut want = OK;
        if null || !Self::allowed(m, &[Instantiated, Init, StepComplete]) {
            want = ERROR;
        } else {
            let initializing = matches!(m.phase, Instantiated | Init);
            for (vr, x) in vrs.iter().zip(&values) {
                let Some(v) = self.vars.iter().find(|v| v.vr == *vr) else {
                    want = ERROR;
                    break;
                };
                let x = match kind {
                    Kind::Real => *x,
                    Kind::Integer => f64::from(*x as fmi2Integer), // what the host passes
                    Kind::Boolean => f64::from(u8::from(*x != 0.0)),
                };
                let bad = v.kind != kind || v.causality == Causality::Output || (v.causality == Causality::Parameter && !initializing) || x.is_nan() || x < v.min || x > v.max;
                if bad {
                    want = ERROR;
                    break;
                }
                m.values.insert(*vr, x);
            }
        }
        if want == ERROR {
            m.phase = Error;
        }
        let vr_ptr = if null { ptr::null() } else { vrs.as_ptr() };
        // SAFETY: a live component; `vr_ptr` and the value arrays hold `vrs.len()` elements (or
        // `vr_ptr` is null, which the FMU must reject).
        let st = unsafe {
            match kind {
                Kind::Real => fmi2SetReal(c, vr_ptr, vrs.len(), values.as_ptr()),
                Kind::Integer => {
                    let ints: Vec<fmi2Integer> = values.iter().map(|&x| x as fmi2Integer).collect();
                    fmi2SetInteger(c, vr_ptr, vrs.len(), ints.as_ptr())
                }
                Kind::Boolean => {
                    let bools: Vec<fmi2Boolean> = values.iter().map(|&x| fmi2Boolean::from(x != 0.0)).collect();
                    fmi2SetBoolean(c, vr_ptr, vrs.len(), bools.as_ptr())
                }
            }
        };
        self.expect(&format!("fmi2Set{kind:?}({vrs:?}, {values:?}, null {null})"), &[want], st, true);
    }

    fn get(&mut self, c: fmi2Component, m: &mut Model) {
        let kind = [Kind::Real, Kind::Integer, Kind::Boolean][self.rng.below(3)];
        let vrs = self.pick_vrs(kind);
        let null = !vrs.is_empty() && self.rng.chance(5);
        let bad_vr = |vr: &u32| self.vars.iter().find(|v| v.vr == *vr).is_none_or(|v| v.kind != kind);
        let want = if null || !Self::allowed(m, &[Init, StepComplete, Terminated, Error]) || vrs.iter().any(bad_vr) { ERROR } else { OK };
        if want == ERROR {
            m.phase = Error;
        }
        let mut reals = vec![f64::NAN; vrs.len()];
        let mut ints = vec![0; vrs.len()];
        let vr_ptr = if null { ptr::null() } else { vrs.as_ptr() };
        // SAFETY: a live component; arrays of `vrs.len()` elements or a null `vr_ptr`.
        let st = unsafe {
            match kind {
                Kind::Real => fmi2GetReal(c, vr_ptr, vrs.len(), reals.as_mut_ptr()),
                Kind::Integer => fmi2GetInteger(c, vr_ptr, vrs.len(), ints.as_mut_ptr()),
                Kind::Boolean => fmi2GetBoolean(c, vr_ptr, vrs.len(), ints.as_mut_ptr()),
            }
        };
        self.expect(&format!("fmi2Get{kind:?}({vrs:?}, null {null})"), &[want], st, true);
        if st == OK && kind == Kind::Real && m.phase == StepComplete && reals.iter().any(|x| !x.is_finite()) {
            self.wrong.push(format!("fmi2GetReal({vrs:?}) gave non-finite values {reals:?} after accepted input"));
        }
    }

    fn step(&mut self, c: fmi2Component, m: &mut Model) {
        let period = 1.0 / self.fs(m);
        let h = match self.rng.below(14) {
            0 => 0.0,
            1 => -period,
            2 => f64::NAN,
            3 => f64::INFINITY,
            4 => 1e300,
            5 => 1e6,
            6 => 1e-300,
            7 => 1e-4,
            8 => 2.5 * period,
            9 => period / 3.0,
            _ => period,
        };
        let t = match self.rng.below(12) {
            0 => f64::NAN,
            1 => m.time + 1.0,
            2 => m.time - 10.0 * period,
            _ => m.time,
        };
        // The FMU takes at most MAX_PERIODS_PER_STEP periods per call (a hang guard).
        let periods = h * self.fs(m);
        // (The ADC's instant must lie within the period, which the XML's range cannot say.)
        let bad_step = !(h > 0.0 && h.is_finite()) || t.is_nan() || (t - m.time).abs() > 0.5 * h || self.real(m, "adc_delay") >= period;
        let mut want = if !Self::allowed(m, &[StepComplete]) || bad_step || periods > buck_fmu::instance::MAX_PERIODS_PER_STEP {
            ERROR
        } else {
            m.time = t + h;
            OK
        };
        if want == ERROR {
            m.phase = Error;
        }
        let start = Instant::now();
        // SAFETY: a live component; scalars only.
        let st = unsafe { fmi2DoStep(c, t, h, 0) };
        if start.elapsed() > Duration::from_secs(5) {
            self.wrong.push(format!("fmi2DoStep({t}, {h}) took {:?}", start.elapsed()));
        }
        if st == OK && want == ERROR && m.phase == Error {
            want = OK; // reported below as a mismatch anyway
            self.wrong.push(format!("fmi2DoStep({t}, {h}) accepted"));
        }
        self.steps_ok += u64::from(st == OK);
        self.expect(&format!("fmi2DoStep({t}, {h})"), &[want], st, true);
    }

    fn state(&mut self, i: usize, c: fmi2Component, m: &mut Model) {
        match self.rng.below(4) {
            0 | 1 => {
                let mut s: fmi2FMUstate = ptr::null_mut();
                // SAFETY: a live component and a writable slot.
                let st = unsafe { fmi2GetFMUstate(c, &mut s) };
                self.expect("fmi2GetFMUstate", &[OK], st, true);
                if !s.is_null() {
                    self.live[i].states.push((s, m.clone()));
                }
            }
            2 if !self.live[i].states.is_empty() => {
                let k = self.rng.below(self.live[i].states.len());
                let (s, saved) = self.live[i].states[k].clone();
                // SAFETY: a live component and a state it made, not freed.
                let st = unsafe { fmi2SetFMUstate(c, s) };
                *m = saved;
                self.expect("fmi2SetFMUstate", &[OK], st, true);
            }
            2 => {
                // SAFETY: a live component; a null state must be rejected.
                let st = unsafe { fmi2SetFMUstate(c, ptr::null_mut()) };
                m.phase = Error;
                self.expect("fmi2SetFMUstate(NULL)", &[ERROR], st, true);
            }
            _ if !self.live[i].states.is_empty() => {
                let k = self.rng.below(self.live[i].states.len());
                let (mut s, _) = self.live[i].states.swap_remove(k);
                let freed = s;
                // SAFETY: a live component and its state, freed once.
                let st = unsafe { fmi2FreeFMUstate(c, &mut s) };
                self.expect("fmi2FreeFMUstate", &[OK], st, false);
                assert!(s.is_null(), "fmi2FreeFMUstate must null the slot");
                self.live[i].freed.push(freed);
            }
            _ if !self.live[i].freed.is_empty() && self.rng.chance(50) => {
                // A freed state again (set, serialize or free twice): refused, never touched.
                let mut stale = self.live[i].freed[self.rng.below(self.live[i].freed.len())];
                if self.live[i].states.iter().any(|(s, _)| *s == stale) {
                    return; // the allocator reused the address for a live state
                }
                let mut size = 0usize;
                // SAFETY: the FMU must check `stale` against its live states before using it.
                let st = unsafe {
                    match self.rng.below(3) {
                        0 => fmi2SetFMUstate(c, stale),
                        1 => fmi2SerializedFMUstateSize(c, stale, &mut size),
                        _ => fmi2FreeFMUstate(c, &mut stale),
                    }
                };
                m.phase = Error;
                self.expect("a freed FMUstate used again", &[ERROR], st, true);
            }
            _ => {
                // SAFETY: a null slot pointer and a null state: nothing to free.
                let st = unsafe { fmi2FreeFMUstate(c, ptr::null_mut()) };
                self.expect("fmi2FreeFMUstate(NULL)", &[OK], st, false);
            }
        }
    }

    fn serialized(&mut self, i: usize, c: fmi2Component, m: &mut Model) {
        if self.live[i].states.is_empty() || self.rng.chance(30) {
            // Deserialize a blob, maybe corrupted.
            let (mut bytes, saved) = match self.live[i].blobs.last().cloned() {
                Some(b) if self.rng.chance(70) => b,
                _ => ((0..self.rng.below(300)).map(|_| self.rng.next() as u8).collect(), m.clone()),
            };
            let intact = !bytes.is_empty() && bytes.len() > 8 && self.live[i].blobs.iter().any(|(b, _)| *b == bytes);
            let mut corrupted = !intact;
            if intact && self.rng.chance(60) {
                corrupted = true;
                match self.rng.below(4) {
                    0 => bytes.truncate(self.rng.below(bytes.len())),
                    1 => {
                        let k = self.rng.below(bytes.len());
                        bytes[k] ^= 1 << self.rng.below(8);
                    }
                    2 => {
                        let k = 8 + self.rng.below(bytes.len() - 8);
                        bytes[k] ^= 1 + self.rng.below(255) as u8; // never the same byte
                    }
                    _ => bytes.extend_from_slice(&[0xff; 9]),
                }
            }
            let mut s: fmi2FMUstate = ptr::null_mut();
            // SAFETY: a live component, `bytes.len()` readable bytes, a writable slot.
            let st = unsafe { fmi2DeSerializeFMUstate(c, bytes.as_ptr().cast(), bytes.len(), &mut s) };
            if corrupted {
                m.phase = Error;
                self.expect(&format!("fmi2DeSerializeFMUstate(corrupted, {} bytes)", bytes.len()), &[ERROR], st, true);
            } else {
                self.expect("fmi2DeSerializeFMUstate", &[OK], st, true);
            }
            if !s.is_null() {
                self.live[i].states.push((s, saved));
            }
            return;
        }
        let k = self.rng.below(self.live[i].states.len());
        let (s, saved) = self.live[i].states[k].clone();
        let mut size = 0usize;
        // SAFETY: a live component, its state, a writable size.
        let st = unsafe { fmi2SerializedFMUstateSize(c, s, &mut size) };
        self.expect("fmi2SerializedFMUstateSize", &[OK], st, true);
        let wrong_size = self.rng.chance(15);
        let len = if wrong_size { size.saturating_sub(1) } else { size };
        let mut bytes = vec![0u8; len];
        // SAFETY: `len` writable bytes.
        let st = unsafe { fmi2SerializeFMUstate(c, s, bytes.as_mut_ptr().cast(), len) };
        if wrong_size {
            m.phase = Error;
            self.expect("fmi2SerializeFMUstate(short buffer)", &[ERROR], st, true);
        } else {
            self.expect("fmi2SerializeFMUstate", &[OK], st, true);
            self.live[i].blobs.push((bytes, saved));
        }
    }

    fn status(&mut self, c: fmi2Component, m: &mut Model) {
        let mut real = f64::NAN;
        let kind = fmi2StatusKind(self.rng.below(5) as u32);
        // SAFETY: a live component and a writable value.
        let st = unsafe { fmi2GetRealStatus(c, kind, &mut real) };
        let want = if kind != fmi2StatusKind::fmi2LastSuccessfulTime {
            DISCARD
        } else if Self::allowed(m, &[StepComplete, Terminated]) {
            OK
        } else {
            ERROR
        };
        self.expect(&format!("fmi2GetRealStatus({})", kind.0), &[want], st, true);
        if st == OK && real != m.time {
            self.wrong.push(format!("fmi2LastSuccessfulTime {real}, the host's time {}", m.time));
        }
        let mut s = OK;
        // SAFETY: a live component and a writable value.
        let st = unsafe { fmi2GetStatus(c, fmi2StatusKind::fmi2DoStepStatus, &mut s) };
        self.expect("fmi2GetStatus", &[DISCARD], st, false);
    }

    fn misc(&mut self, c: fmi2Component, m: &mut Model) {
        match self.rng.below(5) {
            0 => {
                let cats = [c"logStatusError".as_ptr(), c"logCalls".as_ptr(), c"noSuchCategory".as_ptr(), ptr::null()];
                let n = self.rng.below(4);
                let bad = n >= 3; // the unknown category (and the null one after it)
                // SAFETY: a live component and `n` category pointers (some null, to be rejected).
                let st = unsafe { fmi2SetDebugLogging(c, 1, n, cats.as_ptr()) };
                let want = if bad {
                    m.phase = Error;
                    ERROR
                } else {
                    OK
                };
                self.expect(&format!("fmi2SetDebugLogging({n})"), &[want], st, true);
            }
            1 => {
                // SAFETY: a live component; pointers the FMU must not touch (declared unsupported).
                let st = unsafe { fmi2GetDirectionalDerivative(c, ptr::null(), 5, ptr::null(), 5, ptr::null(), ptr::null_mut()) };
                m.phase = Error;
                self.expect("fmi2GetDirectionalDerivative", &[ERROR], st, true);
            }
            2 => {
                // SAFETY: as above.
                let st = unsafe { fmi2CancelStep(c) };
                m.phase = Error;
                self.expect("fmi2CancelStep", &[ERROR], st, true);
            }
            3 => {
                let vr = [0u32];
                let mut out: [fmi2String; 1] = [ptr::null()];
                // SAFETY: one vr and one writable string slot.
                let st = unsafe { fmi2GetString(c, vr.as_ptr(), 1, out.as_mut_ptr()) };
                m.phase = Error;
                self.expect("fmi2GetString", &[ERROR], st, true);
            }
            4 if self.rng.chance(50) => {
                // nvr huge with null arrays: rejected before anything is read or allocated.
                let n = [usize::MAX, usize::MAX / 8, 1 << 40][self.rng.below(3)];
                // SAFETY: null arrays, which the FMU must reject whatever nvr says.
                let st = unsafe {
                    match self.rng.below(3) {
                        0 => fmi2GetReal(c, ptr::null(), n, ptr::null_mut()),
                        1 => fmi2SetReal(c, ptr::null(), n, ptr::null()),
                        _ => fmi2SetInteger(c, ptr::null(), n, ptr::null()),
                    }
                };
                m.phase = Error;
                self.expect(&format!("nvr {n} with null arrays"), &[ERROR], st, true);
            }
            _ => {
                // A null component is rejected by every function.
                // SAFETY: null components are checked by the FMU.
                let sts = unsafe {
                    [
                        fmi2DoStep(ptr::null_mut(), 0.0, 1e-6, 0),
                        fmi2SetReal(ptr::null_mut(), ptr::null(), 0, ptr::null()),
                        fmi2Reset(ptr::null_mut()),
                        fmi2Terminate(ptr::null_mut()),
                        fmi2SetupExperiment(ptr::null_mut(), 0, 0.0, 0.0, 0, 0.0),
                    ]
                };
                for st in sts {
                    self.expect("fmi2*(NULL component)", &[ERROR], st, false);
                }
                // SAFETY: freeing null is a no-op.
                unsafe { fmi2FreeInstance(ptr::null_mut()) };
            }
        }
    }

    /// A whole random case: `ops` operations over up to [`MAX_LIVE`] instances.
    fn run(&mut self, ops: usize) {
        for _ in 0..ops {
            if self.live.is_empty() || (self.live.len() < MAX_LIVE && self.rng.chance(8)) {
                self.instantiate();
            } else if self.rng.chance(3) {
                let i = self.rng.below(self.live.len());
                self.free(i);
            } else {
                let i = self.rng.below(self.live.len());
                self.operate(i);
            }
        }
        while !self.live.is_empty() {
            self.free(0);
        }
    }
}

// ---- Driver: each case in a subprocess ------------------------------------------------------

/// Run as a child: the cases `HOSTILE_CHILD_SEEDS` (`first..last`), then exit. Not a test of its own.
#[test]
fn hostile_child() {
    if std::env::var("HOSTILE_CHILD_RSS").is_ok() {
        return rss_cycles();
    }
    let Ok(range) = std::env::var("HOSTILE_CHILD_SEEDS") else { return };
    let (a, b) = range.split_once("..").unwrap();
    let (a, b): (u64, u64) = (a.parse().unwrap(), b.parse().unwrap());
    let (mut calls, mut steps) = (0, 0);
    for seed in a..b {
        let mut host = Host::new(seed);
        host.run(300);
        calls += host.calls;
        steps += host.steps_ok;
        assert!(host.wrong.is_empty(), "seed {seed}: {} mismatches:\n{}", host.wrong.len(), host.wrong.join("\n"));
    }
    println!("HOSTILE_CALLS={calls} HOSTILE_STEPS={steps}");
}

#[derive(Debug, Default)]
struct Tally {
    cases: u64,
    calls: u64,
    steps_ok: u64,
    crashes: Vec<String>,
    hangs: Vec<String>,
    wrong: Vec<String>,
}

/// Runs cases `first..first + n`, `per` per child process.
fn run_children(first: u64, n: u64, per: u64, timeout: Duration) -> Tally {
    let exe = std::env::current_exe().unwrap();
    let mut tally = Tally::default();
    let mut seed = first;
    while seed < first + n {
        let end = (seed + per).min(first + n);
        let mut child = Command::new(&exe)
            .args(["--exact", "hostile_child", "--nocapture", "--test-threads=1"])
            .env("HOSTILE_CHILD_SEEDS", format!("{seed}..{end}"))
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let started = Instant::now();
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break Some(s);
            }
            if started.elapsed() > timeout {
                child.kill().unwrap();
                child.wait().unwrap();
                break None;
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        let out = child.wait_with_output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        tally.cases += end - seed;
        tally.calls += stdout.split("HOSTILE_CALLS=").nth(1).and_then(|rest| rest.split_whitespace().next()).and_then(|n| n.parse::<u64>().ok()).unwrap_or(0);
        tally.steps_ok += stdout.split("HOSTILE_STEPS=").nth(1).and_then(|rest| rest.split_whitespace().next()).and_then(|n| n.parse::<u64>().ok()).unwrap_or(0);
        use std::os::unix::process::ExitStatusExt;
        match status {
            None => tally.hangs.push(format!("seeds {seed}..{end}: no exit within {timeout:?}")),
            Some(s) if s.signal().is_some() => tally.crashes.push(format!("seeds {seed}..{end}: signal {:?}\n{stderr}", s.signal())),
            Some(s) if !s.success() => tally.wrong.push(format!("seeds {seed}..{end}: {s}\n{stdout}\n{stderr}")),
            Some(_) => {}
        }
        seed = end;
    }
    tally
}

#[test]
fn random_hostile_call_sequences_give_the_right_status_and_never_crash() {
    let n: u64 = std::env::var("HOSTILE_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(300);
    let first: u64 = std::env::var("HOSTILE_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
    let t = Instant::now();
    let tally = run_children(first, n, 10, Duration::from_secs(60));
    eprintln!(
        "hostile host: {} cases, {} calls ({} successful steps), {} crashes, {} hangs, {} wrong statuses in {:.1} s",
        tally.cases,
        tally.calls,
        tally.steps_ok,
        tally.crashes.len(),
        tally.hangs.len(),
        tally.wrong.len(),
        t.elapsed().as_secs_f64()
    );
    assert!(tally.crashes.is_empty() && tally.hangs.is_empty() && tally.wrong.is_empty(), "{tally:#?}");
    assert!(tally.calls > 100 * tally.cases, "the children did not run: {tally:#?}");
}

// ---- Resources: many instances, 10 000 cycles -----------------------------------------------

fn rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    status.lines().find_map(|l| l.strip_prefix("VmRSS:")).unwrap().trim().trim_end_matches(" kB").trim().parse().unwrap()
}

/// Instantiates, initializes, steps and frees one instance; returns the component's vout.
fn lifecycle(guid: &CStr, cb: &fmi2CallbackFunctions, steps: usize) -> fmi2Component {
    // SAFETY: valid strings and callbacks alive for the call.
    let c = unsafe { fmi2Instantiate(c"cycle".as_ptr(), fmi2Type::fmi2CoSimulation, guid.as_ptr(), ptr::null(), cb, 0, 0) };
    assert!(!c.is_null());
    // SAFETY: a live component; scalars only.
    unsafe {
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), OK);
        assert_eq!(fmi2EnterInitializationMode(c), OK);
        assert_eq!(fmi2ExitInitializationMode(c), OK);
        for k in 0..steps {
            assert_eq!(fmi2DoStep(c, k as f64 * 1e-6, 1e-6, 1), OK);
        }
    }
    c
}

/// 10 000 full lifecycles (instantiate, initialize, step, state get/free, terminate, free) in
/// a child process of its own, so that other tests' allocations do not count.
#[test]
fn ten_thousand_instantiate_free_cycles_keep_rss_flat() {
    let out = Command::new(std::env::current_exe().unwrap()).args(["--exact", "hostile_child", "--nocapture", "--test-threads=1"]).env("HOSTILE_CHILD_RSS", "1").output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
    let nums: Vec<u64> = stdout.split("RSS_KIB=").nth(1).unwrap_or_else(|| panic!("no RSS line in {stdout}")).split_whitespace().take(2).map(|n| n.parse().unwrap()).collect();
    let (before, after) = (nums[0], nums[1]);
    eprintln!("10 000 cycles: RSS {before} KiB → {after} KiB");
    // A leak of one converter per cycle (> 1 KiB) would add > 10 MiB.
    assert!(after < before + 1024, "RSS grew from {before} KiB to {after} KiB over 10 000 cycles");
}

fn rss_cycles() {
    let (_, guid) = table();
    let guid = CString::new(guid).unwrap();
    let cb = callbacks(true);
    let cycle = || {
        let c = lifecycle(&guid, &cb, 2);
        let mut s: fmi2FMUstate = ptr::null_mut();
        // SAFETY: a live component, its state freed before the component.
        unsafe {
            assert_eq!(fmi2GetFMUstate(c, &mut s), OK);
            assert_eq!(fmi2FreeFMUstate(c, &mut s), OK);
            assert_eq!(fmi2Terminate(c), OK);
            fmi2FreeInstance(c);
        }
        LOG.lock().unwrap().clear();
    };
    for _ in 0..1000 {
        cycle(); // warm-up: allocator pools, caches
    }
    let before = rss_kib();
    for _ in 0..10_000 {
        cycle();
    }
    println!("RSS_KIB={before} {}", rss_kib());
}

#[test]
fn a_thousand_live_instances_step_independently() {
    let (_, guid) = table();
    let guid = CString::new(guid).unwrap();
    let cb = callbacks(true);
    let comps: Vec<fmi2Component> = (0..1000).map(|_| lifecycle(&guid, &cb, 0)).collect();
    let duty_vr = [0u32];
    for (k, &c) in comps.iter().enumerate() {
        let duty = [0.1 + 0.8 * (k as f64 / 1000.0)];
        // SAFETY: a live component, one vr and one value.
        unsafe {
            assert_eq!(fmi2SetReal(c, duty_vr.as_ptr(), 1, duty.as_ptr()), OK);
            assert_eq!(fmi2DoStep(c, 0.0, 1e-5, 1), OK);
        }
    }
    for (k, &c) in comps.iter().enumerate() {
        let mut d = [f64::NAN];
        // SAFETY: a live component, one vr and one slot; freed once.
        unsafe {
            assert_eq!(fmi2GetReal(c, duty_vr.as_ptr(), 1, d.as_mut_ptr()), OK);
            fmi2FreeInstance(c);
        }
        assert_eq!(d[0], 0.1 + 0.8 * (k as f64 / 1000.0), "instance {k} kept its own duty");
    }
}

// ---- Valgrind ---------------------------------------------------------------------------------

/// The deterministic payload run under valgrind: the normal lifecycle, then 20
/// hostile cases in-process (every error path: bad order, bad values, null pointers, corrupted
/// states). Runs as a normal (fast) test too.
#[test]
fn valgrind_payload() {
    let (_, guid) = table();
    let guid = CString::new(guid).unwrap();
    let cb = callbacks(true);
    let c = lifecycle(&guid, &cb, 50);
    // SAFETY: a live component freed once.
    unsafe {
        assert_eq!(fmi2Terminate(c), OK);
        assert_eq!(fmi2Reset(c), OK);
        fmi2FreeInstance(c);
    }
    for seed in 1000..1020 {
        let mut host = Host::new(seed);
        host.run(120);
        assert!(host.wrong.is_empty(), "seed {seed}: {}", host.wrong.join("\n"));
    }
}

/// `valgrind_payload` under valgrind (memcheck, full leak check): no invalid access, no
/// uninitialised read, no definite leak. About 3 s, so it runs with every `cargo test`;
/// skipped with a note where valgrind is not installed.
#[test]
fn valgrind_finds_no_errors_and_no_definite_leaks() {
    if Command::new("valgrind").arg("--version").output().is_err() {
        eprintln!("valgrind is not installed: skipping the memcheck run");
        return;
    }
    let exe = std::env::current_exe().unwrap();
    let out = Command::new("valgrind")
        .args(["--leak-check=full", "--errors-for-leak-kinds=definite", "--error-exitcode=1", "-q"])
        .arg(&exe)
        .args(["--exact", "valgrind_payload", "--test-threads=1"])
        .output()
        .expect("valgrind");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "valgrind: {}\n{stderr}", out.status);
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 passed"), "the payload did not run");
}

// ---- Findings, replayed ---------------------------------------------------------------------

/// Finding: `fmi2DoStep(0, 1e6)` (or 1e300) looped over every switching period of the step,
/// 3.3e11 of them: the host hung for hours. Now fmi2Error, at once, naming the limit.
#[test]
fn finding_huge_step_is_an_error_not_a_hang() {
    let (_, guid) = table();
    let guid = CString::new(guid).unwrap();
    let cb = callbacks(true);
    for h in [1e6, 1e300, f64::MAX] {
        let c = lifecycle(&guid, &cb, 0);
        LOG.lock().unwrap().clear();
        let t = Instant::now();
        // SAFETY: a live component; freed once.
        let st = unsafe { fmi2DoStep(c, 0.0, h, 0) };
        assert!(t.elapsed() < Duration::from_secs(1), "{h}: {:?}", t.elapsed());
        assert_eq!(st, ERROR, "{h}");
        let log = std::mem::take(&mut *LOG.lock().unwrap());
        assert!(log.iter().any(|(_, m)| m.contains("switching periods") && m.contains("split it")), "{log:?}");
        // SAFETY: as above.
        unsafe { fmi2FreeInstance(c) };
    }
}

/// Finding: a serialized state with one bit flipped (or cut short, or extended) was decoded by
/// postcard as other valid numbers and accepted with fmi2OK, to be restored and stepped with
/// a garbage inductance or phase. Now a checksum rejects it with fmi2Error.
#[test]
fn finding_altered_serialized_state_is_refused() {
    let (_, guid) = table();
    let guid = CString::new(guid).unwrap();
    let cb = callbacks(true);
    let c = lifecycle(&guid, &cb, 3);
    let mut s: fmi2FMUstate = ptr::null_mut();
    let mut size = 0usize;
    // SAFETY: a live component, a writable slot and size.
    unsafe {
        assert_eq!(fmi2GetFMUstate(c, &mut s), OK);
        assert_eq!(fmi2SerializedFMUstateSize(c, s, &mut size), OK);
    }
    let mut bytes = vec![0u8; size];
    // SAFETY: `size` writable bytes.
    assert_eq!(unsafe { fmi2SerializeFMUstate(c, s, bytes.as_mut_ptr().cast(), size) }, OK);
    let mut variants = vec![bytes[..size - 1].to_vec(), [bytes.as_slice(), &[0]].concat()];
    for k in 8..size {
        let mut b = bytes.clone();
        b[k] ^= 0x10;
        variants.push(b);
    }
    for (n, b) in variants.iter().enumerate() {
        let mut out: fmi2FMUstate = ptr::null_mut();
        LOG.lock().unwrap().clear();
        // SAFETY: `b.len()` readable bytes and a writable slot.
        let st = unsafe { fmi2DeSerializeFMUstate(c, b.as_ptr().cast(), b.len(), &mut out) };
        assert_eq!(st, ERROR, "variant {n} accepted");
        assert!(out.is_null());
        let log = std::mem::take(&mut *LOG.lock().unwrap());
        assert!(log.iter().any(|(_, m)| m.contains("corrupt serialized state")), "{log:?}");
        // SAFETY: a live component; leaves the error phase.
        assert_eq!(unsafe { fmi2Reset(c) }, OK);
    }
    let mut out: fmi2FMUstate = ptr::null_mut();
    // SAFETY: the intact bytes still load; every state freed once, then the component.
    unsafe {
        assert_eq!(fmi2DeSerializeFMUstate(c, bytes.as_ptr().cast(), size, &mut out), OK);
        assert_eq!(fmi2FreeFMUstate(c, &mut out), OK);
        assert_eq!(fmi2FreeFMUstate(c, &mut s), OK);
        fmi2FreeInstance(c);
    }
}

/// Finding (valgrind): FMU states the host never freed leaked at `fmi2FreeInstance`, and a
/// state freed twice was freed twice (a double free in the host's process). Now the instance
/// frees its leftover states, and refuses a state it does not hold with fmi2Error.
#[test]
fn finding_states_are_freed_with_the_instance_and_double_free_is_refused() {
    let (_, guid) = table();
    let guid = CString::new(guid).unwrap();
    let cb = callbacks(true);
    let c = lifecycle(&guid, &cb, 1);
    let (mut a, mut b): (fmi2FMUstate, fmi2FMUstate) = (ptr::null_mut(), ptr::null_mut());
    // SAFETY: a live component and writable slots; the stale pointer is checked by the FMU.
    unsafe {
        assert_eq!(fmi2GetFMUstate(c, &mut a), OK);
        assert_eq!(fmi2GetFMUstate(c, &mut b), OK);
        let stale = a;
        assert_eq!(fmi2FreeFMUstate(c, &mut a), OK);
        let mut again = stale;
        assert_eq!(fmi2FreeFMUstate(c, &mut again), ERROR, "double free refused");
        assert_eq!(fmi2SetFMUstate(c, stale), ERROR, "use after free refused");
        assert_eq!(fmi2Reset(c), OK);
        fmi2FreeInstance(c); // frees `b` (valgrind: no definite leak)
    }
    let _ = b;
}
