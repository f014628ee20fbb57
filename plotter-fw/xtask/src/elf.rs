//! Just enough of ELF32 (little-endian, as the ARM toolchain writes it) to cut a flat `.bin` out of a firmware
//! image and to count its flash and RAM: the program headers (what the loader writes where) and the section
//! headers (what each part is). Field offsets are those of the System V ABI's ELF32 header, program header and
//! section header.

use anyhow::{Context as _, bail, ensure};

/// `PT_LOAD`: a segment the loader places in memory.
const PT_LOAD: u32 = 1;
/// `SHT_NOBITS`: a section that occupies memory but no file bytes (`.bss`, `.uninit`).
const SHT_NOBITS: u32 = 8;
/// `SHF_ALLOC`: the section occupies memory at run time.
const SHF_ALLOC: u32 = 2;

/// A loadable segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Segment {
    /// Load (physical) address: where the bytes sit in flash.
    pub(crate) paddr: u32,
    /// File offset of the bytes.
    pub(crate) offset: u32,
    /// Bytes in the file.
    pub(crate) filesz: u32,
}

/// An allocated section.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Section {
    /// Name (`.text`, `.data`, ...).
    pub(crate) name: String,
    /// Run-time address.
    pub(crate) addr: u32,
    /// Size, bytes.
    pub(crate) size: u32,
    /// Whether it has bytes in the image (false for `.bss`-like sections).
    pub(crate) has_bits: bool,
}

/// A parsed image.
#[derive(Debug, Clone)]
pub(crate) struct Elf<'a> {
    data: &'a [u8],
    /// Loadable segments with file bytes.
    pub(crate) segments: Vec<Segment>,
    /// Allocated sections.
    pub(crate) sections: Vec<Section>,
}

fn u16_at(d: &[u8], at: usize) -> anyhow::Result<u16> {
    let b = d.get(at..at + 2).context("ELF file cut short")?;
    Ok(u16::from_le_bytes([b[0], b[1]]))
}

