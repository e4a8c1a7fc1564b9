"""A data set's specification: a TOML file, and the same as frozen dataclasses.

    spec = load_spec("examples/dataset_tiny.toml")      # or parse_spec(dict, base_dir)
    spec.samples, spec.num_shards, spec.hash()

Ranges are ``[lo, hi]`` (a number alone: lo = hi); each sample draws its values uniformly from
them with its own generator (mane.dataset.sampling). Lengths in metres, angles in degrees,
focal lengths in millimetres on a sensor ``sensor_height`` mm tall, temperatures in kelvin.
Every bad value is refused with a one-line ``UsageError`` naming its table and key.
"""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

from ..errors import UsageError
from ..render.shading.melanin import PRESETS   # the renderer's named hair colours: one table for both
from ..setting import read_toml, unknown

OUTPUTS = ("rgb", "hdr", "exr", "mask", "depth", "depth16", "orientation", "ids", "camera", "strands")
"""rgb: rgb.png (8-bit sRGB); hdr: hdr.npy (float16 linear radiance before tone mapping); exr:
rgb_linear.exr (the same as a half-float OpenEXR, ZIP compressed; needs openexr); mask:
mask.png (8-bit hair coverage); depth: depth.npy (float32 metres, 0 = no hair); depth16:
depth16.png (uint16, DEPTH16_SCALE units per metre); orientation: orientation.npy (float32
angle in [0, pi)) and orientation_conf.npy (float32 confidence); ids: strand_id.npy and
guide_id.npy (uint32, 0xFFFFFFFF = no hair); camera: camera.json (intrinsics, extrinsics,
lights, the sample's parameters); strands: strands.npz (the strands in camera space)."""
DEFAULT_OUTPUTS = ("rgb", "mask", "depth", "orientation", "ids", "camera", "strands")
DEPTH16_SCALE = 10000.0   # depth16.png: 0.1 mm per unit, up to 6.5 m
HAIR_FILE_SUFFIXES = (".hair", ".data", ".tfx", ".ply", ".abc", ".usd", ".usda", ".usdc", ".npz", ".bin")
MOTIONS = ("none", "nod", "shake", "turn")
# RenderSettings fields a dataset spec may not set: the renderer that makes the maps needs them so
FIXED_RENDER = {"size": "use the top-level size", "rasterizer": "the maps need 'compute'",
                "pipeline": "the maps need 'compute'", "oit": "the maps need 'none'",
                "supersample": "the maps need 1", "interpolation_mode": "the maps need 'single'",
                "hair_color": "use [colors]", "lod": "distance LOD changes strands per view"}


