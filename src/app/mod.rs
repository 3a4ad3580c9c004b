//! The felt command's tools: the REPL, `felt doc`, the language server, `felt study`, the farm
//! job writers and `felt run --frames`. They sit at the top of the layers: they drive a
//! session and may name anything below; nothing below names them. The command line itself
//! (`cli.rs`, `farm_command.rs`) belongs to the `felt` binary, which declares those two files
//! from here.

pub mod doc;
pub mod farm;
pub mod lsp;
pub mod repl;
pub mod sequence;
pub mod study;
