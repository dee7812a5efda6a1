"""thermcomp: thermal-error compensation models for CNC machine tools.

The same library the ``thermcomp`` command line runs, called in process:
the same figures to the last digit, the same one-line error messages (as
:class:`ThermcompError`, a ``ValueError``).

Runs are pandas DataFrames with a ``t_s`` column (seconds, strictly
increasing) and one column per signal (``T1``, ``speed_rpm``, ``dz_um``,
...), or paths of run files (CSV, CONTRACT.md section 2). A missing value
is ``NaN`` in a DataFrame and an empty cell in a CSV file: the same thing.
Numeric columns go to the library as float64 without temporary files;
non-numeric columns are kept by name and ignored unless a model needs them.
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Iterable, List, Optional, Sequence, Union

import numpy as np
import pandas as pd

from . import _native
from ._native import ThermcompError

__all__ = [
    "Model",
    "ThermcompError",
    "diagnose",
    "fit",
    "load",
    "select",
    "simulate",
]

Run = Union[pd.DataFrame, str, "os.PathLike[str]"]


def _f64_bytes(values: Any) -> bytes:
    return np.ascontiguousarray(np.asarray(values, dtype="<f8")).tobytes()


def _run(data: Run, name: str) -> Any:
    """A run as the native module takes it: a path, or columns as bytes."""
    if isinstance(data, (str, os.PathLike)):
        return os.fspath(data)
    if not isinstance(data, pd.DataFrame):
        raise TypeError(
            f"{name}: a run is a pandas DataFrame or a CSV path, not {type(data).__name__}"
        )
    if "t_s" in data.columns:
        t_s = data["t_s"]
    elif data.index.name == "t_s":
        t_s = data.index.to_series()
    else:
        raise ThermcompError(f"{name}: no t_s column")
    columns = []
    for col in data.columns:
        if col == "t_s":
            continue
        series = data[col]
        values = None
        if pd.api.types.is_numeric_dtype(series.dtype) and not pd.api.types.is_bool_dtype(
            series.dtype
        ):
            values = _f64_bytes(series.to_numpy(dtype="float64", na_value=np.nan))
        columns.append((str(col), values))
    try:
        t = _f64_bytes(t_s.to_numpy(dtype="float64", na_value=np.nan))
    except (TypeError, ValueError) as e:
        raise ThermcompError(f"{name}: t_s is not numeric ({e})") from None
    return (name, t, columns)


def _runs(data: Union[Run, Sequence[Run]], what: str = "data") -> List[Any]:
    """One run or several (a list: each is a separate run)."""
    if isinstance(data, (pd.DataFrame, str, os.PathLike)):
        data = [data]
    runs = list(data)
    if not runs:
        raise ThermcompError(f"{what}: give at least one run")
    return [_run(r, f"{what}[{i}]" if len(runs) > 1 else what) for i, r in enumerate(runs)]


def _names(cols: Union[None, str, Iterable[str]]) -> List[str]:
    if cols is None:
        return []
    if isinstance(cols, str):
        return [c for c in cols.split(",") if c]
    return [str(c) for c in cols]


def _pairs(params: Dict[str, Any]) -> List[tuple]:
    """Keyword options as the CLI's flags (``auto_folds=3`` is
    ``--auto-folds 3``; a list is comma-separated; True sets a flag)."""
    out = []
    for key, value in params.items():
        if value is None:
            continue
        if isinstance(value, bool):
            text = "true" if value else "false"
        elif isinstance(value, (list, tuple)):
            text = ",".join(str(v) for v in value)
        else:
            text = str(value)
        out.append((key, text))
    return out


def _frame(t_s: List[float], columns: List[tuple]) -> pd.DataFrame:
    data = {"t_s": np.asarray(t_s, dtype="float64")}
    for name, values in columns:
        data[name] = np.asarray(values, dtype="float64")
    return pd.DataFrame(data)


class Model:
    """A validated model blob (what the hub runs), with its fit figures
    when it was fitted here."""

    def __init__(self, blob: bytes, fit_report: Optional[Dict[str, Any]] = None):
        self._blob = bytes(blob)
        self._description = json.loads(_native.describe(self._blob))
        #: ``fit --json``'s object (without ``out``), or None for a loaded blob.
        self.fit_report = fit_report

    @property
    def blob(self) -> bytes:
        """The blob's bytes, as written by :meth:`save`."""
        return self._blob

    @property
    def kind(self) -> str:
        return self._description["kind"]

    @property
    def inputs(self) -> List[str]:
        return [i["name"] if isinstance(i, dict) else i for i in self._description["inputs"]]

    @property
    def outputs(self) -> List[str]:
        return list(self._description["outputs"])

    def predict(self, df: Run, interval: bool = False) -> pd.DataFrame:
        """``t_s`` and ``<output>_pred`` per output, row for row (NaN where
        there is no prediction); with ``interval``, ``<output>_lo95`` and
        ``<output>_hi95`` (models fitted with ``model="auto"``)."""
        t_s, columns = _native.predict(self._blob, _run(df, "df"), bool(interval))
        return _frame(t_s, columns)

    def evaluate(self, df: Union[Run, Sequence[Run]]) -> Dict[str, Any]:
        """``eval --json``'s object: per output, ``n``, ``rmse_um``,
        ``fit_pct``, ``r2``, ``eta_pct``, ``max_abs_um``, ``mean_abs_um``,
        ``dpk_um``, ``reduction_pct``, ... and ``per_run``."""
        return json.loads(_native.evaluate(self._blob, _runs(df, "df")))

    def describe(self) -> Dict[str, Any]:
        """``model show --json``'s object: kind, inputs, outputs,
        coefficients, version, CRC."""
        return json.loads(json.dumps(self._description))

    def save(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Writes the blob (atomically) for ``thermcomp hub upload``."""
        _native.save(self._blob, os.fspath(path))

    def __repr__(self) -> str:
        return f"<thermcomp.Model {self.kind}: {', '.join(self.inputs)} -> {', '.join(self.outputs)}>"


def fit(
    data: Union[Run, Sequence[Run]],
    target: Union[str, Sequence[str]],
    model: str = "auto",
    inputs: Union[None, str, Sequence[str]] = None,
    holdout_from_s: Optional[float] = None,
    validate: Union[None, Run, Sequence[Run]] = None,
    reference: str = "change",
    **params: Any,
) -> Model:
    """Trains a model as ``thermcomp fit`` does.

    ``data``: calibration runs; ``holdout_from_s``: rows from this time on
    are held out and scored; ``validate``: runs held out whole; ``model``:
    auto, mlr, pcr, arx, tf, gain, bp, gabp or arma; ``inputs``: default
    every ``T<n>`` (with auto also speed_rpm, power_kw, ambient_c,
    coolant_c). ``**params`` are fit's options by name (``auto_folds=3``,
    ``variance=0.9``, ``dt_s=60``, ``seed=2``, ...). The figures are in
    ``Model.fit_report``.
    """
    runs = _runs(data)
    held = [] if validate is None else _runs(validate, "validate")
    blob, report = _native.fit(
        runs,
        held,
        _names(target),
        _names(inputs),
        str(model),
        None if holdout_from_s is None else float(holdout_from_s),
        str(reference),
        _pairs(params),
    )
    return Model(blob, json.loads(report))


def load(path: Union[str, "os.PathLike[str]"]) -> Model:
    """A model blob file (checked: version, CRC, sizes, stability)."""
    return Model(_native.load(os.fspath(path)))


def select(
    data: Union[Run, Sequence[Run]],
    target: Union[str, Sequence[str]],
    method: str = "maxtree",
    inputs: Union[None, str, Sequence[str]] = None,
    **params: Any,
) -> Dict[str, Any]:
    """``select --json``'s object (``selected``: the sensors picked);
    ``method``: grey, wgrey or maxtree; ``**params``: select's options."""
    opts = {"target": ",".join(_names(target)), "method": method}
    if inputs is not None:
        opts["inputs"] = ",".join(_names(inputs))
    opts.update(params)
    return json.loads(_native.select(_runs(data), _pairs(opts)))


def simulate(**params: Any) -> pd.DataFrame:
    """The run ``thermcomp simulate`` writes, as a DataFrame (values as in
    the file): ``hours``, ``profile``, ``effects`` (list or comma-separated),
    ``seed``, ``machine`` (a machine file), ``dt_s``, ``sensors``."""
    t_s, columns = _native.simulate(_pairs(params))
    return _frame(t_s, columns)


def diagnose(
    sim: Run,
    real: Run,
    holdout_from_s: Optional[float] = None,
    machine: Union[None, str, "os.PathLike[str]"] = None,
) -> Dict[str, Any]:
    """``diagnose --json``'s object: ``gap``, ``where``, ``effects`` and
    ``verdict``. With ``machine`` (the twin's machine file), ``real`` must be
    a CSV path (the physical diagnosis re-reads it)."""
    return json.loads(
        _native.diagnose(
            _run(sim, "sim"),
            _run(real, "real"),
            None if holdout_from_s is None else float(holdout_from_s),
            None if machine is None else os.fspath(machine),
        )
    )
