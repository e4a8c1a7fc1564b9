"""``mane dataset``: the spec and its errors, per-sample parameters, the local and Ray runners
(identical shards), resume after a killed worker, and verify catching a broken shard."""
from __future__ import annotations

import hashlib
import io
import json
import shutil
import tarfile
import tempfile
from pathlib import Path

import numpy as np
import pytest

from mane.errors import UsageError

TINY = {
    "name": "test", "seed": 3, "samples": 6, "samples_per_shard": 2, "size": [40, 32],
    "outputs": ["rgb", "hdr", "exr", "mask", "depth", "depth16", "orientation", "ids", "camera", "strands"],
    "heads": ["none"], "grooms": [{"file": "g.npz", "weight": 2.0}, {"file": "g2.npz"}],
    "colors": {"presets": ["black", "blond", "red"]},
    "views": {"distance": [0.7, 0.9], "azimuth": [-50, 50], "jitter": 0.01},
    "lights": {"count": [1, 2], "temperature": [3000, 7000]},
    "render": {"strands_per_guide": 2, "msaa": 4, "shadows": "shadow_map", "shadow_map_size": 64, "segments": 14},
}


@pytest.fixture(scope="module")
def spec_dir(tmp_path_factory):
    from mane import save
    from mane.grooming.scene import default_scene

    d = tmp_path_factory.mktemp("spec")
    groom, _ = default_scene(num_guides=24, points=8, subdivisions=3)
    save(groom, d / "g.npz")
    save(groom.subset(np.arange(12)), d / "g2.npz")
    return d


@pytest.fixture(scope="module")
def tiny(spec_dir):
    from mane.dataset import parse_spec

    return parse_spec(TINY, spec_dir)


@pytest.fixture(scope="module")
def local_set(tiny, tmp_path_factory):
    from mane.dataset.local import run_local

    out = tmp_path_factory.mktemp("local")
    report = run_local(tiny, out, workers=1, encoders=0, progress=False)
    assert report.ok, report.lines()
    return out


def _shards(d):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(d.glob("shard-*.tar"))}


# ---------------------------------------------------------------------- spec
@pytest.mark.parametrize("change,words", [
    ({"samples": 0}, "samples must be"),
    ({"sampels": 3}, "unknown key 'sampels'"),
    ({"size": [4, 4]}, "size must be"),
    ({"outputs": ["rgb", "normals"]}, "outputs must be"),
    ({"views": {"elevation": [30, 10]}}, "[views] elevation"),
    ({"views": {"fov": 3}}, "unknown key 'fov' in [views]"),
    ({"lights": {"count": [0, 9]}}, "[lights] count"),
    ({"lights": {"temperature": 100}}, "[lights] temperature"),
    ({"colors": {"presets": ["green"]}}, "[colors] presets"),
    ({"grooms": [{"style": "wavy", "file": "g.npz"}]}, "exactly one of style, file or folder"),
    ({"grooms": [{"style": "afro"}]}, "unknown style 'afro'"),
    ({"grooms": [{"file": "nothing.hair"}]}, "no hair file"),
    ({"grooms": [{"style": "wavy", "style_options": {"lenght": 0.2}}]}, "unknown style_options"),
    ({"render": {"rasterizer": "hardware"}}, "cannot be set"),
    ({"render": {"shadow": "none"}}, "unknown RenderSettings field 'shadow'"),
    ({"render": {"shadows": "soft"}}, "shadows must be one of"),
    ({"render": {"shading": "phong"}}, "shading must be one of"),       # RenderSettings' declared choices
    ({"render": {"shading_options": {"shine": 2}}}, "shading_options has no key 'shine'"),
    ({"simulation": {"motions": ["dance"]}}, "[simulation] motions"),
    ({"heads": ["nohead.obj"]}, "no mesh file"),
])
def test_bad_specs_get_one_line_errors(spec_dir, change, words):
    from mane.dataset import parse_spec

    with pytest.raises(UsageError) as e:
        parse_spec({**TINY, **change}, spec_dir)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_toml_file_plan_and_hash(spec_dir, tmp_path, capsys):
    from mane.app.cli import main
    from mane.dataset import load_spec

    text = (f'samples = 5\nsamples_per_shard = 2\nsize = [64, 48]\nheads = ["none"]\n'
            f'[[grooms]]\nfile = "{spec_dir / "g.npz"}"\n[views]\nazimuth = [0, 90]\n')
    (tmp_path / "s.toml").write_text(text)
    s = load_spec(tmp_path / "s.toml")
    assert (s.samples, s.num_shards, list(s.shard_range(2))) == (5, 3, [4])
    assert s.views.azimuth == (0.0, 90.0) and s.views.distance == (0.8, 1.2)   # the rest default
    assert s.hash() == load_spec(tmp_path / "s.toml").hash()
    (tmp_path / "t.toml").write_text(text.replace("samples = 5", "samples = 6"))
    assert load_spec(tmp_path / "t.toml").hash() != s.hash()
    assert main(["dataset", "plan", str(tmp_path / "s.toml")]) == 0
    out = capsys.readouterr().out
    assert "5 samples of 64x48 in 3 shard(s)" in out and "estimated disk" in out
    (tmp_path / "bad.toml").write_text("samples = [")
    assert main(["dataset", "plan", str(tmp_path / "bad.toml")]) == 2


