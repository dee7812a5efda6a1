#!/usr/bin/env bash
# Regenerates the numbers and plots of docs/fl-thermal-gap.md: calibrate the
# twin on the first 24 h of the FL_THERMAL run, simulate the whole run from
# its logged speed, diagnose the gap, and extract the key plots as SVG.
#
#   scripts/fl-thermal-gap.sh [OUT_DIR]     # default: target/fl-thermal-gap
#
# Writes OUT_DIR/{cal.toml, cal.json, sim.csv, diagnose.json, report/index.html}
# and docs/img/fl-thermal-*.svg; prints the calibration's wall time (3 runs).
set -euo pipefail
cd "$(dirname "$0")/.."
REAL=../shared/data/fl_thermal/run.csv
[ -f "$REAL" ] || REAL=/work/shared/data/fl_thermal/run.csv
OUT=${1:-target/fl-thermal-gap}
mkdir -p "$OUT" docs/img
cargo build --release -q -p host-tools
BIN=${CARGO_TARGET_DIR:-target}/release/thermcomp

# 1. Calibrate on t < 24 h and simulate the whole run with the result.
for i in 1 2 3; do
  /usr/bin/time -f "calibration wall time: %e s, peak RSS %M KB" \
    "$BIN" simulate --calibrate "$REAL" --calibrate-until-s 86400 \
      --save-machine "$OUT/cal.toml" --out "$OUT/sim.csv" --json > "$OUT/cal.json"
done
# The same run from the saved machine file (what a user would do later).
"$BIN" simulate --machine "$OUT/cal.toml" --profile "file:$REAL" --out "$OUT/sim2.csv"
cmp "$OUT/sim.csv" "$OUT/sim2.csv" && echo "simulate --machine cal.toml reproduces the calibration's run"

# 2. Diagnose (hold-out from 24 h, the calibration end).
"$BIN" diagnose --sim "$OUT/sim.csv" --real "$REAL" --holdout-from-s 86400 \
  --report "$OUT/report" --json > "$OUT/diagnose.json"

# 3. Tables and plots.
python3 - "$OUT" <<'EOF'
import json, re, sys
out = sys.argv[1]
cal = json.load(open(f"{out}/cal.json"))
print("\nparameter                 value       at bound")
for k, p in cal["params"].items():
    print(f"{k:24s} {p['value']:12.4f} {p.get('unit','')} {p.get('at_bound','')}")
print(f"iterations {cal['iterations']}, simulations {cal['evaluations']}, rounds {cal['rounds']}, "
      f"converged {cal['converged']} ({cal['stop_reason']}), {cal['seconds']:.2f} s")
print("\n| channel | site | rmse < 24 h | fit % < 24 h | rmse >= 24 h | fit % >= 24 h |")
print("|---|---|---|---|---|---|")
def key(n):
    return (0 if n.endswith("_um") else 1, int(re.sub(r"\D", "", n) or 0))
for name in sorted(cal["channels"], key=key):
    c = cal["channels"][name]
    s = c.get("site")
    site = ""
    if s:
        site = s["node"] if s["share"] == 0 else f"{s['node']} {100*s['share']:.0f} % to {s['toward']}"
        site += f", {s['offset_c']:+.2f} K"
    u = "um" if c["unit"] == "um" else "K"
    a, b = c["calibration"], c["rest"]
    print(f"| {name} | {site} | {a['rmse']:.2f} {u} | {a['fit_pct']:.1f} | {b['rmse']:.2f} {u} | {b['fit_pct']:.1f} |")
d = json.load(open(f"{out}/diagnose.json"))
print(f"\nverdict {d['verdict']}, main channel {d['main_channel']} (snr {d.get('main_gap_snr')}), hold-out from {d['holdout_from_t_s']} s")
for e in d["effects"]:
    print(f"  {e['name']:11s} rms {e['rms_before']:.3f} -> {e['rms_after']:.3f}  shrink {e['shrink_pct']:.1f} %  {e.get('params')}")
print("second:", json.dumps(d.get("second")))
print("bands:", json.dumps(d.get("bands")))
for w in d["where"][:8]:
    print(f"  {w['channel']} {w['regime']:24s} {w['from_t_s']/3600:5.1f}-{w['to_t_s']/3600:5.1f} h share {w['share_pct']:.1f} %")
print("gap:", {k: v for k, v in d["gap"].items()})

# The report's inline SVGs, in page order: shrink bars, main residual with the
# best candidate, regime shares, then sim vs real per displacement channel,
# then residuals per channel.
html = open(f"{out}/report/index.html", encoding="utf-8").read()
svgs = re.findall(r"<svg.*?</svg>", html, flags=re.S)
main = d["main_channel"]
def find(title):
    for s in svgs:
        if title in s:
            return s
    return None
picks = {
    "fl-thermal-shrink.svg": svgs[0],
    "fl-thermal-main-residual.svg": svgs[1],
    "fl-thermal-where.svg": svgs[2],
    "fl-thermal-ch3-sim-vs-real.svg": find("ch3_um (um)"),
    "fl-thermal-ch5-sim-vs-real.svg": find("ch5_um (um)"),
    "fl-thermal-t5-residual.svg": find("T5 residual"),
    "fl-thermal-t4-residual.svg": find("T4 residual"),
}
for name, svg in picks.items():
    if svg:
        open(f"docs/img/{name}", "w", encoding="utf-8").write(svg + "\n")
        print("wrote docs/img/" + name)
EOF

# 4. The same diagnosis per channel: diagnose scores every candidate on one
# main channel (the displacement with the largest gap, here ch5_um), so cut
# both files down to one channel at a time to ask each sensor separately.
for ch in ch3_um ch5_um T1 T4 T5 T9; do
  python3 - "$REAL" "$OUT" "$ch" <<'EOF2'
import csv, sys
real, out, ch = sys.argv[1:]
for src, dst in [(real, f"{out}/real_{ch}.csv"), (f"{out}/sim.csv", f"{out}/sim_{ch}.csv")]:
    r = csv.reader(open(src)); h = next(r)
    keep = [i for i, c in enumerate(h) if c in ("t_s", "speed_rpm", ch)]
    w = csv.writer(open(dst, "w", newline=""))
    w.writerow([h[i] for i in keep])
    for row in r:
        w.writerow([row[i] for i in keep])
EOF2
  "$BIN" diagnose --sim "$OUT/sim_$ch.csv" --real "$OUT/real_$ch.csv" --holdout-from-s 86400 --json 2>/dev/null \
    | tee "$OUT/diagnose_$ch.json" | python3 -c "
import json, sys
d = json.load(sys.stdin); b = d['bands'][0]; e = d['effects']
none = next(x for x in e if x['name'] == 'none')
print(f\"| $ch | {d['verdict']} | {e[0]['name']} {e[0]['shrink_pct']:.1f} % | {none['shrink_pct']:.1f} % | {e[0]['rms_before']:.2f} | {b['slow_pct']:.0f} / {b['mid_pct']:.0f} / {b['fast_pct']:.1f} | {b['mid_peak_period_s']/60:.0f} min |\")"
done
# The gate that decided each channel's verdict, if one did (its reason
# states the quiet ratio and period of gate 5); the JSONs stay in $OUT.
for ch in ch3_um ch5_um T1 T4 T5 T9; do
  python3 -c "
import json
d = json.load(open('$OUT/diagnose_$ch.json'))
print('$ch:', d.get('gate') or 'no gate')"
done
