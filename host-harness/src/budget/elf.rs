//! Just enough of 32-bit little-endian ELF to read a firmware image's section headers and
//! symbol table (both flight targets are ELF32 LE).

use anyhow::{Context, Result, bail};

const SHT_SYMTAB: u32 = 2;
const SHT_NOBITS: u32 = 8;
const SHF_WRITE: u32 = 1;
const SHF_ALLOC: u32 = 2;
const SHF_EXECINSTR: u32 = 4;

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
    /// Every section header, in file order.
    pub sections: Vec<Section>,
    symbols: Vec<(String, u64)>,
}

fn u16_at(b: &[u8], at: usize) -> Result<u16> {
    let s = b.get(at..at + 2).context("ELF truncated")?;
    Ok(u16::from_le_bytes([s[0], s[1]]))
}

fn u32_at(b: &[u8], at: usize) -> Result<u32> {
    let s = b.get(at..at + 4).context("ELF truncated")?;
    Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

fn c_str(b: &[u8], at: usize) -> Result<String> {
    let tail = b.get(at..).context("ELF string offset out of range")?;
    let end = tail.iter().position(|&c| c == 0).context("unterminated ELF string")?;
    Ok(String::from_utf8_lossy(&tail[..end]).into_owned())
}

struct RawSection {
    name_off: u32,
    kind: u32,
    flags: u32,
    addr: u32,
    offset: u32,
    size: u32,
    link: u32,
}

impl Elf {
    /// Parses an ELF32 little-endian image.
    pub fn parse(b: &[u8]) -> Result<Elf> {
        if b.get(..4) != Some(b"\x7fELF".as_slice()) {
            bail!("not an ELF file");
        }
        if b.get(4) != Some(&1) || b.get(5) != Some(&1) {
            bail!("only 32-bit little-endian ELF is supported");
        }
        let shoff = u32_at(b, 0x20)? as usize;
        let shentsize = usize::from(u16_at(b, 0x2E)?);
        let shnum = usize::from(u16_at(b, 0x30)?);
        let shstrndx = usize::from(u16_at(b, 0x32)?);
        if shentsize < 40 {
            bail!("bad ELF section header size {shentsize}");
        }
        let raw = (0..shnum)
            .map(|i| {
                let at = shoff + i * shentsize;
                Ok(RawSection {
                    name_off: u32_at(b, at)?,
                    kind: u32_at(b, at + 4)?,
                    flags: u32_at(b, at + 8)?,
                    addr: u32_at(b, at + 12)?,
                    offset: u32_at(b, at + 16)?,
                    size: u32_at(b, at + 20)?,
                    link: u32_at(b, at + 24)?,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let shstr = raw.get(shstrndx).context("ELF section-name table index out of range")?;
        let sections = raw
            .iter()
            .map(|s| {
                Ok(Section {
                    name: c_str(b, shstr.offset as usize + s.name_off as usize)?,
                    addr: u64::from(s.addr),
                    size: u64::from(s.size),
                    alloc: s.flags & SHF_ALLOC != 0,
                    write: s.flags & SHF_WRITE != 0,
                    exec: s.flags & SHF_EXECINSTR != 0,
                    nobits: s.kind == SHT_NOBITS,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let mut symbols = Vec::new();
        for s in raw.iter().filter(|s| s.kind == SHT_SYMTAB) {
            let strtab = raw.get(s.link as usize).context("ELF symbol string table out of range")?;
            for i in 0..(s.size / 16) as usize {
                let at = s.offset as usize + i * 16;
                let name = c_str(b, strtab.offset as usize + u32_at(b, at)? as usize)?;
                if !name.is_empty() {
                    symbols.push((name, u64::from(u32_at(b, at + 4)?)));
                }
            }
        }
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

    /// A hand-assembled ELF32 LE: null section, `.text` (4 bytes at 0x100), `.bss` (NOBITS,
    /// 64 bytes at 0x2000_0000), `.symtab` with one symbol, `.strtab`, `.shstrtab`.
    fn tiny_elf() -> Vec<u8> {
        let shstr = b"\0.text\0.bss\0.symtab\0.strtab\0.shstrtab\0";
        let strtab = b"\0fw_region_begin\0";
        let text = [0u8, 0xBF, 0x70, 0x47];
        let mut f = vec![0u8; 52];
        f[..4].copy_from_slice(b"\x7fELF");
        f[4] = 1;
        f[5] = 1;
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
        sh(1, 1, SHF_ALLOC | SHF_EXECINSTR, 0x100, text_off, 4, 0);
        sh(7, SHT_NOBITS, SHF_ALLOC | SHF_WRITE, 0x2000_0000, 0, 64, 0);
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
        let bss = &elf.sections[2];
        assert!(bss.nobits && bss.write && !bss.exec);
        assert_eq!((bss.addr, bss.size), (0x2000_0000, 64));
        assert!(elf.sections[1].exec);
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
