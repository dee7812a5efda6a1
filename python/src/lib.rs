//! `thermcomp._native`: host-tools' typed jobs for Python. Runs arrive as
//! a CSV path or as columns of little-endian float64 bytes (`NaN` = a
//! missing cell, as an empty CSV cell); figures leave as the JSON text the
//! CLI prints, blobs as bytes. Every error is a `ThermcompError` carrying
//! the CLI's one-line message. The Python layer (`thermcomp/__init__.py`)
//! turns DataFrames into these and back.

use anyhow::{anyhow, bail, Result};
use clap::ValueEnum;
use host_tools::cli::fit::options_from_pairs;
use host_tools::data::dataset::InputForm;
use host_tools::data::runfile::{ReadOptions, RunFile};
use host_tools::fit::{FitKind, FitParams};
use host_tools::runner::ColumnMap;
use model_core::ValidModel;
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyString};
use std::path::PathBuf;

create_exception!(
    _native,
    ThermcompError,
    PyValueError,
    "A thermcomp job failed; the message is the CLI's one-line error."
);

/// A Python error from a job's error, its context chain on one line (as
/// the CLI prints it after `error: `).
fn py_err(e: anyhow::Error) -> PyErr {
    ThermcompError::new_err(format!("{e:#}"))
}

/// Columns as `(name, values)`, `None` as `NaN`.
type Columns = Vec<(String, Vec<f64>)>;

/// float64 values from their little-endian bytes.
fn f64s(bytes: &[u8], what: &str) -> Result<Vec<f64>> {
    if !bytes.len().is_multiple_of(8) {
        bail!(
            "{what}: {} bytes is not a whole number of float64 values",
            bytes.len()
        );
    }
    Ok(bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
        .collect())
}

/// A run: a CSV path (read as the CLI reads it: every column, or `only`
/// these), or `(name, t_s bytes, [(column, bytes or None)])`.
fn run_from(obj: &Bound<'_, PyAny>, only: Option<&[String]>) -> Result<RunFile> {
    if let Some(path) = csv_path(obj)? {
        let opts = ReadOptions {
            only: only.map(<[String]>::to_vec),
            ..ReadOptions::default()
        };
        return Ok(RunFile::read(&path, &opts)?);
    }
    type Memory<'py> = (
        String,
        Bound<'py, PyBytes>,
        Vec<(String, Option<Bound<'py, PyBytes>>)>,
    );
    let (name, t_s, cols): Memory<'_> = obj
        .extract()
        .map_err(|e| anyhow!("a run is a CSV path or (name, t_s, columns): {e}"))?;
    let t_s = f64s(t_s.as_bytes(), &format!("{name}: t_s"))?;
    let mut columns = Vec::with_capacity(cols.len());
    for (col, bytes) in cols {
        let values = bytes
            .map(|b| f64s(b.as_bytes(), &format!("{name}: {col}")))
            .transpose()?;
        columns.push((col, values));
    }
    Ok(RunFile::from_columns(&name, t_s, columns)?)
}

/// The path of a run given as a CSV path.
fn csv_path(obj: &Bound<'_, PyAny>) -> Result<Option<PathBuf>> {
    if !obj.is_instance_of::<PyString>() {
        return Ok(None);
    }
    obj.extract().map(Some).map_err(|e| anyhow!("{e}"))
}

