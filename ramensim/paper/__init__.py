"""The paper's analyses: its claims judged on the archived runs (``ramensim claims``, the page
docs/results/paper/claims.md) and which of the main claims survive each knob of the sensitivity
sweeps (``ramensim sensitivity``, docs/results/sensitivity.md).

One job per module, read bottom-up:

- :mod:`~ramensim.paper.rules`: what a claim is (:class:`~ramensim.paper.rules.Test`,
  :class:`~ramensim.paper.rules.Claim`), the trials, the metrics' keys and units, the per-run helpers
  and the rules both pages share;
- :mod:`~ramensim.paper.archive`: reading an archived sweep (its complete runs and the runs not judged);
- :mod:`~ramensim.paper.trials`: one judging pass (:class:`~ramensim.paper.trials.Judging`): each
  archive read once, claims judged trial by trial, trials on different hosts and runs not judged noted;
- :mod:`~ramensim.paper.spread`, :mod:`~ramensim.paper.falls`: the spread and consensus-error claims
  several experiments share;
- :mod:`~ramensim.paper.table1`, :mod:`~ramensim.paper.fig1`, :mod:`~ramensim.paper.fig5`,
  :mod:`~ramensim.paper.fig7`, :mod:`~ramensim.paper.dsgt`: each experiment's claims;
- :mod:`~ramensim.paper.causes`: the readers of the cause studies the claims quote;
- :mod:`~ramensim.paper.claims`: every claim judged (:func:`~ramensim.paper.claims.judge_all`);
- :mod:`~ramensim.paper.pages`: claims.md;
- :mod:`~ramensim.paper.sensitivity`, :mod:`~ramensim.paper.sensitivity_page`: the sensitivity table;
- :mod:`~ramensim.paper.figures`: completion over time per archived experiment (docs/images/results/);
- :mod:`~ramensim.paper.medium`: the tables of docs/results/medium.md;
- the cause studies of docs/results/ (``ramensim paper STUDY``): :mod:`~ramensim.paper.study` (a finished
  run rebuilt, a study's outputs written), :mod:`~ramensim.paper.rescore`, :mod:`~ramensim.paper.artifacts`,
  :mod:`~ramensim.paper.far_part`, :mod:`~ramensim.paper.surface_steps`, :mod:`~ramensim.paper.plateau`,
  :mod:`~ramensim.paper.copy_age`, :mod:`~ramensim.paper.tracker_drift`.

The commands are ``ramensim/commands/claims.py``, ``ramensim/commands/sensitivity.py`` and
``ramensim/commands/paper.py``; the thin scripts of tools/ call them.
"""
