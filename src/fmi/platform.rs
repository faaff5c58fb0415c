//! The platforms an FMU carries binaries for, with their folder names under
//! `binaries/`, and what a shared library's header says it was built for.
//!
//! FMI 3.0 names a folder by its platform tuple (`x86_64-linux`,
//! `x86_64-windows`, `aarch64-linux`, …). FMI 2.0 names six folders for
//! 32- and 64-bit x86 only (`win64`, `linux64`, `darwin64`, …); for any
//! other platform FMI 2.0.4 admits FMI 3.0's tuples, so the 64-bit ARM
//! binaries are under `aarch64-linux` (and `aarch64-darwin`) in both
//! versions.

use std::fmt;

/// A platform an FMU can hold a binary for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[non_exhaustive]
pub enum Platform {
    /// 64-bit x86 Linux.
    X86_64Linux,
    /// 64-bit x86 Windows.
    X86_64Windows,
    /// 64-bit ARM Linux.
    Aarch64Linux,
    /// 64-bit x86 macOS (built on a Mac: its SDK cannot be redistributed).
    X86_64Darwin,
    /// 64-bit ARM macOS (built on a Mac).
    Aarch64Darwin,
}

impl Platform {
    /// Every platform, in the order an FMU lists them.
    pub const ALL: [Platform; 5] = [
        Platform::X86_64Linux,
        Platform::X86_64Windows,
        Platform::Aarch64Linux,
        Platform::X86_64Darwin,
        Platform::Aarch64Darwin,
    ];

    /// The platforms this project builds and checks on one Linux machine.
    pub const BUILT_HERE: [Platform; 3] = [
        Platform::X86_64Linux,
        Platform::X86_64Windows,
        Platform::Aarch64Linux,
    ];

