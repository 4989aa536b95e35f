"""The package against the CLI it shares the library with: the same pixels, the same meshes, the same
simulation; bad input raises ValueError."""
import pathlib
import struct
import subprocess

import numpy as np
import pytest
from PIL import Image

import meniscus

CAM = ((-1.4, 1.6, 1.9), (-1.4, 0.5, 0.0), 45.0)
CAM_ARG = "-1.4,1.6,1.9:-1.4,0.5,0:45"


def run(*args):
    r = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r


@pytest.mark.parametrize("preset", ["default", "fast"])
def test_render_equals_the_cli_png(cli, frame, tmp_path, preset):
    png = tmp_path / f"cli-{preset}.png"
    run(cli, "render", frame, "--radius", "0.025", "--camera", CAM_ARG, "--width", "160", "--height", "90",
        "--preset", preset, "--out", png)
    want = np.asarray(Image.open(png).convert("RGB"))
    r = meniscus.Renderer(160, 90, preset=preset)
    data = meniscus.load(frame)
    pos = data["positions"]
    # The file's ids seed the surface noise, as in the CLI.
    ids = {"id": data["id"]}
    got = r.render(pos, particle_radius=0.025, camera=CAM, attributes=ids)
    assert got.shape == (90, 160, 3) and got.dtype == np.uint8
    assert np.array_equal(got, want), f"{int((got != want).any(axis=2).sum())} pixels differ"
    # float64 input, the same pixels; the timings name the passes.
    assert np.array_equal(r.render(pos.astype(np.float64), particle_radius=0.025, camera=CAM, attributes=ids), want)
    t = r.timings()
    assert "composite" in t and all(v >= 0 for v in t.values())
    # The host's stages of the same call, by name.
    h = r.host_timings()
    assert list(h) == ["arrays", "upload", "prepare", "slot_wait", "stage", "record", "submit", "wait_and_readback",
                       "to_numpy"] and all(v >= 0 for v in h.values())


def test_work_counts_each_pass(frame):
    r = meniscus.Renderer(160, 90)
    pos = meniscus.load(frame)["positions"]
    assert r.count_work is False  # off by default: the counting costs the frame
    r.count_work = True
    r.render(pos, particle_radius=0.025, camera=CAM)
    w = r.work()
    assert set(w) == {"splat", "iso", "iso_volume", "noise"}, w
    assert w["splat"]["tests"] >= w["splat"]["spheres"] > 0, w
    assert w["iso"]["samples"] > 0 and w["noise"]["evaluated"] > 0, w
    # The first frame of a particle set builds the smoothed field: its deposits are counted.
    assert w["iso_volume"]["deposits"] > 0 and w["iso_volume"]["atomics"] >= w["iso_volume"]["deposits"], w
    # The same frame again: the same splat and cast (the field kept, or rebuilt the same).
    r.render(pos, particle_radius=0.025, camera=CAM)
    again = r.work()
    assert again["splat"] == w["splat"] and again["iso"] == w["iso"], (again, w)
    assert again["iso_volume"] in (None, w["iso_volume"]), again
    # A frame rendered without counting: asking names the switch.
    r.count_work = False
    r.render(pos, particle_radius=0.025, camera=CAM)
    with pytest.raises(ValueError, match="count_work"):
        r.work()
    # The fast preset draws spheres: no iso pass, no field.
    fast = meniscus.Renderer(160, 90, preset="fast")
    fast.count_work = True
    fast.render(pos, particle_radius=0.025, camera=CAM)
    fw = fast.work()
    assert fw["iso"] is None and fw["iso_volume"] is None and fw["splat"]["tests"] > 0, fw


def test_render_buffers_and_a_view_matrix(frame):
    r = meniscus.Renderer(96, 64)
    pos = meniscus.load(frame)["positions"]
    b = r.render_buffers(pos, particle_radius=0.025, camera=CAM)
    assert b["depth"].shape == (64, 96) and np.isfinite(b["depth"]).sum() > 500
    assert b["normals"].shape == (64, 96, 3) and b["image"].shape == (64, 96, 3)
    # The same camera as a 4×4 world-to-view matrix.
    eye, target = np.array(CAM[0]), np.array(CAM[1])
    f = (target - eye) / np.linalg.norm(target - eye)
    s = np.cross(f, [0, 1, 0]); s /= np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    img = r.render(pos, particle_radius=0.025, camera=m)
    assert np.array_equal(img, b["image"])


