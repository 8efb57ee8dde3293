//! `--out X.parquet` of the commands that write tables (`predict`, `gcode
//! interpolate`, `twin predict`): read back with the parquet crate, the file
//! holds the CSV's columns under the same names, as required float64, with the
//! very same numbers (the CSV's shortest round-trip numbers parse back exactly).

use crate::common::*;

use std::path::Path;

use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::RowAccessor;

/// Header and rows of a CSV the tool wrote.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

/// Column names, rows and row-group count of a Parquet file, every column float64.
fn read_parquet(path: &Path) -> (Vec<String>, Vec<Vec<f64>>, usize) {
    let reader = SerializedFileReader::new(std::fs::File::open(path).unwrap()).unwrap();
    let meta = reader.metadata();
    let schema = meta.file_metadata().schema_descr();
    let names: Vec<String> = schema
        .columns()
        .iter()
        .map(|c| c.name().to_string())
        .collect();
    for c in schema.columns() {
        assert_eq!(c.physical_type(), parquet::basic::Type::DOUBLE);
        assert_eq!(c.max_def_level(), 0, "{} is required", c.name());
    }
    let groups = meta.num_row_groups();
    let rows = reader
        .get_row_iter(None)
        .unwrap()
        .map(|r| {
            let r = r.unwrap();
            (0..names.len()).map(|i| r.get_double(i).unwrap()).collect()
        })
        .collect();
    (names, rows, groups)
}

fn run(dir: &Path, args: &[&str]) {
    let o = mtwin(dir, args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// Both outputs of one command hold the same table, bit for bit.
fn assert_same(dir: &Path, csv: &str, parquet: &str) -> usize {
    let (h1, r1) = read_csv(&dir.join(csv));
    let (h2, r2, groups) = read_parquet(&dir.join(parquet));
    assert_eq!(h1, h2);
    assert_eq!(r1.len(), r2.len());
    for (a, b) in r1.iter().zip(&r2) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert_eq!(x.to_bits(), y.to_bits(), "{a:?} vs {b:?}");
        }
    }
    assert!(!r1.is_empty());
    groups
}

#[test]
fn predict_writes_the_csv_table_as_parquet() {
    let dir = tempfile::tempdir().unwrap();
    // 70 000 poses inside the travels of ac-trunnion: two row groups.
    let mut text = String::from("Y,X,Z,A,C\n");
    for k in 0..70_000u32 {
        let f = |m: u32, lo: f64, hi: f64| lo + (hi - lo) * f64::from((k * m) % 1009) / 1008.0;
        text.push_str(&format!(
            "{},{},{},{},{}\n",
            f(7, -100.0, 100.0),
            f(13, -100.0, 100.0),
            f(17, -200.0, -10.0),
            f(19, -90.0, 90.0),
            f(23, 0.0, 300.0)
        ));
    }
    std::fs::write(dir.path().join("poses.csv"), text).unwrap();
    let machine = example("ac-trunnion-with-errors.toml");
    for out in ["pred.csv", "pred.parquet"] {
        run(
            dir.path(),
            &[
                "predict",
                "--machine",
                &machine,
                "--data",
                "poses.csv",
                "--out",
                out,
            ],
        );
    }
    assert_eq!(assert_same(dir.path(), "pred.csv", "pred.parquet"), 2);
}

#[test]
fn interpolate_and_twin_write_the_csv_tables_as_parquet() {
    let dir = tempfile::tempdir().unwrap();
    let machine = example("ac-trunnion-twin.toml");
    let program = repo()
        .join("examples/programs/s-curve-5axis.ngc")
        .display()
        .to_string();
    for out in ["cmd.csv", "cmd.parquet"] {
        run(
            dir.path(),
            &[
                "gcode",
                "interpolate",
                "--machine",
                &machine,
                &program,
                "--tcp",
                "--out",
                out,
            ],
        );
    }
    assert_eq!(assert_same(dir.path(), "cmd.csv", "cmd.parquet"), 1);
    for out in ["pred.csv", "pred.parquet"] {
        run(
            dir.path(),
            &[
                "twin",
                "predict",
                "--machine",
                &machine,
                "--commands",
                "cmd.csv",
                "--out",
                out,
            ],
        );
    }
    assert_same(dir.path(), "pred.csv", "pred.parquet");
}

#[test]
fn a_failed_command_leaves_no_parquet_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.ngc"), "G21 G90\nG1 X10 F100 G1 G0\n").unwrap();
    let o = mtwin(
        dir.path(),
        &[
            "gcode",
            "interpolate",
            "--machine",
            &example("ac-trunnion.toml"),
            "bad.ngc",
            "--out",
            "cmd.parquet",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("bad.ngc:2:"), "{}", stderr(&o));
    assert!(!dir.path().join("cmd.parquet").exists());
}
