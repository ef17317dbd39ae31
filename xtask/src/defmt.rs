//! Decoding the firmware's defmt stream in-process (the `defmt-decoder`
//! crate), so no separate `defmt-print` has to be installed: the QEMU runner
//! (firmware/qemu-run.sh) pipes the raw stream through `cargo xtask
//! defmt-decode <elf>` (or defmt-print, when run without xtask).
//!
//! Lines: a `println!` frame is its message; a logging frame is its level,
//! upper case and padded to five characters, a space and its message (as
//! defmt-print prints them by default, e.g. `ERROR golden ...`).

use std::io::{Read, Write};
use std::path::Path;

use defmt_decoder::{DecodeError, Table};

/// Decodes `raw` with the table of the ELF at `elf`, one line per frame.
pub(crate) fn decode(elf: &Path, raw: &[u8]) -> Result<String, String> {
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let table = Table::parse(&bytes)
        .map_err(|e| format!("{}: defmt table: {e}", elf.display()))?
        .ok_or_else(|| format!("{}: no defmt table (.defmt section)", elf.display()))?;
    let mut out = String::new();
    let mut stream = table.new_stream_decoder();
    stream.received(raw);
    loop {
        match stream.decode() {
            Ok(frame) => {
                let msg = frame.display_message().to_string();
                match frame.level() {
                    Some(level) => out += &format!("{:<5} {msg}\n", level.as_str().to_uppercase()),
                    None => {
                        out += &msg;
                        out.push('\n');
                    }
                }
            }
            Err(DecodeError::UnexpectedEof) => break,
            Err(DecodeError::Malformed) if table.encoding().can_recover() => {
                out += "(defmt: malformed frame skipped)\n";
            }
            Err(DecodeError::Malformed) => {
                out += "(defmt: malformed frame; the rest of the stream cannot be decoded)\n";
                break;
            }
        }
    }
    Ok(out)
}

/// `cargo xtask defmt-decode ELF`: stdin (raw defmt) -> stdout (lines).
pub(crate) fn decode_stdin(elf: &Path) -> i32 {
    let mut raw = Vec::new();
    if let Err(e) = std::io::stdin().read_to_end(&mut raw) {
        eprintln!("xtask defmt-decode: stdin: {e}");
        return 2;
    }
    match decode(elf, &raw) {
        Ok(text) => {
            let _ = std::io::stdout().write_all(text.as_bytes());
            0
        }
        Err(e) => {
            eprintln!("xtask defmt-decode: {e}");
            2
        }
    }
}
