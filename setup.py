"""Builds crankfmu's C kernel (src/crankfmu/native) with the package: a plain shared library that
Python loads through ctypes; and the native FMUs' runtimes (one per FMI version and platform whose
compiler is installed: a native build then compiles nothing); and, in a wheel, the packaged
scenarios' reference runs and documentation figures (fmi/prebuilt_results.py). Everything else is
in pyproject.toml."""

import runpy
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.bdist_wheel import bdist_wheel
from setuptools.command.build_ext import build_ext

native = runpy.run_path(str(Path(__file__).resolve().parent / "src" / "crankfmu" / "native" / "sources.py"))
shim = runpy.run_path(str(Path(__file__).resolve().parent / "src" / "crankfmu" / "fmi" / "python" / "shim" / "prebuilt.py"))
results = runpy.run_path(str(Path(__file__).resolve().parent / "src" / "crankfmu" / "fmi" / "prebuilt_results.py"))


class PlainLibrary(build_ext):
    """crank_kernel.so (.dll): loaded by ctypes, not imported, so no Python ABI tag in its name and
    no module init function to export."""

    def get_ext_filename(self, fullname):
        *package, _ = fullname.split(".")
        return str(Path(*package) / native["library_name"](sys.platform))

    def get_export_symbols(self, ext):
        return []

    def run(self):
        # compiled every time: the library records the digest of its sources (CK_SOURCE_DIGEST),
        # which changes with their names and content where setuptools' timestamps may not (a file
        # moved keeps its time), and a stale library in an in-tree build/ would go into the wheel
        self.force = True
        super().run()
        # the native FMUs' runtimes beside the library, for every platform whose compiler is here:
        # then crankfmu fmu --native compiles nothing (native/sources.RUNTIMES)
        folder = Path(self.get_ext_fullpath("crankfmu.native.crank_kernel")).parent
        try:
            runtimes = native["prebuild_runtimes"](folder / "runtimes")
        except (OSError, RuntimeError) as error:
            print(f"crankfmu: the native FMUs' runtimes were not compiled ({error}); a native build compiles "
                  "the ones it needs into the per-user cache instead", file=sys.stderr)
        else:
            print("crankfmu: native FMU runtimes compiled for "
                  + ", ".join(f"FMI {version} {platform}" for version, platform in runtimes))
        # the Python FMUs' linux64 shim, so that crankfmu fmu needs no compiler
        if sys.platform.startswith("linux"):
            into = Path(self.get_ext_fullpath("crankfmu.native.crank_kernel")).parent.parent / "fmi" / "python" / "shim"
            try:
                shim["prebuild"](into)
            except (OSError, ImportError, RuntimeError) as error:
                print(f"crankfmu: the Python FMUs' shim was not compiled ({error}); each Python FMU's build "
                      "compiles it instead", file=sys.stderr)
        # the packaged scenarios' reference runs and figures, made by building their native FMUs
        # with the package just built (a wheel's build only: an editable install runs the tree's
        # sources, whose results the per-user cache keeps as they change)
        if not (self.inplace or getattr(self, "editable_mode", False)):
            package = Path(self.get_ext_fullpath("crankfmu.native.crank_kernel")).parent.parent
            try:
                names = results["prebuild"](package)
            except (OSError, RuntimeError) as error:
                print(f"crankfmu: the packaged scenarios' reference runs and figures were not made ({error}); "
                      "a build of one makes them into the per-user cache instead", file=sys.stderr)
            else:
                print("crankfmu: reference runs and documentation figures made for " + ", ".join(names))


class PlainWheel(bdist_wheel):
    """The wheel's tag says what it holds: a plain library for this platform, loaded by ctypes
    (no Python extension module, no CPython ABI), so any Python 3 on the platform runs it:
    py3-none-<platform>, not cp3XX-cp3XX-<platform>."""

    def get_tag(self):
        _, _, platform = super().get_tag()
        return "py3", "none", platform


setup(
    cmdclass={"build_ext": PlainLibrary, "bdist_wheel": PlainWheel},
    ext_modules=[Extension(
        "crankfmu.native.crank_kernel",
        sources=[f"src/crankfmu/native/{name}" for name in native["C_FILES"]],
        depends=[f"src/crankfmu/native/{name}" for name in native["SOURCES"]],
        include_dirs=[f"src/crankfmu/native/{folder}" for folder in native["FOLDERS"]],
        extra_compile_args=[f for f in native["CFLAGS"] if f != "-fPIC"],
        define_macros=[("CK_SOURCE_DIGEST", f'"{native["digest"]()}"')],
        libraries=[] if sys.platform == "win32" else ["m"],
    )],
)
