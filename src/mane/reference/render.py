"""The reference renderer: the real-time renderer's scene, path traced by Mitsuba 3.

    img = render(groom, head=mesh, settings=s, camera=cam, lights=lights, spp=256)  # (H, W, 3) f32
    render_png(groom, "ref.png", spp=64)         # the same, written as an sRGB PNG
    cov = hair_coverage(groom, settings=s, ...)  # (H, W): the fraction of each pixel hair covers

``render`` draws exactly what ``Renderer`` draws: the expand pass's strands (interpolation,
multiplication, clumps, strays, curl, root-to-tip width taper) as round B-spline tubes
(``scene.bspline_control_points``), the renderer's camera (pinhole, vertical ``fov_y``, the
aspect of ``settings.size``; ``Renderer.default_camera()`` when none is given), its lights and
the hair material of ``settings`` (``HairMaterial.from_settings``) with Mitsuba's ``hair`` BSDF
(Chiang et al. 2016), and the head mesh (``settings.draw_head``) as a Lambertian of albedo
``settings.skin_color``. Radiance is linear, over ``background`` (black by default).

Light units (the same numbers give comparable images): a directional ``Light`` of colour c
and intensity I is Mitsuba's ``directional`` emitter of irradiance c * I (W/m^2 on a surface
facing it), which is what mane's shading multiplies its hair BSDF (cosine included) by; a
point light is Mitsuba's ``point`` emitter of radiant intensity c * I (W/sr, falling off as
1/d^2, as mane's). There is no ambient term: compare with ``RenderSettings(ambient=0)``.
Mitsuba's diffuse head reflects albedo / pi (mane's head shader reflects the albedo itself).

Mitsuba is an optional extra (``pip install mane[reference]``). Its variant (``variant=``, else
``$MANE_REFERENCE_VARIANT``, else ``scalar_rgb``) is one of ``VARIANTS`` or "auto" (the GPU's
where it starts, else scalar_rgb): ``scalar_rgb`` needs nothing more; ``cuda_ad_rgb`` renders on an NVIDIA GPU (the driver's CUDA and OptiX) and
``llvm_ad_rgb`` on every CPU core (a recent libLLVM), both the same estimator of the same image
with other random numbers. Above ``pass_spp`` samples (64, or 512 for the two JIT variants,
``default_pass_spp``) the image is the mean of independent passes, each rendered in a child
process (``passes.py``). Images are cached on disk by a hash of the strands, camera, lights,
material, head, size, samples (and passes), seed, depth, Mitsuba's version and variant
(``cache.py``), and so is each pass.
"""
from __future__ import annotations

import functools
import os
import tempfile
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..errors import ManeError, UsageError
from . import cache as _cache
from . import passes as _passes
from .scene import ExpandedStrands, HairMaterial, bspline_control_points, renderer_strands

MITSUBA_VARIANT = "scalar_rgb"           # the default variant
VARIANTS = ("scalar_rgb", "cuda_ad_rgb", "llvm_ad_rgb")
VARIANT_ENV = "MANE_REFERENCE_VARIANT"
JIT_PASS_SPP = 512                      # samples per pass of the JIT variants (a pass is one kernel launch)
INSTALL_HINT = "pip install mane[reference]"


class ReferenceUnavailableError(ManeError):
    """Mitsuba 3 (the reference renderer's optional extra) is not installed."""


def resolve_variant(variant: str | None = None) -> str:
    """``variant``, else ``$MANE_REFERENCE_VARIANT``, else ``scalar_rgb``; one of ``VARIANTS``, or
    "auto": cuda_ad_rgb where this machine renders with it, else scalar_rgb (probed once)."""
    name = variant if variant is not None else (os.environ.get(VARIANT_ENV) or MITSUBA_VARIANT)
    if name == "auto":
        return _auto_variant()
    if name not in VARIANTS:
        where = "" if variant is not None else f" (from ${VARIANT_ENV})"
        raise UsageError(f"unknown Mitsuba variant {name!r}{where}: use one of {', '.join(VARIANTS)} or auto")
    return name


@functools.cache
def _auto_variant() -> str:
    """cuda_ad_rgb if Mitsuba can start it here (an NVIDIA driver with CUDA and OptiX), else
    scalar_rgb; the answer is kept for the process."""
    return "cuda_ad_rgb" if available("cuda_ad_rgb") else MITSUBA_VARIANT


