"""Evaluation of neural implicit maps (docs/ALGORITHM.md section 5, NICE-SLAM protocol).

Meshes from an SDF (:mod:`ramensim.evaluation.mesh`), culling to what the cameras saw
(:mod:`ramensim.evaluation.cull`), the paper's metrics -- Artifacts, Holes, Completion ratio
(:mod:`ramensim.evaluation.metrics`) -- and aggregation over agents and trials
(:mod:`ramensim.evaluation.summary`). This package takes callables, arrays and ``trimesh``
meshes; it imports neither ``ramensim`` nor ``agents``.
"""
