//! A real editor as the client (opt-in with `FELT_PEER_TESTS=1`, skipped without `nvim`):
//! Neovim, headless, starts `felt lsp` for a copy of an example with an error typed into it,
//! waits for the diagnostic and writes what it shows to a file, which must say what `felt
//! check` says, where it says it.

use std::process::Command;

/// Starts the server for the current buffer (with `vim.lsp.start` where Neovim has it, 0.8
/// on; with `start_client` before), waits for diagnostics, writes them as `line:col:message`.
const CLIENT: &str = r#"
local felt, out = os.getenv("FELT_BIN"), os.getenv("FELT_OUT")
local config = { name = "felt", cmd = { felt, "lsp" }, root_dir = vim.fn.getcwd() }
if vim.lsp.start then
  vim.lsp.start(config)
else
  vim.lsp.buf_attach_client(0, vim.lsp.start_client(config))
end
vim.wait(30000, function() return #vim.diagnostic.get(0) > 0 end, 50)
local lines = {}
for _, d in ipairs(vim.diagnostic.get(0)) do
  local first = d.message:gsub("\n.*", "")
  table.insert(lines, string.format("%d:%d:%s", d.lnum + 1, d.col + 1, first))
end
vim.fn.writefile(lines, out)
vim.cmd("qall!")
"#;

#[test]
fn neovim_shows_the_error_felt_check_finds() {
    if std::env::var("FELT_PEER_TESTS").as_deref() != Ok("1") {
        eprintln!("skipped: set FELT_PEER_TESTS=1 to drive felt lsp from Neovim");
        return;
    }
    if Command::new("nvim").arg("--version").output().is_err() {
        eprintln!("skipped: nvim is not installed (apt-get install neovim)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let example = std::fs::read_to_string(root.join("examples/first_cloud.felt")).unwrap();
    // A typo TDs make: a keyword another renderer uses.
    let broken = example.replacen("kappa = ", "kapa = ", 1);
    assert_ne!(broken, example);
    let script = dir.path().join("first_cloud.felt");
    std::fs::write(&script, &broken).unwrap();
    let lua = dir.path().join("client.lua");
    std::fs::write(&lua, CLIENT).unwrap();
    let out = dir.path().join("diagnostics.txt");
    let status = Command::new("nvim")
        .args(["--headless", "--clean", "-n"])
        .arg(&script)
        .arg("-c")
        .arg(format!("luafile {}", lua.display()))
        .env("FELT_BIN", env!("CARGO_BIN_EXE_felt"))
        .env("FELT_OUT", &out)
        .current_dir(dir.path())
        .status()
        .unwrap();
    assert!(status.success(), "nvim exited with {status}");
    let shown = std::fs::read_to_string(&out).unwrap();

    let check = Command::new(env!("CARGO_BIN_EXE_felt"))
        .arg("check")
        .arg("first_cloud.felt")
        .current_dir(dir.path())
        .output()
        .unwrap();
    let printed = String::from_utf8_lossy(&check.stderr).into_owned();
    let message = printed
        .lines()
        .find_map(|l| l.trim_start().strip_prefix("× "))
        .unwrap();
    let place = printed
        .split("first_cloud.felt:")
        .nth(1)
        .and_then(|rest| rest.split(']').next())
        .unwrap();
    assert_eq!(
        shown.trim_end(),
        format!("{place}:{message}"),
        "felt check:\n{printed}"
    );
}
