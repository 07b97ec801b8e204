//! An FMU on disk: its extracted folder and parsed model description. Needs no binary.
use std::fmt;
use std::fs;
use std::io::ErrorKind;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use fmi2_schema::{CoSimulation, ModelDescription, ScalarVariable, VariableType};
use tempfile::TempDir;

use crate::archive::{self, Limits};
use crate::callbacks::{LogCallback, LogMessage};
use crate::{ImportError, Instance, python};

/// Platform folder below `binaries/` and the shared-library extension.
#[cfg(target_os = "macos")]
const PLATFORM: (&str, &str) = ("darwin64", "dylib");
#[cfg(not(target_os = "macos"))]
const PLATFORM: (&str, &str) = ("linux64", "so");

/// How many variable names an [`ImportError::UnknownVariable`] lists.
const LISTED_VARIABLES: usize = 200;

/// The extracted folder, shared by the [`Fmu`] and its instances so the resources outlive both.
#[derive(Debug)]
pub(crate) struct Folder {
    root: PathBuf,
    /// Deletes the extraction on drop; `None` for [`Fmu::from_dir`].
    _temp: Option<TempDir>,
    live_instances: AtomicUsize,
}

/// Held by an [`Instance`]: keeps the folder alive and counts the instance.
#[derive(Debug)]
pub(crate) struct InstanceSlot(Arc<Folder>);

impl Drop for InstanceSlot {
    fn drop(&mut self) {
        self.0.live_instances.fetch_sub(1, Ordering::SeqCst);
    }
}

/// The type of a variable, which decides the get/set function to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum VarKind {
    /// `fmi2GetReal`/`fmi2SetReal`.
    Real,
    /// `fmi2GetInteger`/`fmi2SetInteger`.
    Integer,
    /// `fmi2GetBoolean`/`fmi2SetBoolean`.
    Boolean,
    /// `fmi2GetString`/`fmi2SetString` (not wrapped by [`Instance`]).
    String,
    /// An enumeration: `fmi2GetInteger`/`fmi2SetInteger` with the item's value.
    Enumeration,
}

impl From<&VariableType> for VarKind {
    fn from(ty: &VariableType) -> Self {
        match ty {
            VariableType::Real(_) => Self::Real,
            VariableType::Integer(_) => Self::Integer,
            VariableType::Boolean(_) => Self::Boolean,
            VariableType::String(_) => Self::String,
            VariableType::Enumeration(_) => Self::Enumeration,
        }
    }
}

/// Options for [`Fmu::instantiate_with`].
#[derive(Default)]
pub struct InstantiateOptions {
    pub(crate) debug_logging: bool,
    pub(crate) log_callback: Option<LogCallback>,
}

impl InstantiateOptions {
    /// Defaults: debug logging off (errors are logged regardless), no callback.
    pub fn new() -> Self {
        Self::default()
    }

    /// Passes `loggingOn` to `fmi2Instantiate`.
    pub fn debug_logging(mut self, on: bool) -> Self {
        self.debug_logging = on;
        self
    }

    /// Also hands every log message to `f` (from whatever thread the FMU logs on). The
    /// instance keeps its own copy for [`Instance::take_log`] and errors regardless.
    pub fn log_callback(mut self, f: impl Fn(&LogMessage) + Send + Sync + 'static) -> Self {
        self.log_callback = Some(Box::new(f));
        self
    }
}

impl fmt::Debug for InstantiateOptions {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("InstantiateOptions").field("debug_logging", &self.debug_logging).field("log_callback", &self.log_callback.is_some()).finish()
    }
}

/// An FMI 2.0 Co-Simulation FMU, extracted and with its model description read.
///
/// Consistency problems of the model description that do not stop simulation (unknown units,
/// duplicate names, …) do not fail loading; they are listed by [`Fmu::problems`]. A malformed
/// XML, a `fmiVersion` other than `2.0` and a missing `CoSimulation` element are errors.
#[derive(Debug)]
pub struct Fmu {
    folder: Arc<Folder>,
    description: ModelDescription,
    co_simulation: CoSimulation,
    problems: Vec<String>,
}

