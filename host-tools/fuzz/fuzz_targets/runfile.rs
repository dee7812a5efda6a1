//! Fuzzes the run-file reader, `host_tools::data::runfile::RunFile::from_reader`.
//!
//! The first byte picks the options (bit 0: `--skip-bad-rows`; bit 1: read
//! only the column `T1`); the rest is the file. The reader takes whatever a
//! logger writes (any bytes, any line ends, quotes, BOMs), so the invariants
//! are the contract's: no panic; an error is one line; an accepted file has
//! strictly increasing finite times, finite cells, and every skipped row is
//! accounted for.
#![no_main]

use host_tools::data::runfile::{ReadOptions, RunFile};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, text)) = data.split_first() else {
        return;
    };
    let only = (mode & 2 != 0).then(|| vec!["T1".to_string()]);
    let opts = ReadOptions {
        skip_bad_rows: mode & 1 != 0,
        only,
    };
    match RunFile::from_reader("fuzz.csv", text, &opts) {
        Ok(run) => {
            assert!(run.t_s.windows(2).all(|w| w[0] < w[1]), "times increase");
            assert!(run.t_s.iter().all(|t| t.is_finite()));
            for (_, col) in run.iter_columns() {
                assert_eq!(col.len(), run.t_s.len());
                assert!(col.iter().flatten().all(|v| v.is_finite()));
            }
            if !opts.skip_bad_rows {
                assert!(run.skipped.is_empty());
            }
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(!msg.contains('\n'), "one-line error: {msg:?}");
            assert!(msg.starts_with("fuzz.csv"), "names the file: {msg:?}");
        }
    }
});
