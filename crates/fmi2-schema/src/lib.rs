//! FMI 2.0 `modelDescription.xml`: typed structures that read and write the file, and a check
//! that collects every problem at once instead of stopping at the first.
//!
//! Only what Co-Simulation importers and exporters need is typed; unknown attributes and
//! elements are ignored on reading, so vendor extensions do not break loading.
//!
//! ```
//! let xml = r#"<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{1}">
//!   <CoSimulation modelIdentifier="M"/>
//!   <ModelVariables>
//!     <ScalarVariable name="y" valueReference="0" causality="output"><Real/></ScalarVariable>
//!   </ModelVariables>
//!   <ModelStructure><Outputs><Unknown index="1"/></Outputs></ModelStructure>
//! </fmiModelDescription>"#;
//! let md = fmi2_schema::ModelDescription::from_xml(xml).unwrap();
//! assert_eq!(md.variable("y").unwrap().value_reference, 0);
//! assert!(md.problems().is_empty());
//! ```
#![forbid(unsafe_code)]

mod check;
mod model;

pub use model::*;

/// Why a modelDescription could not be read or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SchemaError {
    /// The XML is malformed or does not have the FMI 2.0 structure.
    #[error("modelDescription.xml is not valid FMI 2.0: {0}")]
    Parse(#[from] quick_xml::DeError),
    /// The XML parser panicked on malformed input (quick-xml 0.38 does on a `<!DOCTYPE>` between
    /// two runs of text in an element, tafia/quick-xml#964); the panic is caught and reported.
    #[error("modelDescription.xml is not valid FMI 2.0: the XML parser failed on malformed input ({0})")]
    ParserPanic(String),
    /// Serialization failed.
    #[error("cannot write modelDescription.xml: {0}")]
    Write(#[from] quick_xml::SeError),
}