    /// The FMI 3.0 platform tuple, the name the command line takes.
    pub fn name(self) -> &'static str {
        match self {
            Platform::X86_64Linux => "x86_64-linux",
            Platform::X86_64Windows => "x86_64-windows",
            Platform::Aarch64Linux => "aarch64-linux",
            Platform::X86_64Darwin => "x86_64-darwin",
            Platform::Aarch64Darwin => "aarch64-darwin",
        }
    }

    /// The platform of a name: its FMI 3.0 tuple or its FMI 2.0 folder.
    pub fn from_name(name: &str) -> Option<Platform> {
        Self::ALL
            .into_iter()
            .find(|p| p.name() == name || p.folder(super::FmiVersion::Fmi2) == name)
    }

    /// The folder under `binaries/` in an FMU of `version`.
    pub fn folder(self, version: super::FmiVersion) -> &'static str {
        match (version, self) {
            (super::FmiVersion::Fmi2, Platform::X86_64Linux) => "linux64",
            (super::FmiVersion::Fmi2, Platform::X86_64Windows) => "win64",
            (super::FmiVersion::Fmi2, Platform::X86_64Darwin) => "darwin64",
            _ => self.name(),
        }
    }

    /// The extension of a shared library, with its dot.
    pub fn extension(self) -> &'static str {
        match self {
            Platform::X86_64Linux | Platform::Aarch64Linux => ".so",
            Platform::X86_64Windows => ".dll",
            Platform::X86_64Darwin | Platform::Aarch64Darwin => ".dylib",
        }
    }

    /// The Rust target that builds it.
    pub fn rust_target(self) -> &'static str {
        match self {
            Platform::X86_64Linux => "x86_64-unknown-linux-gnu",
            Platform::X86_64Windows => "x86_64-pc-windows-gnu",
            Platform::Aarch64Linux => "aarch64-unknown-linux-gnu",
            Platform::X86_64Darwin => "x86_64-apple-darwin",
            Platform::Aarch64Darwin => "aarch64-apple-darwin",
        }
    }

    /// The file name cargo gives the shared library `name` (a `cdylib`).
    pub fn library_file(self, name: &str) -> String {
        match self {
            Platform::X86_64Windows => format!("{name}.dll"),
            _ => format!("lib{name}{}", self.extension()),
        }
    }

    /// The platform this program runs on, if it is one of these.
    pub fn host() -> Option<Platform> {
        if cfg!(all(target_arch = "x86_64", target_os = "linux")) {
            Some(Platform::X86_64Linux)
        } else if cfg!(all(target_arch = "x86_64", target_os = "windows")) {
            Some(Platform::X86_64Windows)
        } else if cfg!(all(target_arch = "aarch64", target_os = "linux")) {
            Some(Platform::Aarch64Linux)
        } else if cfg!(all(target_arch = "x86_64", target_os = "macos")) {
            Some(Platform::X86_64Darwin)
        } else if cfg!(all(target_arch = "aarch64", target_os = "macos")) {
            Some(Platform::Aarch64Darwin)
        } else {
            None
        }
    }

    /// What a shared library's first bytes say it was built for: the
    /// object format (ELF, PE, Mach-O) and the machine in its header; what
    /// it is instead, for a file of none of these platforms.
    pub fn of_library(bytes: &[u8]) -> Result<Platform, String> {
        let u16_at = |i: usize| {
            bytes
                .get(i..i + 2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]))
        };
        let u32_at = |i: usize| {
            bytes
                .get(i..i + 4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        };
        if bytes.starts_with(b"\x7fELF") {
            // little-endian ELF: e_machine at 18
            return match (bytes.get(5), u16_at(18)) {
                (Some(1), Some(0x3e)) => Ok(Platform::X86_64Linux),
                (Some(1), Some(0xb7)) => Ok(Platform::Aarch64Linux),
                (_, Some(m)) => Err(format!(
                    "an ELF file for machine {m:#x}, neither x86-64 nor aarch64"
                )),
                _ => Err("a truncated ELF file".into()),
            };
        }
        if bytes.starts_with(b"MZ") {
            // the PE header's offset at 0x3c, its machine after "PE\0\0"
            let pe = u32_at(0x3c).map(|o| o as usize);
            return match pe.filter(|&o| bytes.get(o..o + 4) == Some(b"PE\0\0")) {
                Some(o) => match u16_at(o + 4) {
                    Some(0x8664) => Ok(Platform::X86_64Windows),
                    Some(m) => Err(format!("a Windows DLL for machine {m:#x}, not x86-64")),
                    None => Err("a truncated Windows DLL".into()),
                },
                None => Err("an MZ file without a PE header (not a Windows DLL)".into()),
            };
        }
        if u32_at(0) == Some(0xfeed_facf) {
            return match u32_at(4) {
                Some(0x0100_0007) => Ok(Platform::X86_64Darwin),
                Some(0x0100_000c) => Ok(Platform::Aarch64Darwin),
                Some(c) => Err(format!("a Mach-O file for CPU type {c:#x}")),
                None => Err("a truncated Mach-O file".into()),
            };
        }
        Err("not a shared library (no ELF, PE or Mach-O header)".into())
    }
}

