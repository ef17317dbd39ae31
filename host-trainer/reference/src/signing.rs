//! Signed blobs on the host: `gpecnet keygen`, `gpecnet sign`, `gpecnet
//! verify` (the trailer is specified in `gpecnet_core::blob::signed` and
//! `weights/FORMAT.md`).
//!
//! Key files are hex text: the private key file holds the 32-byte Ed25519
//! seed after the line [`PRIVATE_KEY_TAG`] (created with mode 0600, never
//! printed, never overwritten, nothing left behind if keygen fails), the
//! public key file the 32-byte public key alone (64 hex digits, what the
//! firmware build and the C examples read). Each key is refused in the other
//! role: a tagged private key as a public key; as a private key, a `.pub`
//! file, a file that holds a public key next to it (`<stem>.pub` or
//! [`PUBLIC_KEY_FILE`] in its folder), and a private key that the group or
//! others may read (`chmod 600`). A private key file written before the tag
//! (64 hex digits alone) is still accepted under those checks. `sign` writes
//! a new file, never over its input, its sidecars or the key, and checks
//! its own output with the verifier before it is in place.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use ed25519_dalek::{Signer, SigningKey};
use gpecnet_core::blob::signed::{self, trailer_head, SignError, TrustedKey};
use gpecnet_core::Model;

use crate::inpath::{read_limited, read_text_limited, FileKind, ReadError};
use crate::outpath::{check_output, OutputError};

/// The file names `keygen` writes into its folder.
pub const PRIVATE_KEY_FILE: &str = "gpecnet-signing.key";
/// The public half.
pub const PUBLIC_KEY_FILE: &str = "gpecnet-signing.pub";
/// The first line of a private key file: what it is, so it is never taken for a public key
/// (nor a public key for it).
pub const PRIVATE_KEY_TAG: &str = "gpecnet-ed25519-private-key";

/// The role a key file is read in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeyRole {
    /// The private key that signs (`sign --key`, `--sign-key`).
    Private,
    /// The public key that verifies (`verify --pubkey`).
    Public,
}

impl std::fmt::Display for KeyRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            KeyRole::Private => "private (signing)",
            KeyRole::Public => "public (verifying)",
        })
    }
}

/// Why a signing command failed.
#[derive(Debug, thiserror::Error)]
pub enum SigningError {
    /// A file could not be read.
    #[error(transparent)]
    Read(#[from] ReadError),
    /// The output may not be written there.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A key file is not 64 hex digits (32 bytes).
    #[error("{path}: not a key file (want 64 hex digits, the 32-byte key)")]
    BadKeyFile {
        /// The file.
        path: PathBuf,
    },
    /// A key file given in the wrong role (a public key to sign with, a private key to
    /// verify with).
    #[error("{path}: {why}; a {role} key was expected (gpecnet keygen writes {PRIVATE_KEY_FILE} and {PUBLIC_KEY_FILE})")]
    WrongRole {
        /// The file.
        path: PathBuf,
        /// The role it was given in.
        role: KeyRole,
        /// What it is instead.
        why: String,
    },
    /// A private key file that the group or others may read.
    #[error("{path}: a private key readable by others (mode {mode:04o}); refusing to sign with it. Make it private: chmod 600 {path}")]
    KeyNotPrivate {
        /// The file.
        path: PathBuf,
        /// Its permission bits.
        mode: u32,
    },
    /// keygen would overwrite a key.
    #[error("{path} exists: keygen never overwrites a key (choose another --out folder)")]
    KeyExists {
        /// The file.
        path: PathBuf,
    },
    /// The blob to sign is not a valid blob.
    #[error("{path}: not a valid blob: {source}")]
    BadBlob {
        /// The file.
        path: PathBuf,
        /// Why.
        source: gpecnet_core::BlobError,
    },
    /// The blob to sign is signed already.
    #[error("{path} is signed already: sign the unsigned blob (its first {len} bytes)")]
    AlreadySigned {
        /// The file.
        path: PathBuf,
        /// Bytes of the unsigned blob inside.
        len: usize,
    },
    /// Verification refused the blob.
    #[error("{path}: {source}")]
    Refused {
        /// The file.
        path: PathBuf,
        /// The typed refusal.
        source: SignError,
    },
    /// The operating system gave no randomness.
    #[error("no randomness from the operating system: {0}")]
    Random(String),
    /// Writing failed.
    #[error("{what}: {source}")]
    Io {
        /// What was being written.
        what: String,
        /// The error.
        source: std::io::Error,
    },
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// A key file's text: whether it carries [`PRIVATE_KEY_TAG`], and its 32-byte key.
fn parse_key(path: &Path, text: &str) -> Result<(bool, [u8; 32]), SigningError> {
    let bad = || SigningError::BadKeyFile {
        path: path.to_path_buf(),
    };
    let t = text.trim();
    let (tagged, t) = match t.strip_prefix(PRIVATE_KEY_TAG) {
        Some(rest) => (true, rest.trim()),
        None => (false, t),
    };
    if t.len() != 64 || !t.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(bad());
    }
    let mut key = [0u8; 32];
    for (i, k) in key.iter_mut().enumerate() {
        *k = u8::from_str_radix(&t[2 * i..2 * i + 2], 16).map_err(|_| bad())?;
    }
    Ok((tagged, key))
}

/// The public keys next to `path` (its `<stem>.pub` and [`PUBLIC_KEY_FILE`] in its folder)
/// that parse as key files, with their paths.
fn public_keys_beside(path: &Path) -> Vec<(PathBuf, [u8; 32])> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut out: Vec<(PathBuf, [u8; 32])> = Vec::new();
    for p in [path.with_extension("pub"), dir.join(PUBLIC_KEY_FILE)] {
        if out.iter().any(|(q, _)| *q == p) {
            continue;
        }
        let Ok(text) = read_text_limited(&p, FileKind::Text) else {
            continue;
        };
        if let Ok((false, key)) = parse_key(&p, &text) {
            out.push((p, key));
        }
    }
    out
}

