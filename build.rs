//! Sets `shared_generics` where rustc shares generic instances between
//! crates (`opt-level` 0, 1, `s` and `z`): the crate then compiles the
//! bank's steps for `f32` and `f64` itself, once for every crate that uses
//! them (see `operators::bank::instances`).

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rustc-check-cfg=cfg(shared_generics)");
    if matches!(
        std::env::var("OPT_LEVEL").as_deref(),
        Ok("0" | "1" | "s" | "z")
    ) {
        println!("cargo::rustc-cfg=shared_generics");
    }
}
