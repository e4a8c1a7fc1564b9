"""Units and up axes of real-world grooms and heads (mane.io.units), from synthetic files
written byte by byte after each format's spec (test_io_helpers) in each convention.

The reference scene, in metres and Y up: a head, a sphere of radius 0.1 m at the origin; 300
roots on its top and back; strands 0.3 m long that leave the scalp along its normal for 2 cm
and then hang straight down. Every test stores it in some unit and orientation and checks that
mane.load / mane.load_mesh give it back in metres, Y up, with no flags and with flags."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import trimesh

import mane
from mane.groom import up_axis_matrix
from mane.io import units
from mane.io.units import check_fit, up_signals
from test_io_helpers import cyhair_bytes, tfx4_bytes, usc_bytes

R = 0.1
N_POINTS = 16


def reference_scene(n=300, seed=0):
    """(points (S*N, 3), counts, colours, widths, head trimesh), metres, Y up."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(4 * n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d = d[(d[:, 1] > 0.2) | ((d[:, 2] < -0.3) & (d[:, 1] > -0.3))][:n]
    strands = []
    for normal in d:
        root = normal * R * 1.002
        t = np.linspace(0.0, 1.0, N_POINTS)[:, None]
        out = root + normal * 0.02 * np.minimum(t * 15, 1.0)          # 2 cm along the normal
        hang = np.clip(t * 15 - 1.0, 0, None) / 14.0 * 0.28           # then 28 cm down
        strands.append(out - hang * np.array([0.0, 1.0, 0.0]))
    pts = np.concatenate(strands).astype(np.float32)
    counts = np.full(len(d), N_POINTS)
    colors = np.tile(np.linspace([0.9, 0.8, 0.5], [0.6, 0.5, 0.3], N_POINTS), (len(d), 1)).astype(np.float32)
    widths = np.tile(np.linspace(8e-5, 3e-5, N_POINTS), len(d)).astype(np.float32)
    head = trimesh.creation.icosphere(subdivisions=3, radius=R)
    return pts, counts, colors, widths, head


def store(points, unit_scale, up):
    """Metres Y-up -> the file's numbers: divided by its metres per unit, Y turned to ``up``."""
    m = up_axis_matrix("y", up)[:3, :3]
    return (np.asarray(points, np.float64) @ m.T / unit_scale).astype(np.float32)


def assert_upright_metres(g, tol=1e-4):
    pts, counts, *_ = reference_scene()
    np.testing.assert_array_equal(g.counts, counts)
    np.testing.assert_allclose(g.points, pts, atol=tol)
    assert g.metadata["units"] == "m" and g.metadata["up_axis"] == "y"


def head_file(tmp_path, name, unit_scale, up):
    *_, head = reference_scene()
    mesh = head.copy()
    mesh.vertices = store(head.vertices, unit_scale, up)
    path = tmp_path / name
    mesh.export(path)
    return path


def fits(g, mesh):
    fit = check_fit(g, mesh)
    assert fit["inside_fraction"] < 0.05 and fit["far_fraction"] == 0.0, fit
    return fit


# ------------------------------------------------------------------------------ the guesses
def test_up_signals_read_the_reference_scene():
    pts, counts, *_ = reference_scene()
    g = mane.Groom(pts, counts)
    s = up_signals(g.roots, g.tips, g.strand_lengths())
    assert s["cap"][0][1] > 0.9 and s["cap"][1] > 0.25      # roots cap +Y
    assert s["hang"][0][1] > 0.9                               # strands hang down Y
    for axis in "xz":
        rot = mane.Groom(store(pts, 1.0, axis), counts)
        assert units.guess_up(rot.roots, rot.tips, rot.strand_lengths(), None)[0] == axis


@pytest.mark.parametrize("scale,unit", [(1.0, "m"), (0.01, "cm"), (0.001, "mm")])
def test_units_guessed_from_sizes(scale, unit):
    pts, counts, *_ = reference_scene()
    g = mane.Groom(pts / scale, counts)
    frame = units.groom_frame(g)
    assert frame["file_units"] == unit and frame["scale"] == scale


