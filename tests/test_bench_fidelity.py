"""mane bench fidelity: its metrics against hand-computed values, and a tiny run end to end."""
from __future__ import annotations

import json

import numpy as np
import pytest

from mane.bench import fidelity_metrics as fm


def _img(rgb_rows):
    return np.asarray(rgb_rows, np.float64)


# two pixels side by side; mask picks both or the first
REF = _img([[[1.0, 0.5, 0.0], [0.0, 0.0, 1.0]]])          # (1, 2, 3)
TEST = _img([[[2.0, 0.5, 0.0], [0.0, 0.5, 1.0]]])


def test_mae_p95_and_relative_mae_by_hand():
    # |diff| = [1, 0, 0, 0, 0.5, 0] -> mean 1.5 / 6 = 0.25
    assert fm.mae(TEST, REF) == pytest.approx(0.25)
    # numpy's linear percentile of [0,0,0,0,0.5,1] at 95%: 0.5 + 0.75 * 0.5 = 0.875
    assert fm.p95(TEST, REF) == pytest.approx(0.875)
    # reference luminances 0.2126 + 0.3576 = 0.5702 and 0.0722: mean 0.3212
    assert fm.relative_mae(TEST, REF) == pytest.approx(0.25 / 0.3212)
    mask = np.array([[True, False]])
    assert fm.mae(TEST, REF, mask) == pytest.approx(1.0 / 3.0)
    assert fm.relative_mae(TEST, REF, mask) == pytest.approx((1.0 / 3.0) / 0.5702)


def test_luminance_ratio_and_rgb_balance_by_hand():
    # test luminances 0.4252 + 0.3576 = 0.7828 and 0.3576 + 0.0722 = 0.4298: mean 0.6063
    assert fm.luminance_ratio(TEST, REF) == pytest.approx(0.6063 / 0.3212)
    # ref sums (1, 0.5, 1) / 2.5 = (0.4, 0.2, 0.4); test (2, 1, 1) / 4 = (0.5, 0.25, 0.25)
    np.testing.assert_allclose(fm.rgb_share(REF), [0.4, 0.2, 0.4])
    np.testing.assert_allclose(fm.rgb_balance(TEST, REF), [0.1, 0.05, -0.15])
    assert fm.rgb_balance(TEST, REF).sum() == pytest.approx(0.0)


def test_falloff_splits_the_masks_screen_box_at_its_middle_row():
    img = np.zeros((6, 3, 3))
    img[1:3] = 4.0          # rows 1, 2: the upper half of the box rows 1..4
    img[3:5] = 1.0          # rows 3, 4: the lower half
    mask = np.zeros((6, 3), bool)
    mask[1:5, 1] = True
    assert fm.falloff(img, mask) == pytest.approx(4.0)
    flat = np.ones((6, 3, 3))
    assert fm.falloff_ratio(img, flat, mask) == pytest.approx(4.0)
    # an odd height gives the middle row to the upper half: rows 1..3 -> upper rows 1, 2
    mask[4] = False
    img2 = np.zeros((6, 3, 3))
    img2[1:3] = 2.0
    img2[3] = 1.0
    assert fm.falloff(img2, mask) == pytest.approx(2.0)
    assert np.isnan(fm.falloff(img, np.zeros((6, 3), bool)))


def test_box_means_and_the_block_relative_mae_by_hand():
    img = np.arange(16, dtype=float).reshape(4, 4)
    np.testing.assert_allclose(fm.box(img, 2), [[2.5, 4.5], [10.5, 12.5]])
    # noise that cancels inside each 2 x 2 block: per pixel an error, per block none
    ref = np.full((4, 4, 3), 0.5)
    test = ref + np.array([[0.1, -0.1, 0.1, -0.1], [-0.1, 0.1, -0.1, 0.1]] * 2)[..., None]
    mask = np.ones((4, 4), bool)
    assert fm.relative_mae(test, ref, mask) == pytest.approx(0.1 / 0.5)
    assert fm.relative_mae_box(test, ref, mask, 2) == pytest.approx(0.0)
    mask[:] = False
    mask[0, 3] = mask[3, 0] = True    # one pixel in two blocks: no block is half mask
    assert np.isnan(fm.relative_mae_box(test, ref, mask, 2))