def read_ply(path):
    data = open(path, "rb").read()
    head, body = data.split(b"end_header\n", 1)
    nv = int(head.split(b"element vertex ")[1].split(b"\n")[0])
    nf = int(head.split(b"element face ")[1].split(b"\n")[0])
    v = np.frombuffer(body[: 24 * nv], dtype="<f4").reshape(nv, 6)
    f = np.frombuffer(body[24 * nv:], dtype=np.uint8).reshape(nf, 13)[:, 1:].copy().view("<u4").reshape(nf, 3)
    return v[:, :3], f, v[:, 3:]


@pytest.mark.parametrize("gpu", [False, True])
def test_reconstruct_surface_equals_meniscus_mesh(cli, frame, tmp_path, gpu):
    ply = tmp_path / "m.ply"
    # On the GPU, 1 r cubes (lavapipe emulates the GPU path; the equality does not depend on the cube size).
    cube = 1.0 if gpu else 0.5
    run(cli, "mesh", frame, "--radius", "0.025", "--cube-size", cube, "--out", ply, *(["--gpu"] if gpu else []))
    want_v, want_t, want_n = read_ply(ply)
    pos = meniscus.load(frame)["positions"]
    v, t, n = meniscus.reconstruct_surface(pos, particle_radius=0.025, cube_size=cube, gpu=gpu)
    assert v.dtype == np.float32 and t.dtype == np.uint32 and len(t) > 1000
    assert np.array_equal(t, want_t) and np.array_equal(v, want_v) and np.array_equal(n, want_n)


@pytest.mark.parametrize("gpu", [False, True])
def test_a_reconstructor_keeps_its_device_and_gives_the_same_meshes(frame, gpu):
    """A Reconstructor's meshes are reconstruct_surface's, call after call: a smaller set between two calls of a
    larger one leaves nothing stale in the buffers it keeps (the GPU path's grow, never shrink), and a second
    call of the same size allocates nothing new."""
    pos = meniscus.load(frame)["positions"]
    small = np.ascontiguousarray(pos[pos[:, 1] < np.median(pos[:, 1])])
    # 1 r cubes: the GPU path is emulated on lavapipe, and the buffers' reuse does not depend on the cube size.
    rec = meniscus.Reconstructor(particle_radius=0.025, cube_size=1.0, gpu=gpu)
    assert (rec.device is None) == (not gpu)
    same = lambda a, b: len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))
    first = rec.reconstruct(pos)
    once = lambda p: meniscus.reconstruct_surface(p, particle_radius=0.025, cube_size=1.0, gpu=gpu)
    assert len(first[1]) > 1000 and same(first, once(pos))
    few = rec.reconstruct(small)
    assert 0 < len(few[1]) < len(first[1])
    assert same(few, once(small))
    kept = rec.kept_bytes
    assert same(rec.reconstruct(pos), first)
    assert rec.kept_bytes == kept and (kept > 0) == gpu, (kept, rec.kept_bytes)
    # The comparison sees a different mesh (its control): the small set's is not the large one's.
    assert not same(few, first)
    with pytest.raises(ValueError, match="velocities"):
        rec.reconstruct(pos, velocities=pos[:10])


def test_gpu_smoothing_gives_the_cpu_smoothed_mesh(frame):
    """`mesh_smoothing_iters` on the GPU path (its smoothing passes, `compute::smooth`) gives the CPU path's smoothed
    mesh: as many vertices and triangles, and the vertices' coordinates, each axis sorted (each path numbers the
    vertices its own way, so they are compared as sets, and the neighbours are summed in another order), within
    1e-4 of a radius; the control, one iteration fewer, is told apart."""
    pos = meniscus.load(frame)["positions"]
    r = 0.025
    mesh = lambda gpu, n: meniscus.reconstruct_surface(pos, particle_radius=r, cube_size=1.0,
                                                       mesh_smoothing_iters=n, gpu=gpu)
    apart = lambda a, b: max(np.abs(np.sort(a[:, k]) - np.sort(b[:, k])).max() for k in range(3))
    cpu, gpu = mesh(False, 10), mesh(True, 10)
    assert len(cpu[1]) == len(gpu[1]) > 1000 and len(cpu[0]) == len(gpu[0])
    assert apart(cpu[0], gpu[0]) <= 1e-4 * r, apart(cpu[0], gpu[0]) / r
    assert apart(cpu[0], mesh(True, 9)[0]) > 1e-3 * r, "the control (9 iterations) looks the same"


