//! Signing a program into an image, and checking an image as a cell would.

use std::path::Path;

use ed25519_compact::KeyPair;
use skin_protocol::image::{self, Board, ImageHeader, MAGIC};

use super::{read, Error};

/// The image of `body` for `board` at `version`, signed with `key`
/// (see [`image::sign`]).
pub fn sign(body: &[u8], board: Board, version: u32, key: &KeyPair) -> Result<Vec<u8>, image::ImageError> {
    image::sign(body, board, version, &key.sk.seed())
}

/// Reads a program file and signs it; an empty file, or one that already is
/// an image, is refused.
pub fn sign_file(program: &Path, board: Board, version: u32, key: &KeyPair) -> Result<Vec<u8>, Error> {
    let body = read(program)?;
    let refuse = |reason| Error::BadProgram { path: program.into(), reason };
    if body.is_empty() {
        return Err(refuse("the program is empty"));
    }
    if body.starts_with(&MAGIC) {
        return Err(refuse("already a signed image; sign the program itself"));
    }
    sign(&body, board, version, key).map_err(|source| Error::Image { path: program.into(), source })
}

/// Checks an image file as a cell of `board` would, with no slot limit.
pub fn check_file(path: &Path, board: Board, key: &ed25519_compact::PublicKey) -> Result<ImageHeader, Error> {
    let bytes = read(path)?;
    image::verify(&bytes, board, u32::MAX, key).map_err(|source| Error::Image { path: path.into(), source })
}