impl Fmu {
    /// Extracts the FMU archive at `path` into a temporary folder (deleted when the `Fmu` and
    /// all its instances are dropped) and reads its model description.
    ///
    /// ```no_run
    /// let fmu = fmi2_import::Fmu::open("fmu/BuckConverter.fmu")?;
    /// println!("{} ({} variables)", fmu.model_identifier(), fmu.variables().len());
    /// for problem in fmu.problems() {
    ///     eprintln!("warning: {problem}");
    /// }
    /// # Ok::<(), fmi2_import::ImportError>(())
    /// ```
    pub fn open(path: impl AsRef<Path>) -> Result<Self, ImportError> {
        let path = path.as_ref();
        let temp = tempfile::Builder::new().prefix("fmi2-import-").tempdir().map_err(|source| ImportError::Io { path: std::env::temp_dir(), source })?;
        archive::extract(path, temp.path(), Limits::default())?;
        let root = temp.path().to_path_buf();
        Self::read(root, Some(temp), &path.join("modelDescription.xml"))
    }

    /// Reads an FMU that is already extracted at `dir`; the folder is left in place.
    pub fn from_dir(dir: impl AsRef<Path>) -> Result<Self, ImportError> {
        let dir = dir.as_ref();
        // Absolute, so the resource URI handed to the FMU does not depend on the working dir.
        let root = fs::canonicalize(dir).map_err(|source| ImportError::Io { path: dir.to_path_buf(), source })?;
        let shown = root.join("modelDescription.xml");
        Self::read(root, None, &shown)
    }

    /// `shown` is how error messages name the model description (inside the archive).
    fn read(root: PathBuf, temp: Option<TempDir>, shown: &Path) -> Result<Self, ImportError> {
        let file = root.join("modelDescription.xml");
        // The archive may hold up to MAX_TOTAL_SIZE; the description is parsed in memory, so it
        // has a bound of its own (a 2 GB one would need several GB of RAM).
        match fs::metadata(&file) {
            Ok(meta) if meta.len() > MAX_MODEL_DESCRIPTION_SIZE => {
                return Err(ImportError::TooLarge {
                    path: shown.to_path_buf(),
                    reason: format!("{} bytes, more than the limit of {MAX_MODEL_DESCRIPTION_SIZE} bytes for a modelDescription.xml", meta.len()),
                });
            }
            _ => {}
        }
        let xml = match fs::read_to_string(&file) {
            Ok(xml) => xml,
            Err(e) if e.kind() == ErrorKind::NotFound => {
                return Err(ImportError::MissingModelDescription { path: shown.to_path_buf() });
            }
            Err(source) => return Err(ImportError::Io { path: shown.to_path_buf(), source }),
        };
        let description = match ModelDescription::from_xml(&xml) {
            Ok(d) => d,
            // An FMI 1.0 or 3.0 description fails the 2.0 structure first; say which version
            // it is instead of "missing field `ModelStructure`".
            Err(source) => match fmi2_schema::fmi_version_of(&xml) {
                Some(found) if found != "2.0" => {
                    return Err(ImportError::UnsupportedFmiVersion { path: shown.to_path_buf(), found });
                }
                _ => return Err(ImportError::ModelDescription { path: shown.to_path_buf(), source }),
            },
        };
        let id = description.co_simulation.as_ref().map(|cs| cs.model_identifier.as_str());
        if let Some(id) = id
            && !is_file_stem(id)
        {
            // The binary is binaries/<platform>/<modelIdentifier>.so: a `/` or `..` in the
            // identifier would load a library from outside the FMU (found by fuzzing).
            return Err(ImportError::BadModelIdentifier { path: shown.to_path_buf(), identifier: id.to_owned() });
        }
        if description.fmi_version != "2.0" {
            return Err(ImportError::UnsupportedFmiVersion { path: shown.to_path_buf(), found: description.fmi_version.clone() });
        }
        let Some(co_simulation) = description.co_simulation.clone() else {
            return Err(ImportError::NotCoSimulation { path: shown.to_path_buf() });
        };
        let problems = description.problems();
        let folder = Arc::new(Folder { root, _temp: temp, live_instances: AtomicUsize::new(0) });
        Ok(Self { folder, description, co_simulation, problems })
    }

    /// The folder the FMU is extracted in.
    pub fn dir(&self) -> &Path {
        &self.folder.root
    }

    /// The whole model description.
    pub fn model_description(&self) -> &ModelDescription {
        &self.description
    }

    /// The `CoSimulation` element (always present).
    pub fn co_simulation(&self) -> &CoSimulation {
        &self.co_simulation
    }

    /// The `modelIdentifier` of the Co-Simulation interface: the binary's file stem.
    pub fn model_identifier(&self) -> &str {
        &self.co_simulation.model_identifier
    }

