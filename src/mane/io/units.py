"""Units and up axes of loaded grooms and meshes: what the file says, what its format's
convention is, what the data suggest, and what the user asked for.

mane works in metres with Y up. A loader returns the file's numbers as stored and a
``metadata['file_frame']`` hint (``units``/``up`` with a source: ``"declared"`` when the file
says so, e.g. USD ``metersPerUnit``/``upAxis`` or mane's own marker; ``"convention"`` when its
format has one, e.g. TressFX centimetres Y-up, cyHair Z-up). :func:`normalize_groom` and
:func:`normalize_mesh` then pick, for each of units and up:

1. the user's option (``units="cm"``, ``up="z"``, ``scale=0.01``): source ``"option"``;
2. what the file declares: source ``"declared"`` (never second-guessed);
3. the format's convention, kept when the data agree with it: source ``"convention"``;
4. otherwise a guess from the data: source ``"guessed"``, and one warning line.

Units are guessed from sizes: hair strands are ~2 cm..1 m long and a groom spans ~0.1..3 m;
of metres, centimetres and millimetres the one that makes the groom most like that wins
(a head mesh: 0.2..3 m across; a mesh in none of them is scaled to a 0.35 m diagonal,
unit ``"arbitrary"``). The up axis is guessed from the geometry: roots sit on a cap of the
scalp (a sphere fitted to them; the cap's centre is above the sphere's centre) and hanging
hair runs down from its roots. A convention is overridden only when both signals agree on
another axis; without a convention a confident guess is used, else Y.

The outcome goes to ``metadata['frame']``: ``file_units``, ``units_source``, ``scale``
(metres per file unit), ``file_up``, ``up_source``, ``guessed`` (which of units/up were
guessed) and ``notes``; ``metadata['units']`` becomes ``"m"`` and ``metadata['up_axis']``
``"y"``. A head loaded with its groom (``like=groom_frame``) whose stored coordinates already
fit the groom's stored coordinates (roots on its surface) gets the groom's transform.

:func:`check_fit` measures roots against a head mesh (inside it, far from it) with NumPy and
SciPy only (no GL): the numbers ``mane info`` reports and the warnings the commands print.
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from ..errors import UsageError
from ..groom import AXES, up_axis_matrix

UNIT_SCALES = {"m": 1.0, "cm": 0.01, "mm": 0.001}
UNIT_CHOICES = ("auto", "m", "cm", "mm")
UP_CHOICES = ("auto", "x", "y", "z")
SOURCES = ("option", "declared", "convention", "guessed", "default")

# plausible sizes in metres
HAIR_LENGTH = (0.005, 2.0)        # median strand length
GROOM_SPAN = (0.08, 5.0)          # bounding-box diagonal of a groom (a fringe .. a bear)
MESH_SPAN = (0.2, 3.0)           # bounding-box diagonal of a head, bust or body mesh
MAX_GROOM_SPAN = 1e3              # a groom wider than this is refused, not warned about: not in metres
TYPICAL_LENGTH, TYPICAL_SPAN, TYPICAL_HEAD = 0.2, 0.5, 0.35


class UnitsWarning(UserWarning):
    """A unit or an up axis was guessed, or a fit check failed."""


def _warn(message: str) -> None:
    warnings.warn(message, UnitsWarning, stacklevel=6)   # the caller of mane.load / load_mesh


def check_units(units) -> str:
    u = "auto" if units is None else str(units).lower()
    if u not in UNIT_CHOICES:
        raise UsageError(f"units must be one of {', '.join(UNIT_CHOICES)}; got {units!r}")
    return u


def check_up(up) -> str:
    u = "auto" if up is None else str(up).lower()
    if u not in UP_CHOICES:
        raise UsageError(f"up must be one of {', '.join(UP_CHOICES)}; got {up!r}")
    return u


def check_scale(scale) -> float | None:
    if scale is None:
        return None
    try:
        s = float(scale)
    except (TypeError, ValueError):
        raise UsageError(f"scale must be a positive number, got {scale!r}") from None
    if not (math.isfinite(s) and s > 0):
        raise UsageError(f"scale must be a positive finite number, got {scale!r}")
    return s


# ---------------------------------------------------------------------------- guesses
def _log_distance(value: float, target: float) -> float:
    return abs(math.log(max(value, 1e-30) / target))


def groom_unit_scores(median_length: float, span: float) -> dict[str, float]:
    """Each unit's distance from a typical groom (lower is better; inf: implausible)."""
    out = {}
    for name, s in UNIT_SCALES.items():
        L, D = median_length * s, span * s
        ok = HAIR_LENGTH[0] <= L <= HAIR_LENGTH[1] and GROOM_SPAN[0] <= D <= GROOM_SPAN[1]
        out[name] = _log_distance(L, TYPICAL_LENGTH) + _log_distance(D, TYPICAL_SPAN) if ok else math.inf
    return out


