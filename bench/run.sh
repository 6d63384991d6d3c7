#!/usr/bin/env bash
# `make bench`: every benchmark; results are printed and kept in bench/out/.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p bench/out
bench/io_read.sh | tee bench/out/io_read.txt
bench/core.sh | tee bench/out/core.txt
bench/engine.sh | tee bench/out/engine.txt