def default_pass_spp(variant: str | None = None) -> int:
    """Samples per pass: 64 for scalar_rgb (its curves crashed above that on Sintel blond), 512
    for the JIT variants (each pass costs a process start and a kernel compile)."""
    return _passes.DEFAULT_PASS_SPP if resolve_variant(variant) == "scalar_rgb" else JIT_PASS_SPP


def mitsuba(variant: str | None = None):
    """The ``mitsuba`` module with ``variant`` (``resolve_variant``) set, or a one-line ManeError."""
    name = resolve_variant(variant)
    try:
        import mitsuba as mi
    except ImportError:
        raise ReferenceUnavailableError(f"the reference renderer needs Mitsuba 3: {INSTALL_HINT}") from None
    try:
        if mi.variant() != name:
            mi.set_variant(name)
    except (AttributeError, ImportError, RuntimeError) as exc:
        hint = {"cuda_ad_rgb": "it needs an NVIDIA driver with CUDA and OptiX",
                "llvm_ad_rgb": "it needs libLLVM (DRJIT_LIBLLVM_PATH)"}.get(name, INSTALL_HINT)
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ReferenceUnavailableError(f"Mitsuba's {name} variant is unavailable ({first}); {hint}") from None
    return mi


def available(variant: str | None = None) -> bool:
    try:
        mitsuba(variant)
        return True
    except ReferenceUnavailableError:
        return False


def mitsuba_version() -> str:
    import mitsuba as mi    # the version alone: no variant needed

    return str(mi.__version__)


# ---------------------------------------------------------------- the scene
def _prepare(groom, *, head, camera, lights, settings, size, strands, ctx):
    """(settings, strands, head or None, camera, lights): everything resolved."""
    from ..render import Renderer, RenderSettings
    from ..render.lights import default_lights

    settings = settings if settings is not None else RenderSettings()
    if size is not None:
        settings = settings.replace(size=tuple(int(v) for v in size))
    if strands is None or camera is None:
        if groom is None:
            raise UsageError("reference.render needs a groom (or strands= and camera=)")
        r = Renderer(settings.replace(pipeline="compute", oit="none"), ctx=ctx, profile=False)
        try:
            r.set_strands(groom)
            r.set_head(head)
            if strands is None:
                strands = renderer_strands(r)
            if camera is None:
                camera = r.default_camera()
        finally:
            r.release()
    if not isinstance(strands, ExpandedStrands):
        strands = ExpandedStrands.from_expand_buffer(strands)
    lights = list(lights) if lights is not None else default_lights()
    if head is not None and not settings.draw_head:
        head = None
    return settings, strands.visible(), head, camera, lights


def _write_curves(path: Path, ctrl: np.ndarray, radii: np.ndarray) -> None:
    """Mitsuba's curve text file: "x y z radius" per control point, an empty line between curves."""
    S, M, _ = ctrl.shape
    rows = np.concatenate([ctrl, radii[..., None]], axis=2).reshape(S, M * 4).tolist()
    fmt = "%.9g %.9g %.9g %.9g\n" * M + "\n"
    with open(path, "w") as f:
        f.writelines(fmt % tuple(r) for r in rows)


