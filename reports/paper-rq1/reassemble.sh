#!/bin/sh
# The paper's homogeneous reassembly (section 5.2) of the finished graph runs of paper-rq1, before
# any re-optimisation: for each shape, run i's best gives the legs (biped) or back half (worm),
# run i+1's (cyclically over the seeds) the torso or front half; each reassembled robot and both
# donors are re-run on the 10 validation terrains (rho), and the cuts of disassembly are counted
# (eta, per module and pooled). Writes reassembly/SHAPE-I-J/ (reassembled.json, report.json,
# report.csv) beside this script; about 3 s a pair once the kernels are compiled.
#
#   sh reports/paper-rq1/reassemble.sh
set -e
cd "$(dirname "$0")/../.."
C=reports/paper-rq1/campaign
OUT=reports/paper-rq1/reassembly
for shape in biped worm; do
  for pair in "0 1" "1 2" "2 0"; do
    set -- $pair
    [ -f "$C/rq1/$shape-s$1/done.json" ] && [ -f "$C/rq1/$shape-s$2/done.json" ] || {
      echo "reassemble: rq1/$shape-s$1 or rq1/$shape-s$2 has not finished" >&2; exit 2; }
    rm -rf "$OUT/$shape-$1-$2"
    .venv/bin/somite reassemble "$C/rq1/$shape-s$1" "$C/rq1/$shape-s$2" \
      --out "$OUT/$shape-$1-$2" --yes
  done
done
