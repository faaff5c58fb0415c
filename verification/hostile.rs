//! Hostile inputs through the command line (`docs/FILES.md`, "Limits"):
//! every count in a file or an option that decides an allocation, files of
//! up to 1 MB built to cost the most memory per byte, and the clean-up of
//! temporary files and directories. Each case runs the program as a child
//! and reads its peak resident memory from `wait4`: a refusal is exit 2 and
//! one line, never a panic or an abort, and no case — refused or accepted —
//! takes more than 100 MB. The fuzz targets (`fuzz/`) search the same
//! entry points at random; the findings they made are the `finding_*`
//! tests at the end.

#![cfg(target_os = "linux")]

use std::fs;
use std::path::PathBuf;
use std::process::{Command, Stdio};

use mfcbeam::operators::model::ModelFile;
use mfcbeam::operators::nominal::nominal_model;
use mfcbeam::realtime::limits;

/// The most memory any case may take (the bound).
const MAX_RSS_BYTES: u64 = 100 << 20;

/// A scratch directory of this test, removed at the end.
struct Dir(PathBuf);

impl Dir {
    fn new(name: &str) -> Self {
        let p = std::env::temp_dir().join(format!("mfcbeam-hostile-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&p);
        fs::create_dir_all(&p).unwrap();
        Dir(p)
    }
    fn path(&self, f: &str) -> PathBuf {
        self.0.join(f)
    }
    fn write(&self, f: &str, bytes: impl AsRef<[u8]>) -> String {
        let p = self.path(f);
        fs::write(&p, bytes).unwrap();
        p.to_str().unwrap().to_string()
    }
    fn names(&self) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(&self.0)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

struct Run {
    code: Option<i32>,
    signal: Option<i32>,
    stderr: String,
    max_rss: u64,
}

/// Run `mfcbeam args…` in `dir`, with its peak resident memory (`wait4`'s
/// `ru_maxrss`: the kernel counts what the process held at the moment it
/// was spawned too, a few MB of this test, so it is an upper bound).
fn run(dir: &Dir, args: &[&str]) -> Run {
    let err_path = dir.path(".stderr");
    let child = Command::new(env!("CARGO_BIN_EXE_mfcbeam"))
        .args(args)
        .current_dir(&dir.0)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(fs::File::create(&err_path).unwrap())
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: rusage is plain data; wait4 fills it and status.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(r, pid, "wait4");
    std::mem::forget(child); // reaped above
    let stderr = fs::read_to_string(&err_path).unwrap_or_default();
    fs::remove_file(&err_path).unwrap();
    Run {
        code: libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status)),
        signal: libc::WIFSIGNALED(status).then(|| libc::WTERMSIG(status)),
        stderr,
        max_rss: usage.ru_maxrss as u64 * 1024,
    }
}

/// Refused: exit 2, one line holding every needle, no panic, within the
/// memory bound, and nothing written beside the inputs.
fn refused(dir: &Dir, args: &[&str], needles: &[&str]) {
    let before = dir.names();
    let r = run(dir, args);
    let what = format!("mfcbeam {}", args.join(" "));
    assert_eq!(r.signal, None, "{what}: killed by signal: {}", r.stderr);
    assert_eq!(r.code, Some(2), "{what}: {}", r.stderr);
    assert_eq!(
        r.stderr.trim_end().lines().count(),
        1,
        "{what}: {}",
        r.stderr
    );
    assert!(!r.stderr.contains("panicked"), "{what}: {}", r.stderr);
    for n in needles {
        assert!(
            r.stderr.contains(n),
            "{what}: '{n}' missing from {}",
            r.stderr
        );
    }
    assert!(r.max_rss <= MAX_RSS_BYTES, "{what}: {} bytes", r.max_rss);
    assert_eq!(dir.names(), before, "{what}: left files behind");
}

/// Accepted: exit 0 within the memory bound.
fn accepted(dir: &Dir, args: &[&str]) -> u64 {
    let r = run(dir, args);
    let what = format!("mfcbeam {}", args.join(" "));
    assert_eq!(r.code, Some(0), "{what}: {}", r.stderr);
    assert!(r.max_rss <= MAX_RSS_BYTES, "{what}: {} bytes", r.max_rss);
    r.max_rss
}

fn nominal_file() -> ModelFile {
    nominal_model().to_file().without_state()
}

fn json(file: &ModelFile) -> String {
    serde_json::to_string(file).unwrap()
}

/// A model file with the nominal model and `edit` applied to its JSON.
fn edited(edit: impl FnOnce(&mut serde_json::Value)) -> String {
    let mut v = serde_json::to_value(nominal_file()).unwrap();
    edit(&mut v);
    v.to_string()
}

fn target_trace(dir: &Dir) -> String {
    let mut text = String::from("t,y_d\n");
    for k in 0..200 {
        text.push_str(&format!(
            "{},{}\n",
            k as f64 * 2e-4,
            (k as f64 * 0.05).sin() * 0.3
        ));
    }
    dir.write("target.csv", text)
}

#[test]
fn counts_in_a_model_file_are_refused_before_they_are_allocated() {
    let dir = Dir::new("model-counts");
    let target = target_trace(&dir);
    let delay = |d: serde_json::Value| edited(|v| v["delay"] = d);
    let long = |n: usize| (0..n).map(|i| i as f64).collect::<Vec<f64>>();
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "delay-1e12",
            delay(1_000_000_000_000u64.into()),
            "delay: 1000000000000 exceeds",
        ),
        (
            "delay-max",
            delay(u64::MAX.into()),
            "delay: 18446744073709551615 exceeds",
        ),
        ("delay-1e8", delay(100_000_000.into()), "delay"),
        (
            "delay-limit",
            delay((limits::MAX_DELAY + 1).into()),
            "delay",
        ),
        ("delay-negative", delay((-1).into()), "expected usize"),
        ("delay-fraction", delay(2.5.into()), "expected usize"),
        (
            "plays",
            edited(|v| {
                let n = limits::MAX_PLAYS + 1;
                v["hysteresis"]["thresholds"] = long(n).into();
                v["hysteresis"]["weights"] = vec![0.1; n].into();
            }),
            "hysteresis.thresholds: 1025 exceeds",
        ),
        (
            "creep-eigenvalues",
            edited(|v| {
                v["creep"]["eigenvalues"] = (1..=limits::MAX_CREEP_EIGENVALUES + 1)
                    .map(|i| i as f64)
                    .collect::<Vec<_>>()
                    .into();
            }),
            "creep.eigenvalues: 65 exceeds",
        ),
        (
            "creep-elements",
            edited(|v| {
                // each list within its limit, the product beyond it
                v["creep"]["thresholds"] = long(1000).into();
                v["creep"]["weights"] = vec![0.0; 1000].into();
                v["creep"]["eigenvalues"] = (1..=17).map(|i| i as f64).collect::<Vec<_>>().into();
            }),
            "thresholds × eigenvalues",
        ),
        (
            "superposition-terms",
            edited(|v| {
                let n = limits::MAX_SUPERPOSITION_TERMS + 1;
                v["superposition"] = serde_json::json!({
                    "thresholds": long(n),
                    "weights": vec![1.0; n],
                });
            }),
            "superposition.thresholds: 1025 exceeds",
        ),
        (
            "delay-state",
            edited(|v| {
                v["delay"] = 3.into();
                v["delay_state"] = vec![0.0; 100_000].into();
            }),
            "delay_state",
        ),
    ];
    for (name, text, needle) in &cases {
        let model = dir.write(&format!("{name}.json"), text);
        assert!(text.len() <= 1 << 20, "{name}: {} bytes", text.len());
        refused(
            &dir,
            &[
                "compensate",
                "--model",
                &model,
                "--input",
                &target,
                "--output",
                "out.csv",
            ],
            &[&format!("{name}.json"), needle],
        );
        refused(
            &dir,
            &[
                "simulate", "--model", &model, "--input", &target, "--output", "out.csv",
            ],
            &[needle],
        );
        refused(&dir, &["invert", "--model", &model], &[needle]);
        refused(
            &dir,
            &[
                "conform", "--kind", "model", "--exec", "true", "--model", &model, "--out", "ce",
            ],
            &[needle],
        );
        fs::remove_file(dir.path(&format!("{name}.json"))).unwrap();
    }
}

