"""Installing the package the way Python users do, offline: a virtual environment that sees
Debian's packages, `pip install --no-build-isolation --no-index .` from a fresh copy of the
repository, and a wheel with `python3 -m build --no-isolation --wheel`; then `import voxcut`
from a fresh shell outside the tree.

The compiled module is not built a second time: VOXCUT_BUILD_DIR points setup.py at the build
folder these tests run from (docs/python.md, "Installing")."""

import os
import shutil
import subprocess
import sys
import zipfile

import pytest

from conftest import BINARY_DIR, SOURCE_DIR

PYTHON = "/usr/bin/python3"


def fresh_copy(dest):
    """The repository's files as a clone of its current state has them: tracked files and
    untracked ones git does not ignore (no build folders, no venvs)."""
    files = subprocess.run(["git", "-C", str(SOURCE_DIR), "ls-files", "-z", "--cached",
                            "--others", "--exclude-standard"],
                           check=True, capture_output=True).stdout.split(b"\0")
    for f in files:
        if not f:
            continue
        rel = f.decode()
        src = SOURCE_DIR / rel
        if not src.is_file():  # deleted in the work tree
            continue
        target = dest / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, target)
    return dest


def clean_env(**extra):
    env = {"PATH": "/usr/bin:/bin", "HOME": os.environ.get("HOME", "/tmp"), "LANG": "C.UTF-8"}
    env.update(extra)
    return env


CHECK = """
import voxcut, numpy as np
w = voxcut.World()
b = w.add_body("box:0.05,0.04,0.03", resolution=12, element_level=2)
w.add_plane(point=(0, -0.03, 0), normal=(0, 1, 0))
r = w.step(3)
s = b.surface()
assert s.vertices.shape[1] == 3 and len(s.triangles) > 0
print("ok", voxcut.__file__, r.frame)
"""


@pytest.fixture(scope="module")
def copy(tmp_path_factory):
    return fresh_copy(tmp_path_factory.mktemp("clone") / "voxcut")


def test_pip_install_into_a_venv_and_import_outside_the_tree(copy, tmp_path):
    venv = tmp_path / "venv"
    subprocess.run([PYTHON, "-m", "venv", "--system-site-packages", str(venv)], check=True)
    env = clean_env(VOXCUT_BUILD_DIR=str(BINARY_DIR))
    subprocess.run([str(venv / "bin" / "pip"), "install", "--no-build-isolation", "--no-index",
                    "--quiet", "."], cwd=copy, env=env, check=True)
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    out = subprocess.run([str(venv / "bin" / "python"), "-c", CHECK], cwd=outside,
                         env=clean_env(), check=True, capture_output=True, text=True).stdout
    assert out.startswith("ok ")
    installed = out.split()[1]
    assert installed.startswith(str(venv)), installed  # the venv's copy, not the build's
    # The type information ships with it.
    package = os.path.dirname(installed)
    assert os.path.isfile(os.path.join(package, "py.typed"))
    assert os.path.isfile(os.path.join(package, "_voxcut.pyi"))


def test_wheel_builds_offline(copy, tmp_path):
    dist = tmp_path / "dist"
    env = clean_env(VOXCUT_BUILD_DIR=str(BINARY_DIR))
    subprocess.run([PYTHON, "-m", "build", "--no-isolation", "--wheel", "--outdir", str(dist)],
                   cwd=copy, env=env, check=True, capture_output=True)
    wheels = list(dist.glob("voxcut-*.whl"))
    assert len(wheels) == 1
    names = zipfile.ZipFile(wheels[0]).namelist()
    assert any(n.startswith("voxcut/_voxcut") and n.endswith(".so") for n in names), names
    for needed in ("voxcut/__init__.py", "voxcut/py.typed", "voxcut/_voxcut.pyi",
                   "voxcut/sweep.py"):
        assert needed in names, names
