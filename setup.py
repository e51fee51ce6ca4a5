"""Builds voxcut's compiled module with CMake for pip and `python3 -m build`.

Metadata lives in pyproject.toml. The extension voxcut._voxcut is the CMake target
voxcut_python: with VOXCUT_BUILD_DIR set to a configured build folder (e.g. build/release),
that folder is built and reused; otherwise a fresh one is configured under setuptools' build
folder (Release, no tests or benchmarks) and built with VOXCUT_JOBS parallel jobs (default:
the CPU count). Nothing is downloaded: CMake finds Debian's packages (docs/python.md).
"""

import glob
import os
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = os.path.dirname(os.path.abspath(__file__))


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build_dir = os.environ.get("VOXCUT_BUILD_DIR")
        jobs = os.environ.get("VOXCUT_JOBS", str(os.cpu_count() or 1))
        if build_dir:
            build_dir = os.path.abspath(build_dir)
            if not os.path.isfile(os.path.join(build_dir, "CMakeCache.txt")):
                sys.exit(f"voxcut: VOXCUT_BUILD_DIR={build_dir} is not a configured CMake "
                         "build folder")
        else:
            build_dir = os.path.abspath(os.path.join(self.build_temp, "cmake"))
            subprocess.check_call([
                "cmake", "-S", ROOT, "-B", build_dir,
                "-DCMAKE_BUILD_TYPE=Release",
                "-DVOXCUT_BUILD_PYTHON=ON", "-DVOXCUT_BUILD_TESTS=OFF",
                "-DVOXCUT_BUILD_BENCH=OFF", f"-DPython3_EXECUTABLE={sys.executable}",
            ])
        subprocess.check_call(["cmake", "--build", build_dir, "--target", "voxcut_python",
                               "-j", jobs])
        built = glob.glob(os.path.join(build_dir, "python", "voxcut", "_voxcut*.so"))
        if len(built) != 1:
            sys.exit(f"voxcut: expected one _voxcut*.so under {build_dir}/python/voxcut, "
                     f"found {built}")
        target = self.get_ext_fullpath(ext.name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copyfile(built[0], target)


setup(ext_modules=[CMakeExtension("voxcut._voxcut")], cmdclass={"build_ext": CMakeBuild})
