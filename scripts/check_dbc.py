#!/usr/bin/env python3
"""Decode the hub's CAN frames with the DBC, or check the DBC.

    scripts/check_dbc.py                      check the DBC (exit 1 on mismatch)
    scripts/check_dbc.py 181#0A00F6FF7B000105 ...   decode frames given as ID#HEX
    scripts/check_dbc.py run.log              decode a candump log
                                              ("(1700000000.000000) can0 181#0102...")
    scripts/check_dbc.py run.log --against trace.csv
                                              decode a `thermcomp replay` log and check
                                              every HUB_OFFSETS and HUB_SLOPE against
                                              the replay's --trace (exit 1 on any
                                              difference)

Without arguments it checks, with cantools (requirements.txt):
  1. hand-written vectors below (known physical values -> bytes worked out
     from docs/wire-format.md): cantools must encode the values to exactly
     those bytes and decode the bytes back to the values;
  2. firmware/tests/data/can_vectors.json, which the firmware's Rust test
     (`can_frames::tests::shared_vectors_match_the_encoder`) proves equal to
     what the Rust encoder sends: cantools must decode every vector's bytes
     to its signal values (within half a bit) and re-encode them to the same
     bytes. Together: the Rust encoder and the DBC agree.
"""
import json
import math
import re
import sys
from pathlib import Path

import cantools

ROOT = Path(__file__).resolve().parent.parent
DBC = ROOT / "firmware" / "thermcomp.dbc"
VECTORS = ROOT / "firmware" / "tests" / "data" / "can_vectors.json"

# (frame id, data hex, signals): written from the spec, independent of Rust.
HAND_VECTORS = [
    # dx = +1.0 um, dy = -1.0 um, dz = +12.3 um, Running, counter 5
    (0x181, "0A00F6FF7B000105",
     {"OffsetOut1": 1.0, "OffsetOut2": -1.0, "OffsetOut3": 12.3, "HubState": 1, "Counter": 5}),
    # +500 um clamp value, Holding, counter 255
    (0x181, "881300000000 02FF".replace(" ", ""),
     {"OffsetOut1": 500.0, "OffsetOut2": 0.0, "OffsetOut3": 0.0, "HubState": 2, "Counter": 255}),
    # SENSOR_FAULT | NO_MODEL, channels 0 and 23 faulty, 24 inputs, 4 outputs
    (0x281, "4100010080981E09",
     {"SensorFault": 1, "SpikeRejected": 0, "Stale": 0, "ModelFault": 0, "Clamped": 0,
      "SlewLimited": 0, "NoModel": 1, "Uploading": 0, "Recovering": 0, "Extrapolating": 0,
      "Implausible": 0, "RateOfChange": 0, "Stuck": 0,
      "FaultyChannels": 0x800001,
      "InputCount": 24, "OutputCount": 4, "ConsecutiveFaults": 30, "Counter": 9}),
    # 4th output -0.1 um
    (0x381, "FFFF000000000100", {"OffsetOut4": -0.1, "HubState": 1, "Counter": 0}),
    # slope 1 um/m = 1000 counts, reference 100 mm, output 2
    (0x481, "E803000064000203", {"Slope": 1.0, "ReferencePos": 100, "SlopeOutput": 2, "Counter": 3}),
    (0x701, "05", {"NmtState": 5}),
    # EXTRAPOLATING alone (bit 9), Running, 3 inputs, 1 output
    (0x281, "0002000000230000",
     {"SensorFault": 0, "SpikeRejected": 0, "Stale": 0, "ModelFault": 0, "Clamped": 0,
      "SlewLimited": 0, "NoModel": 0, "Uploading": 0, "Recovering": 0, "Extrapolating": 1,
      "Implausible": 0, "RateOfChange": 0, "Stuck": 0,
      "FaultyChannels": 0, "InputCount": 3, "OutputCount": 1, "ConsecutiveFaults": 0, "Counter": 0}),
    # IMPLAUSIBLE | STUCK (bits 10, 12), Holding's inputs 0 and 2 faulty, 3 inputs, 1 output,
    # 12 faults in a row, counter 0x77
    (0x281, "0014050000230C77",
     {"SensorFault": 0, "SpikeRejected": 0, "Stale": 0, "ModelFault": 0, "Clamped": 0,
      "SlewLimited": 0, "NoModel": 0, "Uploading": 0, "Recovering": 0, "Extrapolating": 0,
      "Implausible": 1, "RateOfChange": 0, "Stuck": 1,
      "FaultyChannels": 5, "InputCount": 3, "OutputCount": 1, "ConsecutiveFaults": 12,
      "Counter": 0x77}),
    # RATE_OF_CHANGE alone (bit 11)
    (0x281, "0008000000230000",
     {"SensorFault": 0, "SpikeRejected": 0, "Stale": 0, "ModelFault": 0, "Clamped": 0,
      "SlewLimited": 0, "NoModel": 0, "Uploading": 0, "Recovering": 0, "Extrapolating": 0,
      "Implausible": 0, "RateOfChange": 1, "Stuck": 0,
      "FaultyChannels": 0, "InputCount": 3, "OutputCount": 1, "ConsecutiveFaults": 0,
      "Counter": 0}),
    # From the CNC: 12000 rpm (1,200,000 x 0.01 rpm), 15.5 kW (1550 x 0.01 kW)
    (0x201, "804F12000E060000", {"SpindleSpeed": 12000.0, "SpindlePower": 15.5}),
    # -1 rpm, power not available (0x7FFF)
    (0x201, "9CFFFFFFFF7F0000", {"SpindleSpeed": -1.0, "SpindlePower": 327.67}),
    # tool 100 mm (100,000 x 0.001 mm), position not available (0x7FFFFFFF)
    (0x301, "A0860100FFFFFF7F", {"ToolLength": 100.0, "AxisPosition": 2147483.647}),
    # CANopen (CiA 301): NMT start node 1; boot-up; EMCY 0x5000 sensor fault,
    # error register 0x81, STATUS flags 0x0001, input 2 faulty; SDO upload of
    # 0x1017:00 and the expedited 2-byte response 1000 ms (0x4B = scs 2, n 2, e, s).
    (0x000, "0101", {"NmtCommand": 1, "NmtNodeId": 1}),
    (0x701, "00", {"NmtState": 0}),
    (0x081, "0050810100040000",
     {"ErrorCode": 0x5000, "ErrorRegister": 0x81, "EmcyStatusFlags": 1, "EmcyFaultyChannels": 4}),
    (0x601, "4017100000000000", {"Command": 0x40, "Index": 0x1017, "SubIndex": 0, "Data": 0}),
    (0x581, "4B171000E8030000", {"Command": 0x4B, "Index": 0x1017, "SubIndex": 0, "Data": 1000}),
]


