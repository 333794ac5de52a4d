//! Reading parameter files: TOML read over the defaults (a key left out keeps its default at
//! every depth), YAML, unknown keys rejected, the result checked ([`super::Valid`]).

use serde::Serialize;
use serde::de::DeserializeOwned;
use thiserror::Error;

use super::{InvalidParam, Params, Valid};

/// A parameter file that could not be read.
#[derive(Debug, Error)]
pub enum ParamsError {
    /// Not valid TOML for the parameters (syntax, unknown key, wrong type).
    #[error("{source_name}: invalid TOML: {message}")]
    Toml {
        /// The source name (usually the file name) given to the parser.
        source_name: String,
        /// The parser's message, with the line when known.
        message: String,
    },
    /// Not valid YAML for the parameters.
    #[error("{source_name}: invalid YAML: {message}")]
    Yaml {
        /// The source name (usually the file name) given to the parser.
        source_name: String,
        /// The parser's message.
        message: String,
    },
    /// Parsed, but a value is out of range.
    #[error("{source_name}: {error}")]
    Invalid {
        /// The source name (usually the file name) given to the parser.
        source_name: String,
        /// The key and why it is wrong.
        error: InvalidParam,
    },
    /// The bytes are not UTF-8 text.
    #[error("{source_name}: not UTF-8 text")]
    NotUtf8 {
        /// The source name (usually the file name) given to the parser.
        source_name: String,
    },
    /// A key written where an older version of the file had it.
    #[error("{source_name}: `{key}` has moved: write it as `{moved_to}`")]
    Moved {
        /// The source name (usually the file name) given to the parser.
        source_name: String,
        /// The key as written.
        key: String,
        /// Where to write it now (e.g. `[explore] max_failed_decisions`).
        moved_to: String,
    },
}

/// A TOML error `e` of `text` in one line, "line N: message" (the crate's own Display draws a
/// multi-line caret).
pub(crate) fn toml_error_line(text: &str, e: &toml::de::Error) -> String {
    let line = e.span().map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
    let message = e.message().trim().replace('\n', " ");
    match line {
        Some(l) => format!("line {l}: {message}"),
        None => message,
    }
}

impl ParamsError {
    /// The TOML error `e` of `text`, from `source_name`.
    pub(crate) fn toml(text: &str, source_name: &str, e: &toml::de::Error) -> Self {
        ParamsError::Toml { source_name: source_name.into(), message: toml_error_line(text, e) }
    }
}

impl Params {
    /// Parses and checks TOML text; `source_name` (usually the file name) is quoted in errors.
    pub fn from_toml(text: &str, source_name: &str) -> Result<Valid<Self>, ParamsError> {
        let text = crate::io::without_bom_str(text);
        let p: Params = from_toml_over_default(text).map_err(|e| ParamsError::toml(text, source_name, &e))?;
        Valid::new(p).map_err(|error| ParamsError::Invalid { source_name: source_name.into(), error })
    }

    /// Parses and checks YAML text; `source_name` is quoted in errors.
    pub fn from_yaml(text: &str, source_name: &str) -> Result<Valid<Self>, ParamsError> {
        let text = crate::io::without_bom_str(text);
        let p: Params = serde_yaml::from_str(text)
            .map_err(|e| ParamsError::Yaml { source_name: source_name.into(), message: e.to_string().replace('\n', " ") })?;
        Valid::new(p).map_err(|error| ParamsError::Invalid { source_name: source_name.into(), error })
    }

    /// Parses TOML or YAML by the file name's extension (`.toml`, `.yaml`/`.yml`).
    pub fn from_bytes(bytes: &[u8], source_name: &str) -> Result<Valid<Self>, ParamsError> {
        let text = std::str::from_utf8(bytes).map_err(|_| ParamsError::NotUtf8 { source_name: source_name.into() })?;
        let lower = source_name.to_ascii_lowercase();
        if lower.ends_with(".yaml") || lower.ends_with(".yml") {
            Self::from_yaml(text, source_name)
        } else {
            Self::from_toml(text, source_name)
        }
    }
}

/// Deserialises TOML `text` over `T::default()`: every key the text leaves out keeps the
/// default's value, at every depth. serde's `default` alone fills the missing keys of a nested
/// table from the nested type's own `Default`, which is not what its parent chose where the two
/// differ (the SLAM front end's optimiser stops earlier than [`crate::slam::OptimizerParams`]'s
/// own default): a file restating one nested default would then change the others. A file the
/// merge refuses (a wrong type, an unknown key) is parsed once more straight into `T`, whose
/// error carries the position in `text`.
pub(crate) fn from_toml_over_default<T: Default + Serialize + DeserializeOwned>(text: &str) -> Result<T, toml::de::Error> {
    let text = crate::io::without_bom_str(text);
    let given: toml::Table = toml::from_str(text)?;
    let mut merged = toml::Table::try_from(T::default()).map_err(<toml::de::Error as serde::de::Error>::custom)?;
    merge_into(&mut merged, given);
    toml::Value::Table(merged).try_into().map_err(|e| toml::from_str::<T>(text).err().unwrap_or(e))
}

/// Overwrites `base` with `over`, descending into tables present in both.
fn merge_into(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge_into(b, o),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}
