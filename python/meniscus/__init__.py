"""Meniscus from Python: render SPH particles as a liquid surface on Vulkan, reconstruct their surface as a
mesh (on the GPU or the CPU), and run the GPU fluid simulation — with NumPy arrays, no files in between.

    import meniscus, numpy as np
    r = meniscus.Renderer(960, 540)
    frame = meniscus.load("ParticleData_Fluid_20.bgeo")
    rgb = r.render(frame["positions"], particle_radius=0.0125)          # H×W×3 uint8
    verts, tris, normals = meniscus.reconstruct_surface(frame["positions"], particle_radius=0.0125)

Everything here calls the Rust library that the `meniscus` command line uses (the same job framing, surfaces,
meshes and simulation), so a render equals `meniscus render FILE --radius R --camera …` pixel for pixel.
Bad input (wrong shapes or dtypes, NaN, empty arrays) raises ValueError; unreadable files OSError; device
failures RuntimeError. The GIL is released while the GPU or the extraction works.
"""

from __future__ import annotations

import warnings
from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from . import _meniscus

__all__ = ["Renderer", "Simulation", "Diffuse", "Foam", "Reconstructor", "reconstruct_surface", "load", "device_info", "sim_scenes",
           "UsdStage", "write_vdb", "sequence", "mesh_edges", "__version__"]
__version__ = _meniscus.__version__

ArrayLike = Any
Camera = Union[Tuple[Sequence[float], Sequence[float]], Tuple[Sequence[float], Sequence[float], float], np.ndarray]


def _points(a: ArrayLike, name: str) -> np.ndarray:
    """An N×3 float32 C-contiguous array (no copy when it already is one), checked."""
    arr = np.asarray(a)
    if arr.dtype not in (np.float32, np.float64):
        raise ValueError(f"{name}: expected float32 or float64 values, got {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name}: expected an N×3 array, got shape {arr.shape}")
    if arr.shape[0] == 0:
        raise ValueError(f"{name}: the array is empty")
    arr = np.ascontiguousarray(arr, dtype=np.float32)
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        raise ValueError(f"{name}: row {int(np.argmax(bad))} is not finite (NaN or inf); {int(bad.sum())} such rows")
    return arr


def _radius(r: float) -> float:
    r = float(r)
    if not (np.isfinite(r) and r > 0):
        raise ValueError(f"particle_radius must be a positive number, got {r}")
    return r


def _camera(camera: Optional[Camera]) -> Optional[Tuple[Tuple[float, ...], Tuple[float, ...], float]]:
    """(eye, target[, fovy_deg]) or a 4×4 world-to-view matrix (its eye and viewing direction; fovy 45°)."""
    if camera is None:
        return None
    if isinstance(camera, np.ndarray) and camera.shape == (4, 4):
        inv = np.linalg.inv(camera.astype(np.float64))
        eye = inv[:3, 3]
        target = eye - inv[:3, 2]
        return tuple(map(float, eye)), tuple(map(float, target)), 45.0
    try:
        eye, target, *rest = camera
        fovy = float(rest[0]) if rest else 45.0
        eye, target = tuple(map(float, eye)), tuple(map(float, target))
    except (TypeError, ValueError) as e:
        raise ValueError(f"camera: expected (eye, target[, fovy_deg]) or a 4×4 view matrix ({e})") from None
    if len(eye) != 3 or len(target) != 3:
        raise ValueError("camera: eye and target are 3 numbers each")
    return eye, target, fovy


