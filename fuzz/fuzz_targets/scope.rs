//! The oscilloscope-capture reader and its reduction to periods (`buckid convert`): any text,
//! read as the contract has it and as a scope's export with its columns named (a Tektronix's
//! and a Rigol's names) and as one channel's file (a LeCroy's or a Tektronix TDS's trace, made
//! the capture's `vout` and `sw`), then reduced from its edges and at a given switching
//! frequency and written out, must give a result or an error with a message, never a panic.
#![no_main]

use capture::{Capture, Named, Trace, reduce, to_csv};
use libfuzzer_sys::fuzz_target;

fuzz_target!(
    init: {
        std::panic::set_hook(Box::new(|info| eprintln!("{info}")));
    },
    |data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let named = |column, header, scale| Named { column, header, scale };
    let scope = [named("time", "TIME", None), named("vout", "CH1", None), named("il", "CH2", Some(10.0)), named("sw", "CH3", None)];
    // A Rigol's names its samples' index `X`.
    let rigol = [named("time", "X", None), named("vout", "CH1", None), named("sw", "CH3", None)];
    let traced = Trace::parse_csv(text).map(|t| {
        assert!(t.time.len() == t.values.len() && !t.time.is_empty());
        Capture::from_traces(vec![("vout", t.clone(), 1.0), ("sw", t, 2.0)])
    });
    let traced = traced.and_then(|c| c);
    for parsed in [Capture::parse_csv(text), Capture::parse_csv_with(text, &scope), Capture::parse_csv_with(text, &rigol), traced] {
        match parsed {
            Ok(cap) => {
                assert!(cap.time.len() == cap.vout.len() && !cap.time.is_empty());
                assert!(cap.time.windows(2).all(|w| w[1] > w[0]), "accepted a time that does not increase");
                for fs in [None, Some(330e3)] {
                    match reduce(&cap, fs) {
                        Ok(p) => {
                            let _ = to_csv(&p, &cap.meta);
                        }
                        Err(e) => assert!(!e.to_string().trim().is_empty()),
                    }
                }
            }
            Err(e) => assert!(!e.to_string().trim().is_empty()),
        }
    }
});
