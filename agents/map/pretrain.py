"""Pretraining the decoders that every agent then keeps frozen (RAMEN's setting).

``pretrain_decoders`` trains the grid AND the decoders jointly on one agent that sees
every frame (Adam on both, the map's lr/betas/eps), and returns the decoder weights.
``save_decoders`` / ``load_decoders`` read and write them (a ~20 KB torch file; the
default is the file shipped in ``agents/data/decoders.pt``).
"""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import torch

from ramensim.core.frames import Frame
from .config import MapConfig
from .decoders import KEYS, init_decoders

log = logging.getLogger(__name__)

DEFAULT_DECODERS = Path(__file__).resolve().parent.parent / "data" / "decoders.pt"
"""The shipped decoder weights."""


def pretrain_decoders(frames: list[Frame], bounds: np.ndarray, cfg: MapConfig,
                      iterations: int, seed: int) -> dict[str, torch.Tensor]:
    """Train grid and decoders jointly for ``iterations`` steps on ``frames`` (all
    keyframes, one agent) and return the decoder weights (dict of four matrices)."""
    from .neural_map import NeuralMap  # local: neural_map imports this package's modules

    if not frames:
        raise ValueError("pretrain_decoders needs at least one frame; got an empty list.")
    if iterations < 1:
        raise ValueError(f"pretrain_decoders: iterations must be >= 1, got {iterations}.")
    ss = np.random.SeedSequence(seed)
    g_init, g_dec, g_samp = (torch.Generator().manual_seed(int(s.generate_state(1)[0]))
                             for s in ss.spawn(3))
    weights = init_decoders(cfg, g_dec)
    m = NeuralMap(bounds, cfg, weights, g_init, g_samp, train_decoders=True)
    for f in frames:
        m.add_frame(f, keyframe=True)
    params = [m.decoders.params[k] for k in KEYS]
    opt = torch.optim.Adam(params, lr=cfg.lr, betas=(cfg.adam_beta1, cfg.adam_beta2),
                           eps=cfg.adam_eps)
    for it in range(iterations):
        scalars, grad = m.loss_and_grad()
        m.optimizer_step(grad)
        for k, p in zip(KEYS, params):
            p.grad = m.decoder_grads[k]
        opt.step()
        if it % 200 == 0 or it == iterations - 1:
            log.info("pretrain %d/%d loss %.5f sdf %.3g depth %.3g rgb %.3g", it + 1, iterations,
                     scalars["loss"], scalars["sdf"], scalars["depth"], scalars["rgb"])
    return m.decoders.weights()


SETTINGS_KEY = "settings"
"""Key of a decoder file's recorded settings: a JSON text (how the weights were made)."""


def save_decoders(weights: dict[str, torch.Tensor], path: str | Path,
                  settings: dict[str, object] | None = None) -> None:
    """Write decoder weights (float32 matrices) to ``path`` with ``torch.save``; ``settings``
    (JSON-able: scene, seed, iterations, ... and the versions that made them) are kept beside
    them as a JSON text under :data:`SETTINGS_KEY` (:func:`decoder_settings` reads it back)."""
    import json

    data: dict[str, object] = {k: weights[k].detach().cpu().float().contiguous() for k in KEYS}
    if settings is not None:
        data[SETTINGS_KEY] = json.dumps(settings, sort_keys=True)
    torch.save(data, str(path))


def decoder_settings(path: str | Path | None = None) -> dict[str, object] | None:
    """The settings a decoder file records (:func:`save_decoders`), or None for a file without
    them (the shipped file predates them; docs/MAP_PERFORMANCE.md gives its command)."""
    import json

    p = Path(path) if path is not None else DEFAULT_DECODERS
    data = torch.load(str(p), map_location="cpu", weights_only=True)
    text = data.get(SETTINGS_KEY) if isinstance(data, dict) else None
    return json.loads(text) if isinstance(text, str) else None


def load_decoders(path: str | Path | None = None) -> dict[str, torch.Tensor]:
    """Read decoder weights (``weights_only=True``); default: the shipped file."""
    p = Path(path) if path is not None else DEFAULT_DECODERS
    if not p.is_file():
        raise FileNotFoundError(f"Decoder weights file {p} does not exist; pass the path of a "
                                f"file written by ramensim.agents.map.pretrain.save_decoders, or "
                                f"pretrain decoders first.")
    try:
        data = torch.load(str(p), map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - any unreadable file is the user's input
        raise ValueError(f"Decoder weights file {p} could not be read as a torch file of "
                         f"tensors ({exc}); expected a file written by save_decoders.") from exc
    if not isinstance(data, dict) or any(k not in data for k in KEYS):
        raise ValueError(f"Decoder weights file {p} holds {type(data).__name__} with keys "
                         f"{sorted(data) if isinstance(data, dict) else '-'}; expected a dict "
                         f"with {list(KEYS)}.")
    return {k: data[k].float() for k in KEYS}


def main(argv: list[str] | None = None) -> None:
    """``python -m ramensim.agents.map.pretrain --out agents/data/decoders.pt``: pretrain on the
    built-in synthetic room (the lead pretrains on the world's scene through the API)."""
    import argparse

    from . import synthetic

    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("--out", default=str(DEFAULT_DECODERS), help="output file")
    ap.add_argument("--iterations", type=int, default=800, help="optimiser steps")
    ap.add_argument("--frames", type=int, default=32, help="synthetic frames")
    ap.add_argument("--seed", type=int, default=0, help="root seed")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    frames = synthetic.frames(args.frames, 80, 60)
    cfg = MapConfig(keyframe_pixel_share=0.2)
    w = pretrain_decoders(frames, synthetic.bounds(), cfg, args.iterations, args.seed)
    save_decoders(w, args.out)
    log.info("wrote %s", args.out)


if __name__ == "__main__":
    main()
