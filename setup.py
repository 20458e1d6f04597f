"""Builds the compiled module of the amctl package with CMake (the same build as `make`) and puts
it beside the pure-Python modules of python/amctl. pyproject.toml holds the metadata.

The CMake build directory is $AMCTL_BUILD_DIR when set (an existing build, e.g. build/release,
is reused: only the _amctl target is brought up to date), else build/pip in this tree. setuptools'
own scratch files go there too, so an install leaves nothing in the source tree.
"""
import os
import pathlib
import shutil
import subprocess
import sys

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.dist import Distribution

ROOT = pathlib.Path(__file__).resolve().parent
BUILD = pathlib.Path(os.environ.get("AMCTL_BUILD_DIR") or ROOT / "build" / "pip").resolve()


class BinaryDistribution(Distribution):
    """A wheel for this interpreter and platform: the package holds a compiled module."""

    def has_ext_modules(self):
        return True


class BuildWithCMake(build_py):
    def run(self):
        super().run()
        if not (BUILD / "CMakeCache.txt").exists():
            generator = ["-G", "Ninja"] if shutil.which("ninja") else []
            subprocess.check_call(["cmake", "-S", str(ROOT), "-B", str(BUILD), *generator,
                                   "-DCMAKE_BUILD_TYPE=Release", "-DAMCTL_BUILD_TESTS=OFF",
                                   "-DAMCTL_BUILD_BENCH=OFF", "-DAMCTL_PYTHON=ON",
                                   f"-DPython3_EXECUTABLE={sys.executable}"])
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
        subprocess.check_call(["cmake", "--build", str(BUILD), "--target", "_amctl", "-j", jobs])
        built = sorted((BUILD / "python" / "amctl").glob("_amctl*.so"))
        if not built:
            raise RuntimeError(f"the CMake build in {BUILD} made no _amctl module")
        target = pathlib.Path(self.build_lib) / "amctl"
        target.mkdir(parents=True, exist_ok=True)
        for so in built:
            shutil.copy2(so, target / so.name)


BUILD.mkdir(parents=True, exist_ok=True)
setup(cmdclass={"build_py": BuildWithCMake}, distclass=BinaryDistribution,
      options={"egg_info": {"egg_base": str(BUILD)}, "build": {"build_base": str(BUILD / "setuptools")}})
