"""ramensim: a discrete-event simulator of multi-robot neural implicit mapping under
lossy, delayed, windowed communication. The composition root of the project."""

__version__ = "0.1.0"