fn u32_at(d: &[u8], at: usize) -> anyhow::Result<u32> {
    let b = d.get(at..at + 4).context("ELF file cut short")?;
    Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

fn usize_at(d: &[u8], at: usize) -> anyhow::Result<usize> {
    Ok(usize::try_from(u32_at(d, at)?)?)
}

impl<'a> Elf<'a> {
    /// Parse `data`.
    pub(crate) fn parse(data: &'a [u8]) -> anyhow::Result<Self> {
        ensure!(data.get(..4) == Some(b"\x7fELF"), "not an ELF file");
        ensure!(data.get(4) == Some(&1) && data.get(5) == Some(&1), "not a 32-bit little-endian ELF file");
        let phoff = usize_at(data, 28)?;
        let shoff = usize_at(data, 32)?;
        let phentsize = usize::from(u16_at(data, 42)?);
        let phnum = usize::from(u16_at(data, 44)?);
        let shentsize = usize::from(u16_at(data, 46)?);
        let shnum = usize::from(u16_at(data, 48)?);
        let shstrndx = usize::from(u16_at(data, 50)?);
        let mut segments = Vec::new();
        for i in 0..phnum {
            let at = phoff + i * phentsize;
            if u32_at(data, at)? != PT_LOAD {
                continue;
            }
            let seg = Segment {
                offset: u32_at(data, at + 4)?,
                paddr: u32_at(data, at + 12)?,
                filesz: u32_at(data, at + 16)?,
            };
            if seg.filesz > 0 {
                segments.push(seg);
            }
        }
        let strtab_off = usize_at(data, shoff + shstrndx * shentsize + 16)?;
        let mut sections = Vec::new();
        for i in 0..shnum {
            let at = shoff + i * shentsize;
            let flags = u32_at(data, at + 8)?;
            if flags & SHF_ALLOC == 0 {
                continue;
            }
            let name_at = strtab_off + usize_at(data, at)?;
            let name_bytes = data.get(name_at..).context("section name out of the file")?;
            let end = name_bytes.iter().position(|&b| b == 0).context("unterminated section name")?;
            sections.push(Section {
                name: String::from_utf8_lossy(&name_bytes[..end]).into_owned(),
                addr: u32_at(data, at + 12)?,
                size: u32_at(data, at + 20)?,
                has_bits: u32_at(data, at + 4)? != SHT_NOBITS,
            });
        }
        Ok(Elf { data, segments, sections })
    }

    /// The flat binary a flasher writes from `base` (the flash start): every loadable segment below
    /// `ram_start` at its load address, gaps filled with 0xFF (erased flash).
    pub(crate) fn flat_binary(&self, base: u32, ram_start: u32) -> anyhow::Result<Vec<u8>> {
        let flash: Vec<&Segment> = self.segments.iter().filter(|s| s.paddr >= base && s.paddr < ram_start).collect();
        let Some(end) = flash.iter().map(|s| s.paddr + s.filesz).max() else { bail!("no loadable segment in flash") };
        let mut out = vec![0xFF; usize::try_from(end - base)?];
        for s in flash {
            let from = usize::try_from(s.offset)?;
            let bytes = self.data.get(from..from + usize::try_from(s.filesz)?).context("segment out of the file")?;
            let at = usize::try_from(s.paddr - base)?;
            out[at..at + bytes.len()].copy_from_slice(bytes);
        }
        Ok(out)
    }

    /// Flash use: every allocated section with bytes (code, constants, the initial values of `.data`).
    pub(crate) fn flash_bytes(&self) -> u64 {
        self.sections.iter().filter(|s| s.has_bits).map(|s| u64::from(s.size)).sum()
    }

    /// Static RAM use: every allocated section at or above `ram_start` (`.data`, `.bss`, `.uninit`).
    pub(crate) fn ram_bytes(&self, ram_start: u32) -> u64 {
        self.sections.iter().filter(|s| s.addr >= ram_start).map(|s| u64::from(s.size)).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-assembled ELF32 image: two PT_LOAD segments (code at 0x0800_0000, data initialisers at
    /// 0x0800_0010 for 0x2000_0000) and sections `.text`, `.data`, `.bss` plus the name table.
    fn tiny() -> Vec<u8> {
        let mut f = vec![0u8; 0x240];
        f[..4].copy_from_slice(b"\x7fELF");
        f[4] = 1;
        f[5] = 1;
        let put32 = |f: &mut Vec<u8>, at: usize, v: u32| f[at..at + 4].copy_from_slice(&v.to_le_bytes());
        let put16 = |f: &mut Vec<u8>, at: usize, v: u16| f[at..at + 2].copy_from_slice(&v.to_le_bytes());
        put32(&mut f, 28, 0x40); // phoff
        put32(&mut f, 32, 0x100); // shoff
        put16(&mut f, 42, 32);
        put16(&mut f, 44, 2);
        put16(&mut f, 46, 40);
        put16(&mut f, 48, 5);
        put16(&mut f, 50, 4); // shstrndx
        // PT_LOAD code: 8 bytes at file 0x80 → 0x0800_0000.
        for (i, (off, paddr, size)) in [(0x80u32, 0x0800_0000u32, 8u32), (0x90, 0x0800_0010, 4)].iter().enumerate() {
            let at = 0x40 + i * 32;
            put32(&mut f, at, PT_LOAD);
            put32(&mut f, at + 4, *off);
            put32(&mut f, at + 12, *paddr);
            put32(&mut f, at + 16, *size);
        }
        f[0x80..0x88].copy_from_slice(&[1, 2, 3, 4, 5, 6, 7, 8]);
        f[0x90..0x94].copy_from_slice(&[9, 9, 9, 9]);
        let names = b"\0.text\0.data\0.bss\0.shstrtab\0";
        f[0x1D0..0x1D0 + names.len()].copy_from_slice(names);
        // Sections: null, .text, .data, .bss, .shstrtab.
        let sec = |f: &mut Vec<u8>, i: usize, name: u32, ty: u32, flags: u32, addr: u32, off: u32, size: u32| {
            let at = 0x100 + i * 40;
            put32(f, at, name);
            put32(f, at + 4, ty);
            put32(f, at + 8, flags);
            put32(f, at + 12, addr);
            put32(f, at + 16, off);
            put32(f, at + 20, size);
        };
        sec(&mut f, 1, 1, 1, SHF_ALLOC | 4, 0x0800_0000, 0x80, 8);
        sec(&mut f, 2, 7, 1, SHF_ALLOC | 1, 0x2000_0000, 0x90, 4);
        sec(&mut f, 3, 13, SHT_NOBITS, SHF_ALLOC | 1, 0x2000_0004, 0, 100);
        sec(&mut f, 4, 18, 3, 0, 0, 0x1D0, u32::try_from(names.len()).unwrap());
        f
    }

    #[test]
    fn flat_binary_places_segments_and_fills_gaps() {
        let f = tiny();
        let e = Elf::parse(&f).unwrap();
        let bin = e.flat_binary(0x0800_0000, 0x2000_0000).unwrap();
        assert_eq!(bin, [1, 2, 3, 4, 5, 6, 7, 8, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 9, 9, 9, 9]);
    }

    #[test]
    fn sizes_count_code_data_and_bss() {
        let f = tiny();
        let e = Elf::parse(&f).unwrap();
        let names: Vec<&str> = e.sections.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, [".text", ".data", ".bss"]);
        // Flash: .text 8 + .data's initial values 4. RAM: .data 4 + .bss 100.
        assert_eq!(e.flash_bytes(), 12);
        assert_eq!(e.ram_bytes(0x2000_0000), 104);
    }

    #[test]
    fn not_an_elf_is_an_error() {
        assert!(Elf::parse(b"hello world, this is not an ELF").is_err());
        let mut f = tiny();
        f.truncate(0x60);
        assert!(Elf::parse(&f).is_err());
    }
}
