"""The package's figures against the CLI's --json on FL_THERMAL, exactly.

Tolerance: none. The package calls the very functions the CLI calls, on the
same float64 values, so every figure must be the same double (compared after
both JSON texts are parsed by Python, which reads shortest round-trip
decimals exactly). Keys that legitimately differ are dropped: `out` (the
CLI's blob path), `seconds` (wall-clock time) and per-run `file` names.
"""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import thermcomp

CHANNEL = "ch3_um"
HOLDOUT_S = 86400  # calibrate on the first 24 h (1250/2500/3750 rpm blocks)


def read_exact(path):
    """A CSV as exact doubles: pandas < 3's default parser can be an ulp off
    (float_precision="round_trip" fixes that; pandas 3 deprecates the option
    and parses exactly by default)."""
    if int(pd.__version__.split(".")[0]) >= 3:
        return pd.read_csv(path)
    return pd.read_csv(path, float_precision="round_trip")


def strip(v, keys=("out", "seconds", "file")):
    if isinstance(v, dict):
        return {k: strip(x, keys) for k, x in v.items() if k not in keys}
    if isinstance(v, list):
        return [strip(x, keys) for x in v]
    return v


def cli_json(cli, *args):
    status, out, err = cli(*args)
    assert status == 0, err
    assert len(out.splitlines()) == 1
    return json.loads(out)


@pytest.fixture(scope="module")
def fl_frame(fl_thermal):
    return read_exact(fl_thermal)


@pytest.mark.parametrize(
    "kind,extra",
    [
        ("mlr", {"inputs": ["T1", "T4", "T5", "T9", "T13"]}),
        ("auto", {"auto_families": "ridge", "auto_folds": 4, "auto_ensemble": 8}),
    ],
)
def test_fit_and_evaluate_match_the_cli(tmp_path, cli, fl_thermal, fl_frame, kind, extra):
    params = dict(extra)
    inputs = params.pop("inputs", None)
    args = ["fit", "--data", str(fl_thermal), "--target", CHANNEL, "--model", kind]
    args += ["--holdout-from-s", str(HOLDOUT_S), "--out", str(tmp_path / "m.bin"), "--json"]
    if inputs:
        args += ["--inputs", ",".join(inputs)]
    for k, v in params.items():
        args += ["--" + k.replace("_", "-"), str(v)]
    want = cli_json(cli, *args)

    for data in (str(fl_thermal), fl_frame):
        m = thermcomp.fit(data, CHANNEL, model=kind, inputs=inputs, holdout_from_s=HOLDOUT_S, **params)
        assert strip(m.fit_report) == strip(want)
        # The blob itself: byte for byte what the CLI wrote.
        assert m.blob == (tmp_path / "m.bin").read_bytes()

    held = want["targets"][CHANNEL]["holdout"]
    assert held["n"] == 11115 - HOLDOUT_S // 15, "rows from 24 h on are held out"

    ev_cli = cli_json(cli, "eval", "--model", str(tmp_path / "m.bin"), "--data", str(fl_thermal), "--json")
    assert strip(m.evaluate(str(fl_thermal))) == strip(ev_cli)
    assert strip(m.evaluate(fl_frame)) == strip(ev_cli)
    assert m.evaluate(fl_frame)[CHANNEL]["n"] == 11115


def test_predict_matches_the_cli_file(tmp_path, cli, fl_thermal, fl_frame):
    m = thermcomp.fit(fl_frame, CHANNEL, model="mlr", inputs="T1,T5,T9", holdout_from_s=HOLDOUT_S)
    m.save(tmp_path / "m.bin")
    status, _, err = cli("predict", "--model", str(tmp_path / "m.bin"), "--data", str(fl_thermal),
                         "--out", str(tmp_path / "p.csv"))
    assert status == 0, err
    want = read_exact(tmp_path / "p.csv")
    got = m.predict(fl_frame)
    assert list(got.columns) == list(want.columns) == ["t_s", f"{CHANNEL}_pred"]
    # The CLI writes the shortest exact text of each double: equal doubles.
    np.testing.assert_array_equal(got.to_numpy(), want.to_numpy())


def test_select_matches_the_cli(cli, fl_thermal, fl_frame):
    want = cli_json(cli, "select", "--data", str(fl_thermal), "--target", CHANNEL, "--method", "maxtree", "--json")
    got = thermcomp.select(fl_frame, CHANNEL, method="maxtree")
    assert got == want
    assert got["selected"] and all(s.startswith("T") for s in got["selected"])


def test_simulate_and_diagnose_match_the_cli(tmp_path, cli):
    opts = dict(hours=24, dt_s=120, profile="spectrum", effects="ambient", seed=3)
    real_df = thermcomp.simulate(**opts)
    real = tmp_path / "real.csv"
    args = ["simulate", "--out", str(real)] + sum((["--" + k.replace("_", "-"), str(v)] for k, v in opts.items()), [])
    assert cli(*args)[0] == 0
    want_real = read_exact(real)
    assert list(real_df.columns) == list(want_real.columns)
    np.testing.assert_array_equal(real_df.to_numpy(), want_real.to_numpy())
    assert len(real_df) == 24 * 3600 // 120 + 1

    sim = tmp_path / "sim.csv"
    assert cli("simulate", "--out", str(sim), "--profile", f"file:{real}", "--seed", "1003")[0] == 0
    want = cli_json(cli, "diagnose", "--sim", str(sim), "--real", str(real), "--json")
    sim_df = read_exact(sim)
    assert thermcomp.diagnose(sim_df, real_df) == want
    assert thermcomp.diagnose(str(sim), str(real)) == want
    assert want["verdict"] in {"ambient", "coolant", "cutting", "motor_loss", "sensor_lag", "none"}