def mesh_unit_scores(span: float) -> dict[str, float]:
    out = {}
    for name, s in UNIT_SCALES.items():
        D = span * s
        out[name] = _log_distance(D, TYPICAL_HEAD) if MESH_SPAN[0] <= D <= MESH_SPAN[1] else math.inf
    return out


def _sphere_fit(p: np.ndarray):
    """(centre, radius) of the least-squares sphere through points, or None when ill-posed."""
    if len(p) < 8:
        return None
    c0 = p.mean(axis=0)
    q = p - c0
    scale = float(np.sqrt((q ** 2).sum(axis=1).mean())) or 1.0
    q = q / scale
    A = np.concatenate([2 * q, np.ones((len(q), 1))], axis=1)
    b = (q ** 2).sum(axis=1)
    sv = np.linalg.svd(A, compute_uv=False)
    if sv[-1] < 1e-3 * sv[0]:
        return None   # the roots lie on a plane or a curve: no cap to read
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    c = sol[:3]
    r2 = sol[3] + c @ c
    if r2 <= 0:
        return None
    r = math.sqrt(r2)
    if r > 20:   # nearly flat: the centre is far away and its side is not known
        return None
    return c * scale + c0, r * scale


def up_signals(roots: np.ndarray, tips: np.ndarray, lengths: np.ndarray) -> dict:
    """Two votes for the up direction (unit vectors with a strength in [0, 1], or None).

    ``cap``: from the centre of a sphere fitted to the roots toward their centroid (roots
    cover the top and back of a head), strength = that offset / radius (0 for a full sphere,
    0.5 for a hemisphere). ``hang``: the mean of root - tip over the mean strand length
    (1 for hair hanging straight down)."""
    roots = np.asarray(roots, np.float64)
    out = {"cap": None, "hang": None}
    fit = _sphere_fit(roots)
    if fit is not None:
        c, r = fit
        d = roots.mean(axis=0) - c
        n = float(np.linalg.norm(d))
        if n > 0:
            out["cap"] = (d / n, min(1.0, n / r))
    mean_len = float(np.mean(lengths)) if len(lengths) else 0.0
    if mean_len > 0:
        d = (np.asarray(roots, np.float64) - np.asarray(tips, np.float64)).mean(axis=0)
        n = float(np.linalg.norm(d))
        if n > 0:
            out["hang"] = (d / n, min(1.0, n / mean_len))
    return out


def _vote_axis(vote, min_strength: float, min_cos: float = 0.75) -> str | None:
    """The axis (x/y/z, + direction only) a vote points along, when it is clear enough."""
    if vote is None:
        return None
    d, strength = vote
    k = int(np.argmax(d))
    if strength < min_strength or d[k] < min_cos:
        return None
    return "xyz"[k]


def guess_up(roots, tips, lengths, prior: str | None) -> tuple[str | None, str]:
    """(axis or None, reason). With a prior (a convention) only two agreeing votes move it."""
    if len(roots) < 8:
        return None, "too few strands to read an up axis"
    s = up_signals(roots, tips, lengths)
    cap = _vote_axis(s["cap"], 0.25)
    hang = _vote_axis(s["hang"], 0.3)
    if prior is not None:
        if cap is not None and cap == hang and cap != prior:
            return cap, f"roots cap the {cap} axis and strands hang down along it"
        return None, ""
    if cap is not None and (hang is None or hang == cap):
        return cap, f"roots cap the {cap} axis" + (" and strands hang along it" if hang else "")
    if cap is None and hang is not None:
        return hang, f"strands hang down along {hang}"
    if cap is not None and hang is not None:   # disagreeing votes: trust the scalp
        return cap, f"roots cap the {cap} axis (strands run along {hang})"
    return None, "no clear up axis in the geometry"


