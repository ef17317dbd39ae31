//! `gpecnet keygen`, `sign` and `verify`: Ed25519 keys and signed blobs.
// Doc comments here are the CLI --help text, where <name> placeholders are plain text.
#![allow(rustdoc::invalid_html_tags)]

use std::path::PathBuf;

use anyhow::Result;

#[derive(clap::Args, Debug)]
pub(crate) struct KeygenArgs {
    /// Folder for the two key files (created if missing).
    #[arg(long)]
    out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub(crate) struct SignArgs {
    /// The unsigned blob.
    #[arg(long)]
    blob: PathBuf,
    /// The private key file (gpecnet keygen).
    #[arg(long)]
    key: PathBuf,
    /// The model's release number: firmware refuses versions below the last it accepted.
    #[arg(long)]
    version: u32,
    /// The signed blob to write (a new file or a regular file; never the input).
    #[arg(long)]
    out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub(crate) struct VerifyArgs {
    /// The signed blob.
    #[arg(long)]
    blob: PathBuf,
    /// The public key file (gpecnet keygen).
    #[arg(long)]
    pubkey: PathBuf,
    /// Refuse versions below this one.
    #[arg(long, default_value_t = 0)]
    min_version: u32,
}

pub(crate) fn cmd_keygen(a: KeygenArgs) -> Result<()> {
    use gpecnet_trainer::signing;
    let (sk, pk, id) = signing::keygen(&a.out)?;
    println!("private key: {} (mode 0600; keep it secret)", sk.display());
    println!("public key:  {}", pk.display());
    println!("key id:      {}", signing::key_id_hex(&id));
    Ok(())
}

pub(crate) fn cmd_sign(a: SignArgs) -> Result<()> {
    use gpecnet_trainer::signing;
    let id = signing::sign_file(&a.blob, &a.key, a.version, &a.out)?;
    println!(
        "signed {} -> {} (key id {}, version {})",
        a.blob.display(),
        a.out.display(),
        signing::key_id_hex(&id),
        a.version
    );
    Ok(())
}

pub(crate) fn cmd_verify(a: VerifyArgs) -> Result<()> {
    use gpecnet_trainer::signing;
    let v = signing::verify_file(&a.blob, &a.pubkey, a.min_version)?;
    println!(
        "{}: signature ok: model {}, key id {}, version {}",
        a.blob.display(),
        v.name,
        signing::key_id_hex(&v.key_id),
        v.model_version
    );
    Ok(())
}
