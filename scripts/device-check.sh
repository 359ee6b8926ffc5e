#!/usr/bin/env bash
# The checks that need a machine this project only borrows (a 16-core host with a GPU; DEVELOPERS.md,
# docs/performance.md 4.7): thread scaling of the Monte Carlo engine (one point, plane36, the command
# line, a Monte Carlo map) and of a GUM scan, the same bits for every thread count, and what the GPU
# and its run-time compiler offer (bench/experiments/gpu_probe.cc: the issue 37 groundwork).
#
#   scripts/device-check.sh pack   here, after a Release build in build/: packs vlt, vlt_bench, the
#                                  probe, every non-libc library they load and the jobs the checks
#                                  run into .devcarry/bundle.tar.xz (ignored by git; the device tool
#                                  carries at most 64 MiB, the files unpacked are about 70 MiB);
#                                  VLT_BASELINE=<vlt binary> adds a baseline build to compare with
#   scripts/device-check.sh run    there (the device tool: carry .devcarry, OUT set): runs every
#                                  check within about five minutes, writing logs and JSON to $OUT;
#                                  `run scan`: only the machine and the scans (one to two minutes);
#                                  `run gpu`: only the machine and the GPU path (docs/gpu.md: its
#                                  tests, a point at 10^7 trials, a map of 10^4 nodes at 10^5
#                                  trials, a custom-model job at 10^7 trials and the demo on
#                                  --device gpu and cpu, the files compared)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
CARRY=/tmp/vlt-devcarry  # the unpacked bundle, here while packing and there while running

pack() {
  rm -rf "$CARRY" "$ROOT/.devcarry"
  mkdir -p "$CARRY/lib" "$CARRY/jobs" "$ROOT/.devcarry"
  grep -qx '/.devcarry/' "$ROOT/.git/info/exclude" 2>/dev/null || echo '/.devcarry/' >>"$ROOT/.git/info/exclude"
  cp "$ROOT/build/runtime/vlt" "$ROOT/build/bench/vlt_bench" "$ROOT/build/tests/test_gpu_kernel" \
    "$ROOT/build/tests/test_gpu_custom" "$CARRY/"
  [[ -n "${VLT_BASELINE:-}" ]] && cp "$VLT_BASELINE" "$CARRY/vlt_baseline"
  g++ -O2 -std=c++20 -ffp-contract=off "$ROOT/bench/experiments/gpu_probe.cc" -ldl -o "$CARRY/gpu_probe"
  for bin in "$CARRY"/vlt "$CARRY"/vlt_bench "$CARRY"/test_gpu_kernel "$CARRY"/test_gpu_custom; do
    ldd "$bin" | awk '/=> \// {print $3}' |
      grep -v -E '/(libc|libm|libpthread|libdl|librt|ld-linux[^/]*)\.so' |
      while read -r lib; do cp -L "$lib" "$CARRY/lib/"; done
  done
  # One point, 10^7 trials (the issue's one-point job), and the demo job at 10^6 trials.
  cp "$ROOT/examples/panel_station.toml" "$ROOT/examples/panel_station_plan.csv" "$CARRY/jobs/"
  sed -e 's/^csv = .*/csv = "one_point.csv"/' -e '/^\[\[task\]\]/,$d' "$ROOT/examples/panel_station.toml" \
    >"$CARRY/jobs/one_point.toml"
  printf '[monte_carlo]\ntrials = 10000000\nseed = 1\n' >>"$CARRY/jobs/one_point.toml"
  printf 'name,x,y,z\nP,1500,400,0\n' >"$CARRY/jobs/one_point.csv"
  # A Monte Carlo map (357 nodes, docs/performance.md 4.6) and a scan of 10^5 points (GUM only).
  cp "$ROOT/examples/online_readings.toml" "$ROOT/examples/online_readings.csv" "$CARRY/jobs/"
  python3 "$ROOT/tests/cli/make_scan.py" 100000 "$CARRY/jobs/scan"
  gpu_jobs
  tar -C "$CARRY" -cJf "$ROOT/.devcarry/bundle.tar.xz" .
  du -sh "$CARRY" "$ROOT/.devcarry/bundle.tar.xz"
}