    /// Consistency problems of the model description that did not prevent loading.
    pub fn problems(&self) -> &[String] {
        &self.problems
    }

    /// The variables in index order.
    pub fn variables(&self) -> &[ScalarVariable] {
        self.description.variables()
    }

    /// The variable called `name`, if any.
    pub fn variable(&self, name: &str) -> Option<&ScalarVariable> {
        self.description.variable(name)
    }

    /// The value reference and kind of the variable called `name`; the error for an unknown
    /// name lists the FMU's variables.
    ///
    /// ```no_run
    /// # let fmu = fmi2_import::Fmu::open("fmu/BuckConverter.fmu")?;
    /// let (vr, kind) = fmu.value_reference("vout")?;
    /// assert_eq!(kind, fmi2_import::VarKind::Real);
    /// # Ok::<(), fmi2_import::ImportError>(())
    /// ```
    pub fn value_reference(&self, name: &str) -> Result<(u32, VarKind), ImportError> {
        match self.variable(name) {
            Some(v) => Ok((v.value_reference, VarKind::from(&v.ty))),
            None => Err(self.unknown_variable(name)),
        }
    }

    /// The error for a name the FMU lacks, listing (the first 200 of) its variables.
    pub(crate) fn unknown_variable(&self, name: &str) -> ImportError {
        let vars = self.variables();
        let mut available: Vec<&str> = vars.iter().take(LISTED_VARIABLES).map(|v| v.name.as_str()).collect();
        let more = vars.len().saturating_sub(LISTED_VARIABLES);
        let more = format!("… and {more} more");
        if vars.len() > LISTED_VARIABLES {
            available.push(&more);
        }
        let available = if available.is_empty() { "(none)".to_owned() } else { available.join(", ") };
        ImportError::UnknownVariable { name: name.to_owned(), available }
    }

    /// Where the binary for this platform must be, e.g. `binaries/linux64/<id>.so`.
    pub fn binary_path(&self) -> PathBuf {
        let (platform, ext) = PLATFORM;
        self.dir().join("binaries").join(platform).join(format!("{}.{ext}", self.model_identifier()))
    }

    /// The `file://` URI of the `resources` folder passed to `fmi2Instantiate`.
    pub fn resource_uri(&self) -> String {
        file_uri(&self.dir().join("resources"))
    }

    /// Whether this FMU was built by pythonfmu (and so needs libpython, see [`crate::LIBPYTHON_ENV`]).
    pub fn is_pythonfmu(&self) -> bool {
        python::is_pythonfmu(self.dir())
    }

    /// Loads the binary and creates an instance with default [`InstantiateOptions`].
    pub fn instantiate(&self, instance_name: &str) -> Result<Instance, ImportError> {
        self.instantiate_with(instance_name, InstantiateOptions::new())
    }

    /// Loads the binary and creates an instance.
    pub fn instantiate_with(&self, instance_name: &str, options: InstantiateOptions) -> Result<Instance, ImportError> {
        Instance::new(self, instance_name, options)
    }

    /// Registers a new instance; refused when the FMU allows only one per process and one is
    /// alive (counted per `Fmu`, which is where the binary is loaded from).
    pub(crate) fn claim_instance(&self) -> Result<InstanceSlot, ImportError> {
        let live = &self.folder.live_instances;
        if self.co_simulation.can_be_instantiated_only_once_per_process == Some(true) {
            live.compare_exchange(0, 1, Ordering::SeqCst, Ordering::SeqCst).map_err(|_| ImportError::OnlyOncePerProcess)?;
        } else {
            live.fetch_add(1, Ordering::SeqCst);
        }
        Ok(InstanceSlot(Arc::clone(&self.folder)))
    }
}

/// Largest `modelDescription.xml` read (256 MiB; the largest FMUs we know have tens of MB).
pub const MAX_MODEL_DESCRIPTION_SIZE: u64 = 256 << 20;

/// Whether `id` can name a file in `binaries/<platform>/`: not empty, not `.`/`..`, no path
/// separator, NUL or control character. (FMI 2.0 wants a C identifier; this is what safety
/// needs, so unusual but harmless identifiers still load.)
fn is_file_stem(id: &str) -> bool {
    !id.is_empty() && id != "." && id != ".." && !id.chars().any(|c| c == '/' || c == '\\' || c.is_control())
}