def test_simulation_equals_meniscus_sim_and_renders_from_the_gpu(cli, tmp_path):
    run(cli, "sim", "dambreak", "--particles", "2000", "--frames", "4", "--export", tmp_path / "f_{}.bgeo")
    want = meniscus.load(tmp_path / "f_4.bgeo")
    sim = meniscus.Simulation("dambreak", particles=2000)
    r = meniscus.Renderer(128, 72)
    before = r.render(sim)  # not stepped yet: the scene's initial block
    sim.step(3)
    assert sim.frames == 3 and sim.count == want["positions"].shape[0]
    assert np.array_equal(sim.positions(), want["positions"])
    assert np.array_equal(sim.velocities(), want["velocity"].astype(np.float32))
    after = r.render(sim)  # from the simulation's GPU buffer
    for img in (before, after):
        water = (img[:, :, 2].astype(int) > img[:, :, 0].astype(int) + 30).sum()
        assert water > 100, water
    assert (before != after).any(axis=2).sum() > 50, "the water did not move"


def test_load_reads_every_attribute(frame):
    d = meniscus.load(frame)
    assert d["positions"].shape == (6859, 3) and d["positions"].dtype == np.float32
    assert d["velocity"].shape == (6859, 3) and d["density"].shape == (6859,) and "id" in d


@pytest.mark.parametrize("bad, msg", [
    (np.zeros((10, 2), np.float32), "N×3"),
    (np.zeros((10, 3), np.int32), "float32 or float64"),
    (np.zeros((0, 3), np.float32), "empty"),
    (np.array([[0, 0, 0], [np.nan, 0, 0]], np.float32), "row 1 is not finite"),
    (np.zeros((4, 3, 1), np.float32), "N×3"),
    ("not an array", "float32 or float64"),
])
def test_bad_arrays_raise_value_error(bad, msg):
    r = meniscus.Renderer(16, 16)
    with pytest.raises(ValueError, match=msg):
        r.render(bad, particle_radius=0.01)
    with pytest.raises(ValueError, match=msg):
        meniscus.reconstruct_surface(bad, particle_radius=0.01)


def test_support_is_the_kernel_and_smoothing_length_still_works_with_a_warning(tmp_path):
    """`support` (particle radii, as `[iso] support`) names the kernel; pysplashsurf's `smoothing_length` (half
    of it) still works, with a DeprecationWarning, and gives the same mesh; both at once is an error."""
    pts = np.random.default_rng(3).random((300, 3), dtype=np.float32) * 0.2
    want = meniscus.reconstruct_surface(pts, particle_radius=0.01, support=4.0, gpu=False)
    with pytest.warns(DeprecationWarning, match="smoothing_length is deprecated"):
        old = meniscus.reconstruct_surface(pts, particle_radius=0.01, smoothing_length=2.0, gpu=False)
    assert all(np.array_equal(a, b) for a, b in zip(want, old))
    with pytest.raises(ValueError, match="not both"):
        with pytest.warns(DeprecationWarning):
            meniscus.reconstruct_surface(pts, particle_radius=0.01, support=3.0, smoothing_length=2.0)
    with pytest.raises(ValueError, match="not both"):
        with pytest.warns(DeprecationWarning):
            meniscus.write_vdb(tmp_path / "x.vdb", pts, particle_radius=0.01, support=4.0, smoothing_length=2.0)


def test_bad_parameters_and_files_raise():
    pts = np.random.default_rng(1).random((100, 3), dtype=np.float32)
    r = meniscus.Renderer(16, 16)
    with pytest.raises(ValueError, match="particle_radius"):
        r.render(pts, particle_radius=-1)
    with pytest.raises(ValueError, match="camera"):
        r.render(pts, particle_radius=0.01, camera=((0, 0, 1), (0, 0, 1)))
    with pytest.raises(ValueError):
        meniscus.Renderer(0, 10)
    with pytest.raises(ValueError, match="unknown preset|preset"):
        meniscus.Renderer(8, 8, preset="nope")
    with pytest.raises(OSError):
        meniscus.load("/no/such/file.bgeo")
    with pytest.raises(ValueError, match="not a regular file"):
        meniscus.load("/dev/zero")
    with pytest.raises(ValueError):
        meniscus.Simulation("nope")