#[test]
fn counts_in_a_beam_file_and_beam_options_are_refused() {
    let dir = Dir::new("beam-counts");
    let mut beam: serde_json::Value =
        serde_json::from_str(&fs::read_to_string("golden/nominal_beam.json").unwrap()).unwrap();
    for n in [
        serde_json::json!(1_000_000_000_000u64),
        serde_json::json!(limits::MAX_BASIS_FUNCTIONS + 1),
    ] {
        beam["basis_functions"] = n;
        let path = dir.write("beam.json", beam.to_string());
        for model in ["ritz", "modal"] {
            refused(
                &dir,
                &["beam", "modes", "--beam", &path, "--beam-model", model],
                &["beam.json", "basis_functions", "exceeds the limit"],
            );
        }
        refused(
            &dir,
            &["feedforward", "--beam", &path, "--output", "ff.csv"],
            &["basis_functions"],
        );
    }
    let nominal = "golden/nominal_beam.json";
    let nominal = fs::canonicalize(nominal).unwrap();
    let nominal = nominal.to_str().unwrap();
    for elements in [
        "100000000",
        "501",
        "2",
        "=-1",
        "1e9",
        "18446744073709551616",
    ] {
        let option = if let Some(v) = elements.strip_prefix('=') {
            format!("--elements={v}")
        } else {
            format!("--elements={elements}")
        };
        refused(
            &dir,
            &["beam", "modes", "--beam", nominal, &option],
            &["--elements"],
        );
    }
    // the largest that is accepted stays within the bound
    accepted(
        &dir,
        &[
            "beam",
            "modes",
            "--beam",
            nominal,
            "--elements",
            &limits::MAX_ELEMENTS.to_string(),
        ],
    );
    let mut b = beam.clone();
    b["basis_functions"] = limits::MAX_BASIS_FUNCTIONS.into();
    let path = dir.write("largest.json", b.to_string());
    accepted(
        &dir,
        &["beam", "modes", "--beam", &path, "--beam-model", "ritz"],
    );
}

