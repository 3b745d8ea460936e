//! A firmware image's section headers and symbol table (the `object` crate reads the ELF32 of
//! the Cortex-M7 and RV32 images and the ELF64 of the Cortex-A53's).

use anyhow::{Context, Result, bail};

use object::{Object, ObjectSection, ObjectSymbol, SectionFlags, SectionKind};

/// One section header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Section {
    /// Name (`.text`, `.bss`, …).
    pub name: String,
    /// Run-time address.
    pub addr: u64,
    /// Size in bytes.
    pub size: u64,
    /// Occupies memory at run time (`SHF_ALLOC`).
    pub alloc: bool,
    /// Writable at run time.
    pub write: bool,
    /// Holds code.
    pub exec: bool,
    /// No bytes in the file (`.bss`-like, `SHT_NOBITS`).
    pub nobits: bool,
}

/// A parsed image: its sections and symbols.
#[derive(Debug, Clone)]
pub struct Elf {
    /// Every section header but the null one, in file order.
    pub sections: Vec<Section>,
    symbols: Vec<(String, u64)>,
}

/// `SHF_WRITE`, `SHF_ALLOC`, `SHF_EXECINSTR`.
const SHF_WRITE: u64 = 1;
const SHF_ALLOC: u64 = 2;
const SHF_EXECINSTR: u64 = 4;

impl Elf {
    /// Parses an ELF image (32- or 64-bit, little-endian: the Cortex-M7, RV32 and Cortex-A53
    /// images) with the `object` crate.
    pub fn parse(b: &[u8]) -> Result<Elf> {
        let file = object::File::parse(b).context("not an ELF image")?;
        if !matches!(file.format(), object::BinaryFormat::Elf) || !file.is_little_endian() {
            bail!("only little-endian ELF is supported");
        }
        let sections = file
            .sections()
            .map(|s| {
                let flags = match s.flags() {
                    SectionFlags::Elf { sh_flags } => sh_flags,
                    _ => 0,
                };
                Ok(Section {
                    name: s.name().context("bad ELF section name")?.to_string(),
                    addr: s.address(),
                    size: s.size(),
                    alloc: flags & SHF_ALLOC != 0,
                    write: flags & SHF_WRITE != 0,
                    exec: flags & SHF_EXECINSTR != 0,
                    nobits: matches!(
                        s.kind(),
                        SectionKind::UninitializedData | SectionKind::UninitializedTls
                    ),
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let symbols = file
            .symbols()
            .filter_map(|s| s.name().ok().filter(|n| !n.is_empty()).map(|n| (n.to_string(), s.address())))
            .collect();
        Ok(Elf { sections, symbols })
    }

    /// Reads and parses an image file.
    pub fn read(path: &std::path::Path) -> Result<Elf> {
        let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
        Elf::parse(&bytes).with_context(|| format!("cannot parse {}", path.display()))
    }

    /// The value (address) of a symbol; Thumb function symbols keep their low bit set.
    pub fn symbol(&self, name: &str) -> Option<u64> {
        self.symbols.iter().find(|(n, _)| n == name).map(|&(_, v)| v)
    }

    /// The sections that occupy memory at run time.
    pub fn alloc_sections(&self) -> impl Iterator<Item = &Section> {
        self.sections.iter().filter(|s| s.alloc && s.size > 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SHT_SYMTAB: u32 = 2;
    const SHT_NOBITS: u32 = 8;
    const ALLOC: u32 = SHF_ALLOC as u32;
    const WRITE: u32 = SHF_WRITE as u32;
    const EXEC: u32 = SHF_EXECINSTR as u32;

    /// A hand-assembled ELF32 LE: null section, `.text` (4 bytes at 0x100), `.bss` (NOBITS,
    /// 64 bytes at 0x2000_0000), `.symtab` with one symbol, `.strtab`, `.shstrtab`.
    fn tiny_elf() -> Vec<u8> {
        let shstr = b"\0.text\0.bss\0.symtab\0.strtab\0.shstrtab\0";
        let strtab = b"\0fw_region_begin\0";
        let text = [0u8, 0xBF, 0x70, 0x47];
        let mut f = vec![0u8; 52];
        f[..4].copy_from_slice(b"\x7fELF");
        f[4] = 1; // ELFCLASS32
        f[5] = 1; // little-endian
        f[6] = 1; // EV_CURRENT
        f[0x10..0x12].copy_from_slice(&2u16.to_le_bytes()); // ET_EXEC
        f[0x12..0x14].copy_from_slice(&40u16.to_le_bytes()); // EM_ARM
        f[0x14..0x18].copy_from_slice(&1u32.to_le_bytes());
        f[0x28..0x2A].copy_from_slice(&52u16.to_le_bytes()); // e_ehsize
        let text_off = f.len();
        f.extend_from_slice(&text);
        let sym_off = f.len();
        f.extend_from_slice(&[0u8; 16]); // null symbol
        let mut sym = [0u8; 16];
        sym[0..4].copy_from_slice(&1u32.to_le_bytes());
        sym[4..8].copy_from_slice(&0x101u32.to_le_bytes());
        f.extend_from_slice(&sym);
        let str_off = f.len();
        f.extend_from_slice(strtab);
        let shstr_off = f.len();
        f.extend_from_slice(shstr);
        while !f.len().is_multiple_of(4) {
            f.push(0);
        }
        let shoff = f.len();
        let mut sh = |name: u32, kind: u32, flags: u32, addr: u32, off: usize, size: usize, link: u32| {
            for v in [name, kind, flags, addr, off as u32, size as u32, link, 0, 4, 0] {
                f.extend_from_slice(&v.to_le_bytes());
            }
        };
        sh(0, 0, 0, 0, 0, 0, 0);
        sh(1, 1, ALLOC | EXEC, 0x100, text_off, 4, 0);
        sh(7, SHT_NOBITS, ALLOC | WRITE, 0x2000_0000, 0, 64, 0);
        sh(12, SHT_SYMTAB, 0, 0, sym_off, 32, 4);
        sh(20, 3, 0, 0, str_off, strtab.len(), 0);
        sh(28, 3, 0, 0, shstr_off, shstr.len(), 0);
        f[0x20..0x24].copy_from_slice(&(shoff as u32).to_le_bytes());
        f[0x2E..0x30].copy_from_slice(&40u16.to_le_bytes());
        f[0x30..0x32].copy_from_slice(&6u16.to_le_bytes());
        f[0x32..0x34].copy_from_slice(&5u16.to_le_bytes());
        f
    }

    #[test]
    fn reads_sections_and_symbols() -> Result<()> {
        let elf = Elf::parse(&tiny_elf())?;
        let names: Vec<_> = elf.alloc_sections().map(|s| s.name.as_str()).collect();
        assert_eq!(names, [".text", ".bss"]);
        let section = |n: &str| elf.sections.iter().find(|s| s.name == n).cloned();
        let bss = section(".bss").context(".bss")?;
        assert!(bss.nobits && bss.write && !bss.exec);
        assert_eq!((bss.addr, bss.size), (0x2000_0000, 64));
        assert!(section(".text").is_some_and(|t| t.exec && !t.nobits));
        assert_eq!(elf.symbol("fw_region_begin"), Some(0x101));
        assert_eq!(elf.symbol("missing"), None);
        Ok(())
    }

    #[test]
    fn rejects_other_formats() {
        let mut b = tiny_elf();
        b[4] = 2; // ELF64
        assert!(Elf::parse(&b).is_err());
        assert!(Elf::parse(b"MZ\0\0").is_err());
        let short = &tiny_elf()[..60];
        assert!(Elf::parse(short).is_err());
    }
}
