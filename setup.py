"""Builds crankfmu's C kernel (src/crankfmu/native) with the package: a plain shared library that
Python loads through ctypes, and the objects native FMUs link (for each FMU compiler installed), so
a first native build compiles only its own files. Everything else is in pyproject.toml."""

import runpy
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

native = runpy.run_path(str(Path(__file__).resolve().parent / "src" / "crankfmu" / "native" / "sources.py"))


class PlainLibrary(build_ext):
    """crank_kernel.so (.dll): loaded by ctypes, not imported, so no Python ABI tag in its name and
    no module init function to export."""

    def get_ext_filename(self, fullname):
        *package, _ = fullname.split(".")
        return str(Path(*package) / native["library_name"](sys.platform))

    def get_export_symbols(self, ext):
        return []

    def run(self):
        super().run()
        # beside the library, where the installed package looks for them (native/sources.PREBUILT);
        # a native build without them compiles them into the per-user cache instead
        folder = Path(self.get_ext_fullpath("crankfmu.native.crank_kernel")).parent / "objects"
        try:
            used = native["prebuild"](folder)
        except (OSError, RuntimeError) as error:
            print(f"crankfmu: the native FMUs' objects were not compiled ({error}); each is compiled "
                  "at its first native build instead", file=sys.stderr)
        else:
            print(f"crankfmu: native FMU objects compiled for {', '.join(used)}")


setup(
    cmdclass={"build_ext": PlainLibrary},
    ext_modules=[Extension(
        "crankfmu.native.crank_kernel",
        sources=[f"src/crankfmu/native/{name}" for name in native["C_FILES"]],
        depends=[f"src/crankfmu/native/{name}" for name in native["SOURCES"]],
        extra_compile_args=[f for f in native["CFLAGS"] if f != "-fPIC"],
        define_macros=[("CK_SOURCE_DIGEST", f'"{native["digest"]()}"')],
        libraries=[] if sys.platform == "win32" else ["m"],
    )],
)