fn runs_from(list: &[Bound<'_, PyAny>], only: Option<&[String]>) -> Result<Vec<RunFile>> {
    list.iter().map(|r| run_from(r, only)).collect()
}

/// A validated model from blob bytes.
fn model_from(blob: &[u8]) -> Result<ValidModel> {
    model_core::decode(blob).map_err(|e| anyhow!("model blob: {e}"))
}

/// A value of a clap `ValueEnum` by its CLI name.
fn value_of<E: ValueEnum>(flag: &str, text: &str) -> Result<E> {
    E::from_str(text, false).map_err(|_| {
        let names: Vec<String> = E::value_variants()
            .iter()
            .filter_map(|v| v.to_possible_value().map(|p| p.get_name().to_string()))
            .collect();
        anyhow!("{flag} {text:?}: not one of {}", names.join(", "))
    })
}

fn nan_columns(cols: Vec<(String, Vec<Option<f64>>)>) -> Columns {
    cols.into_iter()
        .map(|(n, v)| (n, v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect()))
        .collect()
}

/// Trains a model: returns the blob and `fit --json`'s object (no `out`).
#[pyfunction]
#[pyo3(signature = (runs, validate, targets, inputs, kind, holdout_from_s, reference, options))]
#[allow(clippy::too_many_arguments)]
fn fit<'py>(
    py: Python<'py>,
    runs: Vec<Bound<'py, PyAny>>,
    validate: Vec<Bound<'py, PyAny>>,
    targets: Vec<String>,
    inputs: Vec<String>,
    kind: &str,
    holdout_from_s: Option<f64>,
    reference: &str,
    options: Vec<(String, String)>,
) -> PyResult<(Bound<'py, PyBytes>, String)> {
    let job = || -> Result<(Vec<u8>, String)> {
        // `l_defl_mm` is the fit's own setting (five-point geometry), not a
        // trainer option.
        let (geometry, options): (Vec<_>, Vec<_>) =
            options.into_iter().partition(|(k, _)| k == "l_defl_mm");
        let l_defl_mm = match geometry.last() {
            Some((_, v)) => Some(
                v.trim()
                    .parse::<f64>()
                    .map_err(|_| anyhow!("--l-defl-mm {v:?}: not a number"))?,
            ),
            None => None,
        };
        let params = FitParams {
            targets,
            inputs,
            kind: value_of::<FitKind>("--model", kind)?,
            holdout_from_s,
            reference: value_of::<InputForm>("--reference", reference)?,
            l_defl_mm,
            options: options_from_pairs(&options)?,
        };
        let valid = params.check()?;
        // CSV paths: only the columns the fit reads, as the CLI does (the
        // default inputs from the headers of the runs given as paths, when
        // the first is one).
        let paths: Vec<PathBuf> = runs
            .iter()
            .map(csv_path)
            .collect::<Result<Vec<_>>>()?
            .into_iter()
            .flatten()
            .collect();
        let only = match runs.first().map(csv_path).transpose()?.flatten() {
            Some(_) => Some(valid.columns_read(&paths)?),
            None => None,
        };
        let only = only.as_deref();
        let (runs, validate) = (runs_from(&runs, only)?, runs_from(&validate, only)?);
        let o = host_tools::fit::fit(&valid, &runs, &validate)?;
        let json = serde_json::to_value(&o.report)?.to_string();
        Ok((o.bytes, json))
    };
    let (bytes, json) = job().map_err(py_err)?;
    Ok((PyBytes::new(py, &bytes), json))
}

/// `model show --json`'s object for a blob.
#[pyfunction]
fn describe(blob: Vec<u8>) -> PyResult<String> {
    let model = model_from(&blob).map_err(py_err)?;
    Ok(host_tools::show::describe_json(&model, &blob).to_string())
}

/// A blob file's bytes, checked (version, CRC, sizes, stability).
#[pyfunction]
fn load<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyBytes>> {
    let (_, bytes) = host_tools::data::blobfile::read(&path).map_err(py_err)?;
    Ok(PyBytes::new(py, &bytes))
}

/// Writes a blob atomically.
#[pyfunction]
fn save(blob: Vec<u8>, path: PathBuf) -> PyResult<()> {
    let job = || -> Result<()> {
        model_from(&blob)?;
        host_tools::data::fsio::write_bytes_atomic(&path, &blob)
    };
    job().map_err(py_err)
}

