"""Build of the native core: one abi3 wheel (limited API 3.11) per platform.

Flags: -O3 with IEEE semantics kept (-ffp-contract=off: the compiler must not fuse a*b+c on
its own, because the AVX2 and portable kernels must round identically; they fuse explicitly).
No -march=native: the AVX2 kernel gets its ISA from a pragma and is chosen at run time."""
import sys

from setuptools import Extension, setup

if sys.platform == "win32":
    # render.c uses pthreads and clock_gettime, the kernels GCC/Clang's __atomic builtins.
    sys.exit("unbound_core builds with GCC or Clang on POSIX systems only (Linux, macOS)")

sources = ["camera.c", "scene.c", "ifs.c", "kernel_avx2.c", "kernel_portable.c", "render.c", "params.c", "module.c", "mesh.c", "mesh_avx2.c", "mesh_portable.c"]
compile_args = ["-O3", "-std=c11", "-D_GNU_SOURCE", "-ffp-contract=off", "-fno-math-errno",
                "-fvisibility=hidden", "-Wall", "-Wno-unused-function"]
libraries = ["m", "pthread"]

setup(
    ext_modules=[
        Extension(
            "unbound_core._native",
            sources=["src/" + s for s in sources],
            include_dirs=["src"],
            extra_compile_args=compile_args,
            libraries=libraries,
            define_macros=[("Py_LIMITED_API", "0x030B0000")],
            py_limited_api=True,
        )
    ],
    options={"bdist_wheel": {"py_limited_api": "cp311"}},
)
