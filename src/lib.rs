//! felt: a field expression language for volumetric effects.
//!
//! The path of data is one-way, and each folder is a layer that names only its own layer and
//! those below it. From the top: `app` (the command's tools: REPL, `felt doc`, the language
//! server, `felt study`, farm jobs, frame sequences) and `session` (the standard library
//! loaded, scripts checked and run); `interp` (statements, values, builtins, paths and
//! provenance); `check` (types, names, arity: every error before anything runs); `syntax`
//! (lexer, parser, AST with spans, diagnostics); the producers and the renderer (`render`,
//! `particles`, `cloud`, `geometry`, `fluids`); `field` (hash-consed graphs compiled into batch
//! programs); `grid` (caches and grid files); `space`, the sampling vocabulary they share
//! (domains, demand, the traits producers and consumers meet at); `engine` (the run's context:
//! budget, profile, pools, interrupts); `io` (files in and out, frame patterns); `base` (the
//! failure type). `tests/layers.rs` holds that order and fails on an import that runs up it,
//! besides the few it lists with their reasons.

// Block kernels index several parallel lane arrays with one counter; iterator chains over
// zipped slices would hide that and vectorise no better.
#![allow(clippy::needless_range_loop)]

pub mod app;
pub mod base;
pub mod check;
pub mod cloud;
pub mod engine;
pub mod field;
pub mod fluids;
pub mod geometry;
pub mod grid;
pub mod interp;
pub mod io;
pub mod particles;
pub mod render;
pub mod session;
pub mod space;
pub mod syntax;
