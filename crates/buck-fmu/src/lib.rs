//! The buck converter of `buck-model` as an FMI 2.0 Co-Simulation FMU.
//!
//! [`ffi`] holds every exported `fmi2*` function and all the `unsafe` code: it checks pointers,
//! turns them into slices, runs the call inside `catch_unwind` and maps [`instance::Status`]
//! to `fmi2Status`. [`instance`] is the safe FMI state machine around a
//! [`buck_model::Converter`]; [`description`] derives `modelDescription.xml` from the variable
//! table, so the XML, the value references and the GUID cannot disagree.
#![deny(unsafe_code)] // allowed in `ffi` alone

pub mod description;
pub mod ffi;
pub mod instance;

pub use description::{MODEL_IDENTIFIER, model_description};
