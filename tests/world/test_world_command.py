"""The ``ramensim world`` command: export and show."""
import argparse

import numpy as np
import trimesh

from ramensim.commands import world as cmd
from ramensim.world.config import BuiltinSceneConfig, WorldConfig


def _parse(argv):
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    cmd.add_parser(sub)
    return parser.parse_args(argv)


def test_export_writes_coloured_ply(tmp_path):
    out = tmp_path / "office.ply"
    assert cmd.run(_parse(["world", "export", "office", "--seed", "2", "--out", str(out)])) == 0
    m = trimesh.load(out, process=False)
    assert len(m.faces) > 1000 and m.visual.kind == "vertex"


def test_show_writes_png(tmp_path):
    out = tmp_path / "w.png"
    cmd.show(WorldConfig(scene=BuiltinSceneConfig(name="pretrain_room")), 2, 20.0, 0, out)
    from PIL import Image

    img = np.asarray(Image.open(out))
    assert img.shape[0] > 300 and img.shape[1] > 300 and img[..., :3].std() > 10


def test_show_logs_each_agents_coverage(tmp_path, caplog):
    import logging

    cfg = WorldConfig.model_validate({"scene": {"name": "house"}, "trajectory": {"split": "chunks"},
                                      "camera": {"fps": 1.0}})
    with caplog.at_level(logging.INFO, logger="ramensim.commands.world"):
        cmd.show(cfg, 2, 20.0, 0, tmp_path / "h.png", coverage_points=5000)
    assert (tmp_path / "h.png").is_file()
    assert "own coverage" in caplog.text and "team sees" in caplog.text
    args = _parse(["world", "show", "s.yaml", "--no-coverage", "--coverage-points", "1000"])
    assert args.coverage is False and args.coverage_points == 1000