/// `predict`'s columns for one run: `(t_s, [(column, values)])`, NaN where
/// the CLI writes an empty cell.
#[pyfunction]
fn predict(blob: Vec<u8>, run: Bound<'_, PyAny>, interval: bool) -> PyResult<(Vec<f64>, Columns)> {
    let job = || -> Result<(Vec<f64>, Columns)> {
        let model = model_from(&blob)?;
        let map = ColumnMap::default();
        let run = run_from(&run, Some(&map.model_columns(&model, false)))?;
        let table = host_tools::predict::predict_run(&model, &run, &map, interval)?;
        for note in &table.notes {
            eprintln!("note: {}: {note}", run.path.display());
        }
        Ok((table.t_s, nan_columns(table.columns)))
    };
    job().map_err(py_err)
}

/// `eval --json`'s object.
#[pyfunction]
fn evaluate(blob: Vec<u8>, runs: Vec<Bound<'_, PyAny>>) -> PyResult<String> {
    let job = || -> Result<String> {
        let model = model_from(&blob)?;
        let map = ColumnMap::default();
        let runs = runs_from(&runs, Some(&map.model_columns(&model, true)))?;
        let out = host_tools::eval::evaluate(&model, &runs, &map)?;
        Ok(serde_json::to_value(&out)?.to_string())
    };
    job().map_err(py_err)
}

/// `select --json`'s object; `options` are `select`'s flags by name.
#[pyfunction]
fn select(runs: Vec<Bound<'_, PyAny>>, options: Vec<(String, String)>) -> PyResult<String> {
    let job = || -> Result<String> {
        let mut pairs = vec![("data".to_string(), "(in memory)".to_string())];
        pairs.extend(options);
        let args: host_tools::cli::select::SelectArgs =
            host_tools::cli::pairs::args_from_pairs("select", &pairs)?;
        let params = args.params().check()?;
        let runs = runs_from(&runs, None)?;
        let out = host_tools::select::select(&params, &runs)?;
        Ok(serde_json::to_value(&out)?.to_string())
    };
    job().map_err(py_err)
}

/// The run `simulate` writes, as `(t_s, [(column, values)])`.
#[pyfunction]
fn simulate(options: Vec<(String, String)>) -> PyResult<(Vec<f64>, Columns)> {
    let job = || -> Result<(Vec<f64>, Columns)> {
        let mut pairs = vec![("out".to_string(), "(in memory)".to_string())];
        pairs.extend(options);
        let args: host_tools::cli::simulate::SimulateArgs =
            host_tools::cli::pairs::args_from_pairs("simulate", &pairs)?;
        let run = match host_tools::cli::simulate::calibrated(&args, true)? {
            Some(cal) => cal.simulate(args.seed)?,
            None => host_tools::simulate::simulate(&args.params().check()?)?,
        };
        // Stored cells are already NaN where missing.
        let cols = run
            .iter_columns()
            .map(|(n, v)| (n.to_string(), v.stored().to_vec()))
            .collect();
        Ok((run.t_s.clone(), cols))
    };
    job().map_err(py_err)
}

/// `diagnose --json`'s object.
#[pyfunction]
#[pyo3(signature = (sim, real, holdout_from_s=None, machine=None))]
fn diagnose(
    sim: Bound<'_, PyAny>,
    real: Bound<'_, PyAny>,
    holdout_from_s: Option<f64>,
    machine: Option<PathBuf>,
) -> PyResult<String> {
    let job = || -> Result<String> {
        let on_disk = real.is_instance_of::<PyString>();
        if machine.is_some() && !on_disk {
            bail!(
                "machine=: give real as a CSV path (the physical diagnosis re-reads the real run)"
            );
        }
        let twin = machine
            .as_deref()
            .map(host_tools::diagnose::physical::Twin::load)
            .transpose()?;
        let (sim, real) = (run_from(&sim, None)?, run_from(&real, None)?);
        let v =
            host_tools::diagnose::diagnose_runs(&sim, &real, holdout_from_s, None, twin.as_ref())?;
        Ok(serde_json::to_string(&v)?)
    };
    job().map_err(py_err)
}

/// The module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ThermcompError", m.py().get_type::<ThermcompError>())?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(describe, m)?)?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(save, m)?)?;
    m.add_function(wrap_pyfunction!(predict, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(select, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    Ok(())
}
