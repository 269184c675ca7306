#!/usr/bin/env bash
# embree-ratio.sh: shellsim's float tracer (one-ray and packet paths) against Embree on the same rays, in one run.
#
# The Cornell box (18 patches), the Cornell room subdivided to 1,183 and 21,175 patches
# (`scene gen corpus-subdivided-cornell --n 13 / 55`), each with the paper's 969 rings rays
# from 50 sources (48,450 rays), the grid sized to the scene; everything on one thread
# pinned to one core. Prints a Markdown table; ci/bench.sh reads its packet / Embree
# column into BENCHMARKS.md's `embree` rows.
#
#   bash ci/embree-ratio.sh
#
# VENV (default /tmp/embree-venv) gets embreex and numpy from PyPI when it lacks them;
# ROUNDS (default 3) alternates shellsim and Embree that many times, best of each kept.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=${VENV:-/tmp/embree-venv}
if ! "$venv/bin/python" -c "import embreex, numpy" 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q embreex numpy
fi
cargo build --release --example tracer_speed >&2
bin="${CARGO_TARGET_DIR:-target}/release/examples/tracer_speed"
"$venv/bin/python" -c "import embreex; print('embreex', getattr(embreex, '__version__', '?'))" >&2
exec taskset -c 0 "$venv/bin/python" ci/embree_ratio.py "$bin" "${ROUNDS:-3}" \
  scenes/cornell.json cornell-13 cornell-55
