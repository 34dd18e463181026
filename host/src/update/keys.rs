//! The update key pair: the secret key signs images on the robot PC (or a
//! build server), the public key is built into every cell. Both are
//! OpenSSL-compatible PEM files (PKCS#8 and SubjectPublicKeyInfo), so
//! `openssl pkeyutl` can sign and verify with them too.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use ed25519_compact::{KeyPair, PublicKey, Seed};
use rand::TryRngCore;

use super::{read, Error};

/// The public key file beside a secret key file: `KEY.pub`.
pub fn public_path(secret: &Path) -> PathBuf {
    let mut name = secret.as_os_str().to_owned();
    name.push(".pub");
    PathBuf::from(name)
}

/// Makes a new key pair from the operating system's randomness and writes
/// it to `secret` (readable by the owner only) and `KEY.pub`.
/// Returns the public key.
pub fn generate(secret: &Path, force: bool) -> Result<PublicKey, Error> {
    let public = public_path(secret);
    for path in [secret, &public] {
        if !force && path.exists() {
            return Err(Error::Exists(path.to_path_buf()));
        }
    }
    let mut seed = [0u8; Seed::BYTES];
    rand::rngs::OsRng.try_fill_bytes(&mut seed).map_err(|e| Error::Random(e.to_string()))?;
    let pair = KeyPair::try_from_seed(Seed::new(seed)).map_err(|e| Error::Random(e.to_string()))?;
    write_private(secret, pair.sk.to_pem().as_bytes())?;
    fs::write(&public, pair.pk.to_pem()).map_err(|source| Error::Write { path: public, source })?;
    Ok(pair.pk)
}

/// Creates (or truncates) `path` with owner-only permissions and writes `bytes`.
fn write_private(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    let mut options = fs::OpenOptions::new();
    options.write(true).create(true).truncate(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    let mut file = options.open(path).map_err(|source| Error::Write { path: path.into(), source })?;
    file.write_all(bytes).map_err(|source| Error::Write { path: path.into(), source })
}

/// Reads a secret key file.
pub fn load_secret(path: &Path) -> Result<KeyPair, Error> {
    let bad = |reason: String| Error::BadKey { path: path.into(), kind: "secret", reason };
    let text = String::from_utf8(read(path)?).map_err(|_| bad("not text".into()))?;
    KeyPair::from_pem(&text).map_err(|e| bad(e.to_string()))
}

/// Reads a public key file; weak and non-canonical keys are refused.
pub fn load_public(path: &Path) -> Result<PublicKey, Error> {
    let bad = |reason: String| Error::BadKey { path: path.into(), kind: "public", reason };
    let text = String::from_utf8(read(path)?).map_err(|_| bad("not text".into()))?;
    let key = PublicKey::from_pem(&text).map_err(|e| bad(e.to_string()))?;
    key.validate().map_err(|e| bad(e.to_string()))?;
    Ok(key)
}