def test_flip_is_zero_for_equal_images_and_grows_with_the_error():
    pytest.importorskip("flip_evaluator")
    rng = np.random.default_rng(0)
    ref = rng.uniform(0.0, 1.0, (32, 32, 3)).astype(np.float32)
    same, emap = fm.flip(ref, ref)
    assert same == pytest.approx(0.0, abs=1e-6) and emap.shape == (32, 32)
    small = fm.flip(ref * 1.1, ref)[0]
    large = fm.flip(ref * 3.0, ref)[0]
    assert 0.0 < small < large <= 1.0


def _tiny_scene():
    """A few curly strands hanging in front of a box "head" (12 triangles): the bench's paths
    (head in both renderers, hair coverage with the head hiding hair) in seconds."""
    from mane.groom import Groom
    from mane.mesh import Mesh

    t = np.linspace(0, 1, 12)
    strands = []
    for i, x in enumerate(np.linspace(-0.04, 0.04, 9)):
        a = 12 * t + i
        strands.append(np.stack([x + 0.006 * np.cos(a), 0.06 - 0.12 * t, 0.03 + 0.006 * np.sin(a)], axis=1))
    groom = Groom(points=np.concatenate(strands).astype(np.float32), counts=np.full(9, 12, np.int32))
    v = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (-0.08, 0.08) for z in (-0.05, 0.0)], np.float32)
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],
                  [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]], np.int32)
    return groom, Mesh(vertices=v, faces=f)


def test_bench_fidelity_tiny_run_writes_numbers_pictures_and_cache(gl, tmp_path, monkeypatch):
    pytest.importorskip("mitsuba")
    pytest.importorskip("flip_evaluator")
    from mane.bench import fidelity

    monkeypatch.setattr(fidelity, "load_scene", lambda scene, guides=0: _tiny_scene())
    kw = dict(image_dir=tmp_path / "img", cache_dir=tmp_path / "cache", size=(32, 32), spp=4)
    res = fidelity.run(gl, "quick", **kw)
    (row,) = res["results"]
    assert (row["scene"], row["model"], row["shadows"]) == ("curly_head", "marschner", "deep_opacity")
    hair = row["hair"]
    for key in ("mae", "p95", "relative_mae", "luminance_ratio", "flip", "falloff", "falloff_ref"):
        assert np.isfinite(hair[key]), key
    assert len(hair["rgb_balance"]) == 3 and abs(sum(hair["rgb_balance"])) < 1e-9
    assert res["scenes"]["curly_head"]["hair_pixels"] > 0
    pic = tmp_path / "img" / "curly_head_marschner_deep_opacity.png"
    from PIL import Image

    assert Image.open(pic).size == (96, 32)                   # reference | mane | error
    cached = sorted(p.name for p in (tmp_path / "cache").glob("*.npy"))
    assert len(cached) == 2                                   # the radiance and the hair coverage
    assert f"{res['scenes']['curly_head']['reference_key']}.npy" in cached   # what a rerun loads
    json.dumps(res, default=float)
    text = fidelity.format_text(res)
    assert "curly_head" in text and "marschner" in text
    md = fidelity.format_markdown(res).splitlines()
    assert len(md) == 3 and md[2].startswith("| curly_head | marschner | deep_opacity |")


def test_cli_bench_fidelity_rejects_an_unknown_scene(gl, capsys):
    pytest.importorskip("mitsuba")
    from mane.app.cli import main

    assert main(["bench", "fidelity", "--quick", "--scenes", "nowhere"]) == 2
    assert "unknown fidelity scene" in capsys.readouterr().err