def _range(table: str, key: str, value, lo=-math.inf, hi=math.inf, integer=False) -> tuple:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = [value, value]
    if (not isinstance(value, (list, tuple)) or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
        raise UsageError(f"[{table}] {key} must be a number or a range [lo, hi], got {value!r}")
    a, b = (int(v) if integer else float(v) for v in value)
    if integer and any(float(v) != int(v) for v in value):
        raise UsageError(f"[{table}] {key} must be whole numbers, got {value!r}")
    if not (math.isfinite(a) and math.isfinite(b) and a <= b):
        raise UsageError(f"[{table}] {key} must be finite with lo <= hi, got {value!r}")
    if a < lo or b > hi:
        raise UsageError(f"[{table}] {key} must lie within [{lo}, {hi}], got {value!r}")
    return (a, b)


def _keys(table: str, data: dict, cls) -> dict:
    if not isinstance(data, dict):
        raise UsageError(f"[{table}] must be a table, got {data!r}")
    known = [f.name for f in fields(cls)]
    unknown = sorted(set(data) - set(known))
    if unknown:
        raise UsageError(f"unknown key {unknown[0]!r} in [{table}]; known keys: {', '.join(known)}")
    return data


@dataclass(frozen=True)
class GroomSource:
    """One kind of groom: a procedural ``style`` (a grooming preset) grown with ``strands`` guide
    strands of ``points`` points and a seed drawn from ``seeds`` [lo, hi], or a hair ``file``, or
    every hair file in a ``folder``. ``weight``: how often it is picked relative to the others;
    ``scale``: multiplies file coordinates (TressFX samples are in cm: 0.01); ``style_options``:
    StyleSettings fields for the procedural style."""

    style: str | None = None
    file: str | None = None
    folder: str | None = None
    strands: int = 1000
    points: int = 16
    seeds: tuple = (0, 999)
    weight: float = 1.0
    scale: float = 1.0
    style_options: dict = field(default_factory=dict)

    def files(self, base: Path) -> list[Path]:
        if self.file is not None:
            return [base / self.file]
        if self.folder is not None:
            return sorted(p for p in (base / self.folder).iterdir() if p.suffix.lower() in HAIR_FILE_SUFFIXES)
        return []


@dataclass(frozen=True)
class Colors:
    """Hair colour per sample: a ``presets`` name (PRESETS) drawn uniformly, or melanin
    concentrations drawn from ``eumelanin`` and ``pheomelanin`` ranges (when presets is empty)."""

    presets: tuple = ()
    eumelanin: tuple = (0.2, 8.0)
    pheomelanin: tuple = (0.0, 1.0)


@dataclass(frozen=True)
class Views:
    """The camera orbits the hair's centroid: ``azimuth`` about +Y (0 faces the
    face), ``elevation`` above the horizon, ``distance`` (m) from the centre, ``focal_length``
    (mm on a ``sensor_height`` mm tall sensor), the look-at target moved by up to ``jitter`` m
    along each axis."""

    azimuth: tuple = (-180.0, 180.0)
    elevation: tuple = (-10.0, 30.0)
    distance: tuple = (0.8, 1.2)
    focal_length: tuple = (40.0, 70.0)
    sensor_height: float = 24.0
    jitter: float = 0.0


@dataclass(frozen=True)
class Lights:
    """``count`` directional lights (a range of whole numbers, 1..4), each from ``azimuth`` /
    ``elevation`` degrees, with ``intensity`` and a black body's colour at ``temperature`` K;
    ``ambient``: the renderer's ambient term."""

    count: tuple = (1, 3)
    azimuth: tuple = (-180.0, 180.0)
    elevation: tuple = (0.0, 70.0)
    intensity: tuple = (1.0, 3.0)
    temperature: tuple = (3000.0, 7500.0)
    ambient: tuple = (0.05, 0.2)


@dataclass(frozen=True)
class Simulation:
    """Before capture, ``seconds`` (a range; 0: at rest) of simulation with the head moving by
    one of ``motions`` and a horizontal wind of ``wind`` m/s from a random direction."""

    seconds: tuple = (0.0, 0.0)
    motions: tuple = ("none",)
    wind: tuple = (0.0, 0.0)
    fps: float = 60.0

    @property
    def enabled(self) -> bool:
        return self.seconds[1] > 0.0


@dataclass(frozen=True)
class DatasetSpec:
    """The whole data set: see the module's docstring and examples/dataset_*.toml."""

    name: str = "mane-dataset"
    seed: int = 0
    samples: int = 16
    samples_per_shard: int = 1000
    views_per_groom: int = 1
    """Consecutive samples sharing a groom, head and hair colour (index // views_per_groom):
    several views and lights of each hairstyle, and the worker grows or loads it once."""
    size: tuple = (512, 512)
    outputs: tuple = DEFAULT_OUTPUTS
    heads: tuple = ("default",)
    grooms: tuple = (GroomSource(style="long_wavy"),)
    colors: Colors = Colors()
    views: Views = Views()
    lights: Lights = Lights()
    simulation: Simulation = Simulation()
    render: dict = field(default_factory=dict)
    base_dir: str = "."

    @property
    def num_shards(self) -> int:
        return math.ceil(self.samples / self.samples_per_shard)

    def shard_range(self, shard: int) -> range:
        lo = shard * self.samples_per_shard
        return range(lo, min(lo + self.samples_per_shard, self.samples))

    def to_dict(self) -> dict:
        d = asdict(self)
        d.pop("base_dir")
        return json.loads(json.dumps(d))

    def hash(self) -> str:
        """sha256 of the canonical JSON of everything that decides the samples (not base_dir)."""
        return hashlib.sha256(json.dumps(self.to_dict(), sort_keys=True).encode()).hexdigest()

    def render_settings(self):
        """The RenderSettings every sample starts from (colour and ambient vary per sample)."""
        from ..render.settings import RenderSettings

        # the spec's colours decide a sample's look, not a groom file's own colours
        kw = {"shadows": "deep_opacity", "use_file_colors": False, **self.render, "size": tuple(self.size), "rasterizer": "compute",
              "pipeline": "compute"}
        # a material per sample: its tables from the absorption grid (ms), not built (~1 s each)
        kw["shading_options"] = {"tables": "interpolated", **dict(kw.get("shading_options") or {})}
        try:
            settings = RenderSettings(**kw)
        except TypeError as exc:
            raise UsageError(f"[render]: {exc}") from None
        from ..render.renderer import ShadingAdapter

        # the shading model and its options, with a colour from melanin as every sample has
        ShadingAdapter(settings.shading, None, {**settings.shading_options, "melanin": (1.0, 0.2)})
        return settings


def _groom(i: int, d: dict) -> GroomSource:
    t = f"grooms {i}"
    d = dict(_keys(t, d, GroomSource))
    given = [k for k in ("style", "file", "folder") if d.get(k) is not None]
    if len(given) != 1:
        raise UsageError(f"[{t}] needs exactly one of style, file or folder, got {given or 'none'}")
    if "style" in d:
        from ..grooming import PRESETS

        if d["style"] not in PRESETS:
            raise UsageError(f"[{t}] unknown style {d['style']!r}; presets: {', '.join(PRESETS)}")
        from ..grooming import StyleSettings

        opts = d.get("style_options", {})
        known = {f.name for f in fields(StyleSettings)}
        if not isinstance(opts, dict) or set(opts) - known:
            bad = sorted(set(opts) - known) if isinstance(opts, dict) else opts
            raise UsageError(f"[{t}] unknown style_options {bad}; StyleSettings fields: {', '.join(sorted(known))}")
    for k in ("strands", "points"):
        if k in d and (not isinstance(d[k], int) or isinstance(d[k], bool) or d[k] < (1 if k == "strands" else 2)):
            raise UsageError(f"[{t}] {k} must be a whole number >= {1 if k == 'strands' else 2}, got {d[k]!r}")
    if "seeds" in d:
        d["seeds"] = _range(t, "seeds", d["seeds"], 0, 2**31 - 1, integer=True)
    for k in ("weight", "scale"):
        if k in d and not (isinstance(d[k], (int, float)) and float(d[k]) > 0):
            raise UsageError(f"[{t}] {k} must be a number > 0, got {d[k]!r}")
    return GroomSource(**d)


def parse_spec(data: dict, base_dir=".") -> DatasetSpec:
    """A DatasetSpec from a TOML table (paths relative to ``base_dir``), validated."""
    data = dict(_keys("top level", data, DatasetSpec))
    data.pop("base_dir", None)
    kw: dict = {"base_dir": str(Path(base_dir).resolve())}
    if "name" in data:
        kw["name"] = str(data["name"])
    for k, lo in (("seed", 0), ("samples", 1), ("samples_per_shard", 1), ("views_per_groom", 1)):
        if k in data:
            v = data[k]
            if not isinstance(v, int) or isinstance(v, bool) or v < lo or v >= 2**63:
                raise UsageError(f"{k} must be a whole number >= {lo}, got {v!r}")
            kw[k] = v
    if "size" in data:
        s = data["size"]
        if (not isinstance(s, (list, tuple)) or len(s) != 2
                or not all(isinstance(v, int) and 8 <= v <= 8192 for v in s)):
            raise UsageError(f"size must be [width, height] in 8..8192 pixels, got {s!r}")
        kw["size"] = tuple(s)
    if "outputs" in data:
        o = data["outputs"]
        if not isinstance(o, list) or not o or any(x not in OUTPUTS for x in o) or len(set(o)) != len(o):
            raise UsageError(f"outputs must be a list of distinct names from {', '.join(OUTPUTS)}, got {o!r}")
        if "exr" in o:
            try:
                import OpenEXR  # noqa: F401
            except ImportError:
                raise UsageError("outputs: 'exr' needs OpenEXR: pip install 'mane[dataset]' (openexr==3.5.3)") from None
        kw["outputs"] = tuple(o)
    if "heads" in data:
        h = data["heads"]
        if not isinstance(h, list) or not h or not all(isinstance(x, str) for x in h):
            raise UsageError(f"heads must be a list of 'default', 'none' (hair alone) or mesh files, got {h!r}")
        for x in h:
            if x not in ("default", "none") and not (Path(base_dir) / x).is_file():
                raise UsageError(f"heads: no mesh file {x!r} (relative to {base_dir})")
        kw["heads"] = tuple(h)
    if "grooms" in data:
        g = data["grooms"]
        if not isinstance(g, list) or not g:
            raise UsageError("grooms must be a non-empty list of tables ([[grooms]])")
        srcs = tuple(_groom(i, d) for i, d in enumerate(g))
        for i, s in enumerate(srcs):
            if s.style is None:
                try:
                    files = s.files(Path(base_dir))
                except OSError as exc:
                    raise UsageError(f"[grooms {i}] cannot read {s.file or s.folder!r}: {exc}") from None
                if not files or not all(f.is_file() for f in files):
                    raise UsageError(f"[grooms {i}] no hair file at {s.file or s.folder!r} (relative to {base_dir})")
        kw["grooms"] = srcs
    if "colors" in data:
        d = dict(_keys("colors", data["colors"], Colors))
        if "presets" in d:
            p = d["presets"]
            if not isinstance(p, list) or any(x not in PRESETS for x in p):
                raise UsageError(f"[colors] presets must be names from {', '.join(PRESETS)}, got {p!r}")
            d["presets"] = tuple(p)
        for k in ("eumelanin", "pheomelanin"):
            if k in d:
                d[k] = _range("colors", k, d[k], 0.0, 50.0)
        kw["colors"] = Colors(**d)
    if "views" in data:
        d = dict(_keys("views", data["views"], Views))
        limits = {"azimuth": (-360.0, 360.0), "elevation": (-89.0, 89.0), "distance": (0.01, 1000.0),
                  "focal_length": (1.0, 2000.0)}
        for k, (lo, hi) in limits.items():
            if k in d:
                d[k] = _range("views", k, d[k], lo, hi)
        for k in ("sensor_height", "jitter"):
            if k in d and not (isinstance(d[k], (int, float)) and 0 <= float(d[k]) < 1000 and
                               (k == "jitter" or float(d[k]) > 0)):
                raise UsageError(f"[views] {k} must be a number{' > 0' if k == 'sensor_height' else ' >= 0'}, got {d[k]!r}")
        kw["views"] = Views(**d)
    if "lights" in data:
        d = dict(_keys("lights", data["lights"], Lights))
        if "count" in d:
            from ..render.lights import MAX_LIGHTS

            d["count"] = _range("lights", "count", d["count"], 1, MAX_LIGHTS, integer=True)
        limits = {"azimuth": (-360.0, 360.0), "elevation": (-90.0, 90.0), "intensity": (0.0, 1e4),
                  "temperature": (1000.0, 40000.0), "ambient": (0.0, 10.0)}
        for k, (lo, hi) in limits.items():
            if k in d:
                d[k] = _range("lights", k, d[k], lo, hi)
        kw["lights"] = Lights(**d)
    if "simulation" in data:
        d = dict(_keys("simulation", data["simulation"], Simulation))
        if "seconds" in d:
            d["seconds"] = _range("simulation", "seconds", d["seconds"], 0.0, 60.0)
        if "wind" in d:
            d["wind"] = _range("simulation", "wind", d["wind"], 0.0, 100.0)
        if "motions" in d:
            m = d["motions"]
            if not isinstance(m, list) or not m or any(x not in MOTIONS for x in m):
                raise UsageError(f"[simulation] motions must be names from {', '.join(MOTIONS)}, got {m!r}")
            d["motions"] = tuple(m)
        if "fps" in d and not (isinstance(d["fps"], (int, float)) and 1 <= d["fps"] <= 10000):
            raise UsageError(f"[simulation] fps must be in 1..10000, got {d['fps']!r}")
        kw["simulation"] = Simulation(**d)
    if "render" in data:
        r = data["render"]
        if not isinstance(r, dict):
            raise UsageError("[render] must be a table of RenderSettings fields")
        from ..render.settings import RenderSettings

        names = RenderSettings.field_names()
        for k in r:
            if k in FIXED_RENDER:
                raise UsageError(f"[render] {k} cannot be set in a data set spec ({FIXED_RENDER[k]})")
            if k not in names:
                raise UsageError(f"[render] {unknown(k, names, 'RenderSettings field')}")
        kw["render"] = {k: (tuple(v) if isinstance(v, list) else v) for k, v in r.items()}
    spec = DatasetSpec(**kw)
    spec.render_settings()   # RenderSettings validates the values: one-line UsageError
    return spec


def load_spec(path) -> DatasetSpec:
    """Read and validate a TOML spec; relative paths in it are relative to its folder."""
    path = Path(path)
    data = read_toml(path, "spec")
    return parse_spec(data, path.parent)


def estimate_bytes(spec: DatasetSpec) -> dict:
    """Rough bytes per sample per output (PNG guessed at half its raw size), and the total.
    Id maps: the dtype of the largest procedural groom's rendered strands (encode.id_dtype),
    uint32 for hair files (their strand counts are known only once loaded)."""
    import numpy as np

    from .id_maps import id_dtype

    w, h = spec.size
    n = w * h
    strands = max((g.strands * g.points if g.style else 50_000 * 16) for g in spec.grooms)
    spg = int(spec.render_settings().strands_per_guide)
    guides = max((g.strands if g.style else 2 ** 32 - 1) for g in spec.grooms)
    id_bytes = np.dtype(id_dtype(min(guides * spg, 2 ** 32 - 1))).itemsize + np.dtype(id_dtype(guides)).itemsize
    per = {"rgb": n * 3 // 2, "hdr": n * 6, "exr": n * 4, "mask": n // 4, "depth": n * 4, "depth16": n // 2,
           "orientation": n * 4, "ids": n * id_bytes, "camera": 3000, "strands": strands * 12}
    files = {"orientation": 2, "ids": 2}
    sample = sum(per[o] + 512 * (1 + files.get(o, 1)) for o in spec.outputs)
    return {"per_output": {o: per[o] for o in spec.outputs}, "per_sample": sample,
            "total": sample * spec.samples + 1024 * spec.num_shards}
