//! The front end: source text to an AST whose every node knows where it came from.

pub mod ast;
pub mod span;
