#!/usr/bin/env bash
# Hostile contents (a review of 2026-11-29 that tried some 400 mutated jobs, CSVs and paths): each
# input that had crashed vlt, hung it, written inf, ended in "internal error" or been taken
# silently, against the promise of docs/cli.md: exit 2, one line `vlt: error: <file>: <key or
# line>: <problem>`, nothing written; and the legal inputs among them run.
#   hostile_inputs.sh VLT SOURCE_DIR WORK_DIR
set -u
vlt=$1 src=$2 work=$3
rm -rf "$work" && mkdir -p "$work" && cd "$work" || exit 1
fail=0

# refused NAME REGEX ARGS...: `vlt ARGS -o out_NAME` exits 2 within 60 s with one line on stderr
# matching REGEX (grep -E) and writes nothing.
refused() {
  local name=$1 regex=$2
  shift 2
  timeout 60 "$vlt" "$@" -o "out_$name" > stdout.txt 2> stderr.txt
  local rc=$? lines
  lines=$(wc -l < stderr.txt)
  if [ "$rc" != 2 ] || [ "$lines" != 1 ] || ! grep -qE "^vlt: error: .*$regex" stderr.txt || [ -e "out_$name" ]; then
    echo "FAIL $name: exit $rc, $lines stderr lines, output $( [ -e "out_$name" ] && echo written || echo none ):"
    head -c 600 stderr.txt; echo
    fail=1
  fi
}