# The jobs of the GPU path (docs/gpu.md: a mirror tracker without stages): one point at 10^7
# trials, and a Monte Carlo map of 101 x 101 nodes at 10^5 trials. (The demo, with the air, runs
# from vlt itself.)
gpu_jobs() {
  local tracker='[tracker]\nmodel = "mirror"\n[tracker.noise]\nrange = "5 um + 0.5 um/m"\nazimuth = "1 arcsec"\nelevation = "1 arcsec"\n'
  printf '[job]\nname = "gpu_point"\n'"$tracker"'[plan]\nunit = "m"\npoint = [{name = "P", x = 5, y = 1, z = 0.4}]\n[monte_carlo]\ntrials = 10000000\nseed = 1\n' \
    >"$CARRY/jobs/gpu_point.toml"
  printf '[job]\nname = "gpu_map"\n'"$tracker"'[plan]\nunit = "m"\npoint = [{name = "P", x = 5, y = 1, z = 0.4}]\n[map]\nplane = "z=0.3"\nextent = "1,11,-5,5"\nstep = "0.1 m"\nmonte_carlo = true\n[monte_carlo]\ntrials = 100000\nseed = 1\n' \
    >"$CARRY/jobs/gpu_map.toml"
  # A custom-model job (JCGM 101 9.2.2's additive model, its inputs normal: drawn by the kernel).
  printf '[job]\nname = "gpu_custom"\n[model]\nname = "jcgm101_additive"\n[monte_carlo]\ntrials = 10000000\nseed = 1\n' \
    >"$CARRY/jobs/gpu_custom.toml"
}

# gpu: the GPU path's tests (the real-GPU one must pass, not skip), then the point and the map on
# --device gpu and --device cpu: their files the same bytes, the times in cli_times.txt.
gpu() {
  # (Not the tests that read the source tree or build a model: this is a copy elsewhere, without
  # vlt-gen.)
  "$CARRY/test_gpu_kernel" --gtest_filter='GpuKernel.*:GpuPath.*:-GpuKernel.EmbeddedSources*:GpuKernel.ABuiltModel*' 2>&1 |
    tee "$OUT/gpu_tests.txt" || true
  "$CARRY/test_gpu_custom" --gtest_filter='GpuCustom.OnARealGpu*' 2>&1 |
    tee -a "$OUT/gpu_tests.txt" || true
  # The CPU's part of a GPU run with the air, on 1 to 16 threads (bench/bench_mcm.cc
  # mcm/gpu_prepare/*, mcm/gpu_path/*: a stand-in device that costs nothing).
  "$CARRY/vlt_bench" --benchmark_filter='mcm/gpu_prepare|mcm/gpu_path' 2>&1 | grep -E '^mcm' |
    tee "$OUT/gpu_cpu_part.txt" || true
  local job device file
  # The tracker jobs' points.csv, the custom-model job's outputs.csv and budget.csv, and each
  # results.json without the timings.
  for job in gpu_point gpu_map gpu_custom; do
    for device in gpu cpu; do
      rm -rf "/tmp/vlt-$job-$device"
      timed "$job --device $device" "$CARRY/vlt" run "$CARRY/jobs/$job.toml" --device "$device" \
        -o "/tmp/vlt-$job-$device" --quiet
      strip_timings "/tmp/vlt-$job-$device/results.json" >"/tmp/$job-$device.json" 2>/dev/null || true
    done
    python3 -c 'import json,sys; m = json.load(open(sys.argv[2]))["monte_carlo"]; print(sys.argv[1], m["device"], m.get("device_note") or "")' \
      "$job" "/tmp/vlt-$job-gpu/results.json" >>"$OUT/cli_times.txt" 2>&1 || true
    same "$job results.json --device gpu" "/tmp/$job-gpu.json" "/tmp/$job-cpu.json"
    local files="points.csv"
    [[ $job == gpu_custom ]] && files="outputs.csv budget.csv"
    for file in $files; do
      same "$job $file --device gpu" "/tmp/vlt-$job-gpu/$file" "/tmp/vlt-$job-cpu/$file"
    done
  done
  same "gpu_map map.csv --device gpu" /tmp/vlt-gpu_map-gpu/map.csv /tmp/vlt-gpu_map-cpu/map.csv
  # The demo (the air stage prepared on the CPU, 34 points, three tasks, 2 10^5 trials).
  for device in gpu cpu; do
    rm -rf "/tmp/vlt-demo-$device"
    timed "demo --device $device" "$CARRY/vlt" demo --device "$device" -o "/tmp/vlt-demo-$device" --quiet
    strip_timings "/tmp/vlt-demo-$device/results.json" >"/tmp/demo-$device.json" 2>/dev/null || true
  done
  # Where the trials ran, and why not on the GPU if not (the comparison strips both lines).
  python3 -c 'import json,sys; m = json.load(open(sys.argv[1]))["monte_carlo"]; print("demo", m["device"], m.get("device_note", ""))' \
    /tmp/vlt-demo-gpu/results.json >>"$OUT/cli_times.txt" 2>&1 || true
  same "demo results.json --device gpu" /tmp/demo-gpu.json /tmp/demo-cpu.json
  for file in points.csv points.jsonl budget.csv tasks.csv map.csv; do
    same "demo $file --device gpu" "/tmp/vlt-demo-gpu/$file" "/tmp/vlt-demo-cpu/$file"
  done
}

