"""A reference image as independent passes, each path traced in a child process.

    image = render_passes(job, spp=1024, pass_spp=64, seed=0, cache_pass=...)   # (H, W, 3)
    python -m mane.reference.worker JOB.json OUT.npy                           # one pass (worker.py)

Why: Mitsuba 3.9.1's ``bsplinecurve`` plugin segfaults on some scenes at high sample counts
(Sintel blond at >= 128 spp, the same scene that renders at 64), and in-process a segfault
kills the caller. Each pass (``pass_spp`` samples, its own seed) runs in a fresh Python
(``WORKER``); a pass whose process dies is tried again with a new seed (``retries`` times),
then the whole render fails with one line naming the pass, the seed and the signal.

Averaging K independent passes of N samples is an unbiased estimate of one render of K N
samples with the same expectation and, the passes being independent, the same variance
(sigma^2 / (K N)): the noise falls as 1/sqrt(K) (``tests/test_reference.py`` checks both).
Pass k's seed is ``pass_seed(seed, k)``: pass 0 keeps ``seed`` (a single pass is the plain
render of that seed, the same image and cache entry), the others are a 32-bit hash of
(seed, k, attempt), far apart so that Mitsuba's per-block seeding (seed + block index) of
different passes cannot overlap.

The job is plain JSON: the scene folder (curves and head already written by the parent),
the sensor (camera, size), the emitters, the hair BSDF, the head's skin colour, max_depth.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..errors import ManeError

WORKER = [sys.executable, "-m", "mane.reference.worker"]    # + JOB.json OUT.npy (worker.py)
DEFAULT_PASS_SPP = 64     # Sintel blond renders at 64 spp and segfaulted at 128 and 256 (Mitsuba 3.9.1)


class ReferencePassError(ManeError):
    """A reference pass's child process failed (crashed or raised) on every attempt."""


def pass_seed(seed: int, k: int, attempt: int = 0) -> int:
    """The sampler seed of pass ``k`` (attempt ``attempt``): ``seed`` itself for (0, 0), else a
    32-bit mix (splitmix64's finaliser) of the three numbers."""
    if k == 0 and attempt == 0:
        return int(seed)
    x = (int(seed) * 0x9E3779B97F4A7C15 + (k + 1) * 0xBF58476D1CE4E5B9 + attempt * 0x94D049BB133111EB) & (2**64 - 1)
    x ^= x >> 30
    x = (x * 0xBF58476D1CE4E5B9) & (2**64 - 1)
    x ^= x >> 27
    x = (x * 0x94D049BB133111EB) & (2**64 - 1)
    x ^= x >> 31
    return int(x & 0x7FFFFFFF)


def split(spp: int, pass_spp: int) -> list[int]:
    """Samples per pass: as many ``pass_spp`` passes as fit, the remainder last."""
    spp, pass_spp = int(spp), int(pass_spp)
    if spp < 1 or pass_spp < 1:
        raise ManeError(f"spp and pass_spp must be >= 1, got {spp} and {pass_spp}")
    full, rest = divmod(spp, pass_spp)
    return [pass_spp] * full + ([rest] if rest else [])


def _describe_exit(code: int) -> str:
    if code < 0:
        try:
            return f"crashed ({signal.Signals(-code).name})"
        except ValueError:
            return f"died of signal {-code}"
    return f"exited with status {code}"


def _child_env() -> dict:
    """The parent's environment with mane's source folder first on PYTHONPATH (the child
    imports the same mane as the parent, installed or not)."""
    env = dict(os.environ)
    src = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


def run_pass(job: dict, spp: int, seed: int, timeout: float | None = None) -> tuple[np.ndarray | None, str]:
    """One pass in a child process: (image, "") or (None, why it failed in a few words)."""
    with tempfile.TemporaryDirectory(prefix="mane-pass-") as tmp:
        job_path, out_path = Path(tmp) / "job.json", Path(tmp) / "out.npy"
        job_path.write_text(json.dumps({**job, "spp": int(spp), "seed": int(seed)}))
        try:
            proc = subprocess.run([*WORKER, str(job_path), str(out_path)], env=_child_env(), capture_output=True,
                                  text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return None, f"timed out after {timeout:g} s"
        if proc.returncode != 0:
            last = [ln for ln in (proc.stderr or "").strip().splitlines() if ln.strip()]
            return None, _describe_exit(proc.returncode) + (f": {last[-1].strip()}" if last and proc.returncode > 0 else "")
        try:
            return np.load(out_path, allow_pickle=False), ""
        except (OSError, ValueError) as exc:
            return None, f"wrote no image ({exc})"


def render_passes(job: dict, spp: int, pass_spp: int = DEFAULT_PASS_SPP, seed: int = 0, retries: int = 2,
                  cached=None, store=None, progress=None, timeout: float | None = None, runner=None) -> np.ndarray:
    """The spp-weighted mean of ``split(spp, pass_spp)`` passes, each in a child process.

    cached(n, seed) -> image or None and store(n, seed, image): a per-pass cache (the pass of
    n samples and that seed is the plain render of that seed); progress(msg) for a line a pass.
    A pass that fails is tried with a new seed up to ``retries`` times; then ReferencePassError.
    runner(n, seed) -> image renders a pass in this process instead (its exceptions propagate)."""
    counts = split(spp, pass_spp)
    total = np.zeros(0)
    for k, n in enumerate(counts):
        image, errors = None, []
        for attempt in range(int(retries) + 1):
            s = pass_seed(seed, k, attempt)
            image = cached(n, s) if cached is not None else None
            if image is not None:
                break
            image, why = (runner(n, s), "") if runner is not None else run_pass(job, n, s, timeout)
            if image is not None:
                if store is not None:
                    store(n, s, image)
                break
            errors.append(f"seed {s}: {why}")
            if progress is not None:
                progress(f"reference pass {k + 1}/{len(counts)} ({n} spp, seed {s}) {why}"
                         + ("; trying another seed" if attempt < retries else ""))
        if image is None:
            raise ReferencePassError(f"Mitsuba failed on reference pass {k + 1}/{len(counts)} ({n} spp) "
                                     f"{len(errors)} times: " + "; ".join(errors))
        image = np.asarray(image, np.float64)
        total = image * n if total.size == 0 else total + image * n
        if progress is not None:
            progress(f"reference pass {k + 1}/{len(counts)} done ({n} spp)")
    return (total / int(spp)).astype(np.float32)