#[test]
fn option_values_that_would_make_huge_outputs_are_refused_up_front() {
    let dir = Dir::new("options");
    let beam = fs::canonicalize("golden/nominal_beam.json").unwrap();
    let beam = beam.to_str().unwrap();
    for (args, needle) in [
        (&["--plateau", "1e9"][..], "samples"),
        (&["--sample-time", "1e-300"], "samples"),
        (&["--sample-time", "0"], "--sample-time"),
        (&["--sample-time", "nan"], "--sample-time"),
        (&["--periods", "1000000000000"], "levels"),
        (&["--steps", "18446744073709551615"], "levels"),
        (&["--rise", "inf"], "--rise"),
        (&["--amplitude", "1e400"], "--amplitude"),
    ] {
        let mut a = vec!["signal", "--output", "s.csv"];
        a.extend_from_slice(args);
        refused(&dir, &a, &[needle]);
    }
    for (args, needle) in [
        (&["--end", "1e12"][..], "samples"),
        (&["--sample-time", "1e-300"], "samples"),
        (&["--end", "nan"], "end"),
    ] {
        let mut a = vec!["feedforward", "--beam", beam, "--output", "ff.csv"];
        a.extend_from_slice(args);
        refused(&dir, &a, &[needle]);
    }
    let model = fs::canonicalize("golden/nominal_model.json").unwrap();
    let model = model.to_str().unwrap();
    // the largest accepted: just under the generated-samples limit, the
    // feedforward also with the finest beam and a model
    let rss = accepted(
        &dir,
        &[
            "signal",
            "--output",
            "big.csv",
            "--plateau",
            "16.5",
            "--rise",
            "0.1",
        ],
    );
    eprintln!("signal of 996 001 samples: peak {} MB", rss >> 20);
    let rss = accepted(
        &dir,
        &[
            "feedforward",
            "--beam",
            beam,
            "--model",
            model,
            "--end",
            "199",
            "--elements",
            "500",
            "--output",
            "ff.csv",
        ],
    );
    eprintln!(
        "feedforward of 995 001 samples, 500 elements, with a model: peak {} MB",
        rss >> 20
    );
    fs::remove_file(dir.path("big.csv")).unwrap();
    fs::remove_file(dir.path("ff.csv")).unwrap();
    accepted(
        &dir,
        &[
            "signal",
            "--output",
            "u.csv",
            "--plateau",
            "0.1",
            "--rise",
            "0.05",
        ],
    );
    accepted(
        &dir,
        &[
            "simulate", "--model", model, "--input", "u.csv", "--output", "uy.csv",
        ],
    );
    for (args, needle) in [
        (
            &["--hysteresis-operators", "100000"][..],
            "--hysteresis-operators",
        ),
        (&["--creep-operators", "100000"], "--creep-operators"),
        (
            &["--creep-eigenvalues", "1000000000"],
            "--creep-eigenvalues",
        ),
        (&["--superposition", "1000000000000"], "--superposition"),
        (
            &["--hysteresis-operators", "400", "--creep-operators", "200"],
            "weights to fit",
        ),
        (
            &["--delay", "auto", "--max-delay", "1000000000"],
            "--max-delay",
        ),
        (&["--delay", "1000000000000"], "delay"),
    ] {
        let mut a = vec!["identify", "--input", "uy.csv", "--output", "id.json"];
        a.extend_from_slice(args);
        refused(&dir, &a, &[needle]);
    }
    for (args, needle) in [
        (&["--cases", "1000000000"][..], "--cases"),
        (&["--timeout", "1e300"], "--timeout"),
        (&["--timeout", "-1"], "--timeout"),
    ] {
        let mut a = vec![
            "conform", "--kind", "model", "--exec", "true", "--out", "ce",
        ];
        a.extend_from_slice(args);
        refused(&dir, &a, &[needle]);
    }
}

