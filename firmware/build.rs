//! Puts the memory layout of the board being built where cortex-m-rt's
//! `link.x` finds it: the workspace's `memory.x` (`INCLUDE memory.x`), which
//! includes `board.x`, the chosen board's layout. Host builds need none.

use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=memory");
    println!("cargo:rerun-if-changed=../memory.x");
    let boards = [("qemu", "CARGO_FEATURE_QEMU"), ("stm32f4", "CARGO_FEATURE_STM32F4")];
    let chosen: Vec<&str> = boards.iter().filter(|(_, var)| std::env::var_os(var).is_some()).map(|(b, _)| *b).collect();
    let board = match chosen.as_slice() {
        [] => return,
        [one] => *one,
        _ => panic!("features {chosen:?} name two boards: build one board at a time"),
    };
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    std::fs::copy("../memory.x", out.join("memory.x")).expect("the workspace's memory.x exists");
    std::fs::copy(format!("memory/{board}.x"), out.join("board.x")).expect("the board's memory layout exists");
    std::fs::copy("memory/stack.x", out.join("stack.x")).expect("the stack reserve check exists");
    println!("cargo:rustc-link-search={}", out.display());
}
