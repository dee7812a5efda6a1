"""The hub's EDS (firmware/thermcomp.eds) read by an independent CANopen
stack, the PyPI `canopen` package, and the TPDOs of a `thermcomp replay`
candump log (read by `python-can`) decoded with its PDO mapping.

    python3 -m pytest tests/python/test_canopen_eds.py

Needs target/release/thermcomp (`cargo build --release -p host-tools`; or
set THERMCOMP). The replay is of examples/fl_thermal_mlr16.toml on
examples/fl_thermal_holdout_60s.csv, as in .ci/run.
"""
import csv
import os
import subprocess
from pathlib import Path

import can
import canopen
import pytest

ROOT = Path(__file__).resolve().parents[2]
EDS = ROOT / "firmware" / "thermcomp.eds"
THERMCOMP = Path(os.environ.get("THERMCOMP", ROOT / "target" / "release" / "thermcomp"))
NODE_ID = 1
# TPDO1 carries offsets as INTEGER16 in 0.1 um; the trace prints the sent
# offsets rounded to 0.1 um, so both sides are the same multiple of 0.1 um:
# they agree to within float noise, and the tolerance is half a step.
OFFSET_UM_PER_BIT = 0.1
TOLERANCE_UM = OFFSET_UM_PER_BIT / 2


def remote_node():
    """The hub as a remote node on a network with no bus attached: frames
    are fed to it with `network.notify`, as a bus listener would."""
    network = canopen.Network()
    node = network.add_node(canopen.RemoteNode(NODE_ID, str(EDS)))
    # The mapping and COB-IDs as the EDS defaults state them (no SDO needed).
    node.tpdo.read(from_od=True)
    node.rpdo.read(from_od=True)
    return node


def test_eds_imports_with_the_dictionary_defaults():
    od = canopen.import_od(str(EDS), node_id=NODE_ID)
    assert od[0x1000].default == 0
    assert od[0x1017].default == 1000
    assert od[0x1018][2].default == 0x54430001
    assert od[0x1008].default == "thermcomp hub"
    # $NODEID+0x180 etc. resolved for node 1.
    assert od[0x1800][1].default == 0x181
    assert od[0x1803][1].default == 0x481
    assert od[0x1400][1].default == 0x201
    assert od[0x1200][2].default == 0x581
    assert od[0x1014].default == 0x81
    # Mapping: 0x2100:01, 16 bits first in TPDO1.
    assert od[0x1A00][1].default == 0x21000110
    assert od[0x2100][1].data_type == canopen.objectdictionary.INTEGER16
    assert od[0x2104].data_type == canopen.objectdictionary.UNSIGNED24
    assert od[0x2000][1].data_type == canopen.objectdictionary.REAL32
    assert od[0x2000][1].default == pytest.approx(500.0)
    assert (od[0x2006].min, od[0x2006].max) == (1, 127)


def test_pdo_mapping_lengths_and_cob_ids():
    node = remote_node()
    want = {1: (0x181, 8), 2: (0x281, 8), 3: (0x381, 8), 4: (0x481, 8)}
    for n, (cob, length) in want.items():
        assert node.tpdo[n].cob_id == cob
        assert sum(v.length for v in node.tpdo[n].map) == 8 * length
    assert node.rpdo[1].cob_id == 0x201
    assert node.rpdo[2].cob_id == 0x301


def test_rpdo_encodes_the_documented_frames():
    # docs/wire-format.md: 12,000 rpm, 15.5 kW -> 201#804F12000E060000;
    # tool 123.456 mm, position -0.5 mm -> 301#40E201000CFEFFFF.
    node = remote_node()
    rpdo1 = node.rpdo[1]
    rpdo1.map[0].raw = 1_200_000
    rpdo1.map[1].raw = 1550
    assert bytes(rpdo1.data).hex().upper() == "804F12000E060000"
    rpdo2 = node.rpdo[2]
    rpdo2.map[0].raw = 123_456
    rpdo2.map[1].raw = -500
    assert bytes(rpdo2.data).hex().upper() == "40E201000CFEFFFF"


@pytest.fixture(scope="module")
def replay(tmp_path_factory):
    assert THERMCOMP.exists(), f"{THERMCOMP} missing: cargo build --release -p host-tools"
    out = tmp_path_factory.mktemp("replay")
    model, log, trace = out / "m.bin", out / "replay.log", out / "trace.csv"
    subprocess.run([str(THERMCOMP), "model", "build", "--spec",
                    str(ROOT / "examples" / "fl_thermal_mlr16.toml"), "--out", str(model)],
                   check=True, capture_output=True)
    subprocess.run([str(THERMCOMP), "replay", "--model", str(model), "--data",
                    str(ROOT / "examples" / "fl_thermal_holdout_60s.csv"),
                    "--candump", str(log), "--trace", str(trace)],
                   check=True, capture_output=True)
    return log, trace


def test_replay_tpdos_decode_to_the_trace(replay):
    log, trace = replay
    with open(trace, newline="") as f:
        rows = list(csv.DictReader(f))
    sent_cols = [c for c in rows[0] if c.endswith("_sent")]
    by_t = {round(float(r["t_s"]), 6): r for r in rows}

    node = remote_node()
    tpdo1, tpdo2 = node.tpdo[1], node.tpdo[2]
    n_offsets = n_status = 0
    worst = 0.0
    first = None
    heartbeats = []
    for msg in can.CanutilsLogReader(str(log)):
        if first is None:
            first = msg
        cob, data, t = msg.arbitration_id, bytes(msg.data), round(msg.timestamp, 6)
        if cob == 0x701:
            heartbeats.append((t, data))
        elif cob == tpdo1.cob_id:
            node.network.notify(cob, data, msg.timestamp)
            row = by_t[t]
            for i, col in enumerate(sent_cols):
                got_um = tpdo1.map[i].raw * OFFSET_UM_PER_BIT
                worst = max(worst, abs(got_um - float(row[col])))
                assert abs(got_um - float(row[col])) <= TOLERANCE_UM, (t, col)
            assert tpdo1.map[3].raw == int(row["state"]), t  # 0x2101 hub state
            n_offsets += 1
        elif cob == tpdo2.cob_id:
            node.network.notify(cob, data, msg.timestamp)
            assert tpdo2.map[0].raw == int(by_t[t]["flags"]), t  # 0x2103 status flags
            assert tpdo2.map[4].raw == tpdo1.map[4].raw  # counters pair up
            n_status += 1
    assert n_offsets == len(rows) and n_status == len(rows)
    print(f"{n_offsets} TPDO1 frames decoded with the EDS; largest offset difference {worst:.3g} um")
    # Boot-up first, then operational heartbeats every 1000 ms.
    assert (first.arbitration_id, bytes(first.data)) == (0x701, b"\x00")
    assert all(d == b"\x05" for _, d in heartbeats[1:])
    gaps = {round(b[0] - a[0], 6) for a, b in zip(heartbeats[1:], heartbeats[2:])}
    assert gaps == {1.0}
