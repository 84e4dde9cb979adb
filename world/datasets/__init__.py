"""Dataset readers: Replica (NICE-SLAM layout), ScanNet and TUM RGB-D, all producing a
:class:`Sequence` of posed frames on disk."""
from ramensim.world.datasets.common import DatasetFrame, Sequence, split_frames
from ramensim.world.datasets.replica import read_replica
from ramensim.world.datasets.scannet import read_scannet
from ramensim.world.datasets.tum import read_tum

__all__ = ["DatasetFrame", "Sequence", "split_frames", "read_replica", "read_scannet", "read_tum"]
