#!/bin/sh
# The checks each finished run of paper-rq1 gets (README beside it): its final best
# re-run in 2D-VSR-Sim on the validation terrains, with dyn4j as shipped and without its collision
# misfire, on the authors' code's sensors and on the run's own (rows of campaign/transfer.csv,
# which the report's transfer section reads); on 20 fresh terrains in somite; how deep its
# corners go into the ground in both engines. About 4 minutes a run on 2 cores beside the campaign.
#
#   source $VSR/env.sh     # a build of the 2D-VSR-Sim driver with classes-main-sensors (README)
#   sh reports/paper-rq1/check-finished.sh rq1/worm-s1 [TASK ...]
#   CAMPAIGN=reports/paper/campaign sh reports/paper-rq1/check-finished.sh omega-10/worm-s0
#
# Writes campaign/transfer.csv (merged: a task's rows replaced) and campaign/checks/NAME-*.json
# (NAME: the task with / as -; the pack carries them); refuses a task that has not finished,
# before running anything. Deterministic: rq1/biped-s1 re-checked on 2026-12-05 gave its
# transfer.csv rows again to every digit.
set -e
cd "$(dirname "$0")/../.."
C=${CAMPAIGN:-reports/paper-rq1/campaign}
PY=.venv/bin/python
: "${VSR:?set VSR to the 2D-VSR-Sim driver build (source its env.sh)}"
[ "$#" -gt 0 ] || { echo "usage: $0 TASK [TASK ...]  (e.g. rq1/worm-s1)" >&2; exit 2; }
for task in "$@"; do
  [ -f "$C/$task/done.json" ] || { echo "check-finished: $task has not finished ($C/$task/done.json missing)" >&2; exit 2; }
done
mkdir -p "$C/checks"
# to FILE COMMAND...: COMMAND's output into FILE, whole or not at all
to() { out=$1; shift; nice -n 5 "$@" > "$out.tmp"; mv "$out.tmp" "$out"; }
for task in "$@"; do
  name=$(echo "$task" | tr / -)
  for engine in classes-dyn4j classes-dyn4j-noccd; do for sensors in code own; do
    to "$C/checks/$name-transfer-$engine-$sensors.json" $PY benchmarks/transfer.py "$C/$task" \
      --every 3000 --terrains validation --sensors $sensors --dyn4j $engine --campaign "$C"
  done; done
  to "$C/checks/$name-fresh.json" .venv/bin/somite evaluate "$C/$task" --fresh 20 --seed 1 --json
  to "$C/checks/$name-ground-gap.json" $PY benchmarks/ground_gap.py "$C/$task"
  echo "check-finished: $task done ($C/checks/$name-*.json, $C/transfer.csv)"
done