/// Files of at most 1 MB made to cost the most memory per byte a reader
/// holds: a cell per two bytes, one very long cell, very many columns.
#[test]
fn a_one_megabyte_trace_takes_a_small_multiple_of_its_size() {
    let dir = Dir::new("big-trace");
    let model = fs::canonicalize("golden/nominal_model.json").unwrap();
    let model = model.to_str().unwrap();
    let rows = (1 << 20) / 2 - 2;
    let mut short = String::from("u\n");
    short.push_str(&"0\n".repeat(rows));
    let short = dir.write("short.csv", short);
    let rss = accepted(
        &dir,
        &[
            "simulate", "--model", model, "--input", &short, "--output", "o.csv",
        ],
    );
    eprintln!("simulate of {rows} one-byte rows: peak {} MB", rss >> 20);
    fs::remove_file(dir.path("o.csv")).unwrap();
    // identification on a 1 MB record of the most rows (262 143), with the
    // dead-time search and its figure, and with the most weights allowed
    let mut record = String::from("u,y\n");
    for k in 0..(1 << 20) / 4 - 1 {
        record.push_str(&format!("{},{}\n", k % 10, (k * 7) % 10));
    }
    let record = dir.write("record.csv", record);
    for extra in [
        &["--delay", "auto", "--max-delay", "3", "--plot", "fit.png"][..],
        &["--hysteresis-operators", "300", "--creep-operators", "200"],
    ] {
        let mut args = vec!["identify", "--input", &record, "--output", "id.json"];
        args.extend_from_slice(&["--sample-time", "2e-4"]);
        args.extend_from_slice(extra);
        let rss = accepted(&dir, &args);
        eprintln!("identify {extra:?} on 1 MB: peak {} MB", rss >> 20);
    }
    // one cell of a megabyte
    let long = dir.write("long.csv", format!("u\n{}\n", "1".repeat(1 << 20)));
    refused(
        &dir,
        &[
            "simulate", "--model", model, "--input", &long, "--output", "o.csv",
        ],
        &["long.csv", "row 1", "is not a finite number"],
    );
    // 100 000 columns of one row
    let names: Vec<String> = (0..100_000).map(|i| format!("c{i}")).collect();
    let wide = dir.write(
        "wide.csv",
        format!("{}\n{}\n", names.join(","), vec!["0"; 100_000].join(",")),
    );
    refused(
        &dir,
        &[
            "simulate", "--model", model, "--input", &wide, "--output", "o.csv",
        ],
        &["wide.csv", "missing column 'u'"],
    );
    // a model file of a megabyte that is one long list
    let mut file = nominal_file();
    file.hysteresis.state = Some(vec![0.0; 100_000]);
    let text = json(&file);
    assert!(text.len() <= 1 << 20);
    let big = dir.write("big.json", text);
    refused(
        &dir,
        &[
            "simulate", "--model", &big, "--input", &short, "--output", "o.csv",
        ],
        &["big.json", "hysteresis.state"],
    );
}