class Renderer:
    """Screen-space fluid rendering of particles, `width`×`height`, on `device` (a substring of its name;
    default: the first usable one, lavapipe where there is no GPU), with a settings `preset` ("default",
    "fast", "quality", "smooth", "moritz") and an optional TOML `settings` file over it (README: Settings)."""

    def __init__(self, width: int, height: int, *, device: Optional[str] = None, preset: str = "default",
                 settings: Optional[str] = None) -> None:
        self._r = _meniscus.Renderer(int(width), int(height), device, preset, settings)

    def render(self, positions: Union[ArrayLike, "Simulation"], *, particle_radius: Optional[float] = None,
               camera: Optional[Camera] = None, velocities: Optional[ArrayLike] = None,
               attributes: Optional[Dict[str, ArrayLike]] = None, alpha: bool = False,
               diffuse: Optional["Diffuse"] = None, foam: Optional["Diffuse"] = None) -> np.ndarray:
        """Render particles (N×3) — or a `Simulation`, from its GPU buffer without a copy through the host —
        and return the image as H×W×3 uint8 (H×W×4 with `alpha`). The camera is fitted to the particles'
        1st–99th percentile box unless given; `attributes` may hold "density" (N) for the isolated-particle marks (`[isolated]`) and "id"
        (N integers, as `load` returns a file's) to seed each particle's surface noise as the CLI does (else the
        index). Each call is one still frame: the noise keeps its calm amplitude. `diffuse`: a `Diffuse` whose
        spray, foam and bubbles are drawn with the particles (`foam=`: its deprecated spelling). The same particles as the last call's (equal arrays, radius
        and spray settings) are not uploaded again: rendering one frame from many cameras pays its upload once."""
        if isinstance(positions, Simulation):
            img = self._r.render_sim(positions._s, _camera(camera))
        else:
            if particle_radius is None:
                raise ValueError("particle_radius is required for an array of positions")
            pts = _points(positions, "positions")
            vel = None if velocities is None else _points(velocities, "velocities")
            if vel is not None and vel.shape != pts.shape:
                raise ValueError(f"velocities: shape {vel.shape} does not match positions {pts.shape}")
            dens = None
            if attributes and "density" in attributes:
                dens = np.ascontiguousarray(np.asarray(attributes["density"]), dtype=np.float32).reshape(-1)
                if dens.shape[0] != pts.shape[0]:
                    raise ValueError(f"attributes['density']: {dens.shape[0]} values for {pts.shape[0]} particles")
            ids = None
            if attributes and "id" in attributes:
                ids = np.ascontiguousarray(np.asarray(attributes["id"]), dtype=np.int64).reshape(-1)
                if ids.shape[0] != pts.shape[0]:
                    raise ValueError(f"attributes['id']: {ids.shape[0]} values for {pts.shape[0]} particles")
            if foam is not None:
                if diffuse is not None:
                    raise ValueError("diffuse and foam (its deprecated spelling) given both: keep diffuse")
                warnings.warn("render(foam=…) is deprecated: it is render(diffuse=…) now", DeprecationWarning,
                              stacklevel=2)
                diffuse = foam
            if diffuse is not None and not isinstance(diffuse, Diffuse):
                raise ValueError("diffuse: expected a meniscus.Diffuse")
            img = self._r.render(pts, _radius(particle_radius), _camera(camera), vel, dens, ids,
                                 None if diffuse is None else diffuse._f)
        return img if alpha else img[:, :, :3]

    def render_buffers(self, positions: Union[ArrayLike, "Simulation"], **kwargs: Any) -> Dict[str, np.ndarray]:
        """Render as `render` does and return the frame's buffers: "depth" (H×W float32 linear eye depth, +inf
        where there is no fluid), "normals" (H×W×3 view space), "thickness" (float32, at its own resolution),
        and "image" (H×W×3 uint8)."""
        img = self.render(positions, **kwargs)
        out = dict(self._r.buffers())
        out["image"] = img
        return out

    def timings(self) -> Dict[str, float]:
        """The last frame's GPU time of each pass in milliseconds (the frame's order)."""
        return dict(self._r.timings())

    @property
    def count_work(self) -> bool:
        """Whether the passes count their own work in the frames rendered from now on (`work()`). Off by
        default: the counting costs the frame (15–20 % of the noise splat on lavapipe)."""
        return self._r.count_work

    @count_work.setter
    def count_work(self, on: bool) -> None:
        self._r.count_work = bool(on)

    def work(self) -> Dict[str, Optional[Dict[str, int]]]:
        """Each pass's own count of its work in the last frame, as `meniscus bench` reports it: "splat" (tests:
        sphere–pixel tests, spheres, tiles_skipped), "iso" (samples: field samples, queued, fallbacks),
        "iso_volume" (deposits, atomics; only in a frame that rebuilt the smoothed field) and "noise" (level,
        texels, sprites, evaluated, skipped, binned, longest); None for a pass that did not run. What a GPU's
        cost follows, on any device. The last frame must have been rendered with `count_work` on (ValueError
        otherwise)."""
        return dict(self._r.work())

    def host_timings(self) -> Dict[str, float]:
        """The last `render` of an array's host stages in milliseconds: "arrays" (read, camera framed),
        "upload" (particles set), the renderer's "prepare", "slot_wait", "stage", "record", "submit" (as `meniscus
        bench` reports them), "wait_and_readback" (the GPU's frame and the image's copy out of it) and
        "to_numpy"."""
        return dict(self._r.host_timings())


