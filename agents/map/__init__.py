"""The neural implicit map every agent trains (Co-SLAM style, docs/ALGORITHM.md section 1):
hash grid + OneBlob + frozen pretrained decoders, rendering, losses, keyframe rays."""
from .config import PRESETS, MapConfig
from .neural_map import NeuralMap
from .pretrain import load_decoders, pretrain_decoders, save_decoders

__all__ = ["MapConfig", "PRESETS", "NeuralMap", "load_decoders", "pretrain_decoders",
           "save_decoders"]
