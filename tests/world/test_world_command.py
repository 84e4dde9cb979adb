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