def _write_ply(path: Path, mesh) -> None:
    """A binary little-endian PLY of the head: positions, vertex normals, triangles."""
    v = np.ascontiguousarray(mesh.vertices, np.float32)
    n = np.ascontiguousarray(mesh.normals, np.float32)
    f = np.ascontiguousarray(mesh.faces, np.int32)
    header = ("ply\nformat binary_little_endian 1.0\n"
              f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
              "property float nx\nproperty float ny\nproperty float nz\n"
              f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    faces = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", 3)])
    faces["n"], faces["i"] = 3, f
    with open(path, "wb") as out:
        out.write(header.encode("ascii"))
        out.write(np.concatenate([v, n], axis=1).astype("<f4").tobytes())
        out.write(faces.tobytes())


def _hair_bsdf(material: HairMaterial) -> dict:
    d = {"type": "hair", "longitudinal_roughness": float(material.longitudinal_roughness),
         "azimuthal_roughness": float(material.azimuthal_roughness),
         "scale_tilt": float(material.mitsuba_scale_tilt), "int_ior": float(material.eta), "ext_ior": 1.0}
    if material.sigma_a is None:
        d.update(eumelanin=float(material.eumelanin), pheomelanin=float(material.pheomelanin))
    else:   # an "rgb" value in [0, 1] times a scale (RGB textures above 1 would be clipped)
        s = np.asarray(material.sigma_a, float)
        top = float(max(s.max(), 1e-12))
        d.update(sigma_a={"type": "rgb", "value": (s / top).tolist()}, scale=top)
    return d


def _emitter(light) -> dict:
    value = (np.asarray(light.color, float) * float(light.intensity)).tolist()
    if light.is_point:
        return {"type": "point", "position": list(map(float, light.vector)),
                "intensity": {"type": "rgb", "value": value}}
    d = np.asarray(light.vector, float)
    d = d / np.linalg.norm(d)
    return {"type": "directional", "direction": (-d).tolist(), "irradiance": {"type": "rgb", "value": value}}


def _sensor(mi, sensor: dict, spp: int) -> dict:
    w, h = sensor["size"]
    return {"type": "perspective", "fov": float(sensor["fov_y"]), "fov_axis": "y",
            "near_clip": float(sensor["near"]), "far_clip": float(sensor["far"]),
            "to_world": mi.ScalarTransform4f().look_at(origin=sensor["eye"], target=sensor["target"], up=sensor["up"]),
            "film": {"type": "hdrfilm", "width": int(w), "height": int(h), "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": int(spp)}}


def scene_job(folder: Path, strands, head, camera, lights, settings, material, max_depth,
              variant: str = MITSUBA_VARIANT) -> dict:
    """Write the curves (and the head's PLY) into ``folder`` and describe the rest of the scene
    as plain JSON-able data: what ``scene_from_job`` (here or in a child process) loads."""
    folder = Path(folder)
    ctrl, radii = bspline_control_points(strands.points, 0.5 * strands.widths)
    _write_curves(folder / "hair.txt", ctrl, radii)
    if head is not None:
        _write_ply(folder / "head.ply", head)
    return {"folder": str(folder), "head": head is not None, "skin": list(map(float, settings.skin_color)),
            "sensor": {"size": [int(v) for v in settings.size], "fov_y": float(camera.fov_y),
                       "near": float(max(camera.near, 1e-4)), "far": float(camera.far),
                       "eye": list(map(float, camera.eye)), "target": list(map(float, camera.target)),
                       "up": list(map(float, camera.up))},
            "emitters": [_emitter(lt) for lt in lights], "bsdf": _hair_bsdf(material), "max_depth": int(max_depth),
            "variant": str(variant)}


def scene_from_job(mi, job: dict, spp: int | None = None, integrator=None, order=("hair", "head")) -> dict:
    """Mitsuba's scene dict of a ``scene_job`` (``spp`` defaults to the job's own)."""
    folder = Path(job["folder"])
    spp = int(job["spp"] if spp is None else spp)
    scene = {"type": "scene", "sensor": _sensor(mi, job["sensor"], spp),
             "integrator": integrator or {"type": "path", "max_depth": int(job["max_depth"])}}
    shapes = {"hair": {"type": "bsplinecurve", "filename": str(folder / "hair.txt"), "bsdf": job["bsdf"]}}
    if job["head"]:
        shapes["head"] = {"type": "ply", "filename": str(folder / "head.ply"), "face_normals": False,
                          "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": job["skin"]}}}
    if "dummy" in order:    # a tiny curve behind the camera: it moves the other shapes' indices
        dummy = folder / "dummy.txt"
        sensor = job["sensor"]
        eye, target = np.asarray(sensor["eye"], float), np.asarray(sensor["target"], float)
        back = eye - 10.0 * (target - eye) / np.linalg.norm(target - eye)
        dummy.write_text("".join(f"{back[0] + 0.01 * k:.6g} {back[1]:.6g} {back[2]:.6g} 0.001\n" for k in range(4)))
        shapes["dummy"] = {"type": "bsplinecurve", "filename": str(dummy)}
    for i, name in enumerate(n for n in order if n in shapes):   # Mitsuba orders shapes by key
        scene[f"{chr(ord('a') + i)}_{name}"] = shapes[name]
    for i, emitter in enumerate(job["emitters"]):
        scene[f"light{i}"] = emitter
    return scene