def test_bench_fidelity_skips_sintel_without_the_shared_data(gl, monkeypatch):
    pytest.importorskip("mitsuba")
    from mane.bench import fidelity

    monkeypatch.setattr(fidelity, "data_dir", lambda: None)
    res = fidelity.run(gl, "quick", scenes=["sintel_brown"], size=(16, 16), spp=1)
    assert res["results"] == [] and "not found" in res["scenes"]["sintel_brown"]["skipped"]


def test_bench_scene_shades_with_the_tangents_of_the_curves_the_reference_draws(gl):
    """The path tracer's hair BSDF takes its fibre direction from the curve it intersects
    (Mitsuba's bsplinecurve through the expanded points: at knot j the derivative is
    (C[j+1] - C[j-1]) / 2 of the interpolating control points, NumPy here); the real-time side
    shades with the expand pass's tangents. The bench's scene must give both the same fibre
    direction: ``strand_spread``'s per-strand tilt (5 degrees RMS by default) is a tangent the
    reference cannot draw, and it alone was 0.06 of Sintel brown's 0.53 per-pixel relative MAE."""
    from mane.bench import fidelity
    from mane.reference.scene import bspline_control_points, expanded_strands

    groom, head = _tiny_scene()
    settings = fidelity.base_settings(fidelity.SCENES["curly_head"], (32, 32))
    strands = expanded_strands(groom, settings, head=head, ctx=gl)
    ctrl, _ = bspline_control_points(strands.points)
    curve = ctrl[:, 2:] - ctrl[:, :-2]
    curve /= np.linalg.norm(curve, axis=-1, keepdims=True)
    shaded = strands.tangents / np.linalg.norm(strands.tangents, axis=-1, keepdims=True)
    angle = np.degrees(np.arccos(np.clip((curve * shaded).sum(-1), -1.0, 1.0)))
    # the chords of the 12-point test strands alone leave ~2 degrees RMS; a 5-degree RMS tilt
    # on top gives ~5
    assert np.sqrt(np.mean(angle ** 2)) < 3.0


def test_decompose_shift_moves_right_and_down_and_best_shift_finds_the_offset():
    from mane.bench import fidelity_decompose as fd

    img = np.zeros((24, 24, 3))
    img[10, 8] = 1.0
    moved = fd.shifted(img, 1.0, 2.0)                  # one column right, two rows down
    assert np.unravel_index(np.argmax(moved[..., 0]), moved.shape[:2]) == (12, 9)
    # a smooth picture and its copy half a pixel to the left: the shift that undoes it is +0.5 in x
    y, x = np.mgrid[0:32, 0:32].astype(float)
    ref = np.repeat(np.exp(-((x - 15.3) ** 2 + (y - 16.0) ** 2) / 18.0)[..., None], 3, axis=2)
    test = np.repeat(np.exp(-((x - 14.8) ** 2 + (y - 16.0) ** 2) / 18.0)[..., None], 3, axis=2)
    res = fd.best_shift(test, ref, np.ones((32, 32), bool))
    assert res["best"] == [0.5, 0.0]
    assert res["best_relative_mae"] < 0.1 * res["unshifted_relative_mae"]


def test_decompose_blur_keeps_the_mean_and_numbers_sum_the_coverage():
    from mane.bench import fidelity_decompose as fd

    rng = np.random.default_rng(0)
    img = rng.random((40, 40, 3))
    b = fd.blur(img, 1.0)
    assert abs(b.mean() - img.mean()) < 2e-3 and b.std() < 0.5 * img.std()   # white noise: std / (2 sqrt(pi))
    ref = np.full((4, 4, 3), 0.5)
    cov = np.full((4, 4), 0.8)
    alpha = np.full((4, 4), 0.6)
    n = fd.numbers(ref * 1.2, alpha, ref, cov, cov > 0.5)
    assert n["luminance_ratio"] == pytest.approx(1.2)
    assert n["relative_mae"] == pytest.approx(0.1 / 0.5)              # |0.6 - 0.5| over luminance 0.5
    assert n["coverage_ratio"] == pytest.approx(0.75)


