//! Puts the memory layout of each program of the board being built where
//! cortex-m-rt's `link.x` finds it: the workspace's `memory.x` (`INCLUDE
//! memory.x`) includes `board.x`, which is the cell program's layout for
//! `cell-BOARD`, the bootloader's for `boot-BOARD` and, on QEMU, the
//! layout at 0x0 for the examples that run without a bootloader. Each
//! program gets its own directory in the link path. Host builds need none.
//!
//! It also writes the update key every build trusts (`update_key.rs` in
//! `OUT_DIR`): the 32 bytes of `SKIN_UPDATE_KEY` (64 hex digits), or, when
//! it is not set, RFC 8032's TEST 1 public key, a development key whose
//! secret is published (the QEMU tests sign with it).

use std::path::{Path, PathBuf};

/// RFC 8032 section 7.1, TEST 1: the public key.
const DEVELOPMENT_KEY: &str = "d75a980182b10ab7d54bfed3c964073a0ee172f3daa62325af021a68f707511a";

fn main() {
    println!("cargo:rerun-if-changed=memory");
    println!("cargo:rerun-if-changed=../memory.x");
    println!("cargo:rerun-if-env-changed=SKIN_UPDATE_KEY");
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    update_key(&out);
    let boards = [("qemu", "CARGO_FEATURE_QEMU"), ("stm32f4", "CARGO_FEATURE_STM32F4")];
    let chosen: Vec<&str> = boards.iter().filter(|(_, var)| std::env::var_os(var).is_some()).map(|(b, _)| *b).collect();
    let board = match chosen.as_slice() {
        [] => return,
        [one] => *one,
        _ => panic!("features {chosen:?} name two boards: build one board at a time"),
    };
    // An older build script put one layout in OUT_DIR itself, which comes
    // first in the link path: left there, it would link every program at it.
    let _ = std::fs::remove_file(out.join("board.x"));
    std::fs::copy("../memory.x", out.join("memory.x")).expect("the workspace's memory.x exists");
    std::fs::copy("memory/stack.x", out.join("stack.x")).expect("the stack reserve check exists");
    println!("cargo:rustc-link-search={}", out.display());
    let layout = |name: &str| {
        let dir = out.join(name);
        std::fs::create_dir_all(&dir).expect("OUT_DIR is writable");
        std::fs::copy(format!("memory/{name}.x"), dir.join("board.x")).expect("the program's memory layout exists");
        dir
    };
    let cell = layout(board);
    println!("cargo:rustc-link-arg-bin=cell-{board}=-L{}", cell.display());
    let boot = layout(&format!("{board}-boot"));
    println!("cargo:rustc-link-arg-bin=boot-{board}=-L{}", boot.display());
    if board == "qemu" {
        let alone = layout("qemu-alone");
        println!("cargo:rustc-link-arg-examples=-L{}", alone.display());
    }
}

/// Writes the trusted public key as a Rust array expression.
fn update_key(out: &Path) {
    let hex = std::env::var("SKIN_UPDATE_KEY").unwrap_or_else(|_| DEVELOPMENT_KEY.to_owned());
    let hex = hex.trim();
    let bytes: Option<Vec<u8>> = (hex.len() == 64)
        .then(|| (0..32).map(|i| u8::from_str_radix(hex.get(2 * i..2 * i + 2)?, 16).ok()).collect())
        .flatten();
    let Some(bytes) = bytes else {
        panic!("SKIN_UPDATE_KEY must be the 32-byte ed25519 public key in 64 hex digits, got {hex:?}")
    };
    let list: Vec<String> = bytes.iter().map(|b| format!("{b:#04x}")).collect();
    std::fs::write(out.join("update_key.rs"), format!("[{}]\n", list.join(", "))).expect("OUT_DIR is writable");
}
