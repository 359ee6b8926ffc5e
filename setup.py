"""`pip install --no-build-isolation .`: the Python module `vlt` (python/vlt_module.cc) built by the
project's own CMake build and packaged by setuptools (docs/python.md "Installing with pip").

The CMake tree is build/python-package under the source tree (configured once, Release, Ninja when
present, tests and benchmarks off, for the interpreter that runs pip), or VLT_CMAKE_BUILD_DIR when set
(an existing tree: CTest's `python_pip_install` reuses the suite's build). Only the target
`vlt_python` is built; its shared object becomes the package's extension module.
"""
import glob
import os
import re
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = os.path.dirname(os.path.abspath(__file__))


def project_version():
    text = open(os.path.join(ROOT, "CMakeLists.txt"), encoding="utf-8").read()
    return re.search(r"project\(vlt VERSION ([0-9.]+)", text).group(1)


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build_dir = os.environ.get("VLT_CMAKE_BUILD_DIR") or os.path.join(ROOT, "build", "python-package")
        if not os.path.exists(os.path.join(build_dir, "CMakeCache.txt")):
            generator = ["-G", "Ninja"] if shutil.which("ninja") else []
            subprocess.run(["cmake", "-S", ROOT, "-B", build_dir, *generator, "-DCMAKE_BUILD_TYPE=Release",
                            "-DVLT_BUILD_TESTS=OFF", "-DVLT_BUILD_BENCH=OFF",
                            f"-DPython3_EXECUTABLE={sys.executable}", f"-DPython_EXECUTABLE={sys.executable}"],
                           check=True)
        subprocess.run(["cmake", "--build", build_dir, "--target", "vlt_python", "--parallel",
                        str(os.cpu_count() or 1)], check=True)
        built = glob.glob(os.path.join(build_dir, "python", "vlt*.so"))
        if len(built) != 1:
            sys.exit(f"vlt: expected one module in {build_dir}/python, found {built}")
        target = self.get_ext_fullpath(ext.name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copyfile(built[0], target)


setup(
    version=project_version(),
    packages=[],  # one extension module, no Python packages (no automatic discovery of the tree)
    py_modules=[],
    ext_modules=[Extension("vlt", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    # setuptools' own files beside CMake's trees, not in the source root or in build/ itself.
    options={"build": {"build_base": os.path.join("build", "python-package-setuptools")},
             "egg_info": {"egg_base": os.path.join("build")}},
)
