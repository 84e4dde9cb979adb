"""Judging a claim trial by trial over archived runs: one judging pass (:class:`Judging`) reads each
archive once, notes which runs each trial compared (to mark a trial whose runs ran on different
hosts, :func:`host_marks`) and collects what it could not judge, for the pages' notes."""
from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Sequence

from ramensim.paper.archive import Archive, RunValues
from ramensim.paper.rules import MIXED, TRIALS, UNRECORDED, Claim, Unjudgeable, label


class Judging:
    """One judging pass: the archives it read (each once), the trials it could not judge and the
    trials whose compared runs ran on different hosts. Judging code takes it as its first argument;
    the pages read its notes (:attr:`skipped`, :attr:`mixed_runs`) in the order they were made."""

    def __init__(self) -> None:
        self.skipped: list[tuple[str, str]] = []
        """(claim and trial, why not judged) collected while judging: runs lacking what a rule needs."""
        self.mixed_runs: dict[tuple[tuple[str, str], ...], None] = {}
        """The runs of each trial marked †, with their machines, collected while judging (in order, once each)."""
        self._archives: dict[Path, Archive] = {}
        self._used: list[RunValues] | None = None

    def archive(self, folder: Path) -> Archive:
        """The :class:`~ramensim.paper.archive.Archive` of ``folder``, read once per pass; its runs
        are noted while a trial is judged (:meth:`per_trial`)."""
        if folder not in self._archives:
            self._archives[folder] = Archive(folder, self._read)
        return self._archives[folder]

    def _read(self, run: RunValues) -> None:
        if self._used is not None:
            self._used.append(run)

    def note_hosts(self, used: Sequence[RunValues]) -> str:
        """:func:`host_marks` of ``used``, the runs one trial (or one pooled claim) compared; when
        they ran on different hosts the runs are kept, with their machines, for the pages."""
        marks = host_marks(used)
        if MIXED in marks:
            self.mixed_runs[tuple(sorted({(u.where, u.machine or "unrecorded") for u in used}))] = None
        return marks

    def per_trial(self, claim: Claim, need: Callable[[int, int], tuple[Sequence[Any], str] | None],
                  trials: Sequence[tuple[int, int]] = TRIALS) -> Claim:
        """Judge ``claim`` on each trial (run seed, layout): ``need`` returns the trial's value per
        test and its numbers, or None when a run is not done; a run lacking a number is named in
        :attr:`skipped`. Each trial's runs are those ``need`` read from this pass's archives."""
        for seed, layout in trials:
            self._used = []
            try:
                got = need(seed, layout)
            except Unjudgeable as exc:
                self.skipped.append((f"{claim.name}, {label(seed, layout)}", str(exc)))
                got = None
            finally:
                used, self._used = self._used, None
            if got is None:
                continue
            values, text = got
            name = label(seed, layout) + self.note_hosts(used or [])
            claim.samples.append(tuple(values))
            claim.units.append(seed)
            claim.judged.append((name, all(t.clears(v) for t, v in zip(claim.tests, values)), text))
        return claim


def host_marks(used: Sequence[RunValues]) -> str:
    """:data:`~ramensim.paper.rules.MIXED` when two of the runs with a ``build`` record name
    different hosts, :data:`~ramensim.paper.rules.UNRECORDED` when a run has none."""
    from itertools import combinations

    from ramensim.provenance import same_host

    builds = [u.build for u in used]
    known = [b for b in builds if b is not None]
    mixed = any(not same_host(a, b) for a, b in combinations(known, 2))
    return (MIXED if mixed else "") + (UNRECORDED if len(known) < len(builds) else "")