def _mesh_up(vertices: np.ndarray) -> tuple[str | None, str]:
    """A lone mesh's up: the longest axis when it clearly is (a bust or a body stands tall)."""
    ext = vertices.max(axis=0) - vertices.min(axis=0)
    order = np.argsort(ext)[::-1]
    if ext[order[0]] > 1.3 * ext[order[1]]:
        k = int(order[0])
        return "xyz"[k], f"the mesh is tallest along {'xyz'[k]}"
    return None, "no clearly tallest axis"


# ---------------------------------------------------------------------------- the frame
def _hint(metadata: dict) -> dict:
    h = metadata.get("file_frame")
    return dict(h) if isinstance(h, dict) else {}


def frame_matrix(frame: dict) -> np.ndarray:
    """4x4: stored coordinates -> metres, Y up."""
    m = up_axis_matrix(frame["file_up"], "y")
    s = float(frame["scale"])
    return np.diag([s, s, s, 1.0]) @ m


def _resolve(kind: str, hint: dict, units: str, up: str, scale: float | None,
             unit_scores, up_guess, label: str, allow_arbitrary: float | None = None) -> dict:
    units, up, scale = check_units(units), check_up(up), check_scale(scale)
    if scale is not None and units != "auto":
        raise UsageError("give either units or scale, not both")
    notes, guessed = [], []
    # ---- units
    h_units, h_src = hint.get("units"), hint.get("units_source")
    if scale is not None:
        file_units, u_src, s = "arbitrary", "option", scale
        for n, v in UNIT_SCALES.items():
            if math.isclose(v, scale, rel_tol=1e-9):
                file_units = n
    elif units != "auto":
        file_units, u_src, s = units, "option", UNIT_SCALES[units]
    elif h_src == "declared" and h_units is not None:
        file_units, u_src = h_units, "declared"
        s = float(hint.get("scale", UNIT_SCALES.get(h_units, 1.0)))
    else:
        scores = unit_scores()
        best = min(scores, key=scores.get)
        if h_units in UNIT_SCALES and math.isfinite(scores[h_units]):
            file_units, u_src = h_units, "convention"
        elif h_units in UNIT_SCALES:
            if math.isfinite(scores[best]):
                file_units, u_src = best, "guessed"
                notes.append(f"sizes do not fit the format's {h_units}; guessed {best}")
            elif allow_arbitrary is not None:
                file_units, u_src = "arbitrary", "guessed"
                notes.append(f"sizes fit none of m, cm, mm; scaled to a {TYPICAL_HEAD} m diagonal")
            else:
                file_units, u_src = h_units, "convention"
                notes.append(f"sizes look implausible for {kind} in any unit; kept the format's {h_units}")
        elif math.isfinite(scores["m"]) and scores["m"] <= scores[best] + 1.0:
            file_units, u_src = "m", "default"
        elif math.isfinite(scores[best]):
            file_units, u_src = best, "guessed"
        elif allow_arbitrary is not None:
            file_units, u_src = "arbitrary", "guessed"
            notes.append(f"sizes fit none of m, cm, mm; scaled to a {TYPICAL_HEAD} m diagonal")
        else:
            file_units, u_src = "m", "default"
            notes.append(f"sizes look implausible for {kind} in m, cm or mm; kept as metres")
        s = allow_arbitrary if file_units == "arbitrary" else UNIT_SCALES[file_units]
        if u_src == "guessed":
            guessed.append("units")
    # ---- up
    h_up, hu_src = hint.get("up"), hint.get("up_source")
    if up != "auto":
        file_up, up_src = up, "option"
    elif hu_src == "declared" and h_up in AXES:
        file_up, up_src = h_up, "declared"
    else:
        prior = h_up if h_up in AXES else None
        g, reason = up_guess(prior)
        if prior is not None and g is None:
            file_up, up_src = prior, "convention"
        elif g is not None:
            file_up, up_src = g, "guessed"
            guessed.append("up")
            notes.append(reason + (f" (the format's convention is {prior}-up)" if prior else ""))
        else:
            file_up, up_src = "y", "default"
    frame = {"file_units": file_units, "units_source": u_src, "scale": float(s),
             "file_up": file_up, "up_source": up_src, "guessed": guessed, "notes": notes}
    if guessed:
        what = " and ".join(f"{k} {file_units if k == 'units' else file_up + '-up'}" for k in guessed)
        _warn(f"{label}: guessed {what}"
              + (f" ({'; '.join(notes)})" if notes else "")
              + "; say units=/up= (--units/--up, --head-units/--head-up) to be sure")
    elif notes:
        _warn(f"{label}: {'; '.join(notes)}")
    return frame


