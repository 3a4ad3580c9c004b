//! The error type of the engine modules (fields, grids, rendering, geometry, file formats).
//! They know nothing of source text, so they report a `Failure`: a message in the script
//! author's terms and an optional hint. The interpreter attaches the span of the call that
//! failed and turns it into a diagnostic with the source line and the FELT call stack.

use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub struct Failure {
    pub message: String,
    pub help: Option<String>,
}

impl Failure {
    pub fn new(message: impl Into<String>) -> Failure {
        Failure {
            message: message.into(),
            help: None,
        }
    }

    pub fn with_help(mut self, help: impl Into<String>) -> Failure {
        self.help = Some(help.into());
        self
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Failure {}

impl From<std::io::Error> for Failure {
    fn from(e: std::io::Error) -> Failure {
        Failure::new(e.to_string())
    }
}

/// Shorthand for engine results.
pub type Outcome<T> = Result<T, Failure>;

/// `return Err(Failure::new(format!(...)))` in one line.
#[macro_export]
macro_rules! fail {
    ($($arg:tt)*) => {
        return Err($crate::failure::Failure::new(format!($($arg)*)))
    };
}
