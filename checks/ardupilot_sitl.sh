#!/usr/bin/env bash
# Fly `convoy-mav run` against real ArduPilot SITL: three ArduCopters or three
# ArduPlanes protecting a scripted convoy, then score the flight from the tlog.
#
#   SITL_DIR=/path/to/ardupilot checks/ardupilot_sitl.sh plane [DURATION_S] [SPEEDUP]
#   SITL_DIR=/path/to/ardupilot checks/ardupilot_sitl.sh copter
#   SECOND_AFTER=60 SITL_DIR=... checks/ardupilot_sitl.sh plane 600 5
#   SET_SPEEDUP=60:2 SITL_DIR=... checks/ardupilot_sitl.sh copter 600 5
#   ROAD=bends SITL_DIR=... checks/ardupilot_sitl.sh plane 700 5
#   UAVS=4 KILL=60:20 SITL_DIR=... checks/ardupilot_sitl.sh copter 700 5
#
# With SECOND_AFTER (wall s), a second `convoy-mav run` is started then on the same
# aircraft through another of their MAVLink ports (serial1, TCP 5762+10K): it must
# refuse them (exit 2, "driven by another ground station"), and the first service
# warn of it (uav_contested); its output is in out/sitl-FRAME/second.log.
#
# With SET_SPEEDUP=AFTER_S:VALUE, every instance's SIM_SPEEDUP is set to VALUE AFTER_S wall
# s in, by PARAM_SET from another MAVLink client (serial2, TCP 5763+10K), as a user would
# from MAVProxy: the service's mission clock must follow the new rate at once (the
# report's mission_clock: rate_changes, speedup) and the flight go on covered.
# SET_PARAM=AFTER_S:NAME=VALUE sets any parameter so, and PARAMS="NAME=VALUE ..." starts
# every instance with those values over its defaults, e.g. a plane slower than the plan
# (PARAMS="AIRSPEED_MAX=24" SET_PARAM=80:AIRSPEED_MAX=30 ... plane 600 5): the
# service's airframe alarm is raised at set-up and cleared once the range is raised.
#
# CONFIG=FILE flies another mission config on the same three ports, e.g.
# CONFIG=checks/sitl_copter_fast.toml (copters asked for 18 m/s, faster than SITL's quad
# flies at ANGLE_MAX 30 degrees: the service sees its top speed and alarms).
#
# With UAVS=N (more than 3), N aircraft fly the scripted convoy: spares beyond the
# paper's minimum.
#
# With LINK=1, every UAV's link (and ROVER's) runs through a lossy, laggy radio
# (checks/lossy_link.py: the soak's faults, 30 % loss each way, 200 ms latency plus up to
# 100 ms of jitter, 5 % repeated, in simulated time); LINK="--seed 5 --loss 0.1 ..."
# passes its options.
#
# With KILL=AFTER_S:DOWN_S, UAV 1's SITL process is killed AFTER_S wall s in (in flight:
# a power loss) and started again DOWN_S wall s later, on its pad with its eeprom: the
# service must declare it lost, fly on with the others, and set it up, launch it and
# rejoin it once it is back (the report's alarms and events say when).
#
# With ROAD=KIND (a generated road of src/convoy_mav/tracks/roads.py: bends, hairpins,
# urban...), the convoy is two sitl-mock rovers driving that road (300 m north of home,
# setting off 30 sim s in) at the same speedup, and the service sees only their
# telemetry (no route), with the service's count for a road without one (``road_fleet``:
# the stationary minimum + 2, five ArduPlanes; UAVS=N flies N instead, e.g. UAVS=4, the
# count with a route, as the README's first SITL road rows were). The score is the
# rovers' own positions in the tlog.
#
# With ROVER=1 as well, the convoy is one real rover instead: an ArduRover SITL (sysid
# 60, instance 20, its home at the road's start) sent down the road as its mission in
# AUTO at ROVER_SPEED m/s (8; checks/rover_mission.py drive, through its serial1) once its
# position estimate is good, and the service reads that mission as the route
# ([convoy] route = "mission"), with the count for a road with one (the stationary
# minimum + 1). Its speeds and its corners are the firmware's, not the road's. The
# mission sets the speed with a DO_CHANGE_SPEED, which the service reads as the convoy's
# planned speed; ROVER_NO_PLAN_SPEED=1 leaves it out (the rover drives its WP_SPEED, the
# same, and the service has no planned speed), to weigh the plan against the firmware.
# ROVER_HOLDS="AT:FOR ..." has its operator hold it (HOLD at its boot time AT s, AUTO
# again FOR s later; checks/rover_mission.py drive --hold): the service hears each mode.
# ROVER_SPEEDS="AT:MPS ..." has its operator tell it a speed (DO_CHANGE_SPEED at boot
# time AT s; drive --speed-at): the service sees the speed it keeps (planner.convoy_kept).
# ROVER_MOVES="AT:METRES ..." has its operator move a waypoint ahead and upload the
# mission again as it drives (drive --move-at): the service reads it again.
# ROVER_RTL="AT:FOR ..." has its operator call it home (RTL at boot time AT s, AUTO
# again FOR s later; drive --rtl-at): the service forecasts it home and back.
# ROVER_RALLY=METRES uploads a rally point that far to its left before each RTL (drive
# --rally-left): the service reads it and forecasts the convoy there.
# ROVER_SMART_RTL="AT:FOR ..." sends it home back along its path (SMART_RTL at boot time
# AT s, AUTO again FOR s later; drive --smart-rtl-at): forecast back along that path.
#
# SITL_DIR is an ArduPilot tree with build/sitl/bin/arducopter and arduplane built
# (see the project's notes on building SITL; it is not part of `make test`).
# Each instance pushes MAVLink to udpin:127.0.0.1:1456K (its --serial0) and writes
# its eeprom and logs under out/sitl-FRAME/K. The mission's R, r and V make three the
# paper's minimum (see checks/sitl_*.toml). Prints per UAV the take-off, tracking
# error and coverage, scored from the tlog (checks/sitl_report.py).
set -euo pipefail
frame=${1:?usage: checks/ardupilot_sitl.sh copter|plane [DURATION_S] [SPEEDUP]}
duration=${2:-600}
speedup=${3:-1}
: "${SITL_DIR:?set SITL_DIR to an ArduPilot tree with build/sitl/bin built}"
cd "$(dirname "$0")/.."
case $frame in
  copter) bin=arducopter; model=+; defaults=Tools/autotest/default_params/copter.parm ;;
  plane) bin=arduplane; model=plane; defaults=Tools/autotest/models/plane.parm ;;
  *) echo "frame must be copter or plane, not $frame" >&2; exit 2 ;;