def groom_frame(groom, units="auto", up="auto", scale=None, label: str = "groom") -> dict:
    """The frame (see the module docstring) of a groom in its stored coordinates."""
    hint = _hint(groom.metadata)
    lengths = groom.strand_lengths()
    lo, hi = groom.bbox()
    span = float(np.linalg.norm(hi.astype(np.float64) - lo))
    median = float(np.median(lengths))
    return _resolve("hair", hint, units, up, scale,
                    lambda: groom_unit_scores(median, span),
                    lambda prior: guess_up(groom.roots, groom.tips, lengths, prior), label)


def _apply_to_groom(groom, frame: dict):
    g = groom.transformed(frame_matrix(frame)) if (frame["file_up"] != "y" or frame["scale"] != 1.0) else groom
    if g is groom:
        g = groom.replace(metadata=dict(groom.metadata))
    g.metadata.pop("file_frame", None)
    g.metadata["frame"] = frame
    g.metadata["units"] = "m"
    g.metadata["up_axis"] = "y"
    return g


def normalize_groom(groom, units="auto", up="auto", scale=None, label: str = "groom"):
    """The groom in metres, Y up, with ``metadata['frame']`` saying how it got there."""
    return _apply_to_groom(groom, groom_frame(groom, units, up, scale, label))


def _raw_fit(mesh, groom_raw) -> float:
    """Median distance from the raw roots to the raw mesh's nearest vertex over its diagonal."""
    from scipy.spatial import cKDTree

    tree = cKDTree(mesh.vertices.astype(np.float64))
    d, _ = tree.query(groom_raw.roots.astype(np.float64))
    return float(np.median(d)) / max(mesh.diagonal(), 1e-30)


def mesh_frame(mesh, units="auto", up="auto", scale=None, like: dict | None = None,
               groom_raw=None, label: str = "head") -> dict:
    """A mesh's frame; with ``like`` (the frame of a groom, ``groom_raw`` its stored
    coordinates) a mesh whose stored coordinates fit the groom's takes the groom's frame."""
    units, up = check_units(units), check_up(up)
    hint = _hint(mesh.metadata)
    if like is not None and groom_raw is not None and units == "auto" and up == "auto" and scale is None \
            and hint.get("units_source") != "declared":
        try:
            fit = _raw_fit(mesh, groom_raw)
        except Exception:  # noqa: BLE001 - a fit that cannot be measured is no fit
            fit = math.inf
        if fit < 0.05:
            frame = dict(like)
            frame.update(units_source="groom", up_source="groom", guessed=[],
                         notes=[f"stored in the groom's frame (roots on the mesh: median "
                                f"{fit:.3f} of its diagonal); same transform"])
            return frame
    lo, hi = mesh.bbox()
    span = float(np.linalg.norm(hi.astype(np.float64) - lo))
    arbitrary = TYPICAL_HEAD / span if span > 0 else 1.0

    def up_guess(prior):
        if prior is not None:
            return None, ""
        return _mesh_up(mesh.vertices.astype(np.float64))

    return _resolve("a head mesh", hint, units, up, scale, lambda: mesh_unit_scores(span), up_guess,
                    label, allow_arbitrary=arbitrary)


