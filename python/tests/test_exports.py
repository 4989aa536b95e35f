"""What `meniscus mesh` writes for other tools, opened by each format's reference implementation: USD stages by
Pixar's usd-core (`pxr`), OpenVDB level sets and fog volumes by OpenVDB's own Python module (Debian's
python3-openvdb, `pyopenvdb`). Missing readers fail under CI=true (tools/dev installs them), else skip."""
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import _ci

RADIUS = 0.025


def need(module: str):
    """Import a reference reader; Debian's pyopenvdb lives in the system's dist-packages (same CPython 3.11 ABI)."""
    if module == "pyopenvdb":
        # Debian's pyopenvdb is built against numpy 1.x: under numpy 2 it crashes the interpreter (a segfault
        # that kills pytest with no message) instead of failing. The test environments pin numpy < 2 (tools/dev,
        # tools/wheel); a different numpy is this test's failure, said here.
        if int(np.__version__.split(".")[0]) >= 2:
            pytest.fail(f"pyopenvdb needs numpy < 2 (Debian's build); this environment has numpy {np.__version__}")
        if "/usr/lib/python3/dist-packages" not in sys.path:
            sys.path.append("/usr/lib/python3/dist-packages")
    try:
        return __import__(module)
    except ImportError as e:
        if _ci():
            pytest.fail(f"{module} is missing under CI=true: {e}")
        pytest.skip(f"{module} not installed: {e}")


def run(*args, ok=True):
    r = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    if ok:
        assert r.returncode == 0, r.stderr
    return r


def read_ply(path):
    """Vertices, normals and triangles of a binary PLY as `meniscus mesh` writes it."""
    data = open(path, "rb").read()
    head = data.index(b"end_header\n") + len(b"end_header\n")
    nv = int(data.split(b"element vertex ")[1].split(b"\n")[0])
    nf = int(data.split(b"element face ")[1].split(b"\n")[0])
    v = np.frombuffer(data[head:head + 24 * nv], np.float32).reshape(nv, 6)
    f = np.frombuffer(data[head + 24 * nv:head + 24 * nv + 13 * nf], np.uint8).reshape(nf, 13)
    tris = f[:, 1:].copy().view(np.uint32).reshape(nf, 3)
    return v[:, :3], v[:, 3:], tris


@pytest.fixture(scope="module")
def sequence(shared):
    return shared("splishsplash/dambreak_6859")


@pytest.mark.parametrize("ext", ["usd", "usda"])
def test_usd_stage_holds_the_sequence_with_velocities(cli, sequence, tmp_path, ext):
    pxr = need("pxr")
    from pxr import Sdf, Usd, UsdGeom
    pattern = sequence / "partio" / "ParticleData_Fluid_{}.bgeo"
    usd = tmp_path / f"water.{ext}"
    run(cli, "mesh", pattern, "--frames", "16..20", "--out", usd)
    run(cli, "mesh", pattern, "--frames", "16..20", "--out", tmp_path / "ply" / "f_{}.ply")
    stage = Usd.Stage.Open(str(usd))
    assert stage is not None and pxr is not None
    # .usd is the binary crate encoding, .usda text.
    assert usd.read_bytes()[:8] == (b"PXR-USDC" if ext == "usd" else b"#usda 1.")
    assert Sdf.Layer.FindOrOpen(str(usd)).GetFileFormat().formatId == ("usd" if ext == "usd" else "usda")
    assert stage.GetTimeCodesPerSecond() == 25.0  # the scene.json's dataExportFPS
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (16.0, 20.0)
    assert UsdGeom.GetStageUpAxis(stage) == "Y" and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/water/surface"))
    assert mesh and stage.GetDefaultPrim().GetPath() == "/water"
    assert Usd.ModelAPI(stage.GetPrimAtPath("/water")).GetKind() == "component"
    assert (mesh.GetOrientationAttr().Get(), mesh.GetSubdivisionSchemeAttr().Get()) == ("rightHanded", "none")
    assert mesh.GetPointsAttr().GetTimeSamples() == [16.0, 17.0, 18.0, 19.0, 20.0]
    assert mesh.GetNormalsInterpolation() == "vertex"
    import meniscus
    for t in range(16, 21):
        v, n, tris = read_ply(tmp_path / "ply" / f"f_{t:04d}.ply")
        pts = np.array(mesh.GetPointsAttr().Get(t), np.float32)
        assert np.array_equal(pts, v), f"frame {t}: the stage's points are not the PLY's"
        assert np.array_equal(np.array(mesh.GetNormalsAttr().Get(t), np.float32), n)
        assert np.array_equal(np.array(mesh.GetFaceVertexIndicesAttr().Get(t)).reshape(-1, 3), tris)
        assert set(mesh.GetFaceVertexCountsAttr().Get(t)) == {3}
        ext = np.array(mesh.GetExtentAttr().Get(t))
        assert np.allclose(ext, [v.min(axis=0), v.max(axis=0)])
        # Every vertex velocity is a convex combination of particle velocities (Shepard interpolation).
        vel = np.array(mesh.GetVelocitiesAttr().Get(t), np.float64)
        assert vel.shape == v.shape and np.isfinite(vel).all()
        pv = meniscus.load(sequence / "partio" / f"ParticleData_Fluid_{t}.bgeo")["velocity"]
        assert (vel >= pv.min(axis=0) - 1e-4).all() and (vel <= pv.max(axis=0) + 1e-4).all()
        assert np.abs(vel).max() > 0.1  # the water moves at frame 16+
    # ... and computed from the velocities: a moving frame's mean vertex velocity follows the particles' mean.
    assert np.linalg.norm(vel.mean(axis=0) - pv.mean(axis=0)) < 0.5 * np.linalg.norm(pv.mean(axis=0)) + 0.05


