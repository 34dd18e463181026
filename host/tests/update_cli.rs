//! `skin keygen` and `skin sign` as a user runs them, and their files read
//! by a tool we did not write: OpenSSL reads the keys, verifies our
//! signatures and, Ed25519 being deterministic, signs to the same bytes.

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::free_addr;
use skin_protocol::image::{self, Board, HEADER_LEN, SIGNED_LEN};

fn skin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_skin")).args(args).output().expect("the skin binary runs")
}

fn ok(args: &[&str]) -> String {
    let out = skin(args);
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Asserts a failure whose whole stderr is one line starting `error: {says}`.
fn refused(args: &[&str], says: &str) {
    let out = skin(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
    assert!(err.starts_with(&format!("error: {says}")), "{args:?}: {err}");
}

/// A fresh folder of this test's own.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("skin-update-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn openssl(args: &[&str]) -> Output {
    Command::new("openssl").args(args).output().expect("openssl is installed (cargo xtask install)")
}

#[test]
fn keygen_sign_check_round_trip_and_refusals() {
    let dir = scratch("roundtrip");
    let key = dir.join("update.key");
    let program = dir.join("cell.bin");
    fs::write(&program, (0..3000u32).map(|i| (i % 251) as u8).collect::<Vec<_>>()).unwrap();
    ok(&["keygen", "--out", s(&key)]);
    #[cfg(unix)]
    assert_eq!(std::os::unix::fs::PermissionsExt::mode(&fs::metadata(&key).unwrap().permissions()) & 0o077, 0);
    refused(&["keygen", "--out", s(&key)], &format!("{} exists; pass --force", key.display()));

    let said = ok(&["sign", s(&program), "--key", s(&key), "--version", "7"]);
    let signed = dir.join("cell.skfw");
    assert!(said.contains("version 7 for mps2-an386"), "{said}");
    let public = dir.join("update.key.pub");
    let checked = ok(&["sign", "--check", s(&signed), "--key", s(&public)]);
    assert!(checked.contains("valid image, version 7 for mps2-an386, body 3000 bytes"), "{checked}");

    refused(
        &["sign", "--check", s(&signed), "--key", s(&public), "--board", "stm32f405"],
        &format!("{}: image is for board mps2-an386, this is stm32f405", signed.display()),
    );
    refused(
        &["sign", s(&signed), "--key", s(&key), "--version", "8"],
        &format!("{}: already a signed image", signed.display()),
    );
    refused(
        &["sign", s(&program), "--key", s(&public), "--version", "8"],
        &format!("{} is not an ed25519 secret key", public.display()),
    );
    refused(
        &["sign", "--check", s(&signed), "--key", s(&key)],
        &format!("{} is not an ed25519 public key", key.display()),
    );
    let missing = dir.join("nope.key");
    refused(
        &["sign", s(&program), "--key", s(&missing), "--version", "8"],
        &format!("cannot read {}", missing.display()),
    );
    let out = skin(&["sign", s(&program), "--key", s(&key), "--version", "8", "--board", "esp32"]);
    assert_eq!(out.status.code(), Some(2), "clap's usage error");
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown board \"esp32\"; one of mps2-an386, stm32f405"));

    let mut bytes = fs::read(&signed).unwrap();
    let truncated = dir.join("truncated.skfw");
    fs::write(&truncated, &bytes[..bytes.len() - 1]).unwrap();
    refused(
        &["sign", "--check", s(&truncated), "--key", s(&public)],
        &format!("{}: image body is 2999 bytes, its header says 3000", truncated.display()),
    );
    bytes[SIGNED_LEN] ^= 1;
    let tampered = dir.join("tampered.skfw");
    fs::write(&tampered, &bytes).unwrap();
    refused(
        &["sign", "--check", s(&tampered), "--key", s(&public)],
        &format!("{}: image signature does not verify", tampered.display()),
    );
    // Another key's public half refuses the genuine image.
    let other = dir.join("other.key");
    ok(&["keygen", "--out", s(&other)]);
    refused(
        &["sign", "--check", s(&signed), "--key", &format!("{}.pub", other.display())],
        &format!("{}: image signature does not verify", signed.display()),
    );
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn openssl_reads_our_keys_verifies_our_signature_and_signs_the_same_bytes() {
    let dir = scratch("openssl");
    let key = dir.join("update.key");
    let public = dir.join("update.key.pub");
    let program = dir.join("cell.bin");
    fs::write(&program, b"a program of the cell, as objcopy would write it".repeat(40)).unwrap();
    ok(&["keygen", "--out", s(&key)]);
    ok(&["sign", s(&program), "--key", s(&key), "--version", "3", "--board", "stm32f405"]);
    let image = fs::read(dir.join("cell.skfw")).unwrap();
    let header = image::ImageHeader::parse(&image).unwrap();
    assert_eq!((header.board, header.version), (Board::Stm32f405, 3));

    // What the signature covers: the signed header fields, the body by its SHA-256.
    let message = dir.join("signed.bin");
    fs::write(&message, &image[..SIGNED_LEN]).unwrap();
    let digest = openssl(&["dgst", "-sha256", "-binary", s(&program)]);
    assert_eq!(digest.stdout, header.body_sha256, "OpenSSL's SHA-256 of the body is the signed one");
    let signature = dir.join("sig.bin");
    fs::write(&signature, &image[SIGNED_LEN..HEADER_LEN]).unwrap();

    // OpenSSL derives the same public key from our secret key file.
    let derived = openssl(&["pkey", "-in", s(&key), "-pubout"]);
    assert!(derived.status.success(), "{}", String::from_utf8_lossy(&derived.stderr));
    assert_eq!(String::from_utf8_lossy(&derived.stdout), fs::read_to_string(&public).unwrap());

    let verify = |sig: &Path| {
        openssl(&[
            "pkeyutl",
            "-verify",
            "-pubin",
            "-inkey",
            s(&public),
            "-rawin",
            "-in",
            s(&message),
            "-sigfile",
            s(sig),
        ])
    };
    let verified = verify(&signature);
    assert!(verified.status.success(), "{}", String::from_utf8_lossy(&verified.stderr));
    let mut bad = image[SIGNED_LEN..HEADER_LEN].to_vec();
    bad[5] ^= 0x10;
    let bad_sig = dir.join("bad.bin");
    fs::write(&bad_sig, &bad).unwrap();
    assert!(!verify(&bad_sig).status.success(), "OpenSSL must refuse a changed signature");

    let theirs = dir.join("theirs.bin");
    let signed = openssl(&["pkeyutl", "-sign", "-inkey", s(&key), "-rawin", "-in", s(&message), "-out", s(&theirs)]);
    assert!(signed.status.success(), "{}", String::from_utf8_lossy(&signed.stderr));
    assert_eq!(fs::read(&theirs).unwrap(), &image[SIGNED_LEN..HEADER_LEN]);

    // A key OpenSSL made signs images our check accepts.
    let their_key = dir.join("openssl.key");
    assert!(openssl(&["genpkey", "-algorithm", "ed25519", "-out", s(&their_key)]).status.success());
    let their_pub = dir.join("openssl.key.pub");
    assert!(openssl(&["pkey", "-in", s(&their_key), "-pubout", "-out", s(&their_pub)]).status.success());
    let out = dir.join("by-openssl-key.skfw");
    ok(&["sign", s(&program), "--key", s(&their_key), "--version", "4", "--out", s(&out)]);
    ok(&["sign", "--check", s(&out), "--key", s(&their_pub)]);
    fs::remove_dir_all(&dir).unwrap();
}

