//! The FMI state machine and value access, through the safe layer the exports call.
use std::cell::RefCell;
use std::rc::Rc;

use buck_model::variables::{VarId, by_name, guid, vr};

use super::*;

type Log = Rc<RefCell<Vec<(Status, String)>>>;

fn instance() -> (Instance, Log) {
    let log: Log = Rc::default();
    let sink = log.clone();
    let inst = Instance::new(&guid(), Box::new(move |s, _, m| sink.borrow_mut().push((s, m.to_string())))).unwrap();
    (inst, log)
}

fn initialized() -> (Instance, Log) {
    let (mut inst, log) = instance();
    assert_eq!(inst.setup_experiment(0.0), Status::Ok);
    assert_eq!(inst.enter_initialization_mode(), Status::Ok);
    assert_eq!(inst.exit_initialization_mode(), Status::Ok);
    (inst, log)
}

fn get(inst: &mut Instance, id: VarId) -> f64 {
    let mut out = [0.0];
    assert_eq!(inst.get("fmi2GetReal", "Real", &[vr(id)], &mut out), Status::Ok);
    out[0]
}

#[test]
fn wrong_guid_is_rejected_with_a_message() {
    let log: Log = Rc::default();
    let sink = log.clone();
    let res = Instance::new("{not-it}", Box::new(move |s, _, m| sink.borrow_mut().push((s, m.to_string()))));
    assert!(res.is_err());
    assert!(log.borrow()[0].1.contains("GUID"));
}

#[test]
fn calls_out_of_order_are_errors_that_name_the_function() {
    let (mut inst, log) = instance();
    assert_eq!(inst.do_step(0.0, 1e-6), Status::Error);
    assert!(log.borrow().last().unwrap().1.starts_with("fmi2DoStep: not allowed in phase Instantiated"));
    assert_eq!(inst.phase(), Phase::Error);
    // Reset leaves the error phase.
    assert_eq!(inst.reset(), Status::Ok);
    assert_eq!(inst.exit_initialization_mode(), Status::Error);
}

#[test]
fn bad_values_are_errors_that_name_the_variable_and_change_nothing() {
    let (mut inst, log) = initialized();
    let cases: &[(&str, f64, &str)] =
        &[("duty", 1.5, "duty = 1.5 is out of range"), ("duty", f64::NAN, "duty = NaN is out of range"), ("Cl", 1e-6, "Cl is a fixed parameter"), ("vout", 1.0, "vout is an output")];
    for &(name, value, expect) in cases {
        inst.reset();
        assert_eq!(inst.enter_initialization_mode(), Status::Ok);
        assert_eq!(inst.exit_initialization_mode(), Status::Ok);
        let before = get(&mut inst, by_name(name).unwrap().id);
        let status = inst.set("fmi2SetReal", "Real", &[by_name(name).unwrap().vr()], &[value]);
        assert_eq!(status, Status::Error, "{name} = {value}");
        let msg = log.borrow().last().unwrap().1.clone();
        assert!(msg.contains(expect), "{msg:?} lacks {expect:?}");
        assert_eq!(get(&mut inst, by_name(name).unwrap().id), before);
    }
    // Before initialization, non-positive circuit values are rejected as well.
    inst.reset();
    for name in ["L", "C", "Cl", "fs"] {
        let status = inst.set("fmi2SetReal", "Real", &[by_name(name).unwrap().vr()], &[0.0]);
        assert_eq!(status, Status::Error, "{name} = 0 accepted");
        inst.reset();
    }
    let (mut inst, _) = initialized();
    assert_eq!(inst.do_step(0.0, 0.0), Status::Error);
    let (mut inst, _) = initialized();
    assert_eq!(inst.do_step(0.0, -1e-6), Status::Error);
    let (mut inst, _) = initialized();
    assert_eq!(inst.do_step(1.0, 1e-6), Status::Error, "skipping ahead in time must be caught");
}

#[test]
fn types_are_checked() {
    let (mut inst, log) = initialized();
    let mut out = [0.0];
    assert_eq!(inst.get("fmi2GetInteger", "Integer", &[vr(VarId::Duty)], &mut out), Status::Error);
    assert!(log.borrow().last().unwrap().1.contains("duty of type Real, not Integer"));
    let (mut inst, _) = initialized();
    assert_eq!(inst.get("fmi2GetReal", "Real", &[9999], &mut out), Status::Error);
    let (mut inst, _) = initialized();
    assert_eq!(inst.get("fmi2GetInteger", "Integer", &[vr(VarId::Mode)], &mut out), Status::Ok);
    assert_eq!(out[0], 1.0);
}

#[test]
fn parameters_set_before_initialization_define_the_operating_point() {
    let (mut inst, _) = instance();
    inst.set("fmi2SetReal", "Real", &[vr(VarId::Duty), vr(VarId::Io), vr(VarId::Rl)], &[0.4, 2.0, 0.05]);
    inst.set("fmi2SetInteger", "Integer", &[vr(VarId::Mode)], &[2.0]);
    inst.enter_initialization_mode();
    assert_eq!(get(&mut inst, VarId::Vout), 0.4 * 12.0 - 0.05 * 2.0);
    inst.exit_initialization_mode();
    assert_eq!(get(&mut inst, VarId::Il), 2.0);
}

#[test]
fn snapshots_restore_exactly_and_survive_serialization() {
    let (mut inst, _) = initialized();
    inst.set("fmi2SetReal", "Real", &[vr(VarId::Duty)], &[0.6]);
    let t = 1.0 / 330e3;
    inst.do_step(0.0, 3.3 * t);
    let snap = inst.snapshot().unwrap();
    let bytes = inst.serialize("fmi2SerializeFMUstate", &snap).unwrap();
    inst.do_step(3.3 * t, 5.0 * t);
    let reference = get(&mut inst, VarId::Vout);
    let restored = inst.deserialize(&bytes).unwrap();
    assert_eq!(inst.restore(&restored), Status::Ok);
    inst.do_step(3.3 * t, 5.0 * t);
    assert_eq!(get(&mut inst, VarId::Vout), reference);
    // Foreign or truncated bytes are an error, not a panic.
    assert!(inst.deserialize(b"garbage").is_err());
    assert!(inst.deserialize(&bytes[..bytes.len() / 2]).is_err());
}

#[test]
fn restoring_a_state_leaves_the_error_phase() {
    let (mut inst, _) = initialized();
    let snap = inst.snapshot().unwrap();
    inst.do_step(0.0, -1.0);
    assert_eq!(inst.phase(), Phase::Error);
    assert_eq!(inst.restore(&snap), Status::Ok);
    assert_eq!(inst.phase(), Phase::StepComplete);
    assert_eq!(inst.do_step(0.0, 1e-6), Status::Ok);
}