/// A candidate whose output is far larger than its input can explain is
/// refused before its file is read; one that writes garbage is named.
#[test]
fn a_runaway_candidate_output_is_refused_unread() {
    let dir = Dir::new("runaway");
    let script = |name: &str, body: &str| {
        let path = dir.write(name, format!("#!/bin/sh\nfor a; do out=$a; done\n{body}\n"));
        let mut perm = fs::metadata(&path).unwrap().permissions();
        std::os::unix::fs::PermissionsExt::set_mode(&mut perm, 0o755);
        fs::set_permissions(&path, perm).unwrap();
        path
    };
    let huge = script(
        "huge.sh",
        "head -c 300000000 /dev/zero | tr '\\0' '0' > \"$out\"",
    );
    refused(
        &dir,
        &[
            "conform", "--kind", "model", "--cases", "4", "--exec", &huge, "--out", "ce",
        ],
        &["bytes for", "rows"],
    );
    let garbage = script("garbage.sh", "printf 'u,y\\n\\377\\376,x\\n' > \"$out\"");
    refused(
        &dir,
        &[
            "conform", "--kind", "model", "--cases", "4", "--exec", &garbage, "--out", "ce",
        ],
        &["unusable"],
    );
}

/// An FMU that unpacks far beyond its size (a description of 64 MB in a
/// 64 kB archive) is refused with one line, within the memory bound, and
/// its scratch directory goes.
#[test]
fn a_zip_bomb_fmu_is_refused() {
    use std::io::Write;
    let dir = Dir::new("zip-bomb");
    let mut zip = zip::ZipWriter::new(fs::File::create(dir.path("bomb.fmu")).unwrap());
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .large_file(true);
    zip.start_file("modelDescription.xml", options).unwrap();
    let spaces = vec![b' '; 1 << 20];
    for _ in 0..64 {
        zip.write_all(&spaces).unwrap();
    }
    zip.finish().unwrap();
    assert!(fs::metadata(dir.path("bomb.fmu")).unwrap().len() < 1 << 20);
    let model = fs::canonicalize("golden/nominal_model.json").unwrap();
    refused(
        &dir,
        &[
            "conform",
            "--kind",
            "model",
            "--fmu",
            "bomb.fmu",
            "--model",
            model.to_str().unwrap(),
        ],
        &["modelDescription.xml", "more than the 16777216 read"],
    );
}

