"""Image-against-reference numbers for ``mane bench fidelity``: small NumPy functions.

Images are (H, W, 3) linear radiance; ``mask`` is an (H, W) bool (the hair pixels) or None
(the whole image). Luminance is Rec. 709's (0.2126 R + 0.7152 G + 0.0722 B).

    mae(test, ref, mask)              mean |test - ref| over pixels and channels
    p95(test, ref, mask)              the 95th percentile of |test - ref| (pixels x channels)
    relative_mae(test, ref, mask)     mae / mean reference luminance
    luminance_ratio(test, ref, mask)  mean test luminance / mean reference luminance
    rgb_share(img, mask)              each channel's share of R + G + B (summed over pixels)
    rgb_balance(test, ref, mask)      rgb_share(test) - rgb_share(ref)
    falloff(img, mask)                mean luminance of the mask's upper half of its screen box
                                      over that of its lower half (crown / lower)
    falloff_ratio(test, ref, mask)    falloff(test) / falloff(ref)
    box(img, k)                       k x k block means (the image cropped to multiples of k)
    relative_mae_box(test, ref, mask, k)  relative_mae of the k x k block means over the blocks
                                      that are at least half mask: the path tracer's per-pixel
                                      noise averaged down (a 256-spp reference of sub-pixel
                                      strands has a relative MAE of ~0.2 against the truth)
"""
from __future__ import annotations

import numpy as np

LUMA = np.array([0.2126, 0.7152, 0.0722])


def luminance(img) -> np.ndarray:
    return np.asarray(img, np.float64)[..., :3] @ LUMA


def _pixels(img, mask) -> np.ndarray:
    a = np.asarray(img, np.float64)[..., :3]
    if mask is None:
        return a.reshape(-1, 3)
    return a[np.asarray(mask, bool)]


def _safe_div(a: float, b: float) -> float:
    return float(a / b) if b > 0 else float("nan")


def mae(test, ref, mask=None) -> float:
    d = np.abs(_pixels(test, mask) - _pixels(ref, mask))
    return float(d.mean()) if d.size else float("nan")


def p95(test, ref, mask=None) -> float:
    d = np.abs(_pixels(test, mask) - _pixels(ref, mask))
    return float(np.percentile(d, 95)) if d.size else float("nan")


def relative_mae(test, ref, mask=None) -> float:
    return _safe_div(mae(test, ref, mask), float((_pixels(ref, mask) @ LUMA).mean()) if mask is None or np.any(mask) else 0.0)


def luminance_ratio(test, ref, mask=None) -> float:
    t, r = _pixels(test, mask) @ LUMA, _pixels(ref, mask) @ LUMA
    return _safe_div(float(t.mean()) if t.size else 0.0, float(r.mean()) if r.size else 0.0)


def rgb_share(img, mask=None) -> np.ndarray:
    s = _pixels(img, mask).sum(axis=0)
    total = float(s.sum())
    return s / total if total > 0 else np.full(3, np.nan)


def rgb_balance(test, ref, mask=None) -> np.ndarray:
    return rgb_share(test, mask) - rgb_share(ref, mask)


def falloff(img, mask) -> float:
    """Crown over lower: the mask's bounding box on screen split at its middle row (the upper
    half gets the middle row when the height is odd); mean luminance over the mask's pixels of
    the upper half divided by that of the lower half."""
    m = np.asarray(mask, bool)
    rows = np.flatnonzero(m.any(axis=1))
    if rows.size == 0:
        return float("nan")
    top, bottom = int(rows[0]), int(rows[-1]) + 1
    mid = top + (bottom - top + 1) // 2
    lum = luminance(img)
    upper = np.zeros_like(m)
    upper[top:mid] = True
    up, lo = m & upper, m & ~upper
    if not up.any() or not lo.any():
        return float("nan")
    return _safe_div(float(lum[up].mean()), float(lum[lo].mean()))


def falloff_ratio(test, ref, mask) -> float:
    return _safe_div(falloff(test, mask), falloff(ref, mask))


def box(img, k: int) -> np.ndarray:
    a = np.asarray(img, np.float64)
    h, w = (a.shape[0] // k) * k, (a.shape[1] // k) * k
    a = a[:h, :w]
    return a.reshape(h // k, k, w // k, k, *a.shape[2:]).mean(axis=(1, 3))


def relative_mae_box(test, ref, mask, k: int = 4) -> float:
    m = box(np.asarray(mask, np.float64), k) >= 0.5
    if not m.any():
        return float("nan")
    return relative_mae(box(test, k), box(ref, k), m)


def flip(test, ref, mask=None) -> tuple[float, np.ndarray]:
    """NVIDIA FLIP (HDR) of test against ref: (mean error over the mask or the image, the
    (H, W) error map). Needs ``flip-evaluator`` (the reference extra)."""
    try:
        import flip_evaluator
    except ImportError:
        from ..reference.render import INSTALL_HINT, ReferenceUnavailableError

        raise ReferenceUnavailableError(f"the FLIP metric needs flip-evaluator: {INSTALL_HINT}") from None
    r = np.ascontiguousarray(np.maximum(np.asarray(ref, np.float32)[..., :3], 0.0))
    t = np.ascontiguousarray(np.maximum(np.asarray(test, np.float32)[..., :3], 0.0))
    err, _, _ = flip_evaluator.evaluate(r, t, "HDR", applyMagma=False, computeMeanError=False)
    err = np.asarray(err, np.float64)
    if err.ndim == 3:
        err = err[..., 0]
    sel = err if mask is None else err[np.asarray(mask, bool)]
    return (float(sel.mean()) if sel.size else float("nan")), err


def all_metrics(test, ref, mask=None, with_flip: bool = True) -> dict:
    """Every number above for one image pair (and the FLIP mean when ``with_flip``)."""
    out = {"mae": mae(test, ref, mask), "p95": p95(test, ref, mask), "relative_mae": relative_mae(test, ref, mask),
           "luminance_ratio": luminance_ratio(test, ref, mask),
           "rgb_balance": [float(x) for x in rgb_balance(test, ref, mask)],
           "rgb_share_ref": [float(x) for x in rgb_share(ref, mask)]}
    if mask is not None:
        out.update(falloff=falloff(test, mask), falloff_ref=falloff(ref, mask), falloff_ratio=falloff_ratio(test, ref, mask),
                   relative_mae_box4=relative_mae_box(test, ref, mask, 4))
    if with_flip:
        out["flip"] = flip(test, ref, mask)[0]
    return out