# ------------------------------------------------------------------------------ conventions
def test_cyhair_z_up_cm_with_its_head(tmp_path):
    """A cyHair-style groom: Z-up, centimetres, and its PLY head in the same frame."""
    pts, counts, colors, widths, _ = reference_scene()
    f = tmp_path / "hair.hair"
    f.write_bytes(cyhair_bytes(store(pts, 0.01, "z"), counts, colors=colors, thickness=widths / 0.01))
    head = head_file(tmp_path, "head.ply", 0.01, "z")
    with pytest.warns(units.UnitsWarning, match="guessed units cm"):
        g = mane.load(f)
    assert_upright_metres(g)
    frame = g.metadata["frame"]
    assert frame["file_up"] == "z" and frame["up_source"] == "convention"
    assert frame["file_units"] == "cm" and "units" in frame["guessed"]
    np.testing.assert_allclose(g.widths, widths, rtol=1e-5)        # thickness scaled to metres
    np.testing.assert_array_equal(g.colors, colors)
    m = mane.load_mesh(head, like=g)                                # same transform as the groom
    assert m.metadata["frame"]["units_source"] == "groom"
    np.testing.assert_allclose(m.vertices, reference_scene()[4].vertices, atol=1e-5)
    fits(g, m)
    # explicit flags give the same, with no guess and no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        g2 = mane.load(f, units="cm", up="z")
        m2 = mane.load_mesh(head, units="cm", up="z")
    assert_upright_metres(g2)
    np.testing.assert_allclose(m2.vertices, m.vertices, atol=1e-6)
    g3 = mane.load(f, scale=0.01, up="z")
    np.testing.assert_allclose(g3.points, g2.points, atol=1e-7)


def test_y_up_hair_file_is_not_turned(tmp_path):
    """A .hair file that is in fact Y-up (converted from USC data): the geometry says so."""
    pts, counts, *_ = reference_scene()
    f = tmp_path / "yup.hair"
    f.write_bytes(cyhair_bytes(store(pts, 1.0, "y"), counts))
    with pytest.warns(units.UnitsWarning, match="up y-up"):
        g = mane.load(f)
    assert_upright_metres(g)
    assert mane.load(f, up="y", units="m").metadata["frame"]["guessed"] == []


def test_x_up_ct2hair_bin(tmp_path):
    """CT2Hair .bin (USC framing, 7 floats per point), X-up metres: loaded by suffix."""
    pts, counts, *_ = reference_scene()
    raw = store(pts, 1.0, "x")
    body = [np.concatenate([raw[i * N_POINTS:(i + 1) * N_POINTS], np.zeros((N_POINTS, 4), np.float32)], axis=1)
            for i in range(len(counts))]
    out = np.array([len(body)], "<i4").tobytes()
    for b in body:
        out += np.array([len(b)], "<i4").tobytes() + b.astype("<f4").tobytes()
    f = tmp_path / "scan.bin"
    f.write_bytes(out)
    g = mane.load(f)
    assert_upright_metres(g)
    assert g.metadata["frame"]["file_up"] == "x" and g.metadata["frame"]["up_source"] == "convention"


def test_x_up_ply_is_guessed_and_flags_agree(tmp_path):
    pts, counts, *_ = reference_scene()
    g0 = mane.Groom(store(pts, 1.0, "x"), counts)
    f = tmp_path / "x.ply"
    from mane.io import strand_ply

    strand_ply.write(g0, f)   # mane's own comments would declare Y: write a plain file
    text = f.read_bytes().replace(b"comment mane units m\n", b"").replace(b"comment mane up y\n", b"")
    f.write_bytes(text)
    with pytest.warns(units.UnitsWarning, match="up x-up"):
        g = mane.load(f)
    assert_upright_metres(g)
    assert_upright_metres(mane.load(f, up="x", units="m"))