def normalize_mesh(mesh, units="auto", up="auto", scale=None, like: dict | None = None,
                   groom_raw=None, label: str = "head"):
    frame = mesh_frame(mesh, units, up, scale, like=like, groom_raw=groom_raw, label=label)
    m = mesh.transformed(frame_matrix(frame)) if (frame["file_up"] != "y" or frame["scale"] != 1.0) \
        else mesh
    if m is mesh:
        from dataclasses import replace

        m = replace(mesh, metadata=dict(mesh.metadata))
    m.metadata.pop("file_frame", None)
    m.metadata["frame"] = frame
    m.metadata["units"] = "m"
    m.metadata["up_axis"] = "y"
    return m


# ---------------------------------------------------------------------------- checks
def check_fit(groom, mesh, far: float | None = None) -> dict:
    """Roots against a head mesh (both in metres): how many lie inside it, how many far away.

    Inside: the root is behind the nearest vertex's surface (its offset from that vertex
    points against the vertex normal), deeper than 1 mm. Far: farther than ``far`` from
    every vertex (default 2 cm or 5% of the mesh diagonal, the larger). Distances are to the
    nearest vertex (an upper bound of the distance to the surface)."""
    from scipy.spatial import cKDTree

    roots = groom.roots.astype(np.float64)
    v = mesh.vertices.astype(np.float64)
    tree = cKDTree(v)
    d, i = tree.query(roots)
    n = mesh.normals.astype(np.float64)[i]
    side = np.einsum("ij,ij->i", roots - v[i], n)
    inside = side < -1e-3
    far = max(0.02, 0.05 * mesh.diagonal()) if far is None else float(far)
    is_far = d > far
    out = {"roots": int(len(roots)), "inside_fraction": float(inside.mean()),
           "far_fraction": float(is_far.mean()), "median_distance_m": float(np.median(d)),
           "max_distance_m": float(d.max()), "far_threshold_m": far}
    w = []
    if out["inside_fraction"] > 0.05:
        w.append(f"{100 * out['inside_fraction']:.0f}% of the roots lie inside the head mesh")
    if out["far_fraction"] > 0.05:
        w.append(f"{100 * out['far_fraction']:.0f}% of the roots lie more than {far * 100:.0f} cm from the "
                 f"head (median {out['median_distance_m'] * 100:.1f} cm): is the head in the same "
                 "units and axes? (--head-units/--head-up/--head-scale)")
    out["warnings"] = w
    return out


def plausibility(groom) -> list[str]:
    """Warnings when a groom in metres does not look like hair (check_groom_span's error when it
    cannot be hair in metres at all)."""
    w = []
    lo, hi = groom.bbox()
    check_groom_span(lo, hi)
    med = float(np.median(groom.strand_lengths()))
    span = float(np.linalg.norm(hi.astype(np.float64) - lo))
    if not HAIR_LENGTH[0] <= med <= HAIR_LENGTH[1]:
        w.append(f"median strand length {med:.3g} m is implausible for hair (expected "
                 f"{HAIR_LENGTH[0]}..{HAIR_LENGTH[1]} m): check --units/--scale")
    if not GROOM_SPAN[0] <= span <= GROOM_SPAN[1]:
        w.append(f"the groom spans {span:.3g} m (expected {GROOM_SPAN[0]}..{GROOM_SPAN[1]} m): "
                 "check --units/--scale")
    return w


def check_groom_span(lo, hi) -> None:
    """Refuse a groom whose box (``lo``, ``hi``) is not finite or spans more than MAX_GROOM_SPAN:
    the renderer works in metres (strand widths, lights, shadow maps), so such a groom would be
    drawn as nothing or fail in its camera's maths."""
    span = float(np.linalg.norm(np.asarray(hi, np.float64) - np.asarray(lo, np.float64)))
    if not math.isfinite(span) or span > MAX_GROOM_SPAN:
        raise UsageError(f"the groom spans {span:.3g} m: it is not hair in metres. Scale it (Groom.scaled, "
                         f"or the units=/scale= of mane.load; --units/--scale)")


def frame_summary(frame: dict | None) -> str:
    """One line: 'cm (convention) -> m x0.01, z-up (guessed) -> y'."""
    if not frame:
        return "-"
    return (f"{frame['file_units']} ({frame['units_source']}), scale {frame['scale']:g} m per unit; "
            f"{frame['file_up']}-up ({frame['up_source']})")