/// The platform of a whole shared library, as [`Platform::of_library`]
/// reads it, after checking that every part its headers place in the file
/// (ELF: the program and section headers and each loaded segment; PE: the
/// section table and each section's data) lies inside it. A library cut
/// short would otherwise be mapped past its end by the loader, and the
/// process reading it dies (SIGBUS) instead of getting an error.
pub fn check_library(bytes: &[u8]) -> Result<Platform, String> {
    let platform = Platform::of_library(bytes)?;
    let len = bytes.len() as u64;
    let u16_at = |i: u64| -> Option<u64> {
        let i = usize::try_from(i).ok()?;
        bytes
            .get(i..i.checked_add(2)?)
            .map(|b| u16::from_le_bytes([b[0], b[1]]) as u64)
    };
    let u32_at = |i: u64| -> Option<u64> {
        let i = usize::try_from(i).ok()?;
        bytes
            .get(i..i.checked_add(4)?)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64)
    };
    let u64_at = |i: u64| -> Option<u64> {
        let i = usize::try_from(i).ok()?;
        let b = bytes.get(i..i.checked_add(8)?)?;
        Some(u64::from_le_bytes(b.try_into().ok()?))
    };
    let short = |what: &str, end: Option<u64>| -> Result<(), String> {
        match end {
            Some(end) if end <= len => Ok(()),
            _ => Err(format!(
                "cut short or corrupt: its {what} lies beyond its {len} bytes"
            )),
        }
    };
    match platform {
        Platform::X86_64Linux | Platform::Aarch64Linux => {
            if bytes.get(4) != Some(&2) {
                return Err("not a 64-bit ELF file".into());
            }
            let table = |offset: u64, size: u64, count: u64| {
                let (o, s, n) = (u64_at(offset)?, u16_at(size)?, u16_at(count)?);
                Some((o, s, n, o.checked_add(s.checked_mul(n)?)?))
            };
            let (phoff, phentsize, phnum, ph_end) =
                table(0x20, 0x36, 0x38).ok_or("a truncated ELF header")?;
            short("program header table", Some(ph_end))?;
            for k in 0..phnum {
                let h = phoff + k * phentsize;
                let loaded = u32_at(h) == Some(1);
                let end = u64_at(h + 8)
                    .zip(u64_at(h + 32))
                    .and_then(|(o, n)| o.checked_add(n));
                if loaded {
                    short(&format!("segment {k}"), end)?;
                }
            }
            let (shoff, _, _, sh_end) = table(0x28, 0x3a, 0x3c).ok_or("a truncated ELF header")?;
            if shoff != 0 {
                short("section header table", Some(sh_end))?;
            }
        }
        Platform::X86_64Windows => {
            let pe = u32_at(0x3c).ok_or("a truncated PE header")?;
            let sections = u16_at(pe + 6).ok_or("a truncated PE header")?;
            let optional = u16_at(pe + 20).ok_or("a truncated PE header")?;
            let table = pe + 24 + optional;
            short("section table", Some(table + 40 * sections))?;
            for k in 0..sections {
                let h = table + 40 * k;
                let end = u32_at(h + 20).zip(u32_at(h + 16)).map(|(o, n)| o + n);
                short(&format!("section {k}"), end)?;
            }
        }
        // not loaded on the machines this project runs its checks on
        Platform::X86_64Darwin | Platform::Aarch64Darwin => {}
    }
    Ok(platform)
}

impl fmt::Display for Platform {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fmi::FmiVersion;

    #[test]
    fn names_and_folders_are_the_standards() {
        let folders: Vec<_> = Platform::ALL
            .iter()
            .map(|p| (p.folder(FmiVersion::Fmi2), p.folder(FmiVersion::Fmi3)))
            .collect();
        assert_eq!(
            folders,
            [
                ("linux64", "x86_64-linux"),
                ("win64", "x86_64-windows"),
                ("aarch64-linux", "aarch64-linux"),
                ("darwin64", "x86_64-darwin"),
                ("aarch64-darwin", "aarch64-darwin"),
            ]
        );
        for p in Platform::ALL {
            assert_eq!(Platform::from_name(p.name()), Some(p));
            assert_eq!(Platform::from_name(p.folder(FmiVersion::Fmi2)), Some(p));
        }
        assert_eq!(Platform::from_name("win32"), None);
        assert_eq!(Platform::X86_64Windows.library_file("m"), "m.dll");
        assert_eq!(Platform::Aarch64Linux.library_file("m"), "libm.so");
        assert_eq!(Platform::Aarch64Darwin.library_file("m"), "libm.dylib");
    }

