//! Runs in memory (`RunFile::from_columns`, what the Python package passes)
//! against the same run read from CSV text: same values, same error places,
//! and the typed fit job giving the very figures `fit_files` gives.

use host_tools::cli::fit::options_from_pairs;
use host_tools::data::runfile::{ReadOptions, RunFile};
use host_tools::fit::{FitKind, FitOptions, FitParams};

const CSV: &str = "t_s,T1,T2,dz_um\n0,20,21,0\n60,20.5,,1.25\n120,21,21.5,2.5\n180,21.25,22,3\n240,21.5,22.25,3.5\n";

/// Named columns as `RunFile::from_columns` takes them.
type Columns = Vec<(String, Option<Vec<f64>>)>;

fn columns() -> (Vec<f64>, Columns) {
    let nan = f64::NAN;
    let t = vec![0.0, 60.0, 120.0, 180.0, 240.0];
    let cols = vec![
        ("T1".to_string(), Some(vec![20.0, 20.5, 21.0, 21.25, 21.5])),
        ("T2".to_string(), Some(vec![21.0, nan, 21.5, 22.0, 22.25])),
        ("dz_um".to_string(), Some(vec![0.0, 1.25, 2.5, 3.0, 3.5])),
    ];
    (t, cols)
}

#[test]
fn columns_hold_what_the_csv_holds() {
    let (t, cols) = columns();
    let mem = RunFile::from_columns("df", t, cols).unwrap();
    let csv = RunFile::from_reader("df", CSV.as_bytes(), &ReadOptions::default()).unwrap();
    assert_eq!(mem.t_s, csv.t_s);
    assert_eq!(mem.columns, csv.columns);
    for name in ["T1", "T2", "dz_um"] {
        // Exact: both are the same decimal numbers as doubles.
        assert_eq!(mem.column(name), csv.column(name), "{name}");
    }
    assert_eq!(
        mem.column("T2").unwrap().get(1),
        None,
        "NaN is a missing cell"
    );
}

#[test]
fn errors_name_row_and_column_as_a_csv_would() {
    let (t, mut cols) = columns();
    cols[1].1.as_mut().unwrap()[3] = f64::INFINITY;
    let e = RunFile::from_columns("df", t.clone(), cols).unwrap_err();
    // Row 3 is line 5 (header on line 1); T2 is column 3 (t_s is column 1).
    assert_eq!(e.to_string(), "df:5:3 (T2): value \"inf\" is not finite");

    let (_, cols) = columns();
    let mut back = t.clone();
    back[2] = 60.0;
    let e = RunFile::from_columns("df", back, cols).unwrap_err();
    assert!(e.to_string().starts_with("df:4:1 "), "{e}");

    let (_, mut cols) = columns();
    cols[2].0 = "T1".into();
    let e = RunFile::from_columns("df", t.clone(), cols).unwrap_err();
    assert!(
        e.to_string().contains("duplicate column name \"T1\""),
        "{e}"
    );

    let (_, mut cols) = columns();
    cols[0].1.as_mut().unwrap().pop();
    let e = RunFile::from_columns("df", t, cols).unwrap_err();
    assert_eq!(e.to_string(), "df: column T1 has 4 rows, t_s has 5");
}

#[test]
fn typed_fit_matches_fit_files_figure_for_figure() {
    let data = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/synthetic_spindle.csv"
    );
    let run = RunFile::read(data.as_ref(), &ReadOptions::default()).unwrap();
    // The same run rebuilt from its columns, as the Python package builds it.
    let cols = run
        .iter_columns()
        .map(|(n, v)| {
            let v = v.iter().map(|x| x.unwrap_or(f64::NAN)).collect();
            (n.to_string(), Some(v))
        })
        .collect();
    let mem = RunFile::from_columns(data, run.t_s.clone(), cols).unwrap();
    let params = FitParams {
        targets: vec!["dz_um".into()],
        inputs: vec!["T1".into(), "T3".into(), "speed_rpm".into()],
        kind: FitKind::Mlr,
        holdout_from_s: Some(43200.0),
        reference: host_tools::data::dataset::InputForm::Change,
        l_defl_mm: None,
        options: FitOptions::default(),
    };
    let typed = host_tools::fit::fit(&params.check().unwrap(), &[mem], &[]).unwrap();

    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.bin");
    let argv = [
        "fit",
        "--data",
        data,
        "--target",
        "dz_um",
        "--inputs",
        "T1,T3,speed_rpm",
    ];
    let argv = argv.iter().map(|s| s.to_string()).chain([
        "--model".into(),
        "mlr".into(),
        "--holdout-from-s".into(),
        "43200".into(),
        "--out".into(),
        out.display().to_string(),
    ]);
    let pairs: Vec<String> = argv.skip(1).collect();
    let args: host_tools::cli::fit::FitArgs = {
        use clap::{Args, FromArgMatches};
        let cmd = host_tools::cli::fit::FitArgs::augment_args(
            clap::Command::new("fit").no_binary_name(true),
        );
        host_tools::cli::fit::FitArgs::from_arg_matches(&cmd.try_get_matches_from(pairs).unwrap())
            .unwrap()
    };
    let files = host_tools::cli::fit::fit_files(&args).unwrap();
    assert_eq!(typed.bytes, files.bytes, "the same blob");
    assert_eq!(typed.bytes, std::fs::read(&out).unwrap());
    assert_eq!(
        serde_json::to_value(&typed.report).unwrap(),
        serde_json::to_value(&files.report).unwrap()
    );
    let held = typed.report.targets["dz_um"].holdout.as_ref().unwrap();
    assert_eq!(
        held.n,
        4321 - 1440,
        "rows from 12 h on at 30 s: 1440 calibrate"
    );
    // The kind's figures are typed: a library caller reads them without JSON keys.
    let host_tools::fit::Details::Mlr(mlr) = &typed.report.details else {
        panic!("an mlr fit reports MlrDetails");
    };
    let eq = &mlr.equations["dz_um"];
    let inputs: Vec<&String> = eq.coef.keys().collect();
    assert_eq!(inputs, ["T1", "T3", "speed_rpm"]);
    assert!(eq.intercept.is_finite());
}

#[test]
fn options_by_name_use_the_clis_defaults_and_messages() {
    let d = FitOptions::default();
    assert_eq!((d.pcr.variance, d.auto.auto_folds, d.bp.seed), (0.85, 6, 1));
    let o = options_from_pairs(&[("auto_folds".into(), "3".into())]).unwrap();
    assert_eq!(o.auto.auto_folds, 3);
    let e = options_from_pairs(&[("variance".into(), "lots".into())]).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("fit: invalid value 'lots' for '--variance"),
        "{e}"
    );
    let e = options_from_pairs(&[("nope".into(), "1".into())]).unwrap_err();
    assert!(e.to_string().contains("--nope"), "{e}");
}