def test_decompose_scattering_split_by_hand():
    """scattering_split: mane's picture and its single-scattering part against the path tracer's
    full picture and its single scattering (max_depth 2), built so that every figure is known:
    mane's single scattering is the reference's exactly, its multiple scattering half the
    reference's in the lit half and twice it in the dark half."""
    from mane.bench import fidelity_decompose as fd

    ref_single = np.zeros((4, 4, 3))
    ref_single[:2] = 1.0          # lit rows
    ref_single[2:] = 0.1          # dark rows
    ref_multi = np.full((4, 4, 3), 0.2)
    ref = ref_single + ref_multi
    multi = np.where(np.arange(4)[:, None, None] < 2, 0.1, 0.4) * np.ones((4, 4, 3))
    single = ref_single.copy()
    full = single + multi
    mask = np.ones((4, 4), bool)
    s = fd.scattering_split(full, single, ref, ref_single, mask)
    assert s["single"]["luminance_ratio"] == pytest.approx(1.0)
    assert s["single"]["relative_mae"] == pytest.approx(0.0)
    assert s["reference_multiple_share"] == pytest.approx(16 * 0.2 / (8 * 1.2 + 8 * 0.3))
    assert s["multiple"]["luminance_ratio"] == pytest.approx((0.1 * 8 + 0.4 * 8) / (0.2 * 16))
    lo, hi = s["multiple_by_reference_quartile"][0], s["multiple_by_reference_quartile"][-1]
    assert lo == pytest.approx(2.0) and hi == pytest.approx(0.5)    # dark pixels twice, lit half
    # the reference's single scattering with mane's multiple scattering is mane's picture
    assert s["reference_single_with_mane_multiple"] == pytest.approx(fd.fm.relative_mae(full, ref, mask))
    assert s["mane_single_with_reference_multiple"] == pytest.approx(0.0)
    # mane's single scattering 1.5x everywhere, its multiple scattering the reference's
    s = fd.scattering_split(1.5 * ref_single + ref_multi, 1.5 * ref_single, ref, ref_single, mask)
    assert s["single"]["luminance_ratio"] == pytest.approx(1.5)
    assert s["multiple"]["luminance_ratio"] == pytest.approx(1.0)
    assert s["single_by_reference_quartile"] == pytest.approx([1.5] * len(s["single_by_reference_quartile"]))
    assert s["reference_single_with_mane_multiple"] == pytest.approx(0.0)


def test_bench_fidelity_decompose_tiny_run(gl, tmp_path, monkeypatch):
    pytest.importorskip("mitsuba")
    from mane.bench import fidelity, fidelity_decompose

    monkeypatch.setattr(fidelity, "load_scene", lambda scene, guides=0: _tiny_scene())
    monkeypatch.setenv("MANE_GPU_MEMORY", "256M")    # a variant's maps that this budget cannot hold
    variants = {"default": {}, "too big": {"shadow_map_size": 8192}, "msaa 16 (4 x 4 grid)": {"msaa": 16}}
    res = fidelity_decompose.run(gl, "quick", size=(32, 32), spp=4, variants=variants, cache_dir=tmp_path / "cache",
                                 split=True)
    assert [r["variant"] for r in res["results"]] == list(variants)
    big = res["results"][1]
    assert "skipped" in big and "\n" not in big["skipped"] and "relative_mae" not in big   # the rest still ran
    for row in res["results"][::2]:
        for key in ("relative_mae", "relative_mae_box4", "luminance_ratio", "falloff_ratio", "coverage_ratio"):
            assert np.isfinite(row[key]), key
    p = res["probes"]["curly_head"]
    assert set(p["blur"]) == {"0.5", "1.0", "2.0"} and len(p["shift"]["best"]) == 2
    assert "reference_noise" not in p                          # no seed-1 reference in an empty cache
    q = p["scattering_split"]                                  # split: a max_depth 2 reference and mane without MS
    assert 0.0 < q["reference_multiple_share"] < 1.0 and q["single"]["luminance_ratio"] > 0.0
    assert np.isfinite(q["reference_single_with_mane_multiple"]) and len(q["multiple_by_reference_quartile"]) == 4
    assert res["meta"]["settings"]["split"] is True
    text = fidelity_decompose.format_text(res)
    assert "default" in text and "single scattering against max_depth 2" in text


