//! `felt lsp`: a Language Server Protocol server over stdio, so a TD's editor shows felt's
//! errors as they type and offers the builtins, keywords and names of the script.
//!
//! The key decision: everything the server says about errors comes from the same front end
//! and checker as `felt check` (a [`Session`](crate::session::Session) loads the editor's
//! unsaved text as the file it names, imports resolved relative to it, and checks it), so the
//! editor and the command line never disagree. What the editor asks about a place in the text
//! (hover, completion, signature help, definition, symbols) is answered from the tokens of
//! the buffer (`outline`), not from a syntax tree, because the text being typed rarely
//! parses; the lexer never gives up, so a half-typed file still has an outline.
//!
//! Built on rust-analyzer's `lsp-server` (the message loop and JSON-RPC framing, MIT or
//! Apache-2.0, released with rust-analyzer) and `lsp-types` (the protocol's types, MIT). They
//! are synchronous and small: a request is answered on the thread that reads it, with no async
//! runtime to build or to reason about. `lsp-types` is held at 0.95, the version rust-analyzer
//! itself ships with, whose URIs convert to file paths.

mod completion;
mod definition;
mod diagnostics;
mod documents;
mod hover;
mod outline;
mod position;
mod server;
mod signature;

pub use server::serve;
