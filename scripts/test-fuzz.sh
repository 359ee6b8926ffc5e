#!/usr/bin/env bash
# CI stage 3: libFuzzer on the job parser, job + GUM, the CSV / quantity / map parsers and the
# network, test and calibration files
# (tests/fuzz/, docs/testing.md "Fuzzing"). Clang with ASan + UBSan + float-cast-overflow, the
# build of stage 2 (build-sanitize/, scripts/test-sanitizers.sh); each harness runs
# VLT_FUZZ_SECONDS (default 40) from a seed corpus of the examples and test jobs, as many harnesses
# at once as the machine has cores. Long runs: VLT_FUZZ_SECONDS=3600 bash scripts/test-fuzz.sh
# (findings go to build-sanitize/fuzz/findings/).
set -euo pipefail
source "$(dirname "$0")/lib.sh"
seconds=${VLT_FUZZ_SECONDS:-40}
vlt_build_sanitize
harnesses="$VLT_ROOT/build-sanitize/tests/fuzz"
dir="$VLT_ROOT/build-sanitize/fuzz"

# Seed corpora: every job file and CSV the project ships.
rm -rf "$dir/corpus" && mkdir -p "$dir/corpus/job" "$dir/corpus/parsers" "$dir/findings"
# Each file is copied under its path with '/' as '_': files of one name in different folders
# (tests/cli/calibration/unknown_target.toml, tests/cli/network/...) must not collide.
seed_corpus() {  # seed_corpus DEST FIND-ARGS...
  local dest=$1 f rel
  shift
  while IFS= read -r -d '' f; do
    rel=${f#"$VLT_ROOT/"}
    cp "$f" "$dest/${rel//\//_}"
  done < <(find "$VLT_ROOT/examples" "$VLT_ROOT/tests/cli" "$@" -type f -print0)
}
seed_corpus "$dir/corpus/job" -name '*.toml'
seed_corpus "$dir/corpus/parsers" -name '*.csv' -size -64k
printf '12 um\nz = 0.5 m\n0,4,-1,1\n' > "$dir/corpus/parsers/map_plane"
printf '0.8 arcsec\n-1,1,-1,1,0,2\n0.25 m\n' > "$dir/corpus/parsers/map_box"

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export LSAN_OPTIONS=suppressions=$VLT_ROOT/scripts/lsan.supp:print_suppressions=0
# fuzz_one NAME CORPUS : one harness for $seconds; its log in $dir/work/NAME.log.
fuzz_one() {
  local name=$1 corpus=$2
  mkdir -p "$dir/work/$name"
  "$harnesses/$name" -max_total_time="$seconds" -max_len=65536 -timeout=20 -rss_limit_mb=4096 \
      -artifact_prefix="$dir/findings/$name-" -print_final_stats=1 \
      "$dir/work/$name" "$dir/corpus/$corpus" 2>"$dir/work/$name.log"
}
# The harnesses run side by side, one per core (each is one process, one thread).
all=(fuzz_job:job fuzz_job_gum:job fuzz_custom_job:job fuzz_parsers:parsers fuzz_files:job)
# fuzz_files reads an input as a network, test layout, test job, calibration job and calibration
# file, beside copies of the examples' data files (tests/fuzz/fuzz_files.cc).
export VLT_FUZZ_DATA="$VLT_ROOT/examples/network:$VLT_ROOT/examples/calibration:$VLT_ROOT/examples/layouts"
cores=$(nproc)
declare -A pid_of
status=0
passed=0
for ((first = 0; first < ${#all[@]}; first += cores)); do
  names=()
  for harness in "${all[@]:first:cores}"; do
    name=${harness%%:*}
    echo "== $name: ${seconds} s"
    fuzz_one "$name" "${harness##*:}" &
    pid_of[$name]=$!
    names+=("$name")
  done
  for name in "${names[@]}"; do
    if ! wait "${pid_of[$name]}"; then
      echo "FAILED: $name found a problem; the input is in $dir/findings/ (log: $dir/work/$name.log)"
      tail -40 "$dir/work/$name.log"
      status=1
    else
      echo "$name:"
      grep -E "stat::number_of_executed_units|Done [0-9]+ runs" "$dir/work/$name.log" | tail -2
      passed=$((passed + 1))
    fi
  done
done
echo "fuzz: $passed passed, $((${#all[@]} - passed)) failed"
exit $status