def _hash_parts(strands, head, camera, lights, settings, material, spp, seed, max_depth, kind,
                variant=MITSUBA_VARIANT) -> dict:
    parts = {"kind": kind, "points": strands.points, "widths": strands.widths,
             "camera": [list(map(float, camera.eye)), list(map(float, camera.target)), list(map(float, camera.up)),
                        float(camera.fov_y), float(camera.near), float(camera.far)],
             "lights": [[lt.kind, list(lt.vector), list(lt.color), float(lt.intensity)] for lt in lights],
             "size": list(settings.size), "material": material.key(), "spp": int(spp), "seed": int(seed),
             "max_depth": int(max_depth), "mitsuba": mitsuba_version(), "variant": str(variant)}
    if head is not None:
        parts.update(head_vertices=np.asarray(head.vertices, np.float32), head_faces=np.asarray(head.faces, np.int32),
                     head_normals=np.asarray(head.normals, np.float32), skin=list(map(float, settings.skin_color)))
    return parts


def _radiance_parts(strands, head, camera, lights, settings, material, spp, seed, max_depth, pass_spp,
                    variant=MITSUBA_VARIANT) -> dict:
    """The cache parts of a radiance render: one pass is keyed as it always was (spp, seed);
    several passes add their sample counts (their seeds follow from ``seed``)."""
    parts = _hash_parts(strands, head, camera, lights, settings, material, spp, seed, max_depth, "radiance", variant)
    counts = _passes.split(spp, pass_spp if pass_spp else spp)
    if len(counts) > 1:
        parts["passes"] = counts
    return parts


def _cache_folder(cache_dir) -> Path:
    return Path(cache_dir) if cache_dir is not None else _cache.default_dir()


def _cached_render(parts, cache, cache_dir, make) -> np.ndarray:
    key = _cache.scene_hash(parts)
    folder = _cache_folder(cache_dir)
    if cache:
        hit = _cache.load(folder, key)
        if hit is not None:
            return hit
    image = np.asarray(make(), np.float32)
    if cache:
        meta = {k: v for k, v in parts.items() if not isinstance(v, np.ndarray)}
        meta["strands"] = int(parts["points"].shape[0])
        _cache.store(folder, key, image, meta)
    return image


def cache_key(groom=None, *, head=None, camera=None, lights=None, settings=None, spp: int = 64, size=None,
              material: HairMaterial | None = None, strands=None, seed: int = 0, max_depth: int = 64,
              pass_spp: int | None = 0, variant: str | None = None, ctx=None) -> str:
    """The cache key ``render`` would use for these arguments (``pass_spp`` 0: the variant's own)."""
    variant = resolve_variant(variant)
    pass_spp = default_pass_spp(variant) if pass_spp == 0 else pass_spp
    settings, strands, head, camera, lights = _prepare(groom, head=head, camera=camera, lights=lights,
                                                      settings=settings, size=size, strands=strands, ctx=ctx)
    material = material if material is not None else HairMaterial.from_settings(settings)
    return _cache.scene_hash(_radiance_parts(strands, head, camera, lights, settings, material, spp, seed, max_depth,
                                             pass_spp, variant))