# Results of a run without the timings, for comparing two runs byte for byte.
strip_timings() {
  python3 -c '
import json, sys
drop = {"seconds", "gum_seconds", "mcm_seconds", "created", "threads", "device", "device_note"}
def strip(o):
    if isinstance(o, dict): return {k: strip(v) for k, v in o.items() if k not in drop}
    if isinstance(o, list): return [strip(x) for x in o]
    return o
print(json.dumps(strip(json.load(open(sys.argv[1]))), sort_keys=True))' "$1"
}

# timed LABEL COMMAND...: runs the command, its output dropped, and appends its wall time and peak
# memory (or that it failed) to $OUT/cli_times.txt.
timed() {
  local label=$1; shift
  /usr/bin/time -f "$label wall %e s, max RSS %M KB" "$@" >/dev/null 2>>"$OUT/cli_times.txt" ||
    echo "$label FAILED" >>"$OUT/cli_times.txt"
}

# same LABEL FILE REFERENCE: appends whether FILE holds the same bytes as REFERENCE.
same() {
  if cmp -s "$2" "$3"; then echo "$1: the same bytes as $3"; else echo "$1: DIFFERS from $3"; fi \
    >>"$OUT/cli_times.txt"
}

# for_builds_and_threads CHECK ARGS...: CHECK ARGS... BUILD THREADS for this build and the baseline,
# on 1, 4 and 16 threads.
for_builds_and_threads() {
  local bin threads
  for bin in vlt vlt_baseline; do
    [[ -x "$CARRY/$bin" ]] || continue
    for threads in 1 4 16; do "$@" "$bin" "$threads"; done
  done
}

# cli_job JOB BUILD THREADS: `vlt run` of a job (one point at 10^7 trials, the demo panel at 10^6);
# its results without the timings must be those of 1 thread, bit for bit.
cli_job() {
  local job=$1 bin=$2 threads=$3 trials=10000000
  [[ $job == panel_station ]] && trials=1000000
  local dir="/tmp/vlt-$job-$bin-$threads"
  rm -rf "$dir"
  timed "$job $bin threads=$threads" \
    "$CARRY/$bin" run "$CARRY/jobs/$job.toml" --trials "$trials" --threads "$threads" -o "$dir" --quiet
  strip_timings "$dir/results.json" >"/tmp/$job-$bin-$threads.json" 2>/dev/null || true
  [[ $threads == 1 ]] || same "$job $bin threads=$threads" "/tmp/$job-$bin-$threads.json" "/tmp/$job-$bin-1.json"
}

# mcm_map BUILD THREADS: a Monte Carlo map (357 nodes, 10^5 trials); map.csv must be the bytes of
# this build on 1 thread.
mcm_map() {
  local bin=$1 threads=$2 dir="/tmp/vlt-map-$1-$2"
  rm -rf "$dir"
  timed "mcm map $bin threads=$threads" \
    "$CARRY/$bin" map "$CARRY/jobs/online_readings.toml" --plane z=0 --extent 1,6,-2,2 --step 0.25m \
    --mcm --trials 100000 --threads "$threads" -o "$dir" --quiet
  [[ $bin == vlt && $threads == 1 ]] || same "mcm map $bin threads=$threads" "$dir/map.csv" /tmp/vlt-map-vlt-1/map.csv
}

