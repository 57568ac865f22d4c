#!/bin/sh
# The long fuzzing run of issue 10: every libFuzzer harness of tests/fuzz/
# (tests/fuzz/README.md), one after the other on one CPU, for SECONDS each
# (default 3600: an hour per harness), on its corpus and on what earlier
# long runs found (build/fuzz/corpus/, kept between runs).  Prints, per
# harness, the executions, the coverage libFuzzer reached (cov: edges,
# ft: features), the corpus and the verdict, and fails when a harness
# crashed; its input is in build/fuzz/artifacts/NAME/: add it to
# tests/fuzz/corpus/NAME/ as a regression input (README.md) once reported.
#
#   bench/fuzz-long.sh [SECONDS] [HARNESS...]
#   bench/fuzz-long.sh 600 fuzz_bridge fuzz_config_yaml
#
# Environment: FUZZ_DIR (build/fuzz), MAKE (make).
set -u
cd "$(dirname "$0")/.."
seconds=${1:-3600}
[ $# -gt 0 ] && shift
FUZZ_DIR=${FUZZ_DIR:-build/fuzz}
export FUZZ_DIR

${MAKE:-make} -j2 fuzz-build || exit 1
if [ $# -eq 0 ]; then
	set -- $(for f in tests/fuzz/fuzz_*.c; do basename "$f" .c; done)
fi
start=$(date +%s)
echo "fuzz-long: $# harnesses, ${seconds}s each, from $(date -u +%FT%TZ)"
tests/fuzz/run --seconds "$seconds" --keep-going "$@"
rc=$?
echo "fuzz-long: $(($(date +%s) - start))s in all; logs in $FUZZ_DIR/logs/"
exit $rc
