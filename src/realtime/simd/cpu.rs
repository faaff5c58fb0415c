//! What the CPU is, as the kernel choice and the performance figures need
//! it: whether its `f64` step is faster on 512-bit blocks, and its
//! description (vendor, family, model, the vector features used).

/// Whether one `f64` compensator step runs faster on the AVX-512 set's
/// 8-lane blocks than on the AVX2 set's blocks of four (the same bits
/// either way). A step is one dependent chain, so what decides is the
/// latency of each link at each width, measured per CPU (the guide's
/// performance chapter, `benches/peers/chain.c`):
/// - AMD Zen 5 (family 26): yes, by about 2.5 %;
/// - AMD Zen 4 (family 25) splits each 512-bit operation into two 256-bit
///   halves: the chain is 81 cycles on blocks of four, 83 on eight;
/// - Intel Sapphire Rapids adds 256-bit vectors in 2 cycles and 512-bit
///   ones in 4: 84 cycles against 104, the AVX-512 step 1.2 times slower.
///
/// Every other CPU with AVX-512F gets the blocks of four, whose chain was
/// never the longer one by more than Zen 5's 2.5 %. The hosts differ
/// more than that: one Zen 4 guest ran the AVX-512 step 8 % faster
/// (`benches/kernel_choice`), so on Zen 4 the choice is a wash. The bank's 8-lane
/// blocks pay on all of them (throughput, not latency, bounds a bank).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline]
pub fn f64_step_on_512() -> bool {
    use core::sync::atomic::{AtomicU8, Ordering};
    static ON_512: AtomicU8 = AtomicU8::new(0);
    match ON_512.load(Ordering::Relaxed) {
        1 => return false,
        2 => return true,
        _ => {}
    }
    let (amd, family) = vendor_is_amd_and_family();
    let on_512 = amd && family >= 26;
    ON_512.store(if on_512 { 2 } else { 1 }, Ordering::Relaxed);
    on_512
}

/// Whether CPUID names AMD, and the family it gives (base plus extended
/// where the base is 15), as `/proc/cpuinfo` reports them.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
pub(crate) fn vendor_is_amd_and_family() -> (bool, u32) {
    // SAFETY: CPUID exists on every x86-64 CPU (a safe function in newer
    // Rust, unsafe in the MSRV's)
    #[allow(unused_unsafe)]
    let (vendor, signature) = unsafe {
        let v = core::arch::x86_64::__cpuid(0);
        ([v.ebx, v.edx, v.ecx], core::arch::x86_64::__cpuid(1).eax)
    };
    // "AuthenticAMD" as CPUID returns it, four bytes a register
    let amd = vendor == [0x6874_7541, 0x6974_6e65, 0x444d_4163];
    let base = (signature >> 8) & 0xf;
    let family = if base == 0xf {
        base + ((signature >> 20) & 0xff)
    } else {
        base
    };
    (amd, family)
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