class Simulation:
    """The GPU fluid simulation of a built-in scene: "dambreak", "drop", "waterfall" or "pool" (`sim_scenes()`),
    with `particles` particles (default: the scene's own) — or of a SPlisHSPlasH scene file ("path/scene.json":
    its fluid blocks, container, colliders, gravity, fps and viscosity; unsupported keys are named on stderr) —
    on `device`, with the `[sim]` section of an optional TOML `settings` file. `solver`: "pbf" (Position Based
    Fluids, the default) or "dfsph" (Divergence-free SPH, iterated to its error bounds). `adaptive_step`: re-choose
    the step every frame from the largest speed of the frame before (`meniscus sim --adaptive-step`; default:
    the settings file's `[sim] adaptive_step`, on for a scene file whose `cflMethod` is 1 or 2). Deterministic:
    the same scene and count give the same particles as `meniscus sim SCENE --particles N`."""

    def __init__(self, scene: str, *, particles: Optional[int] = None, device: Optional[str] = None,
                 settings: Optional[str] = None, solver: Optional[str] = None,
                 adaptive_step: Optional[bool] = None) -> None:
        self._s = _meniscus.Simulation(scene, particles, device, settings, solver, adaptive_step)

    @property
    def solver(self) -> str:
        """The pressure solver: "pbf" or "dfsph"."""
        return self._s.solver

    def solver_stats(self) -> Optional[Dict[str, Dict[str, float]]]:
        """DFSPH: what its two solves ("density", "divergence") did over the last frame — steps, corrections,
        max_corrections, last_error, max_error, mean_error (fractions of the rest density) and unconverged
        steps; None for PBF or before the first frame."""
        return self._s.solver_stats()

    def step(self, n: int = 1) -> None:
        """Simulate `n` frames."""
        if int(n) < 0:
            raise ValueError("n must be at least 0")
        self._s.step(int(n))

    def positions(self) -> np.ndarray:
        """N×3 float32 positions (m), in the order of the last step."""
        return self._s.positions()

    def velocities(self) -> np.ndarray:
        """N×3 float32 velocities (m/s), in the order of the last step."""
        return self._s.velocities()

    def ids(self) -> np.ndarray:
        """Particle ids (int64), in the order of the last step."""
        return self._s.ids()

    @property
    def count(self) -> int:
        """Particles simulated."""
        return self._s.count

    @property
    def reused(self) -> int:
        """Particles the emitter has recycled since the start (a scene file's `emitterReuseParticles`)."""
        return self._s.reused

    @property
    def substeps(self) -> int:
        """Steps of the last frame (with the adaptive step, chosen per frame)."""
        return self._s.substeps

    @property
    def last_speed(self) -> Optional[float]:
        """The largest particle speed (m/s) of the last frame; None before the first."""
        return self._s.last_speed

    @property
    def particle_radius(self) -> float:
        """The particle radius (m)."""
        return self._s.radius

    @property
    def frames(self) -> int:
        """Frames simulated so far."""
        return self._s.frames