/// `file://` URI of an absolute path, percent-encoding what RFC 3986 does not allow in a path.
fn file_uri(path: &Path) -> String {
    use std::os::unix::ffi::OsStrExt;
    let mut uri = String::from("file://");
    for &b in path.as_os_str().as_bytes() {
        if b.is_ascii_alphanumeric() || b"/-._~!$&'()*+,;=:@".contains(&b) {
            uri.push(char::from(b));
        } else {
            uri.push_str(&format!("%{b:02X}"));
        }
    }
    uri
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    const XML: &str = r#"<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{g}">
  <CoSimulation modelIdentifier="M" canBeInstantiatedOnlyOncePerProcess="true"/>
  <ModelVariables>
    <ScalarVariable name="u" valueReference="3" causality="input"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="n" valueReference="3" causality="parameter" variability="fixed"><Integer start="1"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="4" causality="output"><Real unit="V"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="3"/></Outputs></ModelStructure>
</fmiModelDescription>"#;

    fn dir_with(xml: &str) -> TempDir {
        let tmp = tempfile::tempdir().unwrap();
        fs::write(tmp.path().join("modelDescription.xml"), xml).unwrap();
        tmp
    }

    #[test]
    fn reads_description_without_binary_and_keeps_problems_as_warnings() {
        let tmp = dir_with(XML);
        let fmu = Fmu::from_dir(tmp.path()).unwrap();
        assert_eq!(fmu.model_identifier(), "M");
        assert_eq!(fmu.value_reference("u").unwrap(), (3, VarKind::Real));
        assert_eq!(fmu.value_reference("n").unwrap(), (3, VarKind::Integer));
        // unit "V" is not declared in UnitDefinitions: a warning, not an error.
        assert!(fmu.problems().iter().any(|p| p.contains("unit")), "{:?}", fmu.problems());
        assert!(fmu.binary_path().ends_with("binaries/linux64/M.so"));
        assert!(!fmu.is_pythonfmu());
    }

    #[test]
    fn unknown_variable_lists_the_variables() {
        let tmp = dir_with(XML);
        let err = Fmu::from_dir(tmp.path()).unwrap().value_reference("duty").unwrap_err();
        assert_eq!(err.to_string(), r#"the FMU has no variable "duty"; its variables are: u, n, y"#);
    }

    #[test]
    fn missing_cosimulation_and_wrong_version_are_errors() {
        let tmp = dir_with(&XML.replace(r#"<CoSimulation modelIdentifier="M" canBeInstantiatedOnlyOncePerProcess="true"/>"#, r#"<ModelExchange modelIdentifier="M"/>"#));
        let err = Fmu::from_dir(tmp.path()).unwrap_err();
        assert!(matches!(err, ImportError::NotCoSimulation { .. }), "{err}");
        assert!(err.to_string().contains("no CoSimulation element"), "{err}");

        let tmp = dir_with(&XML.replace(r#"fmiVersion="2.0""#, r#"fmiVersion="3.0""#));
        let err = Fmu::from_dir(tmp.path()).unwrap_err();
        assert!(err.to_string().contains(r#"fmiVersion is "3.0""#), "{err}");
    }

    #[test]
    fn missing_and_malformed_description_are_errors() {
        let tmp = tempfile::tempdir().unwrap();
        let err = Fmu::from_dir(tmp.path()).unwrap_err();
        assert!(matches!(err, ImportError::MissingModelDescription { .. }), "{err}");
        let tmp = dir_with("<fmiModelDescription fmiVersion=\"2.0\"");
        let err = Fmu::from_dir(tmp.path()).unwrap_err();
        assert!(matches!(err, ImportError::ModelDescription { .. }), "{err}");
        assert!(err.to_string().contains("modelDescription.xml"), "{err}");
    }

    #[test]
    fn only_once_per_process_is_enforced_and_released() {
        let tmp = dir_with(XML);
        let fmu = Fmu::from_dir(tmp.path()).unwrap();
        let first = fmu.claim_instance().unwrap();
        assert!(matches!(fmu.claim_instance(), Err(ImportError::OnlyOncePerProcess)));
        drop(first);
        assert!(fmu.claim_instance().is_ok());
    }

    #[test]
    fn resource_uri_is_a_file_uri_with_encoded_specials() {
        assert_eq!(file_uri(Path::new("/tmp/a b/résources")), "file:///tmp/a%20b/r%C3%A9sources");
        assert_eq!(file_uri(Path::new("/tmp/fmi2-import-x1/resources")), "file:///tmp/fmi2-import-x1/resources");
    }
}
