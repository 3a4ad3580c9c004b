//! felt: a field expression language for volumetric effects.
//!
//! The path of data is one-way, and each arrow is a module boundary:
//! source text → `syntax` (lexer, parser, AST with spans) → `check` (types, names, arity; all
//! errors before anything runs) → `interp` (statements, functions, plain values; builds field
//! graphs) → `field` (hash-consed graphs compiled into batch programs) and `grid` (domains,
//! caches, files) → `render` (raymarcher, image writers). Downstream modules never reach back
//! upstream: the raymarcher knows fields, not syntax; the evaluator knows nodes, not statements.
//!
//! So a module names only its own layer and those below it. From the top: the command (`cli`,
//! `repl`, `doc`, `lsp`, `study`, `farm`, `sequence`); `session`; `interp`; `check`; `syntax`
//! and `diagnostic`; the producers and `render`; `field` and `grid`; `sample`, the vocabulary
//! they share; `engine` and `budget`; files and signals (`output`, `input`, `frames`,
//! `interrupt`, `usd`); `failure`. `tests/layers.rs` holds that order and fails on an import
//! that runs up it, besides the few it lists with their reasons.

// Block kernels index several parallel lane arrays with one counter; iterator chains over
// zipped slices would hide that and vectorise no better.
#![allow(clippy::needless_range_loop)]

pub mod budget;
pub mod check;
pub mod cloud;
pub mod diagnostic;
pub mod doc;
pub mod engine;
pub mod failure;
pub mod farm;
pub mod field;
pub mod frames;
pub mod geometry;
pub mod grid;
pub mod input;
pub mod interp;
pub mod interrupt;
pub mod lsp;
pub mod output;
pub mod particles;
pub mod paths;
pub mod provenance;
pub mod render;
pub mod repl;
pub mod sample;
pub mod sequence;
pub mod session;
pub mod study;
pub mod syntax;
#[cfg(test)]
mod test_random;
pub mod usd;