class Diffuse:
    """Spray, foam and air bubbles (diffuse particles: Ihmsen et al. 2012) of a simulation you step yourself:
    give `step` every frame's fluid in time order, and `Renderer.render(…, diffuse=d)` draws them. Fluid particles
    spawn them where air is trapped and at wave crests, in proportion to their kinetic energy; they are spray
    (ballistic), foam (carried by the water) or bubbles (rising) by their fluid neighbours, and age and fade.
    The limits calibrate themselves as the run goes (Bender et al. 2019), so a resting pool stays clear at any
    scale; the `[diffuse]` section of an optional TOML `settings` file sets them otherwise. Deterministic: the
    same frames give the same particles (as `meniscus sim --diffuse` does on the GPU)."""

    def __init__(self, *, particle_radius: float, fps: float = 25.0, settings: Optional[str] = None) -> None:
        self._f = _meniscus.Diffuse(_radius(particle_radius), float(fps), settings)

    def step(self, positions: ArrayLike, velocities: ArrayLike, ids: Optional[ArrayLike] = None) -> Tuple[int, int]:
        """The next frame's fluid: positions and velocities (N×3, m and m/s) and optionally ids (N integers,
        to follow particles a simulation reorders; else the index). Returns (spawned, died) this frame."""
        pts = _points(positions, "positions")
        vel = _points(velocities, "velocities")
        if vel.shape != pts.shape:
            raise ValueError(f"velocities: shape {vel.shape} does not match positions {pts.shape}")
        idv = None
        if ids is not None:
            idv = np.ascontiguousarray(np.asarray(ids), dtype=np.int64).reshape(-1)
            if idv.shape[0] != pts.shape[0]:
                raise ValueError(f"ids: {idv.shape[0]} values for {pts.shape[0]} particles")
        return tuple(self._f.step(pts, vel, idv))

    def particles(self) -> Dict[str, np.ndarray]:
        """The living particles: "positions", "velocities" (N×3 float32), "lifetime" (s left), "age" (s), "kind"
        (uint8: 0 foam, 1 spray, 2 bubbles), "id" and "source" (the spawning fluid particle's id; uint32)."""
        return dict(self._f.particles())

    @property
    def counts(self) -> Tuple[int, int, int]:
        """Living particles of each kind: (foam, spray, bubbles)."""
        return tuple(self._f.counts())


class Foam(Diffuse):
    """Deprecated spelling of `Diffuse` (foam is one kind of diffuse particle)."""

    def __init__(self, *, particle_radius: float, fps: float = 25.0, settings: Optional[str] = None) -> None:
        warnings.warn("meniscus.Foam is deprecated: it is meniscus.Diffuse now", DeprecationWarning, stacklevel=2)
        super().__init__(particle_radius=particle_radius, fps=fps, settings=settings)


def _support(support: Optional[float], smoothing_length: Optional[float]) -> float:
    """The kernel support in particle radii: `support` (`[iso] support`; 4 when not given), or from the
    deprecated `smoothing_length` (pysplashsurf's h, half the support)."""
    if smoothing_length is None:
        return 4.0 if support is None else float(support)
    warnings.warn("smoothing_length is deprecated: pass support = 2 × smoothing_length (the kernel support in "
                  "particle radii, as [iso] support)", DeprecationWarning, stacklevel=3)
    if support is not None:
        raise ValueError("pass support or smoothing_length (deprecated), not both")
    return 2.0 * float(smoothing_length)


