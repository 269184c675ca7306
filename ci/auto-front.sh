#!/usr/bin/env bash
# auto-front.sh BIN: the committed study (docs/explore/study.toml) at the cycle level and with
# timing = "auto", into docs/explore/study and docs/explore/study-auto; checks that the fronts
# of error against cycles are the same rows, and prints the cycle runs saved and the queue
# level's error on every machine point (docs/explore/auto.md).
set -euo pipefail
BIN=$(readlink -f "${1:-target/release/shellsim}")
cd "$(dirname "$0")/.."
RAYON_NUM_THREADS=1 "$BIN" explore run --space docs/explore/study.toml --out docs/explore/study
RAYON_NUM_THREADS=1 "$BIN" explore run --space docs/explore/study.toml --out docs/explore/study-auto --timing auto
cut_timing() { grep '^cycles,' "$1" | cut -d, -f1-9; }
if diff <(cut_timing docs/explore/study/front.csv) <(cut_timing docs/explore/study-auto/front.csv); then
  echo "the auto front equals the all-cycle front: $(cut_timing docs/explore/study/front.csv | wc -l) rows"
else
  echo "the fronts differ" >&2; exit 1
fi
grep -A2 '^| machine points' docs/explore/study-auto/report.md
python3 - <<'PY'
import csv, statistics
a = list(csv.DictReader(open('docs/explore/study/points.csv')))
b = list(csv.DictReader(open('docs/explore/study-auto/points.csv')))
e = [(abs(int(y['queue_cycles']) - int(x['cycles'])) / int(x['cycles']), y['timing'])
     for x, y in zip(a, b) if x['level'] == 'machine']
print(f"queue error on all {len(e)} machine points: mean {100*statistics.mean(v for v, _ in e):.2f} %, "
      f"max {100*max(v for v, _ in e):.2f} %; screened points above 10 %: "
      f"{sum(v > 0.10 and t == 'queue' for v, t in e)}")
PY