esac
exe=$SITL_DIR/build/sitl/bin/$bin
[ -x "$exe" ] || { echo "$exe not found: build SITL first" >&2; exit 2; }
py=${PYTHON:-.venv/bin/python}
out=out/sitl-$frame
rm -rf "$out" && mkdir -p "$out"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT INT TERM
# Homes 40 m apart along a line east of the mission origin (CMAC, ArduPilot's default;
# HOME_ALT=M sets the airfield M metres above the sea, with ROAD only).
lat=-35.363262 lon=149.165237 alt=${HOME_ALT:-584}
base=${CONFIG:-checks/sitl_$frame.toml}  # (the three UAVs, the aircraft and the convoy)
config=$base
uavs=3
if [ -z "${ROAD:-}" ] && [ "${UAVS:-3}" -gt 3 ]; then  # more than the paper's minimum: spares
  uavs=$UAVS config=$out/fleet.toml
  { sed -n '/^\[convoy\]/q;p' "$base"
    for k in $(seq 4 "$uavs"); do
      printf '[[uav]]\nconnection = "udpin:127.0.0.1:%d"\nsysid = %d\n\n' $((14560 + k - 1)) "$k"
    done
    sed -n '/^\[convoy\]/,$p' "$base"; } >"$config"
fi
rover_port=14600  # (the real rover's link: through the radio too with LINK)
[ -n "${LINK:-}" ] && rover_port=14900
if [ -n "${ROAD:-}" ]; then
  config=$out/road.toml
  # The road as the mock's CSV track, and the config: the aircraft past the base
  # config's three, the rovers' links. The mock's own aircraft (idle) keep the rovers'
  # ids past the service's UAVs. Prints the fleet's size.
  uavs=$("$py" - "$ROAD" "$out" "$base" "${UAVS:-0}" $lat $lon $alt "${ROVER:-}" <<'PY'
import sys
from convoy_mav.config import load_config
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mission.choose import road_fleet
from convoy_mav.tracks.roads import road_kind
kind, out, base = sys.argv[1:4]
asked, (lat, lon, alt), rover = int(sys.argv[4]), (float(x) for x in sys.argv[5:8]), sys.argv[8]
plan = load_config(base).plan_request()
fleet = asked or road_fleet(plan.turn_radius, plan.sensor_radius, route=bool(rover))
road, frame = road_kind(kind), LocalFrame(GeoPoint(lat, lon, alt))
with open(f"{out}/road.csv", "w") as fh:
    fh.write("time,lat,lon\n")
    for t, n, e in zip(road.t, road.true_north, road.true_east, strict=True):
        g = frame.to_geo(float(n) + 300.0, float(e))
        fh.write(f"{float(t) + 30.0:.2f},{g.lat:.8f},{g.lon:.8f}\n")
text = open(base).read()
head = text[: text.index("[convoy]")]
if alt != 584.0:  # (the base config's origin is SITL's default home)
    head = head.replace("alt = 584.0 }", f"alt = {alt} }}")
links = "".join(
    f'[[convoy.vehicle]]\nconnection = "udpout:127.0.0.1:{14640 + s - 1}"\nsysid = {s}\n\n'
    for s in (fleet + 2, fleet + 3)
)
more = "".join(
    f'[[uav]]\nconnection = "udpin:127.0.0.1:{14560 + k - 1}"\nsysid = {k}\n\n'
    for k in range(4, fleet + 1)
)
convoy = '[convoy]\nsource = "mavlink"\n\n'
if rover:  # the real rover's own link, and its mission as the route
    convoy = '[convoy]\nsource = "mavlink"\nroute = "mission"\n\n'
    links = '[[convoy.vehicle]]\nconnection = "udpin:127.0.0.1:14600"\nsysid = 60\n\n'
with open(f"{out}/road.toml", "w") as fh:
    fh.write(head + more + convoy + links)
print(fleet)
PY
)
  if [ -n "${ROVER:-}" ]; then
    rover_home=$(sed -n 2p "$out/road.csv" | cut -d, -f2,3)
    mkdir -p "$out/rover"
    printf 'WP_SPEED %s\nCRUISE_SPEED %s\n' "${ROVER_SPEED:-8}" "${ROVER_SPEED:-8}" >"$out/rover.parm"
    (cd "$out/rover" && exec "$SITL_DIR/build/sitl/bin/ardurover" --model rover \
        --speedup "$speedup" -I 20 --sysid 60 --home "$rover_home,$alt,0" \
        --defaults "$SITL_DIR/Tools/autotest/default_params/rover.parm,$PWD/../rover.parm" \
        --serial0 "udpclient:127.0.0.1:${rover_port}" >sitl.log 2>&1) &
    pids+=($!)
    mission_speed=${ROVER_SPEED:-8}
    [ -n "${ROVER_NO_PLAN_SPEED:-}" ] && mission_speed=0  # (no DO_CHANGE_SPEED: WP_SPEED)
    holds=()
    for h in ${ROVER_HOLDS:-}; do holds+=(--hold "$h"); done  # (its operator's HOLDs)
    for v in ${ROVER_SPEEDS:-}; do holds+=(--speed-at "$v"); done  # (... and speeds)
    for m in ${ROVER_MOVES:-}; do holds+=(--move-at "$m"); done  # (... and its edits)
    for r in ${ROVER_RTL:-}; do holds+=(--rtl-at "$r"); done  # (... and its RTLs)
    [ -n "${ROVER_RALLY:-}" ] && holds+=(--rally-left "$ROVER_RALLY")  # (... to a rally point)
    for r in ${ROVER_SMART_RTL:-}; do holds+=(--smart-rtl-at "$r"); done  # (... and SMART_RTLs)
    "$py" checks/rover_mission.py drive tcp:127.0.0.1:5962 "$out/road.csv" "$mission_speed" \
      "${holds[@]}" >"$out/rover_drive.log" 2>&1 &
    pids+=($!)
  else
    .venv/bin/sitl-mock --aircraft $((uavs + 1)) --ground 2 --personality ardupilot \
      --frame "$frame" --speedup "$speedup" --base-port 14640 --origin="$lat,$lon,$alt" \
      --ground-route csv --ground-csv "$out/road.csv" >"$out/mock.log" 2>&1 &
    pids+=($!)
  fi
