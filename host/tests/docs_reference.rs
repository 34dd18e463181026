//! The book's generated reference pages equal what the program generates
//! now: a changed flag, help text or configuration key fails here until the
//! pages are written again (`SKIN_BLESS=1`, as the failure says).

use std::path::Path;
use std::process::Command;

use skin_host::reference::REGENERATE;

/// Compares the committed page with `skin reference <page>`, or writes it
/// when `SKIN_BLESS` is set.
fn check(page: &str) {
    let out = Command::new(env!("CARGO_BIN_EXE_skin")).args(["reference", page]).output().unwrap();
    assert!(out.status.success(), "skin reference {page}: {}", String::from_utf8_lossy(&out.stderr));
    let generated = String::from_utf8(out.stdout).unwrap();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../docs/src/reference/{page}.md"));
    if std::env::var_os("SKIN_BLESS").is_some() {
        std::fs::write(&path, &generated).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if committed != generated {
        let line = committed.lines().zip(generated.lines()).position(|(a, b)| a != b);
        let line = line.unwrap_or_else(|| committed.lines().count().min(generated.lines().count()));
        panic!(
            "{} differs from the generated reference from line {}: committed {:?}, generated {:?}.\n\
             Regenerate it with `{REGENERATE}` and commit it.",
            path.display(),
            line + 1,
            committed.lines().nth(line).unwrap_or("<end>"),
            generated.lines().nth(line).unwrap_or("<end>"),
        );
    }
}

#[test]
fn the_command_line_reference_is_the_generated_one() {
    check("cli");
}

#[test]
fn the_configuration_reference_is_the_generated_one() {
    check("config");
}
