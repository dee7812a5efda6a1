#!/usr/bin/env bash
# Design choices of `fit --model auto` judged on calibration rows only:
#   A' = FL_THERMAL's first 16 h calibrate, 16-24 h scored (reduction %): the
#        calibration part of the 24 h protocol, split the same way (a higher
#        speed block held out);
#   B' = rows [0, 40 %) calibrate, [40 %, 60 %) scored (mean |error|, um): the
#        calibration part of the authors' split, split the same way.
# Extra arguments go to `thermcomp fit` (e.g. --auto-ensemble 1).
# usage: scripts/auto_dev_split.sh [thermcomp fit options]
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
exe=${THERMCOMP:-target/release/thermcomp}
run=../shared/data/fl_thermal/run.csv
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 - "$run" "$tmp" <<'PY'
import csv, sys
rows = list(csv.reader(open(sys.argv[1])))
head, body = rows[0], rows[1:]
n = len(body)
csv.writer(open(f"{sys.argv[2]}/a.csv", "w")).writerows([head] + [r for r in body if float(r[0]) < 86400])
csv.writer(open(f"{sys.argv[2]}/b.csv", "w")).writerows([head] + body[: int(0.6 * n)])
print(body[int(0.4 * n)][0], file=open(f"{sys.argv[2]}/b_split", "w"))
PY
b_split=$(cat "$tmp/b_split")
printf '%-8s %8s %8s\n' target "A' red%" "B' mae"
for ch in ch1_um ch2_um ch3_um ch4_um ch5_um; do
  a=$("$exe" fit --data "$tmp/a.csv" --target $ch --model auto --holdout-from-s 57600 --out "$tmp/m.bin" --json "$@" 2>/dev/null |
      python3 -c "import json,sys; print(round(json.load(sys.stdin)['targets']['$ch']['holdout']['reduction_pct'],1))")
  b=$("$exe" fit --data "$tmp/b.csv" --target $ch --model auto --holdout-from-s "$b_split" --out "$tmp/m.bin" --json "$@" 2>/dev/null |
      python3 -c "import json,sys; print(round(json.load(sys.stdin)['targets']['$ch']['holdout']['mean_abs_um'],2))")
  printf '%-8s %8s %8s\n' $ch "$a" "$b"
done