def test_y_up_metres_usc(tmp_path):
    pts, counts, *_ = reference_scene()
    f = tmp_path / "a.data"
    f.write_bytes(usc_bytes([pts[i * N_POINTS:(i + 1) * N_POINTS] for i in range(len(counts))]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # metres and the format's Y: nothing guessed
        g = mane.load(f)
    assert_upright_metres(g, tol=0)
    assert g.metadata["frame"]["up_source"] == "convention"


def test_tressfx_cm(tmp_path):
    pts, counts, colors, *_ = reference_scene()
    S = len(counts)
    pos4 = np.concatenate([store(pts, 0.01, "y"), np.ones((len(pts), 1), np.float32)], axis=1)
    rgba = np.concatenate([colors, np.ones((len(pts), 1), np.float32)], axis=1)
    f = tmp_path / "a.tfx"
    f.write_bytes(tfx4_bytes(pos4, S, N_POINTS, vertex_color=rgba))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        g = mane.load(f)
    assert_upright_metres(g)
    assert g.metadata["frame"] == {**g.metadata["frame"], "file_units": "cm", "units_source": "convention",
                                   "file_up": "y", "up_source": "convention"}
    np.testing.assert_array_equal(g.colors, colors)


def test_mesh_in_other_units_than_its_groom(tmp_path):
    """Groom in cm Z-up (.hair), head in mm Y-up (.obj): each normalised on its own, they fit."""
    pts, counts, *_ = reference_scene()
    f = tmp_path / "g.hair"
    f.write_bytes(cyhair_bytes(store(pts, 0.01, "z"), counts))
    head = head_file(tmp_path, "head.obj", 0.001, "y")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", units.UnitsWarning)
        g = mane.load(f)
        m = mane.load_mesh(head, like=g)
    assert m.metadata["frame"]["file_units"] == "mm" and m.metadata["frame"]["units_source"] == "guessed"
    fits(g, m)
    m2 = mane.load_mesh(head, units="mm", up="y", like=g)
    np.testing.assert_allclose(m2.vertices, m.vertices)


def test_fit_check_finds_roots_inside_and_far():
    pts, counts, _, _, head = reference_scene()
    mesh = mane.mesh.Mesh(head.vertices, head.faces)
    inner = mane.Groom(pts * 0.8, counts)           # every root 2 cm inside the head
    assert check_fit(inner, mesh)["inside_fraction"] > 0.95
    assert "inside the head" in check_fit(inner, mesh)["warnings"][0]
    far = mane.Groom(pts + np.float32([0, 0.5, 0]), counts)
    assert check_fit(far, mesh)["far_fraction"] == 1.0


def test_implausible_units_reported():
    pts, counts, *_ = reference_scene()
    assert units.plausibility(mane.Groom(pts, counts)) == []
    assert "implausible" in units.plausibility(mane.Groom(pts * 100, counts))[0]


def test_options_are_checked(tmp_path):
    pts, counts, *_ = reference_scene()
    f = tmp_path / "a.npz"
    mane.save(mane.Groom(pts, counts), f)
    for kw in ({"units": "inch"}, {"up": "w"}, {"scale": -1}, {"scale": 0.01, "units": "cm"}):
        with pytest.raises(mane.UsageError):
            mane.load(f, **kw)


# ------------------------------------------------------------------------------ round trips
WRITABLE = [".hair", ".data", ".tfx", ".ply", ".npz", ".usda", ".abc"]
CARRIES = {".hair": {"colors", "widths"}, ".data": set(), ".tfx": {"colors"},  # what each holds
           ".ply": {"colors", "widths"}, ".npz": {"colors", "widths"},
           ".usda": {"colors", "widths"}, ".abc": {"colors", "widths"}}


@pytest.mark.parametrize("suffix", WRITABLE)
def test_conversion_round_trip(tmp_path, suffix):
    """cm Z-up .hair -> SUFFIX -> back: the same metres, Y up, colours and widths."""
    pts, counts, colors, widths, _ = reference_scene(n=60)
    src = tmp_path / "src.hair"
    src.write_bytes(cyhair_bytes(store(pts, 0.01, "z"), counts, colors=colors, thickness=widths / 0.01))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", units.UnitsWarning)
        g = mane.load(src)
    out = tmp_path / f"out{suffix}"
    mane.save(g, out)
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # mane's writers declare metres: nothing is guessed
        back = mane.load(out)
    np.testing.assert_array_equal(back.counts, counts)
    np.testing.assert_allclose(back.points, g.points, atol=1e-6)
    for name in CARRIES[suffix]:
        np.testing.assert_allclose(getattr(back, name), getattr(g, name), rtol=1e-6, err_msg=name)
    frame = back.metadata["frame"]
    assert frame["scale"] == 1.0 and frame["file_up"] in "yz" and frame["guessed"] == []
    if suffix not in (".data",):   # USC-HairSalon has no room for a declaration (Y-up by convention)
        assert frame["units_source"] == "declared"


@pytest.mark.parametrize("counts", [[21, 7, 13], [5, 5, 5], [40, 50, 60]])
def test_tfx_export_resamples_to_a_power_of_two(tmp_path, counts):
    rng = np.random.default_rng(3)
    strands = [np.cumsum(rng.normal(scale=0.01, size=(c, 3)), axis=0) + [0, 0.2, 0] for c in counts]
    g = mane.Groom.from_strands(strands)
    f = tmp_path / "a.tfx"
    mane.save(g, f)
    back = mane.load(f, units="m", up="y")
    n = back.uniform_count
    from mane.io import tressfx

    want = tressfx.nearest_tfx_points(float(np.median(counts)))
    assert n == want and n in (4, 8, 16, 32, 64)
    np.testing.assert_allclose(back.roots, g.roots, atol=1e-7)      # roots and tips kept exactly
    np.testing.assert_allclose(back.tips, g.tips, atol=1e-7)
    tressfx.write(g, f, points=4)
    assert mane.load(f).uniform_count == 4
    with pytest.raises(mane.UsageError):
        tressfx.write(g, f, points=12)


def test_info_reports_the_guesses(tmp_path, capsys):
    from mane.app import cli

    pts, counts, *_ = reference_scene()
    f = tmp_path / "hair.hair"
    f.write_bytes(cyhair_bytes(store(pts, 0.01, "z"), counts))
    head = head_file(tmp_path, "head.ply", 0.01, "z")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", units.UnitsWarning)
        assert cli.main(["info", str(f), "--head", str(head), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["frame"]["file_units"] == "cm" and info["frame"]["units_source"] == "guessed"
    assert info["frame"]["file_up"] == "z" and info["frame"]["up_source"] == "convention"
    assert info["head"]["frame"]["units_source"] == "groom"
    assert info["checks"]["fit"]["inside_fraction"] < 0.05 and info["checks"]["warnings"] == []
    assert cli.main(["info", str(f), "--units", "cm", "--up", "z"]) == 0
    text = capsys.readouterr().out
    assert "cm (option)" in text and "z-up (option)" in text


def test_cyhair_groom_on_its_head_simulates_without_penetration(tmp_path, capsys):
    """The issue's case end to end: a Z-up centimetre .hair on its own PLY head, no flags:
    `mane simulate` sees the roots on the head (no fit warning) and no deep penetration."""
    from mane.app.cli import main

    pts, counts, *_ = reference_scene(n=60)
    f = tmp_path / "hair.hair"
    f.write_bytes(cyhair_bytes(store(pts, 0.01, "z"), counts))
    head = head_file(tmp_path, "head.ply", 0.01, "z")
    stats = tmp_path / "s.json"
    assert main(["simulate", str(f), "--head", str(head), "--seconds", "0.1", "--fps", "10",
                 "--points", "8", "--motion", "none", "--stats", str(stats), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "inside the head" not in err and "from the head" not in err and "implausible" not in err
    s = json.loads(stats.read_text())
    assert s["max_penetration"] < 0.005 and s["max_root_error"] < 1e-4


@pytest.mark.parametrize("command", ["info", "convert", "render", "simulate", "view"])
def test_every_command_takes_the_frame_options(command):
    from mane.app.cli import build_parser

    args = ["g.hair"] + (["out.npz"] if command == "convert" else [])
    ns = build_parser(command).parse_args([command, *args, "--units", "cm", "--up", "z", "--scale", "0.5"])
    assert (ns.units, ns.up, ns.scale) == ("cm", "z", 0.5)
    if command != "convert":
        ns = build_parser(command).parse_args([command, *args, "--head-units", "mm", "--head-up", "x",
                                               "--head-scale", "0.1"])
        assert (ns.head_units, ns.head_up, ns.head_scale) == ("mm", "x", 0.1)
