//! No input file makes thermcomp's readers panic: random bytes and
//! CSV/TOML-shaped noise into the run-file reader, the spec reader and the
//! runner. (The blob decoder has its own: model-core/tests/blob_garbage.rs.)

use host_tools::data::runfile::{ReadOptions, RunFile};
use host_tools::runner::{predict, ColumnMap};
use proptest::prelude::*;

/// Cells that stress the number parser and the CSV layer.
fn cell() -> impl Strategy<Value = String> {
    prop_oneof![
        // Mostly within a temperature's range, so that rows reach the
        // runner (the reader refuses a `T` cell below -273.15 or above
        // 1000 C); sometimes far beyond it.
        (-300f64..1100.0).prop_map(|v| v.to_string()),
        (-1e6f64..1e6).prop_map(|v| v.to_string()),
        Just(String::new()),
        Just("nan".into()),
        Just("-inf".into()),
        Just("1e999".into()),
        Just("\"1,5\"".into()),
        Just("\"a\nb\"".into()),
        "[ -~]{0,8}",
    ]
}

fn csv_text() -> impl Strategy<Value = String> {
    (
        1usize..5,
        proptest::collection::vec(proptest::collection::vec(cell(), 0..6), 0..30),
    )
        .prop_map(|(n_cols, rows)| {
            let mut s = String::from("t_s");
            for c in 1..n_cols {
                s.push_str(&format!(",T{c}"));
            }
            s.push('\n');
            for r in rows {
                s.push_str(&r.join(","));
                s.push('\n');
            }
            s
        })
}

const TF_SPEC: &str = "kind = \"tf\"\ndt_s = 1.0\n[[tf]]\noutput = \"dz_um\"\ninput = \"T1\"\na = [0.5]\nb = [1.0, -0.5]\n";

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn run_file_reader_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        for skip in [false, true] {
            let opts = ReadOptions { skip_bad_rows: skip, only: None };
            let _ = RunFile::from_reader("g.csv", bytes.as_slice(), &opts);
        }
    }

    /// CSV-shaped noise through the reader and, when it reads, the runner of
    /// a dynamic model (resampling, gaps): errors are one line, never panics.
    #[test]
    fn csv_noise_reads_or_fails_cleanly(text in csv_text()) {
        let model = host_tools::data::spec::parse("m.toml", TF_SPEC).unwrap();
        for skip in [false, true] {
            let opts = ReadOptions { skip_bad_rows: skip, only: None };
            match RunFile::from_reader("n.csv", text.as_bytes(), &opts) {
                Ok(run) => {
                    if let Ok(p) = predict(&model, &run, &ColumnMap::default()) {
                        prop_assert!(p.values[0].iter().flatten().all(|v| v.is_finite()));
                    }
                }
                Err(e) => prop_assert!(!e.to_string().contains('\n'), "{}", e),
            }
        }
    }

    #[test]
    fn spec_reader_never_panics(text in "[ -~\n]{0,300}") {
        if let Err(e) = host_tools::data::spec::parse("g.toml", &text) {
            prop_assert!(!e.to_string().contains('\n'), "{}", e);
        }
    }

    /// Valid TOML with wrong shapes and values in every field.
    #[test]
    fn spec_shaped_noise_fails_cleanly(
        kind in prop_oneof![Just("tf"), Just("linear"), Just("pcr"), Just("bp"), Just("arma"), Just("x")],
        dt in prop_oneof![Just("1.0"), Just("-1"), Just("nan"), Just("inf"), Just("0")],
        a in proptest::collection::vec(-1e3f64..1e3, 0..12),
        b in proptest::collection::vec(-2f64..2.0, 0..12),
    ) {
        let list = |v: &[f64]| v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(", ");
        let text = format!(
            "kind = \"{kind}\"\ndt_s = {dt}\n[[tf]]\noutput = \"dz_um\"\ninput = \"T1\"\na = [{}]\nb = [{}]\n",
            list(&a), list(&b)
        );
        if let Err(e) = host_tools::data::spec::parse("s.toml", &text) {
            prop_assert!(!e.to_string().contains('\n'), "{}", e);
        }
    }
}