def render(groom=None, *, head=None, camera=None, lights=None, settings=None, spp: int = 64, size=None,
           material: HairMaterial | None = None, strands=None, seed: int = 0, max_depth: int = 64,
           pass_spp: int | None = 0, isolate: bool = True, progress=None,
           background=(0.0, 0.0, 0.0), cache: bool = True, cache_dir=None, variant: str | None = None,
           ctx=None) -> np.ndarray:
    """Path trace what the real-time renderer draws; (H, W, 3) float32 linear radiance.

    groom     a Groom (or anything ``Renderer.set_strands`` takes); None with ``strands=``
    head      a Mesh drawn as a Lambertian of ``settings.skin_color`` (when settings.draw_head)
    camera    a ``mane.render.Camera`` (default: the real-time renderer's default camera)
    lights    a list of ``mane.render.lights.Light`` (default: ``default_lights()``)
    settings  the ``RenderSettings`` whose strands and material are drawn (size, strands per
              guide, interpolation, widths, shading, shading_options, hair_color, skin_color)
    spp       samples per pixel;  size: (W, H) overriding settings.size
    material  a ``HairMaterial`` overriding the one derived from ``settings``
    strands   an ``ExpandedStrands`` (or the expand pass's (S, N, 8) buffer) to draw instead of
              expanding ``groom`` again
    seed      the sampler's seed (the same seed gives the same image)
    max_depth the path tracer's longest path (Mitsuba's max_depth; Russian roulette after 5;
              2 is single scattering: the first hit lit directly, exact opaque-fibre shadows)
    pass_spp  samples per pass (``passes.py``): spp above it is rendered as independent passes
              of pass_spp samples with seeds derived from ``seed`` and averaged (the same
              expectation, the noise of spp samples); None: one pass; 0 (the default):
              ``default_pass_spp(variant)``
    isolate   run each pass in a child process (default): a Mitsuba crash then fails that pass,
              which is tried again with another seed, and then raises one ReferencePassError
              line instead of killing the caller; False renders in this process
    progress  callable(message) for a line per pass
    background linear RGB added where the camera sees nothing (the hair is not transparent:
              coverage at the silhouettes is exact, so black gives premultiplied radiance)
    cache, cache_dir  keep and reuse the image on disk (``cache.default_dir()`` by default);
              each pass is also cached as the one-pass render of its seed
    variant   Mitsuba's variant (``resolve_variant``: scalar_rgb, cuda_ad_rgb, llvm_ad_rgb)
    """
    variant = resolve_variant(variant)
    mi = mitsuba(variant)
    if pass_spp == 0:
        pass_spp = default_pass_spp(variant)
    if int(spp) < 1:
        raise UsageError(f"spp must be >= 1, got {spp}")
    if pass_spp is not None and int(pass_spp) < 1:
        raise UsageError(f"pass_spp must be >= 1 (or None for one pass), got {pass_spp}")
    settings, strands, head, camera, lights = _prepare(groom, head=head, camera=camera, lights=lights,
                                                      settings=settings, size=size, strands=strands, ctx=ctx)
    material = material if material is not None else HairMaterial.from_settings(settings)
    pass_spp = int(pass_spp) if pass_spp is not None else int(spp)
    parts = _radiance_parts(strands, head, camera, lights, settings, material, spp, seed, max_depth, pass_spp,
                            variant)
    folder = _cache_folder(cache_dir)

    def pass_parts(n, s):
        return _hash_parts(strands, head, camera, lights, settings, material, n, s, max_depth, "radiance", variant)

    def cached(n, s):
        return _cache.load(folder, _cache.scene_hash(pass_parts(n, s))) if cache else None

    def store(n, s, image):
        if cache:
            meta = {k: v for k, v in pass_parts(n, s).items() if not isinstance(v, np.ndarray)}
            _cache.store(folder, _cache.scene_hash(pass_parts(n, s)), image, {**meta, "strands": strands.count})

    def make():
        with tempfile.TemporaryDirectory(prefix="mane-ref-") as tmp:
            job = scene_job(Path(tmp), strands, head, camera, lights, settings, material, max_depth, variant)
            if isolate:
                return _passes.render_passes(job, spp, pass_spp, seed, cached=cached, store=store, progress=progress)
            scene = mi.load_dict(scene_from_job(mi, job, pass_spp))

            def in_process(n, s):
                return np.array(mi.render(scene, seed=int(s), spp=int(n)), np.float32)[..., :3]

            return _passes.render_passes(job, spp, pass_spp, seed, cached=cached, store=store, progress=progress,
                                         runner=in_process)

    image = _cached_render(parts, cache, cache_dir, make).copy()
    bg = np.asarray(background, np.float32).reshape(3)
    if np.any(bg != 0):
        cov = hair_coverage(strands=strands, head=head, camera=camera, settings=settings, spp=max(4, min(int(spp), 16)),
                            seed=seed, cache=cache, cache_dir=cache_dir, include_head=True)
        image += (1.0 - cov)[..., None] * bg
    return image


