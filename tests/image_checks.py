"""Image comparisons that hold on every OpenGL driver.

The tests were written on Mesa llvmpipe, where rasterisation is deterministic and the tight
per-pixel tolerances stay. Other drivers legitimately place MSAA samples elsewhere, dither
alpha to coverage (the hair pass with MSAA) in their own pattern and decide sub-pixel edge
coverage differently, which flips single pixels along thin strands; these helpers state the
driver-independent part: where the picture differs, that it differs only at isolated edge
pixels, and that it keeps its structure (region means).
"""
from __future__ import annotations

import numpy as np

LUMA = np.array([0.2126, 0.7152, 0.0722])


def software_renderer(gl) -> bool:
    """True on the software rasterisers (llvmpipe, ...) the reference images and tight
    tolerances come from (mane.gpu.is_software_renderer)."""
    from mane.gpu import is_software_renderer

    return is_software_renderer(gl)


def luminance(img) -> np.ndarray:
    return np.asarray(img, dtype=np.float64) @ LUMA


def background(img) -> np.ndarray:
    """The per-channel median of the image border (the clear colour in these scenes)."""
    a = np.asarray(img, dtype=np.float64)
    return np.median(np.concatenate([a[0], a[-1], a[:, 0], a[:, -1]]), axis=0)


def foreground(img, bg=None, threshold: float = 2.0) -> np.ndarray:
    """(H, W) mask of the pixels that differ from the background by more than ``threshold``."""
    a = np.asarray(img, dtype=np.float64)
    bg = background(a) if bg is None else np.asarray(bg, dtype=np.float64)
    return np.abs(a - bg).max(axis=-1) > threshold


def edge_pixel_stats(a, b, threshold: float = 8.0) -> dict:
    """How two renders of one scene differ: ``mean`` |a - b| over all channels, ``changed``
    the fraction of foreground pixels (either image) off by more than ``threshold`` in some
    channel, ``ink`` the relative difference of the total foreground intensity
    sum |img - background| (flipped edge pixels move it little; a wider, shifted or missing
    strand moves it by its share)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    bg = background(a)
    fg = foreground(a, bg) | foreground(b, bg)
    d = np.abs(a - b)
    ink_a, ink_b = np.abs(a - bg).sum(), np.abs(b - bg).sum()
    return {
        "mean": float(d.mean()),
        "changed": float((d.max(axis=-1) > threshold).sum() / max(fg.sum(), 1)),
        "ink": float(abs(ink_a - ink_b) / max(ink_a, 1e-9)),
        "foreground": int(fg.sum()),
    }


def block_means(img, block: int) -> np.ndarray:
    """Mean luminance of each block x block tile (the image cropped to whole tiles)."""
    y = luminance(img)
    h, w = (y.shape[0] // block) * block, (y.shape[1] // block) * block
    return y[:h, :w].reshape(h // block, block, w // block, block).mean(axis=(1, 3))


def gradient_energy(img) -> float:
    """Mean squared luminance step between neighbouring pixels. Anti-aliasing splits each
    silhouette step over partially covered pixels, which lowers it (a step of s becomes two
    of s / 2: half the energy), whatever the sample pattern."""
    y = luminance(img)
    return float((np.diff(y, axis=0) ** 2).mean() + (np.diff(y, axis=1) ** 2).mean())
