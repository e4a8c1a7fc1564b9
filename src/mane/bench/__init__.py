"""Benchmarks: ``mane bench TARGET`` runs one and prints aligned tables or JSON.

Each target is a module with ``run(ctx, mode, progress=None) -> dict`` (the JSON object,
``{"meta": ..., "results": [...], ...}``) and ``format_text(result) -> str``; the command
(``mane bench``) finds them in ``mane.bench.targets.TARGETS``. ``mane.bench.common`` holds the
shared pieces: the JSON envelope and writer, timing statistics and table formatting.
"""
from __future__ import annotations

MODES = ("quick", "default", "full")

__all__ = ["MODES"]
