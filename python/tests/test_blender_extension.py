"""The Blender extension (tools/blender-extension): its zip, built from the wheel these tests run against, is
installed by Blender's own installer (`bpy.ops.extensions.package_install_files`, bpy 5.0) in a fresh interpreter
with a user folder of its own; Blender installs the `meniscus` wheel the zip carries, enables the add-on, and the
add-on imports and meshes a frame of the shared 6,859-particle dam break, saying where it meshed (on lavapipe:
the CPU, and why). The control: the same zip without its `wheels` key installs the add-on but not the package.
The wheel: $MENISCUS_WHEEL (tools/wheel --test sets it) or target/wheels; missing fails under CI=true, else
skips. bpy missing likewise."""
import glob
import json
import os
import pathlib
import subprocess
import sys
import zipfile

import pytest

from conftest import ROOT, _ci

try:
    import bpy  # noqa: F401  (only to know it is there: Blender runs in a subprocess)
except ImportError as e:  # pragma: no cover - depends on the environment
    if _ci():
        pytest.fail(f"bpy (Blender as a Python module) is missing under CI=true: {e}", pytrace=False)
    pytest.skip(f"bpy not installed: {e}", allow_module_level=True)

INSTALL = r'''
import json, os, pathlib, sys
import bpy
zip_path, frame = sys.argv[1], sys.argv[2]
out = {"install": sorted(bpy.ops.extensions.package_install_files(
    filepath=zip_path, repo="user_default", enable_on_install=True))}
site = pathlib.Path(bpy.utils.user_resource("EXTENSIONS")) / ".local"
out["package_files"] = sorted(str(p.relative_to(site)) for p in site.rglob("meniscus/__init__.py"))
out["enabled"] = "bl_ext.user_default.meniscus_water" in bpy.context.preferences.addons
if out["enabled"]:
    addon = sys.modules["bl_ext.user_default.meniscus_water"]
    s = bpy.context.scene.meniscus_water
    s.source = frame
    out["device"] = addon.meshing_device(s)[1]
    bpy.context.scene.frame_set(int(frame.rsplit("_", 1)[1].split(".")[0]))
    out["import"] = sorted(bpy.ops.meniscus.import_sequence())
    me = bpy.data.objects[addon.OBJECT].data
    out["mesh"] = [len(me.vertices), len(me.polygons)]
print("RESULT " + json.dumps(out))
'''


def wheel():
    given = os.environ.get("MENISCUS_WHEEL")
    found = [given] if given else sorted(glob.glob(str(ROOT / "target" / "wheels" / "meniscus-*.whl")))
    if not found or not pathlib.Path(found[-1]).is_file():
        if _ci():
            pytest.fail("no meniscus wheel under CI=true (tools/wheel --test sets MENISCUS_WHEEL)", pytrace=False)
        pytest.skip("no wheel built (tools/wheel)")
    return found[-1]


def install(zip_path, frame, home):
    home.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(home))
    r = subprocess.run([sys.executable, "-c", INSTALL, str(zip_path), str(frame)], capture_output=True, text=True,
                       env=env, cwd=home, timeout=600)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")]
    assert r.returncode == 0 and lines, f"Blender's install failed:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return json.loads(lines[-1][len("RESULT "):])


def test_the_extension_zip_installs_its_wheel_and_meshes_a_frame(cli, shared, tmp_path):
    frame = shared("splishsplash/dambreak_6859/partio/ParticleData_Fluid_20.bgeo")
    r = subprocess.run([sys.executable, str(ROOT / "tools" / "blender-extension"), "--wheel", wheel(),
                        "--out", str(tmp_path / "zip")], capture_output=True, text=True, check=True)
    zip_path = pathlib.Path(r.stdout.strip().splitlines()[-1])
    names = zipfile.ZipFile(zip_path).namelist()
    assert "blender_manifest.toml" in names and "__init__.py" in names, names
    assert any(n.startswith("wheels/meniscus-") for n in names), names
    got = install(zip_path, frame, tmp_path / "home")
    assert got["install"] == ["FINISHED"] and got["enabled"], got
    assert got["package_files"], f"Blender did not install the wheel: {got}"
    assert got["import"] == ["FINISHED"], got
    # The frame's mesh is `meniscus mesh`'s (the add-on's defaults: cube 0.5 r, support 4 r, iso 0.6).
    ply = tmp_path / "f.ply"
    subprocess.run([cli, "mesh", str(frame), "--out", str(ply)], check=True, capture_output=True)
    head = ply.read_bytes()[:400].split(b"end_header")[0].decode()
    want = [int(head.split("element vertex ")[1].split()[0]), int(head.split("element face ")[1].split()[0])]
    assert got["mesh"] == want, (got, want)
    # Where it meshed, said: on lavapipe (a CPU driver) the CPU's cores.
    import meniscus
    if meniscus.device_info()["device_type"] == "CPU":
        assert got["device"].startswith("CPU: the only Vulkan device is"), got

    # The control: the same zip without `wheels` in its manifest gives the add-on and no package.
    bare = tmp_path / "bare.zip"
    with zipfile.ZipFile(zip_path) as src, zipfile.ZipFile(bare, "w") as dst:
        for n in src.namelist():
            if n.startswith("wheels/"):
                continue
            data = src.read(n)
            if n == "blender_manifest.toml":
                data = b"\n".join(ln for ln in data.split(b"\n") if not ln.startswith(b"wheels"))
            dst.writestr(n, data)
    got = install(bare, frame, tmp_path / "home-bare")
    assert got["enabled"] and not got["package_files"], f"the control installed a package: {got}"