/// The 32-byte key of the key file `path`, read in `role` (see the module documentation:
/// a key in the other role, or a private key others may read, is refused).
fn read_key(path: &Path, role: KeyRole) -> Result<[u8; 32], SigningError> {
    let text = read_text_limited(path, FileKind::Text)?;
    let (tagged, key) = parse_key(path, &text)?;
    let wrong = |why: String| SigningError::WrongRole {
        path: path.to_path_buf(),
        role,
        why,
    };
    match role {
        KeyRole::Public => {
            if tagged {
                return Err(wrong(format!(
                    "this is a private key (its first line is {PRIVATE_KEY_TAG})"
                )));
            }
            // An untagged (older) private key: its public half is the key file beside it.
            let public = SigningKey::from_bytes(&key).verifying_key().to_bytes();
            for (p, beside) in public_keys_beside(path) {
                if beside == public && p != path {
                    return Err(wrong(format!("this is the private key of {}", p.display())));
                }
            }
        }
        KeyRole::Private => {
            if !tagged {
                if path.extension().is_some_and(|e| e == "pub") {
                    return Err(wrong("this is a public key file (.pub)".into()));
                }
                for (p, public) in public_keys_beside(path) {
                    if public == key {
                        return Err(wrong(format!(
                            "this holds the public key of {}",
                            p.display()
                        )));
                    }
                }
            }
            check_private_mode(path)?;
        }
    }
    Ok(key)
}

/// Refuses a private key file that the group or others may read or write.
fn check_private_mode(path: &Path) -> Result<(), SigningError> {
    use std::os::unix::fs::PermissionsExt;
    let mode = fs::metadata(path)
        .map_err(|source| SigningError::Io {
            what: format!("reading the permissions of {}", path.display()),
            source,
        })?
        .permissions()
        .mode()
        & 0o7777;
    if mode & 0o077 != 0 {
        return Err(SigningError::KeyNotPrivate {
            path: path.to_path_buf(),
            mode,
        });
    }
    Ok(())
}

/// The public key in a public key file, as a trusted key (a private key file is refused).
pub fn read_public_key(path: &Path) -> Result<TrustedKey, SigningError> {
    Ok(TrustedKey::new(read_key(path, KeyRole::Public)?))
}

/// Creates `path` with `text`, failing if it exists; `private`: mode 0600.
fn create_new(path: &Path, text: &str, private: bool) -> Result<(), SigningError> {
    let mut o = fs::OpenOptions::new();
    o.write(true).create_new(true);
    if private {
        use std::os::unix::fs::OpenOptionsExt;
        o.mode(0o600);
    }
    let mut f = o.open(path).map_err(|source| {
        if source.kind() == std::io::ErrorKind::AlreadyExists {
            SigningError::KeyExists {
                path: path.to_path_buf(),
            }
        } else {
            SigningError::Io {
                what: format!("creating {}", path.display()),
                source,
            }
        }
    })?;
    let written = f.write_all(text.as_bytes()).and_then(|()| f.sync_all());
    if let Err(source) = written {
        // Nothing half-written is left to block the next keygen.
        drop(f);
        let _ = fs::remove_file(path);
        return Err(SigningError::Io {
            what: format!("writing {}", path.display()),
            source,
        });
    }
    Ok(())
}

/// `gpecnet keygen --out DIR`: a new key pair; returns (private, public) paths
/// and the key id. Neither file may exist.
pub fn keygen(dir: &Path) -> Result<(PathBuf, PathBuf, [u8; 8]), SigningError> {
    fs::create_dir_all(dir).map_err(|source| SigningError::Io {
        what: format!("creating {}", dir.display()),
        source,
    })?;
    let (sk_path, pk_path) = (dir.join(PRIVATE_KEY_FILE), dir.join(PUBLIC_KEY_FILE));
    for p in [&sk_path, &pk_path] {
        if fs::symlink_metadata(p).is_ok() {
            return Err(SigningError::KeyExists { path: p.clone() });
        }
    }
    let mut seed = [0u8; 32];
    getrandom::fill(&mut seed).map_err(|e| SigningError::Random(e.to_string()))?;
    let sk = SigningKey::from_bytes(&seed);
    let pk = sk.verifying_key().to_bytes();
    create_new(
        &sk_path,
        &format!("{PRIVATE_KEY_TAG}\n{}\n", hex(&seed)),
        true,
    )?;
    if let Err(e) = create_new(&pk_path, &format!("{}\n", hex(&pk)), false) {
        // A private key without its public half is no use: keygen leaves both or neither.
        let _ = fs::remove_file(&sk_path);
        return Err(e);
    }
    Ok((sk_path, pk_path, TrustedKey::new(pk).id()))
}

