//! Each setting runs three times unless told, counted through a side effect of the runs, and
//! its CPU time is reported beside its wall time.

use super::{Table, column, script, study_as_given, text};
use std::process::Command;

/// Adds one to the counter grid in the file `$COUNTER`, so the test can count the runs.
const COUNTED: &str = "\
param int n = 1;
domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.5);
scalarcache k(d);
cachewrite(k, cacheload(\"$COUNTER\", \"count\") + 1);
cachesave(k, \"$COUNTER#count\");
print(\"value\", n * 2);
";

#[test]
fn settings_are_run_three_times_unless_told_and_cpu_time_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let counter = dir.path().join("counter.vdb");
    script(
        dir.path(),
        "zero.felt",
        "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.5);\nscalarcache k(d);\n\
         cachewrite(k, scalarfield(0));\ncachesave(k, \"$COUNTER#count\");\n",
    );
    script(dir.path(), "counted.felt", COUNTED);
    let zero = Command::new(env!("CARGO_BIN_EXE_felt"))
        .current_dir(dir.path())
        .args(["run", "zero.felt"])
        .env("COUNTER", &counter)
        .output()
        .unwrap();
    assert!(zero.status.success(), "{}", text(&zero));
    let count = || -> f64 {
        let probe = script(
            dir.path(),
            "probe.felt",
            "print(\"count\", probe(cacheload(\"$COUNTER\", \"count\"), (0.25, 0.25, 0.25)));\n",
        );
        let out = Command::new(env!("CARGO_BIN_EXE_felt"))
            .arg("run")
            .arg(probe)
            .env("COUNTER", &counter)
            .output()
            .unwrap();
        let shown = String::from_utf8_lossy(&out.stdout).to_string();
        shown
            .trim()
            .strip_prefix("count ")
            .unwrap()
            .parse()
            .unwrap()
    };
    let env = [("COUNTER", counter.as_path())];
    // Two settings and their reference: three settings to run, three times each by default.
    let args = ["counted.felt", "--sweep", "n=1,2", "--reference", "n=3"];
    let out = study_as_given(
        dir.path(),
        &[&args[..], &["--out", "three"][..]].concat(),
        &env,
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert_eq!(count(), 9.0);
    let table = Table::read(&dir.path().join("three/study.csv"));
    let (runs, cpu, seconds) = (
        column(&table.header, "runs"),
        column(&table.header, "cpu_seconds"),
        column(&table.header, "seconds"),
    );
    for row in &table.rows {
        assert_eq!(row[runs], "3");
        let cpu: f64 = row[cpu].parse().unwrap();
        let wall: f64 = row[seconds].parse().unwrap();
        assert!(cpu.is_finite() && cpu >= 0.0 && wall > 0.0, "{row:?}");
    }
    let shown = String::from_utf8_lossy(&out.stdout);
    assert!(
        shown.contains("CPU s") && shown.contains("medians of 3 runs"),
        "{shown}"
    );
    // `--repeat 2`, in a new folder (so the reference is run again): six more runs.
    let out = study_as_given(
        dir.path(),
        &[&args[..], &["--out", "two", "--repeat", "2"][..]].concat(),
        &env,
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert_eq!(count(), 15.0);
    let table = Table::read(&dir.path().join("two/study.csv"));
    assert!(
        table.rows.iter().all(|r| r[runs] == "2"),
        "{:?}",
        table.rows
    );
}
