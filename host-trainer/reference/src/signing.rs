//! Signed blobs on the host: `gpecnet keygen`, `gpecnet sign`, `gpecnet
//! verify` (the trailer is specified in `gpecnet_core::blob::signed` and
//! `weights/FORMAT.md`).
//!
//! Key files are hex text: the private key file holds the 32-byte Ed25519
//! seed (created with mode 0600, never printed, never overwritten), the
//! public key file the 32-byte public key. `sign` writes a new file, never
//! over its input, and checks its own output with the verifier before it
//! is in place.

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

/// A 32-byte key from a hex key file.
fn read_key(path: &Path) -> Result<[u8; 32], SigningError> {
    let text = read_text_limited(path, FileKind::Text)?;
    let t = text.trim();
    let bad = || SigningError::BadKeyFile {
        path: path.to_path_buf(),
    };
    if t.len() != 64 || !t.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(bad());
    }
    let mut key = [0u8; 32];
    for (i, k) in key.iter_mut().enumerate() {
        *k = u8::from_str_radix(&t[2 * i..2 * i + 2], 16).map_err(|_| bad())?;
    }
    Ok(key)
}

/// The public key in a public key file, as a trusted key.
pub fn read_public_key(path: &Path) -> Result<TrustedKey, SigningError> {
    Ok(TrustedKey::new(read_key(path)?))
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
    f.write_all(text.as_bytes())
        .and_then(|()| f.sync_all())
        .map_err(|source| SigningError::Io {
            what: format!("writing {}", path.display()),
            source,
        })
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
    create_new(&sk_path, &format!("{}\n", hex(&seed)), true)?;
    create_new(&pk_path, &format!("{}\n", hex(&pk)), false)?;
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
    /// The private key in `key` (a keygen file) and `version`.
    pub fn load(key: &Path, version: u32) -> Result<Self, SigningError> {
        Ok(SignSpec {
            seed: read_key(key)?,
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
/// blob to `out` (never over `blob` or the key), verified before it is in
/// place; returns the key id.
pub fn sign_file(
    blob: &Path,
    key: &Path,
    version: u32,
    out: &Path,
) -> Result<[u8; 8], SigningError> {
    check_output("--out", out, &[blob, key], &[])?;
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
    let seed = read_key(key)?;
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
