#!/usr/bin/env bash
# Files that are not files (issue 32 item 2, docs/cli.md "Files"): for every role a user gives a
# path in — the job file, a readings CSV, a plan CSV, a calibration file, a network station's
# readings, a calibration job — and every kind of path that used to hang vlt or end in "internal
# error" (a symbolic-link loop, a name component over 255 bytes, a FIFO, /dev/zero, a directory, a
# missing file), vlt must answer within seconds with exit 2, one line `vlt: error: ...` naming the
# file, and write nothing.
#   hostile_files.sh VLT SOURCE_DIR WORK_DIR
set -u
vlt=$1 src=$2 work=$3
rm -rf "$work" && mkdir -p "$work" && cd "$work" || exit 1
ln -s loop loop
mkfifo fifo
mkdir a_directory
long=$(printf 'x%.0s' $(seq 1 300)).csv
ln -s /dev/zero zero
kinds=(loop "$long" fifo zero a_directory missing.csv)
reasons=("Too many levels of symbolic links" "File name too long" "a FIFO" "a device" "a directory" "no such file")

# role: a job or network file naming `path` where the role's file goes; prints the command's file.
make_role() {
  local role=$1 path=$2 dir=role_$1_$3
  mkdir -p "$dir"
  case $role in
    job) echo "$path" ;;
    readings)
      sed "s|^csv = \"online_readings.csv\"|csv = \"../$path\"|" "$src/examples/online_readings.toml" > "$dir/job.toml"
      echo "$dir/job.toml" ;;
    plan)
      cp "$src/examples/panel_station.toml" "$dir/job.toml"
      sed -i "s|^csv = \"panel_station_plan.csv\"|csv = \"../$path\"|" "$dir/job.toml"
      echo "$dir/job.toml" ;;
    calibration)
      sed "s|^calibration = \"calibration.toml\"|calibration = \"../$path\"|" \
        "$src/examples/calibration/measure_with_calibration.toml" > "$dir/job.toml"
      cp "$src/examples/calibration/"*.csv "$dir/" 2>/dev/null
      echo "$dir/job.toml" ;;
    network)
      cp "$src/examples/network/"drift_S*.csv "$dir/"
      sed "s|\"drift_S1.csv\"|\"../$path\"|" "$src/examples/network/drift_network.toml" > "$dir/net.toml"
      echo "$dir/net.toml" ;;
  esac
}

fail=0
for role in job readings plan calibration network; do
  for k in "${!kinds[@]}"; do
    path=${kinds[$k]}
    file=$(make_role "$role" "$path" "$k")
    cmd=run
    [ "$role" = network ] && cmd=network
    out="out_${role}_$k"
    timeout 30 "$vlt" "$cmd" "$file" -o "$out" > stdout.txt 2> stderr.txt
    rc=$?
    lines=$(wc -l < stderr.txt)
    if [ "$rc" != 2 ] || [ "$lines" != 1 ] || ! grep -q "^vlt: error: .*${reasons[$k]}" stderr.txt || [ -e "$out" ]; then
      echo "FAIL $role / ${path:0:20}: exit $rc, $lines stderr lines, output $( [ -e "$out" ] && echo written || echo none ):"
      head -c 400 stderr.txt; echo
      fail=1
    fi
  done
done
[ "$fail" = 0 ] && echo "hostile files: every role and kind refused in one line, exit 2, nothing written"
exit $fail