# accepted NAME ARGS...: `vlt ARGS -o out_NAME` exits 0 and no number in its CSVs is inf or nan.
accepted() {
  local name=$1
  shift
  timeout 120 "$vlt" -q "$@" -o "out_$name" > stdout.txt 2> stderr.txt
  local rc=$?
  if [ "$rc" != 0 ] || grep -qiE '(^|,)[+-]?(inf|nan)' out_"$name"/*.csv 2> /dev/null; then
    echo "FAIL $name: exit $rc:"
    head -c 600 stderr.txt; echo
    fail=1
  fi
}

cp "$src/examples/panel_station.toml" "$src/examples/panel_station_plan.csv" .
cp "$src/examples/online_readings.toml" "$src/examples/online_readings.csv" .

# A dotted key of 50 000 parts overflowed toml++'s stack (exit 139), in a job and a calibration.
python3 -c "open('deep.toml','w').write('a.' * 50000 + 'b = 1\n')"
refused deep_job "deep\.toml: line 1, column [0-9]+: a dotted key or table name of more than 64 parts" run deep.toml
refused deep_map "deep\.toml: line 1, column [0-9]+: a dotted key" map deep.toml --plane z=0 --extent 0,1,0,1 --step 0.5
refused deep_calibration "deep\.toml: line 1, column [0-9]+: a dotted key" run panel_station.toml --calibration deep.toml

# A plan CSV with a header of 10^6 columns (a pairwise check of repeated names hung for minutes).
python3 -c "
n = 1000000
with open('wide.csv', 'w') as f:
    f.write('name,x,y,z,' + ','.join('c%d' % i for i in range(n)) + '\n')
    f.write('A,1,0,0,' + ','.join('0' for i in range(n)) + '\n')"
sed 's|^csv = "panel_station_plan.csv"|csv = "wide.csv"|' panel_station.toml > wide.toml
refused wide_header "wide\.csv: line 1: unknown column 'c0'" run wide.toml --no-mcm

# A NUL byte in a CSV field cut the message where it quoted the field.
printf 'name,x,y,z\nA,1\000,0,0\n' > nul.csv
sed 's|^csv = "panel_station_plan.csv"|csv = "nul.csv"|' panel_station.toml > nul.toml
refused nul_csv "nul\.csv: line 2: a NUL byte \(not a text file\?\)$" run nul.toml --no-mcm

# Map bounds beyond 1e12 m overflowed the nodes' coordinates to -inf in every file.
refused map_extent "command line: extent: beyond what vlt computes with" \
  map panel_station.toml --plane z=0 --extent -1e300,1e300,0,1 --step 1e299
refused map_level "command line: plane: beyond what vlt computes with" \
  map panel_station.toml --plane z=1e300 --extent 0,1,0,1 --step 0.5
# Nodes 1000 km away are skipped (beyond any tracker), not computed as "ok".
accepted map_far map panel_station.toml --plane z=0 --extent -1e6,1e6,0,1 --step 1e5
if [ "$(grep -c 'skipped: beyond any laser tracker' out_map_far/map.csv)" != 20 ]; then
  echo "FAIL map_far: expected 20 nodes skipped beyond 10 km"; fail=1
fi

# An empty -o fell back to the default directory unsaid.
timeout 60 "$vlt" run panel_station.toml --no-mcm -o "" > stdout.txt 2> stderr.txt
rc=$?
if [ "$rc" != 2 ] || [ "$(wc -l < stderr.txt)" != 1 ] || ! grep -q '^vlt: error: command line: --output: an empty path' stderr.txt ||
  [ -e vlt-out ]; then
  echo "FAIL empty_output: exit $rc:"; head -c 600 stderr.txt; echo; fail=1
fi

# A declared face column that is missing, and an empty unit, were taken silently.
sed 's|face = "Face"|face = "Fcae"|' online_readings.toml > face.toml
grep -q 'Fcae' face.toml || { echo "FAIL: online_readings.toml has no columns.face to mutate"; fail=1; }
refused face_column "online_readings\.csv: line [0-9]+: missing column 'Fcae' \(declared by readings\.columns\.face\)" run face.toml --no-mcm
sed 's|azimuth = "deg"|azimuth = ""|' online_readings.toml > unit.toml
grep -q 'azimuth = "",' unit.toml || { echo "FAIL: online_readings.toml has no units.azimuth to mutate"; fail=1; }
refused empty_unit "unit\.toml: readings\.units\.azimuth: empty unit" run unit.toml --no-mcm

# A job file that starts with a UTF-8 byte order mark (Windows editors) runs.
printf '\357\273\277' > bom.toml && cat panel_station.toml >> bom.toml
accepted bom run bom.toml --no-mcm

# An output directory named with 250 bytes (legal) could not be staged (its staging name passed 255).
long=$(printf 'c%.0s' $(seq 1 250))
if ! timeout 60 "$vlt" -q run panel_station.toml --no-mcm -o "$long" 2> stderr.txt || [ ! -f "$long/points.csv" ]; then
  echo "FAIL long_name:"; head -c 600 stderr.txt; echo; fail=1
fi

# Two stations whose names map to one file name (S/1 and S 1 -> S_1) shared one simulated
# readings file: the second overwrote the first, and adjusting the simulated network put S 1 at
# S/1's pose, exit 0. Each now has its own file, and each station comes back where it was.
cp "$src/examples/network/wing_targets.csv" .
cat > collide.toml << 'TOML'
[job]
name = "collide"
[tracker]
model = "head"
[tracker.noise]
range = "1 um + 0.4 um/m"
azimuth = "0.5 arcsec"
elevation = "0.5 arcsec"
[targets]
csv = "wing_targets.csv"
[datum]
station = "S/1"
[[station]]
name = "S/1"
rz = "15 deg"
tx = "-3.0 m"
ty = "1.2 m"
tz = "0.4 m"
sees = "all"
[[station]]
name = "S 1"
rz = "170 deg"
tx = "11.0 m"
ty = "1.5 m"
tz = "0.5 m"
sees = "all"
TOML
accepted collide network collide.toml --simulate 3
if [ "$(grep "csv = 'simulated_S_1" out_collide/simulated_network.toml | sort -u | wc -l)" != 2 ]; then
  echo "FAIL collide: the two stations do not have two files:"; grep "csv =" out_collide/simulated_network.toml; fail=1
fi
(cd out_collide && timeout 60 "$vlt" -q network simulated_network.toml -o ../out_collide_adjusted) ||
  { echo "FAIL collide: the simulated network does not adjust"; fail=1; }
if ! grep -q '^S 1,false,[^,]*,[^,]*,[^,]*,1[01]\.' out_collide_adjusted/stations.csv; then
  echo "FAIL collide: station 'S 1' is not back near tx = 11 m:"; cat out_collide_adjusted/stations.csv; fail=1
fi

# A test layout beyond a tracker's reach (a two-face target 14 km away) was simulated, and the
# calibration its files fed then refused its readings; refused where the layout is read.
cat > far_layout.toml << 'TOML'
[layout]
name = "far"
[[two_face]]
name = "t"
distance = "9999 m"
height = "9999 m"
TOML
cat > far_test.toml << 'TOML'
[tracker]
model = "head"
[tracker.noise]
range = "1 um + 0.2 um/m"
azimuth = "0.1 arcsec"
elevation = "0.1 arcsec"
[tests]
layout = "far_layout.toml"
TOML
refused far_layout "far_layout\.toml: two_face\[0\]: 14140\.7 m from the tracker: beyond any laser tracker" test far_test.toml

[ "$fail" = 0 ] && echo "hostile inputs: each refused in one line with exit 2 and nothing written, or run"
exit $fail