def half_bit(db, frame_id, name):
    sig = db.get_message_by_frame_id(frame_id).get_signal_by_name(name)
    return abs(sig.scale) / 2 + 1e-9


def check_vector(db, frame_id, data_hex, signals, label):
    """Returns a list of mismatch descriptions (empty when the DBC agrees)."""
    errors = []
    data = bytes.fromhex(data_hex)
    msg = db.get_message_by_frame_id(frame_id)
    decoded = msg.decode(data, decode_choices=False, scaling=True)
    if set(decoded) != set(signals):
        errors.append(f"{label}: signals {sorted(decoded)} != {sorted(signals)}")
        return errors
    for name, want in signals.items():
        if abs(decoded[name] - want) > half_bit(db, frame_id, name):
            errors.append(f"{label}: {name} decodes to {decoded[name]}, expected {want}")
    encoded = msg.encode(signals, scaling=True, strict=False, padding=False)
    if encoded != data:
        errors.append(f"{label}: cantools encodes {encoded.hex().upper()}, expected {data_hex}")
    return errors


def check(db):
    errors = []
    for i, (fid, hexdata, sigs) in enumerate(HAND_VECTORS):
        errors += check_vector(db, fid, hexdata, sigs, f"hand vector {i} ({fid:03X}#{hexdata})")
    if not VECTORS.exists():
        errors.append(f"{VECTORS} missing: run `cargo test -p firmware --lib` with UPDATE_CAN_VECTORS=1")
        shared = []
    else:
        shared = json.loads(VECTORS.read_text())["vectors"]
    for v in shared:
        errors += check_vector(db, v["id"], v["data"], v["signals"], v["name"])
    # Every frame in the DBC is covered by the shared vectors.
    covered = {v["id"] for v in shared}
    for m in db.messages:
        if m.frame_id not in covered:
            errors.append(f"{m.name} ({m.frame_id:#x}) has no shared vector")
    for e in errors:
        print("MISMATCH", e, file=sys.stderr)
    n = len(HAND_VECTORS) + len(shared)
    print(f"{DBC.name}: {len(db.messages)} frames, {n} vectors, "
          f"{'OK' if not errors else str(len(errors)) + ' mismatches'}")
    return 0 if not errors else 1


