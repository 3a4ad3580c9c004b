//! Build script: generates the parser from `grammar/felt.lalrpop` into `OUT_DIR/felt.rs`.
//!
//! The grammar lives outside `src/`, so lalrpop's cargo conventions (which look in `src/`)
//! do not apply: the input and output directories are set explicitly.

fn main() {
    println!("cargo:rerun-if-changed=grammar/felt.lalrpop");
    println!("cargo:rerun-if-changed=build.rs");
    let out_dir = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR for build scripts");
    if let Err(error) = lalrpop::Configuration::new()
        .set_in_dir("grammar")
        .set_out_dir(out_dir)
        .process()
    {
        eprintln!("{error}");
        std::process::exit(1);
    }
}
