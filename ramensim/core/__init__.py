"""The shared vocabulary every layer imports downward: posed frames and intrinsics
(:mod:`.frames`), simulation events (:mod:`.events`), typed results (:mod:`.results`) and
atomic files (:mod:`.files`). It imports nothing else of the project."""