fi
serial_base=14560  # (SITL instance K sends to serial_base + K)
if [ -n "${LINK:-}" ]; then  # a lossy, laggy radio between the UAVs and the service
  serial_base=14860
  link_args=()
  [ "$LINK" != 1 ] && read -ra link_args <<<"$LINK"
  "$py" checks/lossy_link.py --speedup "$speedup" "${link_args[@]}" \
    $(for k in $(seq 0 $((uavs - 1))); do echo "$((14860 + k)):$((14560 + k))"; done) \
    ${ROVER:+14900:14600} \
    >"$out/link.log" 2>&1 &
  link_pid=$!
  pids+=("$link_pid")
fi
start_instance() {  # start_instance K: SITL instance K (UAV K+1) on its pad; sets $pid
  local k=$1 home
  home=$("$py" -c "
from convoy_mav.geo import GeoPoint, LocalFrame
g = LocalFrame(GeoPoint($lat, $lon, $alt)).to_geo(0.0, 40.0 * $k)
print(f'{g.lat:.7f},{g.lon:.7f},$alt,90')")
  (cd "$out/$k" && exec "$exe" --model "$model" --speedup "$speedup" \
      --defaults "$defaults" -I "$k" --sysid $((k + 1)) --home "$home" \
      --serial0 "udpclient:127.0.0.1:$((serial_base + k))" >>sitl.log 2>&1) &
  pid=$!
}
if [ -n "${SET_SPEEDUP:-}" ]; then SET_PARAM=${SET_SPEEDUP%%:*}:SIM_SPEEDUP=${SET_SPEEDUP#*:}; fi
if [ -n "${PARAMS:-}" ]; then  # over the frame's defaults, in ArduPilot's parm format
  for kv in $PARAMS; do echo "${kv%%=*} ${kv#*=}"; done >"$out/extra.parm"
  defaults="$SITL_DIR/$defaults,$PWD/$out/extra.parm"
else
  defaults=$SITL_DIR/$defaults
fi
for k in $(seq 0 $((uavs - 1))); do
  mkdir -p "$out/$k"
  start_instance "$k"
  pids+=("$pid")
  [ "$k" = 0 ] && uav1_pid=$pid  # (the rovers, the mock or the radio may come first)
done
if [ -n "${KILL:-}" ]; then
  (sleep "${KILL%%:*}"
   kill -9 "$uav1_pid"
   echo "$(date +%T) UAV 1's SITL killed" >"$out/kill.log"
   sleep "${KILL#*:}"
   start_instance 0
   echo "$(date +%T) UAV 1's SITL started again (pid $pid)" >>"$out/kill.log"
   wait "$pid") &
  pids+=($!)
fi
echo "SITL: $uavs x $bin (speedup $speedup), logs in $out/K/sitl.log${ROAD:+; road $ROAD by sitl-mock}"
if [ -n "${SECOND_AFTER:-}" ]; then
  sed -e 's/udpin:127.0.0.1:14560/tcp:127.0.0.1:5762/' \
    -e 's/udpin:127.0.0.1:14561/tcp:127.0.0.1:5772/' \
    -e 's/udpin:127.0.0.1:14562/tcp:127.0.0.1:5782/' "$base" >"$out/second.toml"
  (sleep "$SECOND_AFTER"
   .venv/bin/convoy-mav run --config "$out/second.toml" --duration "$duration" \
     --report "$out/second.json" --quiet >"$out/second.log" 2>&1
   echo "second service exit status $?" >>"$out/second.log") &
  pids+=($!)
fi
if [ -n "${SET_PARAM:-}" ]; then
  (sleep "${SET_PARAM%%:*}"
   "$py" - "${SET_PARAM#*:}" "$uavs" <<'PY' >"$out/set_param.log" 2>&1
import sys, time
from pymavlink import mavutil
name, value = sys.argv[1].split("=")
for k in range(int(sys.argv[2])):
    link = mavutil.mavlink_connection(f"tcp:127.0.0.1:{5763 + 10 * k}", source_system=250)
    beat = link.wait_heartbeat(timeout=10)
    if beat is None:
        print(f"instance {k}: no heartbeat on serial2"); continue
    link.mav.param_set_send(
        link.target_system, link.target_component, name.encode(), float(value),
        mavutil.mavlink.MAV_PARAM_TYPE_REAL32,
    )
    answer = link.recv_match(type="PARAM_VALUE", condition=f"PARAM_VALUE.param_id=='{name}'",
                             blocking=True, timeout=5)
    print(f"{time.strftime('%H:%M:%S')} instance {k} (sysid {link.target_system}): {name} ->",
          None if answer is None else answer.param_value)
    link.close()
PY
  ) &
  pids+=($!)
fi
.venv/bin/convoy-mav run --config "$config" --duration "$duration" ${RUN_ARGS:-} \
  --report "$out/report.json" --tlog "$out/mission.tlog" --plot "$out/mission.png" \
  --record-mission "$out/mission.inputs"
"$py" checks/sitl_report.py "$config" "$out/report.json" "$out/mission.tlog"
if [ -n "${SET_PARAM:-}" ]; then
  cat "$out/set_param.log"
  "$py" -c "
import json, sys
report = json.load(open(sys.argv[1]))
print('mission clock:', report['mission_clock'])
for a in report['alarms']:
    if a['kind'] == 'airframe':
        print(f\"alarm airframe at {a['t']:.1f} s ({'raised' if a['active'] else 'cleared'}): {a['message']}\")
for v in report['vehicles']:
    print(f\"UAV {v['sysid']} speed range:\", {k: x for k, x in v['learnt'].items() if k.startswith('speed')})
" "$out/report.json"
fi
if [ -n "${ROVER:-}" ]; then
  cat "$out/rover_drive.log"
  "$py" -c "
import json, sys
planner = json.load(open(sys.argv[1]))['planner']
print('route:', planner.get('route_source'), planner.get('route_length_m'), 'm; mission reads:', planner.get('mission_reads'))
print('modes heard:', [(m['t'], m['mode']) for m in planner.get('convoy_modes', [])])
print('speeds kept:', [(k['t'], k['mps'], k['plan_mps']) for k in planner.get('convoy_kept', [])])
" "$out/report.json"
fi
if [ -n "${KILL:-}" ]; then
  cat "$out/kill.log"
  "$py" -c "
import json, sys
report = json.load(open(sys.argv[1]))
for a in report['alarms']:
    if a['kind'] in ('uav_lost', 'gap'):
        print(f\"alarm {a['kind']} at {a['t']:.1f} s ({'raised' if a['active'] else 'cleared'}): {a['message'][:90]}\")
for e in report['events']:
    if 'UAV 1 ' in e and any(w in e for w in ('lost', 'back', 'rebooted', 'armed', 'airborne', 'flying', 'joined', 'cleared')):
        print(e[:110])
" "$out/report.json"
fi
if [ -n "${LINK:-}" ]; then
  kill "$link_pid" 2>/dev/null || true; sleep 1  # (it prints its counts)
  echo "link:"; cat "$out/link.log"
  "$py" -c "
import json, sys
for v in json.load(open(sys.argv[1]))['vehicles']:
    print(f\"UAV {v['sysid']}: round trip {v['link_round_trip_s']} s, streams asked again {v['streams_asked_again']}, tracking {v['mean_tracking_error_m']} m\")
" "$out/report.json"
fi
if [ -n "${SECOND_AFTER:-}" ]; then
  wait "${pids[-1]}" 2>/dev/null || true
  echo "second service:"; grep -E "error|refused|exit status" "$out/second.log" | tail -5
  "$py" -c "
import json, sys
alarms = json.load(open(sys.argv[1]))['alarms']
print('first service uav_contested:', [(round(a['t']), a['active'], a['message'][:40]) for a in alarms if a['kind'] == 'uav_contested'])
" "$out/report.json"
fi
