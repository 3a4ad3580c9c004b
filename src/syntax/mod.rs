//! The front end: source text to an AST whose every node knows where it came from.

mod actions;
pub mod ast;
pub mod diagnostic;
pub mod lexer;
pub mod parse;
pub mod span;

lalrpop_util::lalrpop_mod!(
    /// The LR(1) parser generated from `grammar/felt.lalrpop` by the build script. Generated
    /// code is not held to the project's lints.
    #[allow(clippy::all)]
    grammar,
    "/felt.rs"
);

pub use parse::{SyntaxError, is_incomplete, parse};

#[cfg(test)]
mod tests;
