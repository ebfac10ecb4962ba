#!/usr/bin/env bash
# Run every benchmark case of `mechsolve bench` and keep its output here:
# benchmarks/results.txt (the tables) and benchmarks/work-precision.png (time against error).
# Extra arguments go to `mechsolve bench` (for example --quick, or --case fourbar-kinematics).
# The peers (pylinkage with numba, exudyn) are compared when installed:
#   pip install -e '.[bench]'
set -euo pipefail
cd "$(dirname "$0")/.."
mechsolve bench --plot benchmarks/work-precision.png "$@" | tee benchmarks/results.txt
