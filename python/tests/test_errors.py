"""Errors are ThermcompError (a ValueError) with the CLI's one-line message."""

import numpy as np
import pandas as pd
import pytest

import thermcomp


def small_run(n=50):
    t = np.arange(n) * 60.0
    return pd.DataFrame({"t_s": t, "T1": 20 + 0.01 * t / 60, "T2": 20 + np.sin(t / 600), "dz_um": 0.5 * t / 60})


def test_error_type():
    assert issubclass(thermcomp.ThermcompError, ValueError)


def test_missing_target_message_is_the_clis(tmp_path, cli, fl_thermal):
    status, out, err = cli("fit", "--data", str(fl_thermal), "--target", "nope_um", "--model", "mlr",
                           "--out", str(tmp_path / "m.bin"))
    assert status != 0 and out == ""
    line = err.strip().removeprefix("error: ")
    with pytest.raises(thermcomp.ThermcompError) as e:
        thermcomp.fit(str(fl_thermal), "nope_um", model="mlr")
    assert str(e.value) == line


def test_non_finite_cell_names_row_and_column():
    df = small_run()
    df.loc[7, "T2"] = np.inf
    with pytest.raises(thermcomp.ThermcompError, match=r"^data:9:3 \(T2\): value \"inf\" is not finite$"):
        thermcomp.fit(df, "dz_um", model="mlr")


def test_time_must_increase():
    df = small_run()
    df.loc[10, "t_s"] = df.loc[9, "t_s"]
    with pytest.raises(thermcomp.ThermcompError, match=r"^data:12:1 "):
        thermcomp.fit(df, "dz_um", model="mlr")


def test_nan_is_a_missing_cell_not_an_error():
    df = small_run()
    df.loc[5, "T1"] = np.nan
    m = thermcomp.fit(df, "dz_um", model="mlr", inputs=["T1", "T2"], reference="absolute")
    p = m.predict(df)
    assert len(p) == len(df), "row for row"
    assert np.isnan(p["dz_um_pred"][5]) and np.isfinite(p["dz_um_pred"]).sum() == len(df) - 1


def test_bad_option_and_kind():
    with pytest.raises(thermcomp.ThermcompError, match="--variance"):
        thermcomp.fit(small_run(), "dz_um", model="pcr", variance="lots")
    with pytest.raises(thermcomp.ThermcompError, match='--model "svm": not one of auto, mlr'):
        thermcomp.fit(small_run(), "dz_um", model="svm")


def test_save_load_describe(tmp_path):
    m = thermcomp.fit(small_run(), "dz_um", model="mlr", inputs="T1,T2")
    m.save(tmp_path / "m.bin")
    back = thermcomp.load(tmp_path / "m.bin")
    assert back.blob == m.blob
    d = back.describe()
    assert d["kind"] == "linear" and d["outputs"] == ["dz_um"]
    assert [i["name"] for i in d["inputs"]] == ["T1", "T2"]
    (tmp_path / "bad.bin").write_bytes(m.blob[:-1] + bytes([m.blob[-1] ^ 1]))
    with pytest.raises(thermcomp.ThermcompError):
        thermcomp.load(tmp_path / "bad.bin")