@pytest.mark.parametrize("ext", ["usdc", "usda"])
def test_usd_with_diffuse_particles(cli, sequence, tmp_path, ext):
    need("pxr")
    from pxr import Usd, UsdGeom
    usd = tmp_path / f"foam.{ext}"
    run(cli, "mesh", sequence / "partio" / "ParticleData_Fluid_{}.bgeo", "--frames", "24..26", "--cube-size", "1.0",
        "--diffuse", "--out", usd)
    stage = Usd.Stage.Open(str(usd))
    pts = UsdGeom.Points(stage.GetPrimAtPath("/water/diffuse"))
    assert pts.GetPointsAttr().GetTimeSamples() == [24.0, 25.0, 26.0]
    kind = UsdGeom.PrimvarsAPI(pts).GetPrimvar("kind")
    for t in (24, 25, 26):
        p = pts.GetPointsAttr().Get(t)
        assert len(p) == len(pts.GetWidthsAttr().Get(t)) == len(pts.GetVelocitiesAttr().Get(t)) == len(kind.Get(t))
        assert set(kind.Get(t)) <= {0, 1, 2}
    assert len(pts.GetPointsAttr().Get(26)) > 0


def test_vdb_level_set_and_fog(cli, frame, tmp_path):
    vdb = need("pyopenvdb")
    out = tmp_path / "f20.vdb"
    ply = tmp_path / "f20.ply"
    run(cli, "mesh", frame, "--radius", RADIUS, "--out", out, "--vdb-fog")
    run(cli, "mesh", frame, "--radius", RADIUS, "--out", ply)
    grids, meta = vdb.readAll(str(out))
    by_name = {g.name: g for g in grids}
    ls, fog = by_name["surface"], by_name["density"]
    h = 0.5 * RADIUS
    assert ls.gridClass == "level set" and fog.gridClass == "fog volume"
    assert np.allclose(ls.transform.voxelSize(), (h, h, h))
    assert ls.background == pytest.approx(3 * h)
    # Voxel (0, 0, 0) is the marching-cubes lattice's first corner: the particles' box less the support (4 r).
    import meniscus
    pos = meniscus.load(str(frame))["positions"]
    assert np.allclose(ls.transform.indexToWorld((0, 0, 0)), pos.min(axis=0) - 4 * RADIUS, atol=1e-5)
    # The level set's zero crossing at every marching-cubes vertex of the same frame: within half a voxel.
    v, _, _ = read_ply(ply)
    lo, hi = ls.evalActiveVoxelBoundingBox()
    lo = tuple(c - 1 for c in lo)
    dense = np.full(tuple(b - a + 2 for a, b in zip(lo, hi)), ls.background, np.float32)
    ls.copyToArray(dense, ijk=lo)
    u = (v.astype(np.float64) - np.array(ls.transform.indexToWorld((0, 0, 0)))) / h - np.array(lo)
    i = np.floor(u).astype(int)
    f = u - i
    phi = np.zeros(len(v))
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                w = (f[:, 0] if dx else 1 - f[:, 0]) * (f[:, 1] if dy else 1 - f[:, 1]) * (f[:, 2] if dz else 1 - f[:, 2])
                phi += w * dense[i[:, 0] + dx, i[:, 1] + dy, i[:, 2] + dz]
    assert np.abs(phi).max() <= 0.5 * h, f"level set off the mesh by {np.abs(phi).max() / h:.3f} voxels"
    # Inside is negative: a point deep in the water column.
    inside = np.array(ls.transform.worldToIndexCellCentered(tuple(float(x) for x in np.median(pos, axis=0))))
    assert ls.getAccessor().getValue(tuple(int(c) for c in inside)) < 0
    # The fog: the field, in [0, 1], 0 outside.
    d = np.zeros((40, 40, 40), np.float32)
    fog.copyToArray(d, ijk=tuple(int(c) - 20 for c in inside))
    assert d.min() >= 0 and d.max() <= 1 and d.max() > 0.9
    assert fog.background == 0


def test_export_flags_are_checked(cli, frame, tmp_path):
    r = run(cli, "mesh", frame, "--radius", RADIUS, "--out", tmp_path / "a.vdb", "--field", "metaball", ok=False)
    assert r.returncode != 0 and "metaball" in r.stderr
    r = run(cli, "mesh", frame, "--radius", RADIUS, "--out", tmp_path / "a.ply", "--diffuse", ok=False)
    assert r.returncode != 0 and "USD" in r.stderr
    for flag, value, out in (("--meters-per-unit", "0.01", "a.ply"), ("--vdb-half-width", "4", "a.usd"),
                             ("--vdb-fog", None, "a.ply")):
        r = run(cli, "mesh", frame, "--radius", RADIUS, "--out", tmp_path / out, flag, *([value] if value else []),
                ok=False)
        assert r.returncode != 0 and flag in r.stderr and not (tmp_path / out).exists(), r.stderr
    r = run(cli, "mesh", frame, "--radius", RADIUS, "--out", tmp_path / "a.usda", "--diffuse", ok=False)
    assert r.returncode != 0 and "sequence" in r.stderr
    # Never over an input, never a stray scratch file left.
    r = run(cli, "mesh", frame, "--radius", RADIUS, "--out", frame.with_suffix(".usda"))
    assert frame.with_suffix(".usda").read_bytes().startswith(b"#usda 1.0")
    assert not [p for p in os.listdir(frame.parent) if p.endswith(".partial")]
    for name in ("notes.usda", "notes.usd", "notes.vdb"):
        bad = tmp_path / name
        bad.write_text("my notes\n")
        r = run(cli, "mesh", frame, "--radius", RADIUS, "--out", bad, ok=False)
        assert r.returncode != 0 and bad.read_text() == "my notes\n"