FRAME_RE = re.compile(r"^(?:\((?P<t>[0-9.]+)\)\s+\S+\s+)?(?P<id>[0-9A-Fa-f]{1,3})#(?P<data>[0-9A-Fa-f]*)$")


def decode_line(db, line):
    m = FRAME_RE.match(line.strip())
    if not m:
        raise ValueError(f"not a frame: {line.strip()!r}")
    fid, data = int(m["id"], 16), bytes.fromhex(m["data"])
    stamp = f"({m['t']}) " if m["t"] else ""
    try:
        msg = db.get_message_by_frame_id(fid)
    except KeyError:
        return f"{stamp}{fid:03X} unknown frame"
    sigs = msg.decode(data, decode_choices=True)
    body = " ".join(f"{k}={v}" for k, v in sigs.items())
    return f"{stamp}{msg.name} {body}"


def against(db, log, trace):
    """Every HUB_OFFSETS frame of `log`, decoded by cantools, equals the
    offsets `thermcomp replay` recorded as sent at that time (its trace's
    `<output>_sent` columns, model output order), and every HUB_SLOPE frame
    the slope recorded for its output (`<output>_slope_um_per_m`): the DBC
    reads the frames as the hub meant them."""
    import csv
    with open(trace, newline="") as f:
        rows = list(csv.DictReader(f))
    sent_cols = [c for c in rows[0] if c.endswith("_sent")] if rows else []
    outputs = [c[: -len("_sent")] for c in sent_cols]
    by_t = {round(float(r["t_s"]), 6): r for r in rows}
    n, n_slope, worst, worst_slope, bad = 0, 0, 0.0, 0.0, []
    for i, line in enumerate(Path(log).read_text().splitlines(), 1):
        m = FRAME_RE.match(line.strip())
        if not m:
            bad.append(f"{log}:{i}: not a frame")
            continue
        msg = db.get_message_by_frame_id(int(m["id"], 16))
        sig = msg.decode(bytes.fromhex(m["data"]))  # every frame must decode
        if msg.name not in ("HUB_OFFSETS", "HUB_SLOPE"):
            continue
        row = by_t.get(round(float(m["t"]), 6))
        if row is None:
            bad.append(f"{log}:{i}: no trace row at t = {m['t']}")
            continue
        if msg.name == "HUB_OFFSETS":
            got = [sig[f"OffsetOut{k + 1}"] for k in range(min(3, len(sent_cols)))]
            n += 1
            for g, c in zip(got, sent_cols):
                worst = max(worst, abs(g - float(row[c])))
        else:
            j = int(sig["SlopeOutput"])
            col = f"{outputs[j]}_slope_um_per_m" if j < len(outputs) else None
            if col not in row:
                bad.append(f"{log}:{i}: SLOPE for output {j}, which the trace has no slope for")
                continue
            n_slope += 1
            worst_slope = max(worst_slope, abs(sig["Slope"] - float(row[col])))
    if worst > 1e-9:
        bad.append(f"largest offset difference {worst} um")
    if worst_slope > 1e-9:
        bad.append(f"largest slope difference {worst_slope} um/m")
    print(f"{log}: {n} HUB_OFFSETS and {n_slope} HUB_SLOPE frames decoded by cantools "
          f"{cantools.__version__}; largest difference from the replay trace {worst:.2e} um, "
          f"{worst_slope:.2e} um/m: {'OK' if not bad else 'FAILED'}")
    for b in bad[:10]:
        print(b, file=sys.stderr)
    return 0 if not bad else 1


def main(argv):
    db = cantools.database.load_file(str(DBC))
    if not argv:
        return check(db)
    if len(argv) == 3 and argv[1] == "--against":
        return against(db, argv[0], argv[2])
    lines = []
    for arg in argv:
        p = Path(arg)
        if "#" not in arg and p.exists():
            lines += [(f"{arg}:{i}", l) for i, l in enumerate(p.read_text().splitlines(), 1) if l.strip()]
        else:
            lines.append(("argument", arg))
    status = 0
    for where, line in lines:
        try:
            print(decode_line(db, line))
        except Exception as e:  # a bad line is reported, the rest still decode
            print(f"{where}: {e}", file=sys.stderr)
            status = 1
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