def test_diffuse_equals_the_simulations_gpu_stages_and_draws(cli, tmp_path):
    """`Diffuse` (the CPU model) stepped with a simulation's exported frames gives the particles `meniscus sim
    --diffuse` generated on the GPU for the same frames (by source and spawn id); a resting frame spawns none; the
    render with them differs from the one without."""
    run(cli, "sim", "dambreak", "--particles", "3000", "--frames", "7", "--export", tmp_path / "f_{}.bgeo",
        "--diffuse", tmp_path / "d_{}.bgeo")
    first = meniscus.load(tmp_path / "f_1.bgeo")
    radius = float(meniscus.Simulation("dambreak", particles=3000).particle_radius)
    foam = meniscus.Diffuse(particle_radius=radius, fps=25.0)
    # File n ≥ 2 is the state after frame n − 1 (the GPU stages run after each frame's steps).
    for n in range(2, 8):
        f = meniscus.load(tmp_path / f"f_{n}.bgeo")
        foam.step(f["positions"], f["velocity"].astype(np.float32), f["id"].astype(np.int64))
    mine = foam.particles()
    theirs = meniscus.load(tmp_path / "d_7.bgeo")
    assert mine["positions"].shape[0] == theirs["positions"].shape[0] > 50
    key = lambda src, ids: sorted(zip(src.astype(np.uint32).tolist(), ids.astype(np.uint32).tolist()))
    # The file's ids are written as int32 (their bits): the same uint32 after the cast.
    assert key(mine["source"], mine["id"]) == key(theirs["source"], theirs["id"].astype(np.int64) & 0xFFFFFFFF)
    assert sum(foam.counts) == mine["positions"].shape[0]
    still = meniscus.Diffuse(particle_radius=radius)
    assert still.step(first["positions"], np.zeros_like(first["positions"])) == (0, 0)
    r = meniscus.Renderer(128, 72, preset="fast")
    f = meniscus.load(tmp_path / "f_7.bgeo")
    with_foam = r.render(f["positions"], particle_radius=radius, diffuse=foam)
    without = r.render(f["positions"], particle_radius=radius)
    assert (with_foam != without).any(axis=2).sum() > 20
    with pytest.raises(ValueError):
        meniscus.Diffuse(particle_radius=-1.0)
    # The deprecated spellings still work, with a DeprecationWarning.
    with pytest.warns(DeprecationWarning, match="meniscus.Diffuse"):
        old = meniscus.Foam(particle_radius=radius)
    assert isinstance(old, meniscus.Diffuse)
    with pytest.warns(DeprecationWarning, match="diffuse="):
        again = r.render(f["positions"], particle_radius=radius, foam=foam)
    assert (again == with_foam).all()
    with pytest.raises(ValueError):
        foam.step(f["positions"], f["velocity"][:5].astype(np.float32))


def test_device_info_and_no_loader_error(tmp_path):
    """The package names its Vulkan device; without a Vulkan loader a GPU call is a RuntimeError saying what to
    install, not a crash (a process of its own: the loader is opened once per process)."""
    import os
    import sys
    info = meniscus.device_info()
    assert info["name"] and info["api_version"].startswith("1.") and info["device_type"]
    code = ("import meniscus\ntry:\n    meniscus.device_info()\nexcept RuntimeError as e:\n    print('RuntimeError:', e)\n"
            "import numpy as np\nv, t, n = meniscus.reconstruct_surface(np.zeros((8, 3)) + np.arange(8)[:, None] * 0.01,"
            " particle_radius=0.01, gpu=False)\nprint('cpu mesh ok', len(t))\n")
    env = {**os.environ, "MENISCUS_VULKAN_LOADER": str(tmp_path / "no-libvulkan.so.1")}
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "RuntimeError: cannot load the Vulkan loader" in r.stdout and "apt-get install libvulkan1" in r.stdout
    assert "cpu mesh ok" in r.stdout


