#!/bin/bash
# The paper-horizon protocol (docs/RESULTS.md) as one resumable queue, breadth first: a first
# trial of every experiment, then the remaining seeds and layouts, then each whole file. Run it
# from the repository root; every step skips the points already done (in runs/sweeps/<name>/),
# so it can be stopped and started again at any time:
#     nohup tools/paper_queue.sh >> runs/paper_queue.log 2>&1 &
# On a fresh machine first copy docs/results/paper/<sweep>/runs into runs/sweeps/<sweep>/runs.
# RAMENSIM (default .venv/bin/ramensim) and WORKERS (default: the sweep's own choice) may be set.
set -u
R=${RAMENSIM:-.venv/bin/ramensim}
W=${WORKERS:+--workers $WORKERS}
P=scenarios/sweeps/paper
step() {
  echo "=== $(date -u +%F\ %H:%M:%S) $*"
  "$R" sweep "$@" $W --no-report -q
  echo "=== $(date -u +%F\ %H:%M:%S) rc=$?"
}
first="--only seed=0 --only world.scene.seed=0"
step $P/fig5.yaml $first --only channel.success_rate=1.0,0.2,0.01
step scenarios/sweeps/cause/ramen_link_600.yaml
step $P/dsgt_async.yaml $first --only method=dsgt,dsgd
step $P/fig7.yaml $first --only agents.count=4,6
step $P/table1.yaml --only seed=2 --only method=ramen,centralised,local,dinno
step $P/fig1.yaml --only seed=2
step $P/fig5.yaml $first
step $P/fig5_paper_update.yaml $first
step $P/dsgt_async.yaml $first
step $P/fig7.yaml $first
step $P/table1.yaml --only method=dsgd,dsgt
step $P/fig5.yaml --only seed=0
step $P/dsgt_async.yaml --only seed=0
step $P/fig7.yaml --only seed=0
step $P/fig5_paper_update.yaml --only seed=0
for f in table1 fig1 fig5 fig5_paper_update dsgt_async fig7; do step $P/$f.yaml; done