def hair_coverage(groom=None, *, head=None, camera=None, settings=None, size=None, strands=None, spp: int = 16,
                  seed: int = 0, include_head: bool = False, cache: bool = True, cache_dir=None,
                  ctx=None) -> np.ndarray:
    """(H, W) float32: the fraction of each pixel where the camera sees hair (the head, when
    given, hides what is behind it); with ``include_head`` hair or head. From Mitsuba's
    ``shape_index`` AOV (box filter, ``spp`` samples), which averages each shape's index (its
    place in ``scene.shapes()``, from 1) over the pixel: with the hair's and the head's indices
    (i, j) in one render and (k, l) in a second with a dummy curve added out of view (Mitsuba
    lists curves before meshes, so swapping the keys does not swap them), the two averages give
    the two coverages (a 2 x 2 system; the same seed, the same samples). In this process (the
    AOV integrator traces no paths and has not crashed). Always with ``scalar_rgb`` (it traces
    no paths, so a GPU gains little): cuda_ad_rgb's shape indices of a scene with curves and a
    mesh did not follow ``scene.shapes()`` (the curly head's hair coverage came out 3.5x
    scalar_rgb's, 2026-12-02; without a head the two agreed within 0.1 %)."""
    variant = MITSUBA_VARIANT
    mi = mitsuba(variant)
    settings, strands, head, camera, _ = _prepare(groom, head=head, camera=camera, lights=[],
                                                 settings=settings, size=size, strands=strands, ctx=ctx)
    from ..render.lights import Light

    material = HairMaterial()
    parts = _hash_parts(strands, head, camera, [], settings, material, spp, seed, 0,
                        "hair+head coverage" if include_head else "hair coverage", variant)
    aov = {"type": "aov", "aovs": "si:shape_index"}

    def make():
        with tempfile.TemporaryDirectory(prefix="mane-ref-") as tmp:
            job = scene_job(Path(tmp), strands, head, camera, [Light()], settings, material, 1, variant)

            def one(order):
                scene = mi.load_dict(scene_from_job(mi, job, spp, integrator=aov, order=order))
                index = {s.id().split("_", 1)[-1]: i + 1 for i, s in enumerate(scene.shapes())}
                return np.array(mi.render(scene, seed=int(seed), spp=int(spp)))[..., 0], index

            va, ia = one(("hair", "head"))
            if head is None:
                return np.clip(va / ia["hair"], 0.0, 1.0)
            vb, ib = one(("dummy", "head", "hair"))
        m = np.array([[ia["hair"], ia["head"]], [ib["hair"], ib["head"]]], float)
        if abs(np.linalg.det(m)) < 1e-9:
            raise ManeError(f"Mitsuba gave the hair and the head the same shape indices in both orders ({ia}, {ib})")
        h, d = np.einsum("ij,jyx->iyx", np.linalg.inv(m), np.stack([va, vb]))
        return np.clip(h + d if include_head else h, 0.0, 1.0)

    return _cached_render(parts, cache, cache_dir, make)


# ---------------------------------------------------------------- pictures
def to_srgb8(image, exposure: float = 1.0) -> np.ndarray:
    """Linear radiance -> 8-bit sRGB (times ``exposure``, clipped; no tone curve)."""
    c = np.clip(np.asarray(image, np.float64) * float(exposure), 0.0, 1.0)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
    return np.round(s * 255.0).astype(np.uint8)


def save_png(image, path, exposure: float = 1.0) -> Path:
    """Write linear radiance as an sRGB PNG (clipped at 1 after ``exposure``)."""
    from PIL import Image

    from ..io.atomic import atomic_write_path

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write_path(path) as tmp:
        Image.fromarray(to_srgb8(image, exposure)).save(tmp, format="PNG")
    return path


def render_png(groom=None, path="reference.png", *, exposure: float = 1.0, **kwargs) -> np.ndarray:
    """``render(groom, **kwargs)`` written to ``path`` as an sRGB PNG; returns the linear image."""
    image = render(groom, **kwargs)
    save_png(image, path, exposure)
    return image


def describe(material: HairMaterial) -> str:
    d = asdict(material)
    return ", ".join(f"{k}={v if not isinstance(v, float) else round(v, 4)}" for k, v in d.items())


__all__ = ["render", "render_png", "save_png", "hair_coverage", "cache_key", "available", "mitsuba",
           "to_srgb8", "ReferenceUnavailableError", "MITSUBA_VARIANT", "VARIANTS", "VARIANT_ENV", "resolve_variant",
           "default_pass_spp", "INSTALL_HINT"]
