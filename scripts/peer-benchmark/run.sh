#!/usr/bin/env bash
# Peer benchmark (issue 12): N×N cable nets solved by tdeploy (default
# settings and pure DR), compas_dr and MusclePy, every answer checked to
# 1e-6 m against a Newton reference; prints the times and their ratios,
# all measured in this one run. Not part of CI: it needs PyPI and minutes.
#
#   scripts/peer-benchmark/run.sh [--sizes 5,7,11,15,21,31] [--muscle-budget-s 120]
#
# Makes its own virtual environment (CPython ≥ 3.10; PYTHON=… to choose)
# in target/peer-benchmark-venv with the pinned packages below, builds the
# `peer_nets` example in release mode, and runs nets.py.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
python="${PYTHON:-python3}"
venv="$root/target/peer-benchmark-venv"
if [ ! -x "$venv/bin/python" ]; then
    "$python" -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    compas_dr==0.3.1 compas==2.15.1 musclepy==1.1.0 numpy==2.4.6 scipy==1.17.1
(cd "$root" && cargo build --release --quiet --example peer_nets)
exec "$venv/bin/python" "$here/nets.py" \
    --tdeploy-example "$root/target/release/examples/peer_nets" \
    --net-file "$root/target/peer-benchmark-nets.json" \
    --repo-reference "$root/tests/data/cable-net-7x7.json" "$@"