def test_sample_parameters_depend_on_seed_and_index_only(tiny):
    from mane.dataset.sampling import sample_params

    a = [sample_params(tiny, i) for i in (4, 0, 4)]
    assert a[0] == a[2] and a[0] != a[1]
    more = tiny.__class__(**{**tiny.__dict__, "samples": 1000, "samples_per_shard": 7})
    assert sample_params(more, 4) == a[0]      # nor on the set's size or sharding
    other = tiny.__class__(**{**tiny.__dict__, "seed": 4})
    assert sample_params(other, 4) != a[0]
    p = [sample_params(tiny, i) for i in range(200)]
    assert {x.color_preset for x in p} == {"black", "blond", "red"}
    assert all(-50 <= x.azimuth <= 50 and 0.7 <= x.distance <= 0.9 and 1 <= len(x.lights) <= 2 for x in p)
    picks = np.bincount([x.groom for x in p], minlength=2) / len(p)
    assert abs(picks[0] - 2 / 3) < 0.1          # weights 2 : 1
    f = p[0].focal_length   # fov from focal length on a 24 mm sensor
    assert abs(p[0].fov_y - np.degrees(2 * np.arctan(12.0 / f))) < 1e-9


@pytest.mark.parametrize("kelvin,xy", [(3000, (0.4369, 0.4041)), (4000, (0.3805, 0.3768)),
                                       (5000, (0.3451, 0.3516)), (6500, (0.3135, 0.3236)),
                                       (10000, (0.2807, 0.2884))])
def test_blackbody_on_the_planckian_locus(kelvin, xy):
    # chromaticities of the Planckian locus (CIE 1931 2 deg; Wyszecki & Stiles' tables)
    from mane.dataset.blackbody import blackbody_rgb, blackbody_xyz

    X = blackbody_xyz(kelvin)
    assert np.allclose(X[:2] / X.sum(), xy, atol=0.002)
    rgb = np.array(blackbody_rgb(kelvin))
    assert abs(rgb @ [0.2126, 0.7152, 0.0722] - 1.0) < 1e-9 and rgb.min() >= 0
    assert (rgb[0] > rgb[2]) == (kelvin < 7000)   # the locus crosses sRGB white near 6600 K