/// `blob` (an unsigned blob) signed with the 32-byte `seed` at `version`.
pub fn sign_bytes(blob: &[u8], seed: &[u8; 32], version: u32) -> Vec<u8> {
    let sk = SigningKey::from_bytes(seed);
    let id = TrustedKey::new(sk.verifying_key().to_bytes()).id();
    let mut out = Vec::with_capacity(blob.len() + signed::TRAILER_LEN);
    out.extend_from_slice(blob);
    out.extend_from_slice(&trailer_head(id, version));
    let sig = sk.sign(&out).to_bytes();
    out.extend_from_slice(&sig);
    out
}

/// A key and a version to sign with as a blob is written (`gpecnet export` and
/// `gpecnet quantize` with `--sign-key K --sign-version V`).
#[derive(Clone)]
pub struct SignSpec {
    seed: [u8; 32],
    version: u32,
}

impl std::fmt::Debug for SignSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Never print the private key.
        write!(f, "SignSpec {{ version: {} }}", self.version)
    }
}

impl SignSpec {
    /// The private key in `key` (a keygen file, refused in the wrong role) and `version`.
    pub fn load(key: &Path, version: u32) -> Result<Self, SigningError> {
        Ok(SignSpec {
            seed: read_key(key, KeyRole::Private)?,
            version,
        })
    }

    /// `blob` signed, checked with the verifier before it is returned.
    pub fn sign(&self, blob: &[u8]) -> Result<Vec<u8>, SigningError> {
        let signed_bytes = sign_bytes(blob, &self.seed, self.version);
        let key = TrustedKey::new(
            SigningKey::from_bytes(&self.seed)
                .verifying_key()
                .to_bytes(),
        );
        Model::from_signed_blob(&signed_bytes, &[key], self.version).map_err(|source| {
            SigningError::Refused {
                path: PathBuf::from("(the blob being written)"),
                source,
            }
        })?;
        Ok(signed_bytes)
    }
}

/// `gpecnet sign --blob B --key K --version V --out O`: writes the signed
/// blob to `out` (never over `blob`, its sidecars or the key), verified before it is in
/// place; returns the key id.
pub fn sign_file(
    blob: &Path,
    key: &Path,
    version: u32,
    out: &Path,
) -> Result<[u8; 8], SigningError> {
    // Never over the blob, its golden file or cards, nor the key.
    let sidecars = crate::outpath::blob_and_sidecars(blob);
    let mut inputs: Vec<&Path> = sidecars.iter().map(PathBuf::as_path).collect();
    inputs.extend([blob, key]);
    check_output("--out", out, &inputs, &[])?;
    let bytes = read_limited(blob, FileKind::Blob)?;
    if let Some((inner, _, _)) = signed::split(&bytes) {
        if Model::from_blob(inner).is_ok() {
            return Err(SigningError::AlreadySigned {
                path: blob.to_path_buf(),
                len: inner.len(),
            });
        }
    }
    Model::from_blob(&bytes).map_err(|source| SigningError::BadBlob {
        path: blob.to_path_buf(),
        source,
    })?;
    let seed = read_key(key, KeyRole::Private)?;
    let signed_bytes = sign_bytes(&bytes, &seed, version);
    let trusted = TrustedKey::new(SigningKey::from_bytes(&seed).verifying_key().to_bytes());
    Model::from_signed_blob(&signed_bytes, &[trusted], version).map_err(|source| {
        SigningError::Refused {
            path: out.to_path_buf(),
            source,
        }
    })?;
    crate::rundir::write_atomic(out, &signed_bytes).map_err(|source| SigningError::Io {
        what: format!("writing {}", out.display()),
        source,
    })?;
    Ok(trusted.id())
}

/// What `gpecnet verify` found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Verified {
    /// The model's name.
    pub name: String,
    /// The key id that signed it.
    pub key_id: [u8; 8],
    /// Its `model_version`.
    pub model_version: u32,
}

/// `gpecnet verify --blob B --pubkey P [--min-version N]`.
pub fn verify_file(blob: &Path, pubkey: &Path, min_version: u32) -> Result<Verified, SigningError> {
    let key = read_public_key(pubkey)?;
    let bytes = read_limited(blob, FileKind::Blob)?;
    let (m, model_version) =
        Model::from_signed_blob(&bytes, &[key], min_version).map_err(|source| {
            SigningError::Refused {
                path: blob.to_path_buf(),
                source,
            }
        })?;
    Ok(Verified {
        name: m.name().to_string(),
        key_id: key.id(),
        model_version,
    })
}

/// A key id as printed: 16 hex digits.
pub fn key_id_hex(id: &[u8; 8]) -> String {
    hex(id)
}
