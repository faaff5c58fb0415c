//! The C side of the library, from C: `examples/c/api_errors.c` feeds the
//! API malformed JSON, inadmissible parameters and NULL or uninitialised
//! handles; `examples/c/mfcbeam_run.c`, linked against `libmfcbeam.a`,
//! follows the file contract and goes through `mfcbeam conform` as a model
//! and as a compensator, in `f64` (heap handles) and in `f32`
//! (caller-owned storage, tolerances scaled by `ε₃₂/ε₆₄ = 2²⁹`);
//! `examples/c/start_up.c` starts a compensator from the memory
//! `mfcbeam_estimate_state` estimates.
//!
//! A nested cargo builds the static library and makes sure the `mfcbeam`
//! binary is the one `cargo test --workspace` builds (a `cargo build` of the
//! binary alone resolves other features and would compile it all again).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

/// `target/<profile>` of this test executable.
fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    exe.parent().unwrap().parent().unwrap().to_path_buf()
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn cargo_build(args: &[&str]) {
    let target_dir = profile_dir().parent().unwrap().to_path_buf();
    let mut cmd = Command::new(env!("CARGO"));
    cmd.args(args)
        .arg("--target-dir")
        .arg(&target_dir)
        .current_dir(root());
    if profile_dir().file_name().unwrap() == "release" {
        cmd.arg("--release");
    }
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "cargo build {args:?}:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Compile the C examples once: (mfcbeam_run, api_errors, no_heap,
/// old_names, start_up).
fn programs() -> &'static (PathBuf, PathBuf, PathBuf, PathBuf, PathBuf) {
    static BUILT: OnceLock<(PathBuf, PathBuf, PathBuf, PathBuf, PathBuf)> = OnceLock::new();
    BUILT.get_or_init(|| {
        // the program and the static library as `cargo test --workspace`
        // built them: no rebuild. A test's dependencies are built with all
        // their crate types, so the library is in `deps/` (a build of
        // `-p mfcbeam-capi` alone compiled `mfcbeam` again with other
        // features: 30 s of CI).
        cargo_build(&["test", "--workspace", "--no-run"]);
        let lib = profile_dir().join("deps").join("libmfcbeam.a");
        let dir = profile_dir().join("c-examples");
        std::fs::create_dir_all(&dir).unwrap();
        let build = |name: &str, defines: &[&str]| {
            let exe = dir.join(name);
            let out = Command::new("cc")
                .args(defines)
                .args([
                    "-std=c99",
                    "-D_POSIX_C_SOURCE=200809L",
                    "-Wall",
                    "-Wextra",
                    "-Werror",
                    "-O2",
                    "-I",
                ])
                .arg(root().join("include"))
                .arg("-o")
                .arg(&exe)
                .arg(root().join(format!("examples/c/{name}.c")))
                .arg(&lib)
                .args(["-lpthread", "-ldl", "-lm"])
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "cc {name}.c:\n{}",
                String::from_utf8_lossy(&out.stderr)
            );
            exe
        };
        (
            build("mfcbeam_run", &[]),
            build("api_errors", &[]),
            // only the no_std declarations visible
            build("no_heap", &["-DMFCBEAM_NO_STD"]),
            // the deprecated names warn, and still build
            build("old_names", &["-Wno-error=deprecated-declarations"]),
            build("start_up", &[]),
        )
    })
}

#[test]
fn a_compensator_starts_up_from_an_estimated_memory() {
    let out = Command::new(&programs().4).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.trim_end().ends_with("ok"), "{text}");
}

#[test]
fn the_c_api_refuses_bad_input_cleanly() {
    let out = Command::new(&programs().1).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    eprintln!("{text}");
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert!(text.ends_with("0 failed\n"));
    assert!(!text.contains("FAILED"));
    // every check printed its line
    assert!(text.lines().filter(|l| l.starts_with("ok: ")).count() >= 25);
}

#[test]
fn the_heapless_example_runs_on_caller_owned_storage() {
    let out = Command::new(&programs().2).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    eprintln!("{text}{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert!(text.contains("0 saturated"));
}

fn conform(kind: &str, exec: &str, cases: usize, scale: Option<&str>) -> Output {
    let out_dir = profile_dir().join(format!("c-conform-{kind}-{}", exec.len()));
    let mut cmd = Command::new(profile_dir().join("mfcbeam"));
    cmd.args(["conform", "--kind", kind, "--exec", exec])
        .args(["--cases", &cases.to_string()])
        .arg("--out")
        .arg(&out_dir);
    if let Some(s) = scale {
        cmd.args(["--tolerance-scale", s]);
    }
    let out = cmd.output().unwrap();
    eprintln!(
        "{exec} ({kind}):\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(out_dir);
    out
}

#[test]
fn the_c_example_conforms_in_f64() {
    let run = programs().0.display().to_string();
    for (kind, command) in [("model", "simulate"), ("compensator", "compensate")] {
        let out = conform(kind, &format!("{run} {command}"), 80, None);
        assert_eq!(out.status.code(), Some(0), "{kind} should conform");
    }
}

#[test]
fn the_c_example_conforms_in_f32_at_f32_tolerances() {
    let run = programs().0.display().to_string();
    let scale = ((f32::EPSILON as f64) / f64::EPSILON).to_string();
    assert_eq!(scale, "536870912");
    for (kind, command) in [("model", "simulate"), ("compensator", "compensate")] {
        let out = conform(kind, &format!("{run} {command} --f32"), 80, Some(&scale));
        assert_eq!(out.status.code(), Some(0), "{kind} in f32 should conform");
    }
}

/// The names before 0.2 are deprecated aliases in the header: each call
/// warns at compile time, and gives what its new name gives.
#[test]
fn the_old_c_names_warn_and_give_what_the_new_ones_give() {
    let out = Command::new("cc")
        .args(["-std=c99", "-Wall", "-fsyntax-only", "-I"])
        .arg(root().join("include"))
        .arg(root().join("examples/c/old_names.c"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    for old in [
        "mfcbeam_compensate_f32",
        "mfcbeam_compensate_f32_into",
        "mfcbeam_compensate_f64",
        "mfcbeam_compensate_f64_into",
        "mfcbeam_compensate",
        "mfcbeam_compensate_into",
    ] {
        assert!(
            err.contains(&format!("'{old}' is deprecated"))
                || err.contains(&format!("‘{old}’ is deprecated")),
            "no deprecation warning for {old}:\n{err}"
        );
    }
    let out = Command::new(&programs().3).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert!(text.ends_with("0 failed\n"), "{text}");
    assert_eq!(text.lines().filter(|l| l.starts_with("ok: ")).count(), 15);
}

/// The file contract's errors: one line, exit 2, no output file.
#[test]
fn a_bad_model_file_is_one_line_and_no_output() {
    let dir = profile_dir().join("c-bad-model");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("m.json"), "{\"sample_time\": 1e-3}").unwrap();
    std::fs::write(dir.join("in.csv"), "u\n1.0\n").unwrap();
    let out = Command::new(&programs().0)
        .args(["simulate", "--model"])
        .arg(dir.join("m.json"))
        .arg("--input")
        .arg(dir.join("in.csv"))
        .arg("--output")
        .arg(dir.join("out.csv"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("hysteresis"), "{err}");
    assert!(!dir.join("out.csv").exists());
    std::fs::remove_dir_all(dir).unwrap();
}