    #[test]
    fn headers_name_their_platform() {
        let mut elf = vec![0u8; 64];
        elf[..4].copy_from_slice(b"\x7fELF");
        elf[5] = 1;
        elf[18] = 0x3e;
        assert_eq!(Platform::of_library(&elf), Ok(Platform::X86_64Linux));
        elf[18] = 0xb7;
        assert_eq!(Platform::of_library(&elf), Ok(Platform::Aarch64Linux));
        elf[18] = 0x28; // 32-bit ARM
        assert!(Platform::of_library(&elf).unwrap_err().contains("0x28"));
        let mut pe = vec![0u8; 256];
        pe[..2].copy_from_slice(b"MZ");
        pe[0x3c] = 0x80;
        pe[0x80..0x84].copy_from_slice(b"PE\0\0");
        pe[0x84..0x86].copy_from_slice(&0x8664u16.to_le_bytes());
        assert_eq!(Platform::of_library(&pe), Ok(Platform::X86_64Windows));
        pe[0x3c] = 0xf0; // the header's offset points nowhere
        assert!(Platform::of_library(&pe).is_err());
        let mut macho = 0xfeed_facfu32.to_le_bytes().to_vec();
        macho.extend(0x0100_000cu32.to_le_bytes());
        assert_eq!(Platform::of_library(&macho), Ok(Platform::Aarch64Darwin));
        for junk in [&b""[..], b"\x7fEL", b"MZ", b"#!/bin/sh\n"] {
            assert!(Platform::of_library(junk).is_err(), "{junk:?}");
        }
    }

    /// An ELF file whose one loaded segment ends at `end`, in `len` bytes.
    fn elf(end: u64, len: usize) -> Vec<u8> {
        let mut b = vec![0u8; len.max(120)];
        b[..4].copy_from_slice(b"\x7fELF");
        b[4] = 2;
        b[5] = 1;
        b[18] = 0x3e;
        b[0x20..0x28].copy_from_slice(&64u64.to_le_bytes()); // e_phoff
        b[0x36..0x38].copy_from_slice(&56u16.to_le_bytes()); // e_phentsize
        b[0x38..0x3a].copy_from_slice(&1u16.to_le_bytes()); // e_phnum
        b[64..68].copy_from_slice(&1u32.to_le_bytes()); // PT_LOAD
        b[72..80].copy_from_slice(&0u64.to_le_bytes()); // p_offset
        b[96..104].copy_from_slice(&end.to_le_bytes()); // p_filesz
        b.truncate(len);
        b
    }

    #[test]
    fn a_library_cut_short_is_refused_before_it_is_loaded() {
        assert_eq!(check_library(&elf(4096, 4096)), Ok(Platform::X86_64Linux));
        let e = check_library(&elf(8192, 4096)).unwrap_err();
        assert!(e.contains("segment 0 lies beyond its 4096 bytes"), "{e}");
        // the program header table itself beyond the end
        let e = check_library(&elf(100, 100)).unwrap_err();
        assert!(e.contains("program header table"), "{e}");
        // offsets that overflow are refused, not wrapped
        let mut huge = elf(64, 4096);
        huge[72..80].copy_from_slice(&u64::MAX.to_le_bytes());
        assert!(check_library(&huge).is_err());
        // a PE section's data beyond the end
        let mut pe = vec![0u8; 512];
        pe[..2].copy_from_slice(b"MZ");
        pe[0x3c] = 0x80;
        pe[0x80..0x84].copy_from_slice(b"PE\0\0");
        pe[0x84..0x86].copy_from_slice(&0x8664u16.to_le_bytes());
        pe[0x86..0x88].copy_from_slice(&1u16.to_le_bytes()); // one section
        let section = 0x80 + 24;
        pe[section + 16..section + 20].copy_from_slice(&256u32.to_le_bytes());
        pe[section + 20..section + 24].copy_from_slice(&256u32.to_le_bytes());
        assert_eq!(check_library(&pe), Ok(Platform::X86_64Windows));
        pe[section + 16..section + 20].copy_from_slice(&257u32.to_le_bytes());
        assert!(check_library(&pe).unwrap_err().contains("section 0"));
    }
}
