"""The result pages say only what claims.md's intervals show (issue 68, item 5): a row of
docs/RESULTS.md's summary table that names a claims.md claim carries that claim's verdict and
its interval's numbers, and a sentence of the hand-written pages that quotes a claim by name
followed by a bold verdict word (``"DSGT fails under asynchrony": **fails**``) uses the word
claims.md gives it. claims.md itself is made from the archives (tests/paper/test_paper_claims.py
keeps it current), so these checks tie the prose to the archived runs."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
CLAIMS = REPO / "docs" / "results" / "paper" / "claims.md"
VERDICTS = ("holds", "fails", "inconclusive", "no run yet")
HAND_PAGES = [REPO / "docs" / "RESULTS.md", *sorted((REPO / "docs" / "results").glob("*.md"))]
"""Pages whose verdict sentences are checked (claims.md and the generated sensitivity page are
the source, not prose)."""


def _cells(line: str) -> list[str]:
    return [c.strip() for c in re.split(r"(?<!\\) \| ", line.strip().strip("|").strip())]


def _numbers(text: str) -> list[str]:
    """Signed decimals as printed, with a typographic minus read as '-' and '+' dropped."""
    return [n.lstrip("+") for n in re.findall(r"[-+]?\d+\.\d+", text.replace("−", "-"))]


def claims_md() -> dict[str, tuple[str, str]]:
    """claims.md's rows: claim name -> (verdict, quantity cell)."""
    out = {}
    for line in CLAIMS.read_text(encoding="utf-8").splitlines():
        if line.startswith("| ") and "**" in line:
            cells = _cells(line)
            verdict = re.search(r"\*\*(.*?)\*\*", cells[4])
            if verdict:
                out[cells[0].replace("\\|", "|")] = (verdict.group(1), cells[2])
    return out


def lookup(claims: dict[str, tuple[str, str]], name: str) -> str | None:
    """The claims.md name ``name`` refers to: itself, or the one name it is a prefix of."""
    if name in claims:
        return name
    hits = [c for c in claims if c.startswith(name)]
    return hits[0] if len(hits) == 1 else None


def test_results_summary_rows_carry_claims_md_verdicts_and_numbers():
    claims = claims_md()
    text = (REPO / "docs" / "RESULTS.md").read_text(encoding="utf-8")
    head = text.splitlines()[:80]
    header = next(i for i, ln in enumerate(head) if ln.startswith("| claim"))
    cols = _cells(head[header])
    assert "units (trials)" in cols and "scenes" in cols, "the summary table names its units and scene families"
    at = {c: i for i, c in enumerate(cols)}
    checked = 0
    for line in head[header + 2:]:
        if not line.startswith("|"):
            break
        cells = _cells(line)
        name = lookup(claims, cells[0])
        if name is None:
            continue
        verdict, quantity = claims[name]
        said = cells[at["verdict"]].split()[0].strip(",;")
        assert said == verdict.split()[0], f"RESULTS.md says {said!r} of {name!r}; claims.md: {verdict!r}"
        for n in _numbers(cells[at["estimate [95 % interval over units]"]]):
            assert n in _numbers(quantity), f"RESULTS.md's {n} for {name!r} is not in claims.md's {quantity!r}"
        checked += 1
    assert checked >= 20, f"only {checked} rows of the summary table name a claims.md claim"


EVIDENCE = REPO / "docs" / "results" / "evidence" / "claims.md"


def test_results_breadth_rows_carry_the_breadth_pages_verdicts_and_numbers():
    """A summary row "Breadth, CLAIM" carries the verdict docs/results/evidence/claims.md gives
    CLAIM pooled over all families, and every number of its estimate is one of that page's
    numbers for CLAIM (per family or pooled)."""
    rows: dict[str, dict[str, tuple[str, str]]] = {}
    for line in EVIDENCE.read_text(encoding="utf-8").splitlines():
        if line.startswith("| ") and "**" in line:
            cells = _cells(line)
            verdict = re.search(r"\*\*(.*?)\*\*", cells[4])
            if verdict:
                rows.setdefault(cells[0], {})[cells[1]] = (verdict.group(1), cells[3])
    head = (REPO / "docs" / "RESULTS.md").read_text(encoding="utf-8").splitlines()[:80]
    header = next(i for i, ln in enumerate(head) if ln.startswith("| claim"))
    at = {c: i for i, c in enumerate(_cells(head[header]))}
    checked = 0
    for line in head[header + 2:]:
        if not line.startswith("| Breadth, "):
            continue
        cells = _cells(line)
        name = cells[0][len("Breadth, "):]
        assert name in rows, f"RESULTS.md's breadth row {name!r} is not a claim of {EVIDENCE.name}"
        pooled = rows[name]["all families pooled"][0]
        said = cells[at["verdict"]].split()[0].strip(",;")
        assert said == pooled, f"RESULTS.md says {said!r} of breadth {name!r}; evidence/claims.md pooled: {pooled!r}"
        known = {n for _, q in rows[name].values() for n in _numbers(q)}
        for n in _numbers(cells[at["estimate [95 % interval over units]"]]):
            assert n in known, f"RESULTS.md's {n} for breadth {name!r} is not on evidence/claims.md"
        checked += 1
    assert checked == 4, f"{checked} breadth rows in RESULTS.md's summary table; expected Table I's three and Fig. 5"


QUOTED = re.compile(r'"([^"]{8,200})":\s*\*\*(holds|fails|inconclusive|no run yet)\*\*')


@pytest.mark.parametrize("page", HAND_PAGES, ids=lambda p: p.name)
def test_a_quoted_claim_has_claims_md_verdict(page):
    claims = claims_md()
    for quoted, word in QUOTED.findall(page.read_text(encoding="utf-8")):
        name = lookup(claims, quoted)
        if name is None:
            continue
        assert word == claims[name][0], f"{page.name}: \"{quoted}\": **{word}**, but claims.md says {claims[name][0]}"


def test_the_check_catches_a_wrong_word(tmp_path):
    claims = claims_md()
    name = "Table I: DiNNO's consensus error falls ≥ 10x"
    assert claims[name][0] == "inconclusive"   # over the 3 run seeds; it held over 6 trials
    wrong = f'"{name}": **holds**'
    (quoted, word), = QUOTED.findall(wrong)
    assert lookup(claims, quoted) == name and word != claims[name][0]
