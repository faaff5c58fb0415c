//! What the CPU is, as the kernel choice and the performance figures need
//! it: whether it runs 512-bit operations at full width, and its
//! description (vendor, family, model, the vector features used).

/// Whether this CPU executes a 512-bit operation at full width. AMD's
/// Zen 4 (family 25 with AVX-512F) splits each into two 256-bit halves:
/// there one compensator step's `f64` blocks of four (the AVX2 kernels)
/// are faster than blocks of eight (the same bits either way; measured in
/// the guide's performance chapter), while the bank's 8-lane blocks still
/// pay. Every other CPU with AVX-512F is taken to run it at full width.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline]
pub fn full_width_512() -> bool {
    use core::sync::atomic::{AtomicU8, Ordering};
    static FULL: AtomicU8 = AtomicU8::new(0);
    match FULL.load(Ordering::Relaxed) {
        1 => return false,
        2 => return true,
        _ => {}
    }
    // SAFETY: CPUID exists on every x86-64 CPU (a safe function in newer
    // Rust, unsafe in the MSRV's)
    #[allow(unused_unsafe)]
    let (vendor, signature) = unsafe {
        let v = core::arch::x86_64::__cpuid(0);
        ([v.ebx, v.edx, v.ecx], core::arch::x86_64::__cpuid(1).eax)
    };
    // "AuthenticAMD" as CPUID returns it, four bytes a register
    let amd = vendor == [0x6874_7541, 0x6974_6e65, 0x444d_4163];
    // the family as CPUID gives it: base plus extended where the base is 15
    let base = (signature >> 8) & 0xf;
    let family = if base == 0xf {
        base + ((signature >> 20) & 0xff)
    } else {
        base
    };
    let full = !(amd && family == 25);
    FULL.store(if full { 2 } else { 1 }, Ordering::Relaxed);
    full
}

/// The CPU as a performance figure must name it: vendor, family, model,
/// model name (from `/proc/cpuinfo` on Linux) and the vector features the
/// kernels use.
#[cfg(feature = "std")]
pub fn cpu_description() -> std::string::String {
    use std::string::String;
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |name: &str| -> String {
        info.lines()
            .find(|l| l.split(':').next().map(str::trim) == Some(name))
            .and_then(|l| l.split_once(':'))
            .map(|(_, v)| v.trim().into())
            .unwrap_or_else(|| "?".into())
    };
    #[allow(unused_mut)]
    let mut features: std::vec::Vec<&str> = std::vec::Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        for (name, has) in [
            ("avx2", std::is_x86_feature_detected!("avx2")),
            ("fma", std::is_x86_feature_detected!("fma")),
            ("avx512f", std::is_x86_feature_detected!("avx512f")),
        ] {
            if has {
                features.push(name);
            }
        }
    }
    std::format!(
        "{} ({}, family {}, model {}), {} logical CPUs, features [{}]",
        field("model name"),
        field("vendor_id"),
        field("cpu family"),
        field("model"),
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        features.join(", ")
    )
}
