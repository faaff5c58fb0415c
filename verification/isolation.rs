//! Candidates that crash, hang, abort, exit or allocate without end
//! (`verification/candidates/hostile_*.c`, built here with the C compiler)
//! through `conform`, `bench` and `benchmark-control`: each run ends within
//! the timeout and a second, with one line naming what the candidate did
//! and where, the documented exit code, and no process left behind (every
//! process of the run is found by the temporary directory it was given).

#![cfg(target_os = "linux")]

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The hostile modes of `hostile_fmu.c` and `hostile_library.c`.
const NULL_DEREFERENCE: u32 = 1;
const HANG: u32 = 2;
const ABORT: u32 = 3;
const EXIT_0: u32 = 4;
const ALLOCATION: u32 = 5;
const WRONG: u32 = 6;

/// The timeout given to every run (s).
const TIMEOUT: f64 = 2.0;

/// A directory of this test, removed at the end; also the runs' TMPDIR.
struct Dir(PathBuf);

impl Dir {
    fn new(name: &str) -> Self {
        let p =
            std::env::temp_dir().join(format!("mfcbeam-isolation-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&p);
        fs::create_dir_all(p.join("tmp")).unwrap();
        Dir(p)
    }
    fn path(&self, f: &str) -> PathBuf {
        self.0.join(f)
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

fn source(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("verification/candidates")
        .join(name)
}

fn compile(src: &str, out: &Path, mode: u32, trigger: u64) {
    let status = Command::new("cc")
        .args(["-O1", "-shared", "-fPIC", "-Wall", "-Werror"])
        .arg(format!("-DHOSTILE={mode}"))
        .arg(format!("-DTRIGGER={trigger}"))
        .arg("-o")
        .arg(out)
        .arg(source(src))
        .status()
        .expect("a C compiler (cc)");
    assert!(status.success(), "cc {src}");
}

const DESCRIPTION: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="hostile" guid="{hostile}">
  <CoSimulation modelIdentifier="hostile"/>
  <ModelVariables>
    <ScalarVariable name="y_d" valueReference="0" causality="input" variability="continuous"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="u" valueReference="1" causality="output" variability="continuous"><Real/></ScalarVariable>
    <ScalarVariable name="saturated" valueReference="2" causality="output" variability="discrete"><Boolean/></ScalarVariable>
    <ScalarVariable name="reference" valueReference="3" causality="input" variability="continuous"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="measurement" valueReference="4" causality="input" variability="continuous"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="correction" valueReference="5" causality="output" variability="continuous"><Real/></ScalarVariable>
  </ModelVariables>
</fmiModelDescription>
"#;

/// A hostile FMU (FMI 2.0, Linux x86-64 binary) in `dir`.
fn hostile_fmu(dir: &Dir, mode: u32, trigger: u64) -> PathBuf {
    let so = dir.path(&format!("hostile-{mode}-{trigger}.so"));
    compile("hostile_fmu.c", &so, mode, trigger);
    let path = dir.path(&format!("hostile-{mode}-{trigger}.fmu"));
    let mut zip = zip::ZipWriter::new(fs::File::create(&path).unwrap());
    let options = zip::write::SimpleFileOptions::default();
    zip.start_file("modelDescription.xml", options).unwrap();
    zip.write_all(DESCRIPTION.as_bytes()).unwrap();
    zip.start_file("binaries/linux64/hostile.so", options)
        .unwrap();
    zip.write_all(&fs::read(&so).unwrap()).unwrap();
    zip.finish().unwrap();
    path
}

/// A hostile step library in `dir`.
fn hostile_library(dir: &Dir, mode: u32, trigger: u64) -> PathBuf {
    let so = dir.path(&format!("hostile-library-{mode}-{trigger}.so"));
    compile("hostile_library.c", &so, mode, trigger);
    so
}

struct Run {
    code: Option<i32>,
    stderr: String,
    stdout: String,
    seconds: f64,
}

/// `mfcbeam args…` in `dir` with its TMPDIR, then every process that
/// still has that TMPDIR in its command line or environment.
fn run(dir: &Dir, args: &[&str]) -> (Run, Vec<String>) {
    let start = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_mfcbeam"))
        .args(args)
        .current_dir(&dir.0)
        .env("TMPDIR", dir.path("tmp"))
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let seconds = start.elapsed().as_secs_f64();
    // a killed process is reaped by its parent at once; give it a moment
    std::thread::sleep(Duration::from_millis(100));
    (
        Run {
            code: out.status.code(),
            stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
            stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
            seconds,
        },
        left_behind(&dir.path("tmp")),
    )
}

/// The processes whose command line or environment names `marker`.
fn left_behind(marker: &Path) -> Vec<String> {
    let marker = marker.to_string_lossy().into_owned();
    let mut found = Vec::new();
    for e in fs::read_dir("/proc").unwrap().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if !name.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        for f in ["cmdline", "environ"] {
            if let Ok(b) = fs::read(e.path().join(f)) {
                if String::from_utf8_lossy(&b).contains(&marker) {
                    found.push(format!(
                        "{name}: {}",
                        String::from_utf8_lossy(&b).replace('\0', " ")
                    ));
                    break;
                }
            }
        }
    }
    found
}

fn nominal(dir: &Dir) -> String {
    let path = dir.path("nominal.json");
    let out = Command::new(env!("CARGO_BIN_EXE_mfcbeam"))
        .args(["nominal", "--output"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(out.status.success());
    path.to_string_lossy().into_owned()
}

/// The run ended in time, with exit code `code`, one line on stderr
/// holding every one of `words`, and nothing left behind.
fn assert_contained(what: &str, (r, left): &(Run, Vec<String>), code: i32, words: &[&str]) {
    assert!(left.is_empty(), "{what}: processes left behind: {left:?}");
    assert!(
        r.seconds < TIMEOUT + 1.0,
        "{what}: took {:.2} s (timeout {TIMEOUT} s)",
        r.seconds
    );
    assert_eq!(r.code, Some(code), "{what}: stderr {}", r.stderr);
    let lines: Vec<&str> = r.stderr.lines().collect();
    assert_eq!(lines.len(), 1, "{what}: stderr {:?}", r.stderr);
    for w in words {
        assert!(lines[0].contains(w), "{what}: '{w}' not in {}", lines[0]);
    }
}

const TIMEOUT_ARG: &str = "2";

#[test]
fn conform_survives_every_hostile_fmu_and_names_what_it_did() {
    let dir = Dir::new("conform-fmu");
    let model = nominal(&dir);
    let cases = [
        (
            NULL_DEREFERENCE,
            "crash",
            vec!["SIGSEGV", "in a step at sample 0"],
        ),
        (
            HANG,
            "hang",
            vec!["did not answer within 2 s", "in a step at sample 0"],
        ),
        (ABORT, "crash", vec!["SIGABRT", "in a step"]),
        (EXIT_0, "exit", vec!["exit code 0", "in a step"]),
        (ALLOCATION, "crash", vec!["while an instance was created"]),
    ];
    for (mode, folder, words) in cases {
        let fmu = hostile_fmu(&dir, mode, 0);
        let out = format!("out-{mode}");
        let r = run(
            &dir,
            &[
                "conform",
                "--kind",
                "compensator",
                "--fmu",
                fmu.to_str().unwrap(),
                "--model",
                &model,
                "--timeout",
                TIMEOUT_ARG,
                "--out",
                &out,
            ],
        );
        let mut words = words.clone();
        words.push("on the first, simple case");
        assert_contained(&format!("mode {mode}"), &r, 1, &words);
        // the counterexample: the model and the input up to the sample
        let kept = dir.path(&out).join(folder);
        assert!(kept.join("model.json").is_file(), "mode {mode}");
        assert!(kept.join("input.csv").is_file(), "mode {mode}");
    }
}

#[test]
fn a_crash_in_a_property_names_the_property_the_case_and_the_sample() {
    let dir = Dir::new("conform-late");
    let model = nominal(&dir);
    // the 3001st step of the process crashes: past the first, simple case
    let fmu = hostile_fmu(&dir, NULL_DEREFERENCE, 3000);
    let r = run(
        &dir,
        &[
            "conform",
            "--kind",
            "compensator",
            "--fmu",
            fmu.to_str().unwrap(),
            "--model",
            &model,
            "--timeout",
            TIMEOUT_ARG,
            "--out",
            "out",
        ],
    );
    assert_contained("late crash", &r, 1, &["SIGSEGV", "in property", "(case"]);
    // input.csv holds the instance's input up to and including that sample
    let line = r.0.stderr.lines().next().unwrap().to_string();
    let at = line.split("at sample ").nth(1).unwrap();
    let sample: usize = at.split(' ').next().unwrap().parse().unwrap();
    let input = fs::read_to_string(dir.path("out/crash/input.csv")).unwrap();
    assert_eq!(input.lines().count(), 1 + sample + 1, "{line}");
    // and no report: the crash is the finding
    assert!(!r.0.stdout.contains("holds"), "{}", r.0.stdout);
}

#[test]
fn conform_survives_a_crashing_library() {
    let dir = Dir::new("conform-library");
    for (mode, words) in [
        (NULL_DEREFERENCE, vec!["SIGSEGV", "in property"]),
        (HANG, vec!["did not answer within 2 s", "in property"]),
        (EXIT_0, vec!["exit code 0", "in property"]),
    ] {
        let lib = hostile_library(&dir, mode, 3000);
        let r = run(
            &dir,
            &[
                "conform",
                "--kind",
                "compensator",
                "--library",
                lib.to_str().unwrap(),
                "--timeout",
                TIMEOUT_ARG,
                "--out",
                "out",
            ],
        );
        assert_contained(&format!("library mode {mode}"), &r, 1, &words);
    }
}

#[test]
fn a_library_that_declines_creep_is_checked_on_the_rest() {
    let dir = Dir::new("declines-creep");
    let lib = dir.path("declines_creep.so");
    compile("declines_creep.c", &lib, 0, 0);
    let r = run(
        &dir,
        &[
            "conform",
            "--kind",
            "model",
            "--library",
            lib.to_str().unwrap(),
            "--out",
            "out",
        ],
    );
    let (out, left) = &r;
    assert!(left.is_empty(), "{left:?}");
    // not unusable (2): the cases without creep ran (and the identity
    // fails them), those with creep were declined
    assert_eq!(out.code, Some(1), "{}", out.stderr);
    assert!(
        out.stdout
            .contains("skipped, the implementation declined them"),
        "{}",
        out.stdout
    );
    assert!(out.stdout.contains("monotonicity"), "{}", out.stdout);
}

#[test]
fn a_file_that_is_not_a_library_is_refused_with_the_loaders_reason() {
    let dir = Dir::new("not-a-library");
    let path = dir.path("text.so");
    fs::write(
        &path,
        "not a library, but long enough for a header\n".repeat(4),
    )
    .unwrap();
    let r = run(
        &dir,
        &[
            "conform",
            "--kind",
            "compensator",
            "--library",
            path.to_str().unwrap(),
        ],
    );
    // the reason dlopen gives, not only that it failed
    assert_contained("not a library", &r, 2, &["--library", "invalid ELF header"]);
    let lib = hostile_library(&dir, 0, 0);
    let r = run(
        &dir,
        &[
            "conform",
            "--kind",
            "compensator",
            "--library",
            lib.to_str().unwrap(),
            "--symbol-prefix",
            "other",
        ],
    );
    assert_contained("missing symbol", &r, 2, &["no function other_create"]);
}

#[test]
fn bench_refuses_hostile_candidates_and_times_the_others() {
    let dir = Dir::new("bench");
    let crash = hostile_fmu(&dir, NULL_DEREFERENCE, 0);
    let hang = hostile_library(&dir, HANG, 0);
    let wrong = hostile_library(&dir, WRONG, 0);
    let r = run(
        &dir,
        &[
            "bench",
            "--fmu",
            crash.to_str().unwrap(),
            "--library",
            hang.to_str().unwrap(),
            "--steps",
            "2000",
            "--rounds",
            "2",
            "--timeout",
            TIMEOUT_ARG,
        ],
    );
    let (out, left) = &r;
    assert!(left.is_empty(), "{left:?}");
    assert!(out.seconds < TIMEOUT + 1.0, "{:.2} s", out.seconds);
    assert_eq!(out.code, Some(1), "{}", out.stderr);
    // the reference is timed; each hostile one refused with its reason
    assert!(
        out.stdout.contains("| reference (mfcbeam, f64) |"),
        "{}",
        out.stdout
    );
    assert!(
        out.stdout
            .contains("refused: round 0: the candidate crashed"),
        "{}",
        out.stdout
    );
    assert!(
        out.stdout.contains("did not answer within 2 s"),
        "{}",
        out.stdout
    );
    let r = run(
        &dir,
        &[
            "bench",
            "--library",
            wrong.to_str().unwrap(),
            "--steps",
            "2000",
            "--rounds",
            "1",
        ],
    );
    assert_eq!(r.0.code, Some(1));
    assert!(
        r.0.stdout.contains("a fast wrong answer is not a result"),
        "{}",
        r.0.stdout
    );
}

#[test]
fn benchmark_control_survives_a_crashing_and_a_hanging_controller_fmu() {
    let dir = Dir::new("benchmark-control");
    for (mode, words) in [
        (NULL_DEREFERENCE, vec!["SIGSEGV", "at sample"]),
        (HANG, vec!["did not answer within 2 s", "at sample"]),
        (EXIT_0, vec!["exit code 0", "at sample"]),
    ] {
        let fmu = hostile_fmu(&dir, mode, 100);
        let r = run(
            &dir,
            &[
                "benchmark-control",
                "--fmu",
                fmu.to_str().unwrap(),
                "--scenario",
                "nominal",
                "--timeout",
                TIMEOUT_ARG,
            ],
        );
        assert_contained(&format!("controller mode {mode}"), &r, 2, &words);
    }
}
