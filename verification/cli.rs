//! The command-line contract of `docs/FILES.md`: outputs, number format, and
//! the error contract (exit 2, one line naming file and row or field, no
//! panic, no partial output file).

use crate::common;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use mfcbeam::io::Trace;
use mfcbeam::prelude::*;

struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        let p = std::env::temp_dir().join(format!("mfcbeam-cli-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&p);
        fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }
    fn path(&self, f: &str) -> PathBuf {
        self.0.join(f)
    }
    fn write(&self, f: &str, text: &str) -> PathBuf {
        let p = self.path(f);
        fs::write(&p, text).unwrap();
        p
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

fn mfcbeam(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mfcbeam"))
        .args(args)
        .output()
        .unwrap()
}

/// `mfcbeam CMD --model MODEL --input INPUT --output OUTPUT EXTRA…`: a
/// command of the file contract on its three files.
fn on_files(cmd: &str, model: &str, input: &str, output: &str, extra: &[&str]) -> Output {
    let mut args = vec![cmd, "--model", model, "--input", input, "--output", output];
    args.extend_from_slice(extra);
    mfcbeam(&args)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

const MODEL: &str = "golden/nominal_model.json";

/// A failing command: exit 2, exactly one line on stderr containing every
/// `needle`, no output file.
fn assert_clean_failure(out: &Output, needles: &[&str], output: Option<&Path>) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "one line expected: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "'{n}' missing from: {err}");
    }
    if let Some(p) = output {
        assert!(!p.exists(), "partial output {} left behind", p.display());
        let dir = p.parent().unwrap();
        let leftovers: Vec<_> = fs::read_dir(dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
            .collect();
        assert!(leftovers.is_empty(), "temporary files left behind");
    }
}

#[test]
fn simulate_appends_y_equal_to_the_library_bit_for_bit() {
    let d = TempDir::new("simulate");
    let input = d.write(
        "in.csv",
        "t,u,note\n0.0,0,a\n0.0002,250.5,b\n0.0004,-1e-7,c\n0.0006,900,d\n",
    );
    let output = d.path("out.csv");
    let out = on_files("simulate", MODEL, s(&input), s(&output), &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let trace = Trace::read(&output).unwrap();
    assert_eq!(trace.header(), &["t", "u", "note", "y"]);
    let y = trace.column("y").unwrap();
    let expected = nominal_model().run(&[0.0, 250.5, -1e-7, 900.0]);
    assert_eq!(y, expected);
    // input columns pass through unchanged
    let text = fs::read_to_string(&output).unwrap();
    assert!(text.lines().nth(3).unwrap().starts_with("0.0004,-1e-7,c,"));
}

#[test]
fn compensate_writes_u_and_saturated_and_limits_parse_negative_numbers() {
    let d = TempDir::new("compensate");
    let input = d.write(
        "in.csv",
        "t,y_d\n0,0\n0.0002,300\n0.0004,5000\n0.0006,100\n",
    );
    for limits in [
        vec!["--limits=-1000,1000"],
        vec!["--limits", "-1000,1000"],
        vec![],
    ] {
        let output = d.path("out.csv");
        let mut args = vec![
            "compensate",
            "--model",
            MODEL,
            "--input",
            s(&input),
            "--output",
            s(&output),
        ];
        args.extend(limits.iter().copied());
        let out = mfcbeam(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let trace = Trace::read(&output).unwrap();
        assert_eq!(trace.header(), &["t", "y_d", "u", "saturated"]);
        assert_eq!(trace.column("saturated").unwrap(), vec![0.0, 0.0, 1.0, 0.0]);
        let u = trace.column("u").unwrap();
        assert_eq!(u[2], 1000.0);
        let mut comp = nominal_model()
            .compensator(CompensatorSettings::default())
            .unwrap();
        let expected: Vec<f64> = [0.0, 300.0, 5000.0, 100.0]
            .iter()
            .map(|&t| comp.compensate(t).u)
            .collect();
        assert_eq!(u, expected);
    }
    let output = d.path("free.csv");
    let out = on_files("compensate", MODEL, s(&input), s(&output), &["--no-limits"]);
    assert!(out.status.success());
    let trace = Trace::read(&output).unwrap();
    assert!(trace.column("u").unwrap()[2] > 1000.0);
    assert_eq!(trace.column("saturated").unwrap(), vec![0.0; 4]);
}

#[test]
fn invert_prints_the_inverse_operator_as_json() {
    let out = mfcbeam(&["invert", "--model", MODEL]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let inv = nominal_model().hysteresis().inverse();
    let get = |k: &str| -> Vec<f64> {
        v[k].as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    assert_eq!(get("thresholds"), inv.thresholds());
    assert_eq!(get("weights"), inv.weights());
    assert_eq!(get("state"), vec![0.0; 12]);
}

#[test]
fn signal_then_compensate_then_simulate_round_trip() {
    let d = TempDir::new("roundtrip");
    let sig = d.path("sig.csv");
    let comp = d.path("comp.csv");
    let sim = d.path("sim.csv");
    assert!(mfcbeam(&[
        "signal",
        "--column",
        "y_d",
        "--amplitude",
        "400",
        "--plateau",
        "0.2",
        "--output",
        s(&sig)
    ])
    .status
    .success());
    assert!(mfcbeam(&[
        "compensate",
        "--model",
        MODEL,
        "--input",
        s(&sig),
        "--output",
        s(&comp)
    ])
    .status
    .success());
    assert!(mfcbeam(&[
        "simulate",
        "--model",
        MODEL,
        "--input",
        s(&comp),
        "--output",
        s(&sim)
    ])
    .status
    .success());
    let t = Trace::read(&sim).unwrap();
    let (y, yd) = (t.column("y").unwrap(), t.column("y_d").unwrap());
    let err = y
        .iter()
        .zip(&yd)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(err < 1e-9, "{err}");
}

#[test]
fn error_contract_bad_inputs() {
    let d = TempDir::new("errors");
    let good_in = d.write("in.csv", "t,u\n0,0\n0.0002,1\n");
    let output = d.path("out.csv");
    let run =
        |model: &Path, input: &Path| on_files("simulate", s(model), s(input), s(&output), &[]);
    let model = |name: &str, text: &str| d.write(name, text);
    let h = |thr: &str, w: &str| {
        format!(
            r#"{{"sample_time": 0.0002, "hysteresis": {{"thresholds": {thr}, "weights": {w}}}}}"#
        )
    };

    // missing model file
    let out = run(&d.path("nope.json"), &good_in);
    assert_clean_failure(&out, &["nope.json"], Some(&output));
    // malformed JSON
    let out = run(&model("bad.json", "{\"sample_time\": 0.0002,"), &good_in);
    assert_clean_failure(&out, &["bad.json", "JSON"], Some(&output));
    // non-increasing thresholds
    let out = run(&model("thr.json", &h("[0, 2, 1]", "[1, 1, 1]")), &good_in);
    assert_clean_failure(
        &out,
        &["thr.json", "hysteresis.thresholds[2]"],
        Some(&output),
    );
    // weights breaking (11)
    let out = run(&model("w.json", &h("[0, 1]", "[0.5, -0.6]")), &good_in);
    assert_clean_failure(
        &out,
        &["w.json", "hysteresis.weights", "(11)"],
        Some(&output),
    );
    // mismatched lengths
    let out = run(&model("len.json", &h("[0, 1]", "[0.5]")), &good_in);
    assert_clean_failure(
        &out,
        &["len.json", "hysteresis.weights", "expected 2"],
        Some(&output),
    );
    // non-positive sample time
    let out = run(
        &model(
            "ts.json",
            r#"{"sample_time": 0, "hysteresis": {"thresholds": [0], "weights": [1]}}"#,
        ),
        &good_in,
    );
    assert_clean_failure(&out, &["ts.json", "sample_time"], Some(&output));
    // creep weights breaking (17) and a bad eigenvalue
    let out = run(
        &model(
            "cw.json",
            r#"{"sample_time": 0.0002, "hysteresis": {"thresholds": [0], "weights": [1]}, "creep": {"thresholds": [0, 1], "weights": [0.1, -0.2], "eigenvalues": [5]}}"#,
        ),
        &good_in,
    );
    assert_clean_failure(&out, &["cw.json", "creep.weights", "(17)"], Some(&output));
    let out = run(
        &model(
            "ce.json",
            r#"{"sample_time": 0.0002, "hysteresis": {"thresholds": [0], "weights": [1]}, "creep": {"thresholds": [0], "weights": [0.1], "eigenvalues": [-5]}}"#,
        ),
        &good_in,
    );
    assert_clean_failure(&out, &["ce.json", "creep.eigenvalues[0]"], Some(&output));
    // inadmissible state
    let out = run(
        &model(
            "st.json",
            r#"{"sample_time": 0.0002, "hysteresis": {"thresholds": [0, 1], "weights": [1, 1], "state": [0, 3]}}"#,
        ),
        &good_in,
    );
    assert_clean_failure(&out, &["st.json", "hysteresis.state[1]"], Some(&output));

    // missing column
    let m = Path::new(MODEL);
    let out = run(m, &d.write("nocol.csv", "t,v\n0,1\n"));
    assert_clean_failure(&out, &["nocol.csv", "missing column 'u'"], Some(&output));
    // non-finite number, with its row
    let out = run(m, &d.write("nan.csv", "u\n0\n1\nNaN\n"));
    assert_clean_failure(&out, &["nan.csv", "row 3", "'u'"], Some(&output));
    let out = run(m, &d.write("txt.csv", "u\n0\nabc\n"));
    assert_clean_failure(&out, &["txt.csv", "row 2", "not a number"], Some(&output));
    // ragged row
    let out = run(m, &d.write("ragged.csv", "t,u\n0,1\n0.0002\n"));
    assert_clean_failure(&out, &["ragged.csv"], Some(&output));
    // empty trace
    let out = run(m, &d.write("empty.csv", "u\n"));
    assert_clean_failure(&out, &["empty.csv", "no data rows"], Some(&output));
    // time column not at the model's sample time
    let out = run(m, &d.write("time.csv", "t,u\n0,0\n0.0002,1\n0.0005,2\n"));
    assert_clean_failure(
        &out,
        &["time.csv", "row 3", "'t'", "mean step"],
        Some(&output),
    );
    // output column already present
    let out = run(m, &d.write("dup.csv", "u,y\n0,0\n"));
    assert_clean_failure(&out, &["dup.csv", "'y'"], Some(&output));
    // compensate: bad limits and missing y_d
    let out = on_files(
        "compensate",
        MODEL,
        s(&good_in),
        s(&output),
        &["--limits=5,1"],
    );
    assert_clean_failure(&out, &["--limits", "must be below"], Some(&output));
    // no limits has one spelling: --no-limits
    let out = on_files(
        "compensate",
        MODEL,
        s(&good_in),
        s(&output),
        &["--limits=-inf,inf"],
    );
    assert_clean_failure(&out, &["--limits", "--no-limits"], Some(&output));
    let out = on_files(
        "compensate",
        MODEL,
        s(&good_in),
        s(&output),
        &["--limits=-1,1", "--no-limits"],
    );
    assert_clean_failure(&out, &["--no-limits"], Some(&output));
    let out = on_files("compensate", MODEL, s(&good_in), s(&output), &[]);
    assert_clean_failure(&out, &["in.csv", "missing column 'y_d'"], Some(&output));
}

#[test]
fn an_existing_output_file_survives_a_failed_run() {
    let d = TempDir::new("keep");
    let output = d.write("out.csv", "previous content\n");
    let input = d.write("nan.csv", "u\n0\ninf\n");
    let out = on_files("simulate", MODEL, s(&input), s(&output), &[]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(fs::read_to_string(&output).unwrap(), "previous content\n");
}

/// The paper's identification input (`signal`, 4 shrinking periods of
/// 1000 V) at `sig` and the nominal model's noise-free output on it at
/// `data`.
fn nominal_record(sig: &Path, data: &Path) {
    for out in [
        mfcbeam(&[
            "signal",
            "--periods",
            "4",
            "--amplitude",
            "1000",
            "--plateau",
            "0.1",
            "--output",
            s(sig),
        ]),
        on_files("simulate", MODEL, s(sig), s(data), &[]),
    ] {
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

#[test]
fn identify_round_trip_recovers_a_model_that_compensates() {
    let d = TempDir::new("identify");
    let sig = d.path("sig.csv");
    let data = d.path("data.csv");
    let model = d.path("model.json");
    let ok = |out: Output| {
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        )
    };
    nominal_record(&sig, &data);
    let out = mfcbeam(&["identify", "--input", s(&data), "--output", s(&model)]);
    ok(out.clone());
    let report = String::from_utf8_lossy(&out.stderr);
    assert!(
        report.contains("rms error") && report.contains("cond(Phi)"),
        "{report}"
    );
    let id = mfcbeam::io::read_model(&model).unwrap();
    for (a, b) in id
        .hysteresis()
        .weights()
        .iter()
        .zip(mfcbeam::operators::nominal::HYSTERESIS_WEIGHTS)
    {
        assert!(((a - b) / b).abs() < 1e-6, "{a} vs {b}");
    }
    assert!(mfcbeam::io::read_model_file(&model)
        .unwrap()
        .hysteresis
        .state
        .is_none());
    // explicit orders and thresholds parse
    let out = mfcbeam(&[
        "identify",
        "--input",
        s(&data),
        "--output",
        s(&d.path("m2.json")),
        "--hysteresis-thresholds",
        "0,250,500,750",
        "--creep-operators",
        "0",
        "--epsilon-h",
        "0.01",
    ]);
    ok(out);
    let m2 = mfcbeam::io::read_model(&d.path("m2.json")).unwrap();
    assert_eq!(m2.hysteresis().thresholds(), &[0.0, 250.0, 500.0, 750.0]);
    assert!(m2.creep().is_none());
    // the creep penalty, chosen by GCV, is reported
    let out = mfcbeam(&[
        "identify",
        "--input",
        s(&data),
        "--output",
        s(&d.path("m3.json")),
        "--creep-regularisation",
        "gcv",
    ]);
    ok(out.clone());
    let report = String::from_utf8_lossy(&out.stderr);
    assert!(report.contains("creep penalty        λ = "), "{report}");
}

#[test]
fn identify_error_contract() {
    let d = TempDir::new("identify-errors");
    let output = d.path("m.json");
    let run = |input: &Path, extra: &[&str]| {
        let mut args = vec!["identify", "--input", s(input), "--output", s(&output)];
        args.extend_from_slice(extra);
        mfcbeam(&args)
    };
    let rows = |n: usize, f: &dyn Fn(usize) -> String| -> String {
        let mut t = String::from("t,u,y\n");
        for k in 0..n {
            t.push_str(&f(k));
            t.push('\n');
        }
        t
    };
    let few = d.write(
        "few.csv",
        &rows(10, &|k| format!("{},{},{}", k as f64 * 2e-4, k, k)),
    );
    assert_clean_failure(
        &run(&few, &[]),
        &["few.csv", "too few samples"],
        Some(&output),
    );
    let constant = d.write(
        "const.csv",
        &rows(200, &|k| format!("{},5,{}", k as f64 * 2e-4, k)),
    );
    assert_clean_failure(
        &run(&constant, &[]),
        &["const.csv", "constant"],
        Some(&output),
    );
    for bad in ["ridge", "-1", "NaN"] {
        assert_clean_failure(
            &run(&few, &["--creep-regularisation", bad]),
            &["--creep-regularisation", bad],
            Some(&output),
        );
    }
    let no_t = d.write("not.csv", "u,y\n0,0\n1,1\n");
    assert_clean_failure(
        &run(&no_t, &[]),
        &["not.csv", "missing column 't'"],
        Some(&output),
    );
    let uneven = d.write(
        "uneven.csv",
        &rows(200, &|k| {
            format!("{},{},{}", (k * k) as f64 * 1e-4, k % 7, k)
        }),
    );
    assert_clean_failure(
        &run(&uneven, &[]),
        &["uneven.csv", "'t'", "mean step"],
        Some(&output),
    );
    let nan = d.write(
        "nan.csv",
        &rows(200, &|k| {
            format!(
                "{},{},{}",
                k as f64 * 2e-4,
                k % 7,
                if k == 150 {
                    "nan".into()
                } else {
                    k.to_string()
                }
            )
        }),
    );
    assert_clean_failure(
        &run(&nan, &[]),
        &["nan.csv", "row 151", "'y'"],
        Some(&output),
    );
    let good = d.write(
        "good.csv",
        &rows(400, &|k| {
            format!("{},{},{}", k as f64 * 2e-4, (k % 37) as f64 - 18.0, k % 37)
        }),
    );
    assert_clean_failure(
        &run(&good, &["--sample-time", "-1"]),
        &["--sample-time"],
        Some(&output),
    );
    assert_clean_failure(
        &run(&good, &["--hysteresis-thresholds", "0,2,1"]),
        &["hysteresis_thresholds"],
        Some(&output),
    );
    assert_clean_failure(
        &run(&good, &["--epsilon-h", "0"]),
        &["--epsilon-h"],
        Some(&output),
    );
}

/// Several records: each bad one named, with one line and exit 2.
#[test]
fn identify_several_records_error_contract() {
    let d = TempDir::new("identify-records");
    let output = d.path("m.json");
    let rows = |n: usize, ts: f64| -> String {
        let mut t = String::from("t,u,y\n");
        for k in 0..n {
            let u = (k % 37) as f64 - 18.0;
            t.push_str(&format!("{},{u},{}\n", k as f64 * ts, 0.5 * u));
        }
        t
    };
    let a = d.write("a.csv", &rows(400, 2e-4));
    let b = d.write("b.csv", &rows(300, 2e-4));
    let fast = d.write("fast.csv", &rows(400, 1e-4));
    let run = |extra: &[&str]| {
        let mut args = vec!["identify", "--output", s(&output), "--creep-operators", "0"];
        args.extend_from_slice(extra);
        mfcbeam(&args)
    };
    // a record at another sample time
    assert_clean_failure(
        &run(&["--input", s(&a), "--input", s(&fast)]),
        &["fast.csv", "'t'"],
        Some(&output),
    );
    // a record too short for its --fit-from
    assert_clean_failure(
        &run(&["--input", s(&a), "--input", s(&b), "--fit-from", "350"]),
        &["--fit-from", "b.csv", "beyond"],
        Some(&output),
    );
    // a zeroing stretch outside a validation record
    assert_clean_failure(
        &run(&[
            "--input",
            s(&a),
            "--validate",
            s(&b),
            "--validate-zero",
            "1.0s..1.5s",
        ]),
        &["--validate-zero", "b.csv"],
        Some(&output),
    );
    assert_clean_failure(
        &run(&["--input", s(&a), "--input", s(&b), "--holdout", "0.1"]),
        &["--holdout"],
        Some(&output),
    );
    assert_clean_failure(
        &run(&["--input", s(&a), "--offset", "each"]),
        &["--offset"],
        Some(&output),
    );
    assert_clean_failure(
        &run(&["--input", s(&a), "--dynamics", "spring"]),
        &["--dynamics"],
        Some(&output),
    );
    assert_clean_failure(
        &run(&[
            "--input",
            s(&a),
            "--thresholds",
            "reversals",
            "--hysteresis-thresholds",
            "0,1,2",
        ]),
        &["--thresholds reversals"],
        Some(&output),
    );
    // and the good case: both records, their own offsets, a table of both
    let out = run(&[
        "--input",
        s(&a),
        "--input",
        s(&b),
        "--offset",
        "per-record",
        "--fit-from",
        "0",
        "--validate",
        s(&a),
        "--validate-zero",
        "0..100",
        "--thresholds",
        "reversals",
    ]);
    let report = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{report}");
    for needle in [
        "offset of",
        "a.csv",
        "b.csv",
        "zero offset",
        "first record's offset",
        "minor loops",
    ] {
        assert!(report.contains(needle), "{needle}: {report}");
    }
}

const BEAM: &str = "golden/nominal_beam.json";

#[test]
fn beam_modes_prints_frequencies_and_static_gain() {
    for (model, f1) in [("modal", 12.1887), ("ritz", 12.7112)] {
        let out = mfcbeam(&["beam", "modes", "--beam", BEAM, "--beam-model", model]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let f = v["frequencies_hz"].as_array().unwrap();
        assert_eq!(f.len(), 15);
        assert!(
            (f[0].as_f64().unwrap() - f1).abs() < 1e-4,
            "{model}: {}",
            f[0]
        );
        let g = v["static_gain"].as_f64().unwrap();
        let exact = mfcbeam::beam::BeamParameters::nominal().exact_static_gain();
        assert!(((g - exact) / exact).abs() < 0.07);
    }
    // a closed pipe is not a panic
    let mut child = Command::new(env!("CARGO_BIN_EXE_mfcbeam"))
        .args(["beam", "modes", "--beam", BEAM])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
}

#[test]
fn beam_simulate_and_identify_round_trip() {
    let d = TempDir::new("beam");
    let mut text = String::from("t,u\n");
    for k in 0..3000 {
        text.push_str(&format!(
            "{},{}\n",
            k as f64 * 2e-4,
            if k < 100 { 0.0 } else { 50.0 }
        ));
    }
    let input = d.write("step.csv", &text);
    let sim = d.path("sim.csv");
    let ok = |out: Output| {
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        )
    };
    ok(mfcbeam(&[
        "beam",
        "simulate",
        "--beam",
        BEAM,
        "--input",
        s(&input),
        "--output",
        s(&sim),
        "--elements",
        "60",
    ]));
    let t = Trace::read(&sim).unwrap();
    assert_eq!(t.header(), &["t", "u", "y"]);
    let y = t.column("y").unwrap();
    assert_eq!(y[0], 0.0);
    let g = 50.0 * mfcbeam::beam::BeamParameters::nominal().exact_static_gain();
    assert!(y.iter().any(|&v| v > g), "overshoot expected");
    // fit E and Γ_p from a start 10 % off
    let mut start = mfcbeam::beam::BeamParameters::nominal();
    start.youngs_modulus *= 1.1;
    start.patch.input_gain *= 0.9;
    let start_path = d.write("start.json", &serde_json::to_string(&start).unwrap());
    let fitted = d.path("fitted.json");
    let out = mfcbeam(&[
        "beam",
        "identify",
        "--beam",
        s(&start_path),
        "--input",
        s(&sim),
        "--fit",
        "youngs_modulus,patch.input_gain",
        "--output",
        s(&fitted),
        "--elements",
        "60",
    ]);
    let report = String::from_utf8_lossy(&out.stderr).to_string();
    ok(out);
    assert!(
        report.contains("std. error") && report.contains("rms residual"),
        "{report}"
    );
    let b = mfcbeam::io::read_beam(&fitted).unwrap();
    assert!((b.youngs_modulus / 22e9 - 1.0).abs() < 1e-6);
    assert!((b.patch.input_gain / 8.7e-5 - 1.0).abs() < 1e-6);
    // refusals
    let out = mfcbeam(&[
        "beam", "identify", "--beam", BEAM, "--input", s(&sim), "--fit", "density,youngs_modulus,patch.density,patch.stiffness,viscous_damping,patch.viscous_damping,kelvin_voigt_damping,patch.kelvin_voigt_damping,patch.input_gain",
        "--output", s(&d.path("bad.json")), "--elements", "60",
    ]);
    assert_clean_failure(
        &out,
        &["sim.csv", "not identifiable", "patch.input_gain"],
        Some(&d.path("bad.json")),
    );
    let out = mfcbeam(&[
        "beam",
        "identify",
        "--beam",
        BEAM,
        "--input",
        s(&sim),
        "--fit",
        "colour",
        "--output",
        s(&d.path("bad.json")),
    ]);
    assert_clean_failure(
        &out,
        &["--fit", "unknown parameter 'colour'"],
        Some(&d.path("bad.json")),
    );
    let bad_beam = d.write(
        "badbeam.json",
        &BEAM_TEXT.replace(
            "\"youngs_modulus\": 22000000000.0",
            "\"youngs_modulus\": -1",
        ),
    );
    let out = mfcbeam(&["beam", "modes", "--beam", s(&bad_beam)]);
    assert_clean_failure(&out, &["badbeam.json", "youngs_modulus"], None);
}

const BEAM_TEXT: &str = include_str!("../golden/nominal_beam.json");

#[test]
fn feedforward_writes_the_paper_case() {
    let d = TempDir::new("feedforward");
    let out_path = d.path("ff.csv");
    let out = mfcbeam(&[
        "feedforward",
        "--beam",
        BEAM,
        "--model",
        MODEL,
        "--start",
        "2.9",
        "--duration",
        "0.075",
        "--y-final",
        "0.001",
        "--sigma",
        "1.1",
        "--end",
        "4",
        "--output",
        s(&out_path),
        "--elements",
        "120",
    ]);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("peak |u_d|") && err.contains("inside the supply range"),
        "{err}"
    );
    let t = Trace::read(&out_path).unwrap();
    assert_eq!(
        t.header(),
        &["t", "y_d", "u_d", "u", "u_fs", "u_bs", "saturated"]
    );
    assert_eq!(t.len(), 20001);
    let y = t.column("y_d").unwrap();
    assert_eq!(y[0], 0.0);
    assert!((y[20000] - 1e-3).abs() < 1e-15);
    let (ufs, ubs) = (t.column("u_fs").unwrap(), t.column("u_bs").unwrap());
    assert!(ufs
        .iter()
        .chain(&ubs)
        .all(|&v| (-500.0..=1500.0).contains(&v)));
    // without a model: only t, y_d, u_d; ritz design
    let out = mfcbeam(&[
        "feedforward",
        "--beam",
        BEAM,
        "--beam-model",
        "ritz",
        "--output",
        s(&out_path),
    ]);
    assert!(out.status.success());
    assert_eq!(
        Trace::read(&out_path).unwrap().header(),
        &["t", "y_d", "u_d"]
    );
    // a move too fast for the supply saturates, with a warning
    let out = mfcbeam(&[
        "feedforward",
        "--beam",
        BEAM,
        "--model",
        MODEL,
        "--duration",
        "0.034",
        "--output",
        s(&out_path),
        "--elements",
        "120",
    ]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("warning"));
    assert!(Trace::read(&out_path)
        .unwrap()
        .column("saturated")
        .unwrap()
        .contains(&1.0));
    // bad settings
    let bad = d.path("bad.csv");
    let out = mfcbeam(&[
        "feedforward",
        "--beam",
        BEAM,
        "--duration",
        "0",
        "--output",
        s(&bad),
    ]);
    assert_clean_failure(&out, &["duration"], Some(&bad));
    let out = mfcbeam(&[
        "feedforward",
        "--beam",
        BEAM,
        "--sigma",
        "-1",
        "--output",
        s(&bad),
    ]);
    assert_clean_failure(&out, &["sigma"], Some(&bad));
}

#[test]
fn verify_passes_an_exact_candidate_and_fails_a_perturbed_one() {
    let d = TempDir::new("verify");
    let golden = "golden/compensated.csv";
    // an exact candidate: the golden file itself, and the full-rate scenario
    let out = mfcbeam(&["verify", "--golden", golden, "--candidate", golden]);
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert!(
        text.contains("all within tolerance") && text.contains("max abs"),
        "{text}"
    );
    let full = d.path("full.csv");
    assert!(
        mfcbeam(&["scenario", "compensated", "--full", "--output", s(&full)])
            .status
            .success()
    );
    let out = mfcbeam(&["verify", "--golden", golden, "--candidate", s(&full)]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    // a C port that only produces u from y_d, perturbed by 1e-6 V at one row
    let t = Trace::read(Path::new(golden)).unwrap();
    let (tt, yd, mut u) = (
        t.column("t").unwrap(),
        t.column("y_d").unwrap(),
        t.column("u").unwrap(),
    );
    u[100] += 1e-6;
    let cand = d.path("port.csv");
    Trace::from_columns(&cand, &[("t", &tt), ("y_d", &yd), ("u", &u)])
        .write(&cand)
        .unwrap();
    let out = mfcbeam(&["verify", "--golden", golden, "--candidate", s(&cand)]);
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(
        text.contains("FAIL (first at row 101)") && text.contains("not in candidate"),
        "{text}"
    );
    // wrong length and no common column are errors (exit 2), not verdicts
    let short = d.write("short.csv", "t,u\n0,0\n");
    assert_clean_failure(
        &mfcbeam(&["verify", "--golden", golden, "--candidate", s(&short)]),
        &["short.csv", "rows"],
        None,
    );
    let other = d.write("other.csv", &format!("x\n{}", "1\n".repeat(t.len())));
    assert_clean_failure(
        &mfcbeam(&["verify", "--golden", golden, "--candidate", s(&other)]),
        &["shares no column"],
        None,
    );
}

#[test]
fn golden_check_passes_on_the_committed_files() {
    let out = mfcbeam(&["golden", "--check"]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = mfcbeam(&["scenario", "nonsense", "--output", "/dev/null"]);
    assert_clean_failure(&out, &["unknown", "rectangle"], None);
}

#[test]
fn reproduce_writes_traces_plots_and_a_summary_where_every_claim_holds() {
    let d = TempDir::new("reproduce");
    let out = mfcbeam(&["reproduce", "--out", s(&d.0)]);
    let table = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "{table}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        table.contains("| Fig. 14 |") && !table.contains("| NO |"),
        "{table}"
    );
    for s in mfcbeam::suite::scenarios::SCENARIOS {
        assert!(d.path(&format!("traces/{}.csv", s.id)).exists());
        for ext in ["svg", "png"] {
            let p = d.path(&format!("plots/{}.{ext}", s.id));
            assert!(
                fs::metadata(&p).map(|m| m.len() > 1000).unwrap_or(false),
                "{}",
                p.display()
            );
        }
    }
    assert!(fs::read_to_string(d.path("summary.md"))
        .unwrap()
        .contains("holds"));
}

/// Lab data: a jittered time column is accepted (its mean step is the sample
/// time); a non-increasing one, a repeated column name, a computed
/// non-finite output and bad identify options each end in exit 2 and one
/// line naming the file, row or option — and no output file.
#[test]
fn lab_data_inputs_are_accepted_or_refused_with_one_line() {
    let d = TempDir::new("lab-inputs");
    let output = d.path("out.csv");
    // jitter of up to 2e-4 of a step: accepted
    let jittered: String = std::iter::once("t,u".to_string())
        .chain((0..100).map(|k| {
            let jitter = if k % 2 == 0 { 2e-8 } else { -2e-8 };
            format!("{:?},{}", k as f64 * 2e-4 + jitter, k)
        }))
        .collect::<Vec<_>>()
        .join("\n");
    let input = d.write("jitter.csv", &jittered);
    let out = on_files("simulate", MODEL, s(&input), s(&output), &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    fs::remove_file(&output).unwrap();
    // time going backwards
    let back = d.write("back.csv", "t,u\n0,0\n0.0002,1\n0.0001,2\n0.0003,3\n");
    let out = on_files("simulate", MODEL, s(&back), s(&output), &[]);
    assert_clean_failure(
        &out,
        &["back.csv", "row 3", "'t'", "does not increase"],
        Some(&output),
    );
    // a repeated column name
    let dup = d.write("dupcol.csv", "u,x,u\n1,2,3\n");
    let out = on_files("simulate", MODEL, s(&dup), s(&output), &[]);
    assert_clean_failure(&out, &["dupcol.csv", "'u'", "repeats"], Some(&output));
    // targets no voltage can reach without limits: the output would not be finite
    let huge = d.write("huge.csv", "y_d\n0\n1e308\n-1e308\n");
    let out = on_files("compensate", MODEL, s(&huge), s(&output), &["--no-limits"]);
    assert_clean_failure(&out, &["row 2", "'u'", "non-finite"], Some(&output));
    // invert shows the model's offset, which the compensator subtracts
    let mut file: ModelFile = serde_json::from_str(&fs::read_to_string(MODEL).unwrap()).unwrap();
    file.offset = Some(12.5);
    let with_offset = d.write("offset.json", &serde_json::to_string(&file).unwrap());
    let out = mfcbeam(&["invert", "--model", s(&with_offset)]);
    assert!(out.status.success());
    let inv: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(inv["offset"], 12.5);
    // identify options
    let sig = d.path("sig.csv");
    assert!(mfcbeam(&[
        "signal",
        "--output",
        s(&sig),
        "--periods",
        "2",
        "--plateau",
        "0.05"
    ])
    .status
    .success());
    let lab = d.path("lab.csv");
    let sim = on_files("simulate", MODEL, s(&sig), s(&lab), &[]);
    assert!(sim.status.success());
    let model_out = d.path("m.json");
    for (args, needle) in [
        (vec!["--holdout", "1.5"], "--holdout"),
        (vec!["--plot", "fit.txt"], "--plot"),
        (vec!["--fit-from", "99999999"], "fit_from"),
    ] {
        let mut all = vec!["identify", "--input", s(&lab), "--output", s(&model_out)];
        all.extend(args);
        assert_clean_failure(&mfcbeam(&all), &[needle], Some(&model_out));
    }
}

/// The nominal model with an asymmetric superposition operator, as a file.
fn asymmetric_model(d: &TempDir) -> PathBuf {
    let mut file = mfcbeam::io::read_model_file(Path::new(MODEL)).unwrap();
    file.superposition = Some(mfcbeam::operators::model::SuperpositionData {
        thresholds: vec![-500.0, -200.0, 0.0, 150.0, 400.0],
        weights: vec![0.25, -0.25, 1.0, -0.2, -0.15],
    });
    file.offset = Some(3.0);
    let p = d.path("asym.json");
    fs::write(&p, serde_json::to_string(&file).unwrap()).unwrap();
    p
}

#[test]
fn a_model_with_a_superposition_operator_runs_through_every_command() {
    let d = TempDir::new("superposition");
    let model = asymmetric_model(&d);
    let ok = |out: Output| {
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(out.status.success(), "{err}");
        err
    };
    // invert: S⁻¹ by its rules, its kinks at S(r_i)
    let out = mfcbeam(&["invert", "--model", s(&model)]);
    ok(out.clone());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let kinks: Vec<f64> = v["inverse_superposition"]["thresholds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(kinks, [-425.0, -200.0, 0.0, 150.0, 350.0]);
    // simulate equals the library bit for bit; compensate then simulate is
    // the identity
    let sig = d.path("sig.csv");
    ok(mfcbeam(&[
        "signal",
        "--periods",
        "3",
        "--amplitude",
        "900",
        "--plateau",
        "0.1",
        "--output",
        s(&sig),
    ]));
    let data = d.path("data.csv");
    ok(on_files("simulate", s(&model), s(&sig), s(&data), &[]));
    let trace = Trace::read(&data).unwrap();
    let (u, y) = (trace.column("u").unwrap(), trace.column("y").unwrap());
    let w = mfcbeam::io::read_model(&model).unwrap();
    assert_eq!(w.clone().run(&u), y);
    let targets = d.path("targets.csv");
    let t: Vec<f64> = u.iter().map(|x| 0.5 * x).collect();
    let text: String = std::iter::once("y_d\n".to_string())
        .chain(t.iter().map(|x| format!("{x:?}\n")))
        .collect();
    fs::write(&targets, text).unwrap();
    let comp = d.path("comp.csv");
    ok(on_files(
        "compensate",
        s(&model),
        s(&targets),
        s(&comp),
        &["--no-limits"],
    ));
    let uc = Trace::read(&comp).unwrap().column("u").unwrap();
    let back = w.clone().run(&uc);
    let worst = back
        .iter()
        .zip(&t)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-9, "{worst}");
    // identify with and without S: S is reported, and fits better
    let fit = |m: &str| {
        let out_model = d.path(&format!("id{m}.json"));
        let report = ok(mfcbeam(&[
            "identify",
            "--input",
            s(&data),
            "--output",
            s(&out_model),
            "--superposition",
            m,
        ]));
        let rms = common::report_rms(&report);
        (
            report,
            rms,
            mfcbeam::io::read_model_file(&out_model).unwrap(),
        )
    };
    let (_, rms0, file0) = fit("0");
    let (report2, rms2, file2) = fit("2");
    assert!(file0.superposition.is_none());
    assert_eq!(file2.superposition.as_ref().unwrap().thresholds.len(), 5);
    assert!(report2.contains("superposition S"), "{report2}");
    assert!(rms2 < 0.5 * rms0, "{rms2} vs {rms0}");
    // a decreasing S: exit 2, one line naming the field
    let mut bad = mfcbeam::io::read_model_file(&model).unwrap();
    bad.superposition.as_mut().unwrap().weights[3] = -1.5;
    simulate_refuses(&d, &bad, &sig, "superposition.weights");
    // kinks outside the output's range are refused by name
    let out = mfcbeam(&[
        "identify",
        "--input",
        s(&data),
        "--output",
        s(&d.path("x.json")),
        "--superposition-kinks=1e6",
    ]);
    assert_clean_failure(&out, &["superposition_kinks"], None);
}

/// The asymmetric nominal model with a dead time of `delay` samples.
fn delayed_model(d: &TempDir, delay: usize) -> PathBuf {
    let mut file = mfcbeam::io::read_model_file(&asymmetric_model(d)).unwrap();
    file.delay = Some(delay);
    let p = d.path(&format!("delay{delay}.json"));
    fs::write(&p, serde_json::to_string(&file).unwrap()).unwrap();
    p
}

/// `simulate` shifts the output by the dead time; `compensate` previews the
/// target by it, so that `W[W⁻¹[y_d]] = y_d` from sample `d` on;
/// `feedforward --model` does the same for the planned `u_d`; `identify
/// --delay auto` finds it on a faster validation record and prints the
/// table of every candidate; bad values exit 2 with one line.
#[test]
fn a_model_with_a_dead_time_runs_through_every_command() {
    let d = TempDir::new("delay");
    let ok = |out: Output| {
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(out.status.success(), "{err}");
        err
    };
    let (m0, m3) = (asymmetric_model(&d), delayed_model(&d, 3));
    let sig = d.path("sig.csv");
    ok(mfcbeam(&[
        "signal",
        "--periods",
        "2",
        "--amplitude",
        "900",
        "--plateau",
        "0.05",
        "--output",
        s(&sig),
    ]));
    let run = |model: &Path, name: &str| {
        let out = d.path(name);
        ok(on_files("simulate", s(model), s(&sig), s(&out), &[]));
        Trace::read(&out).unwrap().column("y").unwrap()
    };
    let (y0, y3) = (run(&m0, "y0.csv"), run(&m3, "y3.csv"));
    let shifted: Vec<f64> = (0..y0.len()).map(|k| y0[k.saturating_sub(3)]).collect();
    assert_eq!(y3, shifted);

    // compensate: the identity from sample 3 on, to 1e-9 of the range
    let u = Trace::read(&sig).unwrap().column("u").unwrap();
    let t: Vec<f64> = u.iter().map(|x| 0.5 * x + 3.0).collect();
    let targets = d.path("targets.csv");
    Trace::from_columns(&targets, &[("y_d", &t)])
        .write(&targets)
        .unwrap();
    let comp = d.path("comp.csv");
    ok(on_files(
        "compensate",
        s(&m3),
        s(&targets),
        s(&comp),
        &["--no-limits"],
    ));
    let uc = Trace::read(&comp).unwrap().column("u").unwrap();
    let back = mfcbeam::io::read_model(&m3).unwrap().run(&uc);
    let range = common::range(&t);
    let worst = (3..t.len())
        .map(|k| (back[k] - t[k]).abs())
        .fold(0.0, f64::max);
    assert!(worst <= 1e-9 * range, "{worst}");

    // feedforward --model: W[u] = u_d from sample 3 on
    let ff = d.path("ff.csv");
    ok(mfcbeam(&[
        "feedforward",
        "--beam",
        BEAM,
        "--model",
        s(&m3),
        "--start",
        "0.1",
        "--duration",
        "0.075",
        "--y-final",
        "0.001",
        "--end",
        "0.3",
        "--output",
        s(&ff),
        "--elements",
        "60",
    ]));
    let tr = Trace::read(&ff).unwrap();
    let (u_d, u_ff) = (tr.column("u_d").unwrap(), tr.column("u").unwrap());
    let w = mfcbeam::io::read_model(&m3).unwrap().run(&u_ff);
    let worst = (3..u_d.len())
        .map(|k| (w[k] - u_d[k]).abs())
        .fold(0.0, f64::max);
    assert!(worst <= 1e-9 * common::range(&u_d), "{worst}");

    // identify --delay auto: a 100 Hz record tells the dead time
    let record = |rate: &str, name: &str| {
        let sig = d.path(&format!("sig{name}"));
        ok(mfcbeam(&[
            "signal",
            "--periods",
            "4",
            "--amplitude",
            "900",
            "--plateau",
            "0.001",
            "--rise",
            rate,
            "--output",
            s(&sig),
        ]));
        let data = d.path(name);
        ok(on_files("simulate", s(&m3), s(&sig), s(&data), &[]));
        data
    };
    let (slow, fast) = (record("0.05", "slow.csv"), record("0.005", "fast.csv"));
    let out_model = d.path("id.json");
    let report = ok(mfcbeam(&[
        "identify",
        "--input",
        s(&slow),
        "--output",
        s(&out_model),
        "--superposition",
        "2",
        "--creep-operators",
        "0",
        "--delay",
        "auto",
        "--max-delay",
        "5",
        "--validate",
        s(&fast),
    ]));
    assert!(report.contains("dead time (samples)"), "{report}");
    assert!(
        report.contains("dead time chosen     3 samples, by the validation records"),
        "{report}"
    );
    let table: Vec<&str> = report
        .lines()
        .skip_while(|l| !l.starts_with("dead time (samples)"))
        .skip(1)
        .take(6)
        .collect();
    assert!(table[3].starts_with('*'), "{report}");
    assert_eq!(
        mfcbeam::io::read_model_file(&out_model).unwrap().delay,
        Some(3)
    );
    // a fixed dead time is taken as given
    let report = ok(mfcbeam(&[
        "identify",
        "--input",
        s(&slow),
        "--output",
        s(&out_model),
        "--creep-operators",
        "0",
        "--delay",
        "2",
    ]));
    assert!(
        report.contains("dead time            2 samples"),
        "{report}"
    );
    assert!(!report.contains("dead time chosen"), "{report}");

    // bad values: exit 2, one line
    let never = d.path("never.json");
    let out = mfcbeam(&[
        "identify",
        "--input",
        s(&slow),
        "--output",
        s(&never),
        "--delay",
        "soon",
    ]);
    assert_clean_failure(&out, &["--delay", "soon"], Some(&never));
    let mut bad = mfcbeam::io::read_model_file(&m3).unwrap();
    bad.delay_state = Some(vec![1.0]);
    simulate_refuses(&d, &bad, &sig, "delay_state");
}

/// `simulate` with the model file `bad` exits 2 with one line naming the
/// file and `field`, and writes nothing.
fn simulate_refuses(
    d: &TempDir,
    bad: &mfcbeam::operators::model::ModelFile,
    sig: &Path,
    field: &str,
) {
    let bad_path = d.path("bad.json");
    fs::write(&bad_path, serde_json::to_string(bad).unwrap()).unwrap();
    let never = d.path("never.csv");
    let out = on_files("simulate", s(&bad_path), s(sig), s(&never), &[]);
    assert_clean_failure(&out, &["bad.json", field], Some(&never));
}

/// The score table's rows of `controller` (without the name column).
fn score_rows(table: &str, controller: &str) -> Vec<String> {
    table
        .lines()
        .filter(|l| l.split('|').nth(2).map(str::trim) == Some(controller))
        .map(|l| {
            let cells: Vec<&str> = l.split('|').collect();
            format!("{}|{}", cells[1], cells[3..].join("|"))
        })
        .collect()
}

#[test]
fn benchmark_control_with_a_zero_program_is_the_open_loop_exactly() {
    let zero = "sh -c 'while read l; do echo 0; done'";
    let out = mfcbeam(&["benchmark-control", "--exec", zero]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = String::from_utf8(out.stdout).unwrap();
    let open = score_rows(&table, "open loop");
    let program = score_rows(&table, "sh -c while read l; do echo 0; done");
    assert_eq!(open.len(), 5, "{table}");
    // every score but the compute time (the program's is a pipe round trip)
    let strip = |rows: Vec<String>| -> Vec<String> {
        rows.into_iter()
            .map(|r| {
                r.rsplit_once('|')
                    .unwrap()
                    .0
                    .rsplit_once('|')
                    .unwrap()
                    .0
                    .to_string()
            })
            .collect()
    };
    assert_eq!(strip(open), strip(program), "{table}");
}

#[test]
fn benchmark_control_writes_traces_plots_and_the_table() {
    let d = TempDir::new("benchmark-control");
    let out = mfcbeam(&[
        "benchmark-control",
        "--controller",
        "pid",
        "--scenario",
        "step-load",
        "--output-dir",
        s(&d.0),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in [
        "step-load-open.csv",
        "step-load-pid.csv",
        "step-load.png",
        "step-load.svg",
        "scores.md",
    ] {
        assert!(d.path(f).exists(), "{f}");
    }
    let tr = Trace::read(&d.path("step-load-pid.csv")).unwrap();
    let (tip, r) = (tr.column("tip").unwrap(), tr.column("reference").unwrap());
    let k = tip.len() - 1;
    assert!(
        (tip[k] - r[k]).abs() < 1e-7,
        "the PID's integral removes the load"
    );
    let table = fs::read_to_string(d.path("scores.md")).unwrap();
    assert_eq!(table, String::from_utf8(out.stdout).unwrap());
    assert!(table.contains("| step-load | PID |"), "{table}");
}

#[test]
fn benchmark_control_names_a_controller_that_fails() {
    let cases: [(&[&str], &[&str]); 7] = [
        // answers without reading: its input pipe fills, the writing is
        // bounded by the timeout as the reading is
        (
            &["--exec", "yes 0", "--timeout", "1"],
            &["did not take its input within 1 s"],
        ),
        // closes its output and runs on: reported as such, then killed
        (
            &["--exec", "sh -c 'exec 1>&-; sleep 31.25'", "--timeout", "1"],
            &[
                "at sample 0",
                "closed its output without answering (still running)",
            ],
        ),
        (
            &["--exec", "sh -c 'read l; echo banana'"],
            &[
                "scenario nominal",
                "at sample 0",
                "'banana' is not a number",
            ],
        ),
        (
            &["--exec", "sh -c 'read l; echo 1; exit 4'"],
            &["at sample 1", "exited"],
        ),
        (
            &["--exec", "sh -c 'sleep 20'", "--timeout", "0.5"],
            &["at sample 0", "no answer within 0.5 s"],
        ),
        (&["--exec", "/nonexistent/ctl"], &["could not start"]),
        (
            &["--scenario", "earthquake"],
            &["--scenario", "earthquake", "step-load"],
        ),
    ];
    for (args, needles) in cases {
        let started = std::time::Instant::now();
        let mut all = vec!["benchmark-control"];
        all.extend_from_slice(args);
        assert_clean_failure(&mfcbeam(&all), needles, None);
        assert!(started.elapsed().as_secs() < 15, "{args:?} hung");
    }
    // nothing it started is left running (a zombie's command line is empty)
    let left: Vec<String> = fs::read_dir("/proc")
        .unwrap()
        .filter_map(|e| fs::read(e.ok()?.path().join("cmdline")).ok())
        .map(|c| String::from_utf8_lossy(&c).replace('\0', " "))
        .filter(|c| c.starts_with("sleep 31.25"))
        .collect();
    assert!(left.is_empty(), "left running: {left:?}");
    assert_clean_failure(
        &mfcbeam(&["benchmark-control", "--controller", "mpc"]),
        &["--controller 'mpc'"],
        None,
    );
}

#[test]
fn the_python_pid_example_is_the_built_in_pid_bit_for_bit() {
    // the guide shows this file's code, after its docstring
    let text = fs::read_to_string("examples/control/pid_controller.py").unwrap();
    let guide = fs::read_to_string("docs/guide/closed-loop.md").unwrap();
    let code = &text[text.find("import os").unwrap()..];
    assert!(
        guide.contains(&format!("```python\n{code}```")),
        "the guide's controller differs from the file"
    );
    // its gains are the rule's, to the last bit
    let line = text
        .lines()
        .find(|l| l.starts_with("KP, KI, KD, TF = "))
        .unwrap();
    let theirs: Vec<f64> = line["KP, KI, KD, TF = ".len()..]
        .split(',')
        .map(|x| x.trim().parse().unwrap())
        .collect();
    let b = mfcbeam::control::Benchmark::nominal().unwrap();
    let g = mfcbeam::control::pid::PidGains::design(&b.beam, &Default::default()).unwrap();
    assert_eq!(theirs, vec![g.kp, g.ki, g.kd, g.tf]);
    let d = TempDir::new("python-pid");
    let out = mfcbeam(&[
        "benchmark-control",
        "--controller",
        "pid",
        "--exec",
        "python3 examples/control/pid_controller.py",
        "--scenario",
        "impulse",
        "--scenario",
        "noise",
        "--output-dir",
        s(&d.0),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for id in ["impulse", "noise"] {
        let ours = Trace::read(&d.path(&format!("{id}-pid.csv"))).unwrap();
        let theirs = Trace::read(&d.path(&format!("{id}-program.csv"))).unwrap();
        for c in ["correction", "u", "tip"] {
            assert_eq!(
                ours.column(c).unwrap(),
                theirs.column(c).unwrap(),
                "{id}: {c}"
            );
        }
    }
}

#[test]
fn benchmark_control_takes_the_models_and_the_beam_from_files() {
    let d = TempDir::new("benchmark-files");
    let base = [
        "benchmark-control",
        "--controller",
        "lq",
        "--scenario",
        "step-load",
    ];
    let default = mfcbeam(&base);
    assert!(default.status.success());
    let strip = |o: &Output| -> Vec<String> {
        // the scores without the step times
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .map(|l| l.split('|').take(11).collect::<Vec<_>>().join("|"))
            .collect()
    };
    let same = mfcbeam(
        &[
            &base[..],
            &[
                "--model",
                MODEL,
                "--plant-model",
                MODEL,
                "--beam",
                "golden/nominal_beam.json",
            ],
        ]
        .concat(),
    );
    assert!(
        same.status.success(),
        "{}",
        String::from_utf8_lossy(&same.stderr)
    );
    assert_eq!(strip(&default), strip(&same));
    // a true W 10 % stronger: the loop still settles, the open loop does not
    let mut strong = nominal_model().to_file();
    strong.hysteresis.weights.iter_mut().for_each(|w| *w *= 1.1);
    let strong_path = d.write("strong.json", &serde_json::to_string(&strong).unwrap());
    let out = mfcbeam(&[&base[..], &["--plant-model", s(&strong_path)]].concat());
    assert!(out.status.success());
    assert_ne!(strip(&default), strip(&out));
    // a compensator model that needs a preview cannot be in a loop
    let mut delayed = nominal_model().to_file();
    delayed.delay = Some(3);
    let delayed_path = d.write("delayed.json", &serde_json::to_string(&delayed).unwrap());
    assert_clean_failure(
        &mfcbeam(&[&base[..], &["--model", s(&delayed_path)]].concat()),
        &["model", "preview of 3 samples"],
        None,
    );
    let mut slow = nominal_model().to_file();
    slow.sample_time = 1e-3;
    let slow_path = d.write("slow.json", &serde_json::to_string(&slow).unwrap());
    assert_clean_failure(
        &mfcbeam(&[&base[..], &["--plant-model", s(&slow_path)]].concat()),
        &["--plant-model", "sample time 0.001 s"],
        None,
    );
}

/// A record of the nominal model with a memory: a history (up to 900 V and
/// back to 0), a hold at 0 V (0.4 s), then two periods of a 2 Hz sine of
/// 300 V; noise-free. Returns the model file in the state the record
/// starts in.
fn record_with_a_past(path: &Path) -> ModelFile {
    let ts = mfcbeam::operators::nominal::SAMPLE_TIME;
    let mut m = nominal_model();
    for k in 0..=4000 {
        m.step(900.0 * (1.0 - (k as f64 - 2000.0).abs() / 2000.0));
    }
    let start = m.to_file();
    let u: Vec<f64> = (0..7000)
        .map(|k| {
            let t = k as f64 * ts - 0.4;
            if t < 0.0 {
                0.0
            } else {
                300.0 * (std::f64::consts::TAU * 2.0 * t).sin()
            }
        })
        .collect();
    let y = m.run(&u);
    let t: Vec<f64> = (0..u.len()).map(|k| k as f64 * ts).collect();
    Trace::from_owned_columns(path, vec![("t", t), ("u", u), ("y", y)])
        .write(path)
        .unwrap();
    start
}

/// `identify --fit-initial-state` on a record with a past: the rounds each
/// lower the RMS error over every sample, every sample is fitted, and the
/// model file stays virgin.
#[test]
fn identify_fits_the_initial_state_with_the_weights() {
    let d = TempDir::new("identify-initial-state");
    let record = d.path("record.csv");
    record_with_a_past(&record);
    let model = d.path("model.json");
    let run = mfcbeam(&[
        "identify",
        "--input",
        s(&record),
        "--output",
        s(&model),
        "--fit-initial-state",
    ]);
    let report = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{report}");
    let line = report
        .lines()
        .find(|l| l.starts_with("initial state        fitted with the weights in"))
        .unwrap_or_else(|| panic!("{report}"));
    let rms: Vec<f64> = line
        .rsplit("every sample ")
        .next()
        .unwrap()
        .split(" → ")
        .map(|x| x.parse().unwrap())
        .collect();
    assert!(rms.len() >= 2, "{line}");
    assert!(rms.windows(2).all(|w| w[1] < w[0]), "{line}");
    // the fit starts at the first sample (the ordinary one skips to max|u|)
    assert!(report.contains(" fitted: 0.."), "{report}");
    let file = mfcbeam::io::read_model_file(&model).unwrap();
    assert!(file.hysteresis.state.is_none());
}

#[test]
fn estimate_state_recovers_the_memory_a_record_starts_in() {
    let d = TempDir::new("estimate-state");
    let record = d.path("record.csv");
    let truth = record_with_a_past(&record);
    let (start, end) = (d.path("start.json"), d.path("end.json"));
    // the window: the hold and the sine's first period (samples 0..4500),
    // which moves every play the second one moves
    for (at, out) in [("start", &start), ("end", &end)] {
        let run = on_files(
            "estimate-state",
            MODEL,
            s(&record),
            s(out),
            &["--until", "0.9s", "--state-at", at],
        );
        let report = String::from_utf8_lossy(&run.stderr);
        assert!(run.status.success(), "{report}");
        assert!(report.contains("samples 0..4500"), "{report}");
    }
    let trace = Trace::read(&record).unwrap();
    let (u, y) = (trace.column("u").unwrap(), trace.column("y").unwrap());
    // from the estimated start, the model predicts the record after the
    // window; the virgin model does not
    let estimated = mfcbeam::io::read_model(&start).unwrap().run(&u);
    let virgin = nominal_model().run(&u);
    let error = |x: &[f64]| (4500..u.len()).fold(0.0f64, |m, k| m.max((x[k] - y[k]).abs()));
    assert!(error(&virgin) > 10.0, "{}", error(&virgin));
    assert!(
        error(&estimated) < 1e-2 * error(&virgin),
        "{}",
        error(&estimated)
    );
    // the play states the window shows are the truth's: those the sine
    // moves (thresholds up to 583 V); the others hold what the level asks
    let x = mfcbeam::io::read_model_file(&start)
        .unwrap()
        .hysteresis
        .state
        .unwrap();
    let x_true = truth.hysteresis.state.unwrap();
    for i in 0..=7 {
        assert!((x[i] - x_true[i]).abs() < 2.0, "{x:?} vs {x_true:?}");
    }
    // --state-at end: the estimated start run through the window
    let mut from_start = mfcbeam::io::read_model(&start).unwrap();
    from_start.run(&u[..4500]);
    let after = mfcbeam::io::read_model_file(&end).unwrap();
    assert_eq!(
        after.hysteresis.state,
        from_start.to_file().hysteresis.state
    );
}

#[test]
fn estimate_state_error_contract() {
    let d = TempDir::new("estimate-state-errors");
    let record = d.path("record.csv");
    record_with_a_past(&record);
    let out = d.path("out.json");
    for (until, needle) in [("0", "--until"), ("1", "--until"), ("9s", "--until")] {
        let run = on_files(
            "estimate-state",
            MODEL,
            s(&record),
            s(&out),
            &["--until", until],
        );
        assert_clean_failure(&run, &[needle], Some(&out));
    }
    let bad = d.write("bad.csv", "t,u,y\n0,0,0\n0.0002,nan,0\n0.0004,1,1\n");
    let run = on_files("estimate-state", MODEL, s(&bad), s(&out), &[]);
    assert_clean_failure(&run, &["bad.csv"], Some(&out));
    let no_y = d.write("no_y.csv", "t,u\n0,0\n0.0002,1\n");
    let run = on_files("estimate-state", MODEL, s(&no_y), s(&out), &[]);
    assert_clean_failure(&run, &["y"], Some(&out));
    let run = on_files("estimate-state", s(&no_y), s(&record), s(&out), &[]);
    assert_clean_failure(&run, &["no_y.csv"], Some(&out));
}

#[test]
fn identify_scores_a_record_with_a_past_after_its_estimated_state() {
    let d = TempDir::new("validate-state");
    let (sig, data, model) = (d.path("sig.csv"), d.path("data.csv"), d.path("m.json"));
    let record = d.path("record.csv");
    record_with_a_past(&record);
    let ok = |out: &Output| {
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        )
    };
    nominal_record(&sig, &data);
    // the validation row of record.csv: (from, rms)
    let row = |extra: &[&str]| -> (usize, f64) {
        let mut args = vec![
            "identify",
            "--input",
            s(&data),
            "--output",
            s(&model),
            "--validate",
            s(&record),
        ];
        args.extend_from_slice(extra);
        let out = mfcbeam(&args);
        ok(&out);
        let report = String::from_utf8_lossy(&out.stderr).to_string();
        let line = report
            .lines()
            .find(|l| l.starts_with(s(&record)))
            .unwrap_or_else(|| panic!("no row for the record: {report}"));
        let cells: Vec<&str> = line[s(&record).len()..].split_whitespace().collect();
        (cells[0].parse().unwrap(), cells[2].parse().unwrap())
    };
    let (from, virgin) = row(&[]);
    let (from_estimated, estimated) = row(&["--validate-state-until", "0.9s"]);
    // scored from the end of the window, and the memory no longer counts
    // against the model: the identified model is the nominal one to its
    // rounding, so what is left is the estimate's
    assert_eq!(from_estimated, 4500);
    assert!(from < 4500, "{from}");
    assert!(virgin > 1.0, "{virgin}");
    assert!(estimated < 1e-2 * virgin, "{estimated} against {virgin}");
    let bad = mfcbeam(&[
        "identify",
        "--input",
        s(&data),
        "--output",
        s(&d.path("m2.json")),
        "--validate",
        s(&record),
        "--validate-state-until",
        "99s",
    ]);
    assert_clean_failure(
        &bad,
        &["--validate-state-until", "record.csv"],
        Some(&d.path("m2.json")),
    );
}
