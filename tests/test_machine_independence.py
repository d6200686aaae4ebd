"""The same bits on any x86-64 machine with AVX2 and FMA: what feeds the simulators and the
learners (tests/machine_fingerprint.py) must not change with the BLAS kernel OpenBLAS picks for
the CPU, nor with the SIMD level numpy dispatches to. Each setting this machine can execute is
forced in a fresh interpreter (both are read when the libraries load) and must print the same
fingerprint as the default. Before dmprs.portable, the arm's pour differed under Prescott's kernel.
"""

import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: OpenBLAS kernels of x86-64 and the CPU flags each needs (OpenBLAS's DYNAMIC_ARCH core types)
KERNELS = {"Prescott": {"sse3"}, "Core2": {"ssse3"}, "Nehalem": {"sse4_2"}, "Sandybridge": {"avx"},
           "Haswell": {"avx2", "fma"}, "Zen": {"avx2", "fma"}, "SkylakeX": {"avx512f", "avx512dq"},
           "Cooperlake": {"avx512_bf16"}}


def _cpu_flags() -> set[str]:
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return set()
    return next((set(line.split(":", 1)[1].split()) for line in text.splitlines() if line.startswith("flags")),
                set())


def _dispatched() -> str:
    """numpy's dispatch targets that this CPU has: disabling them all leaves its baseline loops."""
    from numpy._core import _multiarray_umath as m

    return " ".join(f for f in m.__cpu_dispatch__ if m.__cpu_features__.get(f))


def settings() -> dict[str, dict[str, str]]:
    flags = _cpu_flags()
    out = {f"OPENBLAS_CORETYPE={k}": {"OPENBLAS_CORETYPE": k} for k, need in KERNELS.items() if need <= flags}
    if _dispatched():
        out["NPY_DISABLE_CPU_FEATURES=" + _dispatched()] = {"NPY_DISABLE_CPU_FEATURES": _dispatched()}
    return out


def _start(extra: dict[str, str]) -> subprocess.Popen:
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
    return subprocess.Popen([sys.executable, "-m", "tests.machine_fingerprint"], cwd=ROOT, env={**env, **extra},
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.skipif(sys.platform != "linux" or platform.machine() != "x86_64",
                    reason="the kernels and flags named are x86-64's on Linux")
def test_the_bits_do_not_depend_on_the_blas_kernel_or_the_simd_level():
    runs = {"default": {}, **settings()}
    assert any(k.startswith("OPENBLAS") for k in runs), "no OpenBLAS kernel to compare with"
    results = {}
    names = list(runs)
    for i in range(0, len(names), 2):  # two at a time: the machine has two cores
        procs = {name: _start(runs[name]) for name in names[i:i + 2]}
        for name, p in procs.items():
            out, err = p.communicate(timeout=300)
            assert p.returncode == 0, f"{name}: {err[-2000:]}"
            results[name] = json.loads(out.strip().splitlines()[-1])
    base = results["default"]
    for name, got in results.items():
        differ = [part for part in base if got[part] != base[part]]
        assert not differ, f"with {name}, {', '.join(differ)} differ from the default run's bits"
