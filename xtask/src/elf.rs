//! What the reports read from a firmware ELF, through the `object` crate:
//! section sizes (flash, static RAM), symbol addresses (the bench markers)
//! and the functions with their sizes (the per-function profile).

use std::collections::BTreeMap;
use std::path::Path;

use object::elf::{SHF_ALLOC, SHT_NOBITS};
use object::read::elf::{ElfFile32, FileHeader, SectionHeader};
use object::{Endianness, Object, ObjectSymbol, SymbolKind};

use crate::die;

/// One section header, the fields the reports use.
struct Section {
    name: String,
    /// `SHF_ALLOC`: occupies memory at run time.
    alloc: bool,
    /// `SHT_NOBITS`: no file contents (.bss, .uninit).
    nobits: bool,
    addr: u32,
    size: u32,
}

/// A firmware ELF (32-bit little-endian Arm).
pub(crate) struct Elf {
    sections: Vec<Section>,
    /// Symbol name -> address (Thumb bit included, as in the symbol table).
    pub(crate) symbols: BTreeMap<String, u32>,
    /// Defined functions: (start without the Thumb bit, size, demangled name), by address.
    pub(crate) functions: Vec<(u32, u32, String)>,
}

/// Reads `path`; ends xtask with a message if it is not a 32-bit ELF.
pub(crate) fn read_elf(path: &Path) -> Elf {
    let data = std::fs::read(path).unwrap_or_else(|e| die(&format!("{}: {e}", path.display())));
    let file = ElfFile32::<Endianness>::parse(&*data)
        .unwrap_or_else(|e| die(&format!("{}: not an ELF32 file: {e}", path.display())));
    let endian = file.endian();
    let headers = file
        .elf_header()
        .sections(endian, &*data)
        .unwrap_or_else(|e| die(&format!("{}: section headers: {e}", path.display())));
    let sections = headers
        .iter()
        .map(|h| Section {
            name: String::from_utf8_lossy(headers.section_name(endian, h).unwrap_or_default())
                .into_owned(),
            alloc: h.sh_flags(endian) & SHF_ALLOC != 0,
            nobits: h.sh_type(endian) == SHT_NOBITS,
            addr: h.sh_addr(endian),
            size: h.sh_size(endian),
        })
        .collect();
    let mut symbols = BTreeMap::new();
    let mut functions = Vec::new();
    for s in file.symbols() {
        let Ok(name) = s.name() else { continue };
        if name.is_empty() {
            continue;
        }
        symbols.insert(name.to_string(), s.address() as u32);
        if s.kind() == SymbolKind::Text && s.is_definition() && s.size() > 0 {
            functions.push((
                s.address() as u32 & !1,
                s.size() as u32,
                format!("{:#}", rustc_demangle::demangle(name)),
            ));
        }
    }
    functions.sort();
    Elf {
        sections,
        symbols,
        functions,
    }
}

impl Elf {
    /// Flash: allocated sections with file contents (code, rodata, .data's load image).
    pub(crate) fn flash(&self) -> u32 {
        self.sections
            .iter()
            .filter(|s| s.alloc && !s.nobits && s.size > 0)
            .map(|s| s.size)
            .sum()
    }

    /// Static RAM: allocated sections placed in SRAM or CCM (.data, .bss, .uninit).
    pub(crate) fn ram(&self) -> u32 {
        self.sections
            .iter()
            .filter(|s| s.alloc && (s.addr >> 28 == 2 || s.addr >> 28 == 1))
            .map(|s| s.size)
            .sum()
    }

    /// Total size of the sections called `name`.
    pub(crate) fn section(&self, name: &str) -> u32 {
        self.sections
            .iter()
            .filter(|s| s.name == name)
            .map(|s| s.size)
            .sum()
    }
}

/// Writes `data` into the `symbol`'s bytes of the ELF `image` (an object in a
/// section with file contents, e.g. a flash area the firmware reads) and zeroes
/// the rest of them: the image then runs with `data` as if it had been linked in.
pub(crate) fn fill_symbol(image: &mut [u8], symbol: &str, data: &[u8]) -> Result<(), String> {
    let file =
        ElfFile32::<Endianness>::parse(&*image).map_err(|e| format!("not an ELF32 file: {e}"))?;
    let endian = file.endian();
    let sym = file
        .symbols()
        .find(|s| s.name() == Ok(symbol))
        .ok_or_else(|| format!("no symbol {symbol}"))?;
    let (addr, size) = (sym.address() as u32, sym.size() as u32);
    if data.len() as u64 > u64::from(size) {
        return Err(format!("{} B do not fit {symbol} ({size} B)", data.len()));
    }
    let headers = file
        .elf_header()
        .sections(endian, &*image)
        .map_err(|e| format!("section headers: {e}"))?;
    let offset = headers
        .iter()
        .find(|h| {
            let (start, len) = (h.sh_addr(endian), h.sh_size(endian));
            h.sh_type(endian) != SHT_NOBITS
                && h.sh_flags(endian) & SHF_ALLOC != 0
                && start <= addr
                && addr.checked_add(size).is_some_and(|end| end <= start + len)
        })
        .map(|h| (h.sh_offset(endian) + (addr - h.sh_addr(endian))) as usize)
        .ok_or_else(|| format!("{symbol} lies in no section with file contents"))?;
    let area = image
        .get_mut(offset..offset + size as usize)
        .ok_or_else(|| format!("{symbol} lies past the end of the file"))?;
    area.fill(0);
    area[..data.len()].copy_from_slice(data);
    Ok(())
}
