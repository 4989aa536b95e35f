"""Shared fixtures: the CLI binary the Python results are compared with, the shared data, a scratch folder."""
import os
import pathlib
import shutil

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _ci() -> bool:
    return os.environ.get("CI", "") not in ("", "0", "false")


@pytest.fixture(scope="module")
def cli() -> str:
    """The `meniscus` binary built from the same tree (MENISCUS_BIN, else target/debug or target/release)."""
    for p in [os.environ.get("MENISCUS_BIN"), ROOT / "target/debug/meniscus", ROOT / "target/release/meniscus"]:
        if p and pathlib.Path(p).is_file():
            return str(p)
    pytest.fail("no meniscus binary: build it first (tools/dev test does)")


@pytest.fixture(scope="module")
def shared():
    """A folder of ../shared/data; missing data fails under CI=true (it is there in CI), else skips."""
    def get(rel: str) -> pathlib.Path:
        p = ROOT.parent / "shared" / "data" / rel
        if not p.exists():
            if _ci():
                pytest.fail(f"shared data {p} is missing under CI=true")
            pytest.skip(f"shared data {p} not present")
        return p
    return get


@pytest.fixture()
def frame(shared, tmp_path) -> pathlib.Path:
    """The shared 6,859-particle dam break's frame 20, alone in a folder (no scene.json beside it)."""
    src = shared("splishsplash/dambreak_6859/partio/ParticleData_Fluid_20.bgeo")
    dst = tmp_path / "f20.bgeo"
    shutil.copy(src, dst)
    return dst
