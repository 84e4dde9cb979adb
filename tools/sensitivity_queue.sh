#!/bin/bash
# The sensitivity rows' second run seed (docs/results/sensitivity.md; issue 68: a second,
# independent channel realisation for every row) as one resumable queue. Run seed 1 goes over
# every sweep file of scenarios/sweeps/sensitivity/ on house layout 0 first, so that every row
# gets its second unit as early as possible, then on layout 1; each file's finished runs are
# archived into docs/results/sensitivity/<name>/ as soon as its sweep ends (the archive redraws
# its report when the batch ran without one). Run it from the repository root; each sweep skips
# the points already done (in runs/sweeps/<name>/), so it can be stopped and started again:
#     nohup tools/sensitivity_queue.sh >> runs/sensitivity_queue.log 2>&1 &
# Before the first step it puts the runs archived under docs/results/ back into runs/sweeps/
# (never touching a run already there), so on a fresh machine it goes on from the repository.
# RAMENSIM (default .venv/bin/ramensim), WORKERS, THREADS, DEVICE (as `ramensim sweep`), SEED
# (default 1), LAYOUTS (default "0 1") and RESTORE (the restoring command; empty: none) may be set.
# Afterwards: `ramensim sensitivity --out docs/results/sensitivity.md` redraws the page.
set -u
R=${RAMENSIM:-.venv/bin/ramensim}
W="${WORKERS:+--workers $WORKERS} ${THREADS:+--threads $THREADS} ${DEVICE:+--device $DEVICE}"
S=scenarios/sweeps/sensitivity
A=docs/results/sensitivity
RESTORE=${RESTORE-"$R archive --restore docs/results runs/sweeps"}
if [ -n "$RESTORE" ]; then
  echo "=== $(date -u +%F\ %H:%M:%S) $RESTORE"
  $RESTORE || { echo "sensitivity_queue.sh: restoring the archived runs failed" >&2; exit 2; }
fi
for layout in ${LAYOUTS:-0 1}; do
  for file in references methods dual_step beta_l rho rho_dinno; do
    name=sensitivity_$file
    echo "=== $(date -u +%F\ %H:%M:%S) $S/$file.yaml seed ${SEED:-1}, layout $layout"
    "$R" sweep $S/$file.yaml --only seed=${SEED:-1} --only world.scene.seed=$layout $W \
      --out runs/sweeps/$name --no-report -q
    rc=$?
    echo "=== $(date -u +%F\ %H:%M:%S) rc=$rc"
    "$R" archive runs/sweeps/$name $A/$name  # a folder without runs/ is refused in one line
  done
done
