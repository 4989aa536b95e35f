"""What the tools that run SPlisHSPlasH itself share (tools/splishsplash-work.py, -body.py, -emitter.py):
`load()` imports the `pysplishsplash` wheel (exits with the install command when it is missing); the wheel bundles
its own libGLdispatch/libGLX, which crash beside the system's libGLX at import, so the calling script is re-run
once with them preloaded. SPlisHSPlasH finds its resources (the emitters' boundary meshes) beside the running
executable, where the wheel installs them in a virtual environment (its bin/resources) but not where a symlinked
interpreter resolves to: the re-run then uses a copy of the interpreter in the environment's bin/
(python-splishsplash, made once). `scene_copy()` writes the copy of a scene file SPlisHSPlasH runs (nothing is written
beside the input): no exports, stopping at `seconds`, its geometry paths made absolute (relative to the scene's
folder, else the wheel's own models: its example scenes name `../models/UnitBox.obj`, which the wheel installs
beside the interpreter, in data/models/)."""
import argparse
import importlib.metadata
import importlib.util
import json
import os
import pathlib
import shutil
import subprocess
import sys


def load():
    spec = importlib.util.find_spec("pysplishsplash")
    if spec is None:
        sys.exit("pysplishsplash is not installed: pip install pysplishsplash==2.19.0")
    libs = pathlib.Path(spec.origin).parent / "pysplishsplash.libs"
    if "MENISCUS_SPLASH_PRELOADED" not in os.environ and libs.is_dir():
        pre = [str(p) for n in ("libGLdispatch", "libGLX") for p in sorted(libs.glob(n + "-*"))]
        env = dict(os.environ, MENISCUS_SPLASH_PRELOADED="1", LD_PRELOAD=" ".join(pre))
        sys.exit(subprocess.run([interpreter()] + sys.argv, env=env).returncode)
    import pysplishsplash

    return pysplishsplash


def interpreter():
    """The interpreter to re-run with: a copy beside the environment's resources when the running one resolves
    elsewhere."""
    here = pathlib.Path(sys.executable)
    resources = here.parent / "resources"
    real = here.resolve()
    if not resources.is_dir() or (real.parent / "resources").is_dir():
        return sys.executable
    copy = here.parent / "python-splishsplash"
    if not copy.exists():
        partial = copy.with_suffix(".partial")
        shutil.copy2(real, partial)
        partial.replace(copy)
    return str(copy)


def geometry(scene, path):
    p = (scene.parent / path).resolve()
    shipped = pathlib.Path(sys.executable).parent / "data" / "models" / pathlib.Path(path).name
    return str(p if p.exists() or not shipped.exists() else shipped)


def scene_copy(scene, tmp, seconds):
    """The scene (a pathlib.Path) copied into the folder `tmp` for SPlisHSPlasH; returns (the copy's path, the
    parsed scene)."""
    s = json.loads(scene.read_text())
    s["Configuration"].update(stopAt=seconds, enablePartioExport=False, enableVTKExport=False)
    for body in s.get("RigidBodies", []):
        if "geometryFile" in body:
            body["geometryFile"] = geometry(scene, body["geometryFile"])
        body.pop("particleFile", None)
    copy = pathlib.Path(tmp) / "scene.json"
    copy.write_text(json.dumps(s))
    return copy, s


def run(sph, copy, tmp, seconds, after_step):
    """SPlisHSPlasH's headless simulator on `copy` to `seconds`, `after_step` called after every step."""
    base = sph.Exec.SimulatorBase()
    base.init(useGui=False, outputDir=str(pathlib.Path(tmp) / "out"), sceneFile=str(copy))
    base.setValueFloat(base.STOP_AT, seconds)
    base.setTimeStepCB(after_step)
    base.run()


def recording_args(seconds):
    """The recording tools' arguments (SCENE, --seconds, default `seconds`; --fps; --out): (args, the scene's path,
    the output's path); exits when --out is the scene itself."""
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("--seconds", type=float, default=seconds)
    ap.add_argument("--fps", type=float, default=25.0)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    scene = pathlib.Path(a.scene).resolve()
    out = pathlib.Path(a.out).resolve()
    if out == scene:
        sys.exit(f"--out {out} is the scene itself")
    return a, scene, out


def run_per_frame(sph, copy, tmp, seconds, fps, record):
    """`run`, calling `record(t)` at the first step at or past every 1/fps s (t = 0 first)."""
    nxt = [0.0]

    def after_step():
        t = sph.TimeManager.getCurrent().getTime()
        if t + 1e-9 < nxt[0]:
            return
        nxt[0] += 1.0 / fps
        record(t)

    run(sph, copy, tmp, seconds, after_step)


def write_record(out, scene, a, fields):
    """The record's JSON at `out`, written whole (never half): the scene's name, the wheel's version, --seconds and
    --fps, then `fields`."""
    doc = {
        "scene": scene,
        "pysplishsplash": importlib.metadata.version("pysplishsplash"),
        "seconds": a.seconds,
        "fps": a.fps,
        **fields,
    }
    partial = out.with_suffix(out.suffix + ".partial")
    partial.write_text(json.dumps(doc, indent=1) + "\n")
    partial.replace(out)
