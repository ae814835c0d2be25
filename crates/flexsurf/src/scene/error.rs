//! Scene errors: [`SceneError`] names the file, the dotted key (`time.dt`, `obstacle[0].sphere.radius`) and what
//! is wrong; [`parse_toml`] reads TOML into a serde type and turns a parse error's byte span into a line, a
//! column and a key (through [`super::spans`], from the parser's own spans).

use super::spans;
use std::path::Path;
use thiserror::Error;

/// A scene that cannot be read or used. Each message names the file and the dotted key.
#[derive(Debug, Error)]
pub enum SceneError {
    /// The file cannot be read.
    #[error("{file}: cannot read the file")]
    Io {
        /// The file.
        file: String,
        /// Cause.
        source: std::io::Error,
    },
    /// Malformed TOML, an unknown key, a missing key, or a value of the wrong type or an unknown name.
    #[error("{file}:{line}:{column}: `{key}`: {message}")]
    Parse {
        /// The file.
        file: String,
        /// Line (1-based).
        line: usize,
        /// Column (1-based).
        column: usize,
        /// Dotted key path.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// An error inside a file the scene references (a material file): names the referencing file and key, then
    /// the error in the referenced file (whose key [`SceneError::key`] reports).
    #[error("{file}: `{key}`: in the file it names: {inner}")]
    Referenced {
        /// The referencing file.
        file: String,
        /// The referencing key (`material.file`).
        key: String,
        /// The error inside the referenced file.
        inner: Box<SceneError>,
    },
    /// A value that parses but cannot be used (non-finite, non-positive, out of range, inconsistent).
    #[error("{file}: `{key}`: {message}")]
    Invalid {
        /// The file.
        file: String,
        /// Dotted key path.
        key: String,
        /// What is wrong.
        message: String,
    },
}

/// A value that is valid but lies outside the usual range of fabrics (most often a unit slip): the file, the
/// dotted key and what is unusual (the value, unless it comes from a file other than the scene, and the usual
/// range in SI and KES-F units). A scene carries its warnings ([`super::Scene::warnings`]); front ends print
/// them.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{file}: `{key}`: {message}")]
pub struct SceneWarning {
    /// The file.
    pub file: String,
    /// Dotted key path.
    pub key: String,
    /// What is unusual.
    pub message: String,
}

impl SceneError {
    pub(crate) fn io(file: &Path, source: std::io::Error) -> Self {
        SceneError::Io { file: file.display().to_string(), source }
    }

    pub(crate) fn referenced(file: &Path, key: String, inner: SceneError) -> Self {
        SceneError::Referenced { file: file.display().to_string(), key, inner: Box::new(inner) }
    }

    pub(crate) fn invalid(file: &Path, key: String, message: String) -> Self {
        SceneError::Invalid { file: file.display().to_string(), key, message }
    }

    /// The dotted key the error is about (empty for an unreadable file).
    pub fn key(&self) -> &str {
        match self {
            SceneError::Io { .. } => "",
            SceneError::Parse { key, .. } | SceneError::Invalid { key, .. } => key,
            SceneError::Referenced { inner, .. } => inner.key(),
        }
    }
}

/// As [`parse_toml`] for a file other than a scene (a material file): the message loses the values it would
/// quote from the file ([`spans::sanitize`]).
pub(crate) fn parse_toml_foreign<T: serde::de::DeserializeOwned>(text: &str, file: &Path) -> Result<T, SceneError> {
    parse_toml(text, file).map_err(|e| match e {
        SceneError::Parse { file, line, column, key, message } => {
            SceneError::Parse { file, line, column, key, message: spans::sanitize(&message) }
        }
        other => other,
    })
}

/// Parses TOML text read from `file` into `T`, turning the error span into a line, a column and a key path.
pub(crate) fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, file: &Path) -> Result<T, SceneError> {
    toml::from_str(text).map_err(|e| {
        let (line, column, mut key, message) = spans::locate(text, &e);
        if key.is_empty() {
            key = "(top level)".to_string();
        }
        SceneError::Parse { file: file.display().to_string(), line, column, key, message }
    })
}
