#!/bin/bash
# The paper-horizon protocol (docs/RESULTS.md) as one resumable queue, breadth first: a first
# trial of every experiment, then the remaining seeds and layouts, then each whole file. Fig. 5's
# claims rest on 100, 20 and 1 % (RAMEN's drop to 20 %, above local at 1 % on every trial), so
# those three rates run on every trial before the curve's intermediate rates. Run it
# from the repository root; every step skips the points already done (in runs/sweeps/<name>/),
# so it can be stopped and started again at any time:
#     nohup tools/paper_queue.sh >> runs/paper_queue.log 2>&1 &
# Before the first step it puts the runs archived under docs/results/ back into runs/sweeps/
# (tools/restore_archives.py; never touching a run already there), so on a fresh machine the
# queue goes on from what the repository holds.
# RAMENSIM (default .venv/bin/ramensim), PYTHON (default .venv/bin/python), WORKERS (default:
# the sweep's own choice), DEVICE (the maps' torch device, `ramensim sweep --device`: cuda on a
# GPU machine; the runs stay the same points) and RESTORE (the restoring command; empty: none)
# may be set.
#
# Lanes: `tools/paper_queue.sh a` and `tools/paper_queue.sh b` split the same steps into two
# queues whose own steps never touch the same sweep folder (a: Fig. 5, Fig. 1, the paper's update
# at 5 % / 1 %, Fig. 7 and RAMEN's cause runs; b: Table I, DSGT under asynchrony and its cause
# runs); then each lane goes over every whole file, joining the other where it runs one (two
# sweeps of one plan share a folder point by point: docs/SWEEPS.md, "Two sweeps, one folder";
# see "Work sharing" at the end). Run both at once,
# each with one run of one thread, so that no core idles while one step's last run finishes:
#     WORKERS=1 THREADS=1 nohup tools/paper_queue.sh a >> runs/paper_queue_a.log 2>&1 &
#     WORKERS=1 THREADS=1 nohup tools/paper_queue.sh b >> runs/paper_queue_b.log 2>&1 &
# Without a lane (or with `all`) one queue runs every step in the order below.
set -u
LANE=${1:-all}
case "$LANE" in a|b|all) ;; *) echo "paper_queue.sh: lane '$LANE': expected a, b or all" >&2; exit 2;; esac
R=${RAMENSIM:-.venv/bin/ramensim}
W="${WORKERS:+--workers $WORKERS} ${THREADS:+--threads $THREADS} ${DEVICE:+--device $DEVICE}"
P=scenarios/sweeps/paper
C=scenarios/sweeps/cause
log=$(mktemp)  # the last sweep's output (stdout and stderr), read by the work-sharing passes
trap 'rm -f "$log"' EXIT
sweep() {  # sweep HEADER FILE ARGS...: one sweep between a dated header line and its exit status
  echo "=== $(date -u +%F\ %H:%M:%S) $1"; shift
  "$R" sweep "$@" $W --no-report -q 2>&1 | tee "$log"
  local rc=${PIPESTATUS[0]}  # the sweep's, not tee's
  echo "=== $(date -u +%F\ %H:%M:%S) rc=$rc"
}
step() {  # step LANE FILE ARGS...: run the sweep when LANE is this queue's
  local lane=$1; shift
  [ "$LANE" = all ] || [ "$LANE" = "$lane" ] || return 0
  sweep "$*" "$@"
}
RESTORE=${RESTORE-"${PYTHON:-.venv/bin/python} tools/restore_archives.py"}
if [ -n "$RESTORE" ]; then
  echo "=== $(date -u +%F\ %H:%M:%S) $RESTORE"
  $RESTORE || { echo "paper_queue.sh: restoring the archived runs failed" >&2; exit 2; }
fi
first="--only seed=0 --only world.scene.seed=0"
step a $P/fig5.yaml $first --only channel.success_rate=1.0,0.2,0.01
step a $C/ramen_link_600.yaml
step a $C/ramen_weights_1pct.yaml
step b $P/dsgt_async.yaml $first --only method=dsgt,dsgd
step b $C/dsgt_stale.yaml
step a $P/fig7.yaml $first --only agents.count=4,6
step a $P/fig5_paper_update.yaml $first
step b $P/table1.yaml $first --only method=dsgd,dsgt
step a $P/fig7.yaml $first --only agents.count=5
step b $P/table1.yaml --only seed=2 --only method=ramen,centralised,local,dinno
step a $P/fig1.yaml --only seed=2
step a $P/fig5.yaml --only channel.success_rate=1.0,0.2,0.01
step a $P/fig5.yaml $first
# Claims before curves: 5 % and 1 % (issue 25 item 5: RAMEN with the default update against
# DiNNO, the paper's update and local, >= 3 seeds) on every trial before Fig. 5's intermediate
# rates on the other trials (the curve, no claim): the paper's update and Fig. 5's 5 % on the
# three run seeds of layout 0 first, then on layout 1.
step a $P/fig5_paper_update.yaml --only world.scene.seed=0
step a $P/fig5.yaml --only channel.success_rate=0.05 --only world.scene.seed=0
step a $P/fig5_paper_update.yaml
step a $P/fig5.yaml --only channel.success_rate=0.05
step b $P/dsgt_async.yaml $first
step a $P/fig7.yaml $first
step b $P/table1.yaml --only method=dsgd,dsgt
# Fig. 7's rule for 5 and 6 robots was still open after its first two trials (1 of 2, 0 of 2):
# its other trials, one at a time, come before Fig. 5's intermediate rates on the other trials
# (a curve, no claim). Fig. 7 moved from lane b to lane a then, when lane b had DSGT under
# asynchrony's remaining trials (about 5 h) and lane a only Fig. 5's curve left.
step b $P/dsgt_async.yaml --only seed=0
step a $P/fig7.yaml --only seed=0
for s in 1 2; do for l in 0 1; do
  step a $P/fig7.yaml --only seed=$s --only world.scene.seed=$l
