//! What loading a scene file reports: errors that stop it and warnings
//! that do not, both located at a file, line and column. One type,
//! [`Diagnostic`], serves both; its severity is a type parameter, so an
//! error can never be passed where a warning is expected.

use std::marker::PhantomData;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::xml::Pos;

/// The severity of a [`Diagnostic`].
pub trait Severity: Clone + std::fmt::Debug {
    /// Printed between the location and the message ("" or "warning: ").
    const LABEL: &'static str;
}

/// Stops loading.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fatal;

/// Reported; loading goes on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Warn;

impl Severity for Fatal {
    const LABEL: &'static str = "";
}

impl Severity for Warn {
    const LABEL: &'static str = "warning: ";
}

/// The error that caused a diagnostic (an unreadable image, an invalid
/// camera, ...), kept for callers that walk `source()`.
pub type Cause = Arc<dyn std::error::Error + Send + Sync + 'static>;

/// A message about a place in a scene file.
#[derive(Clone, Debug)]
pub struct Diagnostic<S: Severity> {
    pub file: PathBuf,
    /// 1-based; 0 only if the problem has no place in the file.
    pub line: u32,
    pub col: u32,
    pub message: String,
    /// What caused it, if another error did: its `source()`, not part of
    /// its `Display` (print the chain with [`Diagnostic::report`] or
    /// anyhow's `{:#}`).
    pub cause: Option<Cause>,
    severity: PhantomData<S>,
}

/// A scene file that cannot be loaded: where, and why.
pub type SceneError = Diagnostic<Fatal>;

/// Something suspicious in a scene file that does not stop it loading.
pub type Warning = Diagnostic<Warn>;

impl<S: Severity> Diagnostic<S> {
    pub fn new(file: &Path, pos: Pos, message: impl Into<String>) -> Self {
        Diagnostic {
            file: file.to_path_buf(),
            line: pos.line,
            col: pos.col,
            message: message.into(),
            cause: None,
            severity: PhantomData,
        }
    }

    /// The same diagnostic, caused by `cause`.
    pub fn caused_by(mut self, cause: impl std::error::Error + Send + Sync + 'static) -> Self {
        self.cause = Some(Arc::new(cause));
        self
    }
}

impl<S: Severity> PartialEq for Diagnostic<S> {
    /// Same place, same words (causes are not compared).
    fn eq(&self, other: &Self) -> bool {
        (&self.file, self.line, self.col, &self.message)
            == (&other.file, other.line, other.col, &other.message)
    }
}

impl<S: Severity> Diagnostic<S> {
    /// The diagnostic and its chain of causes on one line:
    /// `file:line:col: [warning: ]message: cause: cause of the cause`.
    pub fn report(&self) -> String {
        let mut out = self.to_string();
        let mut next = std::error::Error::source(self);
        while let Some(c) = next {
            out.push_str(": ");
            out.push_str(&c.to_string());
            next = c.source();
        }
        out
    }
}

impl<S: Severity> std::fmt::Display for Diagnostic<S> {
    /// `file:line:col: [warning: ]message` (the cause is the `source()`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}{}",
            self.file.display(),
            self.line,
            self.col,
            S::LABEL,
            self.message
        )
    }
}

impl<S: Severity> std::error::Error for Diagnostic<S> {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.cause
            .as_ref()
            .map(|c| c.as_ref() as &(dyn std::error::Error + 'static))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("the lens is cracked")]
    struct Cracked;

    #[test]
    fn errors_and_warnings_print_their_place_and_cause() {
        let e =
            SceneError::new(Path::new("a.xml"), Pos::new(3, 7), "bad camera").caused_by(Cracked);
        assert_eq!(e.to_string(), "a.xml:3:7: bad camera");
        assert_eq!(e.report(), "a.xml:3:7: bad camera: the lens is cracked");
        let source = std::error::Error::source(&e).expect("the cause is kept");
        assert_eq!(source.to_string(), "the lens is cracked");
        let w = Warning::new(Path::new("a.xml"), Pos::new(1, 2), "odd");
        assert_eq!(w.to_string(), "a.xml:1:2: warning: odd");
        assert!(std::error::Error::source(&w).is_none());
    }
}