/// Starts `skin sim-endpoint` (real time, cells that trust `public`) with
/// the host side at `host`; returns the child once it announced itself.
fn endpoint(public: &Path, host: &str, seconds: &str) -> std::process::Child {
    use std::io::BufRead;
    let mut child = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["sim-endpoint", "--pace", "realtime", "--robot", "127.0.0.1:0", "--host", host, "--duration", seconds])
        .args(["--update-key", s(public)])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("the skin binary runs");
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    assert!(line.starts_with("serving"), "{line}");
    child
}

/// `skin flash` against the simulated HRP-2 skin served on UDP in real
/// time: every cell updated; a forged image refused by every cell, exit 1.
/// Ignored: about 15 s of wall time, and it needs the release build's speed
/// (`cargo test --release -p skin-host --test update_cli -- --ignored`).
#[test]
#[ignore]
fn skin_flash_updates_the_simulated_skin_and_a_forged_image_is_refused_everywhere() {
    let dir = scratch("flash");
    let (key, other) = (dir.join("update.key"), dir.join("other.key"));
    let program = dir.join("cell.bin");
    fs::write(&program, (0..37_364u32).map(|i| (i * 7 % 253) as u8).collect::<Vec<_>>()).unwrap();
    ok(&["keygen", "--out", s(&key)]);
    ok(&["keygen", "--out", s(&other)]);
    let (good, forged) = (dir.join("good.skfw"), dir.join("forged.skfw"));
    ok(&["sign", s(&program), "--key", s(&key), "--version", "2", "--out", s(&good)]);
    ok(&["sign", s(&program), "--key", s(&other), "--version", "2", "--out", s(&forged)]);
    let public = dir.join("update.key.pub");
    for (image, exit, summary) in
        [(&good, 0, "74 cells: 74 updated"), (&forged, 1, "74 cells: 74 refused: bad signature")]
    {
        let host = free_addr();
        let mut served = endpoint(&public, &host, "40");
        let out = skin(&["flash", "--image", s(image), "--interface", &host, "--cells", "74", "--timeout", "30"]);
        let _ = served.kill();
        let _ = served.wait();
        let text = String::from_utf8_lossy(&out.stdout);
        assert_eq!(out.status.code(), Some(exit), "{text}{}", String::from_utf8_lossy(&out.stderr));
        assert!(text.lines().last().is_some_and(|l| l.starts_with(summary)), "{text}");
        println!("{}", text.lines().last().unwrap_or_default());
    }
    fs::remove_dir_all(&dir).unwrap();
}