done; done
step a $P/fig5.yaml --only seed=0
step a $P/fig1.yaml
step a $P/fig5.yaml
step a $P/fig7.yaml
for f in table1 dsgt_async; do step b $P/$f.yaml; done
# Issue 56's evidence (added 2026-11-27), on lane b while lane a runs Fig. 7 with the authors'
# split: RAMEN at DiNNO's bytes and both methods on the 1-Tbit/s link (docs/results/bytes.md),
# then the sensitivity sweeps, their references first (docs/results/sensitivity.md)
B=scenarios/sweeps/bytes
S=scenarios/sweeps/sensitivity
for f in $B/equal_bytes_fig1 $B/unlimited_link $S/methods $S/references $S/dual_step $S/beta_l $S/rho $S/rho_dinno; do
  step b $f.yaml
done
# Fig. 7 with the authors' split of the sequence (issue 56, item 3; added after the 228-run
# protocol was complete): its first trial first, so that "more robots help" is judged early
step a $P/fig7_authors_split.yaml $first
# ... and with the authors' round count (600 * 4 / n s: F/n rounds), whose 4-robot points are the
# authors' split's finished 4-robot RAMEN runs, taken over rather than run again
F7=scenarios/sweeps/fig7
adopt_four() {
  [ "$LANE" = b ] && return 0
  local src=() d
  for d in runs/sweeps/paper_fig7_authors_split/runs/*agents.count=4__method=ramen; do
    [ -f "$d/metrics.json" ] && grep -q '"status": *"ok"' "$d/status.json" 2>/dev/null && src+=("$d")
  done
  [ ${#src[@]} -eq 0 ] || ${PYTHON:-.venv/bin/python} tools/adopt_runs.py "${src[@]}" \
    --plan $F7/fig7_authors_rounds.yaml --into runs/sweeps/fig7_authors_rounds
}
adopt_four
step a $F7/fig7_authors_rounds.yaml $first
step a $P/fig7_authors_split.yaml
adopt_four
step a $F7/fig7_authors_rounds.yaml
# ... then beyond the paper's 6 robots: 8 and 12 on the path and on a ring (issue 56, item 3;
# scenarios/sweeps/fig7/, outside the protocol's count), its first trial first
step a $F7/fig7_many_robots.yaml $first
step a $F7/fig7_many_robots.yaml
# Work sharing. The lanes' own steps above are unequal in length (DSGT's and Fig. 7's runs take
# longer than Fig. 5's), so each lane then goes over every experiment's whole file, in its own order,
# until nothing is left. A file the other lane is running is joined: the two sweeps take its
# points one by one, each claimed by the first to start it. A sweep that cannot plan (the other
# lane's sweep holds the folder lock for longer than 30 s: one started before sweeps could share
# a folder) is refused ("another sweep is running in this output folder"), and the file is taken
# up on the next pass. Only a lane (a or b) shares; `all` ran every whole file above.
share_order_a="fig5_paper_update fig7 dsgt_async fig5 table1 fig1 fig7_authors_split"
share_order_b="fig7_authors_split dsgt_async fig7 fig5_paper_update fig5 table1 fig1"
SHARE_WAIT=${SHARE_WAIT:-300}  # s between passes in which every file left was the other lane's
if [ "$LANE" != all ]; then
  order=share_order_$LANE
  while :; do
    refused=0; ran=0
    for f in ${!order}; do
      sweep "$P/$f.yaml (shared)" $P/$f.yaml
      if grep -q "another sweep is running in this output folder" "$log"; then
        refused=1
      elif ! grep -q " 0 ok, 0 diverged, 0 failed" "$log"; then
        ran=1
      fi
    done
    [ $refused = 1 ] || break  # every file was this lane's to finish, and it did
    [ $ran = 1 ] || sleep "$SHARE_WAIT"
  done
fi
