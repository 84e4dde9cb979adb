"""The shared vocabulary every layer imports downward: posed frames and intrinsics
(:mod:`.frames`), simulation events (:mod:`.events`), typed results (:mod:`.results`) and
atomic files (:mod:`.files`), and the build step of the small C kernels (:mod:`.native`). It
imports nothing else of the project."""
