"""Errors a user can cause. Each says what is wrong, where, and what to do.

The command line prints these without a traceback and exits non-zero; anything
else escaping from a loader or a command is a bug in mane.
"""
from __future__ import annotations


class ManeError(Exception):
    """Base of every error that mane raises on purpose."""


class FormatError(ManeError):
    """A file is not what its name says, or is truncated, corrupt or hostile."""

    def __init__(self, message: str, path=None, offset: int | None = None):
        where = ""
        if path is not None:
            where = f"{path}"
            if offset is not None:
                where += f" (byte {offset})"
            where += ": "
        super().__init__(where + message)
        self.path = path
        self.offset = offset


def not_a_file(path) -> FormatError:
    """The error for a path that is not a file to read: a folder, or nothing."""
    from pathlib import Path

    return FormatError("a folder, not a file" if Path(path).is_dir() else "no such file", path)


class UnsupportedFormatError(ManeError):
    """No reader or writer knows this file suffix."""


class GroomError(ManeError):
    """Strand data breaks an invariant (NaN positions, strands of one point, bad shapes)."""


class UsageError(ManeError):
    """A bad argument, flag or setting."""


class GPUError(ManeError):
    """OpenGL is missing, too old, or failed."""


class GLFeatureError(GPUError):
    """The OpenGL context lacks a version or an extension that a feature needs."""


class ShaderCompileError(GPUError):
    """A GLSL source failed to compile or link; the message names the original file and line."""


class GPUMemoryError(GPUError):
    """The data would not fit in GPU memory; refused before allocating."""