def test_simulation_of_a_splishsplash_scene_file(shared):
    """A SPlisHSPlasH scene.json runs as it is: its fluid block's particles (SPlisHSPlasH's frame 1: 6,859), the
    radius its particleRadius says; a particle count does not apply to it."""
    scene = shared("splishsplash/dambreak_6859/scene.json")
    sim = meniscus.Simulation(str(scene))
    assert sim.count == 6859 and sim.particle_radius == pytest.approx(0.025)
    first = meniscus.load(str(scene.parent / "partio" / "ParticleData_Fluid_1.bgeo"))["positions"]
    assert np.allclose(np.sort(sim.positions()[:, 0]), np.sort(first[:, 0]), atol=0.05)
    sim.step(1)
    assert np.isfinite(sim.positions()).all()
    with pytest.raises(ValueError, match="particleRadius"):
        meniscus.Simulation(str(scene), particles=1000)


def test_simulation_of_a_recycling_emitter():
    """A scene file whose emitter recycles (tests/fixtures/splishsplash-emitter-reuse.scene.json): the jet reaches
    the drain after 0.44 s and its particles are taken back, so the count stays below the room of 600."""
    scene = pathlib.Path(__file__).resolve().parents[2] / "tests/fixtures/splishsplash-emitter-reuse.scene.json"
    sim = meniscus.Simulation(str(scene))
    assert sim.count == 0 and sim.reused == 0
    sim.step(11)
    assert sim.count == 432 and sim.reused == 0
    sim.step(6)
    assert sim.reused > 0 and sim.count < 600


def test_simulation_with_dfsph_reports_its_solves(cli, tmp_path):
    """solver="dfsph" runs the divergence-free solver: the same particles as `meniscus sim --solver dfsph`, and
    its solves' statistics within their bounds; a solver of another name is a ValueError."""
    run(cli, "sim", "dambreak", "--particles", "2000", "--frames", "3", "--solver", "dfsph", "--export",
        tmp_path / "f_{}.bgeo")
    want = meniscus.load(tmp_path / "f_3.bgeo")
    sim = meniscus.Simulation("dambreak", particles=2000, solver="dfsph")
    assert sim.solver == "dfsph" and sim.solver_stats() is None
    sim.step(2)
    assert np.array_equal(sim.positions(), want["positions"])
    st = sim.solver_stats()
    assert st["density"]["steps"] > 0 and st["density"]["corrections"] >= 2 * st["density"]["steps"]
    assert meniscus.Simulation("dambreak", particles=2000).solver == "pbf"
    with pytest.raises(ValueError, match="dfsph"):
        meniscus.Simulation("dambreak", particles=2000, solver="sph")


def test_simulation_with_the_adaptive_step_matches_the_cli(cli, tmp_path):
    """adaptive_step=True re-chooses the step every frame as `meniscus sim --adaptive-step` does: the same
    particles; the last frame's step count and largest speed are reported (the speed at least the fastest
    particle's at the frame's end)."""
    args = ["--particles", "2000", "--frames", "4", "--solver", "dfsph", "--adaptive-step"]
    run(cli, "sim", "dambreak", *args, "--export", tmp_path / "f_{}.bgeo")
    want = meniscus.load(tmp_path / "f_4.bgeo")
    sim = meniscus.Simulation("dambreak", particles=2000, solver="dfsph", adaptive_step=True)
    assert sim.last_speed is None
    sim.step(3)
    assert np.array_equal(sim.positions(), want["positions"])
    assert sim.substeps >= 1
    fastest = float(np.linalg.norm(sim.velocities(), axis=1).max())
    assert sim.last_speed >= fastest * (1 - 1e-6)


def test_render_of_the_same_particles_again_is_the_same_and_a_change_is_seen(frame):
    """The renderer keeps the last array's particles and does not upload equal ones again: the image is the same;
    a changed array (even a copy changed in place) is uploaded and drawn as a new renderer draws it."""
    r = meniscus.Renderer(96, 64)
    pos = meniscus.load(frame)["positions"]
    a = r.render(pos, particle_radius=0.025, camera=CAM)
    assert np.array_equal(a, r.render(pos.copy(), particle_radius=0.025, camera=CAM))
    moved = pos.copy()
    moved[:, 1] += 0.05
    c = r.render(moved, particle_radius=0.025, camera=CAM)
    assert not np.array_equal(a, c)
    assert np.array_equal(c, meniscus.Renderer(96, 64).render(moved, particle_radius=0.025, camera=CAM))
    # Another radius is another set of particles.
    d = r.render(moved, particle_radius=0.03, camera=CAM)
    assert np.array_equal(d, meniscus.Renderer(96, 64).render(moved, particle_radius=0.03, camera=CAM))