# scans: the scan of 10^6 points (issue 33, docs/performance.md 4.2: GUM, the compact per-point
# file by default) on 1, 2, 4, 8 and 16 threads, points.csv and tasks.csv the same bytes as on 1
# thread, and the baseline build's on 1 and 16 threads; the 10^5-point scan in full detail (what
# every scan wrote before), 1 and 16 threads.
scans() {
  python3 "$ROOT/tests/cli/make_scan.py" 1000000 "$CARRY/jobs/scan6" >/dev/null
  local threads dir
  for threads in 1 2 4 8 16; do
    dir="/tmp/vlt-scan6-$threads"
    rm -rf "$dir"
    timed "scan 1e6 vlt threads=$threads" \
      "$CARRY/vlt" run "$CARRY/jobs/scan6/scan.toml" --threads "$threads" -o "$dir" --quiet
    [[ $threads == 1 ]] && du -sb "$dir" >>"$OUT/cli_times.txt"
    [[ $threads == 1 ]] || same "scan 1e6 points.csv threads=$threads" "$dir/points.csv" /tmp/vlt-scan6-1/points.csv
    [[ $threads == 1 ]] || same "scan 1e6 tasks.csv threads=$threads" "$dir/tasks.csv" /tmp/vlt-scan6-1/tasks.csv
  done
  # Like for like with the baseline build (VLT_BASELINE at packing), where there is one: 1 and 16
  # threads, its files the same bytes as this build's.
  if [[ -x "$CARRY/vlt_baseline" ]]; then
    for threads in 1 16; do
      dir="/tmp/vlt-scan6-baseline-$threads"
      rm -rf "$dir"
      timed "scan 1e6 vlt_baseline threads=$threads" \
        "$CARRY/vlt_baseline" run "$CARRY/jobs/scan6/scan.toml" --threads "$threads" -o "$dir" --quiet
      same "scan 1e6 baseline points.csv threads=$threads" "$dir/points.csv" /tmp/vlt-scan6-1/points.csv
    done
  fi
  # Like for like, the detail every scan wrote before (points.jsonl, budget.csv, the full
  # points.csv): the 10^5-point scan with [output] detail = "full", 1 and 16 threads.
  cp "$CARRY/jobs/scan/scan.toml" "$CARRY/jobs/scan/scan_full.toml"
  printf '[output]\ndetail = "full"\n' >>"$CARRY/jobs/scan/scan_full.toml"
  for threads in 1 16; do
    rm -rf /tmp/vlt-scan-full
    timed "scan 1e5 full detail threads=$threads" \
      "$CARRY/vlt" run "$CARRY/jobs/scan/scan_full.toml" --threads "$threads" -o /tmp/vlt-scan-full --quiet
  done
  du -sb /tmp/vlt-scan-full >>"$OUT/cli_times.txt"
}

run() {
  : "${OUT:?OUT must name the folder for the results}"
  rm -rf "$CARRY" && mkdir -p "$CARRY" && tar -C "$CARRY" -xJf "$ROOT/.devcarry/bundle.tar.xz"
  export LD_LIBRARY_PATH="$CARRY/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  {
    date -u; uptime; nproc
    lscpu | grep -E 'Model name|^CPU\(s\)|Thread|Core|Socket|NUMA node\(s\)|Flags' | sed 's/Flags:.*avx512f.*/Flags: ... avx512f .../'
    nvidia-smi -L || true
  } 2>&1 | tee "$OUT/machine.txt"
  if [[ ${1:-all} == scan ]]; then
    scans
    cat "$OUT/cli_times.txt"
    return
  fi
  if [[ ${1:-all} == gpu ]]; then
    gpu
    cat "$OUT/cli_times.txt"
    return
  fi
  "$CARRY/gpu_probe" 2>&1 | tee "$OUT/gpu_probe.txt" || true
  # Monte Carlo thread scaling (bench/bench_mcm.cc mcm/scaling/*): three repetitions, their median.
  "$CARRY/vlt_bench" --benchmark_filter='mcm/scaling' --benchmark_repetitions=3 \
    --benchmark_out="$OUT/mcm_scaling.json" --benchmark_out_format=json 2>&1 | grep -E '^mcm' |
    tee "$OUT/mcm_scaling.txt"
  # The command line: one point at 10^7 trials and the demo job at 10^6, on 1, 4 and 16 threads,
  # this build against the baseline build in the same session; the results of every thread count
  # must be the same bits.
  local job threads
  for job in one_point panel_station; do
    for_builds_and_threads cli_job "$job"
  done
  # The Monte Carlo map, this build against the baseline: map.csv must be the same bytes for every
  # thread count and both builds.
  for_builds_and_threads mcm_map
  # The scan of 10^5 points (GUM, every per-point file), this build.
  for threads in 1 4 16; do
    rm -rf /tmp/vlt-scan
    timed "scan 1e5 vlt threads=$threads" \
      "$CARRY/vlt" run "$CARRY/jobs/scan/scan.toml" --threads "$threads" -o /tmp/vlt-scan --quiet
  done
  du -sh /tmp/vlt-scan >>"$OUT/cli_times.txt"
  scans
  cat "$OUT/cli_times.txt"
}

case "${1:-}" in
  pack) pack ;;
  run) run "${2:-all}" ;;
  *) echo "usage: $0 pack | run [all|scan|gpu]" >&2; exit 2 ;;
esac