class Reconstructor:
    """The SPH iso-surface of particles as a triangle mesh, for a simulator that meshes every frame: the
    parameters fixed once (as `reconstruct_surface`'s), and with `gpu` the device, its pipelines and its buffers
    kept between calls — a call pays for the extraction and its transfers, not for their set-up. Positions are read
    in place when they are a C-contiguous float32 N×3 array (else converted once).

        rec = meniscus.Reconstructor(particle_radius=0.025, gpu=True)
        for step in range(steps):
            sim.step()
            vertices, triangles, normals = rec.reconstruct(sim.positions)
    """

    def __init__(self, *, particle_radius: float, support: Optional[float] = None, cube_size: float = 0.5,
                 iso_surface_threshold: float = 0.6, mesh_smoothing_iters: int = 0, gpu: bool = True,
                 device: Optional[str] = None, smoothing_length: Optional[float] = None) -> None:
        support = _support(support, smoothing_length)
        if not (support > 0 and cube_size > 0.05 and 0 < iso_surface_threshold < 1):
            raise ValueError("support must be > 0, cube_size > 0.05, iso_surface_threshold in (0, 1)")
        if int(mesh_smoothing_iters) < 0 or int(mesh_smoothing_iters) > 1000:
            raise ValueError("mesh_smoothing_iters must be in [0, 1000]")
        self._r = _meniscus.Reconstructor(_radius(particle_radius), support, float(cube_size),
                                          float(iso_surface_threshold), int(mesh_smoothing_iters), bool(gpu), device)

    def reconstruct(self, particles: ArrayLike, velocities: Optional[ArrayLike] = None) -> Tuple[np.ndarray, ...]:
        """(vertices N×3 float32, triangles M×3 uint32, normals N×3 float32), and with `velocities` (one row per
        particle) a fourth array: the velocity at each vertex (SPH-interpolated: motion blur)."""
        pts = _points(particles, "particles")
        vel = None if velocities is None else _points(velocities, "velocities")
        if vel is not None and len(vel) != len(pts):
            raise ValueError(f"velocities: {len(vel)} rows for {len(pts)} particles")
        v, t, n, mv = self._r.reconstruct(pts, vel)
        return (v, t, n) if vel is None else (v, t, n, mv)

    @property
    def device(self) -> Optional[str]:
        """The device it extracts on; None on the CPU."""
        return self._r.device_name()

    @property
    def kept_bytes(self) -> int:
        """Device memory kept between calls (the case table and the grown scratch buffers), bytes."""
        return int(self._r.kept_bytes())


def reconstruct_surface(particles: ArrayLike, *, particle_radius: float, support: Optional[float] = None,
                        cube_size: float = 0.5, iso_surface_threshold: float = 0.6, mesh_smoothing_iters: int = 0,
                        gpu: bool = True, device: Optional[str] = None, velocities: Optional[ArrayLike] = None,
                        smoothing_length: Optional[float] = None) -> Tuple[np.ndarray, ...]:
    """The SPH iso-surface of the particles as a triangle mesh (the kernel's support `support` (default 4) ×
    `particle_radius`, as `[iso] support`: pysplashsurf's 2 × smoothing_length; `smoothing_length=` still works,
    deprecated; the marching-cubes edge `cube_size` × `particle_radius`). Returns (vertices N×3 float32, triangles M×3 uint32, normals N×3 float32): the mesh
    `meniscus mesh` writes (`--gpu` when `gpu`); with `velocities` (one row per particle) a fourth array, the
    velocity at each vertex (SPH-interpolated, as `meniscus mesh --out X.usda` writes it: motion blur). Without a
    real GPU pass `gpu=False`: on lavapipe the GPU path runs emulated on the CPU, about 40× slower than the CPU
    extraction (benches/results/llvmpipe-python-binding.md). One call; a simulator meshing every frame keeps a
    `Reconstructor` instead (its device set-up is paid once)."""
    return Reconstructor(particle_radius=particle_radius, support=support, cube_size=cube_size,
                         iso_surface_threshold=iso_surface_threshold, mesh_smoothing_iters=mesh_smoothing_iters,
                         gpu=gpu, device=device, smoothing_length=smoothing_length).reconstruct(particles, velocities)


def mesh_edges(triangles: ArrayLike) -> Tuple[np.ndarray, np.ndarray]:
    """The edges of a triangle mesh as Blender stores them: (E×2 uint32 vertex pairs, each edge once; 3M uint32:
    per corner of each triangle the edge from it to the next corner). For building a mesh in Blender without its
    own edge derivation (the add-on's)."""
    t = np.ascontiguousarray(triangles, dtype=np.uint32).reshape(-1, 3)
    return _meniscus.mesh_edges(t)


def device_info(device: Optional[str] = None) -> Dict[str, str]:
    """The Vulkan device Meniscus finds (`device`: part of a name; default the best one, as the CLI picks):
    {"name", "driver", "api_version", "device_type"}. Raises RuntimeError with what to install when there is no
    Vulkan loader (libvulkan.so.1) or no usable device; the loader may be named by MENISCUS_VULKAN_LOADER."""
    return dict(_meniscus.device_info(device))