# ---------------------------------------------------------------------- runs
@pytest.mark.gpu
def test_local_run_verifies_and_decodes(tiny, local_set):
    import webdataset as wds

    from mane.dataset.shards import verify

    rep = verify(local_set)
    assert rep["ok"] and rep["samples"] == 6 and rep["shards"] == 3, rep
    m = json.loads((local_set / "manifest.json").read_text())
    assert m["spec_hash"] == tiny.hash() and m["renderers"] and m["mane_version"]
    for name, entry in m["shards"].items():
        assert hashlib.sha256((local_set / name).read_bytes()).hexdigest() == entry["sha256"]
    urls = [str(p) for p in sorted(local_set.glob("shard-*.tar"))]
    def png(key, data):   # PNGs as stored (8-bit RGB, 8-bit grey, 16-bit grey)
        if key.endswith(".png"):
            from PIL import Image

            return np.asarray(Image.open(io.BytesIO(data)))
        return None

    samples = list(wds.WebDataset(urls, shardshuffle=False).decode(png))
    assert [s["__key__"] for s in samples] == [f"{i:09d}" for i in range(6)]
    s = samples[3]
    assert s["rgb.png"].shape == (32, 40, 3) and s["mask.png"].shape == (32, 40)
    # 24 guides x 2 strands: uint8 ids (255: no hair); float16 orientation
    assert s["depth.npy"].dtype == np.float32 and s["strand_id.npy"].dtype == s["guide_id.npy"].dtype == np.uint8
    assert s["orientation.npy"].dtype == s["orientation_conf.npy"].dtype == np.float16
    assert s["hdr.npy"].dtype == np.float16 and s["hdr.npy"].shape == (32, 40, 3)
    import OpenEXR

    with tarfile.open(local_set / "shard-000001.tar") as tar, tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "x.exr").write_bytes(tar.extractfile("000000003.rgb_linear.exr").read())
        with OpenEXR.File(str(Path(tmp) / "x.exr")) as e:
            assert np.array_equal(e.channels()["RGB"].pixels, s["hdr.npy"])   # the same linear values
    hit = s["strand_id.npy"] != 255
    assert hit.any() and np.all(s["depth.npy"][hit] > 0) and np.all(s["depth.npy"][~hit] == 0)
    assert np.array_equal(s["guide_id.npy"][hit], s["strand_id.npy"][hit] // 2)   # strands_per_guide 2
    assert np.all(s["guide_id.npy"][~hit] == 255) and s["strand_id.npy"][hit].max() < 48
    d16 = s["depth16.png"]
    assert np.allclose(d16[hit] / s["camera.json"]["depth16_units_per_metre"], s["depth.npy"][hit], atol=1e-4)
    assert np.all(s["mask.png"][hit] > 0)
    cam = s["camera.json"]
    assert cam["params"]["index"] == 3 and np.array(cam["K"]).shape == (3, 3)
    assert len(cam["lights"]) == len(cam["params"]["lights"])
    assert set(s["strands.npz"]) == {"points", "counts"}


@pytest.mark.gpu
def test_verify_catches_a_truncated_shard(local_set, tmp_path):
    from mane.app.cli import main
    from mane.dataset.shards import verify

    bad = tmp_path / "bad"
    shutil.copytree(local_set, bad)
    p = bad / "shard-000001.tar"
    p.write_bytes(p.read_bytes()[:5000])
    rep = verify(bad)
    assert not rep["ok"] and any("shard-000001.tar" in x and "checksum" in x for x in rep["problems"])
    assert main(["dataset", "verify", str(bad)]) == 1
    assert main(["dataset", "verify", str(local_set)]) == 0


@pytest.mark.gpu
@pytest.mark.slow
def test_resume_after_a_killed_worker_gives_the_same_set(tiny, local_set, tmp_path, monkeypatch):
    from mane.dataset.local import run_local
    from mane.dataset.shards import verify

    out = tmp_path / "killed"
    monkeypatch.setenv("MANE_DATASET_EXIT_AFTER", "3")   # the worker dies rendering shard 1's 2nd sample
    r1 = run_local(tiny, out, workers=1, encoders=0, progress=False)
    assert not r1.ok and r1.done == [0] and 1 in r1.failed and "died" in r1.failed[1]
    assert list(out.glob(".shard-000001.tar.tmp-*"))                  # its partial shard, never renamed
    assert not (out / "shard-000001.tar").exists()
    assert not verify(out)["ok"]
    monkeypatch.delenv("MANE_DATASET_EXIT_AFTER")
    r2 = run_local(tiny, out, workers=1, encoders=1, progress=False)   # an encoder process: PNGs, grooms ahead
    assert r2.ok and sorted(r2.done) == [1, 2] and "unfinished" in r2.redo[1]
    assert r2.steady_rate() > 0 and r1.steady_rate() is None   # the rate after each worker's first shard
    assert not list(out.glob(".shard-*"))
    assert _shards(out) == _shards(local_set)
    r3 = run_local(tiny, out, workers=1, encoders=0, progress=False)   # nothing left to do
    assert r3.ok and r3.done == [] and r3.as_dict()["kept"] == 3
    other = tiny.__class__(**{**tiny.__dict__, "seed": 99})
    with pytest.raises(UsageError, match="another spec"):
        run_local(other, out, progress=False)


@pytest.mark.gpu
@pytest.mark.ray
@pytest.mark.slow
def test_ray_with_two_workers_gives_the_same_shards(tiny, local_set, tmp_path):
    pytest.importorskip("ray")
    from mane.dataset.ray_runner import run_ray

    report = run_ray(tiny, tmp_path / "ray", workers=2, progress=False)
    assert report.ok and report.workers == 2, report.lines()
    assert _shards(tmp_path / "ray") == _shards(local_set)


def test_views_per_groom_share_the_hairstyle_only(tiny):
    from mane.dataset.sampling import sample_params

    spec = tiny.__class__(**{**tiny.__dict__, "views_per_groom": 3})
    p = [sample_params(spec, i) for i in range(6)]
    style = lambda x: (x.groom, x.groom_seed, x.head, x.melanin)  # noqa: E731
    assert style(p[0]) == style(p[1]) == style(p[2]) and style(p[3]) == style(p[4]) == style(p[5])
    assert len({x.azimuth for x in p}) == 6     # the views differ
    assert len({style(sample_params(spec, 3 * i)) for i in range(30)}) > 5


@pytest.mark.gpu
def test_simulated_samples_move_the_hair_before_capture(gl, spec_dir):
    # 0.1 s of wind and a shaking head (no head mesh: no collider): the strands written differ
    # from the groom at rest, and their roots follow the head's transform
    from mane import load
    from mane.dataset import parse_spec
    from mane.dataset.sampling import sample_params
    from mane.dataset.worker import SampleRenderer

    spec = parse_spec({**TINY, "grooms": [{"file": "g2.npz"}],
                       "simulation": {"seconds": 0.1, "motions": ["shake"], "wind": 3.0, "fps": 20}}, spec_dir)
    sr = SampleRenderer(spec, ctx=gl)
    try:
        raw = sr.render(sample_params(spec, 0))
    finally:
        sr.release()
    rest = load(spec_dir / "g2.npz")
    E = np.array(raw["camera"]["world_to_camera"])
    M = np.array(raw["camera"]["head_transform"])
    pts = raw["strands"]["points"]
    world = (np.c_[pts, np.ones(len(pts))] @ np.linalg.inv(E).T)[:, :3]
    assert world.shape == rest.points.shape
    assert np.abs(world - rest.points).max() > 1e-3                 # the hair moved
    roots = rest.offsets[:-1]
    expect = (np.c_[rest.points[roots], np.ones(len(roots))] @ M.T)[:, :3]
    np.testing.assert_allclose(world[roots], expect, atol=1e-4)      # pinned roots ride the head


@pytest.mark.gpu
@pytest.mark.slow
def test_bench_dataset_reports_rate_and_stages(gl, monkeypatch):
    from mane.bench import dataset_bench

    monkeypatch.setitem(dataset_bench.MODES, "quick", {"size": (32, 32), "guides": 20, "strands_per_guide": 2,
                                                       "samples": 3, "stage_samples": 2, "workers": ()})
    result = dataset_bench.run(gl, "quick")
    r = result["results"][0]
    assert r["samples"] == 3 and r["samples_per_s"] > 0 and r["bytes_per_sample"] == sum(r["bytes_per_file"].values())
    for k in ("prepare", "issue", "readback", "camera_strands", "encode_arrays", "encode_png_one_core"):
        assert r["stage_ms_per_sample"][k] > 0 and r["stage_ms_per_sample"]["gpu_wait"] >= 0
    assert r["render_ahead_samples_per_s"] > 0 and r["render_alone_samples_per_s"] > 0
    for k in ("prepare", "issue", "gpu_wait", "readback", "encode_arrays", "submit", "wait_encoders",
              "write_overlapped", "encode_png"):
        assert k in r["pipeline_ms_per_sample"]
    assert r["encoder_ms_per_sample"] > 0 and r["writer_ms_per_sample"] > 0
    # the ceiling replays rendered samples: no rendering in it, the same encoding and writing
    assert r["ceiling_samples_per_s"] > 0 and r["ceiling_ms_per_sample"]["encode_png"] > 0
    assert "issue" not in r["ceiling_ms_per_sample"]
    assert result["meta"]["benchmark"] == "dataset"
    text = dataset_bench.format_text(result)
    assert "samples/s" in text and "ceiling" in text and "GPU wait" in text


@pytest.mark.gpu
def test_contact_sheet_has_a_row_per_sample(local_set, tmp_path):
    from PIL import Image

    from mane.app.cli import main

    assert main(["dataset", "sheet", str(local_set), "--out", str(tmp_path / "s.png"), "--count", "3"]) == 0
    sheet = np.asarray(Image.open(tmp_path / "s.png"))
    assert sheet.shape == (3 * 32 + 2 * 2, 4 * 40 + 3 * 2, 3)

    with tarfile.open(local_set / "shard-000000.tar") as tar:
        d = np.load(io.BytesIO(tar.extractfile("000000000.depth.npy").read()))
    assert np.array_equal(sheet[:32, 84:124].max(axis=-1) > 0, d > 0)   # depth panel: lit where hair
    assert np.array_equal(sheet[:32, :40], np.asarray(Image.open(io.BytesIO(
        tarfile.open(local_set / "shard-000000.tar").extractfile("000000000.rgb.png").read()))))


def test_example_specs_are_valid():

    from mane.dataset import load_spec
    from mane.dataset.spec import estimate_bytes

    ex = Path(__file__).resolve().parents[1] / "examples"
    tiny = load_spec(ex / "dataset_tiny.toml")
    assert tiny.samples <= 8 and max(tiny.size) <= 128
    big = load_spec(ex / "dataset_hairstyles.toml")
    assert big.samples >= 1000 and big.size == (512, 512) and big.views_per_groom > 1
    assert {g.style for g in big.grooms} >= {"straight", "wavy", "curly"}
    assert 1e9 < estimate_bytes(big)["total"] < 1e12
    sheet = load_spec(ex.parent / "docs" / "dataset_contact_sheet.toml")
    assert {"rgb", "mask", "depth", "orientation"} <= set(sheet.outputs)


def test_shard_bytes_are_webdataset_tarwriter_bytes(tmp_path):
    """ShardFile writes each sample in one call; the file is byte for byte what webdataset's
    TarWriter (the library the readers use) writes for the same samples."""
    import io

    from webdataset import TarWriter

    from mane.dataset.shards import ShardFile

    rng = np.random.default_rng(3)
    samples = [{"__key__": f"{i:06d}", "rgb.png": rng.bytes(int(n)), "camera.json": '{"a": 1}'.encode(),
                "depth.npy": rng.bytes(1000 + 7 * i), "_meta": b"skipped"} for i, n in enumerate([1, 511, 512, 20000])]
    mine = ShardFile(tmp_path, 0)
    for s in samples:
        mine.write(dict(s))
    sha, size = mine.close()
    ref = io.BytesIO()
    w = TarWriter(ref, encoder=False, mtime=0, user="mane", group="mane", mode=0o444)
    for s in samples:
        w.write(dict(s))
    w.close()
    data = (tmp_path / "shard-000000.tar").read_bytes()
    assert data == ref.getvalue()
    assert size == len(data) and sha == hashlib.sha256(data).hexdigest()


@pytest.mark.parametrize("count,dtype", [(1, np.uint8), (255, np.uint8), (256, np.uint16), (65535, np.uint16),
                                         (65536, np.uint32), (2 ** 32 - 1, np.uint32)])
def test_id_maps_take_the_smallest_dtype_with_its_maximum_free(count, dtype):
    # ids 0..count-1 and "no hair" (the dtype's maximum) must all be distinct
    from mane.dataset.id_maps import id_dtype, ids

    assert id_dtype(count) is dtype
    m = np.array([[0, count - 1, 0xFFFFFFFF]], np.uint32)
    got = ids(m, count)
    assert got.dtype == dtype and got.tolist() == [[0, count - 1, np.iinfo(dtype).max]]
    with pytest.raises(ValueError):
        id_dtype(2 ** 32)


def test_encoded_maps_are_the_rendered_values_in_their_dtypes():
    # orientation and confidence: float16, within half a float16 step of the float32 values
    # (half of float16's step: 2^-9 in [2, 4), 2^-11 in [0.5, 1)); the largest float32 below
    # pi stays below pi
    from mane.dataset.encode import encode_arrays

    rng = np.random.default_rng(0)
    angle = rng.uniform(0, np.pi, (32, 40)).astype(np.float32)
    angle[0, 0] = np.nextafter(np.float32(np.pi), np.float32(0))
    conf = rng.uniform(0, 1, (32, 40)).astype(np.float32)
    conf[0, 0] = 1.0
    strand = rng.integers(0, 300, (32, 40)).astype(np.uint32)
    strand[:4] = 0xFFFFFFFF
    raw = {"key": "000000007", "angle": angle, "confidence": conf, "strand": strand,
           "guide": np.where(strand == 0xFFFFFFFF, strand, strand // 3), "id_counts": (300, 100),
           "depth": rng.uniform(0.5, 1.0, (32, 40)).astype(np.float32)}
    files = encode_arrays(raw, ["depth", "orientation", "ids"])
    load = lambda name: np.load(io.BytesIO(bytes(files[name])))  # noqa: E731
    a, c = load("orientation.npy"), load("orientation_conf.npy")
    assert a.dtype == c.dtype == np.float16 and a.shape == (32, 40)
    assert np.abs(a.astype(np.float64) - angle).max() <= 2.0 ** -10 and a.max() < np.float64(np.pi)
    assert np.abs(c.astype(np.float64) - conf).max() <= 2.0 ** -12 and c.max() == 1.0
    s, g = load("strand_id.npy"), load("guide_id.npy")
    assert s.dtype == np.uint16 and g.dtype == np.uint8
    assert np.array_equal(s.astype(np.int64), np.where(strand == 0xFFFFFFFF, 0xFFFF, strand))
    assert np.array_equal(g.astype(np.int64), np.where(strand == 0xFFFFFFFF, 0xFF, strand // 3))
    assert np.array_equal(load("depth.npy"), raw["depth"])
    from mane.dataset.shards import _decode

    assert a[0, 0] == np.float16(3.140625)   # the largest float16 below pi: verify takes it
    for name in ("depth.npy", "orientation.npy", "orientation_conf.npy", "strand_id.npy", "guide_id.npy"):
        _decode(name, bytes(files[name]), name, (40, 32))


@pytest.mark.parametrize("name,array,words", [
    ("orientation.npy", np.zeros((32, 40), np.float32), "expected float16"),
    ("orientation.npy", np.full((32, 40), 3.1426, np.float16), "outside [0, pi)"),   # float16 above pi
    ("orientation_conf.npy", np.full((32, 40), 1.5, np.float16), "above 1"),
    ("strand_id.npy", np.zeros((32, 40), np.int32), "expected uint8 or uint16 or uint32"),
    ("depth.npy", np.zeros((40, 32), np.float32), "(32, 40)"),
    ("depth.npy", np.full((32, 40), np.nan, np.float32), "NaN"),
])
def test_verify_checks_each_maps_dtype_shape_and_range(name, array, words):
    from mane.dataset.encode import npy
    from mane.dataset.shards import _decode

    with pytest.raises(ValueError) as e:
        _decode(name, bytes(npy(array)), f"000000001.{name}", (40, 32))
    assert words in str(e.value) and "000000001" in str(e.value)
    good = {"orientation.npy": np.float16, "orientation_conf.npy": np.float16, "strand_id.npy": np.uint16,
            "depth.npy": np.float32}[name]
    _decode(name, bytes(npy(np.zeros((32, 40), good))), name, (40, 32))   # the right one passes


@pytest.mark.parametrize("n", [5, 16384, 16385, 50000])
def test_strands_to_camera_in_row_blocks_are_the_whole_product(n):
    from mane.dataset.worker import to_camera

    rng = np.random.default_rng(n)
    h = np.c_[rng.uniform(-0.3, 0.3, (n, 3)).astype(np.float32).astype(np.float64), np.ones(n)]
    cv = np.c_[rng.normal(size=(4, 3)), rng.normal(size=4)]
    assert np.array_equal(to_camera(h, cv), (h @ cv.T)[:, :3].astype(np.float32))


def test_plan_estimate_follows_the_map_dtypes(spec_dir):
    # 512x512: depth 4 B, orientation 2 x 2 B, ids 2 x 2 B (50k strands of 3125 guides) a pixel
    from mane.dataset import parse_spec
    from mane.dataset.spec import estimate_bytes

    spec = parse_spec({"size": [512, 512], "outputs": ["depth", "orientation", "ids"],
                       "grooms": [{"style": "wavy", "strands": 3125, "points": 16}],
                       "render": {"strands_per_guide": 16}}, spec_dir)
    per = estimate_bytes(spec)["per_output"]
    assert per == {"depth": 4 * 512 * 512, "orientation": 4 * 512 * 512, "ids": 4 * 512 * 512}
    more = parse_spec({"size": [512, 512], "outputs": ["ids"], "grooms": [{"style": "wavy", "strands": 3125}],
                       "render": {"strands_per_guide": 32}}, spec_dir)
    assert estimate_bytes(more)["per_output"]["ids"] == (4 + 2) * 512 * 512   # 100k strands: uint32


def test_shard_writes_survive_short_writev(tmp_path, monkeypatch):
    # writev may write fewer bytes than asked (a pipe, a signal, a full disk's last blocks): the
    # shard is still every byte once, in order (the same file as with whole writes)
    import os

    from mane.dataset.shards import ShardFile

    rng = np.random.default_rng(5)
    samples = [{"__key__": f"{i:06d}", "a.npy": rng.bytes(3000 + 977 * i), "b.json": b"{}"} for i in range(3)]
    (tmp_path / "whole").mkdir()
    whole = ShardFile(tmp_path / "whole", 0)
    for s in samples:
        whole.write(dict(s))
    whole.close()
    real = os.writev
    calls = []

    def short(fd, buffers):   # at most 1000 bytes a call, cutting buffers mid-way
        calls.append(1)
        return real(fd, [bytes(b"".join(bytes(b) for b in buffers)[:1000])])

    monkeypatch.setattr(os, "writev", short)
    (tmp_path / "short").mkdir()
    part = ShardFile(tmp_path / "short", 0)
    for s in samples:
        part.write(dict(s))
    sha, size = part.close()
    data = (tmp_path / "short" / "shard-000000.tar").read_bytes()
    assert len(calls) > 10 and data == (tmp_path / "whole" / "shard-000000.tar").read_bytes()
    assert size == len(data) and sha == hashlib.sha256(data).hexdigest()
