"""`ramensim pretrain-decoders` runs on a tiny budget and writes loadable frozen decoders."""
from __future__ import annotations

from pathlib import Path

import torch

from ramensim.agents.map import MapConfig, load_decoders
from ramensim.agents.map.decoders import decoder_shapes
from ramensim.cli import main


def test_pretrain_decoders_tiny_budget(tmp_path: Path) -> None:
    out = tmp_path / "dec.pt"
    assert main(["pretrain-decoders", "--iterations", "3", "--duration", "1", "--seed", "1",
                 "--out", str(out)]) == 0
    weights = load_decoders(out)
    shipped = load_decoders()
    expected = decoder_shapes(MapConfig())
    assert set(weights) == set(shipped) == set(expected)
    for k, shape in expected.items():
        assert tuple(weights[k].shape) == tuple(shape)
        assert torch.isfinite(weights[k]).all()
        assert not torch.equal(weights[k], shipped[k])  # it trained something of its own


def test_pretrain_rejects_bad_budget(tmp_path: Path, capsys) -> None:
    assert main(["pretrain-decoders", "--iterations", "0", "--out", str(tmp_path / "x.pt")]) == 2
    assert "--iterations" in capsys.readouterr().err