class UsdStage:
    """A USD stage written frame by frame, as `meniscus mesh SEQ --out water.usda` writes it: one UsdGeomMesh
    `/water/surface` with time-sampled points, faces, normals, velocities and extent, and with `diffuse=True` a
    UsdGeomPoints `/water/diffuse` (widths, velocities, an int `kind` primvar: 0 foam, 1 spray, 2 bubbles).
    Time codes are frame numbers at `fps`; add frames in increasing time, then `finish()` (the stage appears
    whole, or not at all; an existing file of another kind or an input is never replaced).

        stage = meniscus.UsdStage("water.usda", fps=25)
        for t, frame in frames:
            v, tri, n, vel = meniscus.reconstruct_surface(frame["positions"], particle_radius=r,
                                                          velocities=frame["velocity"], gpu=False)
            stage.add_mesh(t, v, tri, n, vel)
        stage.finish()
    """

    def __init__(self, path: str, fps: float, meters_per_unit: float = 1.0, diffuse: bool = False) -> None:
        self._s = _meniscus.UsdStage(str(path), float(fps), float(meters_per_unit), bool(diffuse))

    def add_mesh(self, time: float, vertices: ArrayLike, triangles: ArrayLike, normals: ArrayLike,
                 velocities: Optional[ArrayLike] = None) -> None:
        v = np.ascontiguousarray(vertices, dtype=np.float32).reshape(-1, 3)
        t = np.ascontiguousarray(triangles, dtype=np.uint32).reshape(-1, 3)
        n = np.ascontiguousarray(normals, dtype=np.float32).reshape(-1, 3)
        vel = np.zeros_like(v) if velocities is None else np.ascontiguousarray(velocities, dtype=np.float32).reshape(-1, 3)
        self._s.add_mesh(float(time), v, t, n, vel)

    def add_points(self, time: float, positions: ArrayLike, velocities: ArrayLike, widths: ArrayLike,
                   kinds: ArrayLike) -> None:
        p = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1, 3)
        self._s.add_points(float(time), p, np.ascontiguousarray(velocities, dtype=np.float32).reshape(-1, 3),
                           np.ascontiguousarray(widths, dtype=np.float32).reshape(-1),
                           np.ascontiguousarray(kinds, dtype=np.int32).reshape(-1))

    def finish(self) -> None:
        self._s.finish()


def write_vdb(path: str, particles: ArrayLike, *, particle_radius: float, support: Optional[float] = None,
              cube_size: float = 0.5, iso_surface_threshold: float = 0.6, half_width: float = 3.0,
              fog: bool = False, smoothing_length: Optional[float] = None) -> int:
    """Write the particles' SPH iso-surface as an OpenVDB narrow-band level set (grid `surface`, voxel =
    `cube_size` × `particle_radius`, half-width `half_width` voxels), with `fog` also the field as a fog volume
    (grid `density`) — `meniscus mesh FILE --out X.vdb [--vdb-fog]`. Returns the level set's active voxels."""
    pts = _points(particles, "particles")
    support = _support(support, smoothing_length)
    if not (support > 0 and cube_size > 0.05 and 0 < iso_surface_threshold < 1):
        raise ValueError("support must be > 0, cube_size > 0.05, iso_surface_threshold in (0, 1)")
    return _meniscus.write_vdb(str(path), pts, _radius(particle_radius), support,
                               float(cube_size), float(iso_surface_threshold), float(half_width), bool(fog))


def sequence(spec: str) -> Dict[str, Any]:
    """A particle sequence as `meniscus mesh`/`render` resolve it (a pattern with {}, a folder, a glob, a .pvd, or
    one file of a numbered sequence): {"frames": [(number, path), …], "radius": the particle radius the CLI
    uses (a SPlisHSPlasH scene.json beside the files, else estimated; None if it cannot be), "radius_from",
    "fps": the scene.json's export rate or None}."""
    return dict(_meniscus.sequence(str(spec)))


def load(path: str) -> Dict[str, np.ndarray]:
    """Read a particle file of any format the CLI reads (BGEO, VTK, VTU/VTP, PLY, XYZ, CSV, RealFlow): a dict
    with "positions" (N×3 float32) and every per-particle array by its name in the file (float64)."""
    return dict(_meniscus.load(str(path)))


def sim_scenes() -> list:
    """The built-in simulation scenes as (name, default particle count, description)."""
    return list(_meniscus.sim_scenes())
