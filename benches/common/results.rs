//! A bench's figures as data: with `MFCBEAM_RESULTS` set (to a folder, or
//! to `1` for `benches/results`), a bench writes what it measured into
//! `<folder>/<cpu>/<date>.json` beside the CPU, the commit and the kernel
//! set, merged with what other benches wrote there that day.
//! `benches/results/render.py` renders the guide's tables from these files.

use std::path::PathBuf;

use serde_json::{json, Map, Value};

/// One figure: what it is, its unit, and a value per run or per round.
pub struct Figure {
    pub name: String,
    pub unit: &'static str,
    pub values: Vec<f64>,
}

/// `/proc/cpuinfo`'s field `name` (x86 and ARM spellings), or "?".
fn cpu_field(info: &str, names: &[&str]) -> String {
    names
        .iter()
        .find_map(|name| {
            info.lines()
                .find(|l| l.split(':').next().map(str::trim) == Some(*name))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "?".into())
}

/// The CPU as the results name it: vendor, family, model, its name, and a
/// folder name made of them.
fn cpu() -> (Value, String) {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let vendor = cpu_field(&info, &["vendor_id", "CPU implementer"]);
    let family = cpu_field(&info, &["cpu family", "CPU architecture"]);
    let model = cpu_field(&info, &["model", "CPU part"]);
    let name = cpu_field(&info, &["model name"]);
    let slug: String = format!("{vendor}-{family}-{model}")
        .to_lowercase()
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    (
        json!({
            "vendor": vendor,
            "family": family,
            "model": model,
            "name": name,
            "description": mfcbeam::internals::cpu_description(),
        }),
        slug,
    )
}

/// Today's date (UTC), from the system clock.
fn today() -> String {
    let days = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() / 86_400) as i64;
    // civil from days (Howard Hinnant's algorithm)
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

/// The commit measured (with `-dirty` if the tree has changes).
fn commit() -> String {
    let run = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    let head = run(&["rev-parse", "--short=7", "HEAD"]).unwrap_or_else(|| "?".into());
    // the results themselves left out: a bench's second run sees the
    // first one's figures there
    let dirty = run(&[
        "status",
        "--porcelain",
        "--untracked-files=no",
        "--",
        ".",
        ":(exclude)benches/results",
    ])
    .is_some_and(|s| !s.is_empty());
    if dirty {
        format!("{head}-dirty")
    } else {
        head
    }
}

/// Writes `figures` as bench `bench`'s, if `MFCBEAM_RESULTS` asks for it;
/// prints where. A file that cannot be written is a message, not a panic:
/// the figures were printed already.
pub fn record(bench: &str, figures: &[Figure]) {
    let Ok(folder) = std::env::var("MFCBEAM_RESULTS") else {
        return;
    };
    let folder = if folder == "1" {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("benches/results")
    } else {
        PathBuf::from(folder)
    };
    let (cpu, slug) = cpu();
    let path = folder.join(&slug).join(format!("{}.json", today()));
    let mut file = std::fs::read_to_string(&path)
        .ok()
        .and_then(|s| serde_json::from_str::<Value>(&s).ok())
        .and_then(|v| v.as_object().cloned())
        .unwrap_or_default();
    file.insert("cpu".into(), cpu);
    file.insert("date".into(), today().into());
    let mut benches = file
        .remove("benches")
        .and_then(|b| b.as_object().cloned())
        .unwrap_or_else(Map::new);
    // another process of the same bench on the same commit (run.sh runs
    // three) adds its values to the figures
    let commit = commit();
    let before: Vec<Value> = benches
        .get(bench)
        .filter(|b| b.get("commit").and_then(Value::as_str) == Some(commit.as_str()))
        .and_then(|b| b.get("figures"))
        .and_then(Value::as_array)
        .cloned()
        .unwrap_or_default();
    let figures: Vec<Value> = figures
        .iter()
        .map(|f| {
            let mut values: Vec<Value> = before
                .iter()
                .find(|b| b.get("name").and_then(Value::as_str) == Some(f.name.as_str()))
                .and_then(|b| b.get("values"))
                .and_then(Value::as_array)
                .cloned()
                .unwrap_or_default();
            values.extend(f.values.iter().map(|&v| json!(v)));
            json!({"name": f.name, "unit": f.unit, "values": values})
        })
        .collect();
    benches.insert(
        bench.into(),
        json!({
            "commit": commit,
            "kernels": mfcbeam::internals::Kernels::detect().name(),
            "figures": figures,
        }),
    );
    file.insert("benches".into(), Value::Object(benches));
    let text = serde_json::to_string_pretty(&Value::Object(file)).unwrap_or_default() + "\n";
    match std::fs::create_dir_all(path.parent().unwrap_or(&folder))
        .and_then(|()| std::fs::write(&path, text))
    {
        Ok(()) => println!("results: {}", path.display()),
        Err(e) => eprintln!("results: {}: {e}", path.display()),
    }
}