def test_cli_bench_fidelity_decompose_rejects_an_unknown_scene(gl, capsys):
    pytest.importorskip("mitsuba")
    from mane.app.cli import main

    assert main(["bench", "fidelity", "--quick", "--decompose", "--scenes", "nowhere"]) == 2
    assert "unknown fidelity scene" in capsys.readouterr().err
    assert main(["bench", "fidelity", "--quick", "--split"]) == 2          # --split belongs to --decompose
    assert "--split is for mane bench fidelity --decompose" in capsys.readouterr().err


def test_decompose_reference_noise_from_its_passes_by_hand():
    """pass_halves: the mean of the first half of a reference's cached passes against the
    second half's (relative MAE, the second half as reference), half of it the whole
    reference's noise; None with a pass missing or a single pass."""
    from types import SimpleNamespace

    from mane.bench import fidelity_decompose as fd
    from mane.reference.passes import pass_seed

    a, b = np.full((2, 2, 3), 1.0), np.full((2, 2, 3), 1.2)
    store = {f"64-{pass_seed(0, k)}": img for k, img in enumerate((a, a, b, b))}
    reference = SimpleNamespace(cache_key=lambda spp, seed, **kw: f"{spp}-{seed}", default_pass_spp=lambda: 64)
    cache = SimpleNamespace(load=lambda folder, key: store.get(key))
    mask = np.ones((2, 2), bool)
    h = fd.pass_halves(reference, cache, None, {"spp": 256}, 0, mask)
    assert h["passes"] == 4
    assert h["halves_relative_mae"] == pytest.approx(0.2 / 1.2)        # |1.0 - 1.2| over luminance 1.2
    assert h["reference_noise_estimate"] == pytest.approx(0.1 / 1.2)
    assert fd.pass_halves(reference, cache, None, {"spp": 64}, 0, mask) is None      # one pass
    # the passes are the variant's (512 samples each for the GPU's): 1024 spp is two of them
    gpu = SimpleNamespace(cache_key=reference.cache_key, default_pass_spp=lambda: 512)
    store.update({f"512-{pass_seed(0, k)}": img for k, img in enumerate((a, b))})
    assert fd.pass_halves(gpu, cache, None, {"spp": 1024}, 0, mask)["passes"] == 2
    del store[f"64-{pass_seed(0, 3)}"]
    assert fd.pass_halves(reference, cache, None, {"spp": 256}, 0, mask) is None     # a pass not cached


def test_bench_scene_draws_the_scalp_as_the_skin_the_reference_draws():
    """The reference's head is a Lambertian of skin_color everywhere; the renderer tints the
    head's scalp toward the hair (``scalp_tint``, 0.8 by default). The bench's scene must draw the
    scalp the reference draws: the tint alone was 0.16 of the curly head's 0.30 luminance deficit."""
    from mane.bench import fidelity
    from mane.render.passes.head_pass import scalp_albedo

    settings = fidelity.base_settings(fidelity.SCENES["curly_head"], (32, 32))
    hair = (0.1, 0.05, 0.02)
    assert scalp_albedo(settings.skin_color, hair, settings.scalp_tint) == pytest.approx(settings.skin_color)