/// `conform` leaves no scratch directory: on success, on a failure (it
/// writes counterexamples and exits 1), with a candidate that hangs, and on
/// Ctrl-C.
#[test]
fn conform_leaves_no_scratch_directory_on_any_way_out() {
    let dir = Dir::new("conform-scratch");
    let me = env!("CARGO_BIN_EXE_mfcbeam");
    let mine = |pid: u32| {
        fs::read_dir(std::env::temp_dir())
            .unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(&format!("mfcbeam-conform-{pid}-")))
            .collect::<Vec<_>>()
    };
    // a wrong candidate: halves the output (a shell wrapper around simulate)
    let wrong = dir.write(
        "halved.sh",
        format!(
            "#!/bin/sh\n{me} simulate \"$@\" || exit $?\nout=$(eval echo \\${{$#}})\nawk -F, 'NR==1{{print;next}}{{$NF=$NF/2; print}}' OFS=, \"$out\" > \"$out.h\" && mv \"$out.h\" \"$out\"\n"
        ),
    );
    let mut perm = fs::metadata(&wrong).unwrap().permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut perm, 0o755);
    fs::set_permissions(&wrong, perm.clone()).unwrap();
    let sim = format!("{me} simulate");
    for (exec, code) in [(sim.as_str(), 0), (wrong.as_str(), 1)] {
        let child = Command::new(me)
            .args([
                "conform", "--kind", "model", "--cases", "12", "--exec", exec, "--out",
            ])
            .arg(dir.path("ce"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let pid = child.id();
        let out = child.wait_with_output().unwrap();
        assert_eq!(out.status.code(), Some(code), "{exec}");
        assert_eq!(
            mine(pid),
            Vec::<String>::new(),
            "{exec}: scratch left behind"
        );
    }
    // a candidate that hangs, stopped by the timeout
    let hang = dir.write("hang.sh", "#!/bin/sh\nsleep 30\n");
    fs::set_permissions(&hang, perm.clone()).unwrap();
    let conform_hanging = |timeout: &str| {
        Command::new(me)
            .args(["conform", "--kind", "model", "--cases", "4"])
            .args(["--timeout", timeout, "--exec", &hang])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    let child = conform_hanging("0.5");
    let pid = child.id();
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        mine(pid),
        Vec::<String>::new(),
        "timeout: scratch left behind"
    );
    // Ctrl-C while the candidate hangs: the candidate is killed too
    let mut child = conform_hanging("60");
    let pid = child.id();
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
    while mine(pid).is_empty() && std::time::Instant::now() < deadline {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert!(!mine(pid).is_empty(), "conform made no scratch directory");
    std::thread::sleep(std::time::Duration::from_millis(300));
    // SAFETY: sends a signal to our own child.
    unsafe { libc::kill(pid as libc::pid_t, libc::SIGINT) };
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(128 + libc::SIGINT));
    assert_eq!(
        mine(pid),
        Vec::<String>::new(),
        "Ctrl-C: scratch left behind"
    );
}

/// Killed while it writes, a command leaves the old output and no
/// temporary file (the new content was never named).
#[test]
fn a_command_killed_while_it_writes_leaves_the_old_file_and_nothing_else() {
    let dir = Dir::new("killed");
    let me = env!("CARGO_BIN_EXE_mfcbeam");
    let args = [
        "signal",
        "--output",
        "s.csv",
        "--plateau",
        "10",
        "--sample-time",
        "2e-4",
    ];
    // the whole new file, once
    accepted(&dir, &args);
    let whole = fs::read(dir.path("s.csv")).unwrap();
    fs::write(dir.path("s.csv"), "old\n").unwrap();
    // it takes a while to write: kill it at several moments
    for delay_ms in [5, 20, 60, 150, 400] {
        let mut child = Command::new(me)
            .args(args)
            .current_dir(&dir.0)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(delay_ms));
        let _ = child.kill();
        let _ = child.wait();
        let names = dir.names();
        assert_eq!(names, ["s.csv"], "after {delay_ms} ms: {names:?}");
        let now = fs::read(dir.path("s.csv")).unwrap();
        assert!(
            now == b"old\n" || now == whole,
            "after {delay_ms} ms: neither the old file nor the whole new one ({} bytes)",
            now.len()
        );
        fs::write(dir.path("s.csv"), "old\n").unwrap();
    }
}
